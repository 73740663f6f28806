"""The n-sided hole around an extraordinary vertex (gshade.geometry.holes.ring), against
independent oracles.

Oracles: Stam's exact evaluation of the hole's own faces (``subdivision_patches`` of the
mesh given, refined as often as the hole was: the limit surface is C2 across the hole's
boundary with matching uniform parametrisations, so positions, d/dw and d^2/dw^2 agree);
repeated global refinement with the limit-point masks of Halstead et al. (1993) for the
boundary points and corners.
"""

from __future__ import annotations

import numpy as np
import pytest

from gshade import GshadeError
from gshade.geometry import BezierCurve
from gshade.geometry.holes.ring import Hole, find_holes, hole_around
from gshade.geometry.subdivision.quad_mesh import MeshTopology
from gshade.geometry.subdivision.stam import StamPatch, subdivision_patches
from gshade.io import parse_obj, read_obj

from ...support.meshes import (
    CUBE,
    DRUM,
    fan_mesh,
    grid_mesh,
    limit_positions,
    nearest_distances,
    obj_of,
    refine_times,
    wavy_fan,
)

T = np.linspace(0.0, 1.0, 9)
CASES = [(n, rings) for n in (3, 5, 6, 8) for rings in (3, 2)]


def curve(points, t=T, order=0):
    """Derivatives (order + 1, len(t), 3) of the cubic Bézier curve with these points."""
    return BezierCurve(points).derivatives(t, order)


def inside(hole, patches, j, t=T):
    """Stam's patch of the hole face next to segment j, as (position, d/dw, d^2/dw^2, its
    derivative along the segment) with w into the hole, t along the segment."""
    i = j // 2
    one = np.ones_like(t)
    if j % 2:  # e_i -> f_i: the side u = 1 of face i, t = v
        d = patches[hole.half_edges[i] // 4].derivatives(one, t, 2)
        return d[0, 0], -d[1, 0], d[2, 0], d[0, 1]
    # f_(i-1) -> e_i: the side v = 1 of face i - 1, u = 1 - t
    d = patches[hole.half_edges[i - 1] // 4].derivatives(1 - t, one, 2)
    return d[0, 0], -d[0, 1], d[0, 2], -d[1, 0]


@pytest.fixture(scope="module", params=CASES, ids=[f"n{n}-rings{r}" for n, r in CASES])
def case(request):
    n, rings = request.param
    V, F = wavy_fan(n, rings)
    (hole,) = find_holes(V, F)
    patches = subdivision_patches(V, F, levels=hole.refinements)
    assert len(patches) == len(hole.faces)
    return V, F, hole, patches


# --------------------------------------------------------------------------- topology


def test_the_hole_is_the_ring_of_faces_around_the_vertex(case):
    _, F, hole, patches = case
    n = hole.n
    assert hole.vertex == 0  # the centre of the fan
    # 2 rings of regular faces around the vertex: no refinement; 1 ring: one
    rings = 3 if len(F) == 9 * n else 2
    assert hole.refinements == (0 if rings == 3 else 1)
    assert hole.half_edges.shape == (n,) and hole.corner_vertices.shape == (2 * n,)
    assert len(set(hole.corner_vertices.tolist())) == 2 * n
    assert all(isinstance(patches[f], StamPatch) for f in hole.hole_faces)
    assert all(patches[f].valence == n for f in hole.hole_faces)
    topo = MeshTopology(hole.faces, len(hole.points))
    for i, h in enumerate(hole.half_edges):
        e, f = topo.dest[h], topo.dest[topo.next(h)]
        assert topo.origin[h] == hole.vertex
        assert hole.corner_vertices[2 * i + 1] == e  # c_(2i+1) = e_i
        assert hole.corner_vertices[(2 * i + 2) % (2 * n)] == f  # c_(2i+2) = f_i
        assert topo.ccw(h) == hole.half_edges[(i + 1) % n]  # counter-clockwise
    for j in range(2 * n):  # a loop of mesh edges with the hole on its left
        a, b = hole.corner_vertices[j], hole.corner_vertices[(j + 1) % (2 * n)]
        g = np.nonzero((topo.origin == a) & (topo.dest == b))[0]
        assert g.size == 1 and g[0] // 4 in set(hole.hole_faces.tolist())
    assert len(hole.patches) == 2 * n and hole.boundary.shape == (2 * n, 4, 3)


# --------------------------------------------------------------------------- 1. positions


def test_boundary_curves_are_the_limit_surface(case):
    V, F, hole, patches = case
    k = hole.refinements
    Vk, Fk = refine_times(V, F, k)
    np.testing.assert_allclose(hole.points, Vk, atol=1e-13)  # the same mesh
    L = limit_positions(Vk, Fk)  # Halstead et al.'s masks
    np.testing.assert_allclose(hole.corners, L[hole.corner_vertices], atol=1e-13)
    for j in range(2 * hole.n):
        b = curve(hole.boundary[j])[0]
        S = hole.patches[j]
        np.testing.assert_allclose(b, S(np.zeros_like(T), T), atol=1e-12)
        np.testing.assert_allclose(b, inside(hole, patches, j)[0], atol=1e-10)
    # dyadic boundary points t = i / 4 are limit points of the mesh refined twice more
    dyadic = np.concatenate([curve(b, np.arange(5) / 4)[0] for b in hole.boundary])
    L2 = limit_positions(*refine_times(Vk, Fk, 2))
    assert nearest_distances(dyadic, L2).max() <= 1e-12


# --------------------------------------------------------------------------- 2. derivatives


def test_cross_derivatives_are_the_limit_surface_inside_the_hole(case):
    """C2 across the boundary: d/dw and d^2/dw^2 (w into the hole) of the surrounding
    patches are those of Stam's patches of the hole's faces, in the same parametrisation."""
    *_, hole, patches = case
    for j in range(2 * hole.n):
        _, d1, d2, along = inside(hole, patches, j)
        c1, c2 = curve(hole.cross1[j])[0], curve(hole.cross2[j])[0]
        np.testing.assert_allclose(c1, d1, atol=1e-8)
        np.testing.assert_allclose(c2, d2, atol=1e-8)
        np.testing.assert_allclose(curve(hole.boundary[j], order=1)[1], along, atol=1e-8)
        # ... and of the surrounding patch with u = -w (u outward)
        S = hole.patches[j].derivatives(np.zeros_like(T), T, 2)
        np.testing.assert_allclose(c1, -S[1, 0], atol=1e-12)
        np.testing.assert_allclose(c2, S[2, 0], atol=1e-12)
        # orientation: (along the loop) x (into the hole) is the surface's normal side
        normal = np.cross(S[1, 0], S[0, 1])
        assert np.all(np.einsum("ij,ij->i", np.cross(along, c1), normal) > 0)


def test_cross_derivatives_point_into_the_hole(case):
    """Stepping from the boundary along d1 approaches the hole's own surface."""
    hole = case[2]
    for j in range(2 * hole.n):
        b, c1 = curve(hole.boundary[j])[0], curve(hole.cross1[j])[0]
        centre = hole.corners.mean(axis=0)
        assert np.all(np.einsum("ij,ij->i", c1[1:-1], centre - b[1:-1]) > 0)


# --------------------------------------------------------------------------- 3. the loop


def test_the_loop_closes_c2_at_edge_corners_and_turns_at_face_corners(case):
    hole = case[2]
    m = 2 * hole.n
    ends = [0.0, 1.0]
    B = [curve(hole.boundary[j], ends, 2) for j in range(m)]
    D1 = [curve(hole.cross1[j], ends, 1) for j in range(m)]
    D2 = [curve(hole.cross2[j], ends)[0] for j in range(m)]
    for j in range(m):
        k = (j + 1) % m  # segment j ends at loop corner k, where segment k starts
        assert np.array_equal(hole.boundary[j, 3], hole.boundary[k, 0])
        assert np.array_equal(hole.boundary[k, 0], hole.corners[k])
        if k % 2:  # e_i: one grid line of a regular region, C2 with equal speed
            pairs = [(B[j][1, 1], B[k][1, 0]), (B[j][2, 1], B[k][2, 0])]
            pairs += [(D1[j][0, 1], D1[k][0, 0]), (D2[j][1], D2[k][0])]
            pairs += [(D1[j][1, 1], D1[k][1, 0])]
        else:  # f_i: a quarter turn, tangents and cross derivatives swap
            pairs = [(B[k][1, 0], D1[j][0, 1]), (D1[k][0, 0], -B[j][1, 1])]
            pairs += [(B[k][2, 0], D2[j][1]), (D2[k][0], B[j][2, 1])]
            pairs += [(D1[k][1, 0], -D1[j][1, 1])]  # the twist
            # a real corner: the two tangents are independent
            t1, t2 = B[j][1, 1], B[k][1, 0]
            assert np.linalg.norm(np.cross(t1, t2)) > 0.1 * np.linalg.norm(t1) * np.linalg.norm(t2)
        for a, b in pairs:
            np.testing.assert_allclose(a, b, atol=1e-10)


def test_side_corners_and_faces():
    V, F = wavy_fan(5, 3)
    (hole,) = find_holes(V, F)
    np.testing.assert_array_equal(hole.side_corners, hole.corners[0::2])
    np.testing.assert_array_equal(hole.hole_faces, hole.half_edges // 4)
    assert isinstance(hole, Hole)


# --------------------------------------------------------------------------- 4. detection


def test_no_extraordinary_vertex_no_hole():
    V, F = grid_mesh(5, 4, lambda i, j: (i, j, 0.1 * i * j))
    assert find_holes(V, F) == []


def test_extraordinary_vertex_on_the_boundary_is_refused():
    V, F = fan_mesh(6, rings=2, keep=3, seed=1)
    with pytest.raises(GshadeError, match=r"vertex 0 is an extraordinary vertex on the mesh bo"):
        find_holes(V, F)
    mesh = parse_obj(obj_of(V, F), "fan.obj")
    with pytest.raises(GshadeError, match=r"^fan.obj: vertex 1 is an extraordinary vertex on"):
        find_holes(mesh.vertices, mesh.faces, source="fan.obj", face_lines=mesh.face_lines)


def test_hole_around_needs_regular_surroundings():
    V, F = fan_mesh(5, rings=2, seed=2)
    topo = MeshTopology(np.asarray(F), len(V))
    with pytest.raises(GshadeError, match=r"vertex 0: expected regular faces .*refine"):
        hole_around(V, topo, 0)
    boundary = int(np.nonzero(topo.boundary_vertex)[0][0])
    with pytest.raises(GshadeError, match=rf"vertex {boundary}: expected an interior vertex"):
        hole_around(V, topo, boundary)


def test_a_four_sided_hole_in_a_regular_grid():
    V, F = grid_mesh(6, 6, lambda i, j: (i, j, np.sin(i) * np.cos(0.7 * j)))
    topo = MeshTopology(np.asarray(F), len(V))
    hole = hole_around(V, topo, 3 * 7 + 3)
    assert hole.n == 4 and hole.refinements == 0
    patches = subdivision_patches(V, F)
    # the 4-hole's faces are bicubic: its cross derivatives are theirs (C2 everywhere)
    for j in range(8):
        _, d1, d2, _ = inside(hole, _cornered(patches, topo, hole), j)
        np.testing.assert_allclose(curve(hole.cross1[j])[0], d1, atol=1e-12)
        np.testing.assert_allclose(curve(hole.cross2[j])[0], d2, atol=1e-12)


def _cornered(patches, topo, hole):
    """The hole's faces as patches with (0, 0) at the vertex and u along h_i."""
    from gshade.geometry.subdivision.catmull_clark import regular_patch

    out = dict(enumerate(patches))
    for h in hole.half_edges:
        out[h // 4] = regular_patch(hole.points, topo, int(h))
    return out


@pytest.mark.parametrize(
    ("path", "valences", "steps"),
    [(CUBE, {3: 8}, 2), (DRUM, {3: 10, 5: 2}, 1)],
    ids=["cube", "pentadrum"],
)
def test_obj_meshes_with_nearby_extraordinary_vertices(path, valences, steps):
    """Extraordinary vertices on one edge (the cube) need two refinements, on opposite
    corners of a face (the drum's rim and cap centres) one; all holes share one mesh."""
    V, F = read_obj(path)
    holes = find_holes(V, F)
    found: dict[int, int] = {}
    for h in holes:
        found[h.n] = found.get(h.n, 0) + 1
    assert found == valences
    assert {h.refinements for h in holes} == {steps}
    assert all(h.points is holes[0].points for h in holes)
    patches = subdivision_patches(V, F, levels=steps)
    for h in holes[:2] + holes[-2:]:
        for j in range(2 * h.n):
            b, d1, d2, _ = inside(h, patches, j)
            np.testing.assert_allclose(curve(h.boundary[j])[0], b, atol=1e-10)
            np.testing.assert_allclose(curve(h.cross1[j])[0], d1, atol=1e-8)
            np.testing.assert_allclose(curve(h.cross2[j])[0], d2, atol=1e-8)


def test_holes_are_read_only():
    V, F = wavy_fan(3, 3)
    (hole,) = find_holes(V, F)
    for a in (hole.points, hole.boundary, hole.cross1, hole.cross2, hole.corners):
        with pytest.raises(ValueError, match="read-only"):
            a[0] = 0.0
    with pytest.raises(AttributeError):
        hole.n = 4  # type: ignore[misc]
