"""Continuity along B-rep edges (``gshade continuity`` and ``--junctions`` on CAD scenes),
on parts the kernel builds at test time: the classes and measures against closed forms."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

pytest.importorskip("OCP")

from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder
from OCP.BRepTools import BRepTools
from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt

from gshade.analysis.continuity import Tolerances
from gshade.analysis.edge_continuity import edge_report
from gshade.analysis.junction_lines import CLASS_COLOURS
from gshade.app.cli import main
from gshade.cad import read_cad
from gshade.cad.edges import shared_edges
from gshade.rendering import render
from gshade.scene import load_scene

from ..support.cad_parts import (
    filleted_box,
    loft,
    split_bspline_face,
    split_bspline_shells,
    write_shape,
)

R = 2.0  # the fillet radius


def _write(shape, folder: Path, name: str) -> Path:
    path = folder / name
    BRepTools.Write_s(shape, str(path))
    return path


@pytest.fixture(scope="module")
def parts(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("edges")
    axis = gp_Ax2(gp_Pnt(0.0, 0.0, 0.0), gp_Dir(0.0, 0.0, 1.0))
    return {
        "box": _write(BRepPrimAPI_MakeBox(10.0, 20.0, 30.0).Shape(), folder, "box.brep"),
        "rounded": _write(filleted_box(r=R), folder, "rounded.brep"),
        "split": _write(split_bspline_face(), folder, "split.brep"),
        "loft": _write(loft(), folder, "loft.brep"),
        "cylinder": _write(
            BRepPrimAPI_MakeCylinder(axis, 3.0, 5.0).Shape(), folder, "cylinder.brep"
        ),
    }


def test_a_sharp_box_has_twelve_g0_edges_at_right_angles(parts):
    report, _ = edge_report(read_cad(parts["box"]))
    assert len(report) == 12
    assert {j.cls for j in report} == {"G0"}
    assert all(abs(j.normal_angle_deg - 90.0) < 1e-9 for j in report)
    assert all(j.gap < 1e-9 for j in report)
    # every pair of adjacent faces once: 12 distinct face pairs over 6 faces
    assert len({tuple(sorted(j.patches)) for j in report}) == 12
    assert {f for j in report for f in j.patches} == set(range(6))


def test_fillets_meet_planes_and_corners_g1_with_the_curvature_jump_one_over_r(parts):
    """Fillet cylinders (normal curvature 1/r across, 0 along) meet the planes (0) and the
    sphere corners (1/r everywhere): tangent, with a jump of 1/r in the normal curvature."""
    model = read_cad(parts["rounded"])
    kinds = [f.kind for f in model.faces]
    report, _ = edge_report(model)
    # 12 cylinders x (2 planes + 2 spheres); the spheres' poles and seams are no junctions
    assert len(report) == 48
    for j in report:
        pair = sorted(kinds[f] for f in j.patches)
        assert pair in (["cylinder", "plane"], ["cylinder", "sphere"]), pair
        assert j.cls == "G1"
        assert j.gap < 1e-9
        assert j.normal_angle_deg < 1e-6
        assert j.curvature_jump == pytest.approx(1.0 / R, rel=1e-6)


def test_one_surface_split_in_two_faces_meets_itself_smoothly(parts):
    """Both faces are the same cubic surface, C-infinity across the split (no knot there):
    the one edge between them is G3, every measure at round-off."""
    report, _ = edge_report(read_cad(parts["split"]))
    assert len(report) == 1
    (j,) = report
    assert j.cls == "G3"
    assert j.gap < 1e-9 and j.normal_angle_deg < 1e-9
    assert j.curvature_jump < 1e-9 and j.curvature_gradient_jump < 1e-7


def test_faces_each_alone_in_a_shell_are_sewn_and_their_edge_measured(tmp_path):
    """A STEP surface model may put each face in an open shell of its own: the faces share
    no edge until sewn, and the report would hold none (an Unigraphics file's 44 faces)."""
    for suffix in (".brep", ".step"):
        path = write_shape(split_bspline_shells(), tmp_path / f"shells{suffix}")
        report, _ = edge_report(read_cad(path))
        assert len(report) == 1 and report[0].cls == "G3", suffix


def test_a_loft_meets_its_caps_at_an_angle(parts):
    """The loft's side meets each planar cap along a circle: sharp, G0, at the angle between
    the side's slope and the cap (the seam of the side is no junction)."""
    model = read_cad(parts["loft"])
    report, _ = edge_report(model)
    kinds = [f.kind for f in model.faces]
    assert len(report) == 2
    for j in report:
        assert sorted(kinds[f] for f in j.patches) == ["bspline", "plane"]
        assert j.cls == "G0" and 30.0 < j.normal_angle_deg < 150.0


def test_a_seam_is_not_a_junction(parts):
    """A cylinder: its side's seam bounds one face twice; only the two rims are junctions."""
    model = read_cad(parts["cylinder"])
    edges = shared_edges(model)
    assert len(edges) == 2
    report, _ = edge_report(model)
    assert [j.cls for j in report] == ["G0", "G0"]
    assert all(abs(j.normal_angle_deg - 90.0) < 1e-9 for j in report)


def test_the_two_sides_of_an_edge_are_the_same_points(parts):
    """The pcurves sampled at the same edge parameters land on the same 3D points."""
    model = read_cad(parts["rounded"])
    for edge in shared_edges(model, samples=7):
        a = model.faces[edge.faces[0]].patch(*edge.uv[0].T)
        b = model.faces[edge.faces[1]].patch(*edge.uv[1].T)
        assert np.abs(a - b).max() < 1e-9


def test_the_g0_tolerance_is_at_least_the_edges_own(parts):
    """A tolerance below the edges' gaps makes them 'none'; the kernel's edge tolerance
    (1e-7 here) keeps a sub-tolerance gap G0 whatever the given tolerance."""
    model = read_cad(parts["box"])
    report, edges = edge_report(model, tolerances=Tolerances(g0=0.0))
    assert {j.cls for j in report} == {"G0"}
    assert all(e.tolerance > 0 for e in edges)


def test_faces_subset(parts):
    model = read_cad(parts["box"])
    report, _ = edge_report(model, [0, 1, 2])
    assert all(set(j.patches) <= {0, 1, 2} for j in report)
    assert len(report) == 2  # faces 0 and 1 are opposite; 2 touches both


def test_the_continuity_command_on_a_cad_file(parts, capsys):
    assert main(["continuity", str(parts["rounded"]), "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["junctions"]
    assert len(rows) == 48
    assert {"edge", "patches", "class", "gap", "normal_angle_deg"} <= set(rows[0])
    assert "sides" not in rows[0]
    assert len({r["edge"] for r in rows}) == 48
    assert main(["continuity", str(parts["rounded"])]) == 0
    assert capsys.readouterr().out.strip().endswith("48 junctions: 48 G1")
    assert main(["continuity", str(parts["box"]), "--pair", "0:u0,1:u1"]) == 2
    assert "--pair" in capsys.readouterr().err


def test_junction_lines_lie_on_the_edges(parts):
    """Rendered with ``--junctions`` straight at the box's x = 0 face (orthographic, 0.1
    units a pixel): the G1 lines (orange) cover exactly the pixels within a line's half width
    of the fillet-plane edges y = r, y = 20 - r, z = r, z = 30 - r (and of the fillet-sphere
    arcs, in those planes), and no others."""
    scene = parts["rounded"].parent / "front.toml"
    scene.write_text(
        '[[surface]]\ntype = "cad"\nfile = "rounded.brep"\n'
        '[shape]\nfunction = "mean"\ndisplay = "colormap"\n'
        '[render]\nwidth = 240\nheight = 320\nspp = 1\nlighting = "flat"\n'
        '[camera]\ntype = "orthographic"\norigin = [-50, 10, 15]\ntarget = [0, 10, 15]\n'
        "up = [0, 0, 1]\nwidth = 24\n"
    )
    image = render(load_scene(scene), junctions=True)
    plain = render(load_scene(scene))
    rgb = np.stack([image[c] for c in "RGB"], -1)
    changed = np.abs(rgb - np.stack([plain[c] for c in "RGB"], -1)).max(-1) > 1e-6
    orange = np.abs(rgb - np.asarray(CLASS_COLOURS["G1"])).max(-1) < 0.05
    y, z = image["P.Y"], image["P.Z"]
    pixel = 24 / 240
    # the fillet-plane edges, and the fillet-sphere arcs in the planes y = r, z = r, ...
    distance = np.min(
        [np.abs(y - R), np.abs(y - (20 - R)), np.abs(z - R), np.abs(z - (30 - R))], axis=0
    )
    # the edges seen edge-on along the outline are drawn there too: leave 2 px out
    covered = ndimage.binary_erosion(image["A"] > 0, iterations=2)
    # width 2 px: covered within 0.5 px of the edge (up to the one-sided screen derivatives
    # at the faces' borders), untouched beyond 1.5 px
    assert orange[covered & (distance < 0.45 * pixel)].all()
    assert not changed[covered & (distance > 1.6 * pixel)].any()
    assert orange.sum() > 4 * 2 * 100
