"""The points of a face nearest points in space, for the pcurves of Rhino edges
(:mod:`gshade.cad.rhino_pcurves`): a damped Gauss-Newton over many surfaces at once
(:func:`nearest_points`, each step one evaluation of all of them by
:class:`gshade.geometry.evaluation.bezier_cells.Splines`), its least-squares step
(:func:`least_squares_step`), and samples put on one side of a seam (:func:`one_side`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..geometry.evaluation.bezier_cells import Splines
from ..geometry.patches.bspline import BSplinePatch

__all__ = ["least_squares_step", "nearest_points", "one_side"]

#: The relative round-off of a point's coordinates.
_ROUND_OFF = 1e-15
#: Two parameters name one point (a seam) when their points are this close, relative to
#: the model's size.
_SAME_POINT = 1e-6


def least_squares_step(
    su: NDArray[np.float64], sv: NDArray[np.float64], w: NDArray[np.float64]
) -> NDArray[np.float64]:
    """(J^T J)^-1 J^T w per row, J = [su sv] (n, 3, 2), lightly regularised (poles)."""
    a11, a12, a22 = (su * su).sum(1), (su * sv).sum(1), (sv * sv).sum(1)
    g1, g2 = (su * w).sum(1), (sv * w).sum(1)
    reg = 1e-14 * (a11 + a22) + 1e-300
    a11, a22 = a11 + reg, a22 + reg
    det = a11 * a22 - a12 * a12
    det[~(det > 0.0)] = np.inf  # no direction free: no step
    return np.stack([(a22 * g1 - a12 * g2) / det, (a11 * g2 - a12 * g1) / det], -1)


def nearest_points(
    splines: Splines,
    surface: NDArray[np.intp],
    xyz: NDArray[np.float64],
    uv: NDArray[np.float64],
    box: tuple[NDArray[np.float64], NDArray[np.float64]],
    steps: int,
    small: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Damped Gauss-Newton from ``uv`` to the points of the surfaces ``surface`` nearest
    ``xyz`` (the end pieces continued past the domain, within ``box``: per point, lowest
    and highest (u, v); a coordinate whose two are equal is pinned there): one evaluation a
    step, a step kept where it does not take the
    point farther (beyond the distance's round-off), else a quarter of it tried.  A point
    is done when its step moves it (in 3D) by less than ``small`` or its round-off, or when
    the next step will, by the last two steps' ratio (the convergence rate: linear where
    the face lies off the point, quadratic on it).

    Returns the parameters and, there, S - xyz, S_u and S_v.
    """
    lo, hi = box
    free = (hi > lo).astype(np.float64)  # a coordinate pinned to a side: lo = hi
    uv = np.clip(uv, lo, hi)
    s0, su, sv = splines.evaluate(surface, uv[:, 0], uv[:, 1])
    r = s0 - xyz
    f = (r * r).sum(1)
    floor = np.maximum(small, _ROUND_OFF * np.abs(xyz).max(1))  # the points' round-off
    m = len(uv)
    alpha, step, last = np.ones(m), np.zeros((m, 2)), np.zeros(m)
    fresh = np.ones(m, dtype=bool)
    act = np.arange(m)
    for _ in range(steps):
        if not act.size:
            break
        new = act[fresh[act]]
        if new.size:
            step[new] = -least_squares_step(
                su[new] * free[new, :1], sv[new] * free[new, 1:], r[new]
            )
        s = alpha[act, None] * step[act]
        trial = np.clip(uv[act] + s, lo[act], hi[act])
        st, sut, svt = splines.evaluate(surface[act], trial[:, 0], trial[:, 1])
        rt = st - xyz[act]
        ft = (rt * rt).sum(1)
        moved = np.linalg.norm(su[act] * s[:, :1] + sv[act] * s[:, 1:], axis=1)
        ok = ft <= f[act] + floor[act] * (2.0 * np.sqrt(f[act]) + floor[act])
        a = act[ok]
        uv[a], r[a], f[a], su[a], sv[a] = trial[ok], rt[ok], ft[ok], sut[ok], svt[ok]
        rate = np.divide(moved, last[act], out=np.full(act.size, np.inf), where=last[act] > 0)
        rate[moved == 0.0] = 0.0
        done = (moved <= floor[act]) | (ok & (rate < 0.5) & (moved * rate <= floor[act]))
        done |= alpha[act] < 1e-6
        last[a] = moved[ok]
        alpha[a] = np.minimum(1.0, 2.0 * alpha[a])
        alpha[act[~ok]] *= 0.25
        fresh[act] = ok
        act = act[~done]
    return uv, r, su, sv


def one_side(patch: BSplinePatch, uv: NDArray[np.float64], size: float) -> NDArray[np.float64]:
    """The samples on one side of any seam: where consecutive samples are half the domain or
    more apart in a direction in which the surface meets itself (the same point at both
    ends), the samples off the longest run's half moved by the domain's width to its
    side."""
    out = uv.copy()
    for d in (0, 1):
        lo, hi = patch.domain[d]
        span, middle = hi - lo, 0.5 * (lo + hi)
        jump = np.abs(np.diff(out[:, d])) > 0.5 * span
        if not jump.any():
            continue
        run = np.r_[0, np.cumsum(jump)]
        main = run == np.argmax(np.bincount(run))
        high = np.mean(out[main, d]) > middle  # the longest run on the high end
        move = np.flatnonzero(~main & ((out[:, d] < middle) if high else (out[:, d] >= middle)))
        if not move.size:
            continue
        there = out[move].copy()
        there[:, d] = np.clip(there[:, d] + (span if high else -span), lo, hi)
        both = patch(np.r_[there[:, 0], out[move, 0]], np.r_[there[:, 1], out[move, 1]])
        same = np.linalg.norm(both[: move.size] - both[move.size :], axis=1) <= _SAME_POINT * size
        out[move[same], d] = there[same, d]  # where the surface meets itself
    return out
