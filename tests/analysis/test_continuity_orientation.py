"""Issue 26, point 4: faces that continue each other but whose orientations disagree are an
orientation defect, not a fold.  Both read 180 degrees between the outward normals (G0);
each CAD edge row says ``orientation``: ``consistent`` where the two faces' boundaries run
along the edge in opposite directions (any consistently oriented shell, folds included),
``inconsistent`` where they run it the same way.  The independent oracle tells the same from
its normals and the faces' directions across the edge.  Parts built with the kernel."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

pytest.importorskip("OCP")

from OCP.BRep import BRep_Builder
from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
from OCP.BRepTools import BRepTools
from OCP.TopoDS import TopoDS_Shell

from gshade.analysis.edge_continuity import edge_report
from gshade.app.cli import main
from gshade.cad import read_cad

from ..support import kernel_oracle as oracle
from ..support.cad_parts import back_to_back, split_bspline_face


def shell_of(faces, turned: set[int]):
    """A shell of the faces (sharing their edges as they are), the faces in ``turned``
    reversed."""
    shell = TopoDS_Shell()
    builder = BRep_Builder()
    builder.MakeShell(shell)
    for k, face in enumerate(faces):
        builder.Add(shell, face.Reversed() if k in turned else face)
    return shell


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("orientation")


def _both(shape, folder: Path, name: str):
    """gshade's rows and the oracle's, by edge."""
    path = folder / name
    BRepTools.Write_s(shape, str(path))
    report, _ = edge_report(read_cad(path))
    rows = oracle.analyse_shape(shape, samples=32, local_analysis=False)["edges"]
    return path, {j.edge: j for j in report}, {r["edge"]: r for r in rows}


def test_a_smooth_split_with_one_face_reversed_is_an_orientation_defect(folder):
    """One curved B-spline surface as two faces (G3 across the split); with the second face
    reversed the faces still continue each other, outward normals opposite."""
    faces = oracle.faces_of(split_bspline_face())
    _, mine, theirs = _both(shell_of(faces, set()), folder, "kept.brep")
    ((e, kept),) = mine.items()
    assert (kept.cls, kept.orientation, theirs[e]["orientation"]) == ("G3",) + 2 * ("consistent",)
    _, mine, theirs = _both(shell_of(faces, {1}), folder, "turned.brep")
    ((e, turned),) = mine.items()
    assert turned.cls == theirs[e]["class"] == "G0"
    assert turned.normal_angle_deg == pytest.approx(180.0, abs=1e-9)
    assert turned.orientation == theirs[e]["orientation"] == "inconsistent"
    assert theirs[e]["inward_dot"] == pytest.approx(-1.0, abs=1e-9)  # continuing each other
    assert turned.as_dict()["orientation"] == "inconsistent"


def test_the_json_row_says_the_orientation(folder, capsys):
    faces = oracle.faces_of(split_bspline_face())
    path = folder / "turned_json.brep"
    BRepTools.Write_s(shell_of(faces, {0}), str(path))
    assert main(["continuity", str(path), "--json"]) == 0
    rows = [r for r in json.loads(capsys.readouterr().out)["junctions"] if "edge" in r]
    assert [(r["class"], r["orientation"]) for r in rows if "knot" not in r] == [
        ("G0", "inconsistent")
    ]


def test_folds_are_consistently_oriented(folder):
    """Two squares back to back (a fold): 180 degrees too, but the faces lie on the same side
    of each edge and their orientations agree."""
    _, mine, theirs = _both(back_to_back(), folder, "fold.brep")
    assert len(mine) == 4
    for e, j in mine.items():
        assert j.cls == "G0" and j.normal_angle_deg == pytest.approx(180.0, abs=1e-9)
        assert j.orientation == theirs[e]["orientation"] == "consistent"
        assert theirs[e]["inward_dot"] == pytest.approx(1.0, abs=1e-9)


def test_a_box_with_one_face_reversed_has_four_inconsistent_edges_at_right_angles(folder):
    """At a sharp edge the angle does not show it (90 degrees either way); the orientation
    does, on the turned face's four edges only."""
    faces = oracle.faces_of(BRepPrimAPI_MakeBox(1.0, 2.0, 3.0).Shape())
    _, mine, theirs = _both(shell_of(faces, {2}), folder, "box.brep")
    assert len(mine) == 12
    turned = {e for e, j in mine.items() if j.orientation == "inconsistent"}
    assert len(turned) == 4
    assert turned == {e for e, r in theirs.items() if r["orientation"] == "inconsistent"}
    assert {j.cls for j in mine.values()} == {"G0"}
    assert all(j.normal_angle_deg == pytest.approx(90.0, abs=1e-9) for j in mine.values())
