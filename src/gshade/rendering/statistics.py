"""The shape function's numbers for a render: over the visible surface (the exact channels)
and over the whole surface (the textures), each extreme with where it is
(:mod:`gshade.analysis.statistics`).

The whole surface is summarised from the texture grid the render computes anyway (every
patch's tile, a CAD face's texels inside its trimmed region, each weighing the area it
stands for), so it costs no evaluation but the polishing of its two extremes: a pattern
search on the exact function within one texel of the best grid point.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..analysis.statistics import Extreme, ValueStatistics, summarised, value_statistics
from ..geometry import Patch, regularised_derivatives
from ..geometry.core.patch import unit_to_domain
from ..shape import ShapeFunction, evaluate
from .textures import ShapeTextures, texel_areas

__all__ = [
    "POLISH_STEPS",
    "min_radius_summary",
    "surface_statistics",
    "visible_statistics",
    "widened",
]

#: Pattern-search rounds polishing a whole-surface extreme (5 x 5 points, the step / 2.5 each)
POLISH_STEPS = 10


def visible_statistics(channels: dict[str, NDArray]) -> ValueStatistics | None:
    """The summary of ``f`` over the covered pixels: each pixel's exact value at its centre
    hit, its patch (or face) number, (u, v) and P from the exact channels."""
    on = channels["patch"] >= 0
    points = np.stack([channels[f"P.{c}"][on] for c in "XYZ"], -1)
    return value_statistics(
        channels["f"][on],
        np.rint(channels["patch"][on]).astype(np.int64),
        channels["u"][on],
        channels["v"][on],
        points,
    )


def _exact(patch: Patch, fn: ShapeFunction, params: dict, u: NDArray, v: NDArray) -> NDArray:
    d = regularised_derivatives(patch, u, v, fn.order).d
    res = evaluate(fn, d, gradient=False, backend="numpy", **params)  # 25 points: no kernel
    return np.where(res.valid, res.f, np.nan)


def _polish(
    patch: Patch, fn: ShapeFunction, params: dict, u: float, v: float, step: tuple, sign: float
) -> tuple[float, float, float]:
    """(value, u, v) of the largest ``sign`` * f found by a pattern search from (u, v), within
    ``step`` (du, dv) of it and inside the patch's domain."""
    (u0, u1), (v0, v1) = patch.domain
    steps = np.linspace(-1.0, 1.0, 5)
    across, along = np.meshgrid(steps, steps, indexing="ij")
    best_u, best_v = u, v
    best = float(_exact(patch, fn, params, np.array([u]), np.array([v]))[0])
    du, dv = step
    for _ in range(POLISH_STEPS):
        U = np.clip(best_u + du * across, u0, u1).ravel()
        V = np.clip(best_v + dv * along, v0, v1).ravel()
        f = _exact(patch, fn, params, U, V)
        if np.isfinite(f).any():
            k = int(np.nanargmax(sign * f))
            if not np.isfinite(best) or sign * f[k] > sign * best:
                best, best_u, best_v = float(f[k]), float(U[k]), float(V[k])
        du, dv = du / 2.5, dv / 2.5
    return best, best_u, best_v


def surface_statistics(
    tex: ShapeTextures,
    region: NDArray | None,
    patches: Sequence[Patch],
    fn: ShapeFunction,
    params: dict[str, Any],
    numbers: NDArray | None = None,
) -> ValueStatistics | None:
    """The summary of the first function of ``tex`` over the whole surface: the texels where
    it is valid (and, with ``region``, inside the trimmed faces), weighted by area; the
    extremes those of the texels where the parametrisation is regular
    (:func:`~gshade.analysis.statistics.summarised`), polished on the exact surface
    (:func:`_polish`).  ``numbers``: each patch's
    number to report (a CAD model's face numbers; default the index)."""
    atlas = tex.atlas
    valid = tex.valid[0] > 0
    if region is not None:
        valid &= region
    f = tex.values[0][..., 0]
    index = np.full(valid.shape, -1, dtype=np.int64)
    tiles = atlas.all_tile_slices()
    for k, (rows, cols) in enumerate(tiles):
        index[rows, cols] = k
    valid &= index >= 0
    if not valid.any():
        return None
    at = np.flatnonzero(valid)
    values = f.ravel()[at].astype(np.float64)
    domains = np.array([p.domain for p in patches], dtype=np.float64)

    texel_of: dict[int, tuple[int, int]] = {}  # an extreme (by id) -> its texel

    def place(i: int) -> Extreme:
        """The texel of sample i: its patch, (u, v) from its place in its tile."""
        row, col = (int(x) for x in np.unravel_index(at[i], valid.shape))
        k = int(index[row, col])
        (rows, cols), (hs, ht) = tiles[k], atlas.spacing(k)
        s, t = (col - cols.start) * hs, (row - rows.start) * ht
        u, v = unit_to_domain(domains, np.array([s]), np.array([t]), np.array([k]))
        x, y, z = (float(c) for c in tex.position[row, col])
        found = Extreme(float(values[i]), k, float(u[0]), float(v[0]), (x, y, z))
        texel_of[id(found)] = row, col
        return found

    regular = np.ones(valid.shape, dtype=bool) if tex.regular is None else tex.regular
    stats = summarised(values, place, texel_areas(tex, valid), regular.ravel()[at])
    assert stats is not None

    def polished(e: Extreme, sign: float) -> Extreme:
        patch = patches[e.patch]
        hs, ht = atlas.spacing(e.patch)
        (u0, u1), (v0, v1) = patch.domain
        value, pu, pv = _polish(
            patch, fn, params, e.u, e.v, (float(hs) * (u1 - u0), float(ht) * (v1 - v0)), sign
        )
        # within a texel of a smooth extreme, f moves by at most about its change to the
        # next regular texels: a polished value beyond that ran into a singular point (a
        # collapsed edge's corner), and the grid's own value stands
        row, col = texel_of[id(e)]
        window = (slice(max(row - 1, 0), row + 2), slice(max(col - 1, 0), col + 2))
        near = valid[window] & (index[window] == e.patch) & regular[window]
        reach = 2.0 * float(np.abs(f[window][near] - f[row, col]).max(initial=0.0))
        if not np.isfinite(value) or abs(value - e.value) > reach + 1e-6 * abs(e.value):
            value, pu, pv = e.value, e.u, e.v
        point = np.ravel(patch(np.array([pu]), np.array([pv])))
        label = e.patch if numbers is None else int(numbers[e.patch])
        return Extreme(value, label, pu, pv, (float(point[0]), float(point[1]), float(point[2])))

    return ValueStatistics(
        stats.count,
        polished(stats.minimum, -1.0),
        polished(stats.maximum, 1.0),
        stats.mean,
        stats.percentiles,
        stats.singular,
    )


def widened(surface: ValueStatistics, visible: ValueStatistics) -> ValueStatistics:
    """The whole surface's summary with an extreme of the visible surface's where that one
    is beyond it (a pixel's exact value between the grid's points)."""
    low = min(surface.minimum, visible.minimum, key=lambda e: e.value)
    high = max(surface.maximum, visible.maximum, key=lambda e: e.value)
    return replace(surface, minimum=low, maximum=high)


def min_radius_summary(stats: ValueStatistics) -> dict[str, Any]:
    """The smallest radius of curvature of a ``min_radius`` summary (f = the signed curvature
    of largest magnitude): 1 / max |f|, where it is, and its side (f < 0: curving away from
    the normal, convex for an outward normal); on a flat surface, no value (None) and the
    side ``"flat"``."""
    e = stats.maximum if abs(stats.maximum.value) >= abs(stats.minimum.value) else stats.minimum
    if e.value == 0:  # flat everywhere: no radius (JSON has no infinity)
        radius, side = None, "flat"
    else:
        radius, side = 1.0 / abs(e.value), "convex" if e.value < 0 else "concave"
    return {"value": radius, "side": side, **{k: x for k, x in e.as_dict().items() if k != "value"}}
