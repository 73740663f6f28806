"""Closest points on exact surfaces: for each query point q, the point S_k(u, v) of a set of
patches nearest to it, with its patch and (u, v).

A coarse search first: every patch sampled on a grid of its domain, the samples in a k-d
tree (:class:`scipy.spatial.cKDTree`), the :data:`CANDIDATES` nearest samples of q each a
start.  Then Newton's method on the exact surface for the minimum of g = |S(u, v) - q|^2 / 2
over the patch's domain (do Carmo, §2-5; the foot point problem), whose gradient and matrix
are

    grad g = (<S_u, r>, <S_v, r>),   r = S - q,
    H = [[<S_u, S_u> + <S_uu, r>,  <S_u, S_v> + <S_uv, r>],
         [<S_u, S_v> + <S_uv, r>,  <S_v, S_v> + <S_vv, r>]],

with Gauss–Newton's matrix (the first fundamental form) where H is not positive definite.
The domain's sides are an active set: a parameter that reached a side and would leave it
is held there while the other is solved for, so that a foot point on a patch's boundary
(the closest point of a patch is often on its edge) is found as exactly as one inside.
Last, every patch the nearest samples did not lead to is asked where it can come nearer:
its samples are grouped in blocks (:class:`Blocks`), each boxed and widened by two of its
cell diagonals, and every block whose box lies nearer to q than the best point found is a
start of its own.  The nearest of the foot points is the answer.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..geometry import Patch

__all__ = [
    "CANDIDATES",
    "GRID",
    "ON_SURFACE",
    "Blocks",
    "ClosestPoints",
    "Samples",
    "closest_points",
    "foot_points",
    "grid_samples",
]

#: Samples a side of each patch's grid for the coarse search.
GRID = 17
#: The most samples along a side of a patch.
MOST_SAMPLES = 129
#: Nearest samples each query starts Newton's method from (on their patches).
CANDIDATES = 4
#: Shortenings (each by 4) of a Newton step that would take a point farther from its
#: query.
SHORTENINGS = 15
#: A query this near a foot point, relative to the patches' size, is on the surface: no
#: patch can hold a nearer point worth the search.
ON_SURFACE = 1e-13
#: Points at which a batch is evaluated by Dr.Jit (where it works) rather than numpy.
BIG_BATCH = 4096
#: Cells a side of a block of samples boxed for the search's last round (:class:`Blocks`).
BLOCK = 8
#: Starts around a pole a foot stopped at is searched again from (the nearest of them).
POLE_RING = 32
#: Newton steps at most (quadratic convergence: a grid cell's start is exact in ~5; near a
#: pole, where it is linear, more).
NEWTON_STEPS = 24


@dataclass(frozen=True)
class ClosestPoints:
    """Each query's closest point ``point`` (n, 3) on the patches, its ``patch`` (n,),
    its parameters ``uv`` (n, 2) there and the ``distance`` (n,)."""

    point: NDArray[np.float64]
    patch: NDArray[np.int64]
    uv: NDArray[np.float64]
    distance: NDArray[np.float64]


class _Surfaces:
    """Patches evaluated together
    (:class:`~gshade.geometry.evaluation.patch_cells.ManyPatches`) with their domains'
    corners (m, 2)."""

    def __init__(self, patches: Sequence[Patch]) -> None:
        from ..geometry.evaluation.patch_cells import ManyPatches
        from ..shape.kernels import backend

        # numpy for the Newton steps' many small calls (few points still moving, halvings:
        # Dr.Jit's kernel launches cost more there), Dr.Jit for the big batches
        self.small = ManyPatches(patches, drjit=False)
        self.big = ManyPatches(patches, drjit=True) if backend() == "drjit" else self.small
        domains = np.array([p.domain for p in patches], dtype=np.float64).reshape(-1, 2, 2)
        self.lo, self.hi = domains[:, :, 0], domains[:, :, 1]
        self.closed, self.collapsed = self._sides(len(patches))

    def _sides(self, n: int) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
        """(m, 2): whether each patch closes on itself across u (its sides u0 and u1 one
        curve, a periodic face's seam) and across v; and (m, 2, 2): whether its side
        (axis, low or high) is one point (a pole); judged at 9 points of the sides."""
        t = np.linspace(0.0, 1.0, 9)
        index = np.repeat(np.arange(n), t.size)
        out = np.zeros((n, 2), dtype=bool)
        pole = np.zeros((n, 2, 2), dtype=bool)
        for axis in range(2):
            across = np.tile(t, n)
            other = 1 - axis
            a, b = np.empty((index.size, 2)), np.empty((index.size, 2))
            a[:, axis], b[:, axis] = self.lo[index, axis], self.hi[index, axis]
            a[:, other] = b[:, other] = self.lo[index, other] + across * (
                self.hi[index, other] - self.lo[index, other]
            )
            pa, pb = self.derivatives(index, a, 0)[0, 0], self.derivatives(index, b, 0)[0, 0]
            size = np.linalg.norm(np.ptp(pa.reshape(n, -1, 3), axis=1), axis=-1)
            apart = np.linalg.norm(pa - pb, axis=-1).reshape(n, -1).max(axis=1)
            out[:, axis] = apart <= 1e-9 * np.maximum(size, 1e-300)
            both = np.concatenate([pa, pb]).reshape(2, n, -1, 3)
            whole = np.linalg.norm(np.ptp(both, axis=(0, 2)), axis=-1)
            spread = np.linalg.norm(np.ptp(both, axis=2), axis=-1)  # (2, n): each side's
            pole[:, axis] = (spread <= 1e-9 * np.maximum(whole, 1e-300)).T
        return out, pole

    def derivatives(self, index: NDArray, uv: NDArray, order: int) -> NDArray[np.float64]:
        many = self.big if len(index) >= BIG_BATCH else self.small
        return many.derivatives(index, uv[:, 0], uv[:, 1], order)


def foot_points(
    patch: Patch, queries: ArrayLike, start: ArrayLike, steps: int = NEWTON_STEPS
) -> NDArray[np.float64]:
    """The parameters (n, 2) of the points of ``patch`` nearest to ``queries`` (n, 3), by
    Newton's method from ``start`` (n, 2) within the patch's domain (see the module).

    Examples
    --------
    The unit sphere's foot point of (0, 0, 3) is its north pole, at distance 2:

    >>> from gshade.geometry import sphere
    >>> ball = sphere(1.0)
    >>> (u0, u1), (v0, v1) = ball.domain
    >>> uv = foot_points(ball, [[0.0, 0.0, 3.0]], [[0.8 * u1 + 0.2 * u0, 0.5 * (v0 + v1)]])
    >>> (np.round(ball(*uv.T), 12) + 0.0).tolist()
    [[0.0, 0.0, 1.0]]
    """
    q = np.asarray(queries, dtype=np.float64).reshape(-1, 3)
    start = np.asarray(start, dtype=np.float64).reshape(-1, 2)
    return _feet(_Surfaces([patch]), np.zeros(len(q), np.int64), q, start, steps)[0]


def _feet(
    surfaces: _Surfaces,
    index: NDArray,
    q: NDArray,
    start: NDArray,
    steps: int = NEWTON_STEPS,
    wrap: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`foot_points` of each query on its patch ``index`` of ``surfaces``, all
    patches at once; with ``wrap``, a foot stopped at a seam searched again from across
    it (:func:`_wrapped`): the parameters (n, 2) and the distances (n,)."""
    uv = np.array(start, dtype=np.float64).reshape(-1, 2)
    lo, hi = surfaces.lo[index], surfaces.hi[index]
    d = surfaces.derivatives(index, uv, 2)  # at the points still moving
    gap = np.linalg.norm(d[0, 0] - q, axis=-1)
    # a distance's rounding: a step within it neither nearer nor farther
    rounding = 1e-15 * np.abs(q).max(axis=-1) + 1e-300
    active = np.arange(len(q))  # the points still moving
    for _ in range(steps):
        if active.size == 0:
            break
        here, at, target = uv[active], index[active], q[active]
        low, high = lo[active], hi[active]
        step = _newton_step(d, target, here, low, high)
        moved = np.clip(here + step, low, high)
        d = surfaces.derivatives(at, moved, 2)
        after = np.linalg.norm(d[0, 0] - target, axis=-1)
        # a step that does not bring the point nearer is shortened (Newton's full step may
        # leap to another critical point of a curved patch): the longest of its fractions
        # 4^-1 ... 4^-SHORTENINGS that does, all tried in one batch; none: a minimum to
        # rounding, the point stays
        worse = np.flatnonzero(after > gap[active] * (1 + 1e-12) + rounding[active])
        if worse.size:
            scale = 0.25 ** np.arange(1, SHORTENINGS + 1)
            tries = np.clip(
                here[worse, None] + scale[:, None] * step[worse, None],
                low[worse, None],
                high[worse, None],
            ).reshape(-1, 2)
            which = np.repeat(worse, SHORTENINGS)
            far = np.linalg.norm(
                surfaces.derivatives(at[which], tries, 0)[0, 0] - target[which], axis=-1
            ).reshape(-1, SHORTENINGS)
            nearer = far <= (gap[active] * (1 + 1e-12) + rounding[active])[worse, None]
            first = np.argmax(nearer, axis=1)
            found = nearer[np.arange(worse.size), first]
            moved[worse] = np.where(
                found[:, None],
                tries.reshape(-1, SHORTENINGS, 2)[np.arange(worse.size), first],
                here[worse],
            )
            d[:, :, worse] = surfaces.derivatives(at[worse], moved[worse], 2)
            after[worse] = np.linalg.norm(d[0, 0, worse] - target[worse], axis=-1)
        # moving on while the point moves in space by more than its rounding
        change = moved - here
        shift = d[1, 0] * change[:, :1] + d[0, 1] * change[:, 1:]
        going = np.linalg.norm(shift, axis=-1) > 4 * rounding[active]
        uv[active], gap[active] = moved, after
        active, d = active[going], d[:, :, going]
    if wrap:
        _wrapped(surfaces, index, q, uv, gap, steps)
        _off_poles(surfaces, index, q, uv, gap, steps)
    return uv, gap


def _wrapped(
    surfaces: _Surfaces, index: NDArray, q: NDArray, uv: NDArray, gap: NDArray, steps: int
) -> None:
    """Feet (``uv``, at distances ``gap``) that stopped at a side of a patch closed across
    it (a periodic face's seam) searched again from the other side, the nearer kept (in
    place)."""
    lo, hi = surfaces.lo[index], surfaces.hi[index]
    closed = surfaces.closed[index]
    at_lo, at_hi = closed & (uv <= lo), closed & (uv >= hi)
    again = np.flatnonzero((at_lo | at_hi).any(axis=1))
    if not again.size:
        return
    start = uv[again].copy()
    start = np.where(at_lo[again], hi[again], np.where(at_hi[again], lo[again], start))
    other, distance = _feet(surfaces, index[again], q[again], start, steps, wrap=False)
    nearer = distance < gap[again]
    uv[again[nearer]], gap[again[nearer]] = other[nearer], distance[nearer]


def _off_poles(
    surfaces: _Surfaces, index: NDArray, q: NDArray, uv: NDArray, gap: NDArray, steps: int
) -> None:
    """Feet that stopped at a pole (a side that is one point: there the other parameter
    cannot move, whatever side of the pole the query is on) searched again from the
    nearest of :data:`POLE_RING` points just off the pole, the nearer kept (in place)."""
    lo, hi = surfaces.lo[index], surfaces.hi[index]
    pole = surfaces.collapsed[index]  # (n, 2, 2)
    at = np.stack([uv <= lo, uv >= hi], -1) & pole
    again = np.flatnonzero(at.any(axis=(1, 2)))
    if not again.size:
        return
    axis = np.argmax(at[again].any(axis=2), axis=1)  # the parameter at the pole
    high = at[again, axis, 1]
    other = 1 - axis
    ring = np.linspace(0.0, 1.0, POLE_RING, endpoint=False)
    start = np.repeat(uv[again], POLE_RING, axis=0)
    row = np.arange(again.size).repeat(POLE_RING)
    a, o = axis[row], other[row]
    span = (hi - lo)[again][row]
    base = lo[again][row]
    start[np.arange(len(row)), o] = (
        base[np.arange(len(row)), o] + np.tile(ring, again.size) * span[np.arange(len(row)), o]
    )
    inward = np.where(high[row], -1e-3, 1e-3) * span[np.arange(len(row)), a]
    start[np.arange(len(row)), a] += inward
    which = index[again][row]
    near = np.linalg.norm(surfaces.derivatives(which, start, 0)[0, 0] - q[again][row], axis=-1)
    best = np.argmin(near.reshape(again.size, POLE_RING), axis=1)
    chosen = start.reshape(again.size, POLE_RING, 2)[np.arange(again.size), best]
    found, distance = _feet(surfaces, index[again], q[again], chosen, steps, wrap=False)
    nearer = distance < gap[again]
    uv[again[nearer]], gap[again[nearer]] = found[nearer], distance[nearer]


def _newton_step(
    d: NDArray, q: NDArray, uv: NDArray, lo: NDArray, hi: NDArray
) -> NDArray[np.float64]:
    """One step (n, 2) of the foot-point Newton method from the derivatives ``d`` at
    ``uv`` (see the module), a parameter held at a side it reached where the descent leads
    out of the domain."""
    r = d[0, 0] - q
    su, sv = d[1, 0], d[0, 1]
    g = np.stack([np.sum(su * r, -1), np.sum(sv * r, -1)], -1)
    E, F, G = np.sum(su * su, -1), np.sum(su * sv, -1), np.sum(sv * sv, -1)
    a = E + np.sum(d[2, 0] * r, -1)
    b = F + np.sum(d[1, 1] * r, -1)
    c = G + np.sum(d[0, 2] * r, -1)
    definite = (a > 0) & (a * c - b * b > 0)
    a, b, c = np.where(definite, a, E), np.where(definite, b, F), np.where(definite, c, G)
    held = ((uv <= lo) & (g > 0)) | ((uv >= hi) & (g < 0))
    det = a * c - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        step = np.stack([(-c * g[:, 0] + b * g[:, 1]) / det, (b * g[:, 0] - a * g[:, 1]) / det], -1)
    # where the matrix is singular (a pole: S_v = 0), one parameter at a time
    singular = ~(det > 1e-30 * (E + G) ** 2)
    held[singular & (c > a), 0] = True
    held[singular & ~(c > a), 1] = True
    only_v = held[:, 0] & ~held[:, 1]
    only_u = held[:, 1] & ~held[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        step[only_v] = np.stack([np.zeros(only_v.sum()), -g[only_v, 1] / c[only_v]], -1)
        step[only_u] = np.stack([-g[only_u, 0] / a[only_u], np.zeros(only_u.sum())], -1)
    step[held[:, 0] & held[:, 1]] = 0.0
    return np.nan_to_num(step)


def _lattice(patch: Patch, grid: int) -> tuple[int, int]:
    """The samples along u and along v of a patch's ``grid`` x ``grid`` budget, in the
    ratio of its lengths across (a long, thin face gets its samples along its length)."""
    t = np.linspace(0.0, 1.0, 5)
    (u0, u1), (v0, v1) = patch.domain
    u, v = np.meshgrid(u0 + (u1 - u0) * t, v0 + (v1 - v0) * t, indexing="ij")
    p = np.asarray(patch(u.ravel(), v.ravel()), dtype=np.float64).reshape(5, 5, 3)
    along_u = np.linalg.norm(np.diff(p, axis=0), axis=-1).sum(axis=0).max()
    along_v = np.linalg.norm(np.diff(p, axis=1), axis=-1).sum(axis=1).max()
    if not (along_u > 0 and along_v > 0):
        return grid, grid
    nu = int(np.clip(round(grid * np.sqrt(along_u / along_v)), 3, grid * grid // 3))
    return nu, max(3, (grid * grid) // nu)


def _axis_samples(patch: Patch, axis: int, n: int, spacing: float) -> NDArray[np.float64]:
    """A patch's sample parameters along ``axis``: the middles of n cells of equal length
    (arc length, the longest of three lines across; a B-spline's speed measured in each
    knot span, so that a parametrisation that crowds its shape into a few spans has its
    samples there), more where the length needs them ``spacing`` apart (> 0), at most
    :data:`MOST_SAMPLES`."""
    lo, hi = patch.domain[axis]
    breaks = np.array([lo, hi])
    knots = getattr(patch, "knots", None)
    if knots is not None:
        breaks = np.unique(np.clip(np.asarray(knots[axis], dtype=np.float64), lo, hi))
    if breaks.size > MOST_SAMPLES:
        breaks = breaks[:: -(-breaks.size // MOST_SAMPLES)]
    eighths = np.linspace(0.0, 1.0, 9)
    fine = np.unique(breaks[:-1, None] + np.diff(breaks)[:, None] * eighths)
    (u0, u1), (v0, v1) = patch.domain
    across = np.array([1 / 6, 1 / 2, 5 / 6])
    other = (v0 + (v1 - v0) * across) if axis == 0 else (u0 + (u1 - u0) * across)
    t, o = np.meshgrid(fine, other, indexing="ij")
    u, v = (t, o) if axis == 0 else (o, t)
    at = np.asarray(patch(u.ravel(), v.ravel()), dtype=np.float64).reshape(len(fine), 3, 3)
    step = np.linalg.norm(np.diff(at, axis=0), axis=-1).max(axis=1)
    length = np.concatenate([[0.0], np.cumsum(step)])
    if spacing > 0:
        n = max(n, min(MOST_SAMPLES, int(np.ceil(length[-1] / spacing))))
    if not length[-1] > 0:
        return lo + (hi - lo) * (np.arange(n) + 0.5) / n
    return np.interp((np.arange(n) + 0.5) / n * length[-1], length, fine)


def _blocks(at: NDArray, su: NDArray, sv: NDArray, reach: float) -> list[tuple]:
    """The :class:`Blocks` of one patch's lattice of samples ``at`` (nu, nv, 3) at
    parameters ``su`` x ``sv`` whose cells' diagonals are at most ``reach``: (lo, hi,
    (u, v)) each, a block's samples and those of the next row and column (the cells
    between blocks) boxed."""
    out = []
    for i in range(0, max(len(su) - 1, 1), BLOCK):
        for j in range(0, max(len(sv) - 1, 1), BLOCK):
            part = at[i : i + BLOCK + 1, j : j + BLOCK + 1].reshape(-1, 3)
            middle = (su[min(i + BLOCK // 2, len(su) - 1)], sv[min(j + BLOCK // 2, len(sv) - 1)])
            out.append((part.min(axis=0) - 2 * reach, part.max(axis=0) + 2 * reach, middle))
    return out


def _samples(
    patches: Sequence[Patch], grid: int, spacing: float = 0.0
) -> tuple[NDArray, NDArray, NDArray, NDArray, Blocks]:
    """Every patch's samples, ``grid`` x ``grid`` of them spread in the ratio of its
    lengths (:func:`_lattice`), at the middles of its cells (none on a side: the samples
    of a pole or a seam would be many at one point, each a poor start): points (m, 3),
    their patch (m,) and (u, v), each patch's spacing in its domain (k, 2) and the blocks
    (:class:`Blocks`)."""
    points, owner, uv, cells = [], [], [], []
    boxes: list[tuple] = []
    box_patch: list[int] = []
    for k, patch in enumerate(patches):
        nu, nv = _lattice(patch, grid)
        su, sv = _axis_samples(patch, 0, nu, spacing), _axis_samples(patch, 1, nv, spacing)
        # two mean spacings: the starts within that of each other on the patch are one
        cells.append(tuple(2 * np.ptp(t) / max(len(t) - 1, 1) for t in (su, sv)))
        uu, vv = np.meshgrid(su, sv, indexing="ij")
        u, v = uu.ravel(), vv.ravel()
        at = np.asarray(patch(u, v), dtype=np.float64).reshape(len(su), len(sv), 3)
        one = np.linalg.norm(at[1:, 1:] - at[:-1, :-1], axis=-1).max(initial=0.0)
        other = np.linalg.norm(at[1:, :-1] - at[:-1, 1:], axis=-1).max(initial=0.0)
        mine = _blocks(at, su, sv, max(float(one), float(other)))
        boxes += mine
        box_patch += [k] * len(mine)
        points.append(at.reshape(-1, 3))
        owner.append(np.full(u.size, k))
        uv.append(np.stack([u, v], -1))
    cell = np.array(cells, dtype=np.float64).reshape(-1, 2)
    blocks = Blocks(
        np.array([b[0] for b in boxes]).reshape(-1, 3),
        np.array([b[1] for b in boxes]).reshape(-1, 3),
        np.array(box_patch, dtype=np.int64),
        np.array([b[2] for b in boxes], dtype=np.float64).reshape(-1, 2),
    )
    return np.concatenate(points), np.concatenate(owner), np.concatenate(uv), cell, blocks


@dataclass(frozen=True)
class Blocks:
    """Boxes holding the patches piece by piece: each block of a patch's sample lattice
    (:data:`BLOCK` x :data:`BLOCK` cells) boxed by its samples, widened by two of the
    patch's cell diagonals (how far its surface may bulge between samples): corners ``lo``
    and ``hi`` (b, 3), its ``patch`` (b,) and a start ``uv`` (b, 2) in its middle."""

    lo: NDArray[np.float64]
    hi: NDArray[np.float64]
    patch: NDArray[np.int64]
    uv: NDArray[np.float64]


@dataclass(frozen=True)
class Samples:
    """Points of the surface for the coarse search: ``points`` (m, 3) on patches
    ``patch`` (m,) at parameters ``uv`` (m, 2); ``cell`` (k, 2): each patch's spacing of
    samples in its domain, within which two samples of the patch are one start of
    Newton's method; ``blocks``: the patches' blocks of samples, boxed."""

    points: NDArray[np.float64]
    patch: NDArray[np.int64]
    uv: NDArray[np.float64]
    cell: NDArray[np.float64]
    blocks: Blocks


def grid_samples(patches: Sequence[Patch], grid: int = GRID, spacing: float = 0.0) -> Samples:
    """Every patch's ``grid`` x ``grid`` samples at the middles of its cells, spread in
    the ratio of its lengths across, and more along a length that needs them ``spacing``
    apart (> 0: a big face's samples near every point of it, as a start in the basin of
    its foot point)."""
    return Samples(*_samples(patches, grid, spacing))


def closest_points(
    patches: Sequence[Patch],
    queries: ArrayLike,
    *,
    samples: Samples | None = None,
    candidates: int = CANDIDATES,
    inside: Callable[[NDArray[np.int64], NDArray[np.float64]], NDArray[np.bool_]] | None = None,
    boundary: Callable[[NDArray[np.float64]], ClosestPoints] | None = None,
) -> ClosestPoints:
    """The points of ``patches`` nearest to each of ``queries`` (n, 3): from the
    ``candidates`` nearest of the ``samples`` (default :func:`grid_samples`), Newton's
    method on the exact patches (:func:`foot_points`), then from the middle of every block
    of another patch whose box comes nearer (see the module), the nearest foot point kept.

    Trimmed patches: ``inside(index, uv)`` says which (u, v) of patches ``index`` are
    part of the surface (a foot point elsewhere is none), and ``boundary(queries)`` gives
    the closest points on the trims' curves
    (:func:`gshade.analysis.trimmed_faces.boundary_search`), asked for the queries a foot
    point outside the trims was found for.

    Examples
    --------
    >>> from gshade.geometry import sphere
    >>> found = closest_points([sphere(2.0)], [[0.0, 3.0, 4.0]])
    >>> (np.round(found.point, 12) + 0.0).tolist(), round(float(found.distance[0]), 12)
    ([[0.0, 1.2, 1.6]], 3.0)
    """
    from scipy.spatial import cKDTree

    q = np.asarray(queries, dtype=np.float64).reshape(-1, 3)
    samples = samples if samples is not None else grid_samples(patches)
    points, owner = samples.points, samples.patch
    tree = cKDTree(points)
    surfaces = _Surfaces(patches)
    size = float(np.linalg.norm(np.ptp(points, axis=0)))
    best = ClosestPoints(
        np.zeros_like(q), np.zeros(len(q), np.int64), np.zeros((len(q), 2)), np.full(len(q), np.inf)
    )
    if not len(q):
        return best
    k = min(candidates, len(points))
    distance, nearest = tree.query(q, k=k)
    nearest = np.asarray(nearest).reshape(len(q), k)
    spacing = np.asarray(distance).reshape(len(q), k)
    outside = _first_round(surfaces, q, samples, best, nearest, inside)
    if boundary is not None and outside.any():  # the closest points on the trims' curves
        _merge(best, np.flatnonzero(outside), boundary(q[outside]))
    # the last round: every block of a patch the query has not asked whose box comes
    # nearer than the best point found (or than its nearest sample, a point of the
    # surface), Newton's method from the block's middle; a query on the surface (to
    # rounding) has its answer
    m = len(patches)
    pairs = np.unique(np.arange(len(q))[:, None] * m + owner[nearest])  # the patches asked
    unsure = np.flatnonzero(best.distance > ON_SURFACE * size)
    reach = np.minimum(best.distance[unsure], spacing[unsure, 0])
    who, block = _near_blocks(samples.blocks, q[unsure], reach)
    who, patch = unsure[who], samples.blocks.patch[block]
    new = ~np.isin(who * m + patch, pairs)
    who, block, patch = who[new], block[new], patch[new]
    if who.size:
        out = _tried(surfaces, q, who, patch, samples.blocks.uv[block], best, inside)
        fresh = np.setdiff1d(who[out], np.flatnonzero(outside))
        if boundary is not None and fresh.size:
            _merge(best, fresh, boundary(q[fresh]))
    return best


def _tried(
    surfaces: _Surfaces,
    q: NDArray,
    who: NDArray,
    on: NDArray,
    start: NDArray,
    best: ClosestPoints,
    inside: Callable[[NDArray[np.int64], NDArray[np.float64]], NDArray[np.bool_]] | None,
) -> NDArray[np.bool_]:
    """Newton's method for queries ``who`` on patches ``on`` from ``start`` (u, v), all at
    once; each query's nearest foot point inside the trims kept in ``best`` where nearer.
    Which of the feet lie outside the trims and nearer than the best point found (there,
    the face's own closest point may be on its trims' curves; a foot outside and farther
    bounds the face's distance from below: nothing nearer there)."""
    feet, distance = _feet(surfaces, on, q[who], start)
    out = np.zeros(len(who), dtype=bool)
    unbounded = distance.copy()
    if inside is not None:
        out = ~inside(on, feet)
        distance[out] = np.inf
    order = np.lexsort((distance, who))  # each query's nearest foot point first
    lead = order[np.r_[True, who[order][1:] != who[order][:-1]]]
    lead = lead[distance[lead] < best.distance[who[lead]]]
    point = surfaces.derivatives(on[lead], feet[lead], 0)[0, 0]
    _merge(best, who[lead], ClosestPoints(point, on[lead], feet[lead], distance[lead]))
    return out & (unbounded < best.distance[who])


def _near_blocks(blocks: Blocks, q: NDArray, reach: NDArray) -> tuple[NDArray, NDArray]:
    """The (query, block) pairs whose box comes within ``reach`` (n,) of the query ``q``
    (n, 3), the nearest box of each patch: blocks grouped by size (their boxes' half
    diagonals, in powers of 2), each group's centres in a k-d tree asked for those within
    reach + the group's largest half diagonal, then each box's own distance."""
    from scipy.spatial import cKDTree

    centre = 0.5 * (blocks.lo + blocks.hi)
    radius = 0.5 * np.linalg.norm(blocks.hi - blocks.lo, axis=-1)
    group = np.floor(np.log2(np.maximum(radius, 1e-300) / max(radius.min(), 1e-300)))
    rows, found = [], []
    for g in np.unique(group):
        members = np.flatnonzero(group == g)
        tree = cKDTree(centre[members])
        within = reach + radius[members].max()
        counts = tree.query_ball_point(q, within, return_length=True)
        # arrays, not lists: the queries with up to 2^j blocks near asked for 2^j nearest
        size = np.ceil(np.log2(np.maximum(counts, 1))).astype(np.int64)
        for j in np.unique(size[counts > 0]).tolist():
            ask = np.flatnonzero((size == j) & (counts > 0))
            most = min(2**j, len(members))
            apart, index = tree.query(q[ask], k=most, distance_upper_bound=float(within[ask].max()))
            apart = np.asarray(apart).reshape(len(ask), most)
            index = np.asarray(index).reshape(len(ask), most)
            hit = apart <= within[ask, None]
            rows.append(np.repeat(ask, hit.sum(axis=1)))
            found.append(members[index[hit]])
    if not rows:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    who, block = np.concatenate(rows), np.concatenate(found)
    gap = np.maximum(np.maximum(blocks.lo[block] - q[who], q[who] - blocks.hi[block]), 0.0)
    apart = np.linalg.norm(gap, axis=-1)
    near = apart < reach[who]
    who, block, apart = who[near], block[near], apart[near]
    # one block a patch for each query: the nearest box
    order = np.lexsort((apart, blocks.patch[block], who))
    key = who[order] * (blocks.patch.max(initial=0) + 1) + blocks.patch[block[order]]
    lead = order[np.r_[True, key[1:] != key[:-1]]]
    return who[lead], block[lead]


def _merge(best: ClosestPoints, ask: NDArray, found: ClosestPoints) -> None:
    """``found`` for queries ``ask`` kept in ``best`` where nearer."""
    nearer = found.distance < best.distance[ask]
    take = ask[nearer]
    best.point[take], best.patch[take] = found.point[nearer], found.patch[nearer]
    best.uv[take], best.distance[take] = found.uv[nearer], found.distance[nearer]


def _first_round(
    surfaces: _Surfaces,
    q: NDArray,
    samples: Samples,
    best: ClosestPoints,
    nearest: NDArray,
    inside: Callable[[NDArray[np.int64], NDArray[np.float64]], NDArray[np.bool_]] | None,
) -> NDArray[np.bool_]:
    """Newton's method from each query's ``nearest`` samples but those within a cell of a
    nearer one on its patch (one start per sheet: a patch folding back, a tube, has its
    nearest samples on several), all patches at once; the nearer foot points inside the
    trims (``inside``) kept in ``best``.  Whether each query found one outside them
    (:func:`_tried`)."""
    owner, uv = samples.patch, samples.uv
    patch = owner[nearest]
    first = np.ones(patch.shape, dtype=bool)
    cell = samples.cell[patch]
    for j in range(1, patch.shape[1]):
        for i in range(j):
            near = np.all(np.abs(uv[nearest[:, i]] - uv[nearest[:, j]]) <= cell[:, j], -1)
            first[:, j] &= ~(first[:, i] & (patch[:, i] == patch[:, j]) & near)
    rows, js = np.nonzero(first)
    who, sample = rows, nearest[rows, js]
    out = _tried(surfaces, q, who, owner[sample], uv[sample], best, inside)
    outside = np.zeros(len(q), dtype=bool)
    outside[who[out]] = True
    return outside
