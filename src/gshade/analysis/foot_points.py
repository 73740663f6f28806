"""Foot points: the point of a patch nearest to a query point q, by Newton's method on the
exact surface from a start (u, v), for many queries on many patches at once.

The minimum of g = |S(u, v) - q|^2 / 2 over the patch's domain (do Carmo, §2-5; the foot
point problem), whose gradient and matrix are

    grad g = (<S_u, r>, <S_v, r>),   r = S - q,
    H = [[<S_u, S_u> + <S_uu, r>,  <S_u, S_v> + <S_uv, r>],
         [<S_u, S_v> + <S_uv, r>,  <S_v, S_v> + <S_vv, r>]],

with Gauss–Newton's matrix (the first fundamental form) where H is not positive definite.
The domain's sides are an active set: a parameter that reached a side and would leave it
is held there while the other is solved for, so that a foot point on a patch's boundary
(the closest point of a patch is often on its edge) is found as exactly as one inside.  A
foot stopped at a closed patch's seam is searched again from across it, one stopped at a
pole from a ring around it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..geometry import Patch

__all__ = ["NEWTON_STEPS", "SurfacePatches", "foot_parameters", "foot_points"]

#: Shortenings (each by 4) of a Newton step that would take a point farther from its
#: query.
SHORTENINGS = 15
#: Points at which a batch is evaluated by Dr.Jit (where it works) rather than numpy.
BIG_BATCH = 4096
#: Starts around a pole a foot stopped at is searched again from (the nearest of them).
POLE_RING = 32
#: Newton steps at most (quadratic convergence: a grid cell's start is exact in ~5; near a
#: pole, where it is linear, more).
NEWTON_STEPS = 24


class SurfacePatches:
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
    return foot_parameters(SurfacePatches([patch]), np.zeros(len(q), np.int64), q, start, steps)[0]


def foot_parameters(
    surfaces: SurfacePatches,
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
    surfaces: SurfacePatches, index: NDArray, q: NDArray, uv: NDArray, gap: NDArray, steps: int
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
    other, distance = foot_parameters(surfaces, index[again], q[again], start, steps, wrap=False)
    nearer = distance < gap[again]
    uv[again[nearer]], gap[again[nearer]] = other[nearer], distance[nearer]


def _off_poles(
    surfaces: SurfacePatches, index: NDArray, q: NDArray, uv: NDArray, gap: NDArray, steps: int
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
    found, distance = foot_parameters(surfaces, index[again], q[again], chosen, steps, wrap=False)
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
