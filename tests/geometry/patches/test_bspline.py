"""B-splines and NURBS: basis properties, knot insertion, Bézier extraction, derivatives."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade.geometry import BezierPatch, BSplineCurve, BSplinePatch
from gshade.geometry.core.knots import basis_functions

from ...support.random_patches import interior_parameters, knot_vectors, random_net, random_patch


@settings(max_examples=50, deadline=None)
@given(data=st.data(), p=st.integers(1, 4), extra=st.integers(0, 6))
def test_basis_is_a_partition_of_unity(data, p, extra):
    n = p + 1 + extra
    U = data.draw(knot_vectors(p, n))
    lo, hi = U[p], U[n]
    t = np.linspace(lo, hi, 37)
    _, ders = basis_functions(U, p, t, 2)
    np.testing.assert_allclose(ders[0].sum(-1), 1.0, atol=1e-12)
    np.testing.assert_allclose(ders[1].sum(-1), 0.0, atol=1e-8 * (1 + np.abs(ders[1]).max()))
    assert np.all(ders[0] >= -1e-14)


@settings(max_examples=40, deadline=None)
@given(
    data=st.data(),
    p=st.integers(1, 4),
    q=st.integers(1, 3),
    rational=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
)
def test_patch_derivatives_match_finite_differences(data, p, q, rational, seed):
    rng = np.random.default_rng(seed)
    patch = random_patch(data, rng, p, q, rational, extra=4)
    U, V = patch.knots
    u = interior_parameters(rng, patch.domain[0], 8)
    v = interior_parameters(rng, patch.domain[1], 8)
    # finite differences are only valid inside a knot span: nudge off the knots
    u = np.array([x if np.min(np.abs(U - x)) > 2e-4 else x + 3e-4 for x in u])
    v = np.array([x if np.min(np.abs(V - x)) > 2e-4 else x + 3e-4 for x in v])
    d = patch.derivatives(u, v, 3)
    h = 1e-6
    du = (patch.derivatives(u + h, v, 2) - patch.derivatives(u - h, v, 2)) / (2 * h)
    dv = (patch.derivatives(u, v + h, 2) - patch.derivatives(u, v - h, 2)) / (2 * h)
    scale = 1 + np.abs(d).max()
    for i in range(3):
        for j in range(3 - i):
            np.testing.assert_allclose(du[i, j], d[i + 1, j], atol=2e-5 * scale * 10**i)
            np.testing.assert_allclose(dv[i, j], d[i, j + 1], atol=2e-5 * scale * 10**j)


@settings(max_examples=40, deadline=None)
@given(
    data=st.data(),
    p=st.integers(1, 4),
    rational=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
)
def test_curve_derivatives_match_finite_differences(data, p, rational, seed):
    rng = np.random.default_rng(seed)
    n = p + 1 + data.draw(st.integers(0, 6))
    U = data.draw(knot_vectors(p, n))
    P = rng.normal(size=(n, 3))
    W = rng.uniform(0.5, 2, n) if rational else None
    curve = BSplineCurve(P, p, U, W)
    t = interior_parameters(rng, curve.domain, 10)
    t = np.array([x if np.min(np.abs(U - x)) > 2e-4 else x + 3e-4 for x in t])
    d = curve.derivatives(t, 3)
    h = 1e-6
    fd = (curve.derivatives(t + h, 2) - curve.derivatives(t - h, 2)) / (2 * h)
    scale = 1 + np.abs(d).max()
    for k in range(3):
        np.testing.assert_allclose(fd[k], d[k + 1], atol=2e-5 * scale * 10**k)


@settings(max_examples=40, deadline=None)
@given(
    data=st.data(),
    p=st.integers(1, 3),
    q=st.integers(1, 3),
    rational=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
)
def test_knot_insertion_leaves_the_surface_unchanged(data, p, q, rational, seed):
    rng = np.random.default_rng(seed)
    patch = random_patch(data, rng, p, q, rational, extra=3)
    (nu, nv), V = patch.points.shape[:2], patch.knots[1]
    t_u = float(interior_parameters(rng, patch.domain[0], 1)[0])
    t_v = float(
        np.unique(V[(V > patch.domain[1][0]) & (V < patch.domain[1][1])])[0]
        if np.any((V > patch.domain[1][0]) & (V < patch.domain[1][1]))
        else np.mean(patch.domain[1])
    )
    refined = patch.insert_knot("u", t_u, times=min(2, p)).insert_knot("v", t_v)
    assert refined.points.shape == (nu + min(2, p), nv + 1, 3)
    u = interior_parameters(rng, patch.domain[0], 15)
    v = interior_parameters(rng, patch.domain[1], 15)
    np.testing.assert_allclose(refined.derivatives(u, v, 2), patch.derivatives(u, v, 2), atol=1e-9)
    np.testing.assert_allclose(refined(u, v), patch(u, v), atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(
    data=st.data(),
    p=st.integers(1, 3),
    q=st.integers(1, 3),
    rational=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
)
def test_bezier_extraction_leaves_the_surface_unchanged(data, p, q, rational, seed):
    rng = np.random.default_rng(seed)
    patch = random_patch(data, rng, p, q, rational, extra=3)
    U = patch.knots[0]
    pieces = patch.bezier_patches()
    spans_u = len(np.unique(U[(U >= patch.domain[0][0]) & (U <= patch.domain[0][1])])) - 1
    assert len(pieces) == spans_u
    for row in pieces:
        for bez in row:
            assert bez.degree == (p, q)
            u = interior_parameters(rng, bez.domain[0], 5)
            v = interior_parameters(rng, bez.domain[1], 5)
            np.testing.assert_allclose(
                bez.derivatives(u, v, 2),
                patch.derivatives(u, v, 2),
                atol=1e-8 * (1 + np.abs(patch.derivatives(u, v, 2)).max()),
            )


def test_curve_bezier_segments_are_the_curve():
    U = [0, 0, 0, 0.3, 0.3, 0.7, 1, 1, 1]
    rng = np.random.default_rng(5)
    curve = BSplineCurve(rng.normal(size=(6, 2)), 2, U, rng.uniform(0.5, 2, 6))
    segs = curve.bezier_segments()
    assert [s.domain for s in segs] == [(0.0, 0.3), (0.3, 0.7), (0.7, 1.0)]
    for s in segs:
        t = np.linspace(*s.domain, 9)
        np.testing.assert_allclose(s(t), curve(t), atol=1e-12)
        # derivatives inside the segment (at a C0 knot they are one-sided)
        np.testing.assert_allclose(
            s.derivatives(t[1:-1], 2), curve.derivatives(t[1:-1], 2), atol=1e-10
        )


def test_a_bspline_with_bezier_knots_is_the_bezier_patch():
    rng = np.random.default_rng(7)
    P, W = rng.normal(size=(4, 3, 3)), rng.uniform(0.5, 2, (4, 3))
    bsp = BSplinePatch(P, (3, 2), ([0] * 4 + [1] * 4, [0] * 3 + [1] * 3), W)
    bez = BezierPatch(P, W)
    u, v = rng.random(30), rng.random(30)
    np.testing.assert_allclose(bsp.derivatives(u, v, 3), bez.derivatives(u, v, 3), atol=1e-10)


def test_unclamped_uniform_cubic_matches_the_closed_form():
    # uniform cubic B-spline segment: (1/6) [(1-t)^3, 3t^3-6t^2+4, -3t^3+3t^2+3t+1, t^3]
    P = np.random.default_rng(2).normal(size=(4, 3))
    curve = BSplineCurve(P, 3, np.arange(8.0))
    t = np.linspace(0, 1, 11)
    B = (
        np.stack(
            [(1 - t) ** 3, 3 * t**3 - 6 * t**2 + 4, -3 * t**3 + 3 * t**2 + 3 * t + 1, t**3], -1
        )
        / 6
    )
    assert curve.domain == (3.0, 4.0)
    np.testing.assert_allclose(curve(3 + t), B @ P, atol=1e-14)


def test_domain_ends_and_repeated_interior_knots_evaluate():
    # a C^-1 knot (multiplicity p + 1) splits the patch; both ends of the domain evaluate
    U = [0, 0, 0.5, 0.5, 1, 1]
    curve = BSplineCurve([[0, 0], [1, 0], [5, 5], [6, 5]], 1, U)
    np.testing.assert_allclose(curve([0.0, 0.5, 1.0]), [[0, 0], [5, 5], [6, 5]])
    np.testing.assert_allclose(curve(np.nextafter(0.5, 0)), [1, 0], atol=1e-12)


@pytest.mark.parametrize("rational", [False, True])
def test_grid_path_equals_scattered_path(rational):
    rng = np.random.default_rng(11)
    U = [0, 0, 0, 0, 0.2, 0.2, 0.6, 1, 1, 1, 1]
    V = [-1, -1, -1, 0, 0.5, 2, 2, 2]
    P, W = random_net(rng, (7, 5), rational)
    patch = BSplinePatch(P, (3, 2), (U, V), W)
    u = np.r_[0, 0.2, rng.random(5), 1]
    v = np.r_[-1, 0, 0.5, rng.uniform(-1, 2, 4), 2]
    grid = patch.derivatives(u[:, None], v[None, :], 3)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    np.testing.assert_allclose(grid, patch.derivatives(uu + 0, vv + 0, 3), atol=1e-9)


def test_out_buffer_is_filled_in_place():
    rng = np.random.default_rng(4)
    U = [0, 0, 0, 0, 0.4, 1, 1, 1, 1]
    patch = BSplinePatch(rng.normal(size=(5, 5, 3)), (3, 3), (U, U))
    t = np.linspace(0, 1, 30)
    fresh = patch.derivatives(t[:, None], t[None, :], 2)
    reused = patch.derivatives(t[:, None], t[None, :], 2)
    assert patch.derivatives(t[:, None], t[None, :], 2, out=reused) is reused
    np.testing.assert_array_equal(reused, fresh)
    plain = np.zeros((3, 3, 30, 30, 3))  # another layout: filled by one copy
    patch.derivatives(t[:, None], t[None, :], 2, out=plain)
    np.testing.assert_array_equal(plain, fresh)
