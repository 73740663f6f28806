"""One bad face never costs the model (issue 25 point 1): the kernel's healing, faces left
out with a warning, ``--strict``.

The parts are built with the kernel at test time: a filleted box (26 valid faces) beside a
face the kernel's checks find invalid, one that the healing repairs (a B-spline face whose
edges have no curves on its surface) or one it cannot (a face bounded by an open wire).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("OCP")

from OCP.BRep import BRep_Builder
from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeWire
from OCP.BRepCheck import BRepCheck_Analyzer
from OCP.BRepGProp import BRepGProp
from OCP.gp import gp_Pnt
from OCP.GProp import GProp_GProps
from OCP.TopoDS import TopoDS_Compound, TopoDS_Face

from gshade.cad import read_cad
from gshade.cad.kernel import shape_faces
from gshade.cad.mesh import mesh_faces
from gshade.errors import GshadeError
from gshade.io.image import read_exr

from ..support.browser import open_page
from ..support.cad_parts import filleted_box, no_pcurves, open_wire, write_shape

SMALL = ["--width", "48", "--height", "36", "--spp", "1"]


def with_box(face) -> TopoDS_Compound:
    """A compound of the filleted box's 26 faces and ``face`` (number 26)."""
    compound, builder = TopoDS_Compound(), BRep_Builder()
    builder.MakeCompound(compound)
    builder.Add(compound, filleted_box())
    builder.Add(compound, face)
    return compound


def area(face) -> float:
    """The kernel's own area of a face (BRepGProp, its exact surface integral)."""
    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(face, props)
    return props.Mass()


def triangle_area(positions, triangles) -> float:
    p = positions[triangles]
    return 0.5 * float(np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum())


def gshade(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "gshade", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=cwd,
    )


@pytest.fixture(scope="module")
def parts(tmp_path_factory):
    """healed.brep: the box and the face without curves on its surface; open.brep: the box
    and the face bounded by an open wire."""
    folder = tmp_path_factory.mktemp("healing")
    face, _ = no_pcurves()
    assert not BRepCheck_Analyzer(face).IsValid()
    assert not BRepCheck_Analyzer(open_wire()).IsValid()
    return {
        "healed": write_shape(with_box(face), folder / "healed.brep"),
        "open": write_shape(with_box(open_wire()), folder / "open.brep"),
    }


def test_the_healing_repairs_missing_curves_and_says_so(parts):
    """The face without curves on its surface is healed: it is read (face 26), the change
    is said in one line, and its mesh covers it: the triangles' area is the kernel's exact
    area of the surface within 0.5 %."""
    model = read_cad(parts["healed"], isolated=False)
    assert model.left_out == []
    assert model.notes == [
        "face 26: healed, valid now (was: edge 0 has no curve on the face's surface)"
    ], model.notes
    assert [f.index for f in model.faces] == list(range(27))
    mesh = mesh_faces(model, 0.01, faces=[26])
    assert mesh.left_out == [] and len(mesh.triangles) > 0
    _, surface = no_pcurves()
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace

    exact = area(BRepBuilderAPI_MakeFace(surface, 1e-7).Face())  # the untrimmed surface
    assert triangle_area(mesh.positions, mesh.triangles) == pytest.approx(exact, rel=5e-3)


def test_a_face_the_healing_cannot_repair_is_left_out_and_the_rest_meshed(parts):
    """The open-wire face is left out (read_cad names it with what was wrong and what was
    tried); the 26 others are meshed as when the box is alone."""
    model = read_cad(parts["open"], isolated=False)
    assert [f.line() for f in model.left_out] == [
        "face 26 left out: a trimming wire is not closed "
        "(tried: the kernel's healing (ShapeFix_Shape))"
    ]
    mesh = mesh_faces(model, 0.05)
    assert [f.index for f in mesh.left_out] == [] and set(mesh.face) == set(range(26))
    asked = mesh_faces(model, 0.05, faces=[0, 26])  # a left-out face asked for by number
    assert [f.index for f in asked.left_out] == [26] and set(asked.face) == {0}
    alone = mesh_faces(
        read_cad(write_shape(filleted_box(), parts["open"].with_name("box.brep"))), 0.05
    )
    assert triangle_area(mesh.positions, mesh.triangles) == pytest.approx(
        triangle_area(alone.positions, alone.triangles), rel=1e-9
    )


def test_a_face_the_mesher_gives_no_triangles_is_left_out(tmp_path):
    """A plane face without a wire (the whole, infinite plane: valid to the kernel's checks)
    gets no triangles from the mesher: mesh_faces leaves it out, with why and what was
    tried, and meshes the others; automatic sewing, which loses every face of this model,
    falls back to the unsewn faces and says so."""
    from OCP.Geom import Geom_Plane
    from OCP.gp import gp_Pln

    face, builder = TopoDS_Face(), BRep_Builder()
    builder.MakeFace(face, Geom_Plane(gp_Pln()), 1e-7)
    model = read_cad(write_shape(with_box(face), tmp_path / "plane.brep"))
    assert model.notes == ["read unsewn: sewing kept 0 of the 27 faces"]
    mesh = mesh_faces(model, 0.05)
    assert [f.line() for f in mesh.left_out] == [
        "face 26 left out: the kernel's mesher gave no triangles (tried: meshing it with the "
        "kernel's mesher, with the model and alone at 0.25 to 64 times the deflection)"
    ]
    assert set(mesh.face) == set(range(26))


def test_render_draws_the_rest_and_warns_a_line_a_face(parts, tmp_path):
    """``gshade render``: exit 0, one warning line naming the file and the face, the EXR's
    header lists it (left_out_faces), the page's data shows it; the EXR is the box's."""
    exr, page = tmp_path / "open.exr", tmp_path / "open.html"
    run = gshade("render", parts["open"], "-o", exr, "--html", page, *SMALL)
    assert run.returncode == 0, run.stderr
    warnings = [line for line in run.stderr.splitlines() if "warning" in line]
    assert warnings == [
        f"gshade: warning: {parts['open']}: face 26 left out: a trimming wire is not closed "
        "(tried: the kernel's healing (ShapeFix_Shape))"
    ], run.stderr
    _, header = read_exr(exr)
    assert json.loads(header["left_out_faces"]) == [
        {
            "file": "open.brep",
            "face": 26,
            "why": "a trimming wire is not closed",
            "tried": "the kernel's healing (ShapeFix_Shape)",
        }
    ]
    assert "open.brep: face 26 left out: a trimming wire is not closed" in page.read_text()


def test_info_lists_the_left_out_face(parts):
    run = gshade("info", parts["open"])
    assert run.returncode == 0, run.stderr
    assert "model: 27 faces (1 left out)" in run.stdout
    rows = [line.split() for line in run.stdout.splitlines()]
    assert ["26", "left", "out:", "a", "trimming", "wire", "is", "not", "closed"] == rows[
        [r[:1] for r in rows].index(["26"])
    ][:9]
    assert "face 26 left out" in run.stderr


@pytest.mark.parametrize("how", ["flag", "key"])
def test_strict_makes_a_left_out_face_an_error(parts, tmp_path, how):
    """``--strict``, or the cad surface's key ``strict = true``: exit 2, one line naming the
    face, nothing written."""
    out = tmp_path / "out"
    out.mkdir()
    if how == "flag":
        scene, extra = parts["open"], ["--strict"]
    else:
        scene = tmp_path / "strict.toml"
        scene.write_text(
            f'[[surface]]\ntype = "cad"\nfile = "{parts["open"].name}"\nstrict = true\n'
        )
        (tmp_path / parts["open"].name).write_bytes(parts["open"].read_bytes())
        extra = []
    run = gshade("render", scene, "-o", out / "x.exr", "--png", out / "x.png", *extra, *SMALL)
    assert run.returncode == 2, run.stderr
    lines = run.stderr.splitlines()
    assert len(lines) == 1 and "Traceback" not in run.stderr, run.stderr
    assert "face 26 left out: a trimming wire is not closed" in lines[0]
    assert "strict" in lines[0]
    assert list(out.iterdir()) == []
    assert gshade("info", scene, *extra).returncode == 2


def test_a_model_of_left_out_faces_only_is_an_error(tmp_path):
    path = write_shape(open_wire(), tmp_path / "open.brep")
    with pytest.raises(GshadeError, match="no usable face"):
        read_cad(path)


def test_healing_a_valid_model_changes_nothing(tmp_path):
    """A valid model is read as it is: no healing, the kernel's faces in their order."""
    path = write_shape(filleted_box(), tmp_path / "box.brep")
    model = read_cad(path, isolated=False)
    assert model.notes == [] and model.left_out == []
    assert len(shape_faces(model.brep)) == 26 == len(model.faces)


def test_batch_lists_the_warnings(parts, tmp_path):
    out = tmp_path / "batch"
    run = gshade("batch", parts["open"], "-o", out)
    assert run.returncode == 0, run.stderr
    manifest = json.loads((out / "manifest.json").read_text())
    (job,) = manifest["jobs"]
    assert [w.split(": ", 1)[1] for w in job["warnings"]] == [
        "face 26 left out: a trimming wire is not closed "
        "(tried: the kernel's healing (ShapeFix_Shape))"
    ]
    assert "face 26 left out" in run.stderr
    assert Path(job["outputs"][0]).exists()


def test_the_view_page_legend_shows_the_left_out_face(browser, parts, tmp_path):
    """In a real browser (skipped without Chromium and Playwright, except under CI): the
    page of the render lists the left-out face in its legend."""
    exr, html = tmp_path / "open.exr", tmp_path / "open.html"
    assert gshade("render", parts["open"], "-o", exr, "--html", html, *SMALL).returncode == 0
    page = open_page(browser, html)
    legend = page.inner_text('[data-role="legend"]')
    assert "left out" in legend
    assert "open.brep: face 26 left out: a trimming wire is not closed" in legend
    page.close()


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("[1, 2]", "left_out_faces[0] as a JSON object"),
        ('{"face": 3}', "an array of faces"),
        ('[{"face": -1, "why": "", "tried": "", "file": ""}]', "an integer >= 0"),
        ('[{"face": true, "why": "", "tried": "", "file": ""}]', "an integer >= 0"),
        ('[{"face": 1, "why": 3, "tried": "", "file": ""}]', "as strings"),
        ("not json", "JSON text"),
    ],
)
def test_a_malformed_left_out_header_is_dropped_with_a_note(text, expected):
    """The view reads ``left_out_faces`` from an EXR it does not trust: a malformed one is
    left out with a note naming what was expected; a good one becomes lines."""
    from gshade.display.view_header import view_header

    header = view_header({"left_out_faces": text})
    assert header.left_out == []
    assert [n.attribute for n in header.notes] == ["left_out_faces"]
    assert expected in header.notes[0].expected
    good = '[{"file": "<b>x</b>.step", "face": 4, "why": "w", "tried": "t"}]'
    assert view_header({"left_out_faces": good}).left_out == [
        "<b>x</b>.step: face 4 left out: w (tried: t)"
    ]


def box_with_an_open_face():
    """A 10 x 20 x 30 box whose face 0 is rebuilt (BRepTools_ReShape) on its plane from
    three of its four edges: an open wire the healing cannot close (the gap is an edge
    long); the three edges stay shared with the neighbouring faces."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.BRepTools import BRepTools_ReShape
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS_Wire

    box = BRepPrimAPI_MakeBox(10, 20, 30).Shape()
    face = shape_faces(box)[0]
    wire, builder = TopoDS_Wire(), BRep_Builder()
    builder.MakeWire(wire)
    edges = TopExp_Explorer(face, TopAbs_EDGE)
    for _ in range(3):
        builder.Add(wire, edges.Current())
        edges.Next()
    rebuilt = TopoDS_Face()
    builder.MakeFace(rebuilt, BRep_Tool.Surface_s(face), 1e-7)
    builder.Add(rebuilt, wire)
    reshape = BRepTools_ReShape()
    reshape.Replace(face, rebuilt)
    return reshape.Apply(box)


def test_continuity_lists_the_edges_of_a_left_out_face_as_not_measured(tmp_path):
    """Of the box's 12 edges, the 3 the left-out face still shares are not measured (listed
    with the face and why), the 8 between the other faces are measured (G0: right angles),
    the 12th bounds one face only now."""
    path = write_shape(box_with_an_open_face(), tmp_path / "gap.brep")
    run = gshade("continuity", path, "--json")
    assert run.returncode == 0, run.stderr
    report = json.loads(run.stdout)
    assert [j["class"] for j in report["junctions"]] == ["G0"] * 8
    lost = report["not_measured"]
    assert sorted(e["faces"][1] for e in lost) == [0, 0, 0]
    assert len({e["edge"] for e in lost}) == 3
    assert {e["faces"][0] for e in lost} <= {1, 2, 3, 4, 5}
    assert all(e["why"].startswith("face 0 left out: a trimming wire is not closed") for e in lost)
    text = gshade("continuity", path)
    assert text.stdout.splitlines()[-1] == "8 junctions: 8 G0; 3 edges not measured"
    assert sum("not measured (face 0 left out" in line for line in text.stdout.splitlines()) == 3


def test_a_face_the_mesher_leaves_empty_is_meshed_alone_at_another_deflection(
    tmp_path, monkeypatch
):
    """A face the mesher gives no triangles with the model (made so here: its first count
    reads 0, as on the cone faces of a 750-face Fusion part at fine deflections) is meshed
    alone at twice the deflection; a note says so, and its mesh covers it (the area of the
    box's face it is, 10 x 20)."""
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox

    from gshade.cad import mesh as cad_mesh

    box = write_shape(BRepPrimAPI_MakeBox(10, 20, 30).Shape(), tmp_path / "b.brep")
    model = read_cad(box, isolated=False)  # meshed here, where the patch applies
    real, seen = cad_mesh._triangles, []

    def empty_at_first(face):
        seen.append(face)
        return 0 if len(seen) == 1 else real(face)

    monkeypatch.setattr(cad_mesh, "_triangles", empty_at_first)
    mesh = mesh_faces(model, 0.5, faces=[4])  # z = 0
    assert mesh.notes == [
        "face 4: meshed alone at 2 times the deflection (the mesher gave it no triangles at "
        "the deflection asked for)"
    ]
    assert mesh.left_out == []
    assert triangle_area(mesh.positions, mesh.triangles) == pytest.approx(200.0, rel=1e-12)


def twice_round(radius: float = 2.0, height: float = 3.0):
    """A cylinder face (valid to the kernel's checks) whose edges turn through 4 pi: its
    circles' curves on the surface run from u = -3 pi / 2 to 5 pi / 2 (as five pins of a
    1,393-face FreeCAD part do), joined by the seam twice."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.BRepLib import BRepLib
    from OCP.Geom import Geom_CylindricalSurface
    from OCP.Geom2d import Geom2d_Line
    from OCP.gp import gp_Ax3, gp_Dir, gp_Dir2d, gp_Pnt2d

    surface = Geom_CylindricalSurface(gp_Ax3(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), radius)
    a, b = -1.5 * math.pi, 2.5 * math.pi
    wire = BRepBuilderAPI_MakeWire()
    for p, q in (((a, 0), (b, 0)), ((b, 0), (b, height)), ((b, height), (a, height))):
        line = Geom2d_Line(gp_Pnt2d(*p), gp_Dir2d(q[0] - p[0], q[1] - p[1]))
        wire.Add(BRepBuilderAPI_MakeEdge(line, surface, 0.0, math.dist(p, q)).Edge())
    line = Geom2d_Line(gp_Pnt2d(a, height), gp_Dir2d(0, -1))
    wire.Add(BRepBuilderAPI_MakeEdge(line, surface, 0.0, height).Edge())
    face = BRepBuilderAPI_MakeFace(surface, wire.Wire(), True).Face()
    BRepLib.BuildCurves3d_s(face)
    return face


def test_a_face_winding_twice_round_its_surface_is_left_out_in_words(tmp_path):
    """The kernel's mesher joins such a face's nodes across its turns, through the
    cylinder: it is left out with a line that says so (not the arc's range check), and
    the box beside it is read."""
    face = twice_round()
    assert BRepCheck_Analyzer(face).IsValid()
    model = read_cad(write_shape(with_box(face), tmp_path / "twice.brep"), isolated=False)
    assert [f.line() for f in model.left_out] == [
        "face 26 left out: its trims wind 2 times round its surface in u (-4.71239 to "
        "7.85398; gshade renders a face of at most one turn) (tried: reading its surface "
        "and trims)"
    ]
    assert [f.index for f in model.faces] == list(range(26))


def test_the_patch_channel_numbers_faces_as_info_does_past_a_left_out_face(tmp_path):
    """With face 0 left out, the ``patch`` channel holds the faces' own numbers (1-26, as
    ``info``, the warnings and the edge rows number them), not their places among the
    faces rendered: at every covered pixel, the face numbered there evaluated at (u, v)
    is the pixel's P."""
    compound, builder = TopoDS_Compound(), BRep_Builder()
    builder.MakeCompound(compound)
    builder.Add(compound, open_wire())
    builder.Add(compound, filleted_box())
    path = write_shape(compound, tmp_path / "first.brep")
    exr = tmp_path / "first.exr"
    run = gshade("render", path, "-o", exr, *SMALL)
    assert run.returncode == 0, run.stderr
    assert f"{path}: face 0 left out" in run.stderr
    channels, header = read_exr(exr)
    assert header["patch_channel"] == "face"
    from gshade.scene import load_scene

    (surface,) = load_scene(path).surfaces
    swapped = dict(zip(surface.body.faces, surface.body.swapped, strict=True))
    patch = np.rint(channels["patch"]).astype(int)
    numbers = set(np.unique(patch[patch >= 0]).tolist())
    assert len(numbers) > 5 and numbers <= set(range(1, 27)), numbers
    P = np.stack([channels[f"P.{c}"] for c in "XYZ"], -1)
    for k in numbers:
        at = patch == k
        u, v = (channels[c][at].astype(float) for c in "uv")
        face = surface.body.model.face(k)  # the reader's face k, u and v as the kernel's
        exact = face.patch(*((v, u) if swapped[k] else (u, v)))
        assert np.abs(np.asarray(exact) - P[at]).max() < 1e-4, k


def test_a_hole_running_the_outer_loops_way_is_said_in_words():
    """A square face whose square hole runs the same way as its outer loop: the kernel's
    checks find the wires' orientation bad, and why_invalid says so (it said "BRepCheck
    finds it invalid", as for a 709-face Onshape part's face 539)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace, BRepBuilderAPI_MakePolygon

    from gshade.cad.healing import why_invalid

    def square(a: float, b: float):
        polygon = BRepBuilderAPI_MakePolygon()
        for x, y in ((a, a), (b, a), (b, b), (a, b)):
            polygon.Add(gp_Pnt(x, y, 0))
        polygon.Close()
        return polygon.Wire()

    maker = BRepBuilderAPI_MakeFace(square(0, 10), True)
    maker.Add(square(3, 6))
    face = maker.Face()
    assert not BRepCheck_Analyzer(face).IsValid()
    assert why_invalid(face) == "a trimming wire runs the wrong way"


def test_a_face_of_triangles_only_is_left_out_in_words(tmp_path):
    """A tessellated face (STEP AP242's COMPLEX_TRIANGULATED_FACE: triangles, no exact
    surface) beside a face with a surface: left out as a triangle mesh, not as invalid."""
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.BRepTools import BRepTools
    from OCP.Poly import Poly_Triangle, Poly_Triangulation

    from gshade.cad.healing import why_invalid

    triangles = Poly_Triangulation(3, 1, False)
    for k, (x, y) in enumerate(((0.0, 0.0), (1.0, 0.0), (0.0, 1.0)), start=1):
        triangles.SetNode(k, gp_Pnt(x + 5.0, y, 0.0))
    triangles.SetTriangle(1, Poly_Triangle(1, 2, 3))
    mesh_only = TopoDS_Face()
    builder = BRep_Builder()
    builder.MakeFace(mesh_only, triangles)
    assert why_invalid(mesh_only) == "a triangle mesh, no exact surface (a tessellated face)"
    compound = TopoDS_Compound()
    builder.MakeCompound(compound)
    builder.Add(compound, mesh_only)
    for face in shape_faces(BRepPrimAPI_MakeBox(1.0, 1.0, 1.0).Shape())[:1]:
        builder.Add(compound, face)
    path = tmp_path / "mixed.brep"
    BRepTools.Write_s(compound, str(path))
    model = read_cad(path)
    assert len(model.faces) == 1
    (lost,) = model.left_out
    assert "a triangle mesh, no exact surface" in lost.why
