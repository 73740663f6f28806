"""Closest points on exact surfaces (gshade.analysis.closest_points) against closed forms:
spheres of radii R and R + delta, a B-spline patch and its knot-inserted copy, a square's
distance field beyond its edges and corners, a cylinder moved across its axis."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade.analysis.closest_points import closest_points
from gshade.geometry import BezierPatch, BSplinePatch, cylinder, sphere


def _on(patch, n, seed):
    """n points of ``patch`` at random parameters, and the parameters."""
    rng = np.random.default_rng(seed)
    (u0, u1), (v0, v1) = patch.domain
    u, v = rng.uniform(u0, u1, n), rng.uniform(v0, v1, n)
    return np.asarray(patch(u, v)).reshape(-1, 3), np.stack([u, v], -1)


def test_spheres_of_radii_r_and_r_plus_delta_are_delta_apart():
    """Every point of the sphere of radius 2 (poles and seam included) is 0.5 from the
    sphere of radius 2.5, its closest point the radial one, to 1e-12."""
    points, _ = _on(sphere(2.0), 400, 1)
    points = np.vstack([points, [[0, 0, 2.0], [0, 0, -2.0], [2.0, 0, 0], [0, 2.0, 0]]])
    found = closest_points([sphere(2.5)], points)
    np.testing.assert_allclose(found.distance, 0.5, rtol=1e-12)
    np.testing.assert_allclose(found.point, points * 1.25, atol=1e-12)


def _bicubic():
    rng = np.random.default_rng(4)
    net = np.stack(np.meshgrid(np.arange(6.0), np.arange(5.0), indexing="ij"), -1)
    net = np.concatenate([net, rng.uniform(-0.6, 0.6, (6, 5, 1))], -1)
    U = [0, 0, 0, 0, 0.4, 0.7, 1, 1, 1, 1]
    V = [0, 0, 0, 0, 0.5, 1, 1, 1, 1]
    return BSplinePatch(net, (3, 3), (U, V))


def test_a_patch_and_its_knot_inserted_copy_coincide():
    """Knot insertion changes the parametrisation, not the surface: distance 0 to 1e-12 of
    the patch's size both ways, the foot point's parameters those of the point."""
    a = _bicubic()
    b = a.insert_knot("u", 0.55).insert_knot("v", 0.25, times=2)
    for one, other in ((a, b), (b, a)):
        points, uv = _on(one, 300, 2)
        found = closest_points([other], points)
        assert found.distance.max() < 1e-12 * 6
        np.testing.assert_allclose(found.uv, uv, atol=1e-10)


@settings(max_examples=60, deadline=None)
@given(st.floats(-1.0, 2.0), st.floats(-1.0, 2.0), st.floats(0.05, 2.0), st.sampled_from([1, -1]))
def test_a_squares_distance_field_beyond_its_edges(x, y, h, side):
    """The unit square z = 0 seen from (x, y, ±h): the nearest point is (x, y) clamped to
    the square, inside or on an edge or a corner (the active set holds the parameter)."""
    square = BezierPatch([[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]])
    found = closest_points([square], [[x, y, side * h]])
    foot = np.clip([x, y], 0.0, 1.0)
    expected = np.hypot(h, np.hypot(*(np.array([x, y]) - foot)))
    assert found.distance[0] == pytest.approx(expected, rel=1e-12, abs=1e-14)
    np.testing.assert_allclose(found.point[0], [*foot, 0.0], atol=1e-12)


def test_a_cylinder_moved_across_its_axis():
    """Points of the cylinder of radius 1 about the z axis against the same cylinder moved by
    t = (0.3, -0.2, 0): the distance is | |q - t|_xy - 1 | (q within its height)."""
    a, b = cylinder(1.0, 4.0), cylinder(1.0, 4.0)
    moved = BSplinePatch(b.points + np.array([0.3, -0.2, 0.0]), b.degree, b.knots, b.weights)
    points, _ = _on(a, 300, 3)
    points = points[(points[:, 2] > 0.05) & (points[:, 2] < 3.95)]
    found = closest_points([moved], points)
    expected = np.abs(np.hypot(points[:, 0] - 0.3, points[:, 1] + 0.2) - 1.0)
    np.testing.assert_allclose(found.distance, expected, rtol=1e-11, atol=1e-13)


def test_the_nearest_of_several_patches():
    """Two spheres: each point is answered on the nearer one, its patch said."""
    near, far = sphere(1.0), sphere(3.0)
    queries = np.array([[0.0, 0.0, 1.5], [0.0, 0.0, 2.6], [1.9, 0.0, 0.0]])
    found = closest_points([near, far], queries)
    assert found.patch.tolist() == [0, 1, 0]
    np.testing.assert_allclose(found.distance, [0.5, 0.4, 0.9], rtol=1e-12)


def _square(size, z):
    """The square [-size, size]^2 at height z."""
    return BezierPatch([[[-size, -size, z], [-size, size, z]], [[size, -size, z], [size, size, z]]])


def test_a_patch_whose_samples_are_all_farther_is_asked_by_its_blocks():
    """A small square at z = 0, its samples the nearest to every query over it, and a wide
    square at z = 0.5 whose samples are all farther but whose surface is nearer: found by
    the last round (the blocks), for a tile of queries near each other and for queries
    alone, at distance 1 - 0.5 = 0.5."""
    small, wide = _square(1.0, 0.0), _square(100.0, 0.5)
    x, y = np.meshgrid(np.linspace(-0.5, 0.5, 24), np.linspace(-0.5, 0.5, 24))
    tile = np.stack([x.ravel(), y.ravel(), np.ones(x.size)], -1)
    alone = np.array([[0.9, -0.9, 1.0], [-0.7, 0.2, 0.8]])
    found = closest_points([small, wide], np.vstack([tile, alone]))
    assert (found.patch == 1).all()
    np.testing.assert_allclose(found.distance, np.r_[np.full(len(tile), 0.5), 0.5, 0.3], rtol=1e-12)


def test_every_box_of_a_patch_as_near_as_its_nearest_is_a_start():
    """A query inside two boxes of one patch (which block's middle leads Newton's method to
    the patch's nearest point is not known): both are starts; a farther box of that patch
    is not, the nearest box of another patch within reach is."""
    from gshade.analysis.closest_points import _near_blocks
    from gshade.analysis.surface_samples import Blocks

    lo = np.array([[-1.0, -1, -1], [-0.5, -0.5, -0.5], [0.8, 0.8, 0.8], [1.0, -1, -1], [2, -1, -1]])
    blocks = Blocks(lo, lo + 1.5, np.array([0, 0, 0, 1, 1]), np.zeros((5, 2)))
    who, block = _near_blocks(blocks, np.zeros((1, 3)), np.array([1.5]))
    assert sorted(block.tolist()) == [0, 1, 3] and (who == 0).all()
