"""Nielson's ν-splines: G2 interpolating cubics with tensions, and their tensor product.

A ν-spline through points a_i at knots u_i is C1 with p''(u_i+) = p''(u_i-) + ν_i p'(u_i)
(G2 with connection parameters t1 = 1, t2 = ν_i); its tangents solve a tridiagonal system
(:func:`nu_spline`).  ν = 0 gives the C2 interpolating cubic spline, large ν_i pull the
curve toward the polyline near a_i.  For fixed knots and tensions the curve is linear in
the points, so its tensor product interpolating a grid is well defined
(:class:`NuSplinePatch`).

References
----------
G. M. Nielson, "Some piecewise polynomial alternatives to splines under tension", in
R. E. Barnhill, R. F. Riesenfeld (eds.), *Computer Aided Geometric Design*, Academic Press
(1974), 209–235.  Kiciak §2.3.1 (curves, eq. 2.15) and §2.4 (patches).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...errors import GshadeError
from ..core.patch import show_value, validate_points, value_pair
from ..patches.bspline import BSplineCurve, BSplinePatch

__all__ = ["ENDS", "NuSplinePatch", "nu_spline"]

#: How a ν-spline patch ends in each direction.
ENDS = ("natural", "closed")


def _knots(knots: ArrayLike | None, count: int, name: str) -> NDArray:
    """``count`` increasing knots (default 0, 1, ..., count - 1)."""
    if knots is None:
        return np.arange(float(count))
    try:
        u = np.asarray(knots, dtype=np.float64)
    except (TypeError, ValueError):
        raise GshadeError(
            f"{name}: expected {count} increasing numbers, got {show_value(knots)}"
        ) from None
    if u.shape != (count,) or not np.all(np.isfinite(u)) or not np.all(np.diff(u) > 0):
        raise GshadeError(f"{name}: expected {count} increasing numbers, got {show_value(knots)}")
    return u


def _tensions(nu: ArrayLike, count: int, name: str) -> NDArray:
    """Tensions ν_i >= 0: one number for all knots or ``count`` numbers."""
    try:
        v = np.asarray(nu, dtype=np.float64)
    except (TypeError, ValueError):
        raise GshadeError(
            f"{name}: expected numbers >= 0: one number or a list of {count} (one per knot), "
            f"got {show_value(nu)}"
        ) from None
    if v.ndim > 1 or (v.ndim == 1 and v.shape[0] != count):
        raise GshadeError(
            f"{name}: expected numbers >= 0: one number or a list of {count} (one per knot), "
            f"got {v.size} numbers"
        )
    if not np.all(np.isfinite(v) & (v >= 0)):
        raise GshadeError(f"{name}: expected numbers >= 0 (tensions), got {show_value(nu)}")
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
    """Nielson's ν-spline through ``points`` as a piecewise cubic B-spline curve.

    The tangents b_i at the knots solve (Kiciak §2.3.1, eq. 2.15; Nielson 1974), with
    h_i = u_(i+1) - u_i::

        h_i b_(i-1) + (2 (h_(i-1) + h_i) + h_(i-1) h_i ν_i / 2) b_i + h_(i-1) b_(i+1)
            = 3 (h_i / h_(i-1) (a_i - a_(i-1)) + h_(i-1) / h_i (a_(i+1) - a_i)),

    i.e. p''(u_i+) = p''(u_i-) + ν_i p'(u_i): G2 with connection parameters t1 = 1, t2 = ν_i.
    The end rows are natural ends (p'' = 0), given end tangents, or the same equation
    taken cyclically (closed curves).

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
    a = validate_points(points, 1, "ν-spline", min_count=3 if closed else 2)
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
        end_u, end_v = value_pair(ends, "ends")
        for e in (end_u, end_v):
            if e not in ENDS:
                names = ", ".join(f'"{name}"' for name in ENDS)
                raise GshadeError(
                    f"ends: expected one of {names} or a pair [u, v] of them, got {e!r}"
                )
        closed = (end_u == "closed", end_v == "closed")
        A = validate_points(points, 2, "ν-spline patch", min_count=2)
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
