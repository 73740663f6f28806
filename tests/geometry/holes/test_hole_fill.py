"""G1 and G2 filling of n-sided holes (gshade.geometry.holes.fill, hole_energy), against
independent checks.

Oracles: the surrounding bicubic patches' own exact derivatives (outer edges), the filling
patches' exact derivatives (normals and curvatures across inner edges, the centre), finite
differences of the surface's points alone (curvature continuity), Gauss–Legendre quadrature
of the functionals with the chain rule written out, numerical integration of Bernstein
products, and for n = 4 the exact bicubic Catmull–Clark patches of the hole's faces.
"""

from __future__ import annotations

import numpy as np
import pytest

from gshade import GshadeError
from gshade.analysis.continuity import continuity_report
from gshade.geometry.core.bernstein import bernstein_basis, derivative_matrix, gram_matrix
from gshade.geometry.core.differential import gaussian_and_mean_curvature
from gshade.geometry.holes.energy import functional_matrix, sector_jacobian
from gshade.geometry.holes.fill import fill_hole, hole_system, solve_qp
from gshade.geometry.holes.ring import find_holes, hole_around
from gshade.geometry.patches.bezier import BezierPatch
from gshade.geometry.subdivision.catmull_clark import regular_patch
from gshade.geometry.subdivision.quad_mesh import MeshTopology

from ...support.meshes import grid_mesh, wavy_fan

T = np.linspace(0.0, 1.0, 21)[1:]  # 20 points per edge, the centre apart
#: free parameters per coordinate
FREE = {
    "G1": {3: 24, 4: 36, 5: 38, 6: 45, 8: 59},
    "G2": {3: 73, 4: 121, 5: 116, 6: 139, 8: 182},
}
CASES = [("G1", n, r) for n, r in ((3, 3), (5, 3), (6, 3), (8, 3), (5, 2), (4, 0))] + [
    ("G2", n, r) for n, r in ((3, 3), (5, 3), (6, 3), (8, 3), (4, 0))
]


def grid_hole():
    V, F = grid_mesh(6, 6, lambda i, j: (i, j, np.sin(i) * np.cos(0.7 * j)))
    topo = MeshTopology(np.asarray(F), len(V))
    return hole_around(V, topo, 3 * 7 + 3), topo


def make_hole(n, rings):
    if n == 4:
        return grid_hole()[0]
    (hole,) = find_holes(*wavy_fan(n, rings))
    return hole


@pytest.fixture(scope="module", params=CASES, ids=[f"{c}-n{n}-rings{r}" for c, n, r in CASES])
def case(request):
    continuity, n, rings = request.param
    hole = make_hole(n, rings)
    filling = fill_hole(hole, continuity)
    assert hole.n == n and len(filling.patches) == n
    return hole, filling


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def normals(patch, u, v):
    d = patch.derivatives(u, v, 1)
    return unit(np.cross(d[1, 0], d[0, 1]))


def curvatures(patch, u, v):
    return np.array(gaussian_and_mean_curvature(patch.derivatives(u, v, 2)))


def nets(patches):
    return np.concatenate([p.points.reshape(-1, 3) for p in patches])


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


# --------------------------------------------------------------------------- the functionals


def domain_integral(patches, n, name, domain, points=12):
    """The functional by Gauss–Legendre quadrature, the domain derivatives by the chain
    rule written out on the patches' own derivatives (p_x = a p_u + b p_v, ...)."""
    x, w = np.polynomial.legendre.leggauss(points)
    x, w = (x + 1) / 2, w / 2
    u, v = np.meshgrid(x, x, indexing="ij")
    W = np.outer(w, w)[..., None]
    total = 0.0
    for i, p in enumerate(patches):
        J = sector_jacobian(n, i) if domain == "sector" else np.eye(2)
        K = np.linalg.inv(J).T  # [d_x; d_y] = K [d_u; d_v]
        d = p.derivatives(u, v, 3)

        def D(a, b, d=d, K=K):
            """d_x^a d_y^b p: expand the product of the first-order operators."""
            terms = {(0, 0): 1.0}
            for row in [K[0]] * a + [K[1]] * b:
                nxt: dict = {}
                for (j, k), c in terms.items():
                    nxt[(j + 1, k)] = nxt.get((j + 1, k), 0.0) + c * row[0]
                    nxt[(j, k + 1)] = nxt.get((j, k + 1), 0.0) + c * row[1]
                terms = nxt
            return sum(c * d[j, k] for (j, k), c in terms.items())

        if name == "thin-plate":
            f = D(2, 0) ** 2 + 2 * D(1, 1) ** 2 + D(0, 2) ** 2
        elif name == "laplacian":
            f = (D(2, 0) + D(0, 2)) ** 2
        elif name == "third-order":
            f = D(3, 0) ** 2 + 3 * D(2, 1) ** 2 + 3 * D(1, 2) ** 2 + D(0, 3) ** 2
        else:  # laplacian-gradient
            f = (D(3, 0) + D(1, 2)) ** 2 + (D(2, 1) + D(0, 3)) ** 2
        total += abs(np.linalg.det(J)) * float(np.sum(W * f))
    return total


@pytest.mark.parametrize("domain", ["square", "sector"])
@pytest.mark.parametrize("name", ["thin-plate", "laplacian", "third-order", "laplacian-gradient"])
@pytest.mark.parametrize("n", [3, 5])
def test_the_functional_matrix_is_the_integral(n, name, domain):
    rng = np.random.default_rng(n)
    patches = [BezierPatch(rng.normal(size=(6, 6, 3))) for _ in range(n)]
    Q = functional_matrix(name, n, 5, domain)
    x = nets(patches)
    expected = domain_integral(patches, n, name, domain)
    assert np.einsum("ic,ij,jc->", x, Q, x) == pytest.approx(expected, rel=1e-11)


def test_the_domains_agree_for_four_sides():
    for name in ("thin-plate", "third-order"):
        np.testing.assert_allclose(
            functional_matrix(name, 4, 5, "sector"), functional_matrix(name, 4, 5), atol=1e-12
        )


def test_bad_names_are_refused():
    hole = make_hole(5, 3)
    with pytest.raises(GshadeError, match='continuity: expected "G1", "G2", got "G3"'):
        fill_hole(hole, "G3")
    with pytest.raises(GshadeError, match=r'functional: expected "thin-plate".*got "bending"'):
        fill_hole(hole, "G1", "bending")
    with pytest.raises(GshadeError, match='domain: expected "square", "sector", got "disc"'):
        fill_hole(hole, "G1", domain="disc")
    with pytest.raises(GshadeError, match="order 3, more than the patches' degree 2"):
        functional_matrix("third-order", 3, 2)


# --------------------------------------------------------------------------- constraints


def test_the_patches_have_the_degree_and_a_common_centre(case):
    _, filling = case
    degree = {"G1": 5, "G2": 9}[filling.continuity]
    assert all(p.degree == (degree, degree) for p in filling.patches)
    centre = np.array([p.points[0, 0] for p in filling.patches])
    np.testing.assert_array_equal(centre, np.broadcast_to(centre[0], centre.shape))
    assert filling.residual < 1e-12


def test_outer_edges_are_the_boundary_and_join_c1_or_c2(case):
    hole, filling = case
    n, one = hole.n, np.ones_like(T)
    order = {"G1": 1, "G2": 2}[filling.continuity]
    for i, p in enumerate(filling.patches):
        # u = 1 against S_(2i+1), e_i -> f_i: S(0, t) = P(1, t), S_u(0, t) = P_u(1, t), ...
        s = hole.patches[2 * i + 1].derivatives(0 * T, T, 2)
        d = p.derivatives(one, T, 2)
        for k in range(order + 1):
            np.testing.assert_allclose(d[k, 0], s[k, 0], atol=1e-9)
        # v = 1 against S_(2i+2), f_i -> e_(i+1): S(0, t) = P(1 - t, 1), S_u(0, t) = P_v
        s = hole.patches[(2 * i + 2) % (2 * n)].derivatives(0 * T, 1 - T, 2)
        d = p.derivatives(T, one, 2)
        for k in range(order + 1):
            np.testing.assert_allclose(d[0, k], s[k, 0], atol=1e-9)


def test_inner_edges_are_shared(case):
    _, filling = case
    fill = filling.patches
    for i, p in enumerate(fill):
        np.testing.assert_allclose(p(T, 0 * T), fill[i - 1](0 * T, T), atol=1e-10)


def test_the_free_parameters(case):
    hole, filling = case
    assert filling.free == FREE[filling.continuity][hole.n]


# --------------------------------------------------------------------------- G1, G2


def test_g1_across_inner_and_outer_edges(case):
    hole, filling = case
    fill, n, one = filling.patches, hole.n, np.ones_like(T)
    for i, p in enumerate(fill):
        assert np.abs(normals(p, T, 0 * T) - normals(fill[i - 1], 0 * T, T)).max() < 1e-9
        s = hole.patches[2 * i + 1]
        assert np.abs(normals(p, one, T) - normals(s, 0 * T, T)).max() < 1e-9
        s = hole.patches[(2 * i + 2) % (2 * n)]
        assert np.abs(normals(p, T, one) - normals(s, 0 * T, 1 - T)).max() < 1e-9


def test_curvature_across_inner_edges(case):
    """G2: K and H agree on both sides of every inner edge (exact derivatives); G1: they
    jump (n != 4)."""
    hole, filling = case
    fill = filling.patches
    jumps = []
    for i, p in enumerate(fill):
        a, b = curvatures(p, T, 0 * T), curvatures(fill[i - 1], 0 * T, T)
        jumps.append(np.abs(a - b).max() / max(1.0, np.abs(a).max()))
    if filling.continuity == "G2":
        assert max(jumps) < 1e-9
    elif hole.n != 4:
        assert max(jumps) > 1e-3


def test_curvature_across_outer_edges(case):
    hole, filling = case
    if filling.continuity != "G2":
        return
    fill, n, one = filling.patches, hole.n, np.ones_like(T)
    for i, p in enumerate(fill):
        a, b = curvatures(p, one, T), curvatures(hole.patches[2 * i + 1], 0 * T, T)
        np.testing.assert_allclose(a, b, atol=1e-8)
        a = curvatures(p, T, one)
        b = curvatures(hole.patches[(2 * i + 2) % (2 * n)], 0 * T, 1 - T)
        np.testing.assert_allclose(a, b, atol=1e-8)


def fd_mean_curvature(patch, u, v, h, du, dv):
    """H at (u, v) from the patch's points alone: one-sided second-order differences
    stepping into the patch (du, dv = +-1 per direction)."""

    def p(a, b):
        return patch(np.atleast_1d(u + a * du * h), np.atleast_1d(v + b * dv * h))[0]

    # one-sided: f' = (-3 f0 + 4 f1 - f2) / 2h,  f'' = (2 f0 - 5 f1 + 4 f2 - f3) / h^2
    c1, c2 = (-1.5, 2.0, -0.5), (2.0, -5.0, 4.0, -1.0)
    pu = du * sum(c * p(k, 0) for k, c in enumerate(c1)) / h
    pv = dv * sum(c * p(0, k) for k, c in enumerate(c1)) / h
    puu = sum(c * p(k, 0) for k, c in enumerate(c2)) / h**2
    pvv = sum(c * p(0, k) for k, c in enumerate(c2)) / h**2
    # mixed: the one-sided first difference in v of the one-sided first difference in u
    puv = du * dv * sum(a * b * p(j, k) for j, a in enumerate(c1) for k, b in enumerate(c1)) / h**2
    n = np.cross(pu, pv)
    n /= np.linalg.norm(n)
    E, F, G = pu @ pu, pu @ pv, pv @ pv
    L, M, N = puu @ n, puv @ n, pvv @ n
    return (E * N - 2 * F * M + G * L) / (2 * (E * G - F * F))


@pytest.mark.parametrize("n", [3, 5, 6])
def test_the_classes_hold_by_finite_differences(n):
    """Independent of the patches' derivatives: H from points alone on both sides of each
    inner edge agrees for the G2 filling (to the differences' error) and jumps for G1."""
    hole = make_hole(n, 3)
    h = 1e-3
    for continuity, bound in (("G2", 5e-4), ("G1", None)):
        fill = fill_hole(hole, continuity).patches
        jumps = []
        for i, p in enumerate(fill):
            for t in (0.3, 0.6):
                a = fd_mean_curvature(p, t, 0.0, h, 1, 1)  # P_i at (t, 0)
                b = fd_mean_curvature(fill[i - 1], 0.0, t, h, 1, 1)  # P_(i-1) at (0, t)
                jumps.append(abs(a - b))
        if bound is None:
            assert max(jumps) > 2e-2, jumps
        else:
            assert max(jumps) < bound, jumps


def test_the_centre_is_regular(case):
    hole, filling = case
    fill, z = filling.patches, np.zeros(1)
    tangents = np.array([p.derivatives(z, z, 1)[1, 0, 0] for p in fill])  # E_i'(0)
    s = np.linalg.svd(tangents, compute_uv=False)
    # rank 2: the tangents are an affine image of the regular n-gon (G1-in at t = 0),
    # a non-degenerate one (a similarity would give s[1] / s[0] = 1)
    assert s[2] < 1e-10 * s[0]
    assert s[1] > 0.2 * s[0]
    assert np.linalg.norm(tangents, axis=1).min() > 0.1 * np.abs(hole.cross1).max()
    nrm = np.array([normals(p, z, z)[0] for p in fill])
    assert np.abs(nrm - nrm[0]).max() < 1e-9
    assert np.abs(tangents @ nrm[0]).max() < 1e-9 * s[0]
    out = normals(hole.patches[1], z, z)[0]
    assert nrm[0] @ out > 0
    if filling.continuity == "G2":  # one curvature at the centre
        K = np.array([curvatures(p, z, z)[:, 0] for p in fill])
        assert np.abs(K - K[0]).max() < 1e-8 * max(1.0, np.abs(K).max())


def test_the_vertex_enclosure_condition_for_even_n(case):
    """Even n: the circulant of the twist conditions at the centre is singular, and the
    filling satisfies its solvability condition sum_i (-1)^i E_i''(0) = 0 (Peters 1991);
    for odd n nothing forces it."""
    hole, filling = case
    z = np.zeros(1)
    s = np.array([p.derivatives(z, z, 2)[2, 0, 0] for p in filling.patches])  # E_i''(0)
    alternating = (((-1.0) ** np.arange(hole.n))[:, None] * s).sum(0)
    if hole.n % 2 == 0 and hole.n != 4:
        assert np.abs(alternating).max() < 1e-9 * np.abs(s).max()
    elif hole.n % 2:
        assert np.abs(alternating).max() > 1e-3 * np.abs(s).max()


def test_the_functional_is_minimal_in_the_null_space(case):
    hole, filling = case
    system = hole_system(hole, filling.continuity)
    x = nets(filling.patches)
    assert np.abs(system.C @ x - system.r).max() < 1e-10
    _, s, Vt = np.linalg.svd(system.C)
    Z = Vt[int(np.sum(s > 1e-10 * s[0])) :].T
    d = system.degree
    rng = np.random.default_rng(hole.n)

    def F(patches):
        return domain_integral(patches, hole.n, filling.functional, filling.domain)

    f0 = F(filling.patches)
    # x^T Q x cancels: the nets' linear parts have no third derivatives
    assert f0 == pytest.approx(filling.energy, rel=1e-7)
    for _ in range(2):
        dz = Z @ rng.normal(size=(Z.shape[1], 3))
        dz *= 1e-3 * np.abs(x).max() / np.abs(dz).max()

        def moved(sign, dz=dz):
            return [BezierPatch(net) for net in (x + sign * dz).reshape(hole.n, d + 1, d + 1, 3)]

        plus, minus = F(moved(1)), F(moved(-1))
        assert plus > f0 and minus > f0
        # stationary: the first-order change vanishes against the second-order one
        assert abs(plus - minus) < 1e-6 * (plus + minus - 2 * f0)


# --------------------------------------------------------------------------- why these junctions


@pytest.mark.parametrize("n", [3, 5, 6, 8])
def test_a_linear_junction_function_is_inconsistent(n):
    hole = make_hole(n, 3)
    Q = functional_matrix("thin-plate", n, 5)
    for profile, bad in ((lambda t: 1 - t, True), (None, False)):
        system = hole_system(hole, "G1", profile=profile)
        _, _, residual = solve_qp(system.C, system.r, Q)
        assert (residual > 1e-6) == bad


def test_g2_with_a_cubic_junction_function_is_singular_for_three_sides():
    """lambda = 2 cos(2 pi / n) (1 - t)^3 (lambda'(0) != 0) admits G2 fillings for n = 3, but
    only with all centre tangents zero; the profile (1 - t)^3 (1 + 3t) does not."""
    hole, z = make_hole(3, 3), np.zeros(1)
    Q = functional_matrix("third-order", 3, 9)
    for profile, singular in ((lambda t: (1 - t) ** 3, True), (None, False)):
        system = hole_system(hole, "G2", profile=profile)
        x, _, residual = solve_qp(system.C, system.r, Q)
        assert residual < 1e-10
        P = [BezierPatch(net) for net in x.reshape(3, 10, 10, 3)]
        size = max(np.linalg.norm(p.derivatives(z, z, 1)[1, 0, 0]) for p in P)
        assert (size < 1e-9) == singular


def test_classes_by_the_continuity_report(case):
    """gshade's own classification of the inner edges: G1 (G1 filling, n != 4) and G2 but
    not G3 (G2 filling, n != 4)."""
    hole, filling = case
    pairs = [(i, "v0", (i - 1) % hole.n, "u0") for i in range(hole.n)]
    report = continuity_report(list(filling.patches), pairs=pairs)
    classes = {j.cls for j in report}
    if hole.n == 4:
        assert classes <= {filling.continuity, "G2", "G3"}
    else:
        assert classes == {filling.continuity}


# --------------------------------------------------------------------------- n = 4


@pytest.mark.parametrize("continuity", ["G1", "G2"])
def test_a_regular_hole_admits_its_own_bicubic_patches(continuity):
    hole, topo = grid_hole()
    system = hole_system(hole, continuity)
    d = system.degree
    true = [regular_patch(hole.points, topo, int(h)).elevated((d, d)) for h in hole.half_edges]
    assert np.abs(system.C @ nets(true) - system.r).max() < 1e-10
