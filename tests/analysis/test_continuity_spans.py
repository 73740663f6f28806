"""Issue 26, points 1 and 3: a face is measured by its own one-sided derivatives, from the
knot span on its side.  A face that ends on a knot of its B-spline surface, or whose pcurve
lies a tolerance beyond one, is evaluated on the polynomial piece inside it (continued the
sliver beyond), by gshade and by the independent oracle alike.

The parts are built with the kernel at test time: one B-spline surface with a C0 knot at
u = 1 (a plane folded up by ``SLOPE`` there: a kink of atan(SLOPE)), cut into two faces
along an iso-line u = ``at`` and sewn.  Cut at the knot, or a sliver past it, the faces
meet at the kink: G0 at atan(SLOPE) exactly.  Cut well past it, the faces continue the
same piece: G3 (the kink is then a knot line inside the first face).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("OCP")

from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace, BRepBuilderAPI_Sewing
from OCP.BRepTools import BRepTools
from OCP.collections import Array1_double, Array1_int, Array2_gp_Pnt
from OCP.Geom import Geom_BSplineSurface
from OCP.gp import gp_Pnt

from gshade.analysis.edge_continuity import edge_report, inside_pieces
from gshade.cad import read_cad
from gshade.geometry.patches.bspline import BSplinePatch

from ..support import kernel_oracle as oracle

#: The second piece rises by SLOPE per unit of x (the first is flat): the kink's angle.
SLOPE = 0.5
KINK_DEG = math.degrees(math.atan(SLOPE))
#: The faces' tolerance (the kernel's default for a face made from a surface).
TOLERANCE = 1e-7


def kinked_surface(slope: float = SLOPE) -> Geom_BSplineSurface:
    """z = 0 for x <= 1 and z = slope (x - 1) beyond, 0 <= x <= 2, 0 <= y <= 1: degree 3 in
    u (x = u; knots 0, 1, 2, the middle one triple: C0) and 1 in v (y = v)."""
    xs = np.linspace(0.0, 2.0, 7)
    poles = Array2_gp_Pnt(1, 7, 1, 2)
    for i, x in enumerate(xs):
        for j, y in enumerate((0.0, 1.0)):
            poles.SetValue(i + 1, j + 1, gp_Pnt(float(x), y, slope * max(float(x) - 1.0, 0.0)))
    uk, um = Array1_double(1, 3), Array1_int(1, 3)
    for k, (t, m) in enumerate(((0.0, 4), (1.0, 3), (2.0, 4))):
        uk.SetValue(k + 1, t)
        um.SetValue(k + 1, m)
    vk, vm = Array1_double(1, 2), Array1_int(1, 2)
    for k, t in enumerate((0.0, 1.0)):
        vk.SetValue(k + 1, t)
        vm.SetValue(k + 1, 2)
    return Geom_BSplineSurface(poles, uk, vk, um, vm, 3, 1, False, False)


def cut_at(at: float):
    """The kinked surface as two faces, u <= at and u >= at, sewn along u = at."""
    surface = kinked_surface()
    sewing = BRepBuilderAPI_Sewing(1e-6)
    for u0, u1 in ((0.0, at), (at, 2.0)):
        sewing.Add(BRepBuilderAPI_MakeFace(surface, u0, u1, 0.0, 1.0, TOLERANCE).Face())
    sewing.Perform()
    return sewing.SewedShape()


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("spans")


def _measured(shape, folder: Path, name: str):
    """gshade's row of the one edge where the two faces meet (the split), and the oracle's."""
    path = folder / name
    BRepTools.Write_s(shape, str(path))
    report, _ = edge_report(read_cad(path))
    rows = oracle.analyse_shape(shape, samples=32, local_analysis=False)["edges"]
    # the split: the only edge along y (its midpoint at y = 1/2)
    (mine,) = [j for j in report if abs(j.max_at["gap"]["point"][1] - 0.5) < 0.5 - 1e-9]
    (theirs,) = [r for r in rows if abs(r["midpoint"][1] - 0.5) < 0.5 - 1e-9]
    return mine, theirs


def test_faces_meeting_on_a_c0_knot_are_g0_at_the_kink(folder):
    """Cut at the knot: the first face's points (u = 1) were evaluated on the span after
    the knot, the second face's piece, so the kink read G3."""
    mine, theirs = _measured(cut_at(1.0), folder, "at.brep")
    assert mine.cls == theirs["class"] == "G0"
    assert mine.normal_angle_deg == pytest.approx(KINK_DEG, abs=1e-9)
    assert theirs["normal_angle_deg"] == pytest.approx(KINK_DEG, abs=1e-9)
    assert mine.gap < 1e-12


def test_a_pcurve_a_tolerance_past_a_c0_knot_belongs_to_the_piece_inside(folder):
    """Cut 2e-8 past the knot (2.2e-8 along the surface, within the edge's tolerance): the
    first face's sliver of the second piece is no part of it to measure; its piece is the
    one before the knot, continued the sliver.  Both programs read the kink."""
    sliver = 2e-8
    mine, theirs = _measured(cut_at(1.0 + sliver), folder, "past.brep")
    assert sliver * math.hypot(1.0, SLOPE) < theirs["edge_tolerance"]
    assert mine.cls == theirs["class"] == "G0"
    assert mine.normal_angle_deg == pytest.approx(KINK_DEG, abs=1e-9)
    assert theirs["normal_angle_deg"] == pytest.approx(KINK_DEG, abs=1e-9)
    assert theirs["inside_span_samples"][0] == 32  # the oracle asked for the span inside
    # the position is the piece's, continued: z = 0 on the first face, slope x sliver on the
    # second, so the faces lie that far apart (well within the G0 tolerance)
    assert mine.gap == pytest.approx(SLOPE * sliver, rel=1e-6)


def test_a_cut_well_past_the_knot_is_inside_one_piece_and_g3(folder):
    """Cut 0.01 past the knot (far beyond the tolerance): the first face holds a real strip
    of the second piece, and the edge lies inside that piece on both faces."""
    mine, theirs = _measured(cut_at(1.01), folder, "beyond.brep")
    assert mine.cls == theirs["class"] == "G3"
    assert mine.normal_angle_deg < 1e-9 and theirs["normal_angle_deg"] < 1e-9


def test_inside_pieces_picks_the_span_on_the_faces_side():
    """The rule alone: points on a knot (or within reach of it) move to the span beside it
    on the side ``inward`` points to; points elsewhere, or whose inward direction runs
    along the knot line, keep their own span; of edges (runs of points), only those that
    lie on the knot line all along move, not those that cross it."""
    P = np.zeros((7, 2, 3))
    P[..., 0] = np.linspace(0.0, 2.0, 7)[:, None]
    P[..., 1] = [0.0, 1.0]
    patch = BSplinePatch(P, (3, 1), ([0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 2], [0, 0, 1, 1]))
    uv = np.array([[1.0, 0.5], [1.0, 0.5], [1.0 + 1e-9, 0.5], [1.0 - 1e-9, 0.3], [0.5, 0.5]])
    inward = np.array([[-1.0, 0.0], [1.0, 0.0], [-1.0, 0.0], [1.0, 0.0], [-1.0, 0.0]])
    reach = np.full((5, 2), 1e-8)
    moved = {box: list(at) for box, at in inside_pieces(patch, uv, inward, reach)}
    # u = 1 looking back, and 1e-9 past it looking back: the first span; 1e-9 before it
    # looking ahead: the second; the point at u = 0.5 is on no knot
    assert moved == {((0.0, 1.0), (0.0, 1.0)): [0, 2], ((1.0, 2.0), (0.0, 1.0)): [3]}
    assert inside_pieces(patch, uv, np.array([[0.0, 1.0]] * 5), reach) == []
    assert inside_pieces(patch, uv[2:3], inward[2:3], np.full((1, 2), 1e-10)) == []
    # two edges of two points each: one along u = 1 (both on the knot), one crossing it
    edges = np.array([[1.0, 0.2], [1.0 - 1e-9, 0.8], [1.0 - 1e-9, 0.5], [1.5, 0.6]])
    into = np.array([[1.0, 0.0], [1.0, 0.0], [1.0, 0.2], [1.0, 0.2]])
    moved = inside_pieces(patch, edges, into, np.full((4, 2), 1e-8), run=2)
    assert [(box, list(at)) for box, at in moved] == [(((1.0, 2.0), (0.0, 1.0)), [1])]
