"""gshade's continuity across B-rep edges against an independent oracle, the kernel's own
local analysis (``tests/support/kernel_oracle.py``: BRepLProp_SLProps,
LocalAnalysis_SurfaceContinuity, no gshade code), on parts built with the kernel at test time
(issue 26).

For every edge the two must agree on the class, the normal angle (to 1e-6 degrees), the gap
(to 1e-9 of the model's size) and, where the faces are tangent (the oracle's class G1 or
better) and both jumps are above the G2 tolerance, the curvature jump (to 1e-6 relative);
the curvature-gradient jumps (the oracle's from finite differences) to 1e-3 relative where
both are above the G3 tolerance.  At a sharp edge the curvature jump depends on which
tangent plane the shape operators are compared in, so it is not compared there.

The oracle is first checked against closed forms on the same parts (a box's 12 edges at
90 degrees, the filleted box's 48 G1 edges with the jump 1/r, a fillet's jump 1/r between
a plane, a torus and a cylinder, one surface split in faces G3).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

pytest.importorskip("OCP")

from OCP.BRepAdaptor import BRepAdaptor_Curve, BRepAdaptor_Curve2d
from OCP.BRepAlgoAPI import BRepAlgoAPI_Fuse
from OCP.BRepBuilderAPI import (
    BRepBuilderAPI_MakeEdge,
    BRepBuilderAPI_MakeFace,
    BRepBuilderAPI_MakeWire,
    BRepBuilderAPI_Sewing,
)
from OCP.BRepFilletAPI import BRepFilletAPI_MakeFillet
from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder, BRepPrimAPI_MakePrism
from OCP.collections import Array1_gp_Pnt
from OCP.Geom import Geom_BezierCurve, Geom_ConicalSurface, Geom_ToroidalSurface
from OCP.GeomAbs import GeomAbs_CurveType
from OCP.gp import gp_Ax2, gp_Ax3, gp_Dir, gp_Pnt, gp_Vec
from OCP.TopAbs import TopAbs_EDGE
from OCP.TopExp import TopExp_Explorer
from OCP.TopoDS import TopoDS

from gshade.app.cli import main

from ..support import kernel_oracle as oracle
from ..support.cad_parts import FILLET_RADIUS, filleted_box, split_bspline_face, write_shape

#: :func:`boss`: the box's top z = 0, the boss's radius and the fillet's radius.
BOSS_RADIUS = 4.0
BOSS_FILLET = 1.5


def boss(r: float = BOSS_FILLET):
    """A cylindrical boss (radius BOSS_RADIUS) standing on a box, the circle where they meet
    filleted at r: plane - torus - cylinder, both G1 with the normal-curvature jump 1/r."""
    box = BRepPrimAPI_MakeBox(gp_Pnt(-10, -10, -5), gp_Pnt(10, 10, 0)).Shape()
    axis = gp_Ax2(gp_Pnt(0, 0, -1), gp_Dir(0, 0, 1))
    fused = BRepAlgoAPI_Fuse(box, BRepPrimAPI_MakeCylinder(axis, BOSS_RADIUS, 9.0).Shape()).Shape()
    fillet = BRepFilletAPI_MakeFillet(fused)
    explorer = TopExp_Explorer(fused, TopAbs_EDGE)
    while explorer.More():
        edge = TopoDS.Edge(explorer.Current())
        curve = BRepAdaptor_Curve(edge)
        if (
            curve.GetType() == GeomAbs_CurveType.GeomAbs_Circle
            and abs(curve.Circle().Location().Z()) < 1e-9
        ):
            fillet.Add(r, edge)
        explorer.Next()
    return fillet.Shape()


def split_cone():
    """A cone frustum (semi-angle 20 degrees, radius 3 at the base, 6 along the slant) as
    two half faces on copies of one conical surface, sewn along both straight edges: G3."""
    surface = Geom_ConicalSurface(gp_Ax3(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), math.radians(20), 3.0)
    sewing = BRepBuilderAPI_Sewing(1e-6)
    for u0, u1 in ((0.0, math.pi), (math.pi, 2 * math.pi)):
        # copies: on one shared surface the sewn edge at u = 0 = 2 pi would be its seam
        sewing.Add(BRepBuilderAPI_MakeFace(surface.Copy(), u0, u1, 0.0, 6.0, 1e-7).Face())
    sewing.Perform()
    return sewing.SewedShape()


def _bezier_edge(points):
    poles = Array1_gp_Pnt(1, len(points))
    for i, p in enumerate(points):
        poles.SetValue(i + 1, gp_Pnt(*p))
    return BRepBuilderAPI_MakeEdge(Geom_BezierCurve(poles)).Edge()


def fold(height: float = 1.0):
    """The region between y = x² and y = x²/2 for 0 <= x <= 1, extruded along z: the two
    parabolas are tangent at the origin, so their faces meet in a cusp edge (x = y = 0)
    where the outward normals are opposite: a fold, G0 at 180 degrees."""
    lower = _bezier_edge([(0, 0, 0), (0.5, 0, 0), (1, 0.5, 0)])  # y = x²/2
    upper = _bezier_edge([(0, 0, 0), (0.5, 0, 0), (1, 1, 0)])  # y = x²
    side = BRepBuilderAPI_MakeEdge(gp_Pnt(1, 0.5, 0), gp_Pnt(1, 1, 0)).Edge()
    face = BRepBuilderAPI_MakeFace(BRepBuilderAPI_MakeWire(lower, side, upper).Wire(), True).Face()
    return BRepPrimAPI_MakePrism(face, gp_Vec(0, 0, height)).Shape()


@pytest.fixture(scope="module")
def parts(tmp_path_factory):
    out = tmp_path_factory.mktemp("oracle")
    made = {
        "box": (BRepPrimAPI_MakeBox(10.0, 20.0, 30.0).Shape(), "box.step"),
        "rounded": (filleted_box(), "rounded.step"),
        "split": (split_bspline_face(), "split.brep"),
        "boss": (boss(), "boss.step"),
        "cone": (split_cone(), "cone.brep"),
        "fold": (fold(), "fold.brep"),
    }
    return {name: write_shape(shape, out / file) for name, (shape, file) in made.items()}


_cache: dict = {}


def _oracle(path):
    if path not in _cache:
        _cache[path] = oracle.analyse_file(path)
    return _cache[path]


def _gshade(path, capsys) -> dict:
    capsys.readouterr()
    assert main(["continuity", str(path), "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["junctions"]
    return {(r["edge"], tuple(sorted(r["patches"]))): r for r in rows if "knot" not in r}


def _edge(result: dict, edge: int) -> dict:
    (row,) = [r for r in result["edges"] if r["edge"] == edge]
    return row


def _agree(path, capsys) -> tuple[dict, dict]:
    """Every edge of the part: gshade's row against the oracle's (see the module)."""
    o = _oracle(path)
    g = _gshade(path, capsys)
    mine = {(r["edge"], tuple(sorted(r["faces"]))): r for r in o["edges"]}
    assert set(g) == set(mine)
    size, tol = o["diagonal"], o["tolerances"]
    wrong = []
    for key, r in mine.items():
        x = g[key]
        what = []
        if x["class"] != r["class"]:
            what.append(f"class {x['class']} (oracle {r['class']})")
        if not abs(x["normal_angle_deg"] - r["normal_angle_deg"]) <= 1e-6:
            what.append(f"angle {x['normal_angle_deg']} (oracle {r['normal_angle_deg']})")
        if not abs(x["gap"] - r["gap"]) <= 1e-9 * size:
            what.append(f"gap {x['gap']} (oracle {r['gap']})")
        tangent = oracle.CLASSES.index(r["class"]) >= oracle.CLASSES.index("G1")
        k, kg = r["curvature_jump"], x["curvature_jump"]
        if tangent and min(k, kg) > tol["g2"] and not abs(k - kg) <= 1e-6 * max(k, kg):
            what.append(f"curvature jump {kg} (oracle {k})")
        d, dg = r["curvature_gradient_jump"], x["curvature_gradient_jump"]
        if tangent and min(d, dg) > tol["g3"] and not abs(d - dg) <= 1e-3 * max(d, dg):
            what.append(f"curvature-gradient jump {dg} (oracle {d})")
        if what:
            wrong.append(f"edge {key[0]} faces {list(key[1])}: " + ", ".join(what))
    assert not wrong, "\n".join(wrong)
    return o, g


# ---------------------------------------------------------------------------------------
# the oracle against closed forms


def test_the_oracle_finds_a_boxs_twelve_right_angles(parts):
    o = _oracle(parts["box"])
    assert len(o["edges"]) == 12
    for r in o["edges"]:
        assert (r["class"], r["la_class"]) == ("G0", "G0")
        assert r["normal_angle_deg"] == pytest.approx(90.0, abs=1e-9)
        assert r["gap"] < 1e-12


def test_the_oracle_finds_the_fillets_jump_one_over_r(parts):
    o = _oracle(parts["rounded"])
    assert len(o["edges"]) == 48
    for r in o["edges"]:
        assert (r["class"], r["la_class"]) == ("G1", "G1")
        assert r["normal_angle_deg"] < 1e-9
        assert r["curvature_jump"] == pytest.approx(1.0 / FILLET_RADIUS, rel=1e-9)
        assert r["inward_dot"] == pytest.approx(-1.0)  # the faces continue each other
    o = _oracle(parts["boss"])
    tangent = [r for r in o["edges"] if r["class"] != "G0"]
    assert len(tangent) == 2  # plane - torus, torus - cylinder
    for r in tangent:
        assert r["class"] == "G1"
        assert r["curvature_jump"] == pytest.approx(1.0 / BOSS_FILLET, rel=1e-9)


def test_the_oracle_finds_one_surface_in_two_faces_g3(parts):
    for name, count in (("split", 1), ("cone", 2)):
        o = _oracle(parts[name])
        assert len(o["edges"]) == count
        for r in o["edges"]:
            assert r["class"] == "G3"
            assert r["la_class"] == "G2"  # the kernel's analysis stops at G2
            assert r["curvature_jump"] < 1e-12
            assert r["curvature_gradient_jump"] < 1e-3 * o["tolerances"]["g3"]


def test_the_oracle_finds_the_fold(parts):
    """The cusp edge: outward normals opposite, so G0 at 180 degrees for the oracle; the
    kernel's LocalAnalysis folds its angle into [0, 90] and calls it tangent."""
    o = _oracle(parts["fold"])
    (cusp,) = [
        r for r in o["edges"] if np.linalg.norm(np.array(r["midpoint"]) - [0, 0, 0.5]) < 1e-9
    ]
    assert cusp["class"] == "G0"
    assert cusp["normal_angle_deg"] == pytest.approx(180.0, abs=1e-9)
    assert cusp["la_class"] == "G1" and cusp["la_g1_angle_deg"] < 1e-9
    assert cusp["inward_dot"] == pytest.approx(1.0)  # both faces on the same side: a cusp
    # the side x = 1 meets the upper face y = x² (slope 2) at 90 + atan(2) degrees
    side = [
        r
        for r in o["edges"]
        if abs(r["normal_angle_deg"] - (90 + math.degrees(math.atan(2)))) < 1e-9
    ]
    assert len(side) == 1


def test_the_oracles_curvature_gradients_match_a_torus():
    """The finite differences (steps h and h / 2, extrapolated) against the closed form on a
    torus (R = 10, r = 2) at the parallel v = pi / 4: |grad H| = R sin v / (2 r rho^2) and
    |grad K| = R sin v / (r^2 rho^2), rho = R + r cos v, along the meridian.  With h = 0.1
    (a twentieth of r) the one-sided difference alone was 2.4e-5 off, relative (on the
    hammer's long edges its h^3 error rose over the G3 tolerance)."""
    R, r, v = 10.0, 2.0, math.pi / 4
    torus = Geom_ToroidalSurface(gp_Ax3(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), R, r)
    face = BRepBuilderAPI_MakeFace(torus, 0.0, math.pi / 2, v, v + 1.0, 1e-7).Face()
    explorer, parallel = TopExp_Explorer(face, TopAbs_EDGE), None
    while explorer.More():
        edge = TopoDS.Edge(explorer.Current())
        curve = BRepAdaptor_Curve2d(edge, face)
        ends = (curve.Value(curve.FirstParameter()), curve.Value(curve.LastParameter()))
        if all(abs(q.Y() - v) < 1e-12 for q in ends):
            parallel = edge
        explorer.Next()
    side = oracle._Side(parallel, face, np.array([0.25, 0.5, 0.75]))
    rho = R + r * math.cos(v)
    expected = (R * math.sin(v) / (2 * r * rho**2), R * math.sin(v) / (r**2 * rho**2))
    for k in range(3):
        point = side.point(k)
        gradients = side.gradients(k, 0.1, point["pu"], point["pv"])
        for found, closed in zip(gradients, expected, strict=True):
            assert np.linalg.norm(found) == pytest.approx(closed, rel=1e-6)


# ---------------------------------------------------------------------------------------
# gshade against the oracle


def test_a_box_agrees(parts, capsys):
    _agree(parts["box"], capsys)


def test_a_filleted_box_agrees(parts, capsys):
    _agree(parts["rounded"], capsys)


def test_a_fillet_between_a_plane_and_a_cylinder_agrees(parts, capsys):
    _agree(parts["boss"], capsys)


def test_a_bspline_surface_split_in_two_faces_agrees(parts, capsys):
    _agree(parts["split"], capsys)


def test_a_cone_split_in_two_faces_agrees(parts, capsys):
    _agree(parts["cone"], capsys)


def test_a_fold_agrees(parts, capsys):
    """The cusp edge (G0 at 180 degrees) and the side's edge at 153.4 degrees: gshade's
    angle between the normals must be oriented, not folded into [0, 90]."""
    _agree(parts["fold"], capsys)
