"""Issue 26, continuity you can sign: oriented normal angles (a fold is G0), each face's own
scale for poles, round-off above evaluation noise, the exact curvature jump, and where
each measure is largest.  The parts are built with the kernel (OCP) at test time; the
oracles are closed forms and the kernel's own ``BRepLProp_SLProps``."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("OCP")

from OCP.BRep import BRep_Builder
from OCP.BRepBuilderAPI import (
    BRepBuilderAPI_MakeEdge,
    BRepBuilderAPI_MakeFace,
    BRepBuilderAPI_MakePolygon,
    BRepBuilderAPI_MakeWire,
    BRepBuilderAPI_Sewing,
    BRepBuilderAPI_Transform,
)
from OCP.BRepPrimAPI import BRepPrimAPI_MakePrism
from OCP.BRepTools import BRepTools
from OCP.collections import Array1_double, Array1_gp_Pnt, Array1_int, Array2_gp_Pnt
from OCP.Geom import (
    Geom_BezierCurve,
    Geom_BSplineSurface,
    Geom_ConicalSurface,
    Geom_CylindricalSurface,
)
from OCP.gp import gp_Ax3, gp_Dir, gp_Pnt, gp_Trsf, gp_Vec
from OCP.TopoDS import TopoDS_Compound

from gshade.analysis.continuity import Tolerances, continuity_report
from gshade.analysis.edge_continuity import edge_report
from gshade.cad import read_cad
from gshade.geometry.core.differential import normal_curvature, unit_normal
from gshade.geometry.patches.bezier import BezierPatch

from ..support.cad_parts import back_to_back, filleted_box


def _write(shape, folder: Path, name: str):
    path = folder / name
    BRepTools.Write_s(shape, str(path))
    return read_cad(path)


def _bezier_edge(points):
    poles = Array1_gp_Pnt(1, len(points))
    for k, p in enumerate(points, 1):
        poles.SetValue(k, gp_Pnt(*p))
    return BRepBuilderAPI_MakeEdge(Geom_BezierCurve(poles)).Edge()


def fold(height: float = 1.0):
    """The region between y = x^2 and y = x^2 / 2, 0 <= x <= 1 (tangent at the origin),
    extruded along z: the two parabolic faces meet along the z axis with outward normals
    +y and -y, a cusp."""
    upper = _bezier_edge([(0, 0, 0), (0.5, 0, 0), (1, 1, 0)])  # y = x^2
    right = BRepBuilderAPI_MakeEdge(gp_Pnt(1, 1, 0), gp_Pnt(1, 0.5, 0)).Edge()
    lower = _bezier_edge([(1, 0.5, 0), (0.5, 0, 0), (0, 0, 0)])  # y = x^2 / 2
    face = BRepBuilderAPI_MakeFace(BRepBuilderAPI_MakeWire(upper, right, lower).Wire()).Face()
    return BRepPrimAPI_MakePrism(face, gp_Vec(0, 0, height)).Shape()


def _moved(shape, scale: float, offset=(0.0, 0.0, 0.0)):
    t = gp_Trsf()
    t.SetScale(gp_Pnt(0, 0, 0), scale)
    shape = BRepBuilderAPI_Transform(shape, t, True).Shape()
    t = gp_Trsf()
    t.SetTranslation(gp_Vec(*offset))
    return BRepBuilderAPI_Transform(shape, t, True).Shape()


def _compound(*shapes):
    out = TopoDS_Compound()
    builder = BRep_Builder()
    builder.MakeCompound(out)
    for shape in shapes:
        builder.Add(out, shape)
    return out


def split_cone(centre, pieces: int = 3, radius: float = 5.0, length: float = 10.0):
    """One cone (semi-angle 30 degrees) as 3 x 2 faces of the same Geom surface, sewn."""
    axis = gp_Ax3(gp_Pnt(*centre), gp_Dir(0, 0, 1), gp_Dir(1, 0, 0))
    cone = Geom_ConicalSurface(axis, math.radians(30.0), radius)
    sewing = BRepBuilderAPI_Sewing(1e-6)
    for k in range(pieces):
        u0, u1 = 2 * math.pi * k / pieces, 2 * math.pi * (k + 1) / pieces
        for v0, v1 in ((0.0, length / 2), (length / 2, length)):
            sewing.Add(BRepBuilderAPI_MakeFace(cone, u0, u1, v0, v1, 1e-7).Face())
    sewing.Perform()
    return sewing.SewedShape()


R = 2.0  # the cylinder's radius
PHI = math.radians(35.0)  # the touching line's direction in the plane


def plane_and_cylinder(length: float = 4.0, width: float = 3.0):
    """The plane z = 0 (a parallelogram, oblique to its own parameters) and a quarter of the
    cylinder of radius R tangent to it along the line through the origin in direction
    d = (cos PHI, sin PHI, 0), going up on the side m = z x d."""
    d = np.array([math.cos(PHI), math.sin(PHI), 0.0])
    m = np.array([-math.sin(PHI), math.cos(PHI), 0.0])
    a, b = -length * d, length * d
    polygon = BRepBuilderAPI_MakePolygon()
    for p in (a, b, b - width * m, a - width * m):
        polygon.Add(gp_Pnt(*p))
    polygon.Close()
    plane = BRepBuilderAPI_MakeFace(polygon.Wire(), True).Face()
    cylinder = Geom_CylindricalSurface(gp_Ax3(gp_Pnt(0, 0, R), gp_Dir(*d), gp_Dir(0, 0, -1)), R)
    up = np.cross(d, [0.0, 0.0, -1.0]) @ m > 0  # the frame's y direction toward m
    u0, u1 = (0.0, math.pi / 2) if up else (-math.pi / 2, 0.0)
    sewing = BRepBuilderAPI_Sewing(1e-6)
    sewing.Add(plane)
    sewing.Add(BRepBuilderAPI_MakeFace(cylinder, u0, u1, -length, length, 1e-7).Face())
    sewing.Perform()
    return sewing.SewedShape(), d, m


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("signed")


# ------------------------------------------------------------------ 1: folds are G0


def test_a_cusp_between_two_parabolas_is_g0_at_180_degrees(folder):
    model = _write(fold(), folder, "fold.brep")
    report, _ = edge_report(model)
    # the edge along z at x = 0 (its points on the z axis) joins the two parabolic faces
    (cusp,) = [j for j in report if np.allclose(j.max_at["gap"]["point"][:2], 0.0, atol=1e-9)]
    assert {model.faces[f].kind for f in cusp.patches} == {"extrusion"}
    assert cusp.cls == "G0"
    assert cusp.normal_angle_deg == pytest.approx(180.0, abs=1e-9)
    assert cusp.gap < 1e-12


def test_two_coincident_planar_faces_back_to_back_are_g0(folder):
    report, _ = edge_report(_write(back_to_back(), folder, "b2b.brep"))
    assert len(report) == 4
    assert {j.cls for j in report} == {"G0"}
    assert all(j.normal_angle_deg == pytest.approx(180.0, abs=1e-9) for j in report)


def test_patches_folded_back_are_g0_and_reparametrised_ones_keep_their_class():
    """Scene patches: j oriented like i across the junction (its boundary loop run the other
    way): the plane continued is G3 in any parametrisation of j, folded back it is G0."""
    grid = np.stack(np.meshgrid([0.0, 1.0], [0.0, 1.0], indexing="ij"), axis=-1)
    flat = np.concatenate([grid, np.zeros((2, 2, 1))], axis=-1)
    a = BezierPatch(flat)  # x, y in [0, 1]
    on = BezierPatch(flat + np.array([1.0, 0.0, 0.0]))  # x in [1, 2]: the plane continued
    back = BezierPatch(
        flat * np.array([-0.5, 1.0, 1.0]) + np.array([1.0, 0.0, 0.0])
    )  # x from 1 to 0.5: folded
    for b, expected, angle in (
        (on, "G3", 0.0),
        (BezierPatch(on.points[::-1]), "G3", 0.0),  # u reversed: its normal turned
        (BezierPatch(on.points[:, ::-1]), "G3", 0.0),
        (BezierPatch(on.points[::-1, ::-1]), "G3", 0.0),
        (back, "G0", 180.0),
        (BezierPatch(back.points[:, ::-1]), "G0", 180.0),
    ):
        (j,) = continuity_report([a, b])
        assert (j.cls, j.normal_angle_deg) == (expected, pytest.approx(angle, abs=1e-9))


# ------------------------------------------------------------------ 2: each face's own scale


def test_a_tiny_filleted_block_beside_a_huge_one_is_measured_as_alone(folder):
    """Fillets of radius 2e-3 (p_u of length r on a cylinder) beside fillets of 2e3: with
    the batch's scale the tiny ones' points were taken for poles (|p_u x p_v| below 1e-8
    x the huge faces' speed squared) and their normals for limits."""
    from ..support.kernel_oracle import analyse_shape

    tiny = _moved(filleted_box(), 1e-3)
    alone = edge_report(_write(tiny, folder, "tiny.brep"))[0]
    shape = _compound(tiny, _moved(filleted_box(), 1e3, (1e5, 0, 0)))
    size = float(np.linalg.norm(np.subtract(*read_cad(folder / "tiny.brep").bounds)))
    both = edge_report(_write(shape, folder, "both.brep"), tolerances=Tolerances.for_size(size))[0]
    assert len(alone) == 48 and len(both) == 96
    kernel = {
        row["edge"]: row for row in analyse_shape(shape, samples=32, local_analysis=False)["edges"]
    }
    for a, b in zip(alone, both[:48], strict=True):
        assert (a.edge, a.patches, a.cls) == (b.edge, b.patches, b.cls) == (a.edge, a.patches, "G1")
        for key in ("gap", "normal_angle_deg", "curvature_jump", "curvature_gradient_jump"):
            assert getattr(b, key) == getattr(a, key), key  # each face evaluated alike
        assert b.normal_angle_deg == pytest.approx(kernel[b.edge]["normal_angle_deg"], abs=1e-8)
        assert b.curvature_jump == pytest.approx(1 / 2e-3, rel=1e-6)


def test_the_pole_test_ignores_the_parametrisation_speed():
    """The same plane parametrised at speeds 1e-6 and 1e6 in u: its points are regular."""
    from gshade.analysis.junction_measures import side_derivatives

    grid = np.stack(np.meshgrid([0.0, 1.0], [0.0, 1.0], indexing="ij"), axis=-1)
    for speed in (1e-6, 1.0, 1e6):
        pts = np.concatenate([grid * [speed, 1.0], np.zeros((2, 2, 1))], axis=-1)
        d, _, _ = side_derivatives(BezierPatch(pts), np.array([0.0, 0.5]), np.array([0.5, 0.0]))
        n = unit_normal(d).n
        assert np.allclose(n, [0.0, 0.0, 1.0])
        assert np.linalg.norm(np.cross(d[1, 0], d[0, 1]), axis=-1).min() > 0.2


# ------------------------------------------------------------------ 3: G3 not lost to noise


def test_a_cone_split_into_faces_is_g3_on_every_split_edge_far_from_the_origin(folder):
    """Six faces of one Geom cone at (1000, 2000, 500): every split is exactly C-infinity.
    With no G3 tolerance of its own (0) the class rests on the round-off estimate alone."""
    model = _write(split_cone((1000.0, 2000.0, 500.0)), folder, "cone.brep")
    tol = Tolerances(g0=1e-6, g1=0.0, g2=0.0, g3=0.0)
    report, _ = edge_report(model, tolerances=tol)
    assert len(report) == 7  # 3 vertical splits x 2 rows, one circle split in 3... per pair
    assert {j.cls for j in report} == {"G3"}
    for j in report:
        assert j.curvature_gradient_jump > 0.0  # the noise is there, and below its estimate
        assert j.curvature_gradient_jump <= j.round_off["curvature_gradient_jump"]


def test_the_round_off_of_a_part_far_from_the_origin_is_as_near_it(folder):
    """Each face is evaluated about its own centre: the same cone split at the origin and
    1e5 away has the same round-off floors, not 1e4 times larger ones (before, its
    derivatives' round-off went with |P|, the control points' distance from the origin)."""
    tol = Tolerances(g0=1e-6, g1=0.0, g2=0.0, g3=0.0)
    near = edge_report(_write(split_cone((0.0, 0.0, 0.0)), folder, "near.brep"), tolerances=tol)[0]
    far = edge_report(_write(split_cone((1e5, 0.0, 0.0)), folder, "far.brep"), tolerances=tol)[0]
    assert {j.cls for j in near + far} == {"G3"}
    for key in ("normal_angle_deg", "curvature_jump", "curvature_gradient_jump"):
        a = max(j.round_off[key] for j in near)
        b = max(j.round_off[key] for j in far)
        assert b < 2 * a, key
        assert all(getattr(j, key) <= j.round_off[key] for j in far)  # still above the noise


#: :func:`plane_and_parabola`: the second face z = C (x - 1)^2, so the normal curvature
#: jumps by 2 C across x = 1, and the part's offset from the origin.
PARABOLA_C = 5e-10
FAR = (1e5, 1e5, 0.0)


def plane_and_parabola(offset=FAR):
    """The unit square z = 0 (x in [0, 1]) and the parabolic strip z = C (x - 1)^2 (x in
    [1, 2]), each its own B-spline surface (degrees (1, 1) and (2, 1)), sewn along x = 1:
    G1 with the curvature jump 2 C, both moved by ``offset``."""
    ox, oy, oz = offset
    sewing = BRepBuilderAPI_Sewing(1e-6)
    for xs, zs in (((0.0, 1.0), (0.0, 0.0)), ((1.0, 1.5, 2.0), (0.0, 0.0, PARABOLA_C))):
        n = len(xs)
        poles = Array2_gp_Pnt(1, n, 1, 2)
        for i, (x, z) in enumerate(zip(xs, zs, strict=True)):
            for j, y in enumerate((0.0, 1.0)):
                poles.SetValue(i + 1, j + 1, gp_Pnt(ox + x, oy + y, oz + z))
        ends, mults = Array1_double(1, 2), Array1_int(1, 2)
        ends.SetValue(1, 0.0)
        ends.SetValue(2, 1.0)
        mults.SetValue(1, n)
        mults.SetValue(2, n)
        twos = Array1_int(1, 2)
        twos.SetValue(1, 2)
        twos.SetValue(2, 2)
        surface = Geom_BSplineSurface(poles, ends, ends, mults, twos, n - 1, 1, False, False)
        sewing.Add(BRepBuilderAPI_MakeFace(surface, 0.0, 1.0, 0.0, 1.0, 1e-7).Face())
    sewing.Perform()
    return sewing.SewedShape()


def test_a_small_curvature_jump_far_from_the_origin_is_not_lifted_by_the_round_off(folder):
    """A G1 junction 1.4e5 from the origin whose curvature jumps by 1e-9, with the G2
    tolerance 1e-10: G1.  Evaluated about the origin, the parabola's second derivative had
    a round-off estimate of ~1e-8 (8 eps (p + q + 2) sum |B''| |P| with |P| = 1.4e5), which
    lifted the tolerance over the jump: G2 (issue 26: the hammer's edge 102)."""
    model = _write(plane_and_parabola(), folder, "parabola.brep")
    tol = Tolerances(g0=1e-6, g1=1e-3, g2=1e-10, g3=1e-3)
    (j,) = edge_report(model, tolerances=tol)[0]
    assert j.cls == "G1"
    assert j.curvature_jump == pytest.approx(2 * PARABOLA_C, rel=1e-4)
    assert j.round_off["curvature_jump"] < 1e-3 * j.curvature_jump


def test_the_round_off_does_not_hide_a_real_curvature_jump(folder):
    report, _ = edge_report(_write(filleted_box(r=2.0), folder, "box.brep"))
    assert {j.cls for j in report} == {"G1"}
    assert max(j.round_off["curvature_jump"] for j in report) < 1e-6


# ------------------------------------------------------------------ 5: the exact jump


def test_a_cylinder_tangent_to_a_plane_along_an_oblique_line_jumps_by_one_over_r(folder):
    shape, d, m = plane_and_cylinder()
    (j,) = edge_report(_write(shape, folder, "plcyl.brep"))[0]
    assert j.cls == "G1"
    assert j.curvature_jump == pytest.approx(1.0 / R, rel=1e-12)
    across = np.array(j.max_at["curvature_jump"]["direction"])
    assert abs(across @ m) == pytest.approx(1.0, abs=1e-9)  # across the cylinder
    # the point: on the touching line, at the fraction t along the edge
    p = np.array(j.max_at["curvature_jump"]["point"])
    assert np.linalg.norm(p - (p @ d) * d) < 1e-9


def _saddle_pair(b: float, c: float):
    """Patch i: the plane z = 0 over [-1, 1] x [-1, 0]; patch j: z = c y^2 / 2 + b x y over
    [-1, 1] x [0, 1] (Bezier of degree (1, 2)): they touch at the origin, where the shape
    operators differ by D = [[0, b], [b, c]] in the frame (x, y)."""
    x = np.array([-1.0, 1.0])
    plane = np.zeros((2, 2, 3))
    plane[..., 0] = x[:, None]
    plane[..., 1] = np.array([-1.0, 0.0])[None, :]
    j = np.zeros((2, 3, 3))
    j[..., 0] = x[:, None]
    j[..., 1] = np.array([0.0, 0.5, 1.0])[None, :]
    j[..., 2] = 0.5 * c * np.array([0.0, 0.0, 1.0])[None, :] + b * x[:, None] * np.array(
        [0.0, 0.5, 1.0]
    )
    return BezierPatch(plane), BezierPatch(j)


def test_the_curvature_jump_is_exact_where_the_old_eight_directions_read_low():
    """D = [[0, b], [b, c]] with its eigenvector 11.25 degrees off the nearest of the old
    directions k x 22.5 degrees: max |eigenvalue| = c / 2 + sqrt(c^2 / 4 + b^2)."""
    b, c = -0.5 * math.tan(math.radians(22.5)), 1.0
    exact = 0.5 * c + math.hypot(0.5 * c, b)
    i, j = _saddle_pair(b, c)
    (got,) = continuity_report([i, j], samples=1, pairs=[(0, "v1", 1, "v0")])
    assert got.normal_angle_deg < 1e-12 and got.gap == 0.0  # one sample, at x = 0
    assert got.curvature_jump == pytest.approx(exact, rel=1e-13)
    # the old measure: the largest of 8 directions 22.5 degrees apart, 4 % low here
    di, dj = (p.derivatives(np.array([0.5]), np.array([v]), 2) for p, v in ((i, 1.0), (j, 0.0)))
    ni, nj = unit_normal(di).n, unit_normal(dj).n
    old = max(
        abs(normal_curvature(di, ni, e)[0] - normal_curvature(dj, nj, e)[0])
        for e in (
            np.array([[math.cos(t), math.sin(t), 0.0]])
            for t in np.linspace(0, math.pi, 8, endpoint=False)
        )
    )
    assert old == pytest.approx(1.0, rel=1e-12) and old < exact / 1.04


# ------------------------------------------------------------------ 7: where


def test_where_each_measure_is_largest_is_the_closed_forms_place():
    """Patch j = (x, y, b x y + 4 g x (1 - x) (1 - y)) over [0, 1]^2 beside the plane: along
    y = 0 the gap is 4 g x (1 - x) (largest at x = 1/2) and the normals' angle grows with
    x to the last sample; samples at t = (k + 1/2) / 33."""
    g, b, n = 1e-3, 0.3, 33
    x = np.array([0.0, 1.0])
    plane = np.zeros((2, 2, 3))
    plane[..., 0] = x[:, None]
    plane[..., 1] = np.array([-1.0, 0.0])[None, :]
    # degree (2, 1): x(1 - x) has Bernstein coefficients (0, 1/2, 0), x: (0, 1/2, 1)
    j = np.zeros((3, 2, 3))
    j[..., 0] = np.array([0.0, 0.5, 1.0])[:, None]
    j[..., 1] = np.array([0.0, 1.0])[None, :]
    j[..., 2] = b * np.array([0.0, 0.5, 1.0])[:, None] * np.array([0.0, 1.0])[None, :]
    j[..., 2] += 4 * g * np.array([0.0, 0.5, 0.0])[:, None] * np.array([1.0, 0.0])[None, :]
    (got,) = continuity_report(
        [BezierPatch(plane), BezierPatch(j)],
        samples=n,
        pairs=[(0, "v1", 1, "v0")],
        tolerances=Tolerances(g0=1e-2),
    )
    assert got.gap == pytest.approx(g, rel=1e-12)
    assert got.max_at["gap"]["t"] == 0.5
    assert got.max_at["gap"]["point"] == pytest.approx([0.5, 0.0, 0.0], abs=1e-15)
    assert got.max_at["gap"]["uv"] == pytest.approx([0.5, 1.0])  # patch i: its side v1
    last = (n - 0.5) / n
    assert got.max_at["normal_angle_deg"]["t"] == pytest.approx(last)
    assert got.max_at["normal_angle_deg"]["point"] == pytest.approx([last, 0.0, 0.0])
    # the angle there: j's normal at (x, 0) ~ (-z_x, -z_y, 1)
    zx, zy = 4 * g * (1 - 2 * last), b * last - 4 * g * last * (1 - last)
    assert got.normal_angle_deg == pytest.approx(
        math.degrees(math.atan(math.hypot(zx, zy))), rel=1e-12
    )


def test_the_json_row_has_round_off_and_max_at(folder):
    shape, _, _ = plane_and_cylinder()
    (j,) = edge_report(_write(shape, folder, "plcyl2.brep"))[0]
    row = j.as_dict()
    for key in ("gap", "normal_angle_deg", "curvature_jump", "curvature_gradient_jump"):
        assert set(row["max_at"][key]) >= {"t", "point", "uv"} and key in row["round_off"]
        assert 0.0 < row["max_at"][key]["t"] < 1.0
