"""Shape functions against analytic oracles, finite differences and the order theorem."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade import GshadeError
from gshade.geometry import (
    BezierPatch,
    BSplinePatch,
    cylinder,
    principal_curvatures,
    regularised_derivatives,
    sphere,
    torus,
    unit_normal,
)
from gshade.io import read_newell
from gshade.shape import SHAPE_FUNCTIONS, evaluate, validate_parameter

from ..support import curvature_oracles
from ..support.paths import TEAPOT

#: the functions with a formula (the environment is drawn by the renderer: it has none)
FORMULAS = sorted(name for name, fn in SHAPE_FUNCTIONS.items() if not fn.reflection)


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def angle_deg(a, b):
    cos = np.sum(a * b, -1) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1))
    return np.degrees(np.arccos(np.clip(cos, -1, 1)))


# --------------------------------------------------------------------------- sphere, isophotes


def test_sphere_isophotes_are_circles_at_the_analytic_angles():
    R = 1.7
    s = sphere(R)
    u, v = s.parameter_grid(60, 60)
    d = regularised_derivatives(s, u, v, 2).d
    light = unit([0.3, -0.2, 0.9])
    res = evaluate("isophotes", d, light=light)
    n = unit_normal(d).n
    p = d[0, 0]
    # n = -p / R for this parametrisation: f = <n, l> is constant on the circles <p, l> = c
    outward = np.sign(np.sum(n * p, -1))
    np.testing.assert_allclose(res.f * outward, p @ light / R, atol=2e-5)
    regular = np.abs(np.sum(n * p, -1) / R) > 0.999  # everywhere but the nudged poles
    np.testing.assert_allclose((res.f * outward)[1:-1], (p @ light / R)[1:-1], atol=1e-13)
    assert regular.all()
    # grad f is tangent, with |grad f| = sin(angle(n, l)) / R
    assert np.abs(np.sum(res.gradient * n, -1)).max() < 1e-12
    sin = np.sqrt(np.maximum(1 - res.f**2, 0))
    np.testing.assert_allclose(
        np.linalg.norm(res.gradient, axis=-1)[1:-1], (sin / R)[1:-1], atol=1e-12
    )


def test_angle_form_spaces_isophotes_evenly_on_the_sphere():
    R = 2.0
    s = sphere(R)
    u, v = s.parameter_grid(41, 41)
    d = regularised_derivatives(s, u, v, 2).d
    light = unit([1, 1, 1])
    res = evaluate("isophotes", d, light=light, form="angle")
    n = unit_normal(d).n
    np.testing.assert_allclose(res.f, np.arccos(np.clip(n @ light, -1, 1)), atol=1e-12)
    # even spacing: the angle grows at the same rate 1/R everywhere (geodesic distance / R)
    g = np.linalg.norm(res.gradient, axis=-1)[1:-1]
    away = (res.f[1:-1] > 0.05) & (res.f[1:-1] < np.pi - 0.05)
    np.testing.assert_allclose(g[away], 1 / R, rtol=1e-9)


# --------------------------------------------------------------------------- plane, cylinder


def plane_patch(size=4.0):
    P = np.zeros((2, 2, 3))
    P[..., 0] = [[-size, -size], [size, size]]
    P[..., 1] = [[-size, size], [-size, size]]
    return BezierPatch(P)


def test_reflection_lines_on_a_plane_are_straight_where_geometry_puts_them():
    plane = plane_patch()
    u, v = plane.parameter_grid(31, 31)
    d = plane.derivatives(u, v, 2)
    eye = np.array([0.5, -2.0, 3.0])
    h = 5.0
    res = evaluate(
        "reflection_lines", d, eye_point=eye, origin=[0, 0, h], a1=[1, 0, 0], a2=[0, 1, 0]
    )
    p = d[0, 0]
    # mirror in z = 0, hit z = h: x = p_x + h (p_x - e_x) / e_z  (hand-derived)
    expected = p[..., 0] + h * (p[..., 0] - eye[0]) / eye[2]
    assert res.valid.all()
    np.testing.assert_allclose(res.f, expected, atol=1e-12)
    # straight level lines: f depends on x only, so grad f is along x
    np.testing.assert_allclose(res.gradient[..., 1:], 0, atol=1e-12)
    np.testing.assert_allclose(res.gradient[..., 0], 1 + h / eye[2], rtol=1e-12)


def test_reflected_rays_missing_the_light_plane_are_flagged():
    plane = plane_patch()
    u, v = plane.parameter_grid(11, 11)
    d = plane.derivatives(u, v, 2)
    # light plane below the mirror: every reflected ray goes up, away from it
    res = evaluate("reflection_lines", d, eye_point=[0, 0, 3], origin=[0, 0, -1])
    assert not res.valid.any()
    assert np.all(np.isfinite(res.f)) and np.all(res.f == 0)


def test_highlight_lines_on_a_plane():
    plane = plane_patch()
    u, v = plane.parameter_grid(21, 21)
    d = plane.derivatives(u, v, 2)
    res = evaluate("highlight_lines", d, origin=[0, 0, 7], a1=[1, 0, 0], a2=[0, 1, 0])
    # the normal line hits z = 7 straight above p: s = p_x
    np.testing.assert_allclose(res.f, d[0, 0][..., 0], atol=1e-12)
    dist = evaluate("highlight_lines", d, form="distance", origin=[1, 0, 7], a2=[0, 1, 0])
    # Beier–Chen: the distance between the normal line at p and the line x = 1, z = 7 along y
    np.testing.assert_allclose(np.abs(dist.f), np.abs(d[0, 0][..., 0] - 1), atol=1e-12)


def test_cylinder_highlight_and_reflection_lines_are_generators():
    R = 1.0
    c = cylinder(R, 3.0)
    u, v = c.parameter_grid(25, 90)
    d = c.derivatives(u, v, 2)
    p = d[0, 0]
    phi = np.arctan2(p[..., 1], p[..., 0])
    h = 4.0
    hl = evaluate("highlight_lines", d, origin=[h, 0, 0], a1=[0, 1, 0], a2=[0, 0, 1])
    front = np.cos(phi) > 0.2
    assert hl.valid[front].all()
    # the normal line at angle phi meets the plane x = h at y = h tan(phi)
    np.testing.assert_allclose(hl.f[front], h * np.tan(phi[front]), rtol=1e-9, atol=1e-12)
    # straight: constant along the generators (u runs along the axis)
    np.testing.assert_allclose(np.ptp(hl.f, axis=0)[front[0]], 0, atol=1e-9)
    eye = np.array([3.0, -1.0, 1.2])
    rl = evaluate(
        "reflection_lines", d, eye_point=eye, origin=[h, 0, 0], a1=[0, 1, 0], a2=[0, 0, 1]
    )
    # hand-derived: only the xy components of w = p - e matter for where r meets x = h
    n = np.stack([np.cos(phi), np.sin(phi)], -1)
    w = p[..., :2] - eye[:2]
    r = w - 2 * np.sum(w * n, -1)[..., None] * n
    mu = (h - p[..., 0]) / r[..., 0]
    ok = rl.valid
    assert ok.sum() > 100
    np.testing.assert_array_equal(ok, mu > 0)
    np.testing.assert_allclose(rl.f[ok], (p[..., 1] + mu * r[..., 1])[ok], rtol=1e-9, atol=1e-9)
    spread = np.ptp(np.where(ok, rl.f, np.nan), axis=0)
    np.testing.assert_allclose(spread[np.all(ok, axis=0)], 0, atol=1e-9)


def test_zebra_reflection_is_the_angle_of_the_reflected_ray_about_the_axis():
    s = sphere(1.0)
    u, v = s.parameter_grid(21, 21)
    d = regularised_derivatives(s, u, v, 2).d
    eye = np.array([0.0, -6.0, 1.0])
    res = evaluate(
        "reflection_lines", d, eye_point=eye, form="infinity", axis=[0, 0, 1], reference=[1, 0, 0]
    )
    n = unit_normal(d).n
    w = d[0, 0] - eye
    r = w - 2 * np.sum(w * n, -1)[..., None] * n
    np.testing.assert_allclose(res.f, np.arctan2(r[..., 1], r[..., 0]), atol=1e-12)


# --------------------------------------------------------------------------- curvatures


CURVATURE_NAMES = ["gaussian", "mean", "max_principal", "min_principal", "absolute", "rms"]


def closed_forms(k1, k2):
    return {
        "gaussian": k1 * k2,
        "mean": (k1 + k2) / 2,
        "max_principal": np.maximum(k1, k2),
        "min_principal": np.minimum(k1, k2),
        "absolute": np.abs(k1) + np.abs(k2),
        "rms": np.sqrt((k1**2 + k2**2) / 2),
    }


def test_torus_curvature_functions_match_closed_forms():
    R, r = 2.5, 0.8
    t = torus(R, r)
    u, v = t.parameter_grid(50, 50)
    d = t.derivatives(u, v, 3)
    p = d[0, 0]
    rho = np.hypot(p[..., 0], p[..., 1])
    cos_v = (rho - R) / r
    n = unit_normal(d).n
    # principal curvatures k = <p'', n>: the tube circle 1/r and the parallel cos v / rho,
    # negative for the outward normal
    centre = np.stack([R * p[..., 0] / rho, R * p[..., 1] / rho, 0 * rho], -1)
    outward = np.sign(np.sum(n * (p - centre), -1))
    k_tube = -outward / r
    k_par = -outward * cos_v / rho
    expected = closed_forms(k_tube, k_par)
    for name in CURVATURE_NAMES:
        res = evaluate(name, d)
        scale = np.abs(expected[name]).max()
        np.testing.assert_allclose(res.f, expected[name], atol=1e-9 * scale, err_msg=name)


def test_sphere_and_saddle_curvature_functions():
    R = 1.3
    s = sphere(R)
    u, v = s.parameter_grid(30, 30)
    d = regularised_derivatives(s, u, v, 3).d
    sign = 1.0  # n = p_u x p_v points inward here, and the sphere bends toward it: k = +1/R
    expected = closed_forms(np.full(u.shape[0], sign / R), np.full(u.shape[0], sign / R))
    for name in CURVATURE_NAMES:
        f = evaluate(name, d).f
        np.testing.assert_allclose(f[1:-1], expected[name][0], rtol=1e-8, atol=1e-7, err_msg=name)
        np.testing.assert_allclose(f[[0, -1]], expected[name][0], rtol=1e-4, err_msg=name)
    P = np.array([[[-1, -1, 1], [-1, 1, -1]], [[1, -1, -1], [1, 1, 1]]], float)
    saddle = BezierPatch(P)  # z = xy
    u, v = saddle.parameter_grid(17, 17)
    d = saddle.derivatives(u, v, 3)
    pc = principal_curvatures(d)
    expected = closed_forms(pc.k1, pc.k2)
    x, y = d[0, 0][..., 0], d[0, 0][..., 1]
    np.testing.assert_allclose(evaluate("gaussian", d).f, -1 / (1 + x**2 + y**2) ** 2, rtol=1e-12)
    for name in CURVATURE_NAMES:
        np.testing.assert_allclose(evaluate(name, d).f, expected[name], atol=1e-12, err_msg=name)


@pytest.mark.parametrize("backend_name", ["numpy", "drjit"])
@pytest.mark.parametrize("surface", ["sphere", "cylinder", "torus"])
def test_curvature_functions_and_gradients_match_closed_forms(surface, backend_name):
    """Every curvature function, and the surface gradients of K and H, on each backend
    against closed forms (derivatives written out by hand: no patch involved)."""
    if backend_name == "drjit":
        from gshade.shape.kernels import backend

        if backend() != "drjit":
            pytest.skip("no usable libLLVM here: only the numpy backend runs")
    o = curvature_oracles.surface(surface)
    expected = closed_forms(o.k_around, o.k_along)
    for name in CURVATURE_NAMES:
        res = evaluate(name, o.d, backend=backend_name, gradient=False)
        assert res.valid.all(), name
        np.testing.assert_allclose(res.f, expected[name], rtol=1e-12, atol=1e-12, err_msg=name)
    # K and H depend on phi alone, and p_theta is orthogonal to p_phi: grad_S f = f_phi p_phi / G
    p_phi = o.p_phi
    G = np.sum(p_phi * p_phi, -1)
    for name, slope in (("gaussian", o.dK_dphi), ("mean", o.dH_dphi)):
        grad = evaluate(name, o.d, backend=backend_name).gradient
        np.testing.assert_allclose(grad, (slope / G)[:, None] * p_phi, atol=1e-12, err_msg=name)


def test_parametrisation_quality():
    P = np.zeros((2, 2, 3))
    P[1, :, 0] = 2.0  # p = (2u, v, 0): E = 4, F = 0, G = 1
    P[:, 1, 1] = 1.0
    d = BezierPatch(P).derivatives(np.linspace(0, 1, 5), 0.3, 2)
    np.testing.assert_allclose(evaluate("parametrisation_quality", d).f, 9 / 25)
    conformal = sphere(1.0)  # not conformal; a square grid of a plane is
    P[1, :, 0] = 1.0
    d = BezierPatch(P).derivatives(0.5, 0.5, 2)
    assert evaluate("parametrisation_quality", d).f == 0
    del conformal


# --------------------------------------------------------------------------- gradients


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), name=st.sampled_from(FORMULAS))
def test_gradient_matches_finite_differences(seed, name):
    rng = np.random.default_rng(seed)
    P = np.zeros((4, 4, 3))
    P[..., 0] = np.arange(4)[:, None]
    P[..., 1] = np.arange(4)[None, :]
    P[..., 2] = rng.normal(scale=0.5, size=(4, 4))
    patch = BezierPatch(P, rng.uniform(0.6, 1.5, (4, 4)))
    u, v = rng.uniform(0.1, 0.9, 12), rng.uniform(0.1, 0.9, 12)
    params = {"eye_point": [1.5, -6, 4]} if name == "reflection_lines" else {}
    res = evaluate(name, patch.derivatives(u, v, 3), partials=True, **params)
    h = 1e-6

    def f(uu, vv):
        return evaluate(name, patch.derivatives(uu, vv, 2), gradient=False, **params).f

    fu = (f(u + h, v) - f(u - h, v)) / (2 * h)
    fv = (f(u, v + h) - f(u, v - h)) / (2 * h)
    d = patch.derivatives(u, v, 1)
    ok = res.valid
    scale = 1 + np.abs(fu[ok]).max() + np.abs(fv[ok]).max()
    # grad_S f reproduces the parametric derivatives: <grad, p_u> = f_u, <grad, p_v> = f_v
    np.testing.assert_allclose(np.sum(res.gradient * d[1, 0], -1)[ok], fu[ok], atol=1e-5 * scale)
    np.testing.assert_allclose(np.sum(res.gradient * d[0, 1], -1)[ok], fv[ok], atol=1e-5 * scale)
    # the parametric partials themselves
    np.testing.assert_allclose(res.partials[ok, 0], fu[ok], atol=1e-5 * scale)
    np.testing.assert_allclose(res.partials[ok, 1], fv[ok], atol=1e-5 * scale)
    n = unit_normal(d).n
    assert np.abs(np.sum(res.gradient * n, -1)).max() < 1e-9 * scale


# --------------------------------------------------------------------------- order theorem


def junction_pairs():
    """Two bicubic patches sharing the edge u = 1/2: a C2 (hence G2) pair, and a pair made
    G1 but not G2 by moving the second patch's third row of control points."""
    rng = np.random.default_rng(42)
    P = np.zeros((5, 4, 3))
    P[..., 0] = np.linspace(0, 4, 5)[:, None]
    P[..., 1] = np.linspace(0, 3, 4)[None, :]
    P[..., 2] = rng.normal(scale=0.6, size=(5, 4))
    spline = BSplinePatch(P, (3, 3), ([0, 0, 0, 0, 0.5, 1, 1, 1, 1], [0, 0, 0, 0, 1, 1, 1, 1]))
    (a,), (b,) = spline.bezier_patches()
    g2 = (a, b)
    bent = b.points.copy()
    bent[2, :, 2] += 0.8  # keeps p and p_u along u = 1/2: C1, so G1; changes p_uu
    g1 = (a, BezierPatch(bent, domain=b.domain))
    return g1, g2


def edge_values(pair, name, **params):
    t = np.linspace(0.05, 0.95, 19)
    left, right = pair
    half = np.full_like(t, 0.5)
    out = []
    for patch in (left, right):
        d = patch.derivatives(half, t, 3)
        res = evaluate(name, d, **params)
        out.append((res, unit_normal(d).n))
    return out


def test_order_theorem_isophotes_kink_at_g1_and_are_smooth_at_g2():
    light = unit([0.4, 0.3, 1.0])
    g1, g2 = junction_pairs()
    (r1, n1), (r2, n2) = edge_values(g1, "isophotes", light=light)
    np.testing.assert_allclose(n1, n2, atol=1e-12)  # G1: the normals agree
    np.testing.assert_allclose(r1.f, r2.f, atol=1e-12)  # isophotes meet (continuous)
    kink = angle_deg(np.cross(n1, r1.gradient), np.cross(n2, r2.gradient))
    assert kink.max() > 1.0
    (s1, m1), (s2, m2) = edge_values(g2, "isophotes", light=light)
    smooth = angle_deg(np.cross(m1, s1.gradient), np.cross(m2, s2.gradient))
    assert smooth.max() < 0.01


def test_order_theorem_mean_curvature_jumps_at_g1_and_is_continuous_at_g2():
    g1, g2 = junction_pairs()
    (h1, _), (h2, _) = edge_values(g1, "mean")
    assert np.abs(h1.f - h2.f).max() > 0.05 * np.abs(h1.f).max()
    (k1, _), (k2, _) = edge_values(g2, "mean")
    np.testing.assert_allclose(k1.f, k2.f, atol=1e-10 * np.abs(k1.f).max())
    # planar sections (order 0) are smooth across both junctions
    for pair in (g1, g2):
        (p1, n1), (p2, n2) = edge_values(pair, "planar_sections", direction=[1, 2, 0.5])
        assert angle_deg(np.cross(n1, p1.gradient), np.cross(n2, p2.gradient)).max() < 1e-4


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("name", "params", "message"),
    [
        (
            "isophotes",
            {"light": [0, 0, 0]},
            r"^isophotes: light: expected a direction \[x, y, z\] of length at least 1e-12, "
            r"got \[0, 0, 0\]$",
        ),
        # the shortest direction accepted is that of the scene files' (1e-12), not just nonzero
        ("isophotes", {"light": (1e-13, 0, 0)}, r"light: .* at least 1e-12, got \[1e-13, 0, 0\]"),
        ("reflection_lines", {"a1": np.zeros(3)}, r"a1: .* at least 1e-12, got \[0.0, 0.0, 0.0\]"),
        ("isophotes", {"light": [1, 2]}, r"light: expected 3 finite numbers \[x, y, z\]"),
        ("isophotes", {"form": "sine"}, 'form: expected one of "cos", "angle", got "sine"'),
        ("isophotes", {"form": 1}, 'form: expected one of "cos", "angle", got 1$'),
        ("isophotes", {"lihgt": [0, 0, 1]}, "unknown parameter 'lihgt'"),
        (
            "reflection_lines",
            {"a1": [1, 0, 0], "a2": [2, 0, 0]},
            "a1, a2: expected two non-parallel",
        ),
        ("highlight_lines", {"a1": [0, 1, 0], "a2": [0, -3, 0]}, "non-parallel"),
        (
            "reflection_lines",
            {"form": "infinity", "axis": [0, 0, 1], "reference": [0, 0, 2]},
            "reference: expected a direction not parallel",
        ),
        ("planar_sections", {"direction": [0, 0, 0]}, "direction: expected a direction"),
        ("curvature", {}, "function: expected one of planar_sections, isophotes"),
    ],
)
def test_bad_parameters_name_the_parameter(name, params, message):
    d = plane_patch().derivatives(0.5, 0.5, 3)
    with pytest.raises(GshadeError, match=message):
        evaluate(name, d, **params)


def test_one_parameter_is_checked_by_its_declaration():
    """validate_parameter (what a scene file's [shape] keys go through) names the parameter;
    evaluate names the function too."""
    assert validate_parameter("isophotes", "form", "angle") == "angle"
    np.testing.assert_array_equal(validate_parameter("isophotes", "light", [0, 0, 2]), [0, 0, 1])
    np.testing.assert_array_equal(
        validate_parameter("reflection_lines", "a1", [0, 2, 0]), [0, 2, 0]
    )
    np.testing.assert_array_equal(validate_parameter("reflection_lines", "eye_point", [0] * 3), 0)
    with pytest.raises(GshadeError, match=r"^light: expected a direction \[x, y, z\] of length"):
        validate_parameter("isophotes", "light", [0, 1e-13, 0])
    with pytest.raises(GshadeError, match=r"^isophotes: unknown parameter 'lihgt'"):
        validate_parameter("isophotes", "lihgt", [0, 0, 1])


def test_eye_on_the_surface_and_missing_orders():
    plane = plane_patch()
    d = plane.derivatives(np.array([0.5, 0.25]), 0.5, 2)
    with pytest.raises(GshadeError, match="eye_point: expected a point off the surface"):
        evaluate("reflection_lines", d, eye_point=d[0, 0][0])
    with pytest.raises(GshadeError, match="mean: needs derivatives of order 3"):
        evaluate("mean", d)
    assert evaluate("mean", d, gradient=False).gradient is None


def test_teapot_collapsed_edges_give_finite_flagged_values():
    patch = read_newell(TEAPOT)[20]
    u, v = patch.parameter_grid(9, 9)
    raw = patch.derivatives(u, v, 3)
    for name in FORMULAS:
        res = evaluate(
            name, raw, **({"eye_point": [0, -8, 5]} if name == "reflection_lines" else {})
        )
        assert np.all(np.isfinite(res.f)) and np.all(np.isfinite(res.gradient))
        if SHAPE_FUNCTIONS[name].order >= 1 and name != "parametrisation_quality":
            assert not res.valid[0].any(), name  # the collapsed edge is flagged
    reg = regularised_derivatives(patch, u, v, 3)
    res = evaluate("mean", reg.d)
    assert res.valid.all() and np.all(np.isfinite(res.f))


# --------------------------------------------------------------------------- backends


@pytest.mark.parametrize("name", FORMULAS)
def test_drjit_and_numpy_backends_agree(name):
    """The formulas run on Dr.Jit's LLVM backend and on numpy; both must give the same
    values, gradients and masks (to round-off: LLVM may fuse multiply-adds)."""
    pytest.importorskip("drjit")
    from gshade.shape.kernels import backend

    if backend() != "drjit":
        pytest.skip("no usable libLLVM here: only the numpy backend runs")
    rng = np.random.default_rng(7)
    P = np.zeros((4, 4, 3))
    P[..., 0] = np.arange(4)[:, None]
    P[..., 1] = np.arange(4)[None, :]
    P[..., 2] = rng.normal(scale=0.7, size=(4, 4))
    patch = BezierPatch(P, rng.uniform(0.6, 1.5, (4, 4)))
    d = patch.derivatives(*patch.parameter_grid(40, 30), 3)
    d[..., 0, 0, :] = 0.0  # an irregular point: flagged by both
    params = {"eye_point": [1.5, -6, 4]} if name == "reflection_lines" else {}
    forms = SHAPE_FUNCTIONS[name].parameters.get("form")
    for form in forms.choices if forms else (None,):
        kw = {**params, **({"form": form} if form else {})}
        a = evaluate(name, d, backend="drjit", **kw)
        b = evaluate(name, d, backend="numpy", **kw)
        np.testing.assert_array_equal(a.valid, b.valid)
        assert not a.valid[0, 0] or SHAPE_FUNCTIONS[name].order == 0
        scale = np.abs(b.f).max() + 1
        np.testing.assert_allclose(a.f, b.f, rtol=1e-12, atol=1e-12 * scale)
        gscale = np.abs(b.gradient).max() + 1
        np.testing.assert_allclose(a.gradient, b.gradient, rtol=1e-10, atol=1e-12 * gscale)


def test_unknown_backend_is_named():
    d = plane_patch().derivatives(0.5, 0.5, 2)
    with pytest.raises(GshadeError, match="backend: expected one of auto, drjit, numpy"):
        evaluate("isophotes", d, backend="cuda")
