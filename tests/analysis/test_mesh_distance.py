"""Closest points on triangle meshes and in point clouds (gshade.analysis.mesh_distance)
against a brute-force oracle (every query against every triangle, by trimesh's own
point-triangle routine), an icosphere against points at known distances, and a cloud
against every one of its points."""

from __future__ import annotations

import re

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from gshade.analysis.mesh_distance import (
    cloud_closest_points,
    mesh_closest_points,
    morton_order,
    nearest_on_triangles,
    triangle_samples,
)
from gshade.errors import GshadeError


def brute_force(vertices, faces, queries):
    """The distance (q,) of each query to its nearest triangle: every pair measured by
    trimesh.triangles.closest_point (an implementation of Ericson's regions, not ours),
    a flat triangle (a segment or a point) as the nearest of its three sides.  trimesh
    compares with an absolute 1e-13, so each pair is moved to put the query at 0 and
    scaled to make its triangle's longest side 1 first."""
    V, Q = np.asarray(vertices, float), np.asarray(queries, float)
    tri = V[np.asarray(faces)]
    pairs = (tri[None] - Q[:, None, None]).reshape(-1, 3, 3)  # each triangle from each query
    size = np.linalg.norm(pairs - np.roll(pairs, 1, axis=1), axis=-1).max(axis=1)
    pairs /= np.where(size > 0, size, 1.0)[:, None, None]
    flat = np.linalg.norm(np.cross(pairs[:, 1] - pairs[:, 0], pairs[:, 2] - pairs[:, 0]), axis=1)
    flat = flat == 0
    gap = np.empty(len(pairs))
    nearest = trimesh.triangles.closest_point(pairs[~flat], np.zeros((np.sum(~flat), 3)))
    gap[~flat] = np.linalg.norm(nearest, axis=1)
    sides = []
    for a, b in ((0, 1), (1, 2), (2, 0)):  # the query is at 0: |a + w (b - a)|, w in [0, 1]
        start, side = pairs[flat, a], pairs[flat, b] - pairs[flat, a]
        length2 = np.sum(side * side, axis=1)
        w = -np.sum(start * side, axis=1) / np.where(length2 > 0, length2, 1.0)
        sides.append(np.linalg.norm(start + np.clip(w, 0, 1)[:, None] * side, axis=1))
    gap[flat] = np.min(sides, axis=0)
    return (gap * np.where(size > 0, size, 1.0)).reshape(len(Q), len(tri)).min(axis=1)


def check_answer(vertices, faces, queries, found, expected, tol):
    """``found`` (ClosestPoints) is as near as the oracle's ``expected`` distances, and its
    point is on its triangle at its (s, t), at its distance from the query."""
    V, F, Q = np.asarray(vertices, float), np.asarray(faces), np.asarray(queries, float)
    np.testing.assert_allclose(found.distance, expected, rtol=0, atol=tol)
    s, t = found.uv[:, 0], found.uv[:, 1]
    assert np.all(s >= 0) and np.all(t >= 0) and np.all(s + t <= 1 + 1e-12)
    tri = V[F[found.patch]]
    on = tri[:, 0] + s[:, None] * (tri[:, 1] - tri[:, 0]) + t[:, None] * (tri[:, 2] - tri[:, 0])
    np.testing.assert_allclose(found.point, on, rtol=0, atol=tol)
    np.testing.assert_allclose(np.linalg.norm(found.point - Q, axis=1), found.distance, atol=tol)


# halves (coincident and collinear corners come often) or any floats; none so small that
# its square underflows, where the oracle divides 0 by 0 (gshade's answer stays right)
coordinates = st.one_of(
    st.integers(-6, 6).map(lambda k: k / 2),
    st.floats(-3.0, 3.0).filter(lambda x: x == 0 or abs(x) > 1e-100),
)


@st.composite
def meshes(draw):
    """Up to 24 triangles over up to 12 vertices, some repeated (degenerate triangles:
    segments and points come as they are), and up to 16 queries near them."""
    n = draw(st.integers(1, 12))
    vertices = draw(arrays(np.float64, (n, 3), elements=coordinates))
    if draw(st.booleans()):  # a vertex on the line of two others: a collinear triangle
        t = draw(st.floats(-1.0, 2.0))
        vertices = np.vstack([vertices, vertices[0] + t * (vertices[-1] - vertices[0])])
    faces = draw(
        arrays(np.int64, (draw(st.integers(1, 24)), 3), elements=st.integers(0, len(vertices) - 1))
    )
    queries = draw(arrays(np.float64, (draw(st.integers(1, 16)), 3), elements=st.floats(-5.0, 5.0)))
    return vertices, faces, queries


@settings(max_examples=150, deadline=None)
@given(meshes(), st.sampled_from([1.0, 1e-6, 1e6]), st.floats(-1e3, 1e3))
def test_the_nearest_triangle_as_brute_force_finds_it(mesh, scale, shift):
    vertices, faces, queries = mesh
    # the same problem scaled and moved: the answer scales with it (trimesh's absolute
    # tolerance is why the oracle works at size 1)
    V, Q = vertices * scale + shift, queries * scale + shift
    found = mesh_closest_points(V, faces, Q)
    expected = brute_force(vertices, faces, queries) * scale
    size = scale * 10
    check_answer(V, faces, Q, found, expected, tol=1e-12 * size + 1e-15 * abs(shift))


def test_a_mesh_of_slivers_and_small_triangles():
    """A CAD export's kind of mesh: a fan of long slivers (cut into rows of samples) next
    to a fine grid, queries all around and far off: every answer is the nearest."""
    rng = np.random.default_rng(5)
    angles = np.linspace(0, np.pi / 2, 40)
    fan = np.vstack(
        [[0.0, 0.0, 0.0], np.stack([10 * np.cos(angles), 10 * np.sin(angles), 0 * angles], 1)]
    )
    fan_faces = np.stack([np.zeros(39, int), np.arange(1, 40), np.arange(2, 41)], 1)
    x, y = np.meshgrid(np.linspace(0, 1, 15), np.linspace(0, 1, 15))
    grid = np.stack([x.ravel() - 1.5, y.ravel(), 0.1 * np.sin(3 * x.ravel())], 1)
    k = np.arange(14 * 15).reshape(14, 15)[:, :14].ravel()
    grid_faces = np.concatenate([np.stack([k, k + 1, k + 16], 1), np.stack([k, k + 16, k + 15], 1)])
    V = np.vstack([fan, grid])
    F = np.vstack([fan_faces, grid_faces + len(fan)])
    samples = triangle_samples(V[F])
    assert len(samples.points) > len(F)  # the slivers were cut
    Q = np.vstack(
        [
            rng.uniform([-2, -1, -0.5], [10, 10, 0.5], (400, 3)),
            rng.normal(size=(40, 3)) * 50,  # far off: the search widens to the whole mesh
            [[-1.0, 0.5, 0.02], [0.0, 0.0, 0.0], [5.0, 5.0, 0.0]],
        ]
    )
    found = mesh_closest_points(V, F, Q, samples=samples)
    check_answer(V, F, Q, found, brute_force(V, F, Q), tol=1e-11)


@settings(max_examples=60, deadline=None)
@given(
    arrays(np.float64, (3, 3), elements=coordinates),
    st.floats(1e-4, 1.0),
    arrays(np.float64, (50, 2), elements=st.floats(0.0, 1.0)),
)
def test_samples_cover_their_triangles(corners, squash, weights):
    """Every point of a triangle (a sliver too: squashed across) lies within the reach of
    one of its own samples, beside a triangle 20 times smaller that sets the reach."""
    corners = corners.copy()
    corners[2] = corners[0] + squash * (corners[2] - corners[0])
    small = corners / 20 + 5
    found = triangle_samples([corners, small])
    s, t = weights[:, 0], weights[:, 1]
    s, t = np.where(s + t > 1, 1 - s, s), np.where(s + t > 1, 1 - t, t)
    points = (
        corners[0] + s[:, None] * (corners[1] - corners[0]) + t[:, None] * (corners[2] - corners[0])
    )
    own = found.owner == 0
    gap = np.linalg.norm(points[:, None] - found.points[own][None], axis=-1)
    assert np.all((gap - found.reach[own][None]).min(axis=1) <= 1e-12 * (1 + np.abs(corners).max()))
    assert found.reach_max == found.reach.max()


def test_an_icosphere_against_points_at_known_distances():
    """The unit sphere's icosphere (1280 triangles): a point at R times a vertex is R - 1
    from the mesh, the vertex nearest (the polyhedron is convex, its vertices on the
    sphere); a point h above or below a face's inside, |h| from it, the foot point nearest."""
    ball = trimesh.creation.icosphere(subdivisions=3)
    V, F = np.asarray(ball.vertices), np.asarray(ball.faces)
    R = np.array([1.0, 1.5, 2.0, 3.0, 100.0])
    vertex = np.arange(0, len(V), 7)
    outside = (V[vertex][:, None] * R[None, :, None]).reshape(-1, 3)
    found = mesh_closest_points(V, F, outside)
    np.testing.assert_allclose(found.distance, np.tile(R - 1, len(vertex)), atol=1e-13)
    np.testing.assert_allclose(found.point, np.repeat(V[vertex], len(R), axis=0), atol=1e-13)

    rng = np.random.default_rng(3)
    face = rng.integers(0, len(F), 300)
    st = rng.uniform(0.2, 0.4, (300, 2))
    tri = V[F[face]]
    foot = tri[:, 0] + st[:, :1] * (tri[:, 1] - tri[:, 0]) + st[:, 1:] * (tri[:, 2] - tri[:, 0])
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    h = rng.uniform(-1e-3, 1e-3, 300)
    found = mesh_closest_points(V, F, foot + h[:, None] * normal)
    np.testing.assert_allclose(found.distance, np.abs(h), atol=1e-14)
    np.testing.assert_array_equal(found.patch, face)
    np.testing.assert_allclose(found.uv, st, atol=1e-12)
    # the centre: every face far alike; the nearest are those of the greatest inradius
    centre = mesh_closest_points(V, F, [[0.0, 0.0, 0.0]])
    inradius = np.abs(np.sum(normal * tri[:, 0], axis=1))
    planes = np.abs(
        np.einsum(
            "ij,ij->i", np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), V[F[:, 0]]
        )
    )
    planes /= np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    assert inradius.min() >= planes.min() - 1e-15
    np.testing.assert_allclose(centre.distance, planes.min(), atol=1e-14)


def test_the_pairwise_routine_on_degenerate_triangles():
    """A segment (a repeated corner), a collinear triangle and a point."""
    segment = [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]
    collinear = [[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [1.0, 0.0, 0.0]]
    point = [[1.0, 1.0, 1.0]] * 3
    st_, d = nearest_on_triangles(
        [segment, collinear, point, segment],
        [[1.0, 1.0, 0.0], [4.0, 0.0, 0.0], [1.0, 1.0, 3.0], [-1.0, 0.0, 0.0]],
    )
    np.testing.assert_allclose(d, [1.0, 1.0, 2.0, 1.0])
    assert st_[1].tolist() == [1.0, 0.0]  # the collinear one's end B


@settings(max_examples=80, deadline=None)
@given(
    arrays(np.float64, st.tuples(st.integers(1, 40), st.just(3)), elements=coordinates),
    arrays(np.float64, st.tuples(st.integers(1, 20), st.just(3)), elements=st.floats(-5.0, 5.0)),
)
def test_a_cloud_against_every_one_of_its_points(points, queries):
    found = cloud_closest_points(points, queries)
    gap = np.linalg.norm(queries[:, None] - points[None], axis=-1)
    np.testing.assert_allclose(found.distance, gap.min(axis=1), atol=1e-12)
    np.testing.assert_allclose(
        gap[np.arange(len(queries)), found.patch], found.distance, atol=1e-12
    )
    np.testing.assert_array_equal(found.point, points[found.patch])
    assert found.uv.shape == (len(queries), 2) and not found.uv.any()


def test_no_queries_and_the_morton_order():
    empty = mesh_closest_points([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], np.zeros((0, 3)))
    assert empty.point.shape == (0, 3) and empty.distance.shape == (0,)
    assert cloud_closest_points([[0.0, 0, 0]], np.zeros((0, 3))).patch.shape == (0,)
    points = np.random.default_rng(0).uniform(size=(500, 3))
    order = morton_order(points)
    assert sorted(order.tolist()) == list(range(500))
    # neighbours in the order are near: far shorter steps than in a random order
    assert (
        np.linalg.norm(np.diff(points[order], axis=0), axis=1).mean()
        < 0.4 * np.linalg.norm(np.diff(points, axis=0), axis=1).mean()
    )


@pytest.mark.parametrize(
    ("vertices", "faces", "queries", "message"),
    [
        (
            [[0, 0, np.nan], [1, 0, 0], [0, 1, 0]],
            [[0, 1, 2]],
            [[0, 0, 0]],
            "vertices: expected finite",
        ),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 3]], [[0, 0, 0]], "from 0 to 2, found 3"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, -1, 2]], [[0, 0, 0]], "found -1"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.zeros((0, 3), int), [[0, 0, 0]], "m >= 1"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0.0, 1.0, 2.0]], [[0, 0, 0]], "integer"),
        (
            [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
            [[0, 1, 2]],
            [[0, 0, np.inf]],
            "queries: expected finite",
        ),
        ([[0, 0], [1, 0]], [[0, 1, 1]], [[0, 0, 0]], "shape (n, 3)"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 2e15]], [[0, 1, 2]], [[0, 0, 0]], "within ±1e+15"),
    ],
)
def test_bad_arrays_are_refused_before_compiled_code(vertices, faces, queries, message):
    with pytest.raises(GshadeError, match=re.escape(message)):
        mesh_closest_points(vertices, faces, queries)


def test_a_cloud_with_bad_points_is_refused():
    with pytest.raises(GshadeError, match="points: expected finite"):
        cloud_closest_points([[0.0, 0.0, np.nan]], [[0.0, 0.0, 0.0]])
    with pytest.raises(GshadeError, match="n >= 1"):
        cloud_closest_points(np.zeros((0, 3)), [[0.0, 0.0, 0.0]])
