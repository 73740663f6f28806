"""Where a Rhino pcurve's range is cut (:mod:`gshade.cad.rhino_pcurves`), for all the
model's trims at once (:class:`Trims`: their faces, edge curves, samples and boxes):

- the face's points nearest the edge at the trims' samples (:func:`sample_feet`): the
  samples near a side of the domain again by Gauss-Newton on the surface continued past it
  (:func:`gshade.cad.rhino_feet.nearest_points`), the others as recovered;
- the sides a trim runs beyond (there the side's nearest point is the face's: the parameter
  across the side pinned to it), and the edge parameters where the nearest point crosses a
  side or an interior knot line of the face, by Newton on t (:func:`range_cuts`), so that
  between the cuts the nearest point moves analytically with t.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..geometry.evaluation.bezier_cells import Splines
from ..geometry.patches.bspline import BSplinePatch
from .rhino_feet import least_squares_step, nearest_points

__all__ = ["Trims", "range_cuts", "sample_feet"]

#: Gauss-Newton steps at most: at the samples (from the recovered trims) and per Newton step
#: on t at a crossing.
_STEPS_SAMPLES, _STEPS_CROSSING = 6, 4
#: Newton steps on t locating a knot line's crossing.
_CROSSING_STEPS = 4
#: Samples this close to a side of the domain (relative to the span) may lie beyond it.
_NEAR_SIDE = 1e-6


@dataclass
class Trims:
    """All the trims to fit: per trim its face, its edge curve (its number in the
    :class:`Splines`), samples (t, one-sided (u, v)) and the box its inversion stays in
    (lowest and highest (u, v): its face's domain widened, as
    :func:`gshade.cad.rhino_pcurves.fit_faces` sets it); per face its surface (number in
    the :class:`Splines`) and its domain's corners."""

    splines: Splines
    face: NDArray[np.intp]
    curve: NDArray[np.intp]
    samples: list[tuple[NDArray[np.float64], NDArray[np.float64]]]
    patch: NDArray[np.intp]
    lo: NDArray[np.float64]
    hi: NDArray[np.float64]
    reach_lo: NDArray[np.float64]
    reach_hi: NDArray[np.float64]

    def box(self, trim: NDArray[np.intp]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return self.reach_lo[trim], self.reach_hi[trim]

    def edge(
        self, trim: NDArray[np.intp], t: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """C(t) and C'(t) of the trims' edges."""
        c, dc, _ = self.splines.evaluate(self.curve[trim], t)
        return c, dc


def sample_feet(
    trims: Trims, small: float
) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The face's points nearest the edge at the samples of all trims: per sample its trim,
    t, (u, v) and the speeds |S_u|, |S_v| there.  The samples within ``_NEAR_SIDE`` of a
    side of the domain (in parameter) again by Newton on the continued surface (the
    recovered ones stop at the side), the others as recovered (speeds infinite: inside)."""
    sizes = [len(t) for t, _ in trims.samples]
    owner = np.repeat(np.arange(len(sizes)), sizes)
    t = np.concatenate([t for t, _ in trims.samples])
    uv = np.concatenate([uv for _, uv in trims.samples])
    face = trims.face[owner]
    lo, hi = trims.lo[face], trims.hi[face]
    margin = _NEAR_SIDE * (hi - lo)
    near = np.flatnonzero(np.any((uv - lo <= margin) | (hi - uv <= margin), axis=1))
    speed = np.full((len(t), 2), np.inf)
    if near.size:
        xyz, _ = trims.edge(owner[near], t[near])
        surface = trims.patch[face[near]]
        box = trims.box(owner[near])
        uv[near], _, su, sv = nearest_points(
            trims.splines, surface, xyz, uv[near], box, _STEPS_SAMPLES, small
        )
        speed[near] = np.stack([np.linalg.norm(su, axis=1), np.linalg.norm(sv, axis=1)], -1)
    return owner, t, uv, speed


def _brackets(
    index: NDArray[np.intp],
    owner: NDArray[np.intp],
    t: NDArray[np.float64],
    value: NDArray[np.float64],
    level: NDArray[np.float64],
    along: int,
) -> tuple[
    NDArray[np.intp],
    NDArray[np.intp],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.intp],
    NDArray[np.intp],
]:
    """Where ``value`` (per sample ``index``, in t order within each trim) crosses zero
    between consecutive samples of a trim with a nonzero sign: (trim, direction ``along``,
    the crossed level, t low, t high, first estimate, the two samples), an array each."""
    nonzero = np.flatnonzero(value != 0.0)
    i, j = nonzero[:-1], nonzero[1:]
    cross = (owner[i] == owner[j]) & (value[i] * value[j] < 0)
    i, j = i[cross], j[cross]
    w = value[i] / (value[i] - value[j])
    n = i.size
    return (
        owner[i],
        np.full(n, along),
        level[i],
        t[i],
        t[j],
        t[i] + w * (t[j] - t[i]),
        index[i],
        index[j],
    )


def range_cuts(
    trims: Trims,
    patches: list[BSplinePatch],
    feet: tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    accuracy: float,
    small: float,
) -> tuple[list[NDArray[np.float64]], list[list[tuple]]]:
    """Per trim, the edge parameters where the face's nearest point (``feet``, at the
    samples: :func:`sample_feet`) crosses a side of the domain (beyond it, the side's
    nearest point is the face's: pinned there) or an interior knot line of the face (there
    it moves less smoothly with t), found by Newton on t (:func:`_locate`); and per trim the
    sides it runs beyond: (direction, side, where) with ``where`` (t, beyond) > 0 at the
    samples beyond the side (``None``: all of the trim)."""
    owner, t, uv, speed = feet
    uv = uv.copy()
    index = np.arange(len(t))
    face = trims.face[owner]
    by_trim = np.searchsorted(owner, np.arange(len(trims.samples) + 1))
    free_lo, free_hi = trims.box(owner)
    lo, hi = free_lo.copy(), free_hi.copy()  # per sample: pinned beyond a side
    found = []
    sides: list[list[tuple]] = [[] for _ in trims.samples]
    for d in (0, 1):
        for corner, sign in ((trims.lo, -1.0), (trims.hi, 1.0)):
            end = corner[face, d]
            beyond = sign * (uv[:, d] - end) * speed[:, d]  # in 3D, > 0: beyond the side
            state = np.where(beyond > accuracy, 1.0, np.where(beyond < -accuracy, -1.0, 0.0))
            out = np.zeros(len(sides), dtype=bool)
            inside = np.zeros(len(sides), dtype=bool)
            np.logical_or.at(out, owner, state > 0)
            np.logical_or.at(inside, owner, state < 0)
            for j in np.flatnonzero(out):
                rows = slice(by_trim[j], by_trim[j + 1])
                where = (t[rows], beyond[rows]) if inside[j] else None
                sides[j].append((d, corner[trims.face[j], d], where))
                pin = index[rows] if where is None else index[rows][beyond[rows] > 0]
                lo[pin, d] = hi[pin, d] = end[pin]
            mixed = np.isin(owner, np.flatnonzero(out & inside))
            if mixed.any():
                m = np.flatnonzero(mixed)
                found.append(_brackets(m, owner[m], t[m], state[m], end[m], d))
    box = [(free_lo, free_hi)] * len(found)  # sides: located on the continued surface
    pinned = np.flatnonzero(np.any(lo == hi, axis=1))
    if pinned.size:  # the pinned samples' nearest points on their sides
        xyz, _ = trims.edge(owner[pinned], t[pinned])
        surface = trims.patch[face[pinned]]
        uv[pinned] = nearest_points(
            trims.splines, surface, xyz, uv[pinned], (lo[pinned], hi[pinned]), _STEPS_SAMPLES, small
        )[0]
    by_face = np.searchsorted(face, np.arange(len(patches) + 1))  # samples in face order
    for f, patch in enumerate(patches):  # interior knot lines, crossed transversally
        mine = index[by_face[f] : by_face[f + 1]]
        for d in (0, 1):
            a, b = patch.domain[d]
            x = uv[mine, d]
            if not x.size:
                continue
            knots = np.unique(np.asarray(patch.knots[d], dtype=float))
            inner = (knots > max(a + 1e-12 * (b - a), x.min())) & (
                knots < min(b - 1e-12 * (b - a), x.max())
            )
            for k in knots[inner]:
                value = x - k
                value[np.abs(value) <= 1e-9 * (b - a)] = 0.0  # along the line: no crossing
                found.append(_brackets(mine, owner[mine], t[mine], value, np.full(mine.size, k), d))
                box.append((lo, hi))  # in the pinned samples' boxes
    cuts = [np.empty(0) for _ in trims.samples]
    keep = [k for k, x in enumerate(found) if x[0].size]
    if not keep:
        return cuts, sides
    # each crossing in its samples' boxes: where a knot line's crossing and a side's share an
    # interval between samples, in both (the one off its region an extra cut, harmless)
    parts: list[tuple[NDArray, ...]] = []
    for k in keep:
        x = found[k]
        parts.append((*x, box[k][0][x[6]], box[k][1][x[6]]))
        moved = np.any(
            (box[k][0][x[6]] != box[k][0][x[7]]) | (box[k][1][x[6]] != box[k][1][x[7]]), axis=1
        )
        if moved.any():
            parts.append((*(y[moved] for y in x), box[k][0][x[7]][moved], box[k][1][x[7]][moved]))
    who, along, level, tl, th, tc, i, _, bl, bh = (
        np.concatenate(x) for x in zip(*parts, strict=True)
    )
    w = ((tc - tl) / np.where(th > tl, th - tl, 1.0))[:, None]
    start = uv[i] + w * (uv[i + 1] - uv[i])
    located = _locate(trims, who, along, level, tl, th, tc, start, (bl, bh), small)
    order = np.argsort(who, kind="stable")
    at = np.searchsorted(who[order], np.arange(len(cuts) + 1))
    for j in np.unique(who):
        cuts[j] = located[order[at[j] : at[j + 1]]]
    return cuts, sides


def _locate(
    trims: Trims,
    owner: NDArray[np.intp],
    along: NDArray[np.intp],
    level: NDArray[np.float64],
    tl: NDArray[np.float64],
    th: NDArray[np.float64],
    tc: NDArray[np.float64],
    uv: NDArray[np.float64],
    box: tuple[NDArray[np.float64], NDArray[np.float64]],
    small: float,
) -> NDArray[np.float64]:
    """Newton on t for the crossings of coordinate ``along`` of the face's nearest point
    (within ``box``) with ``level``, within [tl, th] (from tc, the nearest point from uv):
    t <- t - (c_d(t) - level) / c_d'(t), the nearest point's speed c' = (J^T J)^-1 J^T C'(t)
    (J's columns of the pinned parameters zero)."""
    surface = trims.patch[trims.face[owner]]
    rows = np.arange(len(tc))
    free = (box[1] > box[0]).astype(np.float64)
    for _ in range(_CROSSING_STEPS):
        xyz, dxyz = trims.edge(owner, tc)
        uv, _, su, sv = nearest_points(trims.splines, surface, xyz, uv, box, _STEPS_CROSSING, small)
        speed = least_squares_step(su * free[:, :1], sv * free[:, 1:], dxyz)[rows, along]
        gap = uv[rows, along] - level
        step = np.divide(-gap, speed, out=np.zeros_like(gap), where=np.abs(speed) > 1e-300)
        new = np.clip(tc + step, tl, th)
        moved = np.abs(new - tc)
        tc = new
        if np.all(moved <= 1e-14 * np.maximum(np.abs(th - tl), 1e-300)):
            break
    return tc
