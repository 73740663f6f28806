"""Boehm's γ-splines: G2 (not C2) cubic splines in B-spline form, curves and patches.

A γ-spline is a piecewise cubic curve over a knot vector t_0 < t_1 < ... with de Boor
(control) points d_0..d_m, built like the C2 cubic B-spline from its Bézier points, with one
shape parameter γ_k > 0 per interior knot; γ ≡ 1 is the C2 cubic B-spline (any knots).  With
h_j = t_(j+1) - t_j, the arc over [t_k, t_(k+1)] has its inner Bézier points on the leg
d_(k-2) d_(k-1), dividing it in the ratios::

    γ_k h_(k-1)  :  h_k  :  γ_(k+1) h_(k+1)

(the C2 B-spline's h_(k-1) : h_k : h_(k+1) with the outer parts scaled by the γ of the
nearer knot), and its junction point at t_k divides the segment between the two inner
Bézier points next to it in the ratio h_(k-1) : h_k (C1).  Every junction is then G2 with
Kiciak's connection parameters t1 = 1, t2 = ν_k (§2.1): the curve is C1 and

    p''(t_k+) = p''(t_k-) + ν_k p'(t_k),   ν_k = 2 (h_(k-1) + h_k) (1 - γ_k) / (γ_k h_(k-1) h_k),

i.e. γ_k = 1 / (1 + ν_k h_(k-1) h_k / (2 (h_(k-1) + h_k))): ν-spline junctions (Nielson's
equation, Kiciak §2.3.1) for a B-spline-like curve.  γ_k < 1 (ν_k > 0) pulls the curve
toward d_(k-2)..d_k there, γ_k > 1 (ν_k < 0) pushes it away.  The basis functions are
non-negative, sum to one and have the B-spline's support (four arcs): the curve lies in the
convex hull of its control polygon and is affine invariant.  Patches are tensor products.

What is taken from where, and what is derived here: the γ-spline as a B-spline-like
(approximating) cubic G2 spline with one shape parameter per knot, C1 with
p*'' = p'' + ν p' at the junctions and γ ≡ 1 the cubic B-spline, is Boehm's (1985; Kiciak
§2.3.3).  Neither Boehm's paper nor the book's section was at hand: the leg ratios above and
the relation between γ and ν were derived here from the G2 equations.  Requiring
p''(+) = p''(-) + ν p' at t_k for every control polygon, with the inner Bézier points on the
legs and the C1 junction points, splits into one equation per leg meeting at d_(k-2); with
the ratios above both reduce to the same γ_k–ν_k relation.  (A note to reconstruct it had
ν h h / (4 (h + h)); the G2 equations give 2, and with uniform knots γ = 1 / (1 + ν / 4)
makes the curve the discretely shaped β-spline with β1 = 1, β2 = ν, which the tests check.)

References
----------
W. Boehm, "Curvature continuous curves and surfaces", *Computer Aided Geometric Design* 2
(1985) 313–323.  G. Farin, *Curves and Surfaces for CAGD*, chapter on geometric continuity
(ν-, β- and γ-splines).  Kiciak §2.3.3 (curves), §2.4 (patches).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...errors import GshadeError
from ..core.patch import BasisCurve, TensorProductPatch, show_value, validate_points, value_pair
from ..patches.bspline import BSplineCurve, BSplinePatch
from .cubic_basis import PiecewiseCubicBasis, arc_bezier_matrices, junction_values, positive

__all__ = [
    "GammaSplineBasis",
    "GammaSplineCurve",
    "GammaSplinePatch",
    "gamma_from_nu",
    "nu_from_gamma",
]


def nu_from_gamma(gamma: ArrayLike, h_left: ArrayLike, h_right: ArrayLike) -> NDArray:
    """ν = 2 (h_l + h_r) (1 - γ) / (γ h_l h_r): the G2 connection parameter t2 of a knot.

    ``h_left``, ``h_right`` are the lengths of the knot intervals either side of the knot.
    """
    g, a, b = (np.asarray(x, dtype=np.float64) for x in (gamma, h_left, h_right))
    return 2 * (a + b) * (1 - g) / (g * a * b)


def gamma_from_nu(nu: ArrayLike, h_left: ArrayLike, h_right: ArrayLike) -> NDArray:
    """γ = 1 / (1 + ν h_l h_r / (2 (h_l + h_r))), the inverse of :func:`nu_from_gamma`.

    γ > 0 needs ν > -2 (h_l + h_r) / (h_l h_r); ν = 0 gives γ = 1 (C2 there).
    """
    n, a, b = (np.asarray(x, dtype=np.float64) for x in (nu, h_left, h_right))
    return 1 / (1 + n * a * b / (2 * (a + b)))


def _knot_vector(knots: ArrayLike | None, n_points: int, name: str) -> NDArray:
    """The cubic B-spline knot vector t_0..t_(n+3): ``n_points`` + 4 increasing numbers
    (default -3, -2, ..., n_points, so that the domain is [0, n_points - 3])."""
    count = n_points + 4
    if knots is None:
        return np.arange(float(count)) - 3.0
    expected = (
        f"{name}: expected {count} strictly increasing numbers (the cubic B-spline knot vector "
        f"of {n_points} control points)"
    )
    try:
        t = np.asarray(knots, dtype=np.float64)
    except (TypeError, ValueError):
        raise GshadeError(f"{expected}, got {show_value(knots)}") from None
    if t.ndim != 1 or t.shape[0] != count:
        got = f"{t.shape[0]} numbers" if t.ndim == 1 else show_value(knots)
        raise GshadeError(f"{expected}, got {got}")
    h = np.diff(t)
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(h)) and np.all(h > 0)):
        raise GshadeError(f"{expected}, got {show_value(knots)}")
    return t


def _bezier_matrices(t: NDArray, g: NDArray) -> NDArray:
    """Bézier points of every arc in terms of its four control points.

    ``t`` is the knot vector t_0..t_(n+3) of n control points, ``g`` the γ of the knots
    t_2..t_(n+1) (those beyond the domain included).  Returns M of shape (n - 3, 4, 4): the
    Bézier points of arc a (over [t_(a+3), t_(a+4)]) are ``M[a] @ (d_a, .., d_(a+3))``.
    """
    n = t.size - 4
    h = np.diff(t)  # h_0..h_(n+2)
    gamma = np.concatenate([[np.nan, np.nan], g, [np.nan]])  # indexed by knot: γ_2..γ_(n+1)
    k = np.arange(2, n + 1)  # legs of the arcs k = 2..n (two of them beyond the domain)
    left, right = gamma[k] * h[k - 1], gamma[k + 1] * h[k + 1]
    total = left + h[k] + right
    total[~np.isfinite(total)] = np.nan  # overflow: no basis (the caller's message)
    s = np.concatenate([[np.nan, np.nan], left / total])  # indexed by arc k
    r = np.concatenate([[np.nan, np.nan], (left + h[k]) / total])
    k = np.arange(3, n)  # the arcs of the domain
    w0 = h[k] / (h[k - 1] + h[k])  # weight of arc k - 1's last inner point in b_0
    w3 = h[k + 1] / (h[k] + h[k + 1])  # weight of arc k's last inner point in b_3
    return arc_bezier_matrices(s[2:], r[2:], w0, w3)  # arcs 2..n: one beyond each end


class GammaSplineBasis(PiecewiseCubicBasis):
    """The cubic γ-spline basis over n control points and a knot vector t_0..t_(n+3).

    Parameters
    ----------
    n_points : int
        Number of control points, >= 4.  The domain is [t_3, t_n], its arcs [t_k, t_(k+1)]
        for k = 3..n - 1 and its interior junctions t_4..t_(n-1) (n - 4 of them).
    gamma : float or sequence of float
        γ > 0: one global number, or n - 4 numbers, one per interior junction.
    knots : array_like, shape (n + 4,), optional
        Strictly increasing knots, the knot vector of the cubic B-spline with the same
        control points (t_0 and t_(n+3) do not affect the curve); default -3, -2, ...,
        n, so that the domain is [0, n - 3] like the β-spline's.
    names : (str, str)
        How error messages call ``gamma`` and ``knots``.

    Notes
    -----
    Arc k's Bézier points, from its control points d_(k-3)..d_k (module docstring for the
    ratios), with s_k = γ_k h_(k-1) / Σ_k, r_k = (γ_k h_(k-1) + h_k) / Σ_k and
    Σ_k = γ_k h_(k-1) + h_k + γ_(k+1) h_(k+1)::

        b_1 = (1 - s_k) d_(k-2) + s_k d_(k-1),   b_2 = (1 - r_k) d_(k-2) + r_k d_(k-1),
        b_0 = (h_k b'_2 + h_(k-1) b_1) / (h_(k-1) + h_k)

    (b'_2 is arc k - 1's b_2), and b_3 likewise with arc k + 1's b_1.  Arc k depends on the
    γ of the knots t_(k-1)..t_(k+2); the two knots beyond each end of the domain (they move
    its end points) take the γ of the nearest interior junction.
    """

    #: γ: one number, or one per interior junction (``per_junction``)
    gamma: float | tuple[float, ...]

    def __init__(
        self,
        n_points: int,
        gamma: ArrayLike = 1.0,
        knots: ArrayLike | None = None,
        names: tuple[str, str] = ("gamma", "knots"),
    ) -> None:
        if n_points < 4:
            raise GshadeError(f"points: a cubic γ-spline needs at least 4, got {n_points}")
        self.n_points = n_points
        count = n_points - 4
        g = junction_values(gamma, count, names[0], n_points, "> 0", positive)
        self.knots = _knot_vector(knots, n_points, names[1])
        self.interval = (float(self.knots[3]), float(self.knots[n_points]))
        if isinstance(g, float):
            self.gamma, self.per_junction = g, False
            extended = np.full(n_points, g)
        else:
            self.gamma, self.per_junction = tuple(map(float, g)), True
            extended = np.concatenate([[g[0]] * 2, g, [g[-1]] * 2])
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            M = _bezier_matrices(self.knots, extended)
        if not np.all(np.isfinite(M)):
            raise GshadeError(
                f"{names[0]}: expected values small enough for a finite basis, got "
                f"{show_value(gamma)}"
            )
        self._set_arcs(M, self.knots[3 : n_points + 1])  # t_3..t_n: the arcs' ends

    @property
    def nu(self) -> tuple[float, ...]:
        """ν_k of the interior junctions t_4..t_(n-1): p''(+) = p''(-) + ν_k p' there."""
        n = self.n_points
        h = np.diff(self.knots)
        g = np.broadcast_to(np.asarray(self.gamma, dtype=np.float64), (n - 4,))
        k = np.arange(4, n)
        with np.errstate(over="ignore"):
            return tuple(map(float, nu_from_gamma(g, h[k - 1], h[k])))


class GammaSplineCurve(BasisCurve):
    """Cubic γ-spline curve (Boehm; Kiciak §2.3.3).

    At every interior knot t_k: c'(t_k+) = c'(t_k-) and c''(t_k+) = c''(t_k-) + ν_k c'(t_k)
    with ν_k = 2 (h_(k-1) + h_k) (1 - γ_k) / (γ_k h_(k-1) h_k) (``nu``).

    Parameters
    ----------
    points : array_like, shape (m + 1, dim), m >= 3
        Control points d_0..d_m.
    gamma : float or sequence of float
        γ > 0: one global number, or m - 3 numbers, one per interior knot t_4..t_m
        (1: the C2 cubic B-spline there).
    knots : array_like, shape (m + 5,), optional
        The strictly increasing knot vector t_0..t_(m+4) of the cubic B-spline with these
        control points; the domain is [t_3, t_(m+1)].  Default -3, -2, ..., m + 1: the
        uniform B-spline on [0, m - 2].
    """

    _basis: GammaSplineBasis

    def __init__(
        self, points: ArrayLike, gamma: ArrayLike = 1.0, knots: ArrayLike | None = None
    ) -> None:
        P = validate_points(points, 1, "γ-spline curve", min_count=4)
        basis = GammaSplineBasis(P.shape[0], gamma, knots)
        self.domain = basis.interval
        self.gamma = basis.gamma
        self.knots = basis.knots
        super().__init__(basis, P, None)

    @property
    def nu(self) -> tuple[float, ...]:
        """ν_k of the interior knots (see the class docstring)."""
        return self._basis.nu

    def bezier_segments(self) -> NDArray:
        """The arcs' Bézier control points, shape (S, 4, dim); arc a is [t_(a+3), t_(a+4)]."""
        return np.einsum("akr,arc->akc", self._basis.bezier_matrices(), self._windows())

    def _windows(self) -> NDArray:
        S = self.points.shape[0] - 3
        return np.stack([self.points[a : a + 4] for a in range(S)])

    def to_bspline(self) -> BSplineCurve:
        """The same curve as a cubic B-spline with triple interior knots (its Bézier arcs)."""
        return BSplineCurve(
            self._basis.bezier_operator() @ self.points, 3, self._basis.bspline_knots()
        )


class GammaSplinePatch(TensorProductPatch):
    """Tensor-product cubic γ-spline patch (Kiciak §2.3.3, §2.4).

    Every curve v = const is the γ-spline curve in u of the control points
    c_i(v) = sum_j d_ij B_j(v) (and symmetrically), so across the knot line u = t_k

        p_u(+) = p_u(-),   p_uu(+) = p_uu(-) + ν_k p_u,

    with p, p_v, p_uv and p_vv continuous: the equations of G2 continuity with connection
    functions α = 0, β = 1, γ = 0, δ = ν_k (not C2 where γ_k != 1); likewise across v = t_l.

    Parameters
    ----------
    points : array_like, shape (m + 1, n + 1, 3), m, n >= 3
        Control net; ``points[i, j]`` multiplies B_i(u) B_j(v).
    gamma : float or (u, v) pair
        Global γ > 0, for both directions or per direction (default 1: a bicubic B-spline).
    gamma_u, gamma_v : float or sequence of float, optional
        Per direction, overriding ``gamma`` there: a number or one value per interior
        junction (m - 3 in u, n - 3 in v).
    knots_u, knots_v : array_like, optional
        Strictly increasing knot vectors of m + 5 and n + 5 numbers (those of the bicubic
        B-spline with the same net); default -3, -2, ...: the domain
        [0, m - 2] x [0, n - 2].
    """

    degree = (3, 3)
    _bu: GammaSplineBasis
    _bv: GammaSplineBasis

    def __init__(
        self,
        points: ArrayLike,
        gamma: ArrayLike = 1.0,
        *,
        gamma_u: ArrayLike | None = None,
        gamma_v: ArrayLike | None = None,
        knots_u: ArrayLike | None = None,
        knots_v: ArrayLike | None = None,
    ) -> None:
        P = validate_points(points, 2, "γ-spline patch", min_count=4)
        given = value_pair(gamma, "gamma")
        bases = []
        for k, (per, knots, d) in enumerate(((gamma_u, knots_u, "u"), (gamma_v, knots_v, "v"))):
            # messages name the argument given: the global value or the direction's
            value, name = (given[k], "gamma") if per is None else (per, f"gamma_{d}")
            bases.append(GammaSplineBasis(P.shape[k], value, knots, names=(name, f"knots_{d}")))
        bu, bv = bases
        self.domain = (bu.interval, bv.interval)
        self.gamma = (bu.gamma, bv.gamma)
        self.knots = (bu.knots, bv.knots)
        super().__init__(bu, bv, P, None)

    @property
    def nu(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """ν of the interior knot lines in u and in v."""
        return self._bu.nu, self._bv.nu

    def to_bspline(self) -> BSplinePatch:
        """The same patch as a bicubic B-spline with triple interior knots (Bézier pieces)."""
        net = np.einsum(
            "ai,ijc,bj->abc", self._bu.bezier_operator(), self.points, self._bv.bezier_operator()
        )
        return BSplinePatch(net, (3, 3), (self._bu.bspline_knots(), self._bv.bspline_knots()))
