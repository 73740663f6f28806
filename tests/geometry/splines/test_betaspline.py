"""β-splines: the uniform B-spline as a special case, G2 (not C2) junctions, global and
per-junction shape parameters, patches, scene files."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade import GshadeError
from gshade.geometry import BetaSplineCurve, BetaSplinePatch, BSplineCurve, BSplinePatch

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


def test_bias_one_and_no_tension_is_the_uniform_cubic_bspline():
    rng = np.random.default_rng(0)
    P = rng.normal(size=(8, 3))
    beta = BetaSplineCurve(P, 1.0, 0.0)
    uniform = BSplineCurve(P, 3, np.arange(12.0))  # domain [3, 8]
    t = np.linspace(0, 5, 41)
    np.testing.assert_allclose(beta.derivatives(t, 3), uniform.derivatives(t + 3, 3), atol=1e-12)
    Q = rng.normal(size=(5, 6, 3))
    patch = BetaSplinePatch(Q)
    spline = BSplinePatch(Q, (3, 3), (np.arange(9.0), np.arange(10.0)))
    u, v = rng.uniform(0, 2, 10), rng.uniform(0, 3, 10)
    np.testing.assert_allclose(
        patch.derivatives(u, v, 2), spline.derivatives(u + 3, v + 3, 2), atol=1e-12
    )


@settings(max_examples=40, deadline=None)
@given(beta1=st.floats(0.2, 5.0), beta2=st.floats(0.0, 20.0), seed=st.integers(0, 2**32 - 1))
def test_junctions_satisfy_the_g2_equations_and_curvature_is_continuous(beta1, beta2, seed):
    P = np.random.default_rng(seed).normal(size=(7, 3))
    curve = BetaSplineCurve(P, beta1, beta2)
    for t in (1.0, 2.0, 3.0):
        left, right = one_sided(curve, t)
        scale = 1 + np.abs(left).max() * (1 + beta1**2 + beta2)
        np.testing.assert_allclose(right[0], left[0], atol=1e-9 * scale)
        np.testing.assert_allclose(right[1], beta1 * left[1], atol=1e-9 * scale)
        np.testing.assert_allclose(
            right[2], beta1**2 * left[2] + beta2 * left[1], atol=1e-8 * scale
        )

        def curvature(d):
            return np.linalg.norm(np.cross(d[1], d[2])) / np.linalg.norm(d[1]) ** 3

        if np.linalg.norm(left[1]) > 1e-3:
            assert curvature(left) == pytest.approx(curvature(right), rel=1e-6, abs=1e-9)


def test_not_c2_in_general():
    P = np.random.default_rng(3).normal(size=(6, 3))
    left, right = one_sided(BetaSplineCurve(P, 1.5, 2.0), 1.0)
    assert np.abs(right[1] - left[1]).max() > 1e-3  # C1 fails (the bias)
    assert np.abs(right[2] - left[2]).max() > 1e-3  # and C2


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: BetaSplineCurve(np.zeros((6, 3)), 0.0, 1.0), "beta1: expected a number > 0"),
        (lambda: BetaSplineCurve(np.zeros((6, 3)), 1.0, -1.0), "beta2: expected a number >= 0"),
        (lambda: BetaSplineCurve(np.zeros((3, 3))), "at least 4"),
        (lambda: BetaSplinePatch(np.zeros((5, 5, 3)), beta1=(1.0, -2.0)), "beta1"),
    ],
)
def test_bad_shape_parameters(make, message):
    with pytest.raises(GshadeError, match=message):
        make()


# --------------------------------------------------------------------------- per-junction β


def curvature_vector(d):
    """k N = (c'' - (c''·T) T) / |c'|^2 with T = c' / |c'|: the same for any regular
    reparametrisation, so equal on both sides of a G2 junction."""
    t = d[1] / np.linalg.norm(d[1])
    return (d[2] - np.dot(d[2], t) * t) / np.dot(d[1], d[1])


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_per_junction_beta_splines_satisfy_each_junctions_equations(seed):
    rng = np.random.default_rng(seed)
    P = rng.normal(size=(8, 3))  # 5 arcs, interior junctions T = 1..4
    beta1 = rng.uniform(0.2, 5.0, 4)
    beta2 = rng.uniform(0.0, 20.0, 4) * (rng.uniform(size=4) < 0.8)
    curve = BetaSplineCurve(P, beta1, beta2)
    assert curve.domain == (0.0, 5.0)
    assert curve.beta1 == tuple(beta1) and curve.beta2 == tuple(beta2)
    for j, (b1, b2) in enumerate(zip(beta1, beta2, strict=True), start=1):
        left, right = one_sided(curve, float(j))
        scale = 1 + np.abs(left).max() * (1 + b1**2 + b2)
        np.testing.assert_allclose(right[0], left[0], atol=1e-10 * scale)
        np.testing.assert_allclose(right[1], b1 * left[1], atol=1e-10 * scale)
        np.testing.assert_allclose(right[2], b1**2 * left[2] + b2 * left[1], atol=1e-9 * scale)
        if np.linalg.norm(left[1]) > 1e-2:  # curvature continuous: G2
            k_left, k_right = curvature_vector(left), curvature_vector(right)
            np.testing.assert_allclose(
                k_right, k_left, rtol=1e-7, atol=1e-7 * (1 + np.abs(k_left).max())
            )
    # partition of unity (and the curve is affine invariant)
    t = rng.uniform(0, 5, 50)
    shift = rng.normal(size=3)
    np.testing.assert_allclose(
        BetaSplineCurve(P + shift, beta1, beta2)(t), curve(t) + shift, atol=1e-12
    )


def test_per_junction_beta_splines_are_g2_but_not_c2():
    P = np.random.default_rng(7).normal(size=(7, 3))
    curve = BetaSplineCurve(P, [0.5, 1.0, 2.5], [3.0, 0.0, 1.0])
    for j in (1, 2, 3):
        left, right = one_sided(curve, float(j))
        np.testing.assert_allclose(
            curvature_vector(right), curvature_vector(left), rtol=1e-8, atol=1e-10
        )
        if j != 2:  # second derivatives jump: not C2
            assert np.abs(right[2] - left[2]).max() > 1e-2
    # junction 2 has β1 = 1, β2 = 0: C2 there, and only there
    left, right = one_sided(curve, 2.0)
    np.testing.assert_allclose(right[:3], left[:3], atol=1e-12)


def test_per_junction_values_one_and_zero_give_the_uniform_cubic_bspline():
    rng = np.random.default_rng(4)
    P = rng.normal(size=(9, 3))
    beta = BetaSplineCurve(P, [1.0] * 5, [0.0] * 5)
    uniform = BSplineCurve(P, 3, np.arange(13.0))  # domain [3, 9]
    t = np.linspace(0, 6, 61)
    np.testing.assert_allclose(beta.derivatives(t, 3), uniform.derivatives(t + 3, 3), atol=1e-12)
    Q = rng.normal(size=(6, 5, 3))
    patch = BetaSplinePatch(Q, beta1_u=[1, 1], beta2_u=[0, 0], beta1_v=[1], beta2_v=[0])
    spline = BSplinePatch(Q, (3, 3), (np.arange(10.0), np.arange(9.0)))
    u, v = rng.uniform(0, 3, 12), rng.uniform(0, 2, 12)
    np.testing.assert_allclose(
        patch.derivatives(u, v, 3), spline.derivatives(u + 3, v + 3, 3), atol=1e-12
    )


def test_constant_per_junction_values_give_the_global_beta_spline():
    rng = np.random.default_rng(5)
    P = rng.normal(size=(8, 3))
    t = rng.uniform(0, 5, 200)
    for b1, b2 in [(1.6, 4.0), (0.3, 11.0), (3.0, 0.0)]:
        glob = BetaSplineCurve(P, b1, b2)
        per = BetaSplineCurve(P, [b1] * 4, [b2] * 4)
        np.testing.assert_allclose(per.derivatives(t, 3), glob.derivatives(t, 3), atol=1e-12)
        # a number for one parameter and a list for the other broadcast likewise
        np.testing.assert_allclose(BetaSplineCurve(P, b1, [b2] * 4)(t), glob(t), atol=1e-12)
        # the Bézier form is the same curve
        np.testing.assert_allclose(
            glob.to_bspline().derivatives(t, 3), glob.derivatives(t, 3), atol=1e-12
        )
    Q = rng.normal(size=(6, 7, 3))
    glob = BetaSplinePatch(Q, (1.6, 0.7), (4.0, 0.5))
    per = BetaSplinePatch(Q, beta1_u=[1.6] * 2, beta2_u=[4.0] * 2, beta1_v=[0.7] * 3, beta2_v=0.5)
    u, v = np.linspace(0, 3, 13)[:, None], np.linspace(0, 4, 11)[None, :]
    np.testing.assert_allclose(per.derivatives(u, v, 3), glob.derivatives(u, v, 3), atol=1e-12)


def test_a_junctions_parameters_change_only_the_four_nearest_arcs():
    P = np.random.default_rng(6).normal(size=(10, 3))  # 7 arcs, junctions 1..6
    beta1 = np.array([1.0, 2.0, 0.5, 1.5, 1.0, 3.0])
    beta2 = np.array([0.0, 1.0, 4.0, 0.0, 2.0, 1.0])
    a = BetaSplineCurve(P, beta1, beta2)
    b1, b2 = beta1.copy(), beta2.copy()
    b1[2], b2[2] = 4.0, 9.0  # junction T = 3: arcs 1..4 (on [1, 5]) may change
    b = BetaSplineCurve(P, b1, b2)
    for arc in range(7):
        t = np.linspace(arc, arc + 1, 9)[1:-1]
        same = np.allclose(a(t), b(t), atol=1e-14, rtol=0)
        assert same == (arc not in (1, 2, 3, 4)), arc


def test_per_junction_beta_spline_patches_meet_the_g2_equations_across_knot_lines():
    rng = np.random.default_rng(8)
    Q = rng.normal(size=(7, 6, 3))
    beta1_u, beta2_u = [0.6, 1.7, 2.5], [0.0, 6.0, 1.0]
    beta1_v, beta2_v = [1.4, 0.8], [3.0, 0.5]
    patch = BetaSplinePatch(Q, beta1_u=beta1_u, beta2_u=beta2_u, beta1_v=beta1_v, beta2_v=beta2_v)
    assert patch.domain == ((0.0, 4.0), (0.0, 3.0))
    s = np.linspace(0.05, 2.95, 7)
    for j, (b1, b2) in enumerate(zip(beta1_u, beta2_u, strict=True), start=1):
        lo, hi = patch_one_sided(patch, "u", float(j), s)
        np.testing.assert_allclose(hi[0, 0], lo[0, 0], atol=1e-12)
        np.testing.assert_allclose(hi[1, 0], b1 * lo[1, 0], atol=1e-10)
        np.testing.assert_allclose(hi[0, 1], lo[0, 1], atol=1e-10)
        np.testing.assert_allclose(hi[2, 0], b1**2 * lo[2, 0] + b2 * lo[1, 0], atol=1e-9)
        np.testing.assert_allclose(hi[1, 1], b1 * lo[1, 1], atol=1e-9)
        np.testing.assert_allclose(hi[0, 2], lo[0, 2], atol=1e-9)
    s = np.linspace(0.05, 3.95, 7)
    for j, (b1, b2) in enumerate(zip(beta1_v, beta2_v, strict=True), start=1):
        lo, hi = patch_one_sided(patch, "v", float(j), s)
        np.testing.assert_allclose(hi[0, 1], b1 * lo[0, 1], atol=1e-10)
        np.testing.assert_allclose(hi[0, 2], b1**2 * lo[0, 2] + b2 * lo[0, 1], atol=1e-9)
    # the grid path and the point path agree
    u, v = np.linspace(0, 4, 9), np.linspace(0, 3, 7)
    grid = patch.derivatives(u[:, None], v[None, :], 3)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    np.testing.assert_allclose(grid, patch.derivatives(uu, vv, 3), atol=1e-12)


def test_beta_spline_patches_are_g2_by_the_continuity_measures():
    rng = np.random.default_rng(9)
    x, y = np.meshgrid(np.arange(6.0), np.arange(5.0), indexing="ij")
    Q = np.stack([x, y, 0.4 * rng.normal(size=x.shape)], axis=-1)
    beta = BetaSplinePatch(Q, beta1_u=[0.6, 2.0], beta2_u=[5.0, 0.0], beta1_v=1.5, beta2_v=2.0)
    found = continuity_classes(beta.to_bspline())
    assert len(found) == 3 * 1 + 2 * 2
    assert set(found) == {"G2"}, found  # curvature continuous, its gradient not


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (
            lambda: BetaSplineCurve(np.zeros((7, 3)), [1.0, 0.0, 2.0]),
            r"beta1: expected numbers > 0 \(the bias\), got 0.0 at junction 2 \(of 3\)",
        ),
        (
            lambda: BetaSplineCurve(np.zeros((7, 3)), [1.0, 2.0]),
            r"beta1: .* a list of 3 such numbers \(one per interior junction \(7 control "
            r"points\)\), got 2 numbers",
        ),
        (
            lambda: BetaSplineCurve(np.zeros((7, 3)), 1.0, [0.0, -1.0, 0.0]),
            r"beta2: expected numbers >= 0 \(the tension\), got -1.0 at junction 2",
        ),
        (lambda: BetaSplineCurve(np.zeros((4, 3)), [1.0]), "no interior junction"),
        (lambda: BetaSplineCurve(np.zeros((7, 3)), [1e308] * 3), "small enough for a finite"),
        (lambda: BetaSplineCurve(np.zeros((7, 3)), "x"), "beta1: expected a number > 0"),
        (lambda: BetaSplineCurve(np.zeros((7, 3)), -0.5), "beta1: expected a number > 0"),
        (
            lambda: BetaSplinePatch(np.zeros((6, 5, 3)), beta1_v=[1.0, 1.0]),
            r"beta1_v: .* a list of 1 such numbers",
        ),
        (
            lambda: BetaSplinePatch(np.zeros((6, 5, 3)), beta2_u=[1.0, -2.0]),
            "beta2_u: expected numbers >= 0",
        ),
        (lambda: BetaSplinePatch(np.zeros((3, 5, 3))), "at least 4"),
    ],
)
def test_bad_beta_spline_input(make, message):
    check_one_line_error(make, message)


# --------------------------------------------------------------------------- scene files


def test_scene_type_betaspline_per_junction(tmp_path):
    points = f"points = {NET_7x6}\n"
    _, scene = load(
        tmp_path,
        'type = "betaspline"\nbeta1_u = [0.6, 1.0, 2.0]\nbeta2_u = [0, 8, 0]\n'
        "beta1_v = [1, 1.5]\nbeta2 = 2\n" + points,
    )
    patch = scene.surfaces[1].patches[0]
    expected = BetaSplinePatch(
        NET_7x6, 1.0, 2.0, beta1_u=[0.6, 1, 2], beta2_u=[0, 8, 0], beta1_v=[1, 1.5]
    )
    assert patch.beta1 == ((0.6, 1.0, 2.0), (1.0, 1.5)) and patch.beta2 == (
        (0.0, 8.0, 0.0),
        (2.0, 2.0),
    )
    u, v = np.linspace(0, 4, 9)[:, None], np.linspace(0, 3, 7)[None, :]
    np.testing.assert_array_equal(patch.derivatives(u, v, 2), expected.derivatives(u, v, 2))


BAD_SCENES = {
    "beta1_u length": (
        'type = "betaspline"\nbeta1_u = [1, 2]\n',
        r"beta1_u: expected a number > 0 \(the bias\) or a list of 3 such numbers \(one per "
        r"interior junction \(7 control points\)\), got 2 numbers",
    ),
    "beta2_v negative": (
        'type = "betaspline"\nbeta2_v = [1, -1]\n',
        r"beta2_v: expected numbers >= 0 \(the tension\), got -1.0 at junction 2 \(of 2\)",
    ),
    "beta1 zero": (
        'type = "betaspline"\nbeta1 = 0\n',
        r"beta1: expected a number > 0 \(the bias\), got 0.0",
    ),
    "beta1_v zero in list": ('type = "betaspline"\nbeta1_v = [1, 0]\n', r"beta1_v: expected"),
    "betaspline few points": (
        'type = "betaspline"\npoints = [[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]]\n',
        r"points: expected at least 4 control points per direction for the β-spline patch, "
        r"got shape \(2, 2, 3\)",
    ),
}


@pytest.mark.parametrize("case", list(BAD_SCENES))
def test_bad_beta_spline_scenes(tmp_path, case):
    check_bad_scene(tmp_path, *BAD_SCENES[case])


@pytest.mark.parametrize("key", ["beta1", "beta2", "beta1_u", "beta2_v"])
def test_any_wrong_value_of_a_beta_spline_key_gives_a_gshade_error(key):
    check_wrong_values("betaspline-junctions", key)
