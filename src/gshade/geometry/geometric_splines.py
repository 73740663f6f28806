"""Geometric spline curves and patches (Kiciak §2.3): Nielson's ν-splines, Barsky's β-splines.

ν-splines (Kiciak eq. 2.15): cubic Hermite arcs through points a_0..a_N at knots
u_0 < ... < u_N whose tangents b_i make p''(u_i+) = p''(u_i-) + ν_i p'(u_i) (G2 with t1 = 1,
t2 = ν_i), i.e. with h_i = u_(i+1) - u_i the tridiagonal system

    h_i b_(i-1) + (2 (h_(i-1) + h_i) + h_(i-1) h_i ν_i / 2) b_i + h_(i-1) b_(i+1)
        = 3 (h_i / h_(i-1) (a_i - a_(i-1)) + h_(i-1) / h_i (a_(i+1) - a_i)),

closed by natural ends (p'' = 0) or given end tangents.  ν_i = 0 gives the C2 interpolating
cubic spline; larger ν_i pull the curve toward the polyline near a_i.

A cubic β-spline s(t) = sum_i d_i B_i(t) joins its polynomial arcs with G2 continuity for a
bias β1 > 0 and a tension β2 >= 0 (Kiciak's connection parameters t1 = β1, t2 = β2): at every
junction s*' = β1 s' and s*'' = β1^2 s'' + β2 s'.  On the arc between integers i and i + 1
(local t = T - i) the four nonzero basis functions are (Barsky 1981), with
δ = 2β1^3 + 4β1^2 + 4β1 + β2 + 2:

    b_-2 = 2β1^3 (1 - t)^3 / δ
    b_-1 = (2β1^3 t (t^2 - 3t + 3) + 2β1^2 (t^3 - 3t^2 + 2) + 2β1 (t^3 - 3t + 2)
            + β2 (2t^3 - 3t^2 + 1)) / δ
    b_0  = (2β1^2 t^2 (3 - t) + 2β1 t (3 - t^2) + β2 t^2 (3 - 2t) + 2 (1 - t^3)) / δ
    b_1  = 2 t^3 / δ

β1 = 1, β2 = 0 gives the uniform cubic B-spline.  Curves with control points d_0..d_m are
defined for T in [0, m - 2]; patches are their tensor products.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import GshadeError
from .patch import BasisCurve, TensorProductPatch, check_points

__all__ = ["BetaSplineBasis", "BetaSplineCurve", "BetaSplinePatch", "nu_spline"]


def nu_spline(
    points: ArrayLike,
    knots: ArrayLike | None = None,
    nu: ArrayLike = 0.0,
    end_tangents: tuple[ArrayLike, ArrayLike] | None = None,
):
    """Nielson's ν-spline through ``points`` as a piecewise cubic B-spline curve.

    Parameters
    ----------
    points : array_like, shape (N + 1, dim), N >= 1
        The points a_i to interpolate.
    knots : array_like, shape (N + 1,), optional
        Increasing parameters u_i (default 0, 1, ..., N).
    nu : float or array_like, shape (N + 1,)
        Tensions ν_i >= 0 at the knots (the end values are not used).
    end_tangents : (b_0, b_N), optional
        Given end tangents; by default natural ends (p'' = 0 there).

    Returns
    -------
    BSplineCurve
        Degree 3 with triple interior knots: each arc is one Bézier segment
        (a_i, a_i + h_i b_i / 3, a_(i+1) - h_i b_(i+1) / 3, a_(i+1)).
    """
    from scipy.linalg import solve_banded

    from .bspline import BSplineCurve

    a = check_points(points, 1, "ν-spline", min_count=2)
    n = a.shape[0] - 1
    u = np.arange(n + 1.0) if knots is None else np.asarray(knots, dtype=np.float64)
    if u.shape != (n + 1,) or not np.all(np.diff(u) > 0):
        raise GshadeError(f"knots: expected {n + 1} increasing numbers, got {knots!r}")
    v = np.broadcast_to(np.asarray(nu, dtype=np.float64), (n + 1,))
    if not np.all(np.isfinite(v) & (v >= 0)):
        raise GshadeError(f"nu: expected numbers >= 0, got {nu!r}")
    h = np.diff(u)
    da = np.diff(a, axis=0)
    ab = np.zeros((3, n + 1))  # banded: super-, main and sub-diagonal
    rhs = np.zeros_like(a)
    if end_tangents is None:  # natural ends: 2 b_0 + b_1 = 3 da_0 / h_0, and mirrored
        ab[1, 0], ab[0, 1], rhs[0] = 2.0, 1.0, 3 * da[0] / h[0]
        ab[1, n], ab[2, n - 1], rhs[n] = 2.0, 1.0, 3 * da[-1] / h[-1]
    else:
        b0, bn = (np.asarray(b, dtype=np.float64) for b in end_tangents)
        if b0.shape != a.shape[1:] or bn.shape != a.shape[1:]:
            raise GshadeError(f"end_tangents: expected two vectors of length {a.shape[1]}")
        ab[1, 0], rhs[0] = 1.0, b0
        ab[1, n], rhs[n] = 1.0, bn
    for i in range(1, n):
        ab[2, i - 1] = h[i]  # coefficient of b_(i-1) in row i
        ab[1, i] = 2 * (h[i - 1] + h[i]) + h[i - 1] * h[i] * v[i] / 2
        ab[0, i + 1] = h[i - 1]  # coefficient of b_(i+1) in row i
        rhs[i] = 3 * (h[i] / h[i - 1] * da[i - 1] + h[i - 1] / h[i] * da[i])
    b = solve_banded((1, 1), ab, rhs)
    net = np.empty((3 * n + 1, a.shape[1]))
    net[0::3] = a
    net[1::3] = a[:-1] + (h[:, None] / 3) * b[:-1]
    net[2::3] = a[1:] - (h[:, None] / 3) * b[1:]
    knot_vector = np.concatenate([[u[0]] * 4, np.repeat(u[1:-1], 3), [u[-1]] * 4])
    return BSplineCurve(net, 3, knot_vector)


def _check_shape(beta1: float, beta2: float) -> tuple[float, float]:
    try:
        b1, b2 = float(beta1), float(beta2)
    except (TypeError, ValueError):
        raise GshadeError(f"beta1, beta2: expected numbers, got {beta1!r}, {beta2!r}") from None
    if not (np.isfinite(b1) and b1 > 0):
        raise GshadeError(f"beta1: expected a number > 0 (the bias), got {beta1!r}")
    if not (np.isfinite(b2) and b2 >= 0):
        raise GshadeError(f"beta2: expected a number >= 0 (the tension), got {beta2!r}")
    return b1, b2


class BetaSplineBasis:
    """The cubic β-spline basis over n control points: the domain is [0, n - 3]."""

    degree = 3

    def __init__(self, n_points: int, beta1: float, beta2: float) -> None:
        if n_points < 4:
            raise GshadeError(f"points: a cubic β-spline needs at least 4, got {n_points}")
        self.n_points = n_points
        self.beta1, self.beta2 = _check_shape(beta1, beta2)
        b1, b2 = self.beta1, self.beta2
        d = 2 * b1**3 + 4 * b1**2 + 4 * b1 + b2 + 2
        # rows: b_-2, b_-1, b_0, b_1; columns: coefficients of 1, t, t^2, t^3
        self.coefficients = (
            np.array(
                [
                    [2 * b1**3, -6 * b1**3, 6 * b1**3, -2 * b1**3],
                    [
                        4 * b1**2 + 4 * b1 + b2,
                        6 * b1**3 - 6 * b1,
                        -6 * b1**3 - 6 * b1**2 - 3 * b2,
                        2 * b1**3 + 2 * b1**2 + 2 * b1 + 2 * b2,
                    ],
                    [2.0, 6 * b1, 6 * b1**2 + 3 * b2, -2 * b1**2 - 2 * b1 - 2 * b2 - 2],
                    [0.0, 0.0, 0.0, 2.0],
                ]
            )
            / d
        )
        self.interval = (0.0, float(n_points - 3))

    def local(self, t: NDArray, order: int) -> tuple[NDArray, NDArray]:
        t = np.asarray(t, dtype=np.float64)
        seg = np.clip(np.floor(t), 0, self.n_points - 4).astype(np.intp)
        x = t - seg
        out = np.zeros((order + 1, t.size, 4))
        c = self.coefficients.copy()
        for k in range(order + 1):
            if k > 3:
                break
            # Horner on each basis polynomial (derivative coefficients of order k in c)
            acc = np.zeros((t.size, 4))
            for power in range(3, -1, -1):
                acc = acc * x[:, None] + c[:, power]
            out[k] = acc
            c = np.concatenate([c[:, 1:] * np.arange(1, 4), np.zeros((4, 1))], axis=1)
        return seg, out

    def dense(self, t: NDArray, order: int) -> NDArray:
        first, ders = self.local(t, order)
        out = np.zeros((order + 1, first.size, self.n_points))
        rows = np.arange(first.size)[:, None]
        out[:, rows, first[:, None] + np.arange(4)] = ders
        return out


class BetaSplineCurve(BasisCurve):
    """Cubic β-spline curve with bias ``beta1`` > 0 and tension ``beta2`` >= 0 (global).

    Parameters
    ----------
    points : array_like, shape (m + 1, dim), m >= 3
    """

    def __init__(self, points: ArrayLike, beta1: float = 1.0, beta2: float = 0.0) -> None:
        P = check_points(points, 1, "β-spline curve", min_count=4)
        basis = BetaSplineBasis(P.shape[0], beta1, beta2)
        self.domain = basis.interval
        self.beta1, self.beta2 = basis.beta1, basis.beta2
        super().__init__(basis, P, None)


class BetaSplinePatch(TensorProductPatch):
    """Tensor-product cubic β-spline patch; ``beta1``/``beta2`` are (u, v) pairs or numbers."""

    def __init__(self, points: ArrayLike, beta1=1.0, beta2=0.0) -> None:
        P = check_points(points, 2, "β-spline patch", min_count=4)
        b1 = np.broadcast_to(np.asarray(beta1, dtype=object), (2,))
        b2 = np.broadcast_to(np.asarray(beta2, dtype=object), (2,))
        bu = BetaSplineBasis(P.shape[0], b1[0], b2[0])
        bv = BetaSplineBasis(P.shape[1], b1[1], b2[1])
        self.domain = (bu.interval, bv.interval)
        self.beta1 = (bu.beta1, bv.beta1)
        self.beta2 = (bu.beta2, bv.beta2)
        super().__init__(bu, bv, P, None)
