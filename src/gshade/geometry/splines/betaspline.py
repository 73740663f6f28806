"""Barsky's cubic β-splines: G2 (not C2) curves and patches with bias and tension.

A cubic β-spline s(t) = sum_i d_i B_i(t) joins its polynomial arcs with G2 continuity for a
bias β1 > 0 and a tension β2 >= 0 (Kiciak's connection parameters t1 = β1, t2 = β2): at
every junction s'(+) = β1 s'(-) and s''(+) = β1^2 s''(-) + β2 s'(-).  With global
parameters, on the arc between integers i and i + 1 (local t = T - i) the four nonzero basis
functions are (Barsky 1981), with δ = 2β1^3 + 4β1^2 + 4β1 + β2 + 2,

    b_-2 = 2β1^3 (1 - t)^3 / δ
    b_-1 = (2β1^3 t (t^2 - 3t + 3) + 2β1^2 (t^3 - 3t^2 + 2) + 2β1 (t^3 - 3t + 2)
            + β2 (2t^3 - 3t^2 + 1)) / δ
    b_0  = (2β1^2 t^2 (3 - t) + 2β1 t (3 - t^2) + β2 t^2 (3 - 2t) + 2 (1 - t^3)) / δ
    b_1  = 2 t^3 / δ

β1 = 1, β2 = 0 gives the uniform cubic B-spline.  Curves with control points d_0..d_m are
defined for T in [0, m - 2]; patches are their tensor products.  Parameters β1_j, β2_j per
junction j give the discretely shaped β-spline, built arc by arc in Bézier form
(:class:`BetaSplineBasis`).

References
----------
B. A. Barsky, *The Beta-spline: a local representation based on shape parameters and
fundamental geometric measures*, PhD thesis, University of Utah (1981).  R. H. Bartels,
J. C. Beatty, B. A. Barsky, *An Introduction to Splines for Use in Computer Graphics and
Geometric Modeling*, Morgan Kaufmann (1987) (discretely shaped β-splines).  Kiciak §2.3.2
(curves), §2.4 (patches).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...errors import GshadeError
from ..core.patch import BasisCurve, TensorProductPatch, show_value, validate_points, value_pair
from ..patches.bspline import BSplineCurve, BSplinePatch
from .cubic_basis import (
    PiecewiseCubicBasis,
    arc_bezier_matrices,
    junction_values,
    non_negative,
    positive,
)

__all__ = ["BetaSplineBasis", "BetaSplineCurve", "BetaSplinePatch"]


def _segment_bezier_matrices(beta1: NDArray, beta2: NDArray) -> NDArray:
    """Bézier points of every arc in terms of its four control points, per-junction case.

    ``beta1``, ``beta2`` hold the parameters of the junctions -1, 0, ..., S + 1 of a curve
    of S arcs (junction j at T = j).  Returns M of shape (S, 4, 4): the Bézier points of arc
    i are ``M[i] @ (d_i, d_(i+1), d_(i+2), d_(i+3))``.
    """
    p, q = beta1[:-1], beta2[:-1]  # arc k (k = -1..S): its left junction k
    P, Q = beta1[1:], beta2[1:]  # and its right junction k + 1
    kappa = ((1 + p) ** 2 + q / 2) / (1 + p)
    mu = (P * (1 + P) ** 2 + Q / 2) / (P**2 * (1 + P))
    s = (mu - 1) / (mu * kappa - 1)
    r = kappa * s
    # G1 at junction j: b_0 divides b'_2 b_1 in the ratio beta1 : 1
    w = beta1[1:-1] / (1 + beta1[1:-1])  # junctions 0..S
    return arc_bezier_matrices(s, r, w[:-1], w[1:])


class BetaSplineBasis(PiecewiseCubicBasis):
    """The cubic β-spline basis over n control points: the domain is [0, n - 3].

    Parameters
    ----------
    n_points : int
        Number of control points, >= 4; the arcs are [i, i + 1] for i = 0..n - 4 and the
        interior junctions are T = 1..n - 4.
    beta1 : float or sequence of float
        Bias β1 > 0: one global number, or n - 4 numbers, one per interior junction.
    beta2 : float or sequence of float
        Tension β2 >= 0, likewise.
    names : (str, str)
        How error messages call ``beta1`` and ``beta2``.

    Notes
    -----
    Global parameters use Barsky's closed-form basis (module docstring).  Per-junction
    parameters β1_j, β2_j use the discretely shaped β-spline (Bartels, Beatty & Barsky), whose
    basis is built here arc by arc in Bézier form.  Local support and the C2 vanishing of
    B_k at the ends of its support put the inner Bézier points of arc i on the control leg
    d_(i+1) d_(i+2)::

        b_1 = (1 - s_i) d_(i+1) + s_i d_(i+2),    b_2 = (1 - r_i) d_(i+1) + r_i d_(i+2),

    and the G1 condition at junction i (arc i - 1 ends with b'_2, arc i starts with b_1)
    fixes the junction point b_0 = (b_1 + β1_i b'_2) / (1 + β1_i).  The G2 condition
    c''(i+) = β1_i^2 c''(i-) + β2_i c'(i-), which must hold for all control points, is linear
    in the two legs meeting at d_(i+1) and splits into one equation for each leg::

        r_i = κ_i s_i,                κ_i = ((1 + β1_i)^2 + β2_i / 2) / (1 + β1_i),
        1 - s_i = μ_i (1 - r_i),      μ_i = (β1_(i+1) (1 + β1_(i+1))^2 + β2_(i+1) / 2)
                                            / (β1_(i+1)^2 (1 + β1_(i+1))),

    (the second one from junction i + 1), so s_i = (μ_i - 1) / (μ_i κ_i - 1), r_i = κ_i s_i,
    with 0 < s_i < r_i < 1 for β1 > 0, β2 >= 0.  Every junction therefore satisfies
    c'(i+) = β1_i c'(i-) and c''(i+) = β1_i^2 c''(i-) + β2_i c'(i-) exactly: G2 with
    Kiciak's t1 = β1_i, t2 = β2_i (§2.1, §2.3.2).  The basis is unique under these
    conditions (local support, partition of unity), so constant values reproduce Barsky's
    global basis; B_k depends only on the parameters of its three interior junctions, arc i
    on those of junctions i - 1..i + 2.  The two junctions beyond each end of the curve
    (which move its end points) take the values of the nearest interior junction.
    """

    #: β1 and β2: one number each, or one per interior junction (``per_junction``)
    beta1: float | tuple[float, ...]
    beta2: float | tuple[float, ...]

    def __init__(
        self,
        n_points: int,
        beta1: ArrayLike = 1.0,
        beta2: ArrayLike = 0.0,
        names: tuple[str, str] = ("beta1", "beta2"),
    ) -> None:
        if n_points < 4:
            raise GshadeError(f"points: a cubic β-spline needs at least 4, got {n_points}")
        self.n_points = n_points
        count = n_points - 4
        b1 = junction_values(beta1, count, names[0], n_points, "> 0 (the bias)", positive)
        b2 = junction_values(beta2, count, names[1], n_points, ">= 0 (the tension)", non_negative)
        self.interval = (0.0, float(n_points - 3))
        segments = n_points - 3
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            self._build(b1, b2, count, segments)
        if not np.all(np.isfinite(self.segment_coefficients)):
            raise GshadeError(
                f"{names[0]}, {names[1]}: expected values small enough for a finite basis, got "
                f"{show_value(beta1)} and {show_value(beta2)}"
            )

    def _build(self, b1: float | NDArray, b2: float | NDArray, count: int, segments: int) -> None:
        """The per-arc coefficients, global (Barsky's closed form) or per junction."""
        if isinstance(b1, float) and isinstance(b2, float):
            self.beta1, self.beta2 = b1, b2
            self.per_junction = False
            self.coefficients = _global_coefficients(b1, b2)
            coefficients = np.broadcast_to(self.coefficients, (segments, 4, 4))
            self._set_coefficients(coefficients, np.arange(segments + 1.0))
        else:
            v1 = np.broadcast_to(b1, (count,)).astype(np.float64)
            v2 = np.broadcast_to(b2, (count,)).astype(np.float64)
            self.beta1, self.beta2 = tuple(map(float, v1)), tuple(map(float, v2))
            self.per_junction = True
            # junctions -1, 0 and S, S + 1 (beyond the ends) repeat the nearest interior one
            e1 = np.concatenate([[v1[0]] * 2, v1, [v1[-1]] * 2])
            e2 = np.concatenate([[v2[0]] * 2, v2, [v2[-1]] * 2])
            M = _segment_bezier_matrices(e1, e2)
            self._set_arcs(M, np.arange(segments + 1.0))


def _global_coefficients(b1: float, b2: float) -> NDArray:
    """Barsky's basis with global β1, β2: rows b_-2..b_1, columns powers 1, t, t^2, t^3."""
    d = 2 * b1**3 + 4 * b1**2 + 4 * b1 + b2 + 2
    return (
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


class BetaSplineCurve(BasisCurve):
    """Cubic β-spline curve with bias β1 > 0 and tension β2 >= 0 (Kiciak §2.3.2).

    At every junction T = j: c'(j+) = β1_j c'(j-), c''(j+) = β1_j^2 c''(j-) + β2_j c'(j-).

    Parameters
    ----------
    points : array_like, shape (m + 1, dim), m >= 3
        Control points d_0..d_m; the domain is [0, m - 2].
    beta1 : float or sequence of float
        The bias: one global number > 0, or m - 3 numbers, one per interior junction
        T = 1..m - 3 (see :class:`BetaSplineBasis` for the construction).
    beta2 : float or sequence of float
        The tension >= 0, likewise.
    """

    _basis: BetaSplineBasis

    def __init__(self, points: ArrayLike, beta1: ArrayLike = 1.0, beta2: ArrayLike = 0.0) -> None:
        P = validate_points(points, 1, "β-spline curve", min_count=4)
        basis = BetaSplineBasis(P.shape[0], beta1, beta2)
        self.domain = basis.interval
        self.beta1, self.beta2 = basis.beta1, basis.beta2
        super().__init__(basis, P, None)

    def to_bspline(self) -> BSplineCurve:
        """The same curve as a cubic B-spline with triple interior knots (its Bézier arcs)."""
        return BSplineCurve(
            self._basis.bezier_operator() @ self.points, 3, self._basis.bspline_knots()
        )


class BetaSplinePatch(TensorProductPatch):
    """Tensor-product cubic β-spline patch (Kiciak §2.4).

    Parameters
    ----------
    points : array_like, shape (m + 1, n + 1, 3), m, n >= 3
        Control net; ``points[i, j]`` multiplies B_i(u) B_j(v); the domain is
        [0, m - 2] x [0, n - 2].
    beta1, beta2 : float or (u, v) pair
        Global bias (> 0) and tension (>= 0), for both directions or per direction.
    beta1_u, beta2_u, beta1_v, beta2_v : float or sequence of float, optional
        Per direction, overriding ``beta1``/``beta2`` there: a number or one value per
        interior junction (m - 3 in u, n - 3 in v).  Every curve v = const is then the
        β-spline curve in u with these parameters, so across the knot line u = j the patch
        satisfies p_u(+) = β1_j p_u(-), p_uu(+) = β1_j^2 p_uu(-) + β2_j p_u(-) with p_v,
        p_vv continuous and p_uv(+) = β1_j p_uv(-): G2 (connection functions α = 0,
        β = β1_j, γ = 0, δ = β2_j).
    """

    degree = (3, 3)
    _bu: BetaSplineBasis
    _bv: BetaSplineBasis

    def __init__(
        self,
        points: ArrayLike,
        beta1: ArrayLike = 1.0,
        beta2: ArrayLike = 0.0,
        *,
        beta1_u: ArrayLike | None = None,
        beta2_u: ArrayLike | None = None,
        beta1_v: ArrayLike | None = None,
        beta2_v: ArrayLike | None = None,
    ) -> None:
        P = validate_points(points, 2, "β-spline patch", min_count=4)
        given = {"beta1": value_pair(beta1, "beta1"), "beta2": value_pair(beta2, "beta2")}
        per = {"beta1_u": beta1_u, "beta2_u": beta2_u, "beta1_v": beta1_v, "beta2_v": beta2_v}
        bases = []
        for k, direction in enumerate("uv"):
            args, names = [], []
            for name in ("beta1", "beta2"):
                key = f"{name}_{direction}"
                if per[key] is None:  # the global value (messages name the argument given)
                    args.append(given[name][k])
                    names.append(name)
                else:
                    args.append(per[key])
                    names.append(key)
            bases.append(BetaSplineBasis(P.shape[k], args[0], args[1], names=(names[0], names[1])))
        bu, bv = bases
        self.domain = (bu.interval, bv.interval)
        self.beta1 = (bu.beta1, bv.beta1)
        self.beta2 = (bu.beta2, bv.beta2)
        super().__init__(bu, bv, P, None)

    def to_bspline(self) -> BSplinePatch:
        """The same patch as a bicubic B-spline with triple interior knots (Bézier pieces)."""
        net = np.einsum(
            "ai,ijc,bj->abc", self._bu.bezier_operator(), self.points, self._bv.bezier_operator()
        )
        return BSplinePatch(net, (3, 3), (self._bu.bspline_knots(), self._bv.bspline_knots()))
