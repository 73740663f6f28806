"""Bernstein polynomials and Bézier curves/patches against independent formulas."""

from math import comb

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade.geometry import BezierCurve, BezierPatch, bernstein_basis, de_casteljau, elevate_degree


@pytest.mark.parametrize("n", [0, 1, 2, 3, 5, 8])
def test_basis_matches_the_closed_form(n):
    t = np.linspace(0, 1, 13)
    B = bernstein_basis(n, t, 0)[0]
    exact = np.array([[comb(n, i) * x**i * (1 - x) ** (n - i) for i in range(n + 1)] for x in t])
    np.testing.assert_allclose(B, exact, atol=1e-15)
    np.testing.assert_allclose(B.sum(-1), 1.0, atol=1e-15)


@pytest.mark.parametrize("n", [1, 2, 3, 4, 7])
def test_basis_derivatives_match_polynomial_differentiation(n):
    t = np.linspace(0, 1, 9)
    B = bernstein_basis(n, t, 4)
    for i in range(n + 1):
        # B_i^n as a power-basis polynomial, differentiated by numpy
        poly = (
            np.polynomial.Polynomial([0.0] * i + [1.0])
            * np.polynomial.Polynomial([1.0, -1.0]) ** (n - i)
            * comb(n, i)
        )
        for k in range(5):
            np.testing.assert_allclose(B[k, :, i], poly.deriv(k)(t), atol=1e-10 * (n**k + 1))


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(1, 7),
    seed=st.integers(0, 2**32 - 1),
    t=st.lists(st.floats(0, 1), min_size=1, max_size=10),
)
def test_bernstein_evaluation_equals_de_casteljau(n, seed, t):
    pts = np.random.default_rng(seed).normal(size=(n + 1, 3))
    t = np.array(t)
    np.testing.assert_allclose(BezierCurve(pts)(t), de_casteljau(pts, t), atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(m=st.integers(1, 5), n=st.integers(1, 5), seed=st.integers(0, 2**32 - 1))
def test_patch_equals_de_casteljau_in_both_directions(m, n, seed):
    rng = np.random.default_rng(seed)
    P = rng.normal(size=(m + 1, n + 1, 3))
    u, v = rng.random(6), rng.random(6)
    patch = BezierPatch(P)
    for k in range(6):
        columns = np.array([de_casteljau(P[:, j], u[k]) for j in range(n + 1)])
        np.testing.assert_allclose(patch(u[k], v[k]), de_casteljau(columns, v[k]), atol=1e-12)


def test_rational_quadratic_is_an_exact_circle_arc():
    s = np.sqrt(0.5)
    arc = BezierCurve([[1, 0], [1, 1], [0, 1]], weights=[1, s, 1])
    t = np.linspace(0, 1, 101)
    d = arc.derivatives(t, 2)
    np.testing.assert_allclose(np.linalg.norm(d[0], axis=-1), 1.0, atol=1e-15)
    # tangent orthogonal to the radius, curvature 1
    np.testing.assert_allclose(np.sum(d[0] * d[1], -1), 0.0, atol=1e-14)
    cross = d[1][:, 0] * d[2][:, 1] - d[1][:, 1] * d[2][:, 0]
    np.testing.assert_allclose(cross / np.linalg.norm(d[1], axis=-1) ** 3, 1.0, atol=1e-13)


@settings(max_examples=30, deadline=None)
@given(
    m=st.integers(1, 4), n=st.integers(1, 4), rational=st.booleans(), seed=st.integers(0, 2**32 - 1)
)
def test_degree_elevation_keeps_the_patch(m, n, rational, seed):
    rng = np.random.default_rng(seed)
    P = rng.normal(size=(m + 1, n + 1, 3))
    W = rng.uniform(0.5, 2, (m + 1, n + 1)) if rational else None
    patch = BezierPatch(P, W, domain=((1, 3), (-1, 0)))
    high = patch.elevated((m + 2, n + 1))
    assert high.degree == (m + 2, n + 1)
    u, v = rng.uniform(1, 3, 20), rng.uniform(-1, 0, 20)
    np.testing.assert_allclose(high.derivatives(u, v, 3), patch.derivatives(u, v, 3), atol=1e-9)


def test_elevate_degree_of_coefficients():
    c = np.array([1.0, -2.0, 0.5])
    t = np.linspace(0, 1, 7)
    up = elevate_degree(c, 2)
    np.testing.assert_allclose(
        bernstein_basis(4, t)[0] @ up, bernstein_basis(2, t)[0] @ c, atol=1e-14
    )


def test_grid_and_scattered_evaluation_agree():
    rng = np.random.default_rng(3)
    patch = BezierPatch(rng.normal(size=(4, 3, 3)), rng.uniform(0.5, 2, (4, 3)))
    u, v = rng.random(7), rng.random(5)
    grid = patch.derivatives(u[:, None], v[None, :], 3)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    scattered = patch.derivatives(uu.copy(), vv.copy() + 0.0, 3)
    assert grid.shape == scattered.shape == (4, 4, 7, 5, 3)
    np.testing.assert_allclose(grid, scattered, atol=1e-12)
    # entries above the requested total order are zero
    assert not grid[2, 2].any() and not grid[3, 1].any()


def test_scalar_and_broadcast_shapes():
    patch = BezierPatch(np.random.default_rng(0).normal(size=(3, 3, 3)))
    assert patch.derivatives(0.5, 0.5, 2).shape == (3, 3, 3)
    assert patch.derivatives(np.zeros((2, 3, 4)), 0.25, 1).shape == (2, 2, 2, 3, 4, 3)
    assert patch(np.zeros(5), np.ones(5)).shape == (5, 3)
