"""Geometric spline curves and patches (Kiciak §2.3–2.4): Nielson's ν-splines, Barsky's β-splines.

ν-splines (Kiciak eq. 2.15): cubic Hermite arcs through points a_0..a_N at knots
u_0 < ... < u_N whose tangents b_i make p''(u_i+) = p''(u_i-) + ν_i p'(u_i) (G2 with t1 = 1,
t2 = ν_i), i.e. with h_i = u_(i+1) - u_i the tridiagonal system

    h_i b_(i-1) + (2 (h_(i-1) + h_i) + h_(i-1) h_i ν_i / 2) b_i + h_(i-1) b_(i+1)
        = 3 (h_i / h_(i-1) (a_i - a_(i-1)) + h_(i-1) / h_i (a_(i+1) - a_i)),

closed by natural ends (p'' = 0), given end tangents, or cyclically (closed curves).  ν_i = 0
gives the C2 interpolating cubic spline; larger ν_i pull the curve toward the polyline near
a_i.  For fixed knots and tensions the curve is linear in the data points, so the tensor
product (interpolate the columns of a grid, then the rows of the result) is a well-defined
patch, :class:`NuSplinePatch` (Kiciak §2.4).

A cubic β-spline s(t) = sum_i d_i B_i(t) joins its polynomial arcs with G2 continuity for a
bias β1 > 0 and a tension β2 >= 0 (Kiciak's connection parameters t1 = β1, t2 = β2): at every
junction s*' = β1 s' and s*'' = β1^2 s'' + β2 s'.  With global parameters, on the arc between
integers i and i + 1 (local t = T - i) the four nonzero basis functions are (Barsky 1981),
with δ = 2β1^3 + 4β1^2 + 4β1 + β2 + 2:

    b_-2 = 2β1^3 (1 - t)^3 / δ
    b_-1 = (2β1^3 t (t^2 - 3t + 3) + 2β1^2 (t^3 - 3t^2 + 2) + 2β1 (t^3 - 3t + 2)
            + β2 (2t^3 - 3t^2 + 1)) / δ
    b_0  = (2β1^2 t^2 (3 - t) + 2β1 t (3 - t^2) + β2 t^2 (3 - 2t) + 2 (1 - t^3)) / δ
    b_1  = 2 t^3 / δ

β1 = 1, β2 = 0 gives the uniform cubic B-spline.  Curves with control points d_0..d_m are
defined for T in [0, m - 2]; patches are their tensor products.

With parameters β1_j, β2_j per junction j (the "discretely shaped" β-spline of Bartels,
Beatty & Barsky) each arc is built as a cubic Bézier arc from the G2 conditions at its two
junctions; see :class:`BetaSplineBasis`.
"""

from __future__ import annotations

from collections.abc import Sequence
from numbers import Real

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import GshadeError
from .bspline import BSplineCurve, BSplinePatch
from .patch import BasisCurve, TensorProductPatch, check_points

__all__ = [
    "BetaSplineBasis",
    "BetaSplineCurve",
    "BetaSplinePatch",
    "NuSplinePatch",
    "nu_spline",
]

#: ``_BERNSTEIN_TO_POWER[k, j]``: coefficient of t^j in the cubic Bernstein polynomial B_k.
_BERNSTEIN_TO_POWER = np.array(
    [[1.0, -3.0, 3.0, -1.0], [0.0, 3.0, -6.0, 3.0], [0.0, 0.0, 3.0, -3.0], [0.0, 0.0, 0.0, 1.0]]
)
_POWER_TO_BERNSTEIN = np.linalg.inv(_BERNSTEIN_TO_POWER)

ENDS = ("natural", "closed")

# --------------------------------------------------------------------------- ν-splines


def _show(value, limit: int = 60) -> str:
    """A value on one line, shortened (numbers as a plain list)."""
    try:
        text = str(np.asarray(value, dtype=np.float64).tolist())
    except (TypeError, ValueError):
        text = repr(value)
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _knots(knots: ArrayLike | None, count: int, name: str) -> NDArray:
    """``count`` increasing knots (default 0, 1, ..., count - 1)."""
    if knots is None:
        return np.arange(float(count))
    try:
        u = np.asarray(knots, dtype=np.float64)
    except (TypeError, ValueError):
        raise GshadeError(
            f"{name}: expected {count} increasing numbers, got {_show(knots)}"
        ) from None
    if u.shape != (count,) or not np.all(np.isfinite(u)) or not np.all(np.diff(u) > 0):
        raise GshadeError(f"{name}: expected {count} increasing numbers, got {_show(knots)}")
    return u


def _tensions(nu: ArrayLike, count: int, name: str) -> NDArray:
    """Tensions ν_i >= 0: one number for all knots or ``count`` numbers."""
    try:
        v = np.asarray(nu, dtype=np.float64)
    except (TypeError, ValueError):
        raise GshadeError(
            f"{name}: expected numbers >= 0: one number or a list of {count} (one per knot), "
            f"got {_show(nu)}"
        ) from None
    if v.ndim > 1 or (v.ndim == 1 and v.shape[0] != count):
        raise GshadeError(
            f"{name}: expected numbers >= 0: one number or a list of {count} (one per knot), "
            f"got {v.size} numbers"
        )
    if not np.all(np.isfinite(v) & (v >= 0)):
        raise GshadeError(f"{name}: expected numbers >= 0 (tensions), got {_show(nu)}")
    return np.broadcast_to(v, (count,)).copy()


def _nu_spline_net(
    a: NDArray, u: NDArray, nu: NDArray, end_tangents: tuple[NDArray, NDArray] | None, closed: bool
) -> tuple[NDArray, NDArray]:
    """Bézier net and knot vector of the ν-spline through the rows of ``a`` (any width).

    Open: ``a`` has N + 1 rows, ``u`` N + 1 knots.  Closed: ``u`` has N + 2 knots, the last
    arc returns from a_N to a_0 and every row of the system is of the form (2.15), cyclically.
    The result is linear in ``a``: this is what makes the tensor-product patch well defined.
    """
    from scipy.linalg import solve_banded

    n = a.shape[0] - 1
    h = np.diff(u)
    if closed:
        m = n + 1  # arcs; tangents b_0..b_n, b_(n+1) = b_0
        da = np.diff(np.concatenate([a, a[:1]]), axis=0)  # a_(i+1) - a_i, cyclic
        A = np.zeros((m, m))
        rhs = np.empty_like(a)
        for i in range(m):
            hp, hi = h[i - 1], h[i]  # h_(i-1) (cyclic), h_i
            A[i, (i - 1) % m] += hi
            A[i, i] += 2 * (hp + hi) + hp * hi * nu[i] / 2
            A[i, (i + 1) % m] += hp
            rhs[i] = 3 * (hi / hp * da[i - 1] + hp / hi * da[i])
        b = np.linalg.solve(A, rhs)
        ends = np.concatenate([a, a[:1]])
        tangents = np.concatenate([b, b[:1]])
    else:
        m = n
        da = np.diff(a, axis=0)
        ab = np.zeros((3, n + 1))  # banded: super-, main and sub-diagonal
        rhs = np.zeros_like(a)
        if end_tangents is None:  # natural ends: 2 b_0 + b_1 = 3 da_0 / h_0, and mirrored
            ab[1, 0], ab[0, 1], rhs[0] = 2.0, 1.0, 3 * da[0] / h[0]
            ab[1, n], ab[2, n - 1], rhs[n] = 2.0, 1.0, 3 * da[-1] / h[-1]
        else:
            ab[1, 0], rhs[0] = 1.0, end_tangents[0]
            ab[1, n], rhs[n] = 1.0, end_tangents[1]
        for i in range(1, n):
            ab[2, i - 1] = h[i]  # coefficient of b_(i-1) in row i
            ab[1, i] = 2 * (h[i - 1] + h[i]) + h[i - 1] * h[i] * nu[i] / 2
            ab[0, i + 1] = h[i - 1]  # coefficient of b_(i+1) in row i
            rhs[i] = 3 * (h[i] / h[i - 1] * da[i - 1] + h[i - 1] / h[i] * da[i])
        tangents = solve_banded((1, 1), ab, rhs)
        ends = a
    net = np.empty((3 * m + 1, a.shape[1]))
    net[0::3] = ends
    net[1::3] = ends[:-1] + (h[:, None] / 3) * tangents[:-1]
    net[2::3] = ends[1:] - (h[:, None] / 3) * tangents[1:]
    knot_vector = np.concatenate([[u[0]] * 4, np.repeat(u[1:-1], 3), [u[-1]] * 4])
    return net, knot_vector


def nu_spline(
    points: ArrayLike,
    knots: ArrayLike | None = None,
    nu: ArrayLike = 0.0,
    end_tangents: tuple[ArrayLike, ArrayLike] | None = None,
    *,
    closed: bool = False,
) -> BSplineCurve:
    """Nielson's ν-spline through ``points`` as a piecewise cubic B-spline curve (Kiciak §2.3.1).

    The tangents b_i at the knots solve Kiciak's equation (2.15)::

        h_i b_(i-1) + (2 (h_(i-1) + h_i) + h_(i-1) h_i ν_i / 2) b_i + h_(i-1) b_(i+1)
            = 3 (h_i / h_(i-1) (a_i - a_(i-1)) + h_(i-1) / h_i (a_(i+1) - a_i)),

    i.e. p''(u_i+) = p''(u_i-) + ν_i p'(u_i): G2 with connection parameters t1 = 1, t2 = ν_i.

    Parameters
    ----------
    points : array_like, shape (N + 1, dim), N >= 1 (N >= 2 if closed)
        The points a_i to interpolate.
    knots : array_like, shape (N + 1,) (N + 2 if closed), optional
        Increasing parameters u_i (default 0, 1, ...); a closed curve returns to a_0 at
        u_(N+1).
    nu : float or array_like, shape (N + 1,)
        Tensions ν_i >= 0 at the knots (for open curves the end values are not used).
    end_tangents : (b_0, b_N), optional
        Given end tangents of an open curve; by default natural ends (p'' = 0 there).
    closed : bool
        A closed curve: N + 1 arcs, G2 also where the last arc meets the first.

    Returns
    -------
    BSplineCurve
        Degree 3 with triple interior knots: each arc is one Bézier segment
        (a_i, a_i + h_i b_i / 3, a_(i+1) - h_i b_(i+1) / 3, a_(i+1)).
    """
    a = check_points(points, 1, "ν-spline", min_count=3 if closed else 2)
    n = a.shape[0] - 1
    u = _knots(knots, n + 2 if closed else n + 1, "knots")
    v = _tensions(nu, n + 1, "nu")
    ends = None
    if end_tangents is not None:
        if closed:
            raise GshadeError("end_tangents: a closed ν-spline has no ends")
        try:
            b0, bn = (np.asarray(b, dtype=np.float64) for b in end_tangents)
        except (TypeError, ValueError):
            raise GshadeError(
                f"end_tangents: expected two vectors of length {a.shape[1]}"
            ) from None
        if b0.shape != a.shape[1:] or bn.shape != a.shape[1:]:
            raise GshadeError(f"end_tangents: expected two vectors of length {a.shape[1]}")
        ends = (b0, bn)
    net, knot_vector = _nu_spline_net(a, u, v, ends, closed)
    return BSplineCurve(net, 3, knot_vector)


def _pair(value, name: str) -> tuple:
    """A (u, v) pair from one value for both directions or a pair."""
    if isinstance(value, np.ndarray) and value.ndim > 0:
        value = list(value)
    if isinstance(value, str) or not isinstance(value, Sequence):
        return value, value
    if len(value) != 2:
        raise GshadeError(f"{name}: expected one value or a (u, v) pair, got {_show(value)}")
    return value[0], value[1]


class NuSplinePatch(BSplinePatch):
    """Tensor-product ν-spline patch interpolating a grid of points (Kiciak §2.4).

    With the ν-spline operators L_u (knots u_i, tensions ν_u,i) and L_v, which map data
    points linearly to Bézier control points (:func:`nu_spline` is linear in its points for
    fixed knots and tensions), the bicubic Bézier net is L_u A L_v^T: every column of the
    grid A is interpolated in u, then every row of the result in v.  Hence p(u_i, v_j) = a_ij,
    every curve v = const is the ν-spline in u through the points c_i(v) = sum_j a_ij φ_j(v)
    (and symmetrically), so across the knot line u = u_i

        p_u(u_i+, v) = p_u(u_i-, v),   p_uu(u_i+, v) = p_uu(u_i-, v) + ν_u,i p_u(u_i, v),

    with p_v, p_uv, p_vv continuous: the equations of G2 continuity with connection
    functions α = 0, β = 1, γ = 0, δ = ν_u,i (not C2 where ν_u,i != 0).  ν = 0 everywhere
    gives the C2 bicubic interpolating spline.

    Parameters
    ----------
    points : array_like, shape (M + 1, N + 1, 3)
        The grid a_ij; i runs along u, j along v.
    knots_u, knots_v : array_like, optional
        Increasing interpolation knots: M + 1 (M + 2 if closed in u) and N + 1 (N + 2)
        numbers; default 0, 1, 2, ...
    nu_u, nu_v : float or array_like
        Tensions >= 0, one number or one per knot line (M + 1 and N + 1 numbers; the end
        values are not used unless the direction is closed).
    ends : str or (str, str)
        "natural" (p'' = 0 at the boundary, default) or "closed" (the grid wraps around),
        for both directions or as a (u, v) pair.

    Notes
    -----
    The patch is a :class:`BSplinePatch` of degree (3, 3) with triple interior knots, so it
    evaluates through the common ``derivatives(u, v, order)`` of every patch and has exact
    Bézier extraction (``bezier_patches``).
    """

    def __init__(
        self,
        points: ArrayLike,
        knots_u: ArrayLike | None = None,
        knots_v: ArrayLike | None = None,
        nu_u: ArrayLike = 0.0,
        nu_v: ArrayLike = 0.0,
        ends: str | tuple[str, str] = "natural",
    ) -> None:
        end_u, end_v = _pair(ends, "ends")
        for e in (end_u, end_v):
            if e not in ENDS:
                raise GshadeError(f"ends: expected one of {', '.join(ENDS)}, got {e!r}")
        closed = (end_u == "closed", end_v == "closed")
        A = check_points(points, 2, "ν-spline patch", min_count=2)
        m, n = A.shape[0] - 1, A.shape[1] - 1
        for direction, count, wrap in (("u", m + 1, closed[0]), ("v", n + 1, closed[1])):
            if wrap and count < 3:
                raise GshadeError(
                    f"points: a ν-spline patch closed in {direction} needs at least 3 points "
                    f"in that direction, got shape {A.shape}"
                )
        u = _knots(knots_u, m + 1 + closed[0], "knots_u")
        v = _knots(knots_v, n + 1 + closed[1], "knots_v")
        tu = _tensions(nu_u, m + 1, "nu_u")
        tv = _tensions(nu_v, n + 1, "nu_v")
        # columns in u (each of the N + 1 columns, 3 coordinates), then rows in v
        net_u, U = _nu_spline_net(A.reshape(m + 1, -1), u, tu, None, closed[0])
        net_u = net_u.reshape(-1, n + 1, 3).transpose(1, 0, 2).reshape(n + 1, -1)
        net, V = _nu_spline_net(net_u, v, tv, None, closed[1])
        net = net.reshape(net.shape[0], -1, 3).transpose(1, 0, 2)
        super().__init__(net, (3, 3), (U, V))
        self.grid = A
        self.interpolation_knots = (u, v)
        self.nu = (tu, tv)
        self.ends = (end_u, end_v)


# --------------------------------------------------------------------------- β-splines


def _shape_values(value, count: int, name: str, bias: bool, n_points: int) -> float | NDArray:
    """A global shape parameter (a float) or ``count`` per-junction values (an array)."""
    what = "> 0 (the bias)" if bias else ">= 0 (the tension)"
    per = (
        f"one per interior junction ({n_points} control points)"
        if count
        else f"but {n_points} control points have no interior junction"
    )
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, (Real, np.number)) and not isinstance(value, bool):
        x = float(value)
        if not (np.isfinite(x) and (x > 0 if bias else x >= 0)):
            raise GshadeError(f"{name}: expected a number {what}, got {_show(value)}")
        return x
    try:
        v = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        v = None
    if v is None or v.ndim != 1:
        raise GshadeError(
            f"{name}: expected a number {what} or a list of {count} such numbers ({per}), "
            f"got {_show(value)}"
        )
    if v.shape[0] != count or count == 0:
        raise GshadeError(
            f"{name}: expected a number {what} or a list of {count} such numbers ({per}), "
            f"got {v.shape[0]} numbers"
        )
    bad = ~(np.isfinite(v) & ((v > 0) if bias else (v >= 0)))
    if np.any(bad):
        j = int(np.flatnonzero(bad)[0])
        raise GshadeError(
            f"{name}: expected numbers {what}, got {float(v[j])!r} at junction {j + 1} (of {count})"
        )
    return v


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
    S = beta1.size - 3
    M = np.zeros((S, 4, 4))
    i = np.arange(S)
    k = i + 1  # index of arc i in s, r
    M[i, 1, 1], M[i, 1, 2] = 1 - s[k], s[k]
    M[i, 2, 1], M[i, 2, 2] = 1 - r[k], r[k]
    b_left, b_right = beta1[i + 1], beta1[i + 2]  # junctions i and i + 1
    M[i, 0, 0] = b_left * (1 - r[k - 1]) / (1 + b_left)
    M[i, 0, 1] = (b_left * r[k - 1] + 1 - s[k]) / (1 + b_left)
    M[i, 0, 2] = s[k] / (1 + b_left)
    M[i, 3, 1] = b_right * (1 - r[k]) / (1 + b_right)
    M[i, 3, 2] = (b_right * r[k] + 1 - s[k + 1]) / (1 + b_right)
    M[i, 3, 3] = s[k + 1] / (1 + b_right)
    return M


class BetaSplineBasis:
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

    degree = 3
    #: β1 and β2: one number each, or one per interior junction (``per_junction``)
    beta1: float | tuple[float, ...]
    beta2: float | tuple[float, ...]

    def __init__(
        self, n_points: int, beta1=1.0, beta2=0.0, names: tuple[str, str] = ("beta1", "beta2")
    ) -> None:
        if n_points < 4:
            raise GshadeError(f"points: a cubic β-spline needs at least 4, got {n_points}")
        self.n_points = n_points
        count = n_points - 4
        b1 = _shape_values(beta1, count, names[0], True, n_points)
        b2 = _shape_values(beta2, count, names[1], False, n_points)
        self.interval = (0.0, float(n_points - 3))
        segments = n_points - 3
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            self._build(b1, b2, count, segments)
        if not np.all(np.isfinite(self.segment_coefficients)):
            raise GshadeError(
                f"{names[0]}, {names[1]}: expected values small enough for a finite basis, got "
                f"{_show(beta1)} and {_show(beta2)}"
            )

    def _build(self, b1: float | NDArray, b2: float | NDArray, count: int, segments: int) -> None:
        """The per-arc coefficients, global (Barsky's closed form) or per junction."""
        if isinstance(b1, float) and isinstance(b2, float):
            self.beta1, self.beta2 = b1, b2
            self.per_junction = False
            self.coefficients = _global_coefficients(b1, b2)
            self.segment_coefficients = np.broadcast_to(self.coefficients, (segments, 4, 4))
        else:
            v1 = np.broadcast_to(b1, (count,)).astype(np.float64)
            v2 = np.broadcast_to(b2, (count,)).astype(np.float64)
            self.beta1, self.beta2 = tuple(map(float, v1)), tuple(map(float, v2))
            self.per_junction = True
            # junctions -1, 0 and S, S + 1 (beyond the ends) repeat the nearest interior one
            e1 = np.concatenate([[v1[0]] * 2, v1, [v1[-1]] * 2])
            e2 = np.concatenate([[v2[0]] * 2, v2, [v2[-1]] * 2])
            M = _segment_bezier_matrices(e1, e2)
            # basis function r of arc i: sum_k M[i, k, r] B_k(t), in powers of t
            self.segment_coefficients = np.einsum("ikr,kj->irj", M, _BERNSTEIN_TO_POWER)

    def bezier_matrices(self) -> NDArray:
        """M, shape (S, 4, 4): arc i's Bézier points are M[i] @ (d_i, .., d_(i+3))."""
        return np.einsum("irj,jk->ikr", self.segment_coefficients, _POWER_TO_BERNSTEIN)

    def bezier_operator(self) -> NDArray:
        """The (3S + 1, n) matrix from control points to the piecewise Bézier net."""
        M = self.bezier_matrices()
        S = M.shape[0]
        out = np.zeros((3 * S + 1, self.n_points))
        for i in range(S):
            out[3 * i : 3 * i + 4, i : i + 4] = M[i]  # the shared junction point: arc i's
        return out

    def bspline_knots(self) -> NDArray:
        """Knot vector of the same curve as a cubic B-spline with triple interior knots."""
        S = self.n_points - 3
        return np.concatenate([[0.0] * 4, np.repeat(np.arange(1.0, S), 3), [float(S)] * 4])

    def local(self, t: NDArray, order: int) -> tuple[NDArray, NDArray]:
        t = np.asarray(t, dtype=np.float64)
        seg = np.clip(np.floor(t), 0, self.n_points - 4).astype(np.intp)
        x = t - seg
        out = np.zeros((order + 1, t.size, 4))
        c = self.segment_coefficients[seg]  # (N, 4 basis functions, 4 powers)
        for k in range(min(order, 3) + 1):
            # Horner on each basis polynomial (derivative coefficients of order k in c)
            acc = np.zeros((t.size, 4))
            for power in range(3, -1, -1):
                acc = acc * x[:, None] + c[:, :, power]
            out[k] = acc
            c = np.concatenate([c[:, :, 1:] * np.arange(1, 4), np.zeros((*c.shape[:2], 1))], -1)
        return seg, out

    def dense(self, t: NDArray, order: int) -> NDArray:
        first, ders = self.local(t, order)
        out = np.zeros((order + 1, first.size, self.n_points))
        rows = np.arange(first.size)[:, None]
        out[:, rows, first[:, None] + np.arange(4)] = ders
        return out


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

    def __init__(self, points: ArrayLike, beta1=1.0, beta2=0.0) -> None:
        P = check_points(points, 1, "β-spline curve", min_count=4)
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

    def __init__(
        self,
        points: ArrayLike,
        beta1=1.0,
        beta2=0.0,
        *,
        beta1_u=None,
        beta2_u=None,
        beta1_v=None,
        beta2_v=None,
    ) -> None:
        P = check_points(points, 2, "β-spline patch", min_count=4)
        given = {"beta1": _pair(beta1, "beta1"), "beta2": _pair(beta2, "beta2")}
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
