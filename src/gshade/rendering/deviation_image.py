"""The deviation picture (``gshade deviation``): scene A rendered from its view, every
covered pixel's exact point P on A given its signed distance to scene B's exact surfaces
(:mod:`gshade.analysis.deviation`), shown in tolerance bands.

Channels: A's render's, with ``f`` (and ``f.mean``) the signed deviation at the pixel
centre's P (0 off the surface), ``B.X B.Y B.Z`` the closest point on B and ``B.patch`` its
patch (a CAD model's face number; -1 off the surface).  Colours: within ±T a neutral grey;
beyond, the diverging colour map of d on [-R, R] (R the largest |d|, at least 2T): the
side A's normal points to red, the other blue.  The band edges are box-filtered over each
pixel's footprint like every band (:func:`gshade.display.bands.band_shares`; d's change
across the pixel from its neighbours), and the colours are shaded by the exact normal
toward the eye.  The header's ``deviation`` holds the numbers
(:func:`gshade.analysis.deviation.deviation_summary`) with B's file and the tolerance.
"""

from __future__ import annotations

import json
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..analysis.trimmed_faces import trim_test
from ..display import Legend, colour_map
from ..display.bands import band_shares, band_text, settled_on_levels
from ..display.colour import srgb_to_linear
from ..shape.registry import Bands
from .camera import View, header_view
from .deviation_measure import covered_summary, pixel_hits
from .rendered_image import RenderedImage

if TYPE_CHECKING:
    from ..scene.model import Scene
    from .deviation_references import Reference

__all__ = [
    "BEYOND_B",
    "DEVIATION_CHANNELS",
    "NEUTRAL",
    "deviation_bands",
    "deviation_image",
]

#: The channels a deviation picture adds to A's render's.
DEVIATION_CHANNELS = ("B.X", "B.Y", "B.Z", "B.patch")
#: The colour of A's points beyond B's free boundary (sRGB).
BEYOND_B = (0.3, 0.3, 0.33)
#: The colour within tolerance (sRGB).
NEUTRAL = (0.78, 0.78, 0.76)


def deviation_bands(tolerance: float) -> Bands:
    """The tolerance bands: below -T, within ±T (a value of exactly ±T is within), above T.

    Examples
    --------
    >>> deviation_bands(0.1).names
    ('beyond, inside', 'within tolerance', 'beyond, outside')
    """
    t = float(tolerance)
    edges = (-t, t) if t > 0 else (0.0,)
    names = (
        ("beyond, inside", "within tolerance", "beyond, outside")
        if t > 0
        else (
            "inside",
            "outside",
        )
    )
    colours = ((0.23, 0.3, 0.75), NEUTRAL, (0.7, 0.02, 0.15))
    return Bands(
        edges,
        names,
        colours if t > 0 else (colours[0], colours[2]),
        closed_above=(1,) if t > 0 else (),
    )


def _footprint(f: NDArray, on: NDArray) -> tuple[NDArray, NDArray]:
    """f's change across one pixel in x and y: central differences where both neighbours
    are on the surface, one-sided where one is, 0 where none."""

    def along(axis: int) -> NDArray:
        ahead, behind = np.roll(f, -1, axis), np.roll(f, 1, axis)
        on_ahead, on_behind = np.roll(on, -1, axis), np.roll(on, 1, axis)
        edge = [slice(None)] * 2
        edge[axis] = slice(-1, None)
        on_ahead[tuple(edge)] = False
        edge[axis] = slice(0, 1)
        on_behind[tuple(edge)] = False
        both = 0.5 * (ahead - behind)
        return np.where(
            on_ahead & on_behind,
            both,
            np.where(on_ahead, ahead - f, np.where(on_behind, f - behind, 0.0)),
        )

    return along(1), along(0)


def _shading(channels: dict[str, NDArray], view: View) -> NDArray:
    """Lambert's |<N, toward the eye>| with an ambient part, per pixel, from the exact N."""
    P = np.stack([channels[f"P.{c}"] for c in "XYZ"], -1).astype(np.float64)
    N = np.stack([channels[f"N.{c}"] for c in "XYZ"], -1).astype(np.float64)
    if view.type == "orthographic":
        toward = np.broadcast_to(view.origin - view.target, P.shape)
    else:
        toward = view.origin - P
    with np.errstate(invalid="ignore", divide="ignore"):
        toward = toward / np.linalg.norm(toward, axis=-1, keepdims=True)
    facing = np.abs(np.nan_to_num(np.sum(N * toward, -1)))
    return 0.35 + 0.65 * facing


def deviation_image(
    a: Scene, b: Reference, tolerance: float, **overrides: Any
) -> tuple[RenderedImage, dict[str, Any]]:
    """Scene ``a`` rendered (with ``overrides``, as :func:`gshade.rendering.render`) and
    coloured by its signed deviation from ``b`` (a scene's surfaces, a mesh or a cloud:
    :mod:`gshade.rendering.deviation_references`) within ``tolerance`` (see the module),
    and the numbers.

    Examples
    --------
    The unit sphere measured against one of radius 1.01, on a 16 x 12 picture: every
    covered pixel's point lies 0.01 from B, beyond the tolerance 0.001, on the side away
    from A's normal (the sphere's p_u x p_v points inward): d = -0.01.

    >>> from gshade.rendering.deviation_references import SurfaceReference
    >>> from gshade.scene import parse_scene
    >>> a = parse_scene('''[[surface]]
    ... type = "sphere"
    ... [render]
    ... width = 16
    ... height = 12
    ... spp = 1''')
    >>> b = SurfaceReference(parse_scene('''[[surface]]
    ... type = "sphere"
    ... radius = 1.01'''))
    >>> image, numbers = deviation_image(a, b, 0.001)
    >>> image.channels["f"].shape, round(numbers["min"], 12), round(numbers["max"], 12)
    ((12, 16), -0.01, -0.01)
    >>> numbers["within"], numbers["beyond"]
    (0.0, 0)
    """
    from .pipeline import render

    image = render(a, **overrides)
    channels = dict(image.channels)
    on = channels["patch"] >= 0
    H, W = on.shape
    view = header_view(image.metadata, W, H)  # the view the picture was rendered with
    P, N, index, uv = pixel_hits(a, channels, view)
    # a pixel whose exact point lies off A's trimmed face (the render's mesh overhangs
    # the trims by its chord) is no point of A
    trims = trim_test(a)
    if trims is not None:
        kept = trims(index, uv)
        on[on] = kept
        P, N = P[kept], N[kept]
    found, beyond = b.measure(P, N, tolerance)
    f = np.zeros(on.shape)
    f[on] = found.distance
    foot = np.zeros((*on.shape, 3))
    foot[on] = found.closest.point
    patch = np.full(on.shape, -1.0)
    patch[on] = b.numbers(found.closest.patch)
    summary, covered = covered_summary(found, beyond, tolerance, P, b.name)
    if summary["count"]:
        k = int(np.flatnonzero(on.ravel())[np.flatnonzero(covered)[summary["index"]]])
        row, col = divmod(k, on.shape[1])
        summary["pixel"] = [col, row]
        summary["patch_a"] = int(channels["patch"][row, col])
        summary["patch_b"] = int(patch[row, col])
    outside_b = np.zeros(on.shape, dtype=bool)
    outside_b[on] = beyond
    on &= ~outside_b
    rgb = _colours(f, on, tolerance, summary.get("max_abs") or 0.0)
    unmeasured = (channels["patch"] >= 0) & ~on & ~outside_b  # off A's trims: neutral
    rgb[unmeasured] = srgb_to_linear(np.asarray(NEUTRAL))
    rgb[outside_b] = srgb_to_linear(np.asarray(BEYOND_B))
    rgb *= _shading(channels, view)[..., None]
    alpha = channels["A"].astype(np.float64)
    for i, c in enumerate("RGB"):
        channels[c] = (rgb[..., i] * alpha).astype(np.float32)
    channels["f"] = channels["f.mean"] = f.astype(np.float32)
    for i, c in enumerate("XYZ"):
        channels[f"B.{c}"] = foot[..., i].astype(np.float32)
    channels["B.patch"] = patch.astype(np.float32)
    metadata = dict(image.metadata)
    metadata["deviation"] = json.dumps(summary, allow_nan=False)
    length = image.metadata.get("length_unit", "length")
    spread = max(summary.get("max_abs") or 0.0, 2.0 * tolerance) or 1.0
    legend = Legend(
        "deviation",
        0,
        "bands",
        value_range=(-spread, spread),
        colormap="coolwarm",
        units=length,
        bands=band_text(deviation_bands(tolerance), length),
        notes=(f"dark grey: beyond {b.name}'s free boundary",) if summary["beyond"] else (),
    )
    metadata["legend"] = legend.text()
    return replace(image, channels=channels, metadata=metadata, legend=legend), summary


def _colours(f: NDArray, on: NDArray, tolerance: float, largest: float) -> NDArray:
    """Linear RGB (H, W, 3): the bands of f, box-filtered over the pixels' footprints,
    the beyond-tolerance ones in the diverging map on [-R, R]."""
    bands = deviation_bands(tolerance)
    fx, fy = _footprint(f, on)
    settled, fx, fy = settled_on_levels(f, fx, fy, bands)
    shares, _ = band_shares(settled, fx, fy, bands)
    spread = max(largest, 2.0 * tolerance) or 1.0
    mapped = colour_map(f, on, value_range=(-spread, spread), cmap="coolwarm").rgb
    neutral = srgb_to_linear(np.asarray(NEUTRAL))
    if len(shares) == 3:
        rgb = (shares[0] + shares[2])[..., None] * mapped + shares[1][..., None] * neutral
    else:
        rgb = mapped
    return np.where(on[..., None], rgb, 0.0)
