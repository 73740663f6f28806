"""β-splines: the uniform B-spline as a special case, G2 (not C2) junctions, patches."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade import GshadeError
from gshade.geometry import BetaSplineCurve, BetaSplinePatch, BSplineCurve, BSplinePatch, nu_spline
from gshade.geometry.geometric_splines import NuSplinePatch


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


def patch_one_sided(patch, direction, knot, other, order=2):
    """One-sided patch derivatives across the knot line ``direction`` = knot."""
    below = np.full_like(other, np.nextafter(knot, -np.inf))
    at = np.full_like(other, knot)
    if direction == "u":
        return patch.derivatives(below, other, order), patch.derivatives(at, other, order)
    return patch.derivatives(other, below, order), patch.derivatives(other, at, order)


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


def classes(patch):
    """Continuity classes of the junctions between a B-spline patch's Bézier pieces."""
    from gshade.analysis.continuity import continuity_report

    pieces = [piece for row in patch.bezier_patches() for piece in row]
    return [j.cls for j in continuity_report(pieces, samples=8)]


def test_beta_and_nu_spline_patches_are_g2_by_the_continuity_measures():
    rng = np.random.default_rng(9)
    x, y = np.meshgrid(np.arange(6.0), np.arange(5.0), indexing="ij")
    Q = np.stack([x, y, 0.4 * rng.normal(size=x.shape)], axis=-1)
    beta = BetaSplinePatch(Q, beta1_u=[0.6, 2.0], beta2_u=[5.0, 0.0], beta1_v=1.5, beta2_v=2.0)
    nu = NuSplinePatch(Q, nu_u=[0, 4.0, 9.0, 2.0, 0, 0], nu_v=[0, 3.0, 1.0, 6.0, 0])
    for patch, junctions in ((beta.to_bspline(), 3 * 1 + 2 * 2), (nu, 4 * 4 + 3 * 5)):
        found = classes(patch)
        assert len(found) == junctions
        assert set(found) == {"G2"}, found  # curvature continuous, its gradient not


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
def test_bad_geometric_spline_input(make, message):
    with pytest.raises(GshadeError, match=message) as info:
        make()
    assert "\n" not in str(info.value)


# --------------------------------------------------------------------------- scene files

NET_7x6 = [[[i, j, 0.1 * ((i * j) % 3)] for j in range(6)] for i in range(7)]


def load(tmp_path, body):
    from gshade.io import load_scene

    path = tmp_path / "scene.toml"
    path.write_text(f'[[surface]]\ntype = "sphere"\n[[surface]]\n{body}', encoding="utf-8")
    return path, load_scene(path)


def test_scene_types_betaspline_per_junction_and_nuspline(tmp_path):
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
    "beta1_u length": (
        'type = "betaspline"\nbeta1_u = [1, 2]\n',
        r"beta1_u: expected a number > 0 or a list of 3 numbers > 0 \(one per interior "
        r"junction in u: rows \(7\) - 4\), got \[1, 2\] \(2 numbers\)",
    ),
    "beta2_v negative": (
        'type = "betaspline"\nbeta2_v = [1, -1]\n',
        r"beta2_v: expected a number >= 0 or a list of 2 numbers >= 0 .*, got \[1, -1\]",
    ),
    "beta1 zero": ('type = "betaspline"\nbeta1 = 0\n', r"beta1: expected a positive number"),
    "beta1_v zero in list": ('type = "betaspline"\nbeta1_v = [1, 0]\n', r"beta1_v: expected"),
    "betaspline few points": (
        'type = "betaspline"\npoints = [[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]]\n',
        r"points: expected at least 4 rows of at least 4 points \(a cubic β-spline\), got 2 "
        r"rows of 2",
    ),
    "nu_v length": (
        'type = "nuspline"\nnu_v = [1, 2, 3]\n',
        r"nu_v: expected a number >= 0 or a list of 6 numbers >= 0 \(one per knot: 6 points "
        r"per row\), got \[1, 2, 3\] \(3 numbers\)",
    ),
    "nu_u negative": ('type = "nuspline"\nnu_u = -1\n', r"nu_u: expected a number >= 0"),
    "nuspline ends": (
        'type = "nuspline"\nends = "open"\n',
        r'ends: expected one of "natural", "closed" or a pair \[u, v\] of them, got "open"',
    ),
    "nuspline knots": (
        'type = "nuspline"\nknots_u = [0, 1, 2]\n',
        r"knots_u: expected 7 increasing numbers, got \[0.0, 1.0, 2.0\]",
    ),
    "nuspline unknown key": ('type = "nuspline"\nnu = 1\n', r"nu: unknown key; did you mean"),
}


@pytest.mark.parametrize("case", list(BAD_SCENES))
def test_bad_geometric_spline_scenes(tmp_path, case):
    body, message = BAD_SCENES[case]
    if "points" not in body:
        body += f"points = {NET_7x6}\n"
    with pytest.raises(GshadeError, match=message) as info:
        load(tmp_path, body)
    text = str(info.value)
    assert text.startswith(f"{tmp_path / 'scene.toml'}: [[surface]] 2 ("), text
    assert "\n" not in text


WRONG_VALUES = [
    "x",
    0,
    -1,
    True,
    [],
    [1],
    [1, 2, 3],
    [[1, 2, 3]],
    {"a": 1},
    ["closed"],
    [1e308] * 3,
]


@pytest.mark.parametrize(
    ("scene", "key"),
    [
        *(("nuspline-mean", k) for k in ("points", "nu_u", "nu_v", "knots_u", "knots_v", "ends")),
        *(("betaspline-junctions", k) for k in ("beta1", "beta2", "beta1_u", "beta2_v")),
    ],
)
def test_any_wrong_value_of_a_geometric_spline_key_gives_a_gshade_error(scene, key):
    from gshade.io import load_scene

    from .conftest import ROOT

    path = ROOT / "scenes" / f"{scene}.toml"
    load_scene(path)
    for value in WRONG_VALUES:
        try:
            load_scene(path, {f"surface.1.{key}": value})
        except GshadeError as exc:
            text = str(exc)
            assert text.startswith(f"{path}: [[surface]] 1 ("), text
            assert "\n" not in text and key in text, text
