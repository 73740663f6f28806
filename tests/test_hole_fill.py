"""G1 filling of n-sided holes (gshade.geometry.hole_fill), against independent checks.

Oracles: the surrounding bicubic patches' own exact derivatives (outer edges), the filling
patches' exact derivatives (normals across inner edges, the centre), Gauss–Legendre
quadrature of the energy, numerical integration of Bernstein products, and for n = 4 the
exact bicubic Catmull–Clark patches of the hole's faces.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from gshade.analysis.continuity import continuity_report
from gshade.geometry.bernstein import bernstein_basis, derivative_matrix, gram_matrix
from gshade.geometry.bezier import BezierPatch
from gshade.geometry.catmull_clark import regular_patch
from gshade.geometry.hole import find_holes, hole_around
from gshade.geometry.hole_fill import fill_g1, g1_system, solve_qp
from gshade.geometry.quad_mesh import MeshTopology

from .test_hole import wavy_fan
from .test_subdivision import grid_mesh

T = np.linspace(0.0, 1.0, 21)[1:]  # 20 points per edge, the centre apart
FREE = {3: 24, 4: 36, 5: 38, 6: 45, 8: 59}  # free parameters per coordinate
CASES = [(3, 3), (5, 3), (6, 3), (8, 3), (5, 2), (4, 0)]


def grid_hole():
    V, F = grid_mesh(6, 6, lambda i, j: (i, j, np.sin(i) * np.cos(0.7 * j)))
    topo = MeshTopology(np.asarray(F), len(V))
    return hole_around(V, topo, 3 * 7 + 3), topo


@pytest.fixture(scope="module", params=CASES, ids=[f"n{n}-rings{r}" for n, r in CASES])
def case(request):
    n, rings = request.param
    if n == 4:
        hole, _ = grid_hole()
    else:
        (hole,) = find_holes(*wavy_fan(n, rings))
    start = time.perf_counter()
    fill = fill_g1(hole)
    elapsed = time.perf_counter() - start
    assert hole.n == n and len(fill) == n
    return hole, fill, elapsed


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def normals(patch, u, v):
    d = patch.derivatives(u, v, 1)
    return unit(np.cross(d[1, 0], d[0, 1]))


def energy(patches, points=12):
    """sum int int |P_uu|^2 + 2 |P_uv|^2 + |P_vv|^2 by Gauss–Legendre quadrature (exact)."""
    x, w = np.polynomial.legendre.leggauss(points)
    x, w = (x + 1) / 2, w / 2
    u, v = np.meshgrid(x, x, indexing="ij")
    W = np.outer(w, w)[..., None]
    total = 0.0
    for p in patches:
        d = p.derivatives(u, v, 2)
        total += float(np.sum(W * (d[2, 0] ** 2 + 2 * d[1, 1] ** 2 + d[0, 2] ** 2)))
    return total


# --------------------------------------------------------------------------- helpers


@pytest.mark.parametrize("m", [1, 3, 5])
def test_gram_matrix_is_the_integral_of_bernstein_products(m):
    x, w = np.polynomial.legendre.leggauss(m + 2)
    B = bernstein_basis(m, (x + 1) / 2)[0]
    np.testing.assert_allclose(gram_matrix(m), (B.T * w / 2) @ B, atol=1e-15)


@pytest.mark.parametrize(("m", "order"), [(5, 1), (5, 2), (4, 3)])
def test_derivative_matrix_differentiates(m, order):
    t = np.linspace(0, 1, 7)
    c = np.random.default_rng(m).normal(size=m + 1)
    exact = bernstein_basis(m, t, order)[order] @ c
    np.testing.assert_allclose(
        bernstein_basis(m - order, t)[0] @ (derivative_matrix(m, order) @ c), exact, atol=1e-12
    )


# --------------------------------------------------------------------------- constraints


def test_the_fill_is_biquintic_with_a_common_centre(case):
    _, fill, _ = case
    assert all(p.degree == (5, 5) for p in fill)
    centre = np.array([p.points[0, 0] for p in fill])
    np.testing.assert_array_equal(centre, np.broadcast_to(centre[0], centre.shape))


def test_outer_edges_are_the_boundary_and_join_c1(case):
    hole, fill, _ = case
    n, one = hole.n, np.ones_like(T)
    for i, p in enumerate(fill):
        # u = 1 against S_(2i+1), e_i -> f_i: S(0, t) = P(1, t), -S_u(0, t) = -P_u(1, t)
        s = hole.patches[2 * i + 1].derivatives(0 * T, T, 1)
        d = p.derivatives(one, T, 1)
        np.testing.assert_allclose(d[0, 0], s[0, 0], atol=1e-10)
        np.testing.assert_allclose(d[1, 0], s[1, 0], atol=1e-9)
        # v = 1 against S_(2i+2), f_i -> e_(i+1): S(0, t) = P(1 - t, 1), S_u(0, t) = P_v
        s = hole.patches[(2 * i + 2) % (2 * n)].derivatives(0 * T, 1 - T, 1)
        d = p.derivatives(T, one, 1)
        np.testing.assert_allclose(d[0, 0], s[0, 0], atol=1e-10)
        np.testing.assert_allclose(d[0, 1], s[1, 0], atol=1e-9)


def test_inner_edges_are_shared(case):
    _, fill, _ = case
    for i, p in enumerate(fill):
        q = fill[i - 1]
        np.testing.assert_allclose(p(T, 0 * T), q(0 * T, T), atol=1e-10)


# --------------------------------------------------------------------------- G1


def test_g1_across_inner_edges(case):
    _, fill, _ = case
    for i, p in enumerate(fill):
        a, b = normals(p, T, 0 * T), normals(fill[i - 1], 0 * T, T)
        assert np.abs(a - b).max() < 1e-9


def test_g1_across_outer_edges(case):
    hole, fill, _ = case
    n, one = hole.n, np.ones_like(T)
    for i, p in enumerate(fill):
        s = hole.patches[2 * i + 1]
        assert np.abs(normals(p, one, T) - normals(s, 0 * T, T)).max() < 1e-9
        s = hole.patches[(2 * i + 2) % (2 * n)]
        assert np.abs(normals(p, T, one) - normals(s, 0 * T, 1 - T)).max() < 1e-9


def test_the_centre_is_regular(case):
    hole, fill, _ = case
    z = np.zeros(1)
    tangents = np.array([p.derivatives(z, z, 1)[1, 0, 0] for p in fill])  # E_i'(0)
    s = np.linalg.svd(tangents, compute_uv=False)
    # rank 2: the tangents are an affine image of the regular n-gon (G1-in at t = 0),
    # a non-degenerate one (a similarity would give s[1] / s[0] = 1)
    assert s[2] < 1e-10 * s[0]
    assert s[1] > 0.2 * s[0]
    nrm = np.array([normals(p, z, z)[0] for p in fill])
    assert np.abs(nrm - nrm[0]).max() < 1e-9
    # the normal is that of the tangent plane, pointing like the surroundings' normals
    assert np.abs(tangents @ nrm[0]).max() < 1e-9 * s[0]
    out = normals(hole.patches[1], z, z)[0]
    assert nrm[0] @ out > 0


def test_the_energy_is_minimal_in_the_null_space(case):
    hole, fill, _ = case
    system = g1_system(hole)
    x = np.concatenate([p.points.reshape(-1, 3) for p in fill])
    assert np.abs(system.C @ x - system.r).max() < 1e-10
    _, s, Vt = np.linalg.svd(system.C)
    Z = Vt[int(np.sum(s > 1e-10 * s[0])) :].T
    assert Z.shape[1] == FREE[hole.n]
    rng = np.random.default_rng(hole.n)
    f0 = energy(fill)
    for _ in range(3):
        dz = Z @ rng.normal(size=(Z.shape[1], 3))
        dz *= 1e-3 * np.abs(x).max() / np.abs(dz).max()

        def moved(sign, dz=dz):
            nets = (x + sign * dz).reshape(hole.n, 6, 6, 3)
            return [BezierPatch(net) for net in nets]

        plus, minus = energy(moved(1)), energy(moved(-1))
        assert plus > f0 and minus > f0
        # stationary: the first-order change vanishes against the second-order one
        assert abs(plus - minus) < 1e-6 * (plus + minus - 2 * f0)
        # a null-space move keeps the filling G1
        p = moved(1)
        for i in range(hole.n):
            assert np.abs(normals(p[i], T, 0 * T) - normals(p[i - 1], 0 * T, T)).max() < 1e-9


def test_the_energy_matrix_is_the_integral(case):
    hole, fill, _ = case
    Q = g1_system(hole).Q
    x = np.concatenate([p.points.reshape(-1, 3) for p in fill])
    assert np.einsum("ic,ij,jc->", x, Q, x) == pytest.approx(energy(fill), rel=1e-12)


@pytest.mark.parametrize("n", [3, 5, 6, 8])
def test_a_linear_junction_function_is_inconsistent(n):
    (hole,) = find_holes(*wavy_fan(n, 3))
    for power, bad in ((1, True), (2, False)):
        system = g1_system(hole, lambda_power=power)
        _, _, residual = solve_qp(system.C, system.r, system.Q)
        assert (residual > 1e-6) == bad


def test_inner_edges_are_g1_but_not_g2(case):
    """gshade's own classification: G1 across the inner edges; curvature jumps there for
    n != 4 (lambda' != 0); for n = 4 (C1 conditions) at least G1."""
    hole, fill, _ = case
    pairs = [(i, "v0", (i - 1) % hole.n, "u0") for i in range(hole.n)]
    report = continuity_report(list(fill), pairs=pairs)
    allowed = {"G1", "G2", "G3"} if hole.n == 4 else {"G1"}
    assert {j.cls for j in report} <= allowed


# --------------------------------------------------------------------------- n = 4


def test_a_regular_hole_admits_its_own_bicubic_patches():
    hole, topo = grid_hole()
    true = [regular_patch(hole.points, topo, int(h)).elevated((5, 5)) for h in hole.half_edges]
    system = g1_system(hole)
    x = np.concatenate([p.points.reshape(-1, 3) for p in true])
    assert np.abs(system.C @ x - system.r).max() < 1e-10
    # and the filling is C1 across the inner edges
    fill = fill_g1(hole)
    for i, p in enumerate(fill):
        dv = p.derivatives(T, 0 * T, 1)[0, 1]
        du = fill[i - 1].derivatives(0 * T, T, 1)[1, 0]
        np.testing.assert_allclose(dv, -du, atol=1e-9)


def test_fill_is_fast(case):
    _, _, elapsed = case
    assert elapsed < 5.0
