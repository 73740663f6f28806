"""Normals and curvatures against analytic surfaces (sphere, cylinder, torus, saddle), and
the formulas themselves on plain arrays and on jets against closed forms."""

import numpy as np
import pytest

from gshade.geometry import (
    BezierPatch,
    cylinder,
    first_fundamental_form,
    gaussian_and_mean_curvature,
    gaussian_curvature,
    irregular_mask,
    mean_curvature,
    patch_normals,
    principal_curvatures,
    regularised_derivatives,
    sphere,
    torus,
    unit_normal,
)
from gshade.geometry.core.differential import (
    fundamental_forms,
    gaussian_from_forms,
    mean_from_forms,
    normal_curvature,
    principal_half_gap,
)
from gshade.geometry.core.jets import NUMPY, Jet
from gshade.geometry.core.jets import sqrt as jet_sqrt
from gshade.io import read_newell

from ...support import curvature_oracles
from ...support.paths import TEAPOT

REL = 1e-9


def grid(patch, n=41):
    return patch.parameter_grid(n, n)


def test_sphere_is_exact_with_its_curvatures():
    R = 2.5
    s = sphere(R)
    u, v = grid(s)
    rd = regularised_derivatives(s, u, v, 2)
    d = rd.d
    np.testing.assert_allclose(np.linalg.norm(d[0, 0], axis=-1), R, rtol=1e-15)
    reg = rd.regular
    assert not reg[0].any() and not reg[-1].any() and reg[1:-1].all()  # the two poles
    K, H = gaussian_and_mean_curvature(d)
    np.testing.assert_allclose(K[reg], 1 / R**2, rtol=REL)
    np.testing.assert_allclose(np.abs(H[reg]), 1 / R, rtol=REL)
    # at the poles the values are limits, finite and close
    np.testing.assert_allclose(K[~reg], 1 / R**2, rtol=1e-5)
    pc = principal_curvatures(d)
    np.testing.assert_allclose(np.abs(pc.k1[reg]), 1 / R, rtol=1e-8)
    np.testing.assert_allclose(np.abs(pc.k2[reg]), 1 / R, rtol=1e-8)


def test_sphere_normals_are_radial_including_the_poles():
    s = sphere(1.5)
    u, v = grid(s, 21)
    normal = patch_normals(s, u, v)
    p = s(u, v)
    radial = p / 1.5
    np.testing.assert_allclose(np.abs(np.sum(normal.n * radial, -1)), 1.0, atol=1e-12)
    # consistent orientation everywhere, the collapsed poles included
    sign = np.sign(np.sum(normal.n * radial, -1))
    assert np.all(sign == sign[10, 10])
    assert not normal.regular[0].any() and normal.regular[1:-1].all()


def test_cylinder_curvatures():
    R = 0.75
    c = cylinder(R, 2.0)
    u, v = grid(c)
    d = c.derivatives(u, v, 2)
    K, H = gaussian_and_mean_curvature(d)
    np.testing.assert_allclose(K, 0.0, atol=REL / R**2)
    np.testing.assert_allclose(np.abs(H), 1 / (2 * R), rtol=REL)
    pc = principal_curvatures(d)
    # one principal curvature is 0 along the axis, the other 1/R around it
    k_abs = np.sort(np.abs(np.stack([pc.k1, pc.k2])), axis=0)
    np.testing.assert_allclose(k_abs[0], 0, atol=1e-9)
    np.testing.assert_allclose(k_abs[1], 1 / R, rtol=REL)
    flat_dir = np.where((np.abs(pc.k1) < np.abs(pc.k2))[..., None], pc.e1, pc.e2)
    np.testing.assert_allclose(np.abs(flat_dir[..., 2]), 1.0, atol=1e-9)


def test_torus_curvatures_match_the_closed_form():
    R, r = 3.0, 1.0
    t = torus(R, r)
    u, v = grid(t, 61)
    d = t.derivatives(u, v, 2)
    p = d[0, 0]
    rho = np.hypot(p[..., 0], p[..., 1])
    cos_v = (rho - R) / r  # v: the angle around the tube
    K_exact = cos_v / (r * (R + r * cos_v))
    H_exact = (R + 2 * r * cos_v) / (2 * r * (R + r * cos_v))
    K = gaussian_curvature(d)
    H = mean_curvature(d)
    np.testing.assert_allclose(K, K_exact, atol=REL * np.abs(K_exact).max())
    np.testing.assert_allclose(np.abs(H), H_exact, rtol=REL)
    pc = principal_curvatures(d)
    k_sorted = np.sort(np.abs(np.stack([pc.k1, pc.k2])), axis=0)
    exact = np.sort(np.stack([np.full_like(rho, 1 / r), np.abs(cos_v) / rho]), axis=0)
    np.testing.assert_allclose(k_sorted, exact, atol=1e-9)
    # principal directions are orthonormal tangents
    n = unit_normal(d).n
    np.testing.assert_allclose(np.sum(pc.e1 * pc.e2, -1), 0, atol=1e-12)
    np.testing.assert_allclose(np.sum(pc.e1 * n, -1), 0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(pc.e1, axis=-1), 1, atol=1e-12)


def test_saddle_gaussian_curvature():
    # z = xy over [-1, 1]^2 is the bilinear Bézier patch with corners (±1, ±1, ±1)
    P = np.array([[[-1, -1, 1], [-1, 1, -1]], [[1, -1, -1], [1, 1, 1]]], float)
    saddle = BezierPatch(P)
    u, v = grid(saddle, 25)
    d = saddle.derivatives(u, v, 2)
    x, y = d[0, 0][..., 0], d[0, 0][..., 1]
    np.testing.assert_allclose(d[0, 0][..., 2], x * y, atol=1e-15)
    np.testing.assert_allclose(gaussian_curvature(d), -1 / (1 + x**2 + y**2) ** 2, rtol=REL)
    H_exact = -x * y / (1 + x**2 + y**2) ** 1.5  # for the upward normal
    n = unit_normal(d).n
    np.testing.assert_allclose(mean_curvature(d) * np.sign(n[..., 2]), H_exact, atol=1e-12)
    pc = principal_curvatures(d)
    np.testing.assert_allclose(pc.k1 * pc.k2, gaussian_curvature(d), rtol=1e-9)


def test_first_fundamental_form_identity():
    s = torus()
    u, v = grid(s, 9)
    d = s.derivatives(u, v, 1)
    E, F, G = first_fundamental_form(d)
    N = np.cross(d[1, 0], d[0, 1])
    np.testing.assert_allclose(E * G - F**2, np.sum(N * N, -1), rtol=1e-12)


@pytest.mark.parametrize("index", [20, 21, 22, 23, 28, 29, 30, 31])
def test_teapot_collapsed_edges_have_finite_limit_values(index):
    patch = read_newell(TEAPOT)[index]
    u, v = grid(patch, 17)
    d = patch.derivatives(u, v, 3)
    assert irregular_mask(d)[0].all() and not irregular_mask(d)[1:].any()
    normal = patch_normals(patch, u, v)
    assert np.all(np.isfinite(normal.n))
    np.testing.assert_allclose(np.linalg.norm(normal.n, axis=-1), 1, atol=1e-12)
    # the limit normal at the collapsed edge is the normal next to it
    near = patch_normals(patch, np.full((1, 1), 1e-6), v)
    np.testing.assert_allclose(normal.n[0], near.n[0], atol=1e-4)
    # the collapsed edge of the lid and the bottom is a pole: all normals there agree
    np.testing.assert_allclose(normal.n[0], normal.n[0, :1].repeat(17, 0), atol=1e-9)
    rd = regularised_derivatives(patch, u, v, 2)
    K, H = gaussian_and_mean_curvature(rd.d)
    assert np.all(np.isfinite(K)) and np.all(np.isfinite(H))
    # the limit curvature continues the values just inside
    inside = regularised_derivatives(patch, np.full((1, 1), 1e-3), v, 2).d
    K_in, H_in = gaussian_and_mean_curvature(inside)
    np.testing.assert_allclose(H[0], H_in[0], rtol=0.05, atol=1e-3)
    np.testing.assert_allclose(K[0], K_in[0], rtol=0.05, atol=1e-3)


def test_curvatures_never_nan_on_raw_irregular_points():
    patch = read_newell(TEAPOT)[20]
    d = patch.derivatives(np.zeros(5), np.linspace(0, 1, 5), 2)
    K, H = gaussian_and_mean_curvature(d)
    pc = principal_curvatures(d)
    for x in (K, H, pc.k1, pc.k2, pc.e1, pc.e2, unit_normal(d).n):
        assert np.all(np.isfinite(x))


# --------------------------------------------------------------------------- the formulas, once


def xyz(a):
    return tuple(a[..., c] for c in range(3))


def jet_vector(d, i, j):
    """The jets (value, d/ds, d/dt) of d^(i+j) p / ds^i dt^j."""
    return tuple(Jet(d[i, j, :, c], d[i + 1, j, :, c], d[i, j + 1, :, c]) for c in range(3))


FORMS_AT = ((1, 0), (0, 1), (2, 0), (1, 1), (0, 2))


def curvatures(forms, sqrt):
    with np.errstate(divide="ignore"):  # the jets' sqrt at 0 (umbilics): slope 0
        H = mean_from_forms(forms, sqrt(forms.W2))
        return gaussian_from_forms(forms), H, principal_half_gap(forms, sqrt)


@pytest.mark.parametrize("name", ["sphere", "cylinder", "torus"])
def test_the_generic_formulas_on_plain_arrays_and_on_jets_match_closed_forms(name):
    """fundamental_forms and K, H, (k1 - k2) / 2 from them, on numpy arrays and on jets
    (whose derivative parts must be the closed-form d/ds = 0 and d/dt = d/dphi)."""
    o = curvature_oracles.surface(name)
    plain = fundamental_forms(*(xyz(o.d[i, j]) for i, j in FORMS_AT))
    on_arrays = curvatures(plain, lambda x: np.sqrt(np.maximum(x, 0)))
    jets = fundamental_forms(*(jet_vector(o.d, i, j) for i, j in FORMS_AT))
    K_jet, H_jet, half_gap_jet = curvatures(jets, lambda x: jet_sqrt(x, NUMPY))
    for K, H, half_gap in (on_arrays, (K_jet.f, H_jet.f, half_gap_jet.f)):
        np.testing.assert_allclose(K, o.K, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(H, o.H, rtol=1e-12)
        np.testing.assert_allclose(half_gap, o.half_gap, atol=1e-12)
    np.testing.assert_allclose(K_jet.u, 0, atol=1e-12)
    np.testing.assert_allclose(K_jet.v, o.dK_dphi, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(H_jet.u, 0, atol=1e-12)
    np.testing.assert_allclose(H_jet.v, o.dH_dphi, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("name", ["sphere", "cylinder", "torus"])
def test_the_numpy_curvature_functions_match_closed_forms(name):
    o = curvature_oracles.surface(name)
    for K, H in (gaussian_and_mean_curvature(o.d), (gaussian_curvature(o.d), mean_curvature(o.d))):
        np.testing.assert_allclose(K, o.K, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(H, o.H, rtol=1e-12)
    pc = principal_curvatures(o.d)
    np.testing.assert_allclose(pc.k1, np.maximum(o.k_around, o.k_along), atol=1e-12)
    np.testing.assert_allclose(pc.k2, np.minimum(o.k_around, o.k_along), atol=1e-12)
    E, F, _ = first_fundamental_form(o.d)
    rho2 = np.sum(o.d[0, 0][..., :2] ** 2, -1)  # E = rho^2, F = SHEAR E here
    np.testing.assert_allclose(E, rho2, rtol=1e-12)
    np.testing.assert_allclose(F, curvature_oracles.SHEAR * rho2, rtol=1e-12)


@pytest.mark.parametrize("name", ["sphere", "cylinder", "torus"])
def test_normal_curvature_follows_euler_s_formula(name):
    """k(e) = k_around cos^2 t + k_along sin^2 t for e = cos t p_theta/|p_theta| + sin t
    p_phi/|p_phi| (do Carmo §3-2), w.r.t. the unit normal given."""
    o = curvature_oracles.surface(name)
    n = unit_normal(o.d).n
    along_theta = o.p_theta / np.linalg.norm(o.p_theta, axis=-1, keepdims=True)
    along_phi = o.p_phi / np.linalg.norm(o.p_phi, axis=-1, keepdims=True)
    for t in np.linspace(0, np.pi, 7):
        e = np.cos(t) * along_theta + np.sin(t) * along_phi
        expected = o.k_around * np.cos(t) ** 2 + o.k_along * np.sin(t) ** 2
        np.testing.assert_allclose(normal_curvature(o.d, n, e), expected, rtol=1e-12, atol=1e-12)
    # a normal of the other side turns every normal curvature over
    np.testing.assert_allclose(normal_curvature(o.d, -n, along_phi), -o.k_along, atol=1e-12)


def test_derivative_scales_are_each_groups_own():
    """Points of two patches of very different sizes: each judged on its own patch's scale
    (the small patch's regular points stay regular beside a large patch)."""
    from gshade.geometry.core.differential import (
        derivative_scale,
        derivative_scales,
        irregular_mask,
    )

    rng = np.random.default_rng(5)
    d = rng.normal(size=(2, 2, 2, 50, 3))
    d[:, :, 1] *= 1e-6  # the second patch a millionth of the first's size
    groups = np.repeat([[0], [1]], 50, axis=1)
    scales = derivative_scales(d, groups)
    for g in (0, 1):
        assert np.all(scales[g] == derivative_scale(d[:, :, g]))
        assert np.array_equal(irregular_mask(d, scale=scales)[g], irregular_mask(d[:, :, g]))
    assert not irregular_mask(d, scale=scales)[1].any()
    assert irregular_mask(d)[1].all()  # on one scale for both, the small patch is "collapsed"
    zero = np.zeros((2, 2, 4, 3))
    assert np.all(derivative_scales(zero, np.arange(4)) == 1.0)  # as derivative_scale of 0


def test_derivative_scales_of_groups_along_some_axes():
    """Groups given per patch of a grid ((n, 1, 1), reduced along the grid's axes first),
    groups repeated on several patches, and unsorted per-point groups: the same scales as
    derivative_scale of each group's points."""
    from gshade.geometry.core.differential import derivative_scale, derivative_scales

    rng = np.random.default_rng(11)
    d = rng.normal(size=(2, 2, 4, 5, 6, 3)) * rng.uniform(1e-3, 1e3, size=(4, 1, 1, 1))
    for groups in (
        np.arange(4)[:, None, None],  # one per patch
        np.array([2, 0, 2, 1])[:, None, None],  # patches 0 and 2 one group
        rng.integers(0, 3, size=(4, 5, 6)),  # per point, unsorted
        np.array([[0, 1, 1, 0, 2, 2]]),  # along the last grid axis only
    ):
        every = np.broadcast_to(groups, (4, 5, 6))
        scales = derivative_scales(d, groups)
        assert scales.shape == (4, 5, 6)
        for g in np.unique(every):
            mine = every == g
            assert np.all(scales[mine] == derivative_scale(d[:, :, mine]))
