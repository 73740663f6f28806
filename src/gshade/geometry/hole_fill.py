"""G1 filling of an n-sided hole with n biquintic Bézier patches (Hahn's scheme).

The hole is a :class:`~gshade.geometry.hole.Hole`: n faces around an extraordinary vertex of
a Catmull–Clark mesh, surrounded by 2n bicubic patches.  It is filled with n tensor-product
Bézier patches P_0, ..., P_(n-1) of degree (5, 5), one per hole face, in the layout of Hahn
(1989; Kiciak 2016, §4.1).  The degrees are those of Kiciak's G1 hole filling in BSTools
(``eghole``, ``bookg1hole``: biquintic patches, quartic inner curves, filling a hole in a
surface of bicubic patches).

Parametrisation.  With hole face F_i = (v, e_i, f_i, e_(i+1)) (see :mod:`.hole`),

    P_i(0, 0) = centre,  P_i(1, 0) = e_i,  P_i(1, 1) = f_i,  P_i(0, 1) = e_(i+1),

so u runs along the EV's edge h_i and P_u x P_v points to the normal side.  The *outer
edges* lie on the hole's boundary,

    P_i(1, t) = b_(2i+1)(t),        P_u(1, t) = -d1_(2i+1)(t)       (segment e_i -> f_i),
    P_i(t, 1) = b_(2i+2)(1 - t),    P_v(t, 1) = -d1_(2i+2)(1 - t)   (segment f_i -> e_(i+1)),

a C1 join to the surrounding patches: in Bézier form the rows a = 4, 5 and the columns
b = 4, 5 of P_i's net are the degree-elevated cubic data.  The *inner edges* are shared,
E_i(t) = P_i(t, 0) = P_(i-1)(0, t) (nets: P_i[a, 0] = P_(i-1)[0, a]), and joined G1 by

    d/dv P_i(t, 0) + d/du P_(i-1)(0, t) = lambda(t) E_i'(t),
    lambda(t) = 2 cos(2 pi / n) (1 - t)^2,                                        (G1-in)

a fixed junction function, so that every condition is linear in the control points and the
same for x, y and z.  At t = 0 it makes the centre tangents E_i'(0) an affine image of the
regular n-gon; lambda(1) = lambda'(1) = 0 makes it agree with the C1 data at e_i (with a
linear lambda the system is inconsistent).  For n = 4 lambda = 0: the filling is C1.

Energy.  Among the fillings satisfying these conditions the one minimising

    F = sum_i int int |P_uu|^2 + 2 |P_uv|^2 + |P_vv|^2 du dv

is chosen.  F is a quadratic form x^T Q x in the control points, assembled exactly from the
Bernstein Gram matrices G_m[i, j] = int_0^1 B_i^m B_j^m = C(m,i) C(m,j) / ((2m+1) C(2m,i+j))
and the derivative operators on Bernstein coefficients.  The conditions are sampled at
Chebyshev points, enough for the polynomial identities to hold exactly, giving C x = r; the
minimiser is found in the null space of C (SVD, rank threshold), which tolerates the
redundant rows (among them the even-n vertex-enclosure condition at the centre).

References
----------
J. Hahn, "Filling polygonal holes with rectangular patches", in *Theory and Practice of
Geometric Modeling*, Springer (1989), 81–91.  P. Kiciak, *Geometric Continuity of Curves
and Surfaces* (2016), §4.1 (Hahn's scheme), §5.3 (constructions with functionals).
P. Kiciak, BSTools (LGPL), https://github.com/radek-p/BSTools, ``src/eghole`` and
``src/projects/bookg1holed.c`` (degrees of the patches; no code taken).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from .bernstein import bernstein_basis, derivative_matrix, elevate_degree, gram_matrix
from .bezier import BezierPatch
from .hole import Hole

__all__ = ["G1System", "fill_g1", "g1_system", "solve_qp"]

DEGREE = 5
#: Sample points per inner edge: (G1-in) has degree 6, so 7 suffice; more are harmless.
SAMPLES = 12
#: Largest residual |C x - r| (relative to the data's size) accepted by :func:`fill_g1`.
RESIDUAL_TOL = 1e-9


def patch_energy(m: int) -> NDArray[np.float64]:
    """Q with int int |P_uu|^2 + 2 |P_uv|^2 + |P_vv|^2 = sum_c X_c^T Q X_c for a patch of
    degree (m, m), X_c its net's coordinate c flattened row-major (index a (m + 1) + b)."""
    I = np.eye(m + 1)
    D1, D2 = derivative_matrix(m, 1), derivative_matrix(m, 2)
    G = {k: gram_matrix(k) for k in (m - 2, m - 1, m)}
    Q = np.zeros(((m + 1) ** 2,) * 2)
    for w, (A, ga), (B, gb) in (
        (1.0, (D2, m - 2), (I, m)),
        (2.0, (D1, m - 1), (D1, m - 1)),
        (1.0, (I, m), (D2, m - 2)),
    ):
        K = np.kron(A, B)
        Q += w * K.T @ np.kron(G[ga], G[gb]) @ K
    return Q


@dataclass(frozen=True)
class G1System:
    """The filling problem min x^T Q x subject to C x = r.

    Attributes
    ----------
    n : int
        Sides of the hole.
    C : ndarray, shape (rows, 36 n)
        Linear conditions on the unknowns: the nets of P_0, ..., P_(n-1), each flattened
        row-major (index 36 i + 6 a + b for P_i[a, b]); the same for every coordinate.
    r : ndarray, shape (rows, 3)
        Right-hand sides (one column per coordinate).
    Q : ndarray, shape (36 n, 36 n)
        The energy F = sum_c x_c^T Q x_c (block diagonal).
    """

    n: int
    C: NDArray[np.float64]
    r: NDArray[np.float64]
    Q: NDArray[np.float64]


def g1_system(hole: Hole, *, lambda_power: int = 2, samples: int = SAMPLES) -> G1System:
    """The conditions and the energy of the G1 filling of ``hole`` (module docstring).

    Parameters
    ----------
    hole : Hole
        The hole and its boundary data.
    lambda_power : int
        p in lambda(t) = 2 cos(2 pi / n) (1 - t)^p.  Only p = 2 gives a consistent system
        for n != 4 (p = 1 is there to show that).
    samples : int
        Chebyshev points per inner edge at which (G1-in) is imposed (>= 7).
    """
    n, m = hole.n, DEGREE
    size = (m + 1) ** 2
    N = n * size
    rows: list[NDArray[np.float64]] = []
    rhs: list[NDArray[np.float64]] = []

    def var(i: int, a: int, b: int) -> int:
        return (i % n) * size + a * (m + 1) + b

    def row(entries: dict[int, float] | None = None) -> NDArray[np.float64]:
        out = np.zeros(N)
        for k, w in (entries or {}).items():
            out[k] += w
        return out

    # outer edges: C1 to the surrounding patches
    boundary = elevate_degree(hole.boundary, m - 3, axis=1)
    cross = elevate_degree(hole.cross1, m - 3, axis=1)
    for i in range(n):
        ju, jv = 2 * i + 1, (2 * i + 2) % (2 * n)
        for b in range(m + 1):
            # u = 1: P(1, t) = b_ju(t), P_u(1, t) = -d1_ju(t)
            rows += [row({var(i, m, b): 1.0}), row({var(i, m - 1, b): 1.0})]
            rhs += [boundary[ju, b], boundary[ju, b] + cross[ju, b] / m]
            # v = 1: P(t, 1) = b_jv(1 - t), P_v(t, 1) = -d1_jv(1 - t)
            rows += [row({var(i, b, m): 1.0}), row({var(i, b, m - 1): 1.0})]
            rhs += [boundary[jv, m - b], boundary[jv, m - b] + cross[jv, m - b] / m]
    # inner edges: shared, and (G1-in)
    t = 0.5 - 0.5 * np.cos((2 * np.arange(samples) + 1) * np.pi / (2 * samples))
    B = bernstein_basis(m, t, 1)  # (2, samples, m + 1)
    lam = 2.0 * np.cos(2.0 * np.pi / n) * (1.0 - t) ** lambda_power
    zero = np.zeros(3)
    for i in range(n):
        for a in range(m + 1):
            rows.append(row({var(i, a, 0): 1.0, var(i - 1, 0, a): -1.0}))
            rhs.append(zero)
        for s in range(samples):
            r = np.zeros(N)
            for a in range(m + 1):
                # m sum_a B_a (P_i[a,1] - P_i[a,0]) + m sum_a B_a (P_(i-1)[1,a] - P_(i-1)[0,a])
                # - lambda sum_a B_a' P_i[a, 0] = 0
                w = m * B[0, s, a]
                r[var(i, a, 1)] += w
                r[var(i, a, 0)] -= w + lam[s] * B[1, s, a]
                r[var(i - 1, 1, a)] += w
                r[var(i - 1, 0, a)] -= w
            rows.append(r)
            rhs.append(zero)
    Q = np.asarray(np.kron(np.eye(n), patch_energy(m)), dtype=np.float64)
    return G1System(n, np.array(rows), np.array(rhs), Q)


def solve_qp(
    C: NDArray[np.float64], r: NDArray[np.float64], Q: NDArray[np.float64], rtol: float = 1e-10
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Minimise sum_c x_c^T Q x_c subject to C x = r by the null-space method.

    With C = U S V^T and rank k (singular values above ``rtol`` times the largest):
    x_p = C^+ r, Z = the last columns of V (a basis of ker C), and x = x_p + Z y with
    (Z^T Q Z) y = -Z^T Q x_p.

    Returns
    -------
    x : ndarray, shape (columns, 3)
        The minimiser (the least-squares solution of C x = r if that is inconsistent).
    Z : ndarray, shape (columns, columns - k)
        The null-space basis: the free parameters.
    residual : float
        max |C x - r|.
    """
    U, s, Vt = np.linalg.svd(C, full_matrices=True)
    k = int(np.sum(s > rtol * s[0]))
    xp = Vt[:k].T @ ((U[:, :k].T @ r) / s[:k, None])
    Z = Vt[k:].T
    if Z.shape[1]:
        H = Z.T @ Q @ Z
        xp = xp + Z @ np.linalg.solve(H, -Z.T @ Q @ xp)
    return xp, Z, float(np.abs(C @ xp - r).max())


def fill_g1(hole: Hole) -> tuple[BezierPatch, ...]:
    """The G1 filling of ``hole``: n biquintic Bézier patches (module docstring).

    P_i covers hole face F_i = (v, e_i, f_i, e_(i+1)): P_i(0, 0) is the centre,
    P_i(1, 0) = e_i, P_i(1, 1) = f_i, P_i(0, 1) = e_(i+1); P_i(t, 0) = P_(i-1)(0, t).
    It joins the surrounding patches C1 (the hole's ``boundary`` and ``cross1``), its
    neighbours G1 by (G1-in), and minimises the thin-plate-like energy among such fillings.

    Raises
    ------
    GshadeError
        If the conditions cannot be met (boundary data violating the corner compatibility
        conditions of :mod:`.hole`).
    """
    system = g1_system(hole)
    x, _, residual = solve_qp(system.C, system.r, system.Q)
    scale = max(1.0, float(np.abs(hole.boundary).max()))
    if residual > RESIDUAL_TOL * scale:
        raise GshadeError(
            f"hole around vertex {hole.vertex}: the G1 conditions are inconsistent "
            f"(residual {residual:.3g})"
        )
    nets = x.reshape(hole.n, DEGREE + 1, DEGREE + 1, 3).copy()
    # make the shared inner edges and the centre bitwise equal (they agree to rounding)
    for i in range(hole.n):
        edge = 0.5 * (nets[i, :, 0] + nets[i - 1, 0, :])
        nets[i, :, 0] = nets[i - 1, 0, :] = edge
    nets[:, 0, 0] = nets[:, 0, 0].mean(axis=0)
    return tuple(BezierPatch(net) for net in nets)
