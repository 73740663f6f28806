"""Planar section curves, the cuts of a surface by the planes <p, a> = c, as curves that
combs run along (:mod:`gshade.analysis.curvature_combs`).

Each section is traced on a patch's (u, v) grid by marching squares
(:func:`skimage.measure.find_contours`; outside a CAD face's trims the grid is NaN, so
that a cut ends at the trim), and every point asked for is then moved onto the exact curve
by Newton's method on f(u, v) = <p(u, v), a> - c along the surface gradient of f.  There
the curve's tangent and curvature vector come from the surface's exact derivatives
(Meusnier's theorem; do Carmo, §3-2): with n the unit normal,

    T = (n x a) / |n x a|,    m = a x T,    k = II(T, T) / <m, n> m,

since the curvature vector of a plane curve lies in its plane, perpendicular to T, and its
normal part <k, n> is the normal curvature II(T, T) of the surface in the direction T.  The
cut is singular where the plane touches the surface (<m, n> = 0): no curvature there.

A section is handed to the combs as a curve parametrised by its traced polyline's point
index; the derivatives given are those of the arc-length parametrisation through the same
point (c' = T, c'' = k), which is all a comb shows.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..geometry import Patch, regularised_derivatives
from ..geometry.core.differential import (
    cross_arrays,
    dot_arrays,
    first_fundamental_form,
    form_at,
    second_fundamental_form,
    solve_first_form,
    unit_normal,
)
from .curvature_combs import CurveFamily, CurveSamples

__all__ = ["GRID", "SectionPlanes", "SectionRegion", "section_family", "section_points"]

#: Grid points a side a patch's box is traced on, and probed on first for the levels near.
GRID, PROBE_GRID = 49, 9
#: Newton steps moving a traced point onto its section (quadratic: a grid cell's error
#: is below rounding after four).
NEWTON_STEPS = 6
#: |<m, n>| below this: the plane touches the surface, the cut is singular there.
TOUCHING = 1e-9


@dataclass(frozen=True)
class SectionPlanes:
    """The planes <p, a> = c for each c of ``levels``, ``direction`` a (unit)."""

    direction: NDArray[np.float64]
    levels: NDArray[np.float64]

    @classmethod
    def spread(cls, direction: Sequence[float], points: NDArray, count: int) -> SectionPlanes:
        """``count`` planes perpendicular to ``direction`` at the middles of equal parts of
        the range of <p, a> over ``points`` (n, 3).

        Examples
        --------
        >>> planes = SectionPlanes.spread([0, 0, 2], np.array([[0, 0, 0], [0, 0, 4.0]]), 4)
        >>> planes.direction.tolist(), planes.levels.tolist()
        ([0.0, 0.0, 1.0], [0.5, 1.5, 2.5, 3.5])
        """
        a = np.asarray(direction, dtype=np.float64)
        a = a / np.linalg.norm(a)
        f = np.asarray(points, dtype=np.float64) @ a
        lo, hi = float(f.min()), float(f.max())
        return cls(a, lo + (hi - lo) * (np.arange(count) + 0.5) / count)


@dataclass(frozen=True)
class SectionRegion:
    """Where sections are traced: the scene patch ``patch``'s parameter ``box``, the
    points inside its trims (``inside(uv) -> bool (n,)`` on the patch's (u, v); None: the
    whole box) and the name the cuts are labelled with (``"patch 3"``, ``"face 12"``)."""

    patch: int
    box: tuple[tuple[float, float], tuple[float, float]]
    inside: Callable[[NDArray[np.float64]], NDArray[np.bool_]] | None
    name: str


def _crossed(patch: Patch, box: tuple, planes: SectionPlanes, n: int) -> bool:
    """Whether a plane may cut the patch's ``box``: its level within the range of
    f = <p, a> on an n x n grid widened by f's largest step between neighbouring points."""
    (u0, u1), (v0, v1) = box
    u, v = np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n), indexing="ij")
    f = (np.asarray(patch(u.ravel(), v.ravel())) @ planes.direction).reshape(n, n)
    reach = max(np.abs(np.diff(f, axis=0)).max(), np.abs(np.diff(f, axis=1)).max())
    near = (planes.levels >= f.min() - reach) & (planes.levels <= f.max() + reach)
    return bool(near.any())


def _traced(
    patch: Patch, region: SectionRegion, planes: SectionPlanes
) -> list[tuple[float, NDArray[np.float64]]]:
    """The cuts of one region as (level, (u, v) polyline (m, 2)), two points at least (a
    region no level comes near on a coarse grid first is passed over)."""
    from skimage.measure import find_contours

    if not _crossed(patch, region.box, planes, PROBE_GRID):
        return []
    (u0, u1), (v0, v1) = region.box
    u, v = np.meshgrid(np.linspace(u0, u1, GRID), np.linspace(v0, v1, GRID), indexing="ij")
    f = np.asarray(patch(u.ravel(), v.ravel())) @ planes.direction
    lo, hi = f.min(), f.max()
    if not np.any((planes.levels >= lo) & (planes.levels <= hi)) or lo == hi:
        return []
    if region.inside is not None:
        inside = region.inside(np.stack([u.ravel(), v.ravel()], -1))
        f = np.where(inside, f, np.nan)
    f = f.reshape(GRID, GRID)
    if not np.isfinite(f).any():
        return []
    lo, hi = np.nanmin(f), np.nanmax(f)
    scale = np.array([u1 - u0, v1 - v0]) / (GRID - 1)
    out = []
    for level in planes.levels:
        if not lo <= level <= hi or lo == hi:
            continue
        for line in find_contours(f, float(level)):
            if len(line) >= 2:
                out.append((float(level), np.array([u0, v0]) + line * scale))
    return out


def section_points(
    patch: Patch,
    uv: NDArray[np.float64],
    direction: NDArray[np.float64],
    level: float | NDArray[np.float64],
    box: tuple[tuple[float, float], tuple[float, float]],
) -> NDArray[np.float64]:
    """The points (n, 2) near ``uv`` on the cuts <p(u, v), a> = ``level`` (one, or one a
    point), by Newton's method along the gradient of f = <p, a> - level in (u, v), kept in
    ``box``; it stops where no point moves by more than rounding.

    Examples
    --------
    The unit sphere's cut by z = 0.5 (a circle of radius sqrt(3) / 2):

    >>> from gshade.geometry import sphere
    >>> ball = sphere(1.0)
    >>> (u0, u1), (v0, v1) = ball.domain
    >>> start = np.array([[0.6 * u0 + 0.4 * u1, 0.5 * (v0 + v1)]])
    >>> uv = section_points(ball, start, np.array([0, 0, 1.0]), 0.5, ball.domain)
    >>> bool(abs(ball(*uv.T)[0, 2] - 0.5) < 1e-14)
    True
    """
    uv = np.array(uv, dtype=np.float64)
    (u0, u1), (v0, v1) = box
    still = 1e-15 * max(u1 - u0, v1 - v0)
    for _ in range(NEWTON_STEPS):
        d = patch.derivatives(uv[:, 0], uv[:, 1], 1)
        f = d[0, 0] @ direction - level
        g = np.stack([d[1, 0] @ direction, d[0, 1] @ direction], -1)
        size = np.sum(g * g, -1)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.nan_to_num(np.where(size[:, None] > 0, -f[:, None] * g / size[:, None], 0.0))
        uv = uv + step
        uv[:, 0] = np.clip(uv[:, 0], u0, u1)
        uv[:, 1] = np.clip(uv[:, 1], v0, v1)
        if not np.abs(step).max(initial=0.0) > still:
            break
    return uv


def _section_samples(
    patch: Patch, uv: NDArray, heading: NDArray, direction: NDArray
) -> NDArray[np.float64]:
    """(3, n, 3): the points, T (pointing along ``heading`` in (u, v)) and k (Meusnier)."""
    d = regularised_derivatives(patch, uv[:, 0], uv[:, 1], 2).d
    n = unit_normal(d).n
    along = cross_arrays(n, np.broadcast_to(direction, n.shape))
    with np.errstate(divide="ignore", invalid="ignore"):
        tangent = along / np.linalg.norm(along, axis=-1)[:, None]
        forward = d[1, 0] * heading[:, :1] + d[0, 1] * heading[:, 1:]
        tangent *= np.where(dot_arrays(tangent, forward) < 0, -1.0, 1.0)[:, None]
        E, F, G = first_fundamental_form(d)
        a, b = solve_first_form(
            E, F, G, E * G - F * F, dot_arrays(tangent, d[1, 0]), dot_arrays(tangent, d[0, 1])
        )
        normal_curvature = form_at(*second_fundamental_form(d, n), a, b)
        m = cross_arrays(np.broadcast_to(direction, n.shape), tangent)
        tilt = dot_arrays(m, n)
        k = (normal_curvature / tilt)[:, None] * m
    k[~(np.abs(tilt) > TOUCHING)] = np.nan
    return np.stack([d[0, 0], tangent, k])


def _guess(
    cut: tuple[SectionRegion, float, NDArray], t: NDArray[np.float64]
) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """At the traced polyline's parameters t: its (u, v) (n, 2), its heading (n, 2), the
    cut's level (n,) and patch (n,)."""
    region, level, line = cut
    index = np.arange(len(line))
    uv = np.stack([np.interp(t, index, line[:, 0]), np.interp(t, index, line[:, 1])], -1)
    segment = np.clip(np.floor(t).astype(np.int64), 0, len(line) - 2)
    n = len(t)
    return uv, line[segment + 1] - line[segment], np.full(n, level), np.full(n, region.patch)


def section_family(
    patches: Sequence[Patch], regions: Sequence[SectionRegion], planes: SectionPlanes
) -> CurveFamily:
    """The cuts of the scene ``patches`` in ``regions`` by ``planes``: each traced piece a
    curve, labelled ``"section <p, a> = c (face 12)"``, its parameter the point index of
    the traced polyline (see the module's description)."""
    found: list[tuple[SectionRegion, float, NDArray]] = []
    boxes = {region.patch: region.box for region in regions}
    for region in regions:
        for level, line in _traced(patches[region.patch], region, planes):
            found.append((region, level, line))

    def evaluate(requests: list[tuple[int, NDArray[np.float64]]]) -> list[CurveSamples]:
        """The requests' points moved onto their cuts and their derivatives, the points
        on one patch together."""
        if not requests:
            return []
        columns = [_guess(found[c], t) for c, t in requests]
        guess, heading, level, patch_of = (np.concatenate(x) for x in zip(*columns, strict=True))
        uv, samples = np.empty((len(guess), 2)), np.empty((3, len(guess), 3))
        for k in np.unique(patch_of).tolist():
            on = patch_of == k
            uv[on] = section_points(patches[k], guess[on], planes.direction, level[on], boxes[k])
            samples[:, on] = _section_samples(patches[k], uv[on], heading[on], planes.direction)
        out, start = [], 0
        for c, t in requests:
            part = slice(start, start + len(t))
            out.append(CurveSamples(samples[:, part], found[c][0].patch, uv[part]))
            start += len(t)
        return out

    labels = [f"section <p, a> = {level:.6g} ({region.name})" for region, level, _ in found]
    return CurveFamily(labels, [(0.0, float(len(line) - 1)) for *_, line in found], evaluate)
