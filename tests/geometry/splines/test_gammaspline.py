"""γ-splines: the cubic B-spline as γ ≡ 1 (uniform and nonuniform knots), the junction
equations C1 and p'' jumping by ν p' (exact one-sided derivatives and finite differences),
G2 but not C2, the β-spline with β1 = 1 for uniform knots, patches, scene files."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import BSpline

from gshade.geometry import BetaSplineCurve, BSplineCurve, GammaSplineCurve, GammaSplinePatch
from gshade.geometry.core.differential import gaussian_and_mean_curvature, unit_normal
from gshade.geometry.splines.gammaspline import gamma_from_nu, nu_from_gamma

from ...support.spline_checks import (
    NET_7x6,
    check_bad_scene,
    check_one_line_error,
    check_wrong_values,
    continuity_classes,
    load,
    one_sided,
    patch_one_sided,
)


def random_knots(rng, count):
    """``count`` strictly increasing knots with intervals between 0.3 and 3."""
    return np.cumsum(rng.uniform(0.3, 3.0, count)) - 2.0


def curvature_vector(d):
    """k N = (c'' - (c''·T) T) / |c'|^2: the same for any regular reparametrisation."""
    t = d[1] / np.linalg.norm(d[1])
    return (d[2] - np.dot(d[2], t) * t) / np.dot(d[1], d[1])


def expected_nu(gamma, knots, k):
    """ν at knot t_k from γ, written out: 2 (h_(k-1) + h_k) (1 - γ) / (γ h_(k-1) h_k)."""
    a, b = knots[k] - knots[k - 1], knots[k + 1] - knots[k]
    return 2 * (a + b) * (1 - gamma) / (gamma * a * b)


# --------------------------------------------------------------------------- γ = 1


def test_gamma_one_is_the_uniform_cubic_bspline():
    rng = np.random.default_rng(0)
    P = rng.normal(size=(8, 3))
    for gamma in (1.0, [1.0] * 4):
        curve = GammaSplineCurve(P, gamma)
        assert curve.domain == (0.0, 5.0)
        uniform = BSplineCurve(P, 3, np.arange(12.0))  # domain [3, 8]
        t = np.linspace(0, 5, 41)
        np.testing.assert_allclose(
            curve.derivatives(t, 3), uniform.derivatives(t + 3, 3), atol=1e-12
        )
    Q = rng.normal(size=(5, 6, 3))
    patch = GammaSplinePatch(Q)
    u, v = rng.uniform(0, 2, 10), rng.uniform(0, 3, 10)
    d = patch.derivatives(u, v, 3)
    # independently: scipy's B-spline in u of the rows, then in v
    for i in range(4):
        for j in range(4 - i):
            rows = BSpline(np.arange(9.0) - 3, Q.reshape(5, -1), 3)(u, i).reshape(-1, 6, 3)
            want = np.stack(
                [BSpline(np.arange(10.0) - 3, rows[n], 3)(v[n], j) for n in range(u.size)]
            )
            np.testing.assert_allclose(d[i, j], want, atol=1e-11)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_gamma_one_is_the_nonuniform_cubic_bspline(seed):
    rng = np.random.default_rng(seed)
    P = rng.normal(size=(9, 2))
    knots = random_knots(rng, 13)
    curve = GammaSplineCurve(P, [1.0] * 5, knots)
    assert curve.domain == (knots[3], knots[9])
    t = np.linspace(*curve.domain, 57)
    reference = BSpline(knots, P, 3)
    d = curve.derivatives(t, 3)
    for k in range(4):
        np.testing.assert_allclose(d[k], reference(t, k), atol=1e-9 * 10**k)
    Q = rng.normal(size=(6, 5, 3))
    ku, kv = random_knots(rng, 10), random_knots(rng, 9)
    patch = GammaSplinePatch(Q, knots_u=ku, knots_v=kv)
    u = rng.uniform(ku[3], ku[6], 8)
    v = rng.uniform(kv[3], kv[5], 8)
    d = patch.derivatives(u, v, 2)
    rows = BSpline(ku, Q.reshape(6, -1), 3)(u).reshape(-1, 5, 3)
    want = np.stack([BSpline(kv, rows[n], 3)(v[n]) for n in range(u.size)])
    np.testing.assert_allclose(d[0, 0], want, atol=1e-12)


# --------------------------------------------------------------------------- junctions


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), uniform=st.booleans())
def test_junctions_are_c1_with_the_second_derivative_jumping_by_nu_times_the_first(seed, uniform):
    rng = np.random.default_rng(seed)
    P = rng.normal(size=(9, 3))  # 6 arcs, interior knots t_4..t_8
    knots = np.arange(13.0) - 3 if uniform else random_knots(rng, 13)
    gamma = rng.uniform(0.1, 3.0, 5) * (rng.uniform(size=5) < 0.8) + (rng.uniform(size=5) < 0.2)
    gamma = np.where(gamma > 0, gamma, 1.0)
    curve = GammaSplineCurve(P, gamma, None if uniform else knots)
    nus = [expected_nu(g, knots, k) for k, g in zip(range(4, 9), gamma, strict=True)]
    np.testing.assert_allclose(curve.nu, nus, rtol=1e-12)
    for k, nu in zip(range(4, 9), nus, strict=True):
        left, right = one_sided(curve, float(knots[k]))
        scale = 1 + np.abs(left).max() * (1 + abs(nu))
        np.testing.assert_allclose(right[0], left[0], atol=1e-11 * scale)
        np.testing.assert_allclose(right[1], left[1], atol=1e-10 * scale)
        np.testing.assert_allclose(right[2], left[2] + nu * left[1], atol=1e-9 * scale)
        if np.linalg.norm(left[1]) > 1e-2:  # curvature continuous: G2
            k_left, k_right = curvature_vector(left), curvature_vector(right)
            np.testing.assert_allclose(
                k_right, k_left, rtol=1e-7, atol=1e-7 * (1 + np.abs(k_left).max())
            )


def fitted_derivatives(curve, t0, side, step):
    """c, c', c'' at t0 from four samples on one side, by the cubic through them: a finite
    difference formula of order 3, exact on a cubic arc (up to rounding)."""
    s = t0 + side * step * np.arange(0.5, 4.5)  # inside the arc, never at the knot itself
    values = curve(s)
    coefficients = np.polyfit(s - t0, values, 3)  # (4, dim), highest power first
    return coefficients[3], coefficients[2], 2 * coefficients[1]


@pytest.mark.parametrize("seed", [4, 5, 6])
def test_junction_equations_hold_by_finite_differences(seed):
    rng = np.random.default_rng(seed)
    P = rng.normal(size=(8, 3))
    knots = random_knots(rng, 12)
    gamma = np.array([0.3, 1.7, 0.6, 1.0])
    curve = GammaSplineCurve(P, gamma, knots)
    for k, g in zip(range(4, 8), gamma, strict=True):
        tk = knots[k]
        step = 0.1 * min(tk - knots[k - 1], knots[k + 1] - tk)
        p0, p1, p2 = fitted_derivatives(curve, tk, -1, step)
        q0, q1, q2 = fitted_derivatives(curve, tk, +1, step)
        nu = expected_nu(g, knots, k)
        scale = 1 + np.abs(p2).max() + abs(nu) * np.abs(p1).max()
        np.testing.assert_allclose(q0, p0, atol=1e-8 * scale)
        np.testing.assert_allclose(q1, p1, atol=1e-6 * scale)
        np.testing.assert_allclose(q2, p2 + nu * p1, atol=1e-5 * scale)
        if g != 1.0:  # the jump is really there, far above the differences' error
            assert np.abs(q2 - p2).max() > 1e-2
        # and crude difference quotients agree too
        eps = 1e-5
        d_left = (curve(np.array([tk - eps]))[0] - curve(np.array([tk - 2 * eps]))[0]) / eps
        d_right = (curve(np.array([tk + 2 * eps]))[0] - curve(np.array([tk + eps]))[0]) / eps
        np.testing.assert_allclose(d_right, d_left, atol=1e-3 * scale)


def test_g2_but_not_c2_and_c2_where_gamma_is_one():
    rng = np.random.default_rng(7)
    P = rng.normal(size=(7, 3))
    knots = random_knots(rng, 11)
    curve = GammaSplineCurve(P, [0.5, 1.0, 2.5], knots)
    for k in (4, 5, 6):
        left, right = one_sided(curve, float(knots[k]))
        np.testing.assert_allclose(
            curvature_vector(right), curvature_vector(left), rtol=1e-8, atol=1e-10
        )
        if k != 5:
            assert np.abs(right[2] - left[2]).max() > 1e-2  # the second derivative jumps
    left, right = one_sided(curve, float(knots[5]))  # γ = 1: C2 there (C3 fails)
    np.testing.assert_allclose(right[:3], left[:3], atol=1e-10)


def test_uniform_gamma_splines_are_beta_splines_with_unit_bias_and_tension_nu():
    rng = np.random.default_rng(8)
    P = rng.normal(size=(9, 3))
    nu = np.array([0.0, 3.0, 12.0, 0.5, 40.0])
    gamma = gamma_from_nu(nu, 1.0, 1.0)
    np.testing.assert_allclose(gamma, 1 / (1 + nu / 4))
    np.testing.assert_allclose(nu_from_gamma(gamma, 1.0, 1.0), nu, atol=1e-12)
    t = np.linspace(0, 6, 61)
    np.testing.assert_allclose(
        GammaSplineCurve(P, gamma).derivatives(t, 3),
        BetaSplineCurve(P, 1.0, nu).derivatives(t, 3),
        atol=1e-11,
    )
    np.testing.assert_allclose(
        GammaSplineCurve(P, 0.5).derivatives(t, 3),
        BetaSplineCurve(P, 1.0, 4.0).derivatives(t, 3),
        atol=1e-11,
    )


def test_gamma_and_nu_are_inverse_for_any_knot_intervals():
    rng = np.random.default_rng(9)
    a, b = rng.uniform(0.1, 5, 20), rng.uniform(0.1, 5, 20)
    gamma = rng.uniform(0.05, 4.0, 20)
    nu = nu_from_gamma(gamma, a, b)
    np.testing.assert_allclose(gamma_from_nu(nu, a, b), gamma, rtol=1e-12)
    assert np.all((nu > 0) == (gamma < 1))


# --------------------------------------------------------------------------- the basis


def test_partition_of_unity_nonnegative_basis_and_affine_invariance():
    rng = np.random.default_rng(10)
    P = rng.normal(size=(10, 3))
    knots = random_knots(rng, 14)
    gamma = rng.uniform(0.1, 4.0, 6)
    curve = GammaSplineCurve(P, gamma, knots)
    t = rng.uniform(*curve.domain, 200)
    B = curve._basis.dense(t, 3)
    np.testing.assert_allclose(B[0].sum(axis=1), 1.0, atol=1e-13)
    np.testing.assert_allclose(B[1:].sum(axis=2), 0.0, atol=1e-9)
    assert B[0].min() >= -1e-15  # the curve lies in its control polygon's convex hull
    A, shift = rng.normal(size=(3, 3)), rng.normal(size=3)
    moved = GammaSplineCurve(P @ A.T + shift, gamma, knots)
    np.testing.assert_allclose(moved(t), curve(t) @ A.T + shift, atol=1e-12)
    # the Bézier form (segments, B-spline with triple knots) is the same curve
    segments = curve.bezier_segments()
    assert segments.shape == (7, 4, 3)
    np.testing.assert_allclose(segments[1:, 0], segments[:-1, 3], atol=1e-14)
    np.testing.assert_allclose(
        curve.to_bspline().derivatives(t, 3), curve.derivatives(t, 3), atol=1e-9
    )
    np.testing.assert_allclose(segments[:, 0], curve(knots[3:10]), atol=1e-13)


def test_a_knots_gamma_changes_only_the_four_nearest_arcs():
    rng = np.random.default_rng(11)
    P = rng.normal(size=(10, 3))  # 7 arcs [t_3, t_4] .. [t_9, t_10], interior knots t_4..t_9
    knots = random_knots(rng, 14)
    gamma = np.array([1.0, 2.0, 0.5, 1.5, 1.0, 3.0])
    a = GammaSplineCurve(P, gamma, knots)
    changed = gamma.copy()
    changed[2] = 0.2  # knot t_6: arcs 1..4 ([t_4, t_8]) may change
    b = GammaSplineCurve(P, changed, knots)
    for arc in range(7):
        t = np.linspace(knots[arc + 3], knots[arc + 4], 9)[1:-1]
        same = np.allclose(a(t), b(t), atol=1e-14, rtol=0)
        assert same == (arc not in (1, 2, 3, 4)), arc


# --------------------------------------------------------------------------- patches


def g2_patch(rng):
    Q = rng.normal(size=(7, 6, 3))
    ku, kv = random_knots(rng, 11), random_knots(rng, 10)
    gamma_u, gamma_v = [0.3, 1.0, 2.2], [0.5, 1.6]
    return GammaSplinePatch(Q, gamma_u=gamma_u, gamma_v=gamma_v, knots_u=ku, knots_v=kv)


def test_patches_meet_the_g2_equations_across_knot_lines():
    patch = g2_patch(np.random.default_rng(12))
    (ku, kv), (gu, gv) = patch.knots, patch.gamma
    assert patch.domain == ((ku[3], ku[7]), (kv[3], kv[6]))
    s = np.linspace(kv[3], kv[6], 7)
    for k, g in zip(range(4, 7), gu, strict=True):
        nu = expected_nu(g, ku, k)
        lo, hi = patch_one_sided(patch, "u", float(ku[k]), s)
        np.testing.assert_allclose(hi[0, 0], lo[0, 0], atol=1e-12)
        np.testing.assert_allclose(hi[1, 0], lo[1, 0], atol=1e-10)
        np.testing.assert_allclose(hi[0, 1], lo[0, 1], atol=1e-10)
        np.testing.assert_allclose(hi[2, 0], lo[2, 0] + nu * lo[1, 0], atol=1e-8)
        np.testing.assert_allclose(hi[1, 1], lo[1, 1], atol=1e-9)
        np.testing.assert_allclose(hi[0, 2], lo[0, 2], atol=1e-9)
        if g != 1.0:
            assert np.abs(hi[2, 0] - lo[2, 0]).max() > 1e-2
    s = np.linspace(ku[3], ku[7], 7)
    for k, g in zip(range(4, 6), gv, strict=True):
        nu = expected_nu(g, kv, k)
        lo, hi = patch_one_sided(patch, "v", float(kv[k]), s)
        np.testing.assert_allclose(hi[0, 1], lo[0, 1], atol=1e-10)
        np.testing.assert_allclose(hi[1, 0], lo[1, 0], atol=1e-10)
        np.testing.assert_allclose(hi[0, 2], lo[0, 2] + nu * lo[0, 1], atol=1e-8)
        np.testing.assert_allclose(hi[2, 0], lo[2, 0], atol=1e-9)
    np.testing.assert_allclose(
        patch.nu[0],
        [expected_nu(g, ku, k) for k, g in zip(range(4, 7), gu, strict=True)],
        rtol=1e-12,
    )
    # the grid path and the point path agree
    u, v = np.linspace(ku[3], ku[7], 9), np.linspace(kv[3], kv[6], 7)
    grid = patch.derivatives(u[:, None], v[None, :], 3)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    np.testing.assert_allclose(grid, patch.derivatives(uu, vv, 3), atol=1e-11)


def test_patch_normals_and_curvatures_are_continuous_across_knot_lines():
    rng = np.random.default_rng(13)
    x, y = np.meshgrid(np.arange(7.0), np.arange(6.0), indexing="ij")
    Q = np.stack([x, y, 0.6 * rng.normal(size=x.shape)], axis=-1)
    ku, kv = np.arange(11.0) - 3, random_knots(rng, 10)
    patch = GammaSplinePatch(Q, gamma_u=[0.25, 1.0, 3.0], gamma_v=0.4, knots_u=ku, knots_v=kv)
    checks = [("u", ku[k], np.linspace(kv[3], kv[6], 11)) for k in (4, 6)]
    checks += [("v", kv[k], np.linspace(ku[3], ku[7], 11)) for k in (4, 5)]
    for direction, knot, s in checks:
        lo, hi = patch_one_sided(patch, direction, float(knot), s)
        np.testing.assert_allclose(unit_normal(hi).n, unit_normal(lo).n, atol=1e-10)
        K_lo, H_lo = gaussian_and_mean_curvature(lo)
        K_hi, H_hi = gaussian_and_mean_curvature(hi)
        np.testing.assert_allclose(K_hi, K_lo, rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(H_hi, H_lo, rtol=1e-7, atol=1e-9)
        # second derivatives across the line jump (not C2), the curvatures do not
        i, j = (2, 0) if direction == "u" else (0, 2)
        assert np.abs(hi[i, j] - lo[i, j]).max() > 1e-2
    assert set(continuity_classes(patch.to_bspline())) == {"G2"}


def test_patch_curves_are_gamma_spline_curves_of_the_rows():
    patch = g2_patch(np.random.default_rng(14))
    (ku, kv), (gu, gv) = patch.knots, patch.gamma
    v0 = 0.3 * kv[3] + 0.7 * kv[6]
    rows = np.stack(
        [GammaSplineCurve(patch.points[i], gv, kv)(np.array([v0]))[0] for i in range(7)]
    )
    curve = GammaSplineCurve(rows, gu, ku)
    u = np.linspace(ku[3], ku[7], 17)
    np.testing.assert_allclose(
        patch.derivatives(u, np.full_like(u, v0), 3)[:, 0], curve.derivatives(u, 3), atol=1e-11
    )


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (
            lambda: GammaSplineCurve(np.zeros((7, 3)), [1.0, 0.0, 2.0]),
            r"gamma: expected numbers > 0, got 0.0 at junction 2 \(of 3\)",
        ),
        (
            lambda: GammaSplineCurve(np.zeros((7, 3)), [1.0, 2.0]),
            r"gamma: expected a number > 0 or a list of 3 such numbers \(one per interior "
            r"junction \(7 control points\)\), got 2 numbers",
        ),
        (lambda: GammaSplineCurve(np.zeros((4, 3)), [1.0]), "no interior junction"),
        (lambda: GammaSplineCurve(np.zeros((7, 3)), -0.5), "gamma: expected a number > 0"),
        (lambda: GammaSplineCurve(np.zeros((7, 3)), "x"), "gamma: expected a number > 0"),
        (lambda: GammaSplineCurve(np.zeros((7, 3)), np.nan), "gamma: expected a number > 0"),
        (lambda: GammaSplineCurve(np.zeros((7, 3)), [1e308] * 3), "small enough for a finite"),
        (
            lambda: GammaSplineCurve(np.zeros((5, 3)), 1.0, [0, 1, 2, 3, 4, 5, 6, 7]),
            r"knots: expected 9 strictly increasing numbers \(the cubic B-spline knot vector "
            r"of 5 control points\), got 8 numbers",
        ),
        (
            lambda: GammaSplineCurve(np.zeros((5, 3)), 1.0, [0, 1, 2, 3, 3, 5, 6, 7, 8]),
            "knots: expected 9 strictly increasing numbers",
        ),
        (lambda: GammaSplineCurve(np.zeros((3, 3))), "at least 4"),
        (
            lambda: GammaSplinePatch(np.zeros((6, 5, 3)), gamma_v=[1.0, 1.0]),
            r"gamma_v: expected a number > 0 or a list of 1 such numbers",
        ),
        (
            lambda: GammaSplinePatch(np.zeros((6, 5, 3)), gamma_u=[1.0, -2.0]),
            r"gamma_u: expected numbers > 0, got -2.0 at junction 2",
        ),
        (lambda: GammaSplinePatch(np.zeros((5, 5, 3)), gamma=(1.0, 0.0)), "gamma: expected"),
        (
            lambda: GammaSplinePatch(np.zeros((5, 5, 3)), knots_v=[0, 1, 2]),
            "knots_v: expected 9 strictly increasing numbers",
        ),
        (lambda: GammaSplinePatch(np.zeros((3, 5, 3))), "at least 4"),
    ],
)
def test_bad_gamma_spline_input(make, message):
    check_one_line_error(make, message)


# --------------------------------------------------------------------------- scene files


def test_scene_type_gammaspline(tmp_path):
    knots_v = [-3, -2, -1, 0, 1.5, 2.5, 4, 5, 6, 7]
    _, scene = load(
        tmp_path,
        f'type = "gammaspline"\ngamma_u = [0.6, 1.0, 2.0]\ngamma = 0.5\nknots_v = {knots_v}\n'
        f"points = {NET_7x6}\n",
    )
    patch = scene.surfaces[1].patches[0]
    assert isinstance(patch, GammaSplinePatch)
    assert patch.gamma == ((0.6, 1.0, 2.0), 0.5)
    expected = GammaSplinePatch(NET_7x6, 0.5, gamma_u=[0.6, 1, 2], knots_v=knots_v)
    u, v = np.linspace(0, 4, 9)[:, None], np.linspace(0, 4, 7)[None, :]
    np.testing.assert_array_equal(patch.derivatives(u, v, 2), expected.derivatives(u, v, 2))


BAD_SCENES = {
    "gamma_u length": (
        'type = "gammaspline"\ngamma_u = [1, 2]\n',
        r"gamma_u: expected a number > 0 or a list of 3 such numbers \(one per interior "
        r"junction \(7 control points\)\), got 2 numbers",
    ),
    "gamma_v zero in list": (
        'type = "gammaspline"\ngamma_v = [1, 0]\n',
        r"gamma_v: expected numbers > 0, got 0.0 at junction 2 \(of 2\)",
    ),
    "gamma negative": ('type = "gammaspline"\ngamma = -1\n', r"gamma: expected a number > 0"),
    "gamma_u a string": (
        'type = "gammaspline"\ngamma_u = "x"\n',
        r'gamma_u: expected a number or a list of numbers .*got "x"$',
    ),
    "knots_u count": (
        'type = "gammaspline"\nknots_u = [0, 1, 2]\n',
        r"knots_u: expected 11 strictly increasing numbers \(the cubic B-spline knot vector of "
        r"7 control points\), got 3 numbers",
    ),
    "knots_v decreasing": (
        'type = "gammaspline"\nknots_v = [0, 1, 2, 3, 4, 5, 6, 7, 9, 8]\n',
        r"knots_v: expected 10 strictly increasing numbers",
    ),
    "few points": (
        'type = "gammaspline"\npoints = [[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]]\n',
        r"points: expected at least 4 control points per direction for the γ-spline patch, "
        r"got shape \(2, 2, 3\)",
    ),
    "unknown key": ('type = "gammaspline"\ngama = 1\n', r"gama: unknown key; did you mean"),
}


@pytest.mark.parametrize("case", list(BAD_SCENES))
def test_bad_gamma_spline_scenes(tmp_path, case):
    check_bad_scene(tmp_path, *BAD_SCENES[case])


@pytest.mark.parametrize("key", ["points", "gamma", "gamma_u", "gamma_v", "knots_u", "knots_v"])
def test_any_wrong_value_of_a_gamma_spline_key_gives_a_gshade_error(key):
    check_wrong_values("gammaspline-mean", key)
