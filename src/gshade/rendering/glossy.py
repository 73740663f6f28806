"""A glossy reflection's picture, sampled until two seeds agree.

A glossy conductor (``environment`` with ``roughness`` > 0) is a Monte Carlo estimate: each
camera sample reflects one direction drawn by Mitsuba's ``roughconductor``
(:class:`gshade.rendering.reflection_sampling.ReflectionSampling`).  :func:`converged_picture`
renders it twice, with the seeds s and s + 1, and renders again, with four times the
samples, every pixel that is not yet converged, up to :data:`MAX_GLOSSY_SPP`.  A pixel is
converged when

* the two seeds' pictures differ there by less than :data:`TOLERANCE` (1 % of the sRGB
  range, in each of R, G, B), and
* the spread of a seed's value there (:func:`spread`: the seeds' differences pooled over
  the pixels around it) is below ``TOLERANCE / (2 sqrt 2)``: then two seeds' pictures
  differ by less than TOLERANCE at two standard deviations (and two pictures each the mean
  of two seeds, at nearly three).  Two values that happen to
  agree are not enough: at a pixel whose samples spread widely, two seeds agree within 1 %
  one time in five or so (measured before this rule: two pictures, each of two seeds that
  agreed within 1 % everywhere, differed by 3.3 %).

The picture is the two renders' mean, and :class:`Convergence` says how far they agree (the
legend states it).  Differences are measured in sRGB, the picture as the PNG shows it: 1 %
of white in linear RGB is a visible grain in the dark (0.02 and 0.03 linear are 0.155 and
0.191 in sRGB).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ..io.image import linear_to_srgb
from ..limits import MAX_SAMPLES
from ..scene.model import RenderSettings
from .camera import View
from .channels import PICTURE
from .mitsuba_scene import MitsubaScene, render_pixels_of, render_uniform

__all__ = [
    "MAX_GLOSSY_SPP",
    "MIN_GLOSSY_SPP",
    "TOLERANCE",
    "Convergence",
    "converged_picture",
    "spread",
]

#: The largest difference between the two seeds' pictures allowed, in sRGB (white 1).
TOLERANCE = 0.01
#: The most samples per pixel the pixels not yet converged are given.
MAX_GLOSSY_SPP = 65536
#: The fewest samples per pixel of each seed's first render: with fewer, both seeds may miss
#: a bright strip in a pixel's lobe alike (measured: at 16, a teapot at roughness 0.05 had
#: dots 5 % darker or brighter than their neighbours; at 256 none to see)
MIN_GLOSSY_SPP = 256
#: The side, in pixels, of the square over which the seeds' differences are pooled.
POOL = 5
#: A pixel is converged when the seeds' difference there, sqrt(2) times a seed's spread,
#: is below TOLERANCE at this many standard deviations.
SIGMAS = 2.0


@dataclass(frozen=True)
class Convergence:
    """How far the two seeds' pictures agree: the samples per pixel of each (fewest and
    most, each seed), the largest difference left, and the share of the covered pixels whose
    difference is below :data:`TOLERANCE`."""

    spp: tuple[int, int]
    max_difference: float
    within: float

    def describe(self) -> str:
        """The legend's phrase."""
        lo, hi = self.spp
        samples = f"{lo} spp" if lo == hi else f"{lo}-{hi} spp"
        if self.within >= 1.0:
            agree = f"differ by < {TOLERANCE:.0%} (sRGB) at every pixel"
        else:
            agree = f"differ by < {TOLERANCE:.0%} (sRGB) at {self.within:.2%} of the pixels"
        return f"2 seeds x {samples}, {agree} (max {self.max_difference:.2%})"


def _differences(a: NDArray, b: NDArray) -> NDArray:
    """The largest difference in sRGB R, G, B of each pixel (n, channels) of two films."""
    return np.abs(linear_to_srgb(a[..., :3]) - linear_to_srgb(b[..., :3])).max(axis=-1)


def spread(a: NDArray, b: NDArray, samples: NDArray, covered: NDArray) -> NDArray[np.float64]:
    """Each pixel's standard deviation in sRGB of one seed's value (n,), from the seeds'
    films (n, channels) of ``samples`` (n,) each, over the image ``covered`` (H, W): the
    differences d (:func:`_differences`) as per-sample variances ``d^2 N / 2``, pooled over
    the covered pixels of the :data:`POOL` x :data:`POOL` square around each (one d is a
    weak estimate: two values agree by chance), then ``sqrt(v / N)`` at the pixel.

    Examples
    --------
    >>> a = np.zeros((9, 5)); b = a.copy(); b[:, :3] = 0.2  # d = 0.484 in sRGB everywhere
    >>> spread(a, b, np.full(9, 4), np.ones((3, 3), bool)).round(3)[:2]
    array([0.343, 0.343])
    """
    return _spread(_differences(a, b), samples, covered)


def _spread(d: NDArray, samples: NDArray, covered: NDArray) -> NDArray[np.float64]:
    """:func:`spread` of the seeds' differences d (n,)."""
    from scipy.ndimage import uniform_filter

    weight = covered.astype(np.float64)
    v = (d * d * samples / 2).reshape(covered.shape) * weight
    pooled = uniform_filter(v, POOL, mode="constant") / np.maximum(
        uniform_filter(weight, POOL, mode="constant"), 1e-12
    )
    return np.sqrt(np.maximum(pooled.ravel(), 0.0) / samples)


def _unsettled(d: NDArray, samples: NDArray, covered: NDArray) -> NDArray:
    """The covered pixels not yet converged (see the module's docstring), from the seeds'
    differences d."""
    far = SIGMAS * np.sqrt(2) * _spread(d, samples, covered) >= TOLERANCE
    return covered.ravel() & ((d >= TOLERANCE) | far)


def converged_picture(
    scene: MitsubaScene, view: View, settings: RenderSettings
) -> tuple[NDArray[np.float32], Convergence]:
    """The glossy picture (H, W, 5: R, G, B, A, f): the mean of two renders with the seeds
    ``settings.seed`` and ``seed + 1``, ``settings.spp`` samples per pixel (at least
    :data:`MIN_GLOSSY_SPP`, as the sample budget :data:`gshade.limits.MAX_SAMPLES` allows),
    and four times more where a pixel is not yet converged, up to :data:`MAX_GLOSSY_SPP`
    and the budget."""
    seeds = (settings.seed, settings.seed + 1)
    pixels = view.image_width * view.image_height
    base = settings.spp
    while base < MIN_GLOSSY_SPP and 2 * pixels * base * 4 <= MAX_SAMPLES:
        base *= 4
    settings = replace(settings, spp=base)
    kept = len(PICTURE)
    films = [render_uniform(scene, replace(settings, seed=s))[..., :kept].copy() for s in seeds]
    flat = [f.reshape(-1, kept) for f in films]
    spp = np.full(flat[0].shape[0], base, np.int64)
    count = base
    covered = flat[0][:, 3] + flat[1][:, 3] > 0
    while True:
        differences = _differences(flat[0], flat[1])
        todo = np.flatnonzero(_unsettled(differences, spp, covered.reshape(films[0].shape[:2])))
        count *= 4
        if not todo.size or count > MAX_GLOSSY_SPP or todo.size * count > MAX_SAMPLES:
            break
        more = replace(settings, spp=count)
        for film, s in zip(flat, seeds, strict=True):
            film[todo] = render_pixels_of(scene, view, replace(more, seed=s), todo)[:, :kept]
        spp[todo] = count
    difference = differences[covered]  # the films' last: the loop ends before rendering
    convergence = Convergence(
        (int(spp[covered].min(initial=base)), int(spp[covered].max(initial=base))),
        float(difference.max(initial=0.0)),
        float(np.mean(difference < TOLERANCE)) if difference.size else 1.0,
    )
    return (films[0] + films[1]) / 2, convergence
