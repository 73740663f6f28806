"""β-splines: the uniform B-spline as a special case, G2 (not C2) junctions, patches."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade import GshadeError
from gshade.geometry import BetaSplineCurve, BetaSplinePatch, BSplineCurve, BSplinePatch


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


def one_sided(curve, t):
    """Derivatives just left of t (from the arc ending there) and at t (the next arc)."""
    left = curve.derivatives(np.array([np.nextafter(t, -np.inf)]), 3)[:, 0]
    right = curve.derivatives(np.array([t]), 3)[:, 0]
    return left, right


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


def test_nu_zero_is_the_c2_interpolating_spline():
    from scipy.interpolate import CubicSpline

    from gshade.geometry import nu_spline

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
    from gshade.geometry import nu_spline

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
    from gshade.geometry import nu_spline

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
