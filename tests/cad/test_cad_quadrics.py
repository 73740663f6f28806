"""Planes and quadrics read without the kernel's NURBS conversion: gshade's own exact arcs
(:func:`gshade.geometry.patches.revolution.arc`) and the map from the kernel's angles to their
parameters, against the kernel's own evaluation of the same faces."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade.geometry.patches.revolution import arc, arc_parameters

pytest.importorskip("OCP")

from OCP.BRep import BRep_Tool
from OCP.BRepAdaptor import BRepAdaptor_Surface
from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
from OCP.BRepLProp import BRepLProp_SLProps
from OCP.BRepPrimAPI import (
    BRepPrimAPI_MakeCone,
    BRepPrimAPI_MakeCylinder,
    BRepPrimAPI_MakeSphere,
    BRepPrimAPI_MakeTorus,
)
from OCP.gp import gp_Ax1, gp_Ax2, gp_Dir, gp_Pnt, gp_Trsf, gp_Vec

from gshade.cad import read_cad
from gshade.cad.kernel import shape_faces
from gshade.shape import evaluate

from ..support.cad_parts import write_shape


@settings(max_examples=60, deadline=None)
@given(
    st.floats(-10.0, 10.0),
    st.floats(1e-3, 2 * np.pi),
    st.lists(st.floats(0.0, 1.0), min_size=1, max_size=20),
)
def test_the_arc_passes_through_each_angle_at_its_parameter(a0, span, fractions):
    a1 = a0 + span
    curve = arc(a0, a1)
    angle = a0 + span * np.asarray(fractions)
    s = arc_parameters(angle, a0, a1)
    assert curve.domain == (a0, a1)
    assert np.all(np.diff(s[np.argsort(angle)]) >= -1e-12)  # monotone
    expected = np.stack([np.cos(angle), np.sin(angle)], -1)
    assert np.abs(curve(s) - expected).max() < 1e-12


def test_the_arc_parameter_is_the_angle_at_the_knots():
    s = arc_parameters(np.array([0.0, np.pi / 2, np.pi, 1.5 * np.pi, 2 * np.pi]), 0.0, 2 * np.pi)
    assert np.allclose(s, [0.0, np.pi / 2, np.pi, 1.5 * np.pi, 2 * np.pi], atol=1e-15)
    assert not np.isclose(arc_parameters(np.array([0.3]), 0.0, 2 * np.pi)[0], 0.3)


def _moved(shape):
    """The shape turned and shifted: the faces carry a location the reader must apply."""
    trsf = gp_Trsf()
    trsf.SetRotation(gp_Ax1(gp_Pnt(1, 2, 3), gp_Dir(1, 1, 0.3)), 0.7)
    turned = BRepBuilderAPI_Transform(shape, trsf, False).Shape()
    trsf = gp_Trsf()
    trsf.SetTranslation(gp_Vec(5, -4, 2))
    return BRepBuilderAPI_Transform(turned, trsf, False).Shape()


def _parts():
    axis = gp_Ax2(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1))
    return {
        "cylinder": BRepPrimAPI_MakeCylinder(axis, 2.0, 5.0, 4.0).Shape(),  # 4 rad of a turn
        "cone": BRepPrimAPI_MakeCone(axis, 3.0, 1.0, 4.0).Shape(),
        "sphere": BRepPrimAPI_MakeSphere(axis, 2.5, -0.5, 1.2, 5.0).Shape(),
        "torus": BRepPrimAPI_MakeTorus(axis, 4.0, 1.0).Shape(),  # full turns both ways
    }


def _agrees_with_the_kernel(face, kernel_face, rng, samples: int) -> None:
    """At random kernel (u, v) of the face: our patch at to_patch(u, v) is the kernel's
    point, its unit normal the kernel's (the same orientation), its mean curvature the
    kernel's (BRepLProp), wherever the kernel defines them."""
    adaptor = BRepAdaptor_Surface(kernel_face)
    (u0, u1), (v0, v1) = face.box
    uv = np.stack([rng.uniform(u0, u1, samples), rng.uniform(v0, v1, samples)], -1)
    q = face.to_patch(uv)
    d = face.patch.derivatives(q[:, 0], q[:, 1], 3)
    H = evaluate("mean", d).f
    for k, (u, v) in enumerate(uv):
        props = BRepLProp_SLProps(adaptor, u, v, 2, 1e-12)
        p = props.Value()
        assert np.abs(d[0, 0, k] - [p.X(), p.Y(), p.Z()]).max() < 1e-11
        if not props.IsNormalDefined():
            continue
        n = props.Normal()
        mine = np.cross(d[1, 0, k], d[0, 1, k])
        mine /= np.linalg.norm(mine)
        assert np.abs(mine - [n.X(), n.Y(), n.Z()]).max() < 1e-9
        if props.IsCurvatureDefined():
            assert H[k] == pytest.approx(props.MeanCurvature(), rel=1e-8, abs=1e-9)


@pytest.mark.parametrize("kind", ["cylinder", "cone", "sphere", "torus"])
def test_quadric_faces_are_the_kernels_surfaces(tmp_path, kind):
    """At random kernel (u, v) of each face: our patch at to_patch(u, v) is the kernel's
    point (to 1e-11), its normal the kernel's (the same orientation), and its
    mean curvature the kernel's (BRepLProp)."""
    shape = _moved(_parts()[kind])
    model = read_cad(write_shape(shape, tmp_path / f"{kind}.brep"), isolated=False)
    assert kind in {f.kind for f in model.faces}
    rng = np.random.default_rng(0)
    for face, kernel_face in zip(model.faces, shape_faces(model.brep), strict=True):
        _agrees_with_the_kernel(face, kernel_face, rng, 25)
        if face.kind == kind:
            assert face.arcs[0] is not None


def _bspline_edge(points):
    """An edge on the cubic B-spline approximating the points."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge
    from OCP.collections import Array1_gp_Pnt
    from OCP.GeomAPI import GeomAPI_PointsToBSpline

    array = Array1_gp_Pnt(1, len(points))
    for i, p in enumerate(points, start=1):
        array.SetValue(i, gp_Pnt(*p))
    curve = GeomAPI_PointsToBSpline(array).Curve()
    return BRepBuilderAPI_MakeEdge(curve).Edge()


def _swept_parts():
    from OCP.BRepPrimAPI import BRepPrimAPI_MakePrism, BRepPrimAPI_MakeRevol
    from OCP.gp import gp_Ax1

    profile = _bspline_edge([(3, 0, 0), (4, 0, 1), (3.5, 0, 2.5), (4.5, 0, 4), (3, 0, 5)])
    wave = _bspline_edge([(0, 0, 0), (1, 0.6, 0), (2, -0.4, 0), (3, 0.8, 0), (4, 0, 0)])
    return {
        "revolution": BRepPrimAPI_MakeRevol(
            profile, gp_Ax1(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), 4.5
        ).Shape(),
        "extrusion": BRepPrimAPI_MakePrism(wave, gp_Vec(0.3, 0.2, 3.0)).Shape(),
    }


@pytest.mark.parametrize("kind", ["revolution", "extrusion"])
def test_swept_faces_are_the_kernels_surfaces(tmp_path, kind):
    """A B-spline profile turned by 4.5 rad, a B-spline wave extruded along a slanted
    direction: read without the kernel's conversion, our patches at to_patch(u, v) are the
    kernel's points, normals and mean curvatures."""
    path = write_shape(_moved(_swept_parts()[kind]), tmp_path / f"{kind}.brep")
    model = read_cad(path, isolated=False)  # the kernel's shape here
    swept = [
        (face, kernel)
        for face, kernel in zip(model.faces, shape_faces(model.brep), strict=True)
        if face.kind == kind
    ]
    assert len(swept) == 1
    rng = np.random.default_rng(1)
    for face, kernel_face in swept:
        # the kept shape is the file's: this face was built by gshade, not converted
        assert type(BRep_Tool.Surface_s(kernel_face)).__name__ in (
            "Geom_SurfaceOfRevolution",
            "Geom_SurfaceOfLinearExtrusion",
        )
        _agrees_with_the_kernel(face, kernel_face, rng, 30)
        assert (face.arcs[0] is not None) == (kind == "revolution")


def test_a_full_turn_written_a_sliver_too_long_is_read(tmp_path):
    """A cylinder face whose angle runs from -pi to pi + 6.7e-11, as Fusion 360 writes
    them: read (not refused), its patch the kernel's surface at the kernel's parameters."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.Geom import Geom_CylindricalSurface
    from OCP.gp import gp_Ax3

    u0, u1 = -3.1415926535900573, 3.141592653656146
    surface = Geom_CylindricalSurface(gp_Ax3(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), 2.0)
    face = BRepBuilderAPI_MakeFace(surface, u0, u1, 0.0, 5.0, 1e-7).Face()
    model = read_cad(write_shape(face, tmp_path / "overturn.brep"), isolated=False)
    (cad,) = model.faces
    assert cad.kind == "cylinder"
    rng = np.random.default_rng(1)
    _agrees_with_the_kernel(cad, shape_faces(model.brep)[0], rng, 25)
    with pytest.raises(Exception, match="expected a0 < a1"):
        arc(-np.pi, np.pi + 0.1)  # more than a tolerance: still refused


@pytest.mark.parametrize(
    ("a0", "a1"),
    # as Fusion 360 and NX 10 write them
    [(-np.pi, np.pi + 6.7e-11), (-np.pi - 5.1e-5, np.pi + 6e-6), (0.0, 2 * np.pi + 0.006)],
)
def test_a_full_turn_overshooting_by_a_tolerance_is_an_exact_arc(a0, a1):
    """A periodic face's box may pass a full turn by the file's tolerance: the arc is built
    (on the unit circle, the parameter the angle at its knots) and covers its start twice
    over that sliver; a turn and a quarter is refused."""
    from gshade.errors import GshadeError

    curve = arc(a0, a1)
    t = np.linspace(a0, a1, 101)
    points = np.asarray(curve(t))
    assert np.abs(np.linalg.norm(points, axis=-1) - 1) == pytest.approx(0, abs=1e-12)
    knots = np.unique(curve.knots)
    assert np.allclose(np.asarray(curve(knots)), np.stack([np.cos(knots), np.sin(knots)], -1))
    with pytest.raises(GshadeError, match="a0 < a1 <= a0 \\+ 2 pi"):
        arc(-np.pi, np.pi + 0.5 * np.pi)
