"""Catmull–Clark subdivision surfaces: OBJ input, mesh checks, exact limit patches (B-spline
and Stam), against independent oracles.

Oracles: the uniform bicubic B-spline surface (BSplinePatch) for regular meshes; repeated
global refinement with the limit-point masks of Halstead, Kass & DeRose (1993) for the
limit surface near extraordinary vertices; their tangent masks for the limit normal;
finite differences for the derivatives.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade import GshadeError
from gshade.analysis.continuity import find_junctions
from gshade.geometry import (
    BezierPatch,
    BSplinePatch,
    irregular_mask,
    patch_normals,
    regularised_derivatives,
)
from gshade.geometry.subdivision.catmull_clark import catmull_clark
from gshade.geometry.subdivision.quad_mesh import MeshTopology, validate_mesh
from gshade.geometry.subdivision.stam import StamPatch, subdivision_patches
from gshade.io import parse_obj, read_obj
from gshade.scene import load_scene
from gshade.shape import evaluate

from ...support.meshes import (
    CUBE,
    DRUM,
    fan_mesh,
    grid_mesh,
    limit_positions,
    nearest_distances,
    obj_of,
    refine_times,
)

# --------------------------------------------------------------------------- oracles


def assert_limit_points_on_patches(V, F, patches, k, tol=1e-12, complete=False):
    """After k refinements every dyadic patch point p(i / 2^k, j / 2^k) is the limit point
    of a vertex, and (``complete``: all the patches given) every vertex's limit point is a
    dyadic patch point."""
    L = limit_positions(*refine_times(V, F, k))
    g = np.arange(2**k + 1) / 2**k
    pts = np.concatenate([p(g[:, None], g[None, :]).reshape(-1, 3) for p in patches])
    scale = np.ptp(L, axis=0).max()
    assert nearest_distances(pts, L).max() <= tol * scale
    if complete:
        assert nearest_distances(L, pts).max() <= tol * scale


def halstead_normal(V, F, vertex):
    """The limit normal at an inner vertex from the tangent masks of Halstead et al.:
    t = sum_i A_n c_i e_i + (c_i + c_(i+1)) f_i with c_i = cos(2 pi i / n + phase),
    A_n = 1 + cos(2 pi / n) + cos(pi / n) sqrt(2 (9 + cos(2 pi / n))), for two phases."""
    V, F = np.asarray(V, float), np.asarray(F)
    topo = MeshTopology(F, len(V))
    h0 = int(np.nonzero(topo.origin == vertex)[0][0])
    ring, g = [], h0
    while True:
        ring.append((int(topo.dest[g]), int(topo.dest[topo.next(g)])))
        g = topo.ccw(g)
        if g == h0:
            break
    n = len(ring)
    A = 1 + np.cos(2 * np.pi / n) + np.cos(np.pi / n) * np.sqrt(2 * (9 + np.cos(2 * np.pi / n)))
    tangents = []
    for phase in (0.0, np.pi / 2):
        c = np.cos(2 * np.pi * np.arange(n + 1) / n - phase)
        tangents.append(
            sum(A * c[i] * V[e] + (c[i] + c[i + 1]) * V[f] for i, (e, f) in enumerate(ring))
        )
    normal = np.cross(*tangents)
    return normal / np.linalg.norm(normal)


def torus_mesh(m=6, n=5, R=3.0, r=1.0):
    def point(i, j):
        a, b = 2 * np.pi * i / m, 2 * np.pi * j / n
        return ((R + r * np.cos(b)) * np.cos(a), (R + r * np.cos(b)) * np.sin(a), r * np.sin(b))

    return grid_mesh(m, n, point, closed_u=True, closed_v=True)


@pytest.fixture(scope="module")
def cube1():
    """The cube refined once: 24 faces, each with one valence-3 vertex."""
    return catmull_clark(*read_obj(CUBE))


@pytest.fixture(scope="module")
def drum1():
    """The valence-3/5 mesh refined once: every face has at most one extraordinary vertex."""
    return catmull_clark(*read_obj(DRUM))


# --------------------------------------------------------------------------- OBJ


def test_obj_reference_forms_negative_indices_and_ignored_statements():
    text = (
        "# a comment\nmtllib x.mtl\no thing\ng group\ns 1\nusemtl red\n"
        "v 0 0 0\nv 1 0 0\nv 1 1 0 1.0\nv 0 1 0 0.5 0.5 0.5\n"
        "vt 0 0\nvn 0 0 1\n"
        "f 1 2 3 4\n"
        "f 1/1 2/1 3/1   # trailing comment\n"
        "f 1/1/1 2/1/1 3/1/1 4/1/1\n"
        "f 1//1 2//1 3//1 4//1\n"
        "f -4 -3 -2 -1\n"
        "l 1 2\n"
    )
    mesh = parse_obj(text, "m.obj")
    np.testing.assert_array_equal(mesh.vertices[2], [1, 1, 0])
    assert mesh.faces == [(0, 1, 2, 3), (0, 1, 2), (0, 1, 2, 3), (0, 1, 2, 3), (0, 1, 2, 3)]
    assert mesh.face_lines == [13, 14, 15, 16, 17]
    V, F = read_obj(CUBE)
    assert V.shape == (8, 3) and len(F) == 6 and all(len(f) == 4 for f in F)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "v 0 0\n",
            r"m.obj, line 1: expected a vertex 'v x y z' .*a line of 3 fields \(not shown\)",
        ),
        ("v 0 0 x\n", r"line 1: expected a vertex"),
        ("v 0 0 inf\n", r"line 1: expected finite coordinates"),
        ("v 0 0 0\nv 1 0 0\nf 1 2\n", r"line 3: expected a face 'f a b c ...'"),
        ("v 0 0 0\nf 1 2 x\n", r"line 2: expected vertex references .* not \(not shown\)"),
        ("v 0 0 0\nf 1 2/3/4/5 1\n", r"line 2: expected vertex references .* not"),
        ("v 0 0 0\nf 1 0 1\n", r"line 2: expected a vertex index other than 0"),
        ("v 0 0 0\nf 1 1 5\n", r"line 2: expected vertex indices from 1 to 1, found 5"),
        ("v 0 0 0\nf -1 -2 -1\n", r"line 2: expected a relative vertex index from -1 to -1"),
        ("v 0 0 0\ncurv 0 1 1 2\n", r"line 2: expected a polygon mesh .* free-form"),
        ("v 0 0 0\nvertex 1 2 3\n", r"line 2: expected an OBJ statement such as 'v' or 'f', "),
        ("v 0 0 0\n", r"m.obj: expected at least one face"),
    ],
)
def test_obj_errors_name_file_line_expected_and_found(text, message):
    with pytest.raises(GshadeError, match=message):
        parse_obj(text, "m.obj")


def test_obj_missing_file(tmp_path):
    with pytest.raises(GshadeError, match=r"nothing\.obj: no such file"):
        read_obj(tmp_path / "nothing.obj")


# --------------------------------------------------------------------------- mesh checks


def check_text(text):
    mesh = parse_obj(text, "bad.obj")
    return validate_mesh(mesh.vertices, mesh.faces, source="bad.obj", face_lines=mesh.face_lines)


def test_mesh_errors_name_what_is_wrong():
    V, F = read_obj(CUBE)
    tri = [*F[:5], (F[5][0], F[5][1], F[5][2])]
    with pytest.raises(
        GshadeError, match=r"bad.obj: face 6 \(line 14\) has 3 vertices; expected a quad"
    ):
        check_text(obj_of(V, tri))
    flipped = [*F[:5], tuple(reversed(F[5]))]
    with pytest.raises(
        GshadeError,
        match=r"edge \d-\d runs in the same direction in face \d \(line \d+\) and face 6",
    ):
        check_text(obj_of(V, flipped))
    with pytest.raises(GshadeError, match=r"uses a vertex twice"):
        check_text(obj_of(V, [*F[:5], (1, 2, 1, 3)]))
    # a fin: a third face on an edge of the cube
    extra = np.vstack([V, [[3, 3, 3], [4, 4, 4]]])
    a, b = F[0][0], F[0][1]
    with pytest.raises(
        GshadeError, match=rf"edge {a + 1}-{b + 1} is shared by 3 faces .*at most 2"
    ):
        check_text(obj_of(extra, [*F, (b, a, 8, 9)]))
    # two cubes touching at a vertex: two fans around it
    shift = V + 2.0
    shift[7] = V[7]  # cube 2's vertex 8 (index 7) is cube 1's
    idx = [i + 8 if i != 7 else 7 for f in F for i in f]
    F2 = [tuple(idx[4 * k : 4 * k + 4]) for k in range(6)]
    with pytest.raises(
        GshadeError, match=r"vertex 8 joins separate fans of faces \(a non-manifold"
    ):
        check_text(obj_of(np.vstack([V, shift[:7], [[0, 0, 0]]]), [*F, *F2]))


def test_mesh_errors_with_0_based_names():
    with pytest.raises(GshadeError, match=r"face 1 has 3 vertices"):
        validate_mesh(np.zeros((5, 3)), [(0, 1, 2, 3), (0, 1, 2)])
    with pytest.raises(GshadeError, match=r"face 0: expected vertex indices from 0 to 3, found 7"):
        validate_mesh(np.zeros((4, 3)), [(0, 1, 2, 7)])
    with pytest.raises(GshadeError, match=r"levels: expected an integer >= 0"):
        subdivision_patches(*read_obj(CUBE), levels=-1)


# --------------------------------------------------------------------------- refinement


def test_refinement_keeps_limit_points_and_orientation(cube1):
    """The limit point of a vertex is that of its vertex point after one more step (a
    check of the oracle and of the refinement alike)."""
    V, F = read_obj(DRUM)
    V1, F1 = catmull_clark(V, F)
    np.testing.assert_allclose(limit_positions(V1, F1)[: len(V)], limit_positions(V, F), atol=1e-14)
    assert len(V1) == len(V) + 60 + 30 and F1.shape == (120, 4)
    validate_mesh(V1, F1)  # still manifold and consistently oriented
    Vo, Fo = grid_mesh(3, 2, lambda i, j: (i, j, i * j))
    Vr, Fr = catmull_clark(Vo, Fo)
    np.testing.assert_allclose(
        limit_positions(Vr, Fr)[: len(Vo)], limit_positions(Vo, Fo), atol=1e-14
    )


# --------------------------------------------------------------------------- regular meshes


def assert_patches_are_spans(patches, surface, columns, n):
    """Patch f (row-major over the faces, ``columns`` per row) is the uniform B-spline
    surface's span [3 + i, 4 + i] x [3 + j, 4 + j], derivatives to order 2 included."""
    u, v = np.linspace(0, 1, n)[:, None], np.linspace(0, 1, n)[None, :]
    for f, p in enumerate(patches):
        i, j = divmod(f, columns)
        expected = surface.derivatives(u + 3 + i, v + 3 + j, 2)
        np.testing.assert_allclose(p.derivatives(u, v, 2), expected, atol=1e-12)


def test_regular_closed_mesh_is_the_uniform_bicubic_bspline():
    V, F = torus_mesh(6, 5)
    patches = subdivision_patches(V, F)
    assert all(isinstance(p, BezierPatch) for p in patches) and len(patches) == 30
    net = V.reshape(6, 5, 3)
    wrapped = net[np.arange(-1, 8) % 6][:, np.arange(-1, 7) % 5]  # 9 x 8 periodic net
    surface = BSplinePatch(wrapped, (3, 3), (np.arange(13.0), np.arange(12.0)))
    assert_patches_are_spans(patches, surface, columns=5, n=7)


def test_open_grid_is_the_bspline_over_phantom_points():
    """Boundary rules (B-spline boundary curves, fixed corners) = the B-spline surface over
    the net extended by phantom points 2 b - p."""
    rng = np.random.default_rng(7)
    heights = rng.normal(size=(7, 7))
    V, F = grid_mesh(6, 6, lambda i, j: (i, 0.9 * j, heights[i, j]))
    patches = subdivision_patches(V, F)
    assert all(isinstance(p, BezierPatch) for p in patches) and len(patches) == 36
    net = V.reshape(7, 7, 3)
    net = np.concatenate([2 * net[:1] - net[1:2], net, 2 * net[-1:] - net[-2:-1]], axis=0)
    net = np.concatenate([2 * net[:, :1] - net[:, 1:2], net, 2 * net[:, -1:] - net[:, -2:-1]], 1)
    surface = BSplinePatch(net, (3, 3), (np.arange(13.0), np.arange(13.0)))
    assert_patches_are_spans(patches, surface, columns=6, n=5)
    assert_limit_points_on_patches(V, F, patches, 2, complete=True)


# --------------------------------------------------------------------------- Stam patches


def test_cube_limit_surface_matches_refinement_near_the_vertices(cube1):
    patches = subdivision_patches(*cube1)
    assert len(patches) == 24 and all(isinstance(p, StamPatch) for p in patches)
    assert {p.valence for p in patches} == {3}
    assert patches[0].subdominant == pytest.approx(
        (5 + np.cos(2 * np.pi / 3) + np.cos(np.pi / 3) * np.sqrt(2 * (9 + np.cos(2 * np.pi / 3))))
        / 16,
        abs=1e-12,
    )
    # u, v down to 2^-5 next to the vertex
    assert_limit_points_on_patches(*cube1, patches[:2], 5)
    assert_limit_points_on_patches(*cube1, patches, 2, complete=True)


def test_valence_3_and_5_limit_surface_matches_refinement(drum1):
    V, F = drum1
    patches = subdivision_patches(V, F)
    stam = [k for k, p in enumerate(patches) if isinstance(p, StamPatch)]
    assert sorted({patches[k].valence for k in stam}) == [3, 5] and len(stam) == 40
    chosen = [patches[k] for k in stam[:3] + stam[-3:]] + [patches[k] for k in range(0, 120, 17)]
    assert_limit_points_on_patches(V, F, chosen, 3)


def test_boundary_extraordinary_vertices_match_refinement():
    for sectors, keep in ((4, 3), (6, 4), (5, 5)):
        V, F = fan_mesh(sectors, keep=keep, seed=sectors)
        patches = subdivision_patches(V, F)
        stam = [p for p in patches if isinstance(p, StamPatch)]
        assert len(stam) == keep and all(p.boundary == (keep < sectors) for p in stam)
        assert_limit_points_on_patches(V, F, patches, 3, complete=True)


@settings(max_examples=4, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_perturbed_meshes_match_refinement(drum1, seed):
    rng = np.random.default_rng(seed)
    V, F = drum1
    V = V + 0.05 * rng.normal(size=V.shape)
    patches = subdivision_patches(V, F)
    stam = [p for p in patches if isinstance(p, StamPatch)]
    assert_limit_points_on_patches(V, F, [stam[0], stam[-1], patches[1]], 2)


def test_limit_normal_at_the_vertex_from_tangent_masks(drum1):
    V, F = drum1
    patches = subdivision_patches(V, F)
    topo = MeshTopology(np.asarray(F), len(V))
    L = limit_positions(V, F)
    seen = set()
    for f, p in enumerate(patches):
        if not isinstance(p, StamPatch):
            continue
        ev = int(F[f][np.nonzero(~topo.regular[F[f]])[0][0]])
        expected = halstead_normal(V, F, ev)
        np.testing.assert_allclose(p(0, 0), L[ev], atol=1e-13)
        # the project's irregular-point machinery: irregular there, exact limit normal
        d = p.derivatives(0.0, 0.0, 3)
        assert np.all(np.isfinite(d)) and irregular_mask(d[:, :, None])[0]
        zero = np.zeros(1)
        np.testing.assert_allclose(patch_normals(p, zero, zero).n[0], expected, atol=1e-12)
        np.testing.assert_allclose(p.limit_normal, expected, atol=1e-12)
        # normals approaching the vertex converge to it
        if p.valence not in seen:
            seen.add(p.valence)
            t = 2.0 ** -np.arange(4, 21, 4)
            n = patch_normals(p, t, 0.5 * t).n
            gaps = np.linalg.norm(n - expected, axis=-1)
            assert np.all(np.diff(gaps) < 0) and gaps[-1] < 1e-3
            r = regularised_derivatives(p, zero, zero, 3)
            assert np.all(np.isfinite(r.d)) and not r.regular
    assert seen == {3, 5}


def test_normals_point_outward(cube1):
    for p in subdivision_patches(*read_obj(CUBE)):
        u, v = p.parameter_grid(6, 6)
        n = patch_normals(p, u, v).n
        assert np.all(np.sum(n * p(u, v), axis=-1) > 0)


def test_g1_across_every_patch_edge(drum1):
    V, F = drum1
    patches = subdivision_patches(V, F)
    junctions = find_junctions(patches, 1e-9)
    assert len(junctions) == 2 * len(F)  # every edge of the closed mesh
    t = np.linspace(0, 1, 11)

    def side(p, name, t):
        u = {"u0": np.zeros_like(t), "u1": np.ones_like(t)}.get(name, t)
        v = {"v0": np.zeros_like(t), "v1": np.ones_like(t)}.get(name, t)
        return p(u, v), patch_normals(p, u, v).n

    kinds = set()
    for i, si, j, sj, rev in junctions:
        pi, ni = side(patches[i], si, t)
        pj, nj = side(patches[j], sj, t[::-1] if rev else t)
        np.testing.assert_allclose(pi, pj, atol=1e-12)
        np.testing.assert_allclose(ni, nj, atol=1e-10)
        kinds.add(tuple(sorted(type(patches[k]).__name__ for k in (i, j))))
    assert kinds == {
        ("BezierPatch", "BezierPatch"),
        ("BezierPatch", "StamPatch"),
        ("StamPatch", "StamPatch"),
    }


def test_derivatives_agree_with_finite_differences(drum1):
    V, F = drum1
    patches = subdivision_patches(V, F)
    rng = np.random.default_rng(3)
    for p in [q for q in patches if isinstance(q, StamPatch)][::13]:
        # points inside pieces of rings 1..12 (away from piece borders: C2 only there)
        n = rng.integers(1, 13, 40)
        s, t = rng.uniform(0.15, 0.85, 40), rng.uniform(0.15, 0.85, 40)
        q = rng.integers(1, 4, 40)
        u = (s + (q != 3)) * 2.0**-n
        v = (t + (q != 1)) * 2.0**-n
        d = p.derivatives(u, v, 3)
        for a in range(3):
            for b in range(3 - a):
                for du, dv, (ea, eb) in ((1, 0, (a + 1, b)), (0, 1, (a, b + 1))):
                    h = 1e-5 * 2.0**-n
                    fd = (
                        p.derivatives(u + du * h, v + dv * h, a + b)[a, b]
                        - p.derivatives(u - du * h, v - dv * h, a + b)[a, b]
                    ) / (2 * h)[:, None]
                    scale = np.linalg.norm(d[ea, eb], axis=-1, keepdims=True) + 1e-9
                    assert np.all(np.abs(fd - d[ea, eb]) <= 2e-6 * scale)


def test_grid_and_point_evaluation_agree_everywhere(cube1):
    p = subdivision_patches(*cube1)[5]
    g = np.concatenate([[0.0, 1e-300, 2.0**-60, 1e-9, 1e-6], np.linspace(0, 1, 37)[1:]])
    u, v = g[:, None], g[None, :]
    grid = p.derivatives(u, v, 4)
    uu, vv = np.broadcast_arrays(u, v)
    points = p.derivatives(uu.ravel(), vv.ravel(), 4).reshape(grid.shape)
    assert np.all(np.isfinite(grid))
    # two algorithms, round-off apart: relative to the largest derivative of each order
    norms = np.linalg.norm(grid, axis=-1)
    for a in range(5):
        for b in range(5 - a):
            size = np.max([norms[i, a + b - i] for i in range(a + b + 1)], axis=0)
            assert np.all(np.abs(grid[a, b] - points[a, b]) <= 1e-13 * size[..., None])
    assert np.all(grid[4, 0] == 0) and np.all(grid[0, 4] == 0)  # bicubic pieces
    out = np.full_like(grid, np.nan)
    p.derivatives(u, v, 4, out=out)
    np.testing.assert_array_equal(out, grid)


# --------------------------------------------------------------------------- scenes


def scene_text(file, extra=""):
    return f'[[surface]]\ntype = "subdivision"\nfile = "{file}"\n{extra}'


def test_subdivision_scene_patches_data_file_and_hash(tmp_path):
    (tmp_path / "m.obj").write_text(CUBE.read_text())
    path = tmp_path / "s.toml"
    path.write_text(scene_text("m.obj"))
    scene = load_scene(path)
    assert scene.surfaces[0].kind == "subdivision" and len(scene.patches) == 24
    assert scene.data_files == ((tmp_path / "m.obj").resolve(),)
    before = scene.text_hash
    # levels 1 = the one step that separates the cube's corners anyway; 2 splits again
    assert len(load_scene(path, {"surface.1.levels": 1}).patches) == 24
    assert len(load_scene(path, {"surface.1.levels": 2}).patches) == 96
    (tmp_path / "m.obj").write_text(CUBE.read_text().replace("v 1 1 1", "v 1 1 1.5"))
    assert load_scene(path).text_hash != before


@pytest.mark.parametrize(
    ("obj", "extra", "message"),
    [
        (None, "levels = -1\n", r"\(subdivision\): levels: expected an integer >= 0, got -1"),
        (None, "levels = 9\n", r"levels: expected an integer from 0 to 4 .*got 9"),
        (None, 'file = "x.obj"\n', None),  # duplicate key: invalid TOML
        ("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n", "", r"m\.obj: face 1 \(line 4\) has 3 vertices"),
        ("v 0 0 0\nf 1 2 3 4\n", "", r"m\.obj, line 2: expected vertex indices from 1 to 1"),
    ],
)
def test_subdivision_scene_errors(tmp_path, obj, extra, message):
    (tmp_path / "m.obj").write_text(obj if obj is not None else CUBE.read_text())
    path = tmp_path / "s.toml"
    path.write_text(scene_text("m.obj", extra))
    with pytest.raises(GshadeError, match=message or "invalid TOML") as info:
        load_scene(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_render_of_a_bad_mesh_exits_2_with_one_line(tmp_path):
    V, F = read_obj(CUBE)
    (tmp_path / "m.obj").write_text(obj_of(V, [*F[:5], tuple(reversed(F[5]))]))
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text("m.obj"))
    out = tmp_path / "out.exr"
    result = subprocess.run(
        [sys.executable, "-m", "gshade", "render", str(scene), "-o", str(out)],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr
    assert "scene.toml" in lines[0] and "m.obj" in lines[0]
    assert "same direction" in lines[0] and "consistently oriented" in lines[0]
    assert not out.exists()


def test_missing_obj_in_scene(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(scene_text("gone.obj"))
    with pytest.raises(GshadeError, match=r"file: expected an existing file .*gone\.obj"):
        load_scene(path)


def test_curvature_artefacts_at_extraordinary_vertices(drum1):
    """The known defect of Catmull–Clark surfaces that the curvature pictures show: toward
    an extraordinary vertex the curvature's surface gradient grows without bound (and for
    valence 5 the Gaussian curvature itself keeps growing), while at a regular vertex both
    stay bounded."""
    patches = subdivision_patches(*drum1)
    r = 10.0 ** -np.arange(1, 6)
    for valence in (3, 5):
        patch = next(p for p in patches if isinstance(p, StamPatch) and p.valence == valence)
        K = evaluate("gaussian", patch.derivatives(r, r, 3))
        slope = np.linalg.norm(K.gradient, axis=-1)
        assert K.valid.all() and np.all(np.diff(slope) > 0), (valence, slope)
        assert slope[-1] > 1e3 * slope[0], (valence, slope)
        if valence == 5:
            assert np.all(np.diff(K.f) > 0) and K.f[-1] > 4 * K.f[0]
    regular = next(p for p in patches if isinstance(p, BezierPatch))
    K = evaluate("gaussian", regular.derivatives(r, r, 3))
    slope = np.linalg.norm(K.gradient, axis=-1)
    assert slope.max() < 2 * slope.min() + 1.0
