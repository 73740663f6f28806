"""B-spline (and NURBS) curves and tensor-product patches with nonuniform knots.

Knot insertion (Boehm) and Bézier extraction are exact: they change the representation, not
the curve or surface (Kiciak, A.3; Piegl & Tiller, ch. 5).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import GshadeError
from .bezier import BezierCurve, BezierPatch
from .knots import domain, insert_knot, refine_to_bezier, validate_knots
from .patch import BasisCurve, BSplineBasis, TensorProductPatch, validate_points, validate_weights

__all__ = ["BSplineCurve", "BSplinePatch"]


def _split(h: NDArray, rational: bool) -> tuple[NDArray, NDArray | None]:
    """Homogeneous control points back to (points, weights)."""
    if not rational:
        return h, None
    return h[..., :-1] / h[..., -1:], h[..., -1]


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
    """

    def __init__(self, points: ArrayLike, degree: int, knots: ArrayLike, weights=None):
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
    """

    def __init__(self, points: ArrayLike, degree, knots, weights: ArrayLike | None = None):
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
        """The same patch with the knot ``t`` inserted ``times`` times in 'u' or 'v'."""
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
