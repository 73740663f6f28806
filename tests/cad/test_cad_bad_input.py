"""Bad CAD files on the command line: exit status 2, one line on stderr naming the file and
what is wrong, no traceback, no output created or overwritten, never a crash of the bindings.

Each case runs ``python -m gshade render BAD -o new.exr --png old.png`` in a fresh process
(a crash of the native bindings would show as a signal, not as a failed test run), where
``new.exr`` does not exist and ``old.png`` does: neither may change.  The readers' own
messages for these files are checked in-process by tests/cad/test_cad_occt.py::test_bad_files
(text, truncated and wireframe files through ``read_cad``); here the cases it lacks (curves
only, vertices only, faces the kernel reports invalid) and the command line's contract.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("OCP")

from OCP.BRep import BRep_Builder
from OCP.BRepBuilderAPI import (
    BRepBuilderAPI_MakeEdge,
    BRepBuilderAPI_MakeFace,
    BRepBuilderAPI_MakePolygon,
    BRepBuilderAPI_MakeVertex,
    BRepBuilderAPI_MakeWire,
)
from OCP.BRepCheck import BRepCheck_Analyzer
from OCP.Geom import Geom_Circle, Geom_Plane
from OCP.gp import gp_Ax2, gp_Dir, gp_Pln, gp_Pnt
from OCP.TopoDS import TopoDS_Compound, TopoDS_Face

from gshade.cad import read_cad

from ..support.cad_parts import filleted_box, open_wire, write_shape


def curves_only():
    """A wire of a line and a half circle: curves, no surface."""
    circle = Geom_Circle(gp_Ax2(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), 5.0)
    arc = BRepBuilderAPI_MakeEdge(circle, gp_Pnt(5, 0, 0), gp_Pnt(-5, 0, 0)).Edge()
    line = BRepBuilderAPI_MakeEdge(gp_Pnt(-5, 0, 0), gp_Pnt(5, 0, 0)).Edge()
    return BRepBuilderAPI_MakeWire(arc, line).Wire()


def vertices_only():
    """A compound of three vertices."""
    compound, builder = TopoDS_Compound(), BRep_Builder()
    builder.MakeCompound(compound)
    for p in ((0, 0, 0), (1, 2, 3), (4, 0, 1)):
        builder.Add(compound, BRepBuilderAPI_MakeVertex(gp_Pnt(*p)).Vertex())
    return compound


def bow_tie():
    """A plane face whose wire crosses itself (a bow tie): invalid for the kernel."""
    polygon = BRepBuilderAPI_MakePolygon()
    for p in ((0, 0, 0), (10, 10, 0), (10, 0, 0), (0, 10, 0)):
        polygon.Add(gp_Pnt(*p))
    polygon.Close()
    return BRepBuilderAPI_MakeFace(gp_Pln(), polygon.Wire(), True).Face()


def off_its_surface():
    """A face on the plane z = 0 bounded (by hand, with BRep_Builder) by a square at z = 1:
    its edges do not lie on its surface, which the kernel reports invalid."""
    polygon = BRepBuilderAPI_MakePolygon()
    for p in ((0, 0, 1), (10, 0, 1), (10, 10, 1), (0, 10, 1)):
        polygon.Add(gp_Pnt(*p))
    polygon.Close()
    face, builder = TopoDS_Face(), BRep_Builder()
    builder.MakeFace(face, Geom_Plane(gp_Pln()), 1e-7)
    builder.Add(face, polygon.Wire())
    return face


def _text(path: Path) -> Path:
    path.write_text("hello, not a CAD file\n")
    return path


def _truncated(path: Path) -> Path:
    good = write_shape(filleted_box(), path.with_name("good.step")).read_bytes()
    path.write_bytes(good[: len(good) // 2])
    path.with_name("good.step").unlink()
    return path


#: name -> (how to make it in a folder, words the error line holds)
CASES = {
    "curves.igs": (lambda p: write_shape(curves_only(), p), "no surfaces"),
    "wire.step": (lambda p: write_shape(curves_only(), p), "no surfaces"),
    "points.step": (lambda p: write_shape(vertices_only(), p), "no surfaces"),
    "open.brep": (
        lambda p: write_shape(open_wire(), p),
        "no usable face (1 left out; face 0 left out: a trimming wire is not closed",
    ),
    "text.step": (_text, "not a STEP file"),
    "truncated.step": (_truncated, "truncated STEP file"),
    "stl.toml": (lambda p: _scene_of(_text(p.with_name("part.stl")), p), "expected a CAD file"),
}


def _scene_of(part: Path, path: Path) -> Path:
    """A scene whose cad surface is ``part`` (a file given directly on the command line is
    read as a scene file unless its extension is a CAD one)."""
    path.write_text(f'[[surface]]\ntype = "cad"\nfile = "{part.name}"\n')
    return path


def test_the_invalid_faces_are_invalid():
    """The hand-built faces are what the kernel calls invalid (so the cases test something)."""
    assert not BRepCheck_Analyzer(bow_tie()).IsValid()
    assert not BRepCheck_Analyzer(off_its_surface()).IsValid()
    assert not BRepCheck_Analyzer(open_wire()).IsValid()
    assert BRepCheck_Analyzer(filleted_box()).IsValid()


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_cad_file_on_the_command_line(tmp_path, name):
    """Exit 2, one line on stderr naming the file and what is wrong, no traceback, the new
    output not created, the existing one untouched, nothing else left in the folder."""
    make, words = CASES[name]
    bad = make(tmp_path / name)
    old = tmp_path / "old.png"
    old.write_bytes(b"an earlier picture")
    before = sorted(p.name for p in tmp_path.iterdir())
    outputs = ["-o", str(tmp_path / "new.exr"), "--png", str(old)]
    small = ["--width", "32", "--height", "24", "--spp", "1"]
    run = subprocess.run(
        [sys.executable, "-m", "gshade", "render", str(bad), *outputs, *small],
        capture_output=True,
        text=True,
        timeout=120,
    )
    lines = run.stderr.splitlines()
    assert run.returncode == 2, run.stderr
    assert len(lines) == 1 and "Traceback" not in run.stderr, run.stderr
    assert lines[0].startswith("gshade: error: ") and str(bad) in lines[0]
    if name == "stl.toml":
        assert "part.stl" in lines[0]
    assert words in lines[0], lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    assert old.read_bytes() == b"an earlier picture"


@pytest.mark.parametrize(
    ("make", "words"),
    [
        (bow_tie, "(it had 27: faces split"),
        (off_its_surface, "face 26: healed, valid now (was: edge 0 lies 1 off the face's surface"),
    ],
)
def test_invalid_faces_are_healed_and_said(tmp_path, make, words):
    """``read_cad`` heals an invalid face with the kernel's healing and says what it changed
    (the face's number among the model's faces, after the valid ones, and what was wrong),
    one line each; nothing is left out."""
    compound, builder = TopoDS_Compound(), BRep_Builder()
    builder.MakeCompound(compound)
    builder.Add(compound, filleted_box())  # 26 valid faces first
    builder.Add(compound, make())
    path = write_shape(compound, tmp_path / "part.brep")
    model = read_cad(path)
    assert model.left_out == []
    assert len(model.notes) == 1 and "\n" not in model.notes[0]
    assert words in model.notes[0], model.notes


def test_a_face_healing_cannot_repair_is_left_out(tmp_path):
    """A face whose wire stays open after the healing is left out, named with what is wrong
    and what was tried; the 26 faces before it are read."""
    compound, builder = TopoDS_Compound(), BRep_Builder()
    builder.MakeCompound(compound)
    builder.Add(compound, filleted_box())
    builder.Add(compound, open_wire())
    model = read_cad(write_shape(compound, tmp_path / "part.brep"))
    assert [f.index for f in model.faces] == list(range(26))
    assert [f.line() for f in model.left_out] == [
        "face 26 left out: a trimming wire is not closed "
        "(tried: the kernel's healing (ShapeFix_Shape))"
    ]


def test_a_3dm_file_without_rhino3dm_says_how_to_install_it(tmp_path):
    """Where rhino3dm is missing (a process that cannot import it), a .3dm file is refused in
    one line naming the file and the install command, exit status 2; nothing is written."""
    model, out = tmp_path / "model.3dm", tmp_path / "out.exr"
    model.write_bytes(b"")
    code = (
        "import sys; sys.modules['rhino3dm'] = None\n"
        "from gshade.app.cli import main\n"
        f"sys.exit(main(['render', {str(model)!r}, '-o', {str(out)!r}]))\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and str(model) in lines[0], lines
    assert 'pip install "gshade[cad]"' in lines[0] and "rhino3dm" in lines[0]
    assert not out.exists()
