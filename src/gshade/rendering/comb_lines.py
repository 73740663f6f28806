"""Curvature combs drawn over a rendered picture: spines, envelopes and inflection marks.

Each comb (:mod:`gshade.analysis.curvature_combs`) is projected through the view: a spine
from each sample c to c - scale k, the envelope through the spines' tips, a ring at each
inflection.  A spine is drawn where its foot is in sight (:func:`in_sight`, from the exact ``P``
channels) and the envelope between two samples in sight.
The lines are rasterised anti-aliased by Matplotlib's Agg (a constant width in pixels) and
laid over R, G, B and A (premultiplied: a comb off the surface shows on the background);
f and the geometric channels stay exact.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from ..analysis.curvature_combs import Comb
    from .camera import View

__all__ = ["COMB_COLOUR", "INFLECTION_COLOUR", "draw_combs", "draw_rings", "in_sight"]

#: Linear RGB of the spines and envelopes (a deep teal, apart from the junction and
#: parabolic-line colours) and of the inflection rings (white, with a dark outline).
COMB_COLOUR = (0.0, 0.18, 0.28)
INFLECTION_COLOUR = (1.0, 1.0, 1.0)
#: How far (in pixels' size at its depth) a point may lie from the surface seen around it
SLACK = 2.0
#: A spine at every this many samples (the envelope runs through all)
SPINE_EVERY = 2
#: Widths in pixels: spines, envelope, the inflection ring's diameter.
SPINE_WIDTH, ENVELOPE_WIDTH, RING_SIZE = 0.8, 1.6, 9.0


def in_sight(points: NDArray, channels: dict[str, NDArray], view: View) -> NDArray[np.bool_]:
    """Whether each point (n, 3) on the surface is in sight: within the picture, and in the
    3 x 3 pixels around its image either a surface point within :data:`SLACK` pixels' size
    of it, the pixel's footprint on the surface added (the surface there is the one it
    lies on), or none nearer the eye than it by more than that size (it lies on an
    outline)."""
    H, W = channels["patch"].shape
    x, y, z = view.camera_coordinates(points)
    col, row = view.image_positions(x, y, z)
    ahead = z > 0 if view.type != "orthographic" else np.ones(len(points), bool)
    with np.errstate(invalid="ignore"):
        inside = ahead & (col >= 0) & (col < W) & (row >= 0) & (row < H)
    out = np.zeros(len(points), bool)
    at = np.flatnonzero(inside)
    if not at.size:
        return out
    r = row[at].astype(np.int64)[:, None] + np.repeat(np.arange(-1, 2), 3)[None, :]
    c = col[at].astype(np.int64)[:, None] + np.tile(np.arange(-1, 2), 3)[None, :]
    r, c = np.clip(r, 0, H - 1), np.clip(c, 0, W - 1)
    P = np.stack([channels[f"P.{k}"][r, c] for k in "XYZ"], -1).astype(np.float64)
    covered = channels["patch"][r, c] >= 0
    depth = view.camera_coordinates(P.reshape(-1, 3))[2].reshape(r.shape)
    slack = SLACK * np.array([view.pixel_size(float(d)) for d in z[at]])
    reach = slack[:, None] + SLACK * _footprint(channels)[r, c]
    here = np.linalg.norm(P - points[at][:, None, :], axis=-1) <= reach
    nearer = covered & (depth < z[at][:, None] - slack[:, None])
    out[at] = (covered & here).any(axis=1) | ~nearer.any(axis=1)
    return out


def _footprint(channels: dict[str, NDArray]) -> NDArray:
    """Each covered pixel's size on the surface: the larger distance from its exact point
    to its right and lower neighbours' on the same patch (0 where it has none): at a
    grazing angle a pixel spans much more surface than its size at its depth."""
    P = np.stack([channels[f"P.{k}"] for k in "XYZ"], -1).astype(np.float64)
    patch = channels["patch"]
    out = np.zeros(patch.shape)
    for axis in (0, 1):
        step = np.linalg.norm(np.diff(P, axis=axis), axis=-1)
        same = (np.diff(patch, axis=axis) == 0) & (np.delete(patch, -1, axis=axis) >= 0)
        step = np.where(same, step, 0.0)
        lo = [slice(None)] * 2
        hi = [slice(None)] * 2
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        out[tuple(lo)] = np.maximum(out[tuple(lo)], step)
        out[tuple(hi)] = np.maximum(out[tuple(hi)], step)
    return out


def _image_points(points: NDArray, view: View) -> NDArray:
    col, row = view.image_positions(*view.camera_coordinates(points))
    return np.stack([col, row], -1)


def _coverage(
    shape: tuple[int, int], lines: list[tuple[list[NDArray], float]], rings: NDArray
) -> tuple[NDArray, NDArray]:
    """The coverage (H, W) of polylines (each group with its width in pixels) and of the
    rings' outlines, and of the rings' fills, rasterised by Agg."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import LineCollection
    from matplotlib.figure import Figure

    H, W = shape
    dpi = 100.0
    points = 72.0 / dpi  # a pixel in points

    def raster(draw: object) -> NDArray:
        figure = Figure(figsize=(W / dpi, H / dpi), dpi=dpi)
        figure.patch.set_alpha(0.0)
        axes = figure.add_axes((0.0, 0.0, 1.0, 1.0))
        axes.set_xlim(0, W)
        axes.set_ylim(H, 0)
        axes.set_axis_off()
        axes.patch.set_alpha(0.0)
        draw(axes)  # type: ignore[operator]
        canvas = FigureCanvasAgg(figure)
        canvas.draw()
        return np.asarray(canvas.buffer_rgba())[:H, :W, 3] / 255.0

    def strokes(axes: object) -> None:
        for segments, width in lines:
            if segments:
                axes.add_collection(  # type: ignore[attr-defined]
                    LineCollection(segments, linewidths=width * points, colors="k")
                )
        if len(rings):
            axes.scatter(  # type: ignore[attr-defined]
                rings[:, 0],
                rings[:, 1],
                s=(RING_SIZE * points) ** 2,
                facecolors="none",
                edgecolors="k",
                linewidths=2.0 * points,
            )

    def fills(axes: object) -> None:
        if len(rings):
            axes.scatter(  # type: ignore[attr-defined]
                rings[:, 0],
                rings[:, 1],
                s=((RING_SIZE - 2.0) * points) ** 2,
                facecolors="k",
                edgecolors="none",
            )

    return raster(strokes), raster(fills)


def draw_combs(
    channels: dict[str, NDArray[np.float32]],
    found: Sequence[Comb],
    scale: float,
    view: View,
    longest: float = np.inf,
) -> dict[str, NDArray[np.float32]]:
    """Channels with the combs drawn into R, G, B and A (new arrays; the others as given):
    spines -``scale`` x the shown curvature vector long (cut at ``longest``), envelopes,
    inflection rings."""
    spines: list[NDArray] = []
    envelopes: list[NDArray] = []
    at = [np.array(i.point) for comb in found for i in comb.inflections]
    rings_at = np.array(at).reshape(-1, 3)
    everything = np.concatenate([c.points for c in found] + [rings_at])
    seen_all = in_sight(everything, channels, view)
    start = 0
    for comb in found:
        seen = np.isfinite(comb.values) & seen_all[start : start + len(comb.points)]
        start += len(comb.points)
        spine = -scale * np.nan_to_num(comb.vectors)
        length = np.linalg.norm(spine, axis=-1, keepdims=True)
        tips = comb.points + spine * np.minimum(1.0, longest / np.maximum(length, 1e-300))
        foot, tip = _image_points(comb.points, view), _image_points(tips, view)
        drawn = seen & (np.arange(len(seen)) % SPINE_EVERY == 0)
        spines.extend(np.stack([foot[drawn], tip[drawn]], 1))
        both = seen[:-1] & seen[1:]
        envelopes.extend(np.stack([tip[:-1][both], tip[1:][both]], 1))
    rings = _image_points(rings_at, view)[seen_all[start:]]
    lines = [(spines, SPINE_WIDTH), (envelopes, ENVELOPE_WIDTH)]
    return _laid_over(channels, *_coverage(channels["patch"].shape, lines, rings))


def draw_rings(
    channels: dict[str, NDArray[np.float32]], points: NDArray, view: View
) -> dict[str, NDArray[np.float32]]:
    """Channels with a ring (as an inflection's) drawn at each point (n, 3) in sight."""
    rings = _image_points(points, view)[in_sight(points, channels, view)]
    return _laid_over(channels, *_coverage(channels["patch"].shape, [], rings))


def _laid_over(
    channels: dict[str, NDArray[np.float32]], strokes: NDArray, fills: NDArray
) -> dict[str, NDArray[np.float32]]:
    """The strokes (:data:`COMB_COLOUR`) and then the fills (:data:`INFLECTION_COLOUR`)
    laid over R, G, B and A."""
    out = dict(channels)
    rgb = np.stack([channels[c] for c in "RGB"], -1).astype(np.float64)
    alpha = channels["A"].astype(np.float64)
    for coverage, colour in ((strokes, COMB_COLOUR), (fills, INFLECTION_COLOUR)):
        rgb = rgb * (1.0 - coverage[..., None]) + np.asarray(colour) * coverage[..., None]
        alpha = alpha * (1.0 - coverage) + coverage
    for i, name in enumerate("RGB"):
        out[name] = rgb[..., i].astype(np.float32)
    out["A"] = alpha.astype(np.float32)
    return out
