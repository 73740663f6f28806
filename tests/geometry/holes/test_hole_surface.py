"""Catmull–Clark surfaces with their holes filled (gshade.geometry.holes.surface, the scene
type ``hole``), and their shape against the Catmull–Clark limit surface of the same mesh.

Oracles: Stam's exact patches of the same mesh (the surroundings are the same surface; the
curvature near the extraordinary vertex is the subdivision surface's), gshade's own
continuity report with its default tolerances, and the hole's own data.
"""

from __future__ import annotations

import numpy as np
import pytest

from gshade import GshadeError
from gshade.analysis.continuity import continuity_report
from gshade.geometry.holes.fairing import fairing_value
from gshade.geometry.holes.surface import filled_surface
from gshade.geometry.patches.bezier import BezierPatch
from gshade.geometry.subdivision.stam import StamPatch, subdivision_patches
from gshade.io import read_obj
from gshade.scene import load_scene
from gshade.shape.registry import evaluate

from ...support.meshes import CUBE, DRUM, grid_mesh, obj_of
from ...support.paths import ROOT

HEXADRUM = ROOT / "scenes" / "data" / "hexadrum.obj"


@pytest.fixture(scope="module", params=["G1", "G2"])
def drum(request):
    V, F = read_obj(DRUM)
    return filled_surface(V, F, request.param)


def test_the_holes_are_replaced_by_their_fillings(drum):
    holes, fillings = drum.holes, drum.fillings
    assert sorted(h.n for h in holes) == [3] * 10 + [5] * 2
    faces = np.concatenate([h.hole_faces for h in holes])
    assert len(np.unique(faces)) == len(faces)  # the holes share no face
    patches, regular = drum.patches, len(holes[0].faces) - len(faces)
    assert len(patches) == regular + len(faces) and drum.outside == patches[:regular]
    assert all(isinstance(p, BezierPatch) and p.degree == (3, 3) for p in patches[:regular])
    degree = {"G1": 5, "G2": 9}[fillings[0].continuity]
    assert all(p.degree == (degree, degree) for p in patches[regular:])
    assert [p for f in fillings for p in f.patches] == patches[regular:]
    # the bicubic part is the Catmull–Clark surface's own
    cc = subdivision_patches(holes[0].points, holes[0].faces)
    kept = [f for f in range(len(holes[0].faces)) if f not in set(faces.tolist())]
    for f, p in list(zip(kept, drum.outside, strict=True))[::17]:
        np.testing.assert_array_equal(p.points, cc[f].points)


def test_every_junction_of_the_surface_is_classed_as_the_filling(drum):
    """gshade's continuity report over the whole surface: every junction (bicubic ones,
    outer and inner edges of the fillings, those meeting at the centres) is G2 for the G2
    filling; for the G1 filling the fillings' edges are G1 and nothing is worse."""
    report = continuity_report(drum.patches)
    classes = [j.cls for j in report]
    assert len(classes) == 2 * len(drum.patches)  # a closed quad surface: 2 edges per patch
    if drum.fillings[0].continuity == "G2":
        assert set(classes) == {"G2"}
    else:
        assert set(classes) == {"G1", "G2"}
        assert classes.count("G1") >= sum(h.n for h in drum.holes)


def test_a_mesh_without_extraordinary_vertices_has_no_hole(tmp_path):
    V, F = grid_mesh(5, 5, lambda i, j: (i, j, 0.1 * i * j))
    with pytest.raises(GshadeError, match=r"m\.obj: expected a mesh with an interior vertex of"):
        filled_surface(V, F, source="m.obj")


# --------------------------------------------------------------------------- shape


def ring_maxima(patch, k, m=12):
    """max |K| and max |grad H| over the ring 2^-(k+1) <= max(u, v) <= 2^-k of a patch
    with (0, 0) at the centre."""
    a = np.linspace(2.0 ** -(k + 1), 2.0**-k, 4)
    s = np.linspace(0.0, 1.0, m)
    u = np.concatenate([np.repeat(a, m), (s * a[:, None]).ravel()])
    v = np.concatenate([(s * a[:, None]).ravel(), np.repeat(a, m)])
    d = patch.derivatives(u, v, 3)
    K, H = evaluate("gaussian", d, gradient=False), evaluate("mean", d)
    assert K.valid.all() and H.valid.all()
    return np.abs(K.f).max(), np.linalg.norm(H.gradient, axis=-1).max()


RINGS = (0, 1, 2, 3, 5, 10, 15, 20)


@pytest.mark.parametrize("path", [DRUM, HEXADRUM], ids=["pentadrum", "hexadrum"])
@pytest.mark.parametrize("continuity", ["G1", "G2"])
def test_the_filling_has_bounded_curvature_where_catmull_clark_has_not(path, continuity):
    """Over the filled region, toward the centre: the filling's |K| and |grad H| settle
    (bounded), the Catmull–Clark surface's |grad H| grows without bound; the filling's
    maxima of both are below the subdivision surface's."""
    surface = filled_surface(*read_obj(path), continuity)
    cc = subdivision_patches(surface.holes[0].points, surface.holes[0].faces)
    for n in sorted({h.n for h in surface.holes}):
        hole, filling = next(
            (h, f) for h, f in zip(surface.holes, surface.fillings, strict=True) if h.n == n
        )
        stam = [cc[int(f)] for f in hole.hole_faces]
        assert all(isinstance(p, StamPatch) for p in stam)
        ours = np.array([[ring_maxima(p, k) for p in filling.patches] for k in RINGS]).max(1)
        theirs = np.array([[ring_maxima(p, k) for p in stam] for k in RINGS]).max(1)
        # bounded: the innermost rings agree (the centre's own values)
        np.testing.assert_allclose(ours[-1], ours[-2], rtol=0.05)
        # the subdivision surface's gradient of H grows like a power of 1/r
        assert np.all(np.diff(theirs[3:, 1]) > 0) and theirs[-1, 1] > 1e4 * theirs[3, 1]
        # and its maxima exceed the filling's
        assert ours[:, 0].max() < theirs[:, 0].max(), (n, ours[:, 0], theirs[:, 0])
        assert ours[:, 1].max() < theirs[:, 1].max()


# --------------------------------------------------------------------------- scenes


def scene_text(file, extra=""):
    return f'[[surface]]\ntype = "hole"\nfile = "{file}"\n{extra}'


def test_hole_scene(tmp_path):
    (tmp_path / "m.obj").write_text(DRUM.read_text())
    path = tmp_path / "s.toml"
    path.write_text(scene_text("m.obj", 'continuity = "G1"\n'))
    scene = load_scene(path)
    assert scene.surfaces[0].kind == "hole" and len(scene.patches) == 120
    assert {p.degree for p in scene.patches} == {(3, 3), (5, 5)}
    assert scene.data_files == ((tmp_path / "m.obj").resolve(),)
    g2 = load_scene(path, {"surface.1.continuity": "G2"})
    assert {p.degree for p in g2.patches} == {(3, 3), (9, 9)}
    other = load_scene(path, {"surface.1.functional": "laplacian", "surface.1.domain": "sector"})
    assert other.text_hash != scene.text_hash
    assert not np.allclose(other.patches[-1].points, scene.patches[-1].points)


def test_hole_scene_optimised(tmp_path):
    """optimise: the measure lowered on every filling, the junctions still G1 (and the
    rest of the surface untouched)."""
    (tmp_path / "m.obj").write_text(DRUM.read_text())
    path = tmp_path / "s.toml"
    path.write_text(scene_text("m.obj", 'continuity = "G1"\n'))
    plain = load_scene(path).patches
    changed = {"surface.1.optimise": "mean-gradient", "surface.1.iterations": 3}
    optimised = load_scene(path, changed).patches
    assert len(optimised) == len(plain) == 120
    surface = filled_surface(*read_obj(DRUM), "G1")
    k = len(surface.outside)
    for a, b in zip(plain[:k], optimised[:k], strict=True):
        np.testing.assert_array_equal(a.points, b.points)
    for filling in surface.fillings:
        n = len(filling.patches)
        fill, k = optimised[k : k + n], k + n
        x = np.concatenate([p.points.reshape(-1, 3) for p in fill])
        assert fairing_value(x, n, 5, "mean-gradient") < fairing_value(
            filling.nets, n, 5, "mean-gradient"
        )
    report = continuity_report(optimised)
    assert {j.cls for j in report} == {"G1", "G2"}


@pytest.mark.parametrize(
    ("obj", "extra", "message"),
    [
        (
            None,
            'continuity = "G3"\n',
            r'\(hole\): continuity: expected one of "G1", "G2", got "G3"',
        ),
        (None, 'functional = "bend"\n', r'functional: expected one of "thin-plate", .*got "bend"'),
        (None, 'domain = "disc"\n', r'domain: expected one of "square", "sector", got "disc"'),
        (None, "iterations = 0\n", r"iterations: expected an integer from 1 to 100, got 0"),
        (None, 'continuity = "G1"\nfunctional = "third-order"\n', None),
        ("grid", "", r"m\.obj: expected a mesh with an interior vertex of valence other than 4"),
        ("v 0 0 0\nf 1 2 3 4\n", "", r"m\.obj, line 2: expected vertex indices from 1 to 1"),
        ("big", "", r"file: expected a mesh of at most 6250 faces .*, got 6400"),
        ("spiky", "", r"file: expected at most 1000 extraordinary vertices .*got 1681"),
    ],
)
def test_hole_scene_errors(tmp_path, obj, extra, message):
    if obj == "grid":
        obj = obj_of(*grid_mesh(4, 4, lambda i, j: (i, j, 0.0)))
    elif obj == "big":
        obj = obj_of(*grid_mesh(80, 80, lambda i, j: (i, j, 0.0)))
    elif obj == "spiky":  # a grid with every fourth face taken out: 1681 vertices in 3 faces
        V, F = grid_mesh(42, 42, lambda i, j: (i, j, 0.0))
        obj = obj_of(V, [f for k, f in enumerate(F) if k % 4 != 0])
    (tmp_path / "m.obj").write_text(obj if obj is not None else CUBE.read_text())
    path = tmp_path / "s.toml"
    path.write_text(scene_text("m.obj", extra))
    if message is None:  # a third-order functional on a G1 filling is fine
        assert len(load_scene(path).patches) == 96
        return
    with pytest.raises(GshadeError, match=message) as info:
        load_scene(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)
