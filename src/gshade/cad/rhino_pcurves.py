"""Pcurves for Rhino edges that trace the edge on the face to round-off.

rhino3dm gives no 2D trimming curves; :mod:`gshade.cad.rhino` recovers each trim's (u, v)
at samples of the edge.  A cubic interpolating those samples strays from the edge between
them, and the more so where the edge has a corner (a joined curve: interior knots of full
multiplicity) or the face a knot line; two faces' pcurves then part by far more than the
faces do (1e-4 of the model on Rhino's logo).  Here each pcurve traces the face's point
nearest the kernel's edge curve C(t) at every t, within ``ACCURACY`` of the model's size,
the trims of all the model's faces at once (a few numpy calls a Newton step, whatever the
number of faces: :class:`Splines` evaluates many patches and curves together):

- nearest points by Gauss-Newton point inversion on the surface with its end pieces
  continued past the domain (so that an edge a tolerance outside the face has a smooth
  nearest point), first at the samples; where those lie beyond a side of the domain, the
  side's nearest point is the face's: the parameter across the side pinned to it;
- the parameter range is cut at the edge curve's distinct knots (its corners and its
  pieces' joins), where the nearest point crosses the face's interior knot lines and
  where it crosses a side (both by Newton on t), so that on each piece the nearest point
  moves analytically with t (the samples' nearest points and these cuts:
  :mod:`gshade.cad.rhino_cuts`);
- on each piece the pcurve is the polynomial of degree ``DEGREE`` through the nearest
  points at the piece's Chebyshev-Lobatto nodes; its error is measured at the midpoints
  between the nodes: the 3D length of the Gauss-Newton step from the pcurve's point
  towards the nearest point;
- a piece is kept when that error is within the accuracy, or when halving no longer
  lowers it (round-off, or a face that strays from the edge in a way no polynomial
  follows); else it is halved, the halves' Newton started from its own polynomial (one or
  two steps), up to ``MAX_PIECES`` pieces a pcurve;
- the pieces join into one B-spline (interior knots of multiplicity ``DEGREE``, lowered by
  one where that moves the pcurve by less than the accuracy: no kink there), its poles
  clamped into the domain.

Where the faces meet C(t) exactly, S(c(t)) = C(t) to round-off; where a face lies off the
edge (a file whose faces meet only within its tolerance), c(t) is the face's nearest point,
so that the distance between two faces' S(c(t)) is their true gap, not a fitting artefact.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from OCP.collections import Array1_double, Array1_gp_Pnt2d, Array1_int
from OCP.Geom2d import Geom2d_BSplineCurve
from OCP.gp import gp_Pnt2d

from ..geometry.core.bernstein import bernstein_basis
from ..geometry.evaluation.bezier_cells import Splines
from ..geometry.patches.bspline import BSplinePatch
from .rhino_cuts import Trims, range_cuts, sample_feet
from .rhino_feet import least_squares_step, nearest_points, one_side

__all__ = ["ACCURACY", "DEGREE", "MAX_PIECES", "Pcurve", "fit_faces"]

#: The pcurve's image within this fraction of the model's size of the face's point nearest
#: the edge.
ACCURACY = 1e-12
#: The pieces' polynomial degree.
DEGREE = 7
#: At most so many pieces a pcurve, and halvings of a piece.
MAX_PIECES, _MAX_DEPTH = 256, 40
#: A halved piece whose error is above this fraction of its parent's is not halved again.
_STALL = 0.8
#: Gauss-Newton steps at most: at the first pieces' nodes (from the samples) and from a
#: parent piece's polynomial (the samples' and the crossings': :mod:`gshade.cad.rhino_cuts`).
_STEPS_FIRST, _STEPS_WARM = 12, 6
#: The inversion stays within the domain widened by this fraction of its span.
_REACH = 0.25

_NODES = 0.5 - 0.5 * np.cos(np.pi * np.arange(DEGREE + 1) / DEGREE)  # Chebyshev-Lobatto
_CHECKS = 0.5 * (_NODES[:-1] + _NODES[1:])

#: Bernstein coefficients from the values at the nodes.
_TO_POLES = np.linalg.inv(bernstein_basis(DEGREE, _NODES)[0])
#: Values at the check points from the Bernstein coefficients.
_AT_CHECKS = bernstein_basis(DEGREE, _CHECKS)[0]
#: Values at the nodes of the two halves, from the Bernstein coefficients.
_AT_HALVES = (
    bernstein_basis(DEGREE, 0.5 * _NODES)[0],
    bernstein_basis(DEGREE, 0.5 + 0.5 * _NODES)[0],
)


@dataclass
class Pcurve:
    """A fitted pcurve: the ``Geom2d_BSplineCurve`` (the edge's parameters), its measured
    error (the largest 3D distance, at the check points, between S(c(t)) and the face's
    point nearest C(t)), the largest |S(c(t)) - C(t)| there (the face's own distance from
    the edge, plus the error) and its number of pieces."""

    curve: Any
    error: float
    apart: float
    pieces: int


def fit_faces(
    faces: list[tuple[BSplinePatch, list[tuple[Any, NDArray[np.float64], NDArray[np.float64]]]]],
    size: float,
) -> list[list[Pcurve]]:
    """The pcurves of the trims of many faces, all at once.

    Parameters
    ----------
    faces : list of (BSplinePatch, list of (curve, t, uv))
        Per face: its surface (the kernel's, exactly) and its trims: the kernel edge's
        ``Geom_BSplineCurve`` C(t) (one object per edge: shared by the faces that use it);
        the trim's samples, edge parameters (increasing, the pcurve's range [t[0], t[-1]])
        and the face's parameters there (the Newton starts, interpolated).
    size : float
        The model's size (the accuracy is ``ACCURACY`` of it).

    Returns
    -------
    list of list of Pcurve
        Per face, in the order of its trims: each a ``Geom2d_BSplineCurve`` of degree
        ``DEGREE`` with the edge's parameters, inside the domain, its measured error and
        distance.
    """
    splines = Splines()
    curve_number: dict[int, int] = {}
    face_of, curve_of, samples = [], [], []
    patch_number = [splines.add_patch(patch) for patch, _ in faces]
    for f, (patch, face_trims) in enumerate(faces):
        for curve, t, uv in face_trims:
            if id(curve) not in curve_number:
                curve_number[id(curve)] = splines.add_curve(curve)
            face_of.append(f)
            curve_of.append(curve_number[id(curve)])
            samples.append((np.asarray(t, dtype=float), one_side(patch, uv, size)))
    splines.freeze()
    lo = np.array([[p.domain[0][0], p.domain[1][0]] for p, _ in faces])
    hi = np.array([[p.domain[0][1], p.domain[1][1]] for p, _ in faces])
    accuracy = ACCURACY * size
    face = np.array(face_of, dtype=np.intp)
    reach = _REACH * (hi[face] - lo[face])
    trims = Trims(
        splines, face, np.array(curve_of, dtype=np.intp), samples,
        np.array(patch_number, dtype=np.intp), lo, hi, lo[face] - reach, hi[face] + reach,
    )  # fmt: skip
    small = 1e-3 * accuracy
    feet = sample_feet(trims, small)
    cuts, sides = range_cuts(trims, [p for p, _ in faces], feet, accuracy, small)
    owner, a, b, start, lo_box, hi_box = _pieces(trims, cuts, sides, feet)
    kept = _refine(trims, owner, a, b, start, lo_box, hi_box, accuracy, small)
    out = _assemble(trims, kept, accuracy)
    bounds = np.searchsorted(trims.face, np.arange(len(faces) + 1))
    return [out[bounds[f] : bounds[f + 1]] for f in range(len(faces))]


def _pieces(
    trims: Trims,
    cuts: list[NDArray[np.float64]],
    sides: list[list[tuple]],
    feet: tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
) -> tuple[
    NDArray[np.intp],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
]:
    """The first pieces between each trim's cuts: (trim, start, end, the Newton starts at
    their nodes (the samples' nearest points interpolated), the box each stays in: the
    trim's, pinned to the sides it runs beyond at the piece's middle)."""
    owner, t, uv, _ = feet
    bounds = np.searchsorted(owner, np.arange(len(trims.samples) + 1))
    out: list[list[NDArray]] = [[], [], [], [], [], []]
    for j, (ts, _) in enumerate(trims.samples):
        t0, t1 = float(ts[0]), float(ts[-1])
        breaks = trims.splines.breaks(int(trims.curve[j]))
        inner = breaks[(breaks > t0) & (breaks < t1)]
        at = np.unique(np.concatenate([[t0], inner, cuts[j], [t1]]))
        at = at[(at >= t0) & (at <= t1)]
        at = at[np.r_[True, np.diff(at) > 1e-11 * (t1 - t0)]]
        at[-1] = t1
        a, b = at[:-1], at[1:]
        nodes = (a[:, None] + (b - a)[:, None] * _NODES).ravel()
        rows = slice(bounds[j], bounds[j + 1])
        start = _hermite(nodes, t[rows], uv[rows])
        lo, hi = trims.box(np.full(len(a), j))
        lo, hi = lo.copy(), hi.copy()
        for d, side, where in sides[j]:
            pin = (
                np.ones(len(a), dtype=bool)
                if where is None
                else np.interp(0.5 * (a + b), *where) > 0
            )
            lo[pin, d] = hi[pin, d] = side
        start = np.clip(start.reshape(-1, DEGREE + 1, 2), lo[:, None], hi[:, None])
        for x, part in zip(out, (np.full(len(a), j), a, b, start, lo, hi), strict=True):
            x.append(part)
    owner, a, b, start, lo, hi = (np.concatenate(x) for x in out)
    return owner, a, b, start, lo, hi


def _hermite(
    x: NDArray[np.float64], t: NDArray[np.float64], y: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The cubic Hermite interpolant of the points ``y`` (n, 2) at the increasing ``t``
    (slopes by central differences: Catmull-Rom) at ``x``; linear with two points."""
    if len(t) < 3:
        return np.stack([np.interp(x, t, y[:, d]) for d in (0, 1)], -1)
    i = np.clip(np.searchsorted(t, x, side="right") - 1, 0, len(t) - 2)
    slope = np.empty_like(y)
    slope[1:-1] = (y[2:] - y[:-2]) / (t[2:] - t[:-2])[:, None]
    slope[0] = (y[1] - y[0]) / (t[1] - t[0])
    slope[-1] = (y[-1] - y[-2]) / (t[-1] - t[-2])
    h = (t[i + 1] - t[i])[:, None]
    s = (x - t[i])[:, None] / h
    s2, s3 = s * s, s * s * s
    return (
        (2 * s3 - 3 * s2 + 1) * y[i]
        + (s3 - 2 * s2 + s) * h * slope[i]
        + (-2 * s3 + 3 * s2) * y[i + 1]
        + (s3 - s2) * h * slope[i + 1]
    )


def _refine(
    trims: Trims,
    owner: NDArray[np.intp],
    a: NDArray[np.float64],
    b: NDArray[np.float64],
    start: NDArray[np.float64],
    lo: NDArray[np.float64],
    hi: NDArray[np.float64],
    accuracy: float,
    small: float,
) -> list[NDArray]:
    """Fit every piece (its nearest points within its box ``lo``, ``hi``), halve those not
    within the accuracy (their halves started from their polynomials), until all are kept;
    the kept pieces as arrays (trim, start, end, poles, error, distance, the surface's
    largest speed at its nodes)."""
    depth = np.zeros(len(a), dtype=np.intp)
    parent_error = np.full(len(a), np.inf)
    count = np.bincount(owner, minlength=len(trims.samples))
    kept: list[tuple[NDArray, ...]] = []
    steps = _STEPS_FIRST
    p = DEGREE
    while a.size:
        k = len(a)
        ts = (a[:, None] + (b - a)[:, None] * _NODES).ravel()
        tc = (a[:, None] + (b - a)[:, None] * _CHECKS).ravel()
        xyz, _ = trims.edge(
            np.concatenate([np.repeat(owner, p + 1), np.repeat(owner, p)]), np.concatenate([ts, tc])
        )
        face_n = trims.face[np.repeat(owner, p + 1)]
        face_c = trims.face[np.repeat(owner, p)]
        foot, rn, su, sv = nearest_points(
            trims.splines,
            trims.patch[face_n],
            xyz[: len(ts)],
            start.reshape(-1, 2),
            (np.repeat(lo, p + 1, axis=0), np.repeat(hi, p + 1, axis=0)),
            steps,
            small,
        )
        steps = _STEPS_WARM
        fn = foot.reshape(k, p + 1, 2)
        poles = np.einsum("ij,kjd->kid", _TO_POLES, fn)
        poles[:, 0], poles[:, -1] = fn[:, 0], fn[:, -1]
        at = np.einsum("ij,kjd->kid", _AT_CHECKS, poles).reshape(-1, 2)
        box_lo, box_hi = np.repeat(lo, p, axis=0), np.repeat(hi, p, axis=0)
        at = np.clip(at, box_lo, box_hi)
        s, s_u, s_v = trims.splines.evaluate(trims.patch[face_c], at[:, 0], at[:, 1])
        rc = s - xyz[len(ts) :]
        free = (box_hi > box_lo).astype(np.float64)  # along a side: its parameter along it only
        step = least_squares_step(s_u * free[:, :1], s_v * free[:, 1:], rc)
        miss = np.linalg.norm(s_u * step[:, :1] + s_v * step[:, 1:], axis=1)
        error = miss.reshape(k, p).max(1)
        apart = np.maximum(
            np.linalg.norm(rc, axis=1).reshape(k, p).max(1),
            np.linalg.norm(rn, axis=1).reshape(k, p + 1).max(1),
        )
        speed = np.maximum(np.linalg.norm(su, axis=1), np.linalg.norm(sv, axis=1))
        speed = speed.reshape(k, p + 1).max(1)
        split = (error > accuracy) & (depth < _MAX_DEPTH) & (error < _STALL * parent_error)
        for i in np.flatnonzero(split):  # within each trim's budget of pieces
            if count[owner[i]] < MAX_PIECES:
                count[owner[i]] += 1
            else:
                split[i] = False
        keep = ~split
        kept.append(
            (owner[keep], a[keep], b[keep], poles[keep], error[keep], apart[keep], speed[keep])
        )
        mid = 0.5 * (a[split] + b[split])
        a, b = np.concatenate([a[split], mid]), np.concatenate([mid, b[split]])
        start = np.concatenate([np.einsum("ij,kjd->kid", h, poles[split]) for h in _AT_HALVES])
        owner = np.concatenate([owner[split]] * 2)
        lo, hi = np.concatenate([lo[split]] * 2), np.concatenate([hi[split]] * 2)
        depth = np.concatenate([depth[split] + 1] * 2)
        parent_error = np.concatenate([error[split]] * 2)
    return [np.concatenate(x) for x in zip(*kept, strict=True)]


def _assemble(trims: Trims, kept: list[NDArray], accuracy: float) -> list[Pcurve]:
    """Each trim's pieces joined into one B-spline, poles clamped into the domain; the
    distance |S(c(t)) - C(t)| measured again where clamping moved a pole by more than
    round-off."""
    owner, a, b, poles, error, apart, speed = kept
    face = trims.face[owner]
    clamped = np.clip(poles, trims.lo[face][:, None], trims.hi[face][:, None])
    span = (trims.hi - trims.lo)[face][:, None]
    moved = np.flatnonzero(np.any(np.abs(clamped - poles) > 1e-12 * span, axis=(1, 2)))
    if moved.size:
        at = np.einsum("ij,kjd->kid", _AT_CHECKS, clamped[moved]).reshape(-1, 2)
        tc = (a[moved, None] + (b - a)[moved, None] * _CHECKS).ravel()
        xyz, _ = trims.edge(np.repeat(owner[moved], DEGREE), tc)
        surface = trims.patch[np.repeat(face[moved], DEGREE)]
        s, _, _ = trims.splines.evaluate(surface, at[:, 0], at[:, 1])
        off = np.linalg.norm(s - xyz, axis=1).reshape(-1, DEGREE).max(1)
        apart[moved] = np.maximum(apart[moved], off)
    order = np.lexsort((a, owner))
    owner, a, b, clamped = owner[order], a[order], b[order], clamped[order]
    error, apart, speed = error[order], apart[order], speed[order]
    bounds = np.searchsorted(owner, np.arange(len(trims.samples) + 1))
    out = []
    for j in range(len(trims.samples)):
        rows = slice(bounds[j], bounds[j + 1])
        tolerance = accuracy / max(float(speed[rows].max()), 1e-300)
        curve, smoothed = _bspline(a[rows], float(b[rows][-1]), clamped[rows], tolerance)
        extra = accuracy if smoothed else 0.0
        out.append(
            Pcurve(
                curve,
                float(error[rows].max()) + extra,
                float(apart[rows].max()) + extra,
                int(bounds[j + 1] - bounds[j]),
            )
        )
    return out


def _bspline(
    a: NDArray[np.float64], end: float, poles: NDArray[np.float64], tolerance: float
) -> tuple[Any, bool]:
    """The pieces starting at ``a`` (in order, the last ending at ``end``) as one
    ``Geom2d_BSplineCurve``, its interior knots of multiplicity ``DEGREE`` lowered by one
    (tangent continuous joins) where that moves the pcurve by less than ``tolerance`` (in
    (u, v)); and whether any was."""
    p, n = DEGREE, len(a)
    pts = np.concatenate([poles[0], poles[1:, 1:].reshape(-1, 2)])
    P = Array1_gp_Pnt2d(1, len(pts))
    for i, (x, y) in enumerate(pts.tolist()):
        P.SetValue(i + 1, gp_Pnt2d(x, y))
    K = Array1_double(1, n + 1)
    M = Array1_int(1, n + 1)
    for i, s in enumerate([*a.tolist(), end]):
        K.SetValue(i + 1, s)
        M.SetValue(i + 1, p + 1 if i in (0, n) else p)
    pcurve = Geom2d_BSplineCurve(P, K, M, p, False)
    smoothed = False
    for i in range(2, n + 1):  # a corner stays one
        smoothed |= bool(pcurve.RemoveKnot(i, DEGREE - 1, tolerance))
    return pcurve, smoothed
