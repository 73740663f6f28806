"""Seams and poles of a Rhino face: choosing among parameters that name the same point.

A trim pulled back into (u, v) by point inversion (:mod:`gshade.cad.rhino`) is ambiguous
where the surface meets itself: on the seam of a closed direction, u = u0 and u = u1 are the
same points, and at a pole (a sphere's, a cone's apex) every u is.  Newton lands on either
end, or anywhere along a pole; the kernel's face then needs each trim on the end that its
loop's sense asks for, or the loop encloses no area and the mesher gives no triangles:

- a direction is closed for the trims where openNURBS says so, or where its two ends lie
  within ``_NEAR_CLOSED`` of the surface's width of each other (a surface closed within the
  file's tolerance, not exactly, with an edge on each end);
- a point is on the seam within ``_SEAM`` of the span of an end, or within twice the
  parameter distance that the ends' gap spans (an edge along a nearly closed seam pulls
  back a little inside either end);
- a pole's points take no part in choosing a seam's side: their parameter along the pole is
  free, and they take their neighbour's afterwards.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..geometry.patches.bspline import BSplinePatch

__all__ = ["closed_directions", "fix_ambiguous", "outward", "seam_widths"]

#: Points this close (relative to the span) to a closed direction's end are on its seam.
_SEAM = 1e-4
#: A direction whose two ends meet within this fraction of the surface's width across it
#: is closed for the trims.
_NEAR_CLOSED = 1e-2
#: Samples along each direction for the ends' gaps.
_SAMPLES = 17


def closed_directions(nurbs: Any, patch: BSplinePatch) -> tuple[bool, bool]:
    """The directions in which the face's trims may run along either end of the domain:
    openNURBS's closed ones, and those whose two ends lie within ``_NEAR_CLOSED`` of the
    surface's width across the direction of each other (a seam edge used twice, or two
    edges on the two ends of a surface closed within the file's tolerance, not exactly:
    an edge there pulls back to either end)."""
    (u0, u1), (v0, v1) = patch.domain
    s = np.linspace(0.0, 1.0, _SAMPLES)
    u, v = np.meshgrid(u0 + (u1 - u0) * s, v0 + (v1 - v0) * s, indexing="ij")
    grid = patch(u.ravel(), v.ravel()).reshape(_SAMPLES, _SAMPLES, 3)
    closed = []
    for d in (0, 1):
        rows = np.moveaxis(grid, d, 0)  # rows[k]: the curve at the k-th parameter along d
        gap = float(np.linalg.norm(rows[-1] - rows[0], axis=-1).max())
        width = float(np.linalg.norm(rows - rows[:1], axis=-1).max())
        closed.append(bool(nurbs.IsClosed(d)) or gap <= _NEAR_CLOSED * width)
    return closed[0], closed[1]


def seam_widths(patch: BSplinePatch, closed: tuple[bool, bool]) -> NDArray[np.float64]:
    """Per direction, how near (in parameter) an end a point is on the seam: ``_SEAM`` of
    the span, or for a closed direction twice the parameter distance that the ends' gap
    spans (an edge along a surface closed within the file's tolerance, not exactly, pulls
    back a little inside either end), at most a quarter of the span."""
    (u0, u1), (v0, v1) = patch.domain
    lo, hi = np.array([u0, v0]), np.array([u1, v1])
    span = hi - lo
    out = _SEAM * span
    scale = float(np.ptp(patch.points.reshape(-1, 3), axis=0).max()) or 1.0
    for d in (0, 1):
        if not closed[d]:
            continue
        other = np.linspace(lo[1 - d], hi[1 - d], _SAMPLES)
        ends = []
        for at in (lo[d], hi[d]):
            u, v = (np.full(_SAMPLES, at), other) if d == 0 else (other, np.full(_SAMPLES, at))
            ends.append(patch.derivatives(u, v, 1))
        gap = np.linalg.norm(ends[1][0, 0] - ends[0][0, 0], axis=-1)
        along = (1, 0) if d == 0 else (0, 1)
        speed = np.minimum(*(np.linalg.norm(e[along], axis=-1) for e in ends))
        moving = speed > 1e-12 * scale
        if moving.any():
            out[d] = max(out[d], 2.0 * float((gap[moving] / speed[moving]).max()))
        out[d] = min(out[d], 0.25 * span[d])
    return out


def fix_ambiguous(
    grid: Any,
    uv: NDArray[np.float64],
    free: NDArray[np.intp],
    outer: bool = True,
    pieces: list[int] | None = None,
) -> None:
    """Choose, in place, among parameters that name the same point.

    ``grid`` gives the domain (``lo``, ``hi``), the closed directions (``closed``) and the
    seams' widths (``seam``, :func:`seam_widths`).  Across the seam of a closed direction,
    per trim (``pieces``: the trims' sample counts, in order; default one piece): a trim that
    runs along the seam (all its points within ``grid.seam`` of it, or at a pole: a seam
    edge) lies at the end that the loop's sense asks for (an outer loop runs
    counterclockwise in (u, v): up a u-seam at the high end, down it at the low one; a hole
    the other way round; the sense from its steps, the short way across the other seam of
    a torus); any other point near the seam goes to the side of the nearest point of its
    trim away from the seam and off the poles (a trim never crosses the seam, and Newton
    may stop a hair inside either end).  At a pole (``free`` >= 0: the direction along
    which the surface does not move) the neighbour's parameter."""
    m = len(uv)
    span = grid.hi - grid.lo
    cuts = np.cumsum([0, *(pieces if pieces is not None else [m])])
    for d in (0, 1):
        if not grid.closed[d]:
            continue
        e, lo, hi, near = 1 - d, grid.lo[d], grid.hi[d], grid.seam[d]
        for a, b in itertools.pairwise(cuts):
            x = uv[a:b, d]
            loose = free[a:b] == d  # at a pole: any x names the point
            seam = (x - lo <= near) | (hi - x <= near)
            if not (seam & ~loose).any():
                continue
            seam |= loose
            if seam.all():
                step = np.diff(uv[a:b, e])
                if grid.closed[e]:  # across the other seam (a torus's corner): the short way
                    step = (step + 0.5 * span[e]) % span[e] - 0.5 * span[e]
                travel = float(step.sum())
                if abs(travel) <= 1e-9 * span[e]:
                    continue
                high = (travel > 0) if (d == 0) == outer else (travel < 0)
                x[:] = hi if high else lo
                continue
            away = np.flatnonzero(~seam)
            for i in np.flatnonzero(seam & ~loose):
                j = away[np.argmin(np.abs(away - i))]
                side_hi = x[j] - lo > hi - x[j]
                if side_hi and x[i] - lo <= near:
                    x[i] = min(x[i] + span[d], hi)
                elif not side_hi and hi - x[i] <= near:
                    x[i] = max(x[i] - span[d], lo)
    pole = free >= 0
    for k in outward(pole):
        j = (k - 1) % m if not pole[(k - 1) % m] else (k + 1) % m
        uv[k, free[k]] = uv[j, free[k]]
        pole[k] = False


def outward(mask: NDArray[np.bool_]) -> list[int]:
    """Indices of ``mask`` ordered so that each comes next to one already resolved (none
    when every index is in ``mask``)."""
    m = len(mask)
    mask = mask.copy()
    order: list[int] = []
    while mask.any() and not mask.all():
        ready = [i for i in np.flatnonzero(mask) if not (mask[(i - 1) % m] and mask[(i + 1) % m])]
        if not ready:
            break
        for i in ready:
            mask[i] = False
        order.extend(int(i) for i in ready)
    return order
