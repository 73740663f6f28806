"""ν-splines: the C2 interpolating spline at ν = 0, G2 with the given tensions, closed
curves, tensor-product patches, scene files."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade import GshadeError
from gshade.geometry import NuSplinePatch, nu_spline

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


def test_nu_zero_is_the_c2_interpolating_spline():
    from scipy.interpolate import CubicSpline

    rng = np.random.default_rng(1)
    a = rng.normal(size=(7, 3))
    u = np.concatenate([[0.0], np.cumsum(rng.uniform(0.5, 2.0, 6))])
    t = np.linspace(u[0], u[-1], 101)
    np.testing.assert_allclose(
        nu_spline(a, u)(t), CubicSpline(u, a, bc_type="natural")(t), atol=1e-12
    )
    b0, bn = rng.normal(size=3), rng.normal(size=3)
    clamped = CubicSpline(u, a, bc_type=((1, b0), (1, bn)))
    np.testing.assert_allclose(nu_spline(a, u, end_tangents=(b0, bn))(t), clamped(t), atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), tension=st.floats(0.0, 50.0))
def test_nu_splines_interpolate_and_are_g2_with_the_given_tension(seed, tension):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(6, 2))
    u = np.concatenate([[0.0], np.cumsum(rng.uniform(0.3, 2.0, 5))])
    nu = rng.uniform(0, tension, 6)
    curve = nu_spline(a, u, nu)
    np.testing.assert_allclose(curve(u), a, atol=1e-12)
    for i in range(1, 5):
        left, right = one_sided(curve, u[i])
        np.testing.assert_allclose(right[1], left[1], atol=1e-9 * (1 + np.abs(left[1]).max()))
        np.testing.assert_allclose(
            right[2], left[2] + nu[i] * left[1], atol=1e-8 * (1 + np.abs(right[2]).max())
        )


def test_tension_pulls_the_curve_to_the_polyline_and_bad_input():
    a = np.array([[0, 0], [1, 1], [2, 0], [3, 1.0]])
    knots = np.array([1.0, 2.0])
    loose, tight = nu_spline(a, nu=0.0), nu_spline(a, nu=1e4)
    # great tension: the tangents at the interior points shrink, the curve turns there
    slow = np.linalg.norm(tight.derivatives(knots, 1)[1], axis=-1)
    fast = np.linalg.norm(loose.derivatives(knots, 1)[1], axis=-1)
    assert np.all(slow < 1e-3 * fast)
    with pytest.raises(GshadeError, match="knots: expected 4 increasing numbers"):
        nu_spline(a, knots=[0, 1, 1, 2])
    with pytest.raises(GshadeError, match="nu: expected numbers >= 0"):
        nu_spline(a, nu=-1.0)
    with pytest.raises(GshadeError, match="at least 2"):
        nu_spline(a[:1])


def test_closed_nu_spline_curves_are_g2_where_they_close():
    from scipy.interpolate import CubicSpline

    rng = np.random.default_rng(11)
    a = rng.normal(size=(5, 2))
    knots = np.concatenate([[0.0], np.cumsum(rng.uniform(0.5, 2.0, 5))])
    np.testing.assert_allclose(
        nu_spline(a, knots, closed=True)(knots[:-1] + 0.3),
        CubicSpline(knots, np.vstack([a, a[:1]]), bc_type="periodic")(knots[:-1] + 0.3),
        atol=1e-12,
    )
    nu = rng.uniform(0, 10, 5)
    curve = nu_spline(a, knots, nu, closed=True)
    start = curve.derivatives(np.array([knots[0]]), 2)[:, 0]
    end = curve.derivatives(np.array([knots[-1]]), 2)[:, 0]
    np.testing.assert_allclose(end[0], start[0], atol=1e-12)
    np.testing.assert_allclose(start[1], end[1], atol=1e-10)
    np.testing.assert_allclose(start[2], end[2] + nu[0] * end[1], atol=1e-9)


# --------------------------------------------------------------------------- ν-spline patches


def nu_grid(seed, m=5, n=6):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(m, n, 3))
    u = np.concatenate([[0.0], np.cumsum(rng.uniform(0.4, 2.0, m - 1))])
    v = np.concatenate([[0.0], np.cumsum(rng.uniform(0.4, 2.0, n - 1))])
    return rng, A, u, v


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_nu_spline_patches_interpolate_and_are_tensor_products_of_the_curves(seed):
    rng, A, u, v = nu_grid(seed)
    nu_u, nu_v = rng.uniform(0, 20, 5), rng.uniform(0, 20, 6)
    patch = NuSplinePatch(A, u, v, nu_u, nu_v)
    assert patch.domain == ((u[0], u[-1]), (v[0], v[-1]))
    np.testing.assert_allclose(patch(u[:, None], v[None, :]), A, atol=1e-12)
    # on the knot lines the patch is the ν-spline curve through that row or column
    t = np.linspace(u[0], u[-1], 17)
    for j in (0, 2, 5):
        np.testing.assert_allclose(
            patch.derivatives(t, v[j], 2)[:, 0],
            nu_spline(A[:, j], u, nu_u).derivatives(t, 2),
            atol=1e-11,
        )
    # across u = u_i: p_u continuous, p_uu jumps by ν_i p_u; p_v, p_uv, p_vv continuous
    s = np.linspace(v[0], v[-1], 9)
    for i in range(1, 4):
        lo, hi = patch_one_sided(patch, "u", u[i], s)
        scale = 1 + np.abs(lo).max() * (1 + nu_u[i])
        np.testing.assert_allclose(hi[1, 0], lo[1, 0], atol=1e-10 * scale)
        np.testing.assert_allclose(hi[2, 0], lo[2, 0] + nu_u[i] * lo[1, 0], atol=1e-9 * scale)
        for k in ((0, 1), (1, 1), (0, 2)):
            np.testing.assert_allclose(hi[k], lo[k], atol=1e-9 * scale)


def test_nu_zero_patch_is_the_c2_bicubic_interpolating_spline():
    from scipy.interpolate import CubicSpline

    _, A, u, v = nu_grid(10)
    uu, vv = np.linspace(u[0], u[-1], 31), np.linspace(v[0], v[-1], 29)

    def natural(x, y, axis):
        return CubicSpline(x, y, axis=axis, bc_type="natural")

    # scipy's 1-D splines applied in u, then in v: the tensor-product interpolant
    ref = natural(v, natural(u, A, 0)(uu), 1)(vv)
    patch = NuSplinePatch(A, u, v)
    np.testing.assert_allclose(patch(uu[:, None], vv[None, :]), ref, atol=1e-12)
    d_uv = natural(v, natural(u, A, 0)(uu, 1), 1)(vv, 1)
    np.testing.assert_allclose(
        patch.derivatives(uu[:, None], vv[None, :], 2)[1, 1], d_uv, atol=1e-11
    )
    # C2 across the knot lines when ν = 0, not C2 with tension
    lo, hi = patch_one_sided(patch, "u", u[2], vv)
    np.testing.assert_allclose(hi[2, 0], lo[2, 0], atol=1e-10)
    tense = NuSplinePatch(A, u, v, nu_u=5.0)
    lo, hi = patch_one_sided(tense, "u", u[2], vv)
    assert np.abs(hi[2, 0] - lo[2, 0]).max() > 1e-2
    # closed in u: scipy's periodic spline
    closed = NuSplinePatch(A, np.append(u, u[-1] + 1.3), v, ends=("closed", "natural"))
    periodic = CubicSpline(
        np.append(u, u[-1] + 1.3), np.concatenate([A, A[:1]]), axis=0, bc_type="periodic"
    )
    uc = np.linspace(u[0], u[-1] + 1.3, 37)
    np.testing.assert_allclose(
        closed(uc[:, None], vv[None, :]), natural(v, periodic(uc), 1)(vv), atol=1e-12
    )


def test_nu_spline_patches_are_g2_by_the_continuity_measures():
    rng = np.random.default_rng(9)
    x, y = np.meshgrid(np.arange(6.0), np.arange(5.0), indexing="ij")
    Q = np.stack([x, y, 0.4 * rng.normal(size=x.shape)], axis=-1)
    nu = NuSplinePatch(Q, nu_u=[0, 4.0, 9.0, 2.0, 0, 0], nu_v=[0, 3.0, 1.0, 6.0, 0])
    found = continuity_classes(nu)
    assert len(found) == 4 * 4 + 3 * 5
    assert set(found) == {"G2"}, found  # curvature continuous, its gradient not


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: NuSplinePatch(np.zeros((1, 3, 3))), "at least 2"),
        (lambda: NuSplinePatch(np.zeros((4, 2, 3)), ends=("natural", "closed")), "at least 3"),
        (lambda: NuSplinePatch(np.zeros((4, 3, 3)), nu_u=-1.0), "nu_u: expected numbers >= 0"),
        (
            lambda: NuSplinePatch(np.zeros((4, 3, 3)), nu_v=[1.0, 2.0]),
            r"nu_v: expected numbers >= 0: one number or a list of 3 \(one per knot\), got 2",
        ),
        (
            lambda: NuSplinePatch(np.zeros((4, 3, 3)), knots_u=[0, 1, 1, 2]),
            r"knots_u: expected 4 increasing numbers, got \[0.0, 1.0, 1.0, 2.0\]",
        ),
        (lambda: NuSplinePatch(np.zeros((4, 3, 3)), ends="open"), "ends: expected one of"),
        (lambda: nu_spline(np.zeros((2, 3)), closed=True), "at least 3"),
        (lambda: nu_spline(np.zeros((4, 3)), nu=[1, 2]), "nu: expected .* list of 4"),
    ],
)
def test_bad_nu_spline_input(make, message):
    check_one_line_error(make, message)


# --------------------------------------------------------------------------- scene files


def test_scene_type_nuspline(tmp_path):
    points = f"points = {NET_7x6}\n"
    _, scene = load(
        tmp_path,
        'type = "nuspline"\nnu_u = [0, 1, 2, 3, 4, 5, 6]\nnu_v = 2.5\nends = ["natural", '
        '"closed"]\nknots_v = [0, 1, 2, 3, 4, 5, 7]\n' + points,
    )
    patch = scene.surfaces[1].patches[0]
    assert isinstance(patch, NuSplinePatch) and patch.ends == ("natural", "closed")
    expected = NuSplinePatch(
        NET_7x6, None, [0, 1, 2, 3, 4, 5, 7], np.arange(7.0), 2.5, ("natural", "closed")
    )
    u, v = np.linspace(0, 6, 9)[:, None], np.linspace(0, 7, 7)[None, :]
    np.testing.assert_array_equal(patch.derivatives(u, v, 2), expected.derivatives(u, v, 2))


BAD_SCENES = {
    "nu_v length": (
        'type = "nuspline"\nnu_v = [1, 2, 3]\n',
        r"nu_v: expected numbers >= 0: one number or a list of 6 \(one per knot\), got 3 numbers",
    ),
    "nu_u negative": (
        'type = "nuspline"\nnu_u = -1\n',
        r"nu_u: expected numbers >= 0 \(tensions\), got -1.0",
    ),
    "nuspline ends": (
        'type = "nuspline"\nends = "open"\n',
        r'ends: expected one of "natural", "closed" or a pair \[u, v\] of them, got \'open\'',
    ),
    "nuspline knots": (
        'type = "nuspline"\nknots_u = [0, 1, 2]\n',
        r"knots_u: expected 7 increasing numbers, got \[0.0, 1.0, 2.0\]",
    ),
    "nuspline unknown key": ('type = "nuspline"\nnu = 1\n', r"nu: unknown key; did you mean"),
}


@pytest.mark.parametrize("case", list(BAD_SCENES))
def test_bad_nu_spline_scenes(tmp_path, case):
    check_bad_scene(tmp_path, *BAD_SCENES[case])


@pytest.mark.parametrize("key", ["points", "nu_u", "nu_v", "knots_u", "knots_v", "ends"])
def test_any_wrong_value_of_a_nu_spline_key_gives_a_gshade_error(key):
    check_wrong_values("nuspline-mean", key)
