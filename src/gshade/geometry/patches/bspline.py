"""B-spline (and NURBS) curves and tensor-product patches with nonuniform knots.

Knot insertion (Boehm) and Bézier extraction are exact: they change the representation, not
the curve or surface (Kiciak, A.3; Piegl & Tiller, ch. 5).
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...errors import GshadeError, show
from ..core.knots import domain, insert_knot, refine_to_bezier, validate_knots
from ..core.patch import (
    BasisCurve,
    BSplineBasis,
    TensorProductPatch,
    homogeneous,
    validate_points,
    validate_weights,
)
from .bezier import BezierCurve, BezierPatch

__all__ = ["BSplineCurve", "BSplinePatch"]


def _split(h: NDArray, rational: bool) -> tuple[NDArray, NDArray | None]:
    """Homogeneous control points back to (points, weights)."""
    if not rational:
        return h, None
    return h[..., :-1] / h[..., -1:], h[..., -1]


def _restrict(
    knots: NDArray, degree: int, net: NDArray, a: float, b: float
) -> tuple[NDArray, NDArray]:
    """Knots and control points (axis 0 of ``net``) of the same spline over [a, b] only.

    ``a`` and ``b`` (U_p <= a < b <= U_{n+1}) are inserted until each has multiplicity >= p
    (Boehm, on all of ``net`` at once).  If U_r is then the last knot equal to a and U_s the
    first equal to b, the spans in [a, b] use the points P_{r-p}..P_{s-1} and the knots
    U_{r-p+1}..U_{s+p-1} only, which equal a up to U_r and b from U_s: the knots beyond are
    replaced by a and b (clamped ends), which changes no basis function on [a, b].
    """
    U, P, p = knots, net, degree
    for t in (a, b):
        mult = int(np.count_nonzero(U == t))
        if mult < p:
            U, P = insert_knot(U, p, P, t, p - mult)
    r = int(np.searchsorted(U, a, side="right")) - 1
    s = int(np.searchsorted(U, b, side="left"))
    ends = np.ones(p + 1)
    return np.concatenate([a * ends, U[r + 1 : s], b * ends]), P[r - p : s].copy()


def _continue_start(knots: NDArray, degree: int, net: NDArray, a: float) -> tuple[NDArray, NDArray]:
    """The clamped spline (knots starting with p + 1 copies of U_0 > a) over [a, ...]: its
    first span's polynomial continued down to a, no knot added.

    The control points P_i = f(t_{i+1}, ..., t_{i+p}) are the blossom f of the polynomial of
    any span in their support (Ramshaw 1989; Kiciak, A.3).  Only P_0 .. P_{p-1} name one of
    the start knots, so only they change: P_i = f_1(a^(p - i), U_{p+1}, ..., U_{p+i}), with f_1
    the first span's blossom, evaluated by de Casteljau steps at those parameters on the
    span's Bezier points.
    """
    U, p = knots, degree
    a0, k1 = float(U[p]), float(U[p + 1])
    _, bezier = _restrict(U, p, net, a0, k1)  # the first span's Bezier points over [a0, k1]
    out = net.copy()
    for i in range(p):
        pts = bezier
        for x in [a] * (p - i) + list(U[p + 1 : p + 1 + i]):
            tau = (float(x) - a0) / (k1 - a0)
            pts = (1.0 - tau) * pts[:-1] + tau * pts[1:]
        out[i] = pts[0]
    U = U.copy()
    U[: p + 1] = a
    return U, out


#: A box end closer than this to a knot inside the box, relative to the span beyond that
#: knot, would cut a sliver span (a CAD face's box a round-off short of a knot): the spline
#: is cut at the knot instead, and that span's polynomial continued to the end.
SLIVER = 1e-6


def _cuts(knots: NDArray, degree: int, a: float, b: float) -> tuple[float, float]:
    """Where to cut the spline for the interval [a, b] inside its domain: a and b, except an
    end that would leave a sliver span (:data:`SLIVER`), moved onto its knot.

    On a sliver of relative length h, a k-th derivative from the span's Bezier points loses
    k log10(1/h) digits (a box 4e-14 short of a knot: the second derivatives off by 1e13);
    the next span's polynomial continued over it differs from the spline by O(h^c) relative
    (c the continuity there), below round-off for the slivers moved."""
    p = degree
    inner = np.unique(knots[p : len(knots) - p])
    inner = inner[(inner > a) & (inner < b)]
    if inner.size:
        beyond = inner[1] if inner.size > 1 else b  # a's knot's span
        if inner[0] - a <= SLIVER * (beyond - inner[0]):
            a = float(inner[0])
        before = inner[-2] if inner.size > 1 else a  # b's knot's span
        if b - inner[-1] <= SLIVER * (inner[-1] - before) and inner[-1] > a:
            b = float(inner[-1])
    return a, b


def _over(knots: NDArray, degree: int, net: NDArray, a: float, b: float) -> tuple[NDArray, NDArray]:
    """Knots and control points (axis 0 of ``net``) of the spline over [a, b], which may reach
    past the domain [U_p, U_{n+1}]: there the end spans' polynomials are continued (and over
    a sliver span the box's end would cut, :func:`_cuts`)."""
    p = degree
    lo, hi = float(knots[p]), float(knots[-p - 1])
    cut_a, cut_b = _cuts(knots, p, max(a, lo), min(b, hi))
    U, P = _restrict(knots, p, net, cut_a, cut_b)
    if a < cut_a:
        U, P = _continue_start(U, p, P, a)
    if b > cut_b:  # the same at the end, on the reversed spline
        U, P = _continue_start(-U[::-1], p, P[::-1], -b)
        U, P = -U[::-1], P[::-1]
    return U, np.ascontiguousarray(P)


def _box(
    box: Any, dom: tuple, beyond: bool = False
) -> tuple[tuple[float, float], tuple[float, float]]:
    """``box`` as ((u0, u1), (v0, v1)) of finite floats, checked to be non-empty and (unless
    ``beyond``) inside ``dom``."""
    ends: list[float] = []
    try:
        (a0, a1), (b0, b1) = box
        for x in (a0, a1, b0, b1):
            if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
                break
            ends.append(float(x))
    except (TypeError, ValueError):
        pass
    if len(ends) != 4 or not np.all(np.isfinite(ends)):
        raise GshadeError(f"box: expected ((u0, u1), (v0, v1)) of finite numbers, got {show(box)}")
    u0, u1, v0, v1 = ends
    for name, (a, b), (lo, hi) in (("u", (u0, u1), dom[0]), ("v", (v0, v1), dom[1])):
        if not a < b:
            raise GshadeError(
                f"box: expected {name}0 < {name}1, got the empty {name} range [{a!r}, {b!r}]"
            )
        if not beyond and not (lo <= a and b <= hi):
            raise GshadeError(
                f"box: expected a {name} range inside the domain's [{lo!r}, {hi!r}], "
                f"got [{a!r}, {b!r}]"
            )
    return (u0, u1), (v0, v1)


class BSplineCurve(BasisCurve):
    """B-spline curve of degree p, rational (NURBS) if weights are given.

    Parameters
    ----------
    points : array_like, shape (n + 1, dim)
    degree : int
        p >= 1.
    knots : array_like, length n + p + 2
        Non-decreasing; clamped or not; the domain is [U_p, U_{n+1}].
    weights : array_like, shape (n + 1,), optional

    Examples
    --------
    A quadratic of two spans; inserting a knot (Boehm) adds a control point, not a change:

    >>> from gshade.geometry import BSplineCurve
    >>> curve = BSplineCurve([[0, 0], [1, 2], [3, 2], [4, 0]], 2, [0, 0, 0, 0.5, 1, 1, 1])
    >>> curve(0.5).tolist()  # at the knot: the middle of P1 P2
    [2.0, 2.0]
    >>> curve.insert_knot(0.25).points.tolist()
    [[0.0, 0.0], [0.5, 1.0], [1.5, 2.0], [3.0, 2.0], [4.0, 0.0]]
    >>> [segment.domain for segment in curve.bezier_segments()]
    [(0.0, 0.5), (0.5, 1.0)]
    """

    def __init__(
        self,
        points: ArrayLike,
        degree: int,
        knots: ArrayLike,
        weights: ArrayLike | None = None,
    ) -> None:
        P = validate_points(points, 1, "B-spline curve")
        U = validate_knots(knots, degree, P.shape[0], "knots")
        w = validate_weights(weights, P.shape[:1], "B-spline curve")
        self.degree = int(degree)
        self.knots = U
        self.domain = domain(U, self.degree)
        super().__init__(BSplineBasis(self.degree, U), P, w)

    def insert_knot(self, t: float, times: int = 1) -> BSplineCurve:
        """The same curve with the knot ``t`` inserted ``times`` times."""
        U, h = insert_knot(self.knots, self.degree, self._net, float(t), times)
        P, w = _split(h, self.rational)
        return BSplineCurve(P, self.degree, U, w)

    def bezier_segments(self) -> list[BezierCurve]:
        """The polynomial (or rational) pieces as Bézier curves over their knot intervals."""
        breaks, pieces = refine_to_bezier(self.knots, self.degree, self._net)
        out = []
        for k, h in enumerate(pieces):
            P, w = _split(h, self.rational)
            out.append(BezierCurve(P, w, domain=(breaks[k], breaks[k + 1])))
        return out


class BSplinePatch(TensorProductPatch):
    """Tensor-product B-spline patch, rational (NURBS) if weights are given.

    Parameters
    ----------
    points : array_like, shape (nu, nv, 3)
        Control net; ``points[i, j]`` multiplies N_i(u) N_j(v).
    degree : (int, int)
        (p, q), each >= 1.
    knots : (array_like, array_like)
        (U, V) with len(U) = nu + p + 1 and len(V) = nv + q + 1.
    weights : array_like, shape (nu, nv), optional

    Examples
    --------
    A NURBS quarter cylinder of radius 1 and height 2 (rational quadratic in u with the
    weights 1, cos 45°, 1; linear in v): every point lies on the radius.

    >>> import numpy as np
    >>> from gshade.geometry import BSplinePatch
    >>> net = [[[1, 0, 0], [1, 0, 2]], [[1, 1, 0], [1, 1, 2]], [[0, 1, 0], [0, 1, 2]]]
    >>> w = np.sqrt(0.5)
    >>> knots = ([0, 0, 0, 1, 1, 1], [0, 0, 1, 1])
    >>> quarter = BSplinePatch(net, (2, 1), knots, weights=[[1, 1], [w, w], [1, 1]])
    >>> np.round(quarter(0.5, 0.5), 12).tolist()
    [0.707106781187, 0.707106781187, 1.0]
    >>> ring = quarter(np.linspace(0.0, 1.0, 5), 0.25)
    >>> np.round(np.hypot(ring[:, 0], ring[:, 1]), 12).tolist()
    [1.0, 1.0, 1.0, 1.0, 1.0]
    >>> d = quarter.derivatives(0.5, 0.5, order=1)  # p_u along the circle, p_v up
    >>> np.round(d[1, 0], 12).tolist(), np.round(d[0, 1], 12).tolist()
    ([-1.171572875254, 1.171572875254, 0.0], [0.0, 0.0, 2.0])
    """

    def __init__(
        self,
        points: ArrayLike,
        degree: Sequence[int],
        knots: Sequence[ArrayLike],
        weights: ArrayLike | None = None,
    ) -> None:
        P = validate_points(points, 2, "B-spline patch")
        try:
            p, q = degree
            U_in, V_in = knots
        except (TypeError, ValueError):
            raise GshadeError(
                f"degree, knots: expected pairs (p, q) and (U, V), got {degree!r} and "
                f"a {type(knots).__name__}"
            ) from None
        U = validate_knots(U_in, p, P.shape[0], "knots_u")
        V = validate_knots(V_in, q, P.shape[1], "knots_v")
        w = validate_weights(weights, P.shape[:2], "B-spline patch")
        self.degree = (int(p), int(q))
        self.knots = (U, V)
        self.domain = (domain(U, self.degree[0]), domain(V, self.degree[1]))
        super().__init__(BSplineBasis(self.degree[0], U), BSplineBasis(self.degree[1], V), P, w)

    def insert_knot(self, direction: str, t: float, times: int = 1) -> BSplinePatch:
        """The same patch with the knot ``t`` inserted ``times`` times in 'u' or 'v'.

        Examples
        --------
        >>> import numpy as np
        >>> from gshade.geometry import cylinder
        >>> tube = cylinder(radius=2.0, height=3.0)
        >>> finer = tube.insert_knot("v", 0.125)
        >>> tube.points.shape, finer.points.shape
        ((2, 9, 3), (2, 10, 3))
        >>> u, v = np.random.default_rng(0).random((2, 100))
        >>> bool(np.allclose(finer(u, v), tube(u, v), rtol=0.0, atol=1e-13))  # unchanged
        True
        """
        if direction not in ("u", "v"):
            raise GshadeError(f"direction: expected 'u' or 'v', got {direction!r}")
        p, q = self.degree
        U, V = self.knots
        if direction == "u":
            U, h = insert_knot(U, p, self._net, float(t), times)
        else:
            V, h = insert_knot(V, q, np.swapaxes(self._net, 0, 1), float(t), times)
            h = np.swapaxes(h, 0, 1)
        P, w = _split(h, self.rational)
        return BSplinePatch(P, self.degree, (U, V), w)

    def restricted(self, box: Sequence[Sequence[float]], beyond: bool = False) -> BSplinePatch:
        """The same surface over the sub-box ``box`` of the domain, as a patch of its own.

        Parameters
        ----------
        box : ((u0, u1), (v0, v1))
            Inside the domain, with u0 < u1 and v0 < v1 (e.g. a CAD face's parameter box).
        beyond : bool, optional
            Let ``box`` reach past the domain: there the end spans' polynomial (rational)
            pieces are continued, as :meth:`derivatives_beyond` evaluates them and the CAD
            kernel extrapolates (e.g. a CAD face whose trims stray past its surface's domain
            by the file's tolerance).  Default False: such a box is an error.

        Returns
        -------
        BSplinePatch
            A new patch of the same degrees whose domain is exactly ``box`` and which equals
            this one there, derivatives included (knots outside ``box`` play no part).

        Raises
        ------
        GshadeError
            If ``box`` is not two pairs of finite numbers, is empty or leaves the domain.

        Notes
        -----
        In each direction the box ends are inserted (Boehm 1980; Piegl & Tiller, *The NURBS
        Book*, §5.2) until each has multiplicity >= p, which splits the spline there
        (§5.3); the control points and knots between them are kept, and the knots
        beyond them set to the box end (a clamped knot vector over the box).  Insertion acts on
        the homogeneous points (w P, w) of a rational patch, then the weights are divided out;
        it works on all rows of the net at once.  This is exact up to round-off, for clamped
        and unclamped (e.g. once periodic) knot vectors alike (Kiciak, A.3).  Past the
        domain, the end's first p control points are the blossom of the end span's
        polynomial at the new end knots (Ramshaw 1989): no knot is added.  A box end closer
        to a knot than :data:`SLIVER` of the span beyond it (a CAD face's box a round-off
        short of a knot) is treated the same way: the spline is cut at the knot and that
        span's polynomial continued to the end, instead of a sliver span whose derivatives
        would lose all their digits.

        Examples
        --------
        >>> import numpy as np
        >>> from gshade.geometry.patches.bspline import BSplinePatch
        >>> net = np.random.default_rng(0).normal(size=(4, 3, 3))
        >>> patch = BSplinePatch(net, (2, 2), ([0, 0, 0, .5, 1, 1, 1], [0, 0, 0, 1, 1, 1]))
        >>> wider = patch.restricted(((-0.1, 1.0), (0.0, 1.2)), beyond=True)
        >>> u, v = np.array([-0.05, 0.3]), np.array([1.1, 0.4])
        >>> bool(np.allclose(wider(u, v), patch.derivatives_beyond(u, v)[0, 0]))
        True
        """
        (u0, u1), (v0, v1) = _box(box, self.domain, beyond)
        p, q = self.degree
        U, V = self.knots
        U, h = _over(U, p, self._net, u0, u1)
        V, h = _over(V, q, np.swapaxes(h, 0, 1), v0, v1)
        P, w = _split(np.swapaxes(h, 0, 1), self.rational)
        return BSplinePatch(P, self.degree, (U, V), w)  # its domain: U_p = u0, ... exactly

    def translated(self, offset: ArrayLike) -> BSplinePatch:
        """The patch moved by ``offset`` (the points P + offset; the same knots, degrees
        and weights, not validated again: a rational patch's weights keep
        sum w B (P + o) / sum w B = p + o)."""
        moved = copy.copy(self)
        moved.points = np.asarray(self.points, dtype=np.float64) + np.asarray(offset, float)
        moved._net = homogeneous(moved.points, self.weights)
        return moved

    def bezier_patches(self) -> list[list[BezierPatch]]:
        """Bézier extraction: ``out[a][b]`` is the piece over the a-th u-span and b-th v-span,
        with that sub-rectangle as its domain, so it evaluates like the B-spline there."""
        p, q = self.degree
        U, V = self.knots
        ub, strips = refine_to_bezier(U, p, self._net)
        out = []
        for a, strip in enumerate(strips):
            vb, pieces = refine_to_bezier(V, q, np.swapaxes(strip, 0, 1))
            row = []
            for b, h in enumerate(pieces):
                P, w = _split(np.swapaxes(h, 0, 1), self.rational)
                row.append(BezierPatch(P, w, domain=((ub[a], ub[a + 1]), (vb[b], vb[b + 1]))))
            out.append(row)
        return out

    def derivatives_beyond(self, u: ArrayLike, v: ArrayLike, order: int = 0) -> NDArray:
        """``derivatives`` at points (u, v) (1-D arrays of one length) inside the domain or
        beyond it, where the end pieces are continued: past an end of the domain the
        polynomial (rational) piece of the end span is evaluated as it is, the way the
        kernel's ``Geom_BSplineSurface`` extrapolates.  Shape (order + 1, order + 1, N, 3).

        Inside the domain this equals ``derivatives(u, v, order)``; parameters are not
        checked against the domain (the caller bounds them, e.g. a CAD edge's pcurve
        straying past its face's box by a tolerance).
        """
        u = np.asarray(u, dtype=np.float64).ravel()
        v = np.asarray(v, dtype=np.float64).ravel()
        if u.shape != v.shape or not (np.isfinite(u).all() and np.isfinite(v).all()):
            raise GshadeError(
                f"u, v: expected finite 1-D arrays of one length, got {u.shape}, {v.shape}"
            )
        return np.moveaxis(self._derivatives_points(u, v, int(order)), 2, -1)
