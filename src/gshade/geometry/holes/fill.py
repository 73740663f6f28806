"""G1 and G2 filling of an n-sided hole with n Bézier patches (Hahn's scheme).

The hole is a :class:`~gshade.geometry.holes.ring.Hole`: n faces around an extraordinary vertex of
a Catmull–Clark mesh, surrounded by 2n bicubic patches.  It is filled with n tensor-product
Bézier patches P_0, ..., P_(n-1) of degree (d, d), one per hole face, in the layout of Hahn
(1989; Kiciak 2016, §4.1): d = 5 for G1, d = 9 for G2, the degrees of Kiciak's G1 and G2
hole fillings in BSTools (``eghole``, ``bookg1hole``).

Parametrisation.  With hole face F_i = (v, e_i, f_i, e_(i+1)) (see :mod:`.hole`),

    P_i(0, 0) = centre,  P_i(1, 0) = e_i,  P_i(1, 1) = f_i,  P_i(0, 1) = e_(i+1),

so u runs along the EV's edge h_i and P_u x P_v points to the normal side.

Outer edges.  They lie on the hole's boundary and join the surrounding patches C1 (G1) or
C2 (G2): with the hole's boundary data b_j, d1_j, d2_j,

    P_i(1, t) = b_(2i+1)(t),  -P_u(1, t) = d1_(2i+1)(t),  P_uu(1, t) = d2_(2i+1)(t),
    P_i(t, 1) = b_(2i+2)(1-t),  -P_v(t, 1) = d1_(2i+2)(1-t),  P_vv(t, 1) = d2_(2i+2)(1-t);

in Bézier form the last two (three) rows and columns of P_i's net are fixed by the
degree-elevated cubic data.

Inner edges.  They are shared, E_i(t) = P_i(t, 0) = P_(i-1)(0, t), and joined by the
reparametrisation (u, v) = (t + lambda(t) s, -s) + O(s^2) of Kiciak's Ch. 3 (BOOK_NOTES:
p*_v = alpha p_u + beta p_v with alpha = lambda, beta = -1; gamma = delta = 0 at second order):

    G1:  d_u P_(i-1)(0, t) = lambda(t) P_i,u(t, 0) - P_i,v(t, 0),                 (G1-in)
    G2:  d_uu P_(i-1)(0, t) = lambda^2 P_i,uu - 2 lambda P_i,uv + P_i,vv  at (t, 0), (G2-in)

with a fixed *junction function* lambda(t) = 2 cos(2 pi / n) h(t), so that every condition
is linear in the control points and the same for x, y and z:

- G1: h(t) = (1 - t)^2;
- G2: h(t) = (1 - t)^3 (1 + 3t).

Why these.  At t = 0, (G1-in) makes the centre tangents E_i'(0) an affine image of the
regular n-gon (e_(i+1) + e_(i-1) = 2 cos(2 pi / n) e_i), the tangent plane's compatibility
condition (Kiciak §4.3).  At t = 1 the inner edge ends at a regular vertex of the
surroundings, where the junction is C1 (C2): h must vanish there to first (second) order,
else the corner conditions contradict the boundary data (with h = 1 - t the G1 system is
inconsistent).  For G2 the higher-order compatibility at the centre matters too: with
h = (1 - t)^3 and gamma = delta = 0 the system is solvable, but for n = 3 only with all
centre tangents zero (a singular point).  h = (1 - t)^3 (1 + 3t) has h'(0) = 0: near the
centre the junctions are those of the planar star of sectors (a linear reparametrisation,
lambda constant), which is regular, so the conditions at the centre admit a regular jet for
every n; the system is consistent at degree 8 and 9 for n = 3..12 (degree 7: not for
n >= 5).  For even n the circulant of the centre conditions is singular and its
solvability condition (the vertex enclosure constraint, Peters 1991) is among the rows.
For n = 4, lambda = 0: the filling is C1 (C2).

Shape.  Among the fillings meeting these conditions the one minimising a quadratic
functional (:mod:`.hole_energy`; book §5.3) is chosen.  The conditions are sampled at
Chebyshev points, enough for the polynomial identities to hold exactly, giving C x = r; the
minimiser is found in the null space of C (SVD, rank threshold), which tolerates the
redundant rows.  Optionally a nonlinear measure on the surface is then lowered within the
same null space (:mod:`gshade.geometry.holes.fairing`; book §5.4).

References
----------
J. Hahn, "Filling polygonal holes with rectangular patches", in *Theory and Practice of
Geometric Modeling*, Springer (1989), 81–91.  P. Kiciak, *Geometric Continuity of Curves
and Surfaces* (2016), Ch. 3 (junctions), §4.1 (Hahn's scheme), §4.3 (compatibility at the
centre), §5.3 (constructions with functionals).  J. Peters, "Smooth interpolation of a mesh
of curves", *Constructive Approximation* 7 (1991), 221–246 (vertex enclosure).  P. Kiciak,
BSTools (LGPL), https://github.com/radek-p/BSTools, ``src/eghole`` and
``src/projects/bookg1holed.c`` (degrees of the patches; no code taken).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...errors import GshadeError, one_of, show
from ..core.bernstein import bernstein_basis, elevate_degree
from ..core.blas_threads import single_threaded_blas
from ..patches.bezier import BezierPatch
from .energy import FUNCTIONALS, functional_matrix
from .ring import Hole

__all__ = [
    "JUNCTIONS",
    "HoleFilling",
    "HoleSystem",
    "Junctions",
    "fill_hole",
    "filling_patches",
    "hole_system",
    "solve_qp",
]

#: Largest residual |C x - r| (relative to the data's size) accepted by :func:`fill_hole`.
RESIDUAL_TOL = 1e-9
#: Singular values of C below this times the largest count as zero (the rank).
RANK_TOL = 1e-10


@dataclass(frozen=True)
class Junctions:
    """How a filling of the given continuity is built: patch degree, the order of the
    junction conditions, the profile h of the junction function lambda = 2 cos(2 pi/n) h,
    and the default functional."""

    continuity: str
    degree: int
    order: int
    profile: Callable[[NDArray[np.float64]], NDArray[np.float64]]
    functional: str


#: The fillings by continuity (module docstring).
JUNCTIONS: dict[str, Junctions] = {
    "G1": Junctions("G1", 5, 1, lambda t: (1.0 - t) ** 2, "thin-plate"),
    "G2": Junctions("G2", 9, 2, lambda t: (1.0 - t) ** 3 * (1.0 + 3.0 * t), "third-order"),
}


@dataclass(frozen=True)
class HoleSystem:
    """The conditions C x = r on a filling of n patches of degree (degree, degree).

    Attributes
    ----------
    C : ndarray, shape (rows, n (degree + 1)^2)
        Linear conditions on the unknowns: the nets of P_0, ..., P_(n-1), each flattened
        row-major (index (degree + 1)^2 i + (degree + 1) a + b for P_i[a, b]); the same for
        every coordinate.
    r : ndarray, shape (rows, 3)
        Right-hand sides (one column per coordinate).
    """

    n: int
    continuity: str
    degree: int
    C: NDArray[np.float64]
    r: NDArray[np.float64]


def _continuity(continuity: str) -> Junctions:
    if continuity not in JUNCTIONS:
        expected = one_of(tuple(JUNCTIONS))
        raise GshadeError(f"continuity: expected {expected}, got {show(continuity)}")
    return JUNCTIONS[continuity]


def _add(rows: NDArray[np.float64], column: np.integer, values: NDArray[np.float64]) -> None:
    rows[:, column] += values


def _outer_unknowns(n: int, d: int, order: int) -> list[tuple[int, int, int, int]]:
    """The unknowns the outer edges fix, and where each value comes from: (unknown, k, j,
    b) for the k-th net row from the edge, b-th point of segment j's data (module
    docstring: rows a = d - k of P_i against segment 2i + 1, columns b = d - k against
    segment 2i + 2, reversed)."""
    var = np.arange(n * (d + 1) ** 2).reshape(n, d + 1, d + 1)
    out = []
    for i in range(n):
        ju, jv = 2 * i + 1, (2 * i + 2) % (2 * n)
        for k in range(order + 1):
            for b in range(d + 1):
                out.append((int(var[i, d - k, b]), k, ju, b))
                out.append((int(var[i, b, d - k]), k, jv, d - b))
    return out


def _conditions(
    n: int, d: int, order: int, profile: Callable[[NDArray[np.float64]], NDArray[np.float64]]
) -> NDArray[np.float64]:
    """C: the fixed unknowns of the outer edges (identity rows, in :func:`_outer_unknowns`'
    order), then the inner edges' conditions.  It depends on n, the degree, the order and
    the junction function only, not on the hole's data."""
    size = (d + 1) ** 2
    var = np.arange(n * size).reshape(n, d + 1, d + 1)  # var[i, a, b]: unknown of P_i[a, b]
    fixed = [k for k, _, _, _ in _outer_unknowns(n, d, order)]

    # inner edges: shared nets, then (G1-in) and (G2-in) at Chebyshev points
    samples = 2 * d + 8
    t = 0.5 - 0.5 * np.cos((2 * np.arange(samples) + 1) * np.pi / (2 * samples))
    B = bernstein_basis(d, t, 2)  # (3, samples, d + 1)
    lam = 2.0 * math.cos(2.0 * math.pi / n) * profile(t)
    blocks = []
    for i in range(n):
        Pi, Pj = var[i], var[i - 1]  # P_i, and P_(i-1) across E_i
        rows = np.zeros((d + 1, n * size))
        rows[np.arange(d + 1), Pi[:, 0]] = 1.0
        rows[np.arange(d + 1), Pj[0, :]] -= 1.0
        blocks.append(rows)
        # d_u P_(i-1)(0, t) - lambda P_i,u(t, 0) + P_i,v(t, 0) = 0
        rows = np.zeros((samples, n * size))
        w = d * B[0]
        for a in range(d + 1):
            _add(rows, Pj[1, a], w[:, a])
            _add(rows, Pj[0, a], -w[:, a])
            _add(rows, Pi[a, 0], -lam * B[1, :, a] - w[:, a])
            _add(rows, Pi[a, 1], w[:, a])
        blocks.append(rows)
        if order < 2:
            continue
        # d_uu P_(i-1)(0, t) - lambda^2 P_i,uu + 2 lambda P_i,uv - P_i,vv = 0
        rows = np.zeros((samples, n * size))
        w2, w1 = d * (d - 1) * B[0], d * B[1]
        for a in range(d + 1):
            for c, coef in enumerate((1.0, -2.0, 1.0)):
                _add(rows, Pj[c, a], coef * w2[:, a])
                _add(rows, Pi[a, c], -coef * w2[:, a])
            _add(rows, Pi[a, 0], -(lam**2) * B[2, :, a] - 2 * lam * w1[:, a])
            _add(rows, Pi[a, 1], 2 * lam * w1[:, a])
        blocks.append(rows)
    given = np.zeros((len(fixed), n * size))
    given[np.arange(len(fixed)), fixed] = 1.0
    return np.concatenate([given, *blocks])


def _right_hand_side(hole: Hole, d: int, order: int, rows: int) -> NDArray[np.float64]:
    """r: the outer edges' fixed values (the degree-elevated boundary data, C^order), then
    zeros for the inner edges' ``rows - len(fixed)`` conditions."""
    data = [elevate_degree(x, d - 3, axis=1) for x in (hole.boundary, hole.cross1, hole.cross2)]
    from_edge = [data[0], data[0] + data[1] / d]  # the k-th net row from the edge
    from_edge.append(data[2] / (d * (d - 1)) - from_edge[0] + 2.0 * from_edge[1])
    fixed = np.array([from_edge[k][j, b] for _, k, j, b in _outer_unknowns(hole.n, d, order)])
    return np.concatenate([fixed, np.zeros((rows - len(fixed), 3))])


@single_threaded_blas
def hole_system(
    hole: Hole,
    continuity: str = "G1",
    *,
    profile: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None,
    degree: int | None = None,
) -> HoleSystem:
    """The conditions of the ``continuity`` filling of ``hole`` (module docstring).

    Parameters
    ----------
    hole : Hole
        The hole and its boundary data.
    continuity : {"G1", "G2"}
    profile : callable, optional
        h in lambda(t) = 2 cos(2 pi / n) h(t), instead of the continuity's own (to show
        that other choices fail).
    degree : int, optional
        The patches' degree, instead of the continuity's own.
    """
    kind = _continuity(continuity)
    d = degree or kind.degree
    if profile is None and d == kind.degree:
        C = _factored(hole.n, continuity).C
    else:
        C = _conditions(hole.n, d, kind.order, profile or kind.profile)
    return HoleSystem(hole.n, continuity, d, C, _right_hand_side(hole, d, kind.order, len(C)))


@dataclass(frozen=True)
class _Factorisation:
    """C = U S V^T cut to its rank k: what :func:`solve_qp` needs of C."""

    C: NDArray[np.float64]
    U: NDArray[np.float64]  # the first k columns
    s: NDArray[np.float64]  # the k singular values above the threshold
    Vt: NDArray[np.float64]  # the first k rows
    Z: NDArray[np.float64]  # the last columns of V: a basis of ker C


def _factor(C: NDArray[np.float64], rtol: float) -> _Factorisation:
    U, s, Vt = np.linalg.svd(C, full_matrices=True)
    k = int(np.sum(s > rtol * s[0]))
    return _Factorisation(C, U[:, :k], s[:k], Vt[:k], Vt[k:].T)


@lru_cache(maxsize=32)
def _factored(n: int, continuity: str) -> _Factorisation:
    """The conditions of an n-sided ``continuity`` filling, factored once: they do not
    depend on the hole's data (only the right-hand side does)."""
    kind = JUNCTIONS[continuity]
    factored = _factor(_conditions(n, kind.degree, kind.order, kind.profile), RANK_TOL)
    for a in (factored.C, factored.U, factored.s, factored.Vt, factored.Z):
        a.flags.writeable = False
    return factored


def _minimiser(
    f: _Factorisation, r: NDArray[np.float64], Q: NDArray[np.float64]
) -> tuple[NDArray[np.float64], float]:
    """x_p = C^+ r moved within ker C to the minimum of x^T Q x, and max |C x - r|."""
    xp = f.Vt.T @ ((f.U.T @ r) / f.s[:, None])
    if f.Z.shape[1]:
        H = f.Z.T @ Q @ f.Z
        xp = xp + f.Z @ np.linalg.solve(H, -f.Z.T @ Q @ xp)
    return xp, float(np.abs(f.C @ xp - r).max())


@single_threaded_blas
def solve_qp(
    C: NDArray[np.float64],
    r: NDArray[np.float64],
    Q: NDArray[np.float64],
    rtol: float = RANK_TOL,
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
    f = _factor(C, rtol)
    x, residual = _minimiser(f, r, Q)
    return x, f.Z, residual


@dataclass(frozen=True)
class HoleFilling:
    """A filled hole.

    Attributes
    ----------
    patches : tuple of BezierPatch
        P_0, ..., P_(n-1) (module docstring): P_i(0, 0) the centre, P_i(1, 0) = e_i,
        P_i(1, 1) = f_i, P_i(0, 1) = e_(i+1), P_i(t, 0) = P_(i-1)(0, t).
    continuity, functional, domain : str
        How it was made.
    residual : float
        max |C x - r| of the junction conditions, relative to the data's size.
    energy : float
        The functional's value sum_c x_c^T Q x_c at the quadratic solution.
    nets : ndarray, shape (n (d + 1)^2, 3)
        The patches' control points x (as in :class:`HoleSystem`).
    free_basis : ndarray, shape (n (d + 1)^2, k)
        A basis Z of the conditions' null space: every x + Z Y meets them (C Z = 0).
    fairing : FairingReport or None
        The report of a nonlinear optimisation that moved ``nets`` within that space
        (:func:`gshade.geometry.holes.fairing_cache.optimise_filling`), or None.
    """

    patches: tuple[BezierPatch, ...]
    continuity: str
    functional: str
    domain: str
    residual: float
    energy: float
    nets: NDArray[np.float64]
    free_basis: NDArray[np.float64]
    fairing: Any = None

    @property
    def degree(self) -> int:
        """The patches' degree in each direction."""
        return int(self.patches[0].degree[0])

    @property
    def free(self) -> int:
        """Free parameters per coordinate (the null space's dimension)."""
        return int(self.free_basis.shape[1])


@single_threaded_blas
def fill_hole(
    hole: Hole,
    continuity: str = "G1",
    functional: str | None = None,
    *,
    domain: str = "square",
) -> HoleFilling:
    """Fill ``hole`` with n Bézier patches joined G1 or G2 (module docstring).

    Parameters
    ----------
    hole : Hole
    continuity : {"G1", "G2"}
        G1: biquintic patches, C1 to the surroundings; G2: degree (9, 9), C2 to them.
    functional : str, optional
        The quadratic functional minimised (:data:`.hole_energy.FUNCTIONALS`); default
        ``thin-plate`` for G1, ``third-order`` for G2.
    domain : {"square", "sector"}
        The domain it is integrated over (:data:`.hole_energy.DOMAINS`).

    Raises
    ------
    GshadeError
        For unknown names, or if the conditions cannot be met (boundary data violating the
        corner compatibility conditions of :mod:`.hole`).
    """
    kind = _continuity(continuity)
    functional = kind.functional if functional is None else functional
    if functional not in FUNCTIONALS:
        expected = one_of(tuple(FUNCTIONALS))
        raise GshadeError(f"functional: expected {expected}, got {show(functional)}")
    factored = _factored(hole.n, continuity)
    Q = functional_matrix(functional, hole.n, kind.degree, domain)
    r = _right_hand_side(hole, kind.degree, kind.order, len(factored.C))
    x, residual = _minimiser(factored, r, Q)
    scale = max(1.0, float(np.abs(hole.boundary).max()))
    if residual > RESIDUAL_TOL * scale:
        raise GshadeError(
            f"hole around vertex {hole.vertex}: the {continuity} conditions are inconsistent "
            f"(residual {residual:.3g})"
        )
    return HoleFilling(
        patches=filling_patches(x, hole.n, kind.degree),
        continuity=continuity,
        functional=functional,
        domain=domain,
        residual=residual / scale,
        energy=float(np.einsum("ic,ij,jc->", x, Q, x)),
        nets=x,
        free_basis=factored.Z,
    )


def filling_patches(x: NDArray[np.float64], n: int, degree: int) -> tuple[BezierPatch, ...]:
    """The patches P_0, ..., P_(n-1) of the nets x (shape (n (degree + 1)^2, 3)), their
    shared inner edges and the centre made bitwise equal (they agree to rounding)."""
    nets = x.reshape(n, degree + 1, degree + 1, 3).copy()
    for i in range(n):
        edge = 0.5 * (nets[i, :, 0] + nets[i - 1, 0, :])
        nets[i, :, 0] = nets[i - 1, 0, :] = edge
    nets[:, 0, 0] = nets[:, 0, 0].mean(axis=0)
    return tuple(BezierPatch(net) for net in nets)
