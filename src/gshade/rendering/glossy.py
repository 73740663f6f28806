"""A glossy reflection's picture, sampled until two seeds agree.

A glossy conductor (``environment`` with ``roughness`` > 0) is a Monte Carlo estimate: each
camera sample reflects one direction drawn by Mitsuba's ``roughconductor``
(:meth:`gshade.rendering.integrator.ShapeIntegrator._glossy`).  :func:`converged_picture`
renders it twice, with the seeds s and s + 1, and where the two pictures differ by more than
:data:`TOLERANCE` (1 % of white, in any of R, G, B) renders those pixels again with four
times the samples, up to :data:`MAX_GLOSSY_SPP`; the picture is the two renders' mean, and
:class:`Convergence` says how far they agree (the legend states it).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ..limits import MAX_SAMPLES
from ..scene.model import RenderSettings
from .camera import View
from .mitsuba_scene import MitsubaScene, render_pixels_of, render_uniform

__all__ = ["MAX_GLOSSY_SPP", "TOLERANCE", "Convergence", "converged_picture"]

#: The largest difference between the two seeds' pictures allowed, in linear RGB (white 1).
TOLERANCE = 0.01
#: The most samples per pixel the pixels that still differ are given.
MAX_GLOSSY_SPP = 65536
#: The picture's channels (R, G, B, A and f) in the film.
PICTURE_CHANNELS = 5


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
            agree = f"differ by < {TOLERANCE:.0%} of white at every pixel"
        else:
            agree = f"differ by < {TOLERANCE:.0%} of white at {self.within:.2%} of the pixels"
        return f"2 seeds x {samples}, {agree} (max {self.max_difference:.2%})"


def _differences(a: NDArray, b: NDArray) -> NDArray:
    """The largest difference in R, G, B of each pixel (n, channels) of two films."""
    return np.abs(a[..., :3] - b[..., :3]).max(axis=-1)


def converged_picture(
    scene: MitsubaScene, view: View, settings: RenderSettings
) -> tuple[NDArray[np.float32], Convergence]:
    """The glossy picture (H, W, :data:`PICTURE_CHANNELS`): the mean of two renders with
    the seeds ``settings.seed`` and ``seed + 1``, ``settings.spp`` samples per pixel, and
    four times more where they still differ by more than :data:`TOLERANCE`, up to
    :data:`MAX_GLOSSY_SPP` and the sample budget :data:`gshade.limits.MAX_SAMPLES`."""
    seeds = (settings.seed, settings.seed + 1)
    films = [
        render_uniform(scene, replace(settings, seed=s))[..., :PICTURE_CHANNELS].copy()
        for s in seeds
    ]
    flat = [f.reshape(-1, PICTURE_CHANNELS) for f in films]
    spp = np.full(flat[0].shape[0], settings.spp, np.int64)
    count = settings.spp
    covered = flat[0][:, 3] + flat[1][:, 3] > 0
    while True:
        differ = np.flatnonzero(covered & (_differences(*flat) >= TOLERANCE))
        count *= 4
        if not differ.size or count > MAX_GLOSSY_SPP or differ.size * count > MAX_SAMPLES:
            break
        more = replace(settings, spp=count)
        for film, s in zip(flat, seeds, strict=True):
            film[differ] = render_pixels_of(scene, view, replace(more, seed=s), differ)[
                :, :PICTURE_CHANNELS
            ]
        spp[differ] = count
    difference = _differences(*flat)[covered]
    convergence = Convergence(
        (int(spp[covered].min(initial=settings.spp)), int(spp[covered].max(initial=settings.spp))),
        float(difference.max(initial=0.0)),
        float(np.mean(difference < TOLERANCE)) if difference.size else 1.0,
    )
    return (films[0] + films[1]) / 2, convergence
