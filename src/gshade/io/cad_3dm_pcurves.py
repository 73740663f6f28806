"""Pcurves for Rhino edges that trace the edge on the face to round-off.

rhino3dm gives no 2D trimming curves; :mod:`gshade.io.cad_3dm` recovers each trim's (u, v)
at samples of the edge.  A cubic interpolating those samples strays from the edge between
them, and the more so where the edge has a corner (a joined curve: interior knots of full
multiplicity) or the face a knot line; two faces' pcurves then part by far more than the
faces do (1e-4 of the model on Rhino's logo).  Here each pcurve is built to trace the face's
point nearest the kernel's edge curve C(t) at every t, within ``ACCURACY`` of the model's
size:

- the parameter range is cut at the edge curve's distinct knots (its corners and its
  pieces' joins), and each piece into halves where needed;
- on each piece the pcurve is the polynomial of degree ``DEGREE`` through the face's
  parameters of the points nearest C(t) (Newton point inversion, started from the trim's
  samples, on the trim's side of a seam) at the piece's Chebyshev-Lobatto nodes;
- a piece is kept when, at the midpoints between its nodes, S(c(t)) lies within the
  accuracy of the face's point nearest C(t) (the fit's own error, measured); else it is
  halved, up to ``MAX_PIECES`` pieces a pcurve (then the best one found is kept);
- the pieces join into one B-spline (interior knots of multiplicity ``DEGREE``: continuous,
  with the pieces' tangents agreeing within the accuracy).

Where the faces meet C(t) exactly, S(c(t)) = C(t) to round-off; where a face lies off the
edge (a file whose faces meet only within its tolerance), c(t) is the face's nearest point,
so that the distance between two faces' S(c(t)) is their true gap, not a fitting artefact.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
from numpy.typing import NDArray
from OCP.collections import Array1_double, Array1_gp_Pnt2d, Array1_int
from OCP.Geom2d import Geom2d_BSplineCurve
from OCP.gp import gp_Pnt2d
from scipy.interpolate import BSpline

from ..geometry.bspline import BSplinePatch

__all__ = ["ACCURACY", "DEGREE", "EdgeCurve", "Feet", "fit", "one_side"]

#: The pcurve's image within this fraction of the model's size of the face's point nearest
#: the edge.
ACCURACY = 1e-12
#: The pieces' polynomial degree.
DEGREE = 7
#: At most so many pieces a pcurve, and halvings of a piece.
MAX_PIECES, _MAX_DEPTH = 256, 40
_NEWTON_STEPS, _POLISH = 30, 2
#: Two parameters name one point (a seam) when their points are this close, relative to
#: the model's size.
_SAME_POINT = 1e-6

_NODES = 0.5 - 0.5 * np.cos(np.pi * np.arange(DEGREE + 1) / DEGREE)  # Chebyshev-Lobatto
_CHECKS = 0.5 * (_NODES[:-1] + _NODES[1:])


def _bernstein(x: NDArray[np.float64], p: int) -> NDArray[np.float64]:
    from math import comb

    i = np.arange(p + 1)
    return np.array([comb(p, k) for k in i]) * x[:, None] ** i * (1.0 - x[:, None]) ** (p - i)


#: Bernstein coefficients from the values at the nodes.
_TO_POLES = np.linalg.inv(_bernstein(_NODES, DEGREE))
#: Values at the check points from the Bernstein coefficients.
_AT_CHECKS = _bernstein(_CHECKS, DEGREE)


class EdgeCurve:
    """A kernel edge's ``Geom_BSplineCurve``, evaluated many points at once (its knots and
    homogeneous poles in a :class:`scipy.interpolate.BSpline`)."""

    def __init__(self, curve: Any):
        n, p = int(curve.NbPoles()), int(curve.Degree())
        flat = curve.KnotSequence()
        knots = np.array([flat.Value(i) for i in range(flat.Lower(), flat.Upper() + 1)])
        poles = np.array([[q.X(), q.Y(), q.Z()] for q in (curve.Pole(i) for i in range(1, n + 1))])
        w = np.array([curve.Weight(i) for i in range(1, n + 1)])
        self._h = BSpline(knots, np.hstack([poles * w[:, None], w[:, None]]), p, extrapolate=True)
        self.breaks = np.array([curve.Knot(i) for i in range(1, int(curve.NbKnots()) + 1)])

    def __call__(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        h = self._h(t)
        return h[:, :3] / h[:, 3:]


def _nearest(
    patch: BSplinePatch, xyz: NDArray[np.float64], uv: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Gauss-Newton from ``uv`` to the face's points nearest ``xyz``, inside the domain (no
    wrapping across a seam: the starting points are on the trim's side), steps halved where
    they do not bring a point closer."""
    (u0, u1), (v0, v1) = patch.domain
    lo, hi = np.array([u0, v0]), np.array([u1, v1])
    small = 1e-15 * np.maximum(hi - lo, 1e-300)
    uv = np.clip(uv, lo, hi)
    act = np.arange(len(uv))
    for _ in range(_NEWTON_STEPS):
        d = patch.derivatives(uv[act, 0], uv[act, 1], 1)
        r = d[0, 0] - xyz[act]
        J = np.stack([d[1, 0], d[0, 1]], -1)
        A = np.einsum("mki,mkj->mij", J, J)
        g = np.einsum("mki,mk->mi", J, r)
        A += (1e-14 * np.trace(A, axis1=1, axis2=2) + 1e-300)[:, None, None] * np.eye(2)
        step = np.linalg.solve(A, -g[..., None])[..., 0]
        f = (r**2).sum(-1)
        alpha = np.ones(len(act))
        new = np.clip(uv[act] + step, lo, hi)
        fn = ((patch(new[:, 0], new[:, 1]) - xyz[act]) ** 2).sum(-1)
        for _ in range(8):  # halve the steps that do not bring the point closer
            worse = fn > f
            if not worse.any():
                break
            alpha[worse] *= 0.5
            new[worse] = np.clip(uv[act[worse]] + alpha[worse, None] * step[worse], lo, hi)
            fn[worse] = ((patch(new[worse, 0], new[worse, 1]) - xyz[act[worse]]) ** 2).sum(-1)
        better = fn <= f
        moved = np.any(np.abs(new - uv[act]) > small, axis=1)
        uv[act[better]] = new[better]
        act = act[better & moved]
        if not act.size:
            break
    # a few plain Gauss-Newton steps to finish: near the answer the distance changes by
    # less than its rounding (a face off the edge), so that no longer tells a better step
    for _ in range(_POLISH):
        d = patch.derivatives(uv[:, 0], uv[:, 1], 1)
        J = np.stack([d[1, 0], d[0, 1]], -1)
        A = np.einsum("mki,mkj->mij", J, J)
        A += (1e-14 * np.trace(A, axis1=1, axis2=2) + 1e-300)[:, None, None] * np.eye(2)
        g = np.einsum("mki,mk->mi", J, d[0, 0] - xyz)
        uv = np.clip(uv - np.linalg.solve(A, g[..., None])[..., 0], lo, hi)
    return uv


def one_side(patch: BSplinePatch, uv: NDArray[np.float64], size: float) -> NDArray[np.float64]:
    """The samples on one side of any seam: where consecutive samples are half the domain or
    more apart in a direction in which the surface meets itself (the same point at both
    ends), the shorter runs moved by the domain's width to the longest one's side."""
    out = uv.copy()
    for d in (0, 1):
        lo, hi = patch.domain[d]
        span = hi - lo
        jumps = np.flatnonzero(np.abs(np.diff(out[:, d])) > 0.5 * span)
        if not jumps.size:
            continue
        runs = np.split(np.arange(len(out)), jumps + 1)
        main = max(runs, key=len)
        side = np.mean(out[main, d]) > lo + 0.5 * span  # the longest run on the high end
        for run in runs:
            low = out[run, d] < lo + 0.5 * span
            move = low if side else ~low
            if not move.any():
                continue
            there = out[run[move]].copy()
            there[:, d] = np.clip(there[:, d] + (span if side else -span), lo, hi)
            same = np.linalg.norm(
                patch(there[:, 0], there[:, 1]) - patch(out[run[move], 0], out[run[move], 1]),
                axis=1,
            )
            keep = same <= _SAME_POINT * size  # the surface meets itself there
            out[run[move][keep], d] = there[keep, d]
    return out


class Feet:
    """Where a face traces an edge: its points nearest C(t) (an edge of one face, a seam)."""

    def __init__(self, patch: BSplinePatch, curve: EdgeCurve):
        self.patch, self.curve = patch, curve

    def __call__(
        self, ts: NDArray[np.float64], start: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The face's (u, v) at the edge parameters ``ts`` (from ``start``), and C(ts)."""
        xyz = self.curve(ts)
        return _nearest(self.patch, xyz, start), xyz


def _crossings(
    patch: BSplinePatch, target: Any, t: NDArray[np.float64], uv: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The edge parameters where the trim crosses the face's interior knot lines (there the
    face's parameters along the edge are less smooth): bracketed by samples, then found by
    false position on the target's parameters."""
    lo, hi, knots = [], [], []
    for d in (0, 1):
        a, b = patch.domain[d]
        inner = np.unique(np.asarray(patch.knots[d], dtype=float))
        inner = inner[(inner > a + 1e-12 * (b - a)) & (inner < b - 1e-12 * (b - a))]
        for k in inner:
            side = np.sign(uv[:, d] - k)
            for i in np.flatnonzero(side[:-1] * side[1:] < 0):
                lo.append(t[i])
                hi.append(t[i + 1])
                knots.append((d, k, side[i]))
    if not lo:
        return np.empty(0)
    tl, th = np.array(lo), np.array(hi)
    along = np.array([x[0] for x in knots], dtype=np.intp)
    level = np.array([x[1] for x in knots])
    rows = np.arange(len(tl))
    il = np.searchsorted(t, tl)
    gl = uv[il, along] - level
    gh = uv[il + 1, along] - level
    guess = uv[il] + (uv[il + 1] - uv[il]) * (gl / (gl - gh))[:, None]
    tm = 0.5 * (tl + th)
    for _ in range(_FALSE_POSITION):  # false position, the end kept twice weighed down
        tm = tl - gl * (th - tl) / (gh - gl)
        tm = np.where(np.isfinite(tm), np.clip(tm, tl, th), 0.5 * (tl + th))
        guess, _ = target(tm, guess)
        gm = guess[rows, along] - level
        right = np.sign(gm) == np.sign(gl)  # the crossing in [tm, th]
        tl, th = np.where(right, tm, tl), np.where(right, th, tm)
        gl, gh = np.where(right, gm, 0.5 * gl), np.where(right, 0.5 * gh, gm)
    return tm


#: False-position steps locating a knot line's crossing.
_FALSE_POSITION = 12


def fit(
    patch: BSplinePatch,
    curve: EdgeCurve,
    t: NDArray[np.float64],
    uv: NDArray[np.float64],
    size: float,
    target: Any = None,
) -> tuple[Any, float, float]:
    """The pcurve on ``patch`` of the edge ``curve`` over [t[0], t[-1]].

    Parameters
    ----------
    patch : BSplinePatch
        The face's surface (the kernel's, exactly).
    curve : EdgeCurve
        The kernel edge's 3D curve C(t).
    t, uv : ndarray (n,), (n, 2)
        The trim's samples: edge parameters (increasing) and the face's parameters there,
        on the trim's side of any seam (the Newton starts, interpolated).
    size : float
        The model's size (the accuracy is ``ACCURACY`` of it).
    target : Feet, optional
        The face's parameters to trace at given t (default :class:`Feet`).

    Returns
    -------
    pcurve, error, deviation
        A ``Geom2d_BSplineCurve`` of degree ``DEGREE`` with the edge's parameters; its
        measured error (the largest distance, at the check points, between S(c(t)) and the
        traced point, plus what smoothing the joins may move it); and the largest distance
        |S(c(t)) - C(t)| at the nodes and check points (the face's own distance from the
        edge, plus the error).
    """
    t0, t1 = float(t[0]), float(t[-1])
    target_of = Feet(patch, curve) if target is None else target
    accuracy = ACCURACY * size
    uv = one_side(patch, uv, size)
    inner = curve.breaks[(curve.breaks > t0) & (curve.breaks < t1)]
    cuts = np.unique(np.concatenate([[t0], inner, _crossings(patch, target_of, t, uv), [t1]]))
    cuts = cuts[(cuts >= t0) & (cuts <= t1)]
    cuts = cuts[np.r_[True, np.diff(cuts) > 1e-12 * (t1 - t0)]]
    cuts[-1] = t1
    todo = [(float(a), float(b), 0) for a, b in itertools.pairwise(cuts)]
    done: list[tuple[float, NDArray[np.float64], float]] = []  # (start, poles, error)
    p = DEGREE
    (u0, u1), (v0, v1) = patch.domain
    apart = 0.0  # the largest |S(c(t)) - C(t)| seen
    while todo:
        a = np.array([x[0] for x in todo])
        b = np.array([x[1] for x in todo])
        k = len(todo)
        ts = np.concatenate(
            [
                (a[:, None] + (b - a)[:, None] * _NODES).ravel(),
                (a[:, None] + (b - a)[:, None] * _CHECKS).ravel(),
            ]
        )
        start = np.stack([np.interp(ts, t, uv[:, 0]), np.interp(ts, t, uv[:, 1])], -1)
        foot, xyz = target_of(ts, start)
        fn = foot[: k * (p + 1)].reshape(k, p + 1, 2)
        fc = foot[k * (p + 1) :]
        poles = np.einsum("ij,kjd->kid", _TO_POLES, fn)
        poles[:, 0], poles[:, -1] = fn[:, 0], fn[:, -1]
        at = np.einsum("ij,kjd->kid", _AT_CHECKS, poles).reshape(k * p, 2)
        at = np.clip(at, [u0, v0], [u1, v1])
        image = patch(at[:, 0], at[:, 1])
        err = np.linalg.norm(image - patch(fc[:, 0], fc[:, 1]), axis=1).reshape(k, p).max(axis=1)
        off = np.linalg.norm(patch(foot[:, 0], foot[:, 1]) - xyz, axis=1)
        apart = max(apart, float(off.max()) + float(err.max()))
        bad = {i for i in range(k) if err[i] > accuracy and todo[i][2] < _MAX_DEPTH}
        if len(done) + k + len(bad) > MAX_PIECES:
            bad = set()
        again = []
        for i in range(k):
            if i in bad:
                m = 0.5 * (a[i] + b[i])
                again += [(float(a[i]), m, todo[i][2] + 1), (m, float(b[i]), todo[i][2] + 1)]
            else:
                done.append((float(a[i]), poles[i], float(err[i])))
        todo = again
    done.sort(key=lambda x: x[0])
    n = len(done)
    pts = np.concatenate([done[0][1]] + [d[1][1:] for d in done[1:]])
    P = Array1_gp_Pnt2d(1, len(pts))
    for i, (x, y) in enumerate(pts):
        P.SetValue(i + 1, gp_Pnt2d(float(x), float(y)))
    K = Array1_double(1, n + 1)
    M = Array1_int(1, n + 1)
    for i, s in enumerate([d[0] for d in done] + [t1]):
        K.SetValue(i + 1, float(s))
        M.SetValue(i + 1, p + 1 if i in (0, n) else p)
    pcurve = Geom2d_BSplineCurve(P, K, M, p, False)
    # the joins as smooth as the curve is there: each interior knot's multiplicity lowered
    # as far as that moves the pcurve (in 3D) by less than the accuracy; a corner stays one
    d = patch.derivatives(np.clip(pts[:, 0], u0, u1), np.clip(pts[:, 1], v0, v1), 1)
    speed = max(
        float(np.linalg.norm(d[1, 0], axis=1).max()), float(np.linalg.norm(d[0, 1], axis=1).max())
    )
    moved = accuracy / max(speed, 1e-300)
    smoothed = False
    for i in range(2, n + 1):
        for m in range(1, p):
            if pcurve.RemoveKnot(i, m, moved):
                smoothed = True
                break
    extra = accuracy if smoothed else 0.0
    return pcurve, max(x[2] for x in done) + extra, apart + extra
