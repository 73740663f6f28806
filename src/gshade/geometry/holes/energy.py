"""Quadratic fairing functionals of a hole's filling, integrated over a planar domain
(Kiciak 2016, §5.3).

A filling of an n-sided hole (:mod:`.hole_fill`) is n tensor-product Bézier patches
P_i(u, v) of degree (d, d).  Its shape is chosen by minimising a quadratic form in the
control points, the integral over a planar *domain* Omega of squared derivatives of the
surface p seen as a function of the domain's coordinates (x, y).  Two domains
(:data:`DOMAINS`):

- ``square`` (the default): each patch over its own unit square, (x, y) = (u, v), the
  parametric functional of Kiciak's biquintic construction (``bookg1hole``);
- ``sector``: the regular n-gon's star of sectors, patch i the image of

      D_i(u, v) = u e_i + v e_(i+1),    e_j = (cos 2 pi j / n, sin 2 pi j / n),

  (the directions of the centre tangents a G1 filling takes, up to an affine map), so that
  with J_i = [e_i e_(i+1)] the domain derivatives are [d_x; d_y] = J_i^-T [d_u; d_v] and
  dx dy = |det J_i| du dv = sin(2 pi / n) du dv.

For n = 4 the two agree.  The sector domain keeps the centre's symmetry, but its corners
f_i lie no farther out than the e_i for n = 3, and on holes with sharp corners it gives the
rounder surfaces' larger curvature; the square is the default.  The functionals (Kiciak's
BSTools ``eghole`` library names the second and fourth F_a and F_c):

- ``thin-plate``: int |p_xx|^2 + 2 |p_xy|^2 + |p_yy|^2 (the bending energy of a thin plate);
- ``laplacian``: int |p_xx + p_yy|^2;
- ``third-order``: int |p_xxx|^2 + 3 |p_xxy|^2 + 3 |p_xyy|^2 + |p_yyy|^2;
- ``laplacian-gradient``: int |d_x (p_xx + p_yy)|^2 + |d_y (p_xx + p_yy)|^2.

Each is sum_c x_c^T Q x_c over the coordinates c, Q block diagonal over the patches.  The
integrands are polynomials of degree <= 2d in u and in v, so Gauss–Legendre quadrature
with d + 1 points a direction integrates them exactly.

References
----------
P. Kiciak, *Geometric Continuity of Curves and Surfaces* (2016), §5.3.  P. Kiciak, BSTools
(LGPL), ``doc/English/eghole.tex`` (the functionals F_a, F_c; no code taken).
J. Duchon, "Splines minimizing rotation-invariant semi-norms in Sobolev spaces" (1977), for
the thin-plate energy.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from ...errors import GshadeError, one_of, show
from ..core.bernstein import bernstein_basis

__all__ = ["DOMAINS", "FUNCTIONALS", "Functional", "functional_matrix", "sector_jacobian"]

#: The domains the functionals are integrated over (module docstring).
DOMAINS = ("square", "sector")

# A linear differential operator in (d_x, d_y): {(a, b): coefficient of d_x^a d_y^b}.
_Operator = dict[tuple[int, int], float]


@dataclass(frozen=True)
class Functional:
    """A quadratic functional: sum of weight * int |L p|^2 over its terms (weight, L)."""

    name: str
    order: int
    description: str
    terms: tuple[tuple[float, _Operator], ...]


def _d(a: int, b: int) -> _Operator:
    return {(a, b): 1.0}


#: The functionals by name (module docstring).
FUNCTIONALS: dict[str, Functional] = {
    f.name: f
    for f in (
        Functional(
            "thin-plate",
            2,
            "int |p_xx|^2 + 2 |p_xy|^2 + |p_yy|^2",
            ((1.0, _d(2, 0)), (2.0, _d(1, 1)), (1.0, _d(0, 2))),
        ),
        Functional("laplacian", 2, "int |p_xx + p_yy|^2", ((1.0, {(2, 0): 1.0, (0, 2): 1.0}),)),
        Functional(
            "third-order",
            3,
            "int |p_xxx|^2 + 3 |p_xxy|^2 + 3 |p_xyy|^2 + |p_yyy|^2",
            ((1.0, _d(3, 0)), (3.0, _d(2, 1)), (3.0, _d(1, 2)), (1.0, _d(0, 3))),
        ),
        Functional(
            "laplacian-gradient",
            3,
            "int |grad (p_xx + p_yy)|^2",
            ((1.0, {(3, 0): 1.0, (1, 2): 1.0}), (1.0, {(2, 1): 1.0, (0, 3): 1.0})),
        ),
    )
}


def sector_jacobian(n: int, i: int) -> NDArray[np.float64]:
    """J_i = [e_i e_(i+1)], the Jacobian of patch i's domain map D_i (2 x 2, columns)."""
    angles = 2.0 * np.pi * np.array([i, i + 1]) / n
    return np.array([np.cos(angles), np.sin(angles)])


def _in_uv(op: _Operator, K: NDArray[np.float64]) -> _Operator:
    """The operator rewritten in (d_u, d_v), with d_x = K00 d_u + K01 d_v and
    d_y = K10 d_u + K11 d_v (K = J^-T)."""
    out: _Operator = {}
    for (a, b), c in op.items():
        poly: _Operator = {(0, 0): c}
        for row in [K[0]] * a + [K[1]] * b:
            nxt: _Operator = {}
            for (j, k), w in poly.items():
                nxt[(j + 1, k)] = nxt.get((j + 1, k), 0.0) + w * row[0]
                nxt[(j, k + 1)] = nxt.get((j, k + 1), 0.0) + w * row[1]
            poly = nxt
        for key, w in poly.items():
            out[key] = out.get(key, 0.0) + w
    return out


@lru_cache(maxsize=32)
def _patch_matrix(name: str, n: int, degree: int, domain: str) -> NDArray[np.float64]:
    """The functional's Q for one patch of the n-sided star (all patches have the same:
    the sectors are rotations of each other and the functionals rotation invariant)."""
    functional = FUNCTIONALS[name]
    J = sector_jacobian(n, 0) if domain == "sector" else np.eye(2)
    K = np.linalg.inv(J).T
    area = abs(float(np.linalg.det(J)))
    x, w = np.polynomial.legendre.leggauss(degree + 1)
    t, w = 0.5 * (x + 1.0), 0.5 * w
    B = bernstein_basis(degree, t, functional.order)  # (order + 1, q, d + 1)
    weights = np.outer(w, w).ravel() * area
    size = (degree + 1) ** 2
    Q = np.zeros((size, size))
    for weight, op in functional.terms:
        A = np.zeros((t.size**2, size))
        for (j, k), c in _in_uv(op, K).items():
            A += c * np.kron(B[j], B[k])
        Q += weight * A.T @ (weights[:, None] * A)
    Q = 0.5 * (Q + Q.T)
    Q.flags.writeable = False
    return Q


def functional_matrix(
    name: str, n: int, degree: int, domain: str = "square"
) -> NDArray[np.float64]:
    """Q with F = sum_c x_c^T Q x_c for the functional ``name`` of a filling of n patches of
    degree (degree, degree), x_c the nets' coordinate c (index (degree + 1)^2 i +
    (degree + 1) a + b for P_i[a, b]).

    Raises
    ------
    GshadeError
        For an unknown functional or domain, or a functional of higher order than the
        degree.
    """
    if domain not in DOMAINS:
        raise GshadeError(f"domain: expected {one_of(DOMAINS)}, got {show(domain)}")
    if name not in FUNCTIONALS:
        raise GshadeError(f"functional: expected {one_of(tuple(FUNCTIONALS))}, got {show(name)}")
    if FUNCTIONALS[name].order > degree:
        raise GshadeError(
            f"functional: {name} has order {FUNCTIONALS[name].order}, more than the patches' "
            f"degree {degree}"
        )
    return np.asarray(np.kron(np.eye(n), _patch_matrix(name, n, degree, domain)), dtype=np.float64)
