"""Many patches on one grid: the grouped Bézier products equal each patch's own evaluation."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade.geometry import BezierPatch, BSplinePatch, sphere
from gshade.geometry.evaluation.patch_groups import grid_derivatives
from gshade.io import read_newell
from gshade.rendering.tessellate import chord_resolution, max_chord_resolution

from ...support.paths import TEAPOT


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), order=st.integers(0, 3))
def test_grouped_grid_equals_per_patch_evaluation(seed, order):
    """Bézier patches and one-span B-spline patches (grouped), every other patch (alone)."""
    rng = np.random.default_rng(seed)
    patches = []
    for _ in range(5):
        m, n = rng.integers(1, 5, 2)
        u0, v0 = rng.uniform(-2, 2, 2)
        du, dv = rng.uniform(0.1, 3.0, 2)
        patches.append(
            BezierPatch(rng.normal(size=(m + 1, n + 1, 3)), domain=((u0, u0 + du), (v0, v0 + dv)))
        )
    patches.append(BezierPatch(rng.normal(size=(3, 4, 3)), rng.uniform(0.5, 2.0, (3, 4))))
    patches.append(sphere(1.3))
    P = rng.normal(size=(5, 4, 3))
    patches.append(
        BSplinePatch(P, (2, 3), ([0, 0, 0, 0.3, 0.6, 1, 1, 1], [0, 0, 0, 0, 1, 1, 1, 1]))
    )
    # one clamped knot span each way (a CAD face's plane, a one-span cylinder): Bézier cells,
    # polynomial and rational, on knots anywhere; an unclamped span is not one
    for rational in (False, True):
        for _ in range(3):
            p, q = rng.integers(1, 4, 2)
            a, c = rng.uniform(-5, 5, 2)
            b, d = a + rng.uniform(0.01, 4.0), c + rng.uniform(0.01, 4.0)
            knots = ([a] * (p + 1) + [b] * (p + 1), [c] * (q + 1) + [d] * (q + 1))
            w = rng.uniform(0.3, 3.0, (p + 1, q + 1)) if rational else None
            patches.append(BSplinePatch(rng.normal(size=(p + 1, q + 1, 3)), (p, q), knots, w))
    unclamped = ([0, 1, 2, 3, 4, 5], [0, 0, 1, 1])
    patches.append(BSplinePatch(rng.normal(size=(3, 2, 3)), (2, 1), unclamped))
    rng.shuffle(patches)
    points = 5 if seed % 2 else 12  # all points at once (< ALONE_FROM), or patch by patch
    s = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0, 1, points)]))
    grouped = grid_derivatives(patches, s, order)
    for k, patch in enumerate(patches):
        (u0, u1), (v0, v1) = patch.domain
        own = patch.derivatives((u0 + (u1 - u0) * s)[:, None], (v0 + (v1 - v0) * s)[None, :], order)
        scale = 1.0 + np.abs(own).max()
        np.testing.assert_allclose(grouped[k], own, atol=1e-12 * scale)


def _chord_error(patch, n: int, k: int = 4) -> float:
    """The largest distance between the patch and the two triangles per cell that
    tessellate makes of an n x n grid of its normalised parameters, at k x k points per
    cell: from the patch's own evaluation and the interpolation alone."""
    cells = n - 1
    s = np.linspace(0.0, 1.0, cells * k + 1)
    (u0, u1), (v0, v1) = patch.domain
    P = patch(u0 + (u1 - u0) * s[:, None], v0 + (v1 - v0) * s[None, :])
    a, b = P[:-1:k, :-1:k], P[k::k, :-1:k]  # cell corners (i, j), (i + 1, j)
    c, d = P[k::k, k::k], P[:-1:k, k::k]  # (i + 1, j + 1), (i, j + 1)
    worst = 0.0
    for x in range(k + 1):
        for y in range(k + 1):
            X, Y = x / k, y / k
            # triangle (a, b, c) below the diagonal, (a, c, d) above it
            flat = a + X * (b - a) + Y * (c - b) if Y <= X else a + Y * (d - a) + X * (c - d)
            exact = P[x : x + cells * k : k, y : y + cells * k : k]
            worst = max(worst, float(np.linalg.norm(exact - flat, axis=-1).max()))
    return worst


def _teapot_on_many_domains():
    """The teapot's patches on domains of many sizes: the same surface (the measured
    chord error does not change), but the chain rule of the grouped products matters."""
    rng = np.random.default_rng(7)
    patches = []
    for p in read_newell(TEAPOT):
        u0, v0 = rng.uniform(-3, 3, 2)
        du, dv = rng.choice([0.25, 0.5, 1.0, 2.0, 4.0], 2)
        patches.append(BezierPatch(p.points, domain=((u0, u0 + du), (v0, v0 + dv))))
    return patches


def _saddles():
    """Twisted patches, p_uv their only second derivative (z = c u v): only the twist
    term of the bound, and the triangles' diagonal, make their chord error."""
    out = []
    for c, degree, domain in ((0.7, (1, 1), ((0, 2), (1, 1.5))), (0.3, (2, 3), ((-1, 0), (0, 3)))):
        m, n = degree
        i, j = np.meshgrid(np.arange(m + 1) / m, np.arange(n + 1) / n, indexing="ij")
        out.append(BezierPatch(np.stack([i, j, c * i * j], -1), domain=domain))
    return out


@pytest.mark.parametrize("make", [_teapot_on_many_domains, _saddles])
def test_chord_resolution_meets_the_tolerance_measured_on_the_surface(make):
    """The resolution chosen for many patches at once (their second derivatives from the
    grouped grid evaluation) keeps the measured chord error of every patch below the
    tolerance, and is not wastefully fine: with a quarter fewer cells the error exceeds
    it."""
    patches = make()
    for tol in (1e-2, 2e-3):
        n = max_chord_resolution(patches, tol)
        errors = [_chord_error(p, n) for p in patches]
        assert max(errors) <= tol, (tol, n, max(errors))
        # a quarter fewer cells: the bound is close to the error (measured on the teapot:
        # 0.72-0.74 of the tolerance at n, 1.35-1.42 times it at three quarters of the cells)
        coarse = int(0.75 * (n - 1)) + 1
        assert max(_chord_error(p, coarse) for p in patches) > tol, (tol, n)
        # one patch at a time: the resolution for all is the largest of their own ones,
        # and each patch's own one meets the tolerance on that patch
        own = [chord_resolution(p, tol) for p in patches]
        assert max(own) == n
        for k in (0, int(np.argmin(own))):
            assert _chord_error(patches[k], own[k]) <= tol


def test_unit_to_domain_one_domain_and_an_array_of_them():
    from gshade.geometry.core.patch import unit_to_domain

    s, t = np.array([0.0, 0.25, 1.0]), np.array([1.0, 0.5, 0.0])
    u, v = unit_to_domain(((2.0, 4.0), (-1.0, 1.0)), s, t)
    assert np.array_equal(u, [2.0, 2.5, 4.0]) and np.array_equal(v, [1.0, 0.0, -1.0])
    domains = np.array([((0.0, 1.0), (0.0, 1.0)), ((2.0, 4.0), (-1.0, 1.0)), ((0, 8), (3, 5))])
    u, v = unit_to_domain(domains, s, t)  # each point into its own domain
    assert np.array_equal(u, [0.0, 2.5, 8.0]) and np.array_equal(v, [1.0, 0.0, 3.0])
    u, v = unit_to_domain(domains, s, t, index=[2, 2, 1])  # point k into domain index[k]
    assert np.array_equal(u, [0.0, 2.0, 4.0]) and np.array_equal(v, [5.0, 4.0, -1.0])
