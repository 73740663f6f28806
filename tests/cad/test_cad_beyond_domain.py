"""A CAD face whose trims reach past its surface's domain (issue 26 point 6): the renderer
evaluates it there as the kernel, the edge sampler and the mesh do, by continuing the end
pieces, so the sliver past the domain is drawn where it is, with exact channels (it was
clamped onto the domain's edge)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("OCP")

from OCP.BRep import BRep_Builder, BRep_Tool
from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
from OCP.BRepCheck import BRepCheck_Analyzer
from OCP.BRepTools import BRepTools
from OCP.collections import Array1_double, Array1_int, Array2_gp_Pnt
from OCP.Geom import Geom_BSplineSurface
from OCP.gp import gp_Pnt
from OCP.TopAbs import TopAbs_EDGE, TopAbs_WIRE
from OCP.TopExp import TopExp_Explorer
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import TopoDS, TopoDS_Face

from gshade.io import read_exr
from gshade.rendering import render
from gshade.scene import load_scene

#: The face reaches this far (in u, and in v at the other end) past its surface's domain.
PAST = 0.05
#: The surface is the graph z = F(x, y) over [-0.1, 1] x [0, 1.1] (a biquadratic Bezier
#: patch stretched to 20 x 20); its domain [0, 1]^2 is the segment of that patch.
SIDE = 20.0


def _height(x, y):
    s, t = x / SIDE, y / SIDE
    return 4 * ((1 - s) ** 2 + s**2) + 3 * ((1 - t) ** 2 + t**2)


def _mean_curvature(x, y):
    s, t = x / SIDE, y / SIDE
    fx, fy = 8 * (2 * s - 1) / SIDE, 6 * (2 * t - 1) / SIDE
    fxx, fyy = 16 / SIDE**2, 12 / SIDE**2
    return ((1 + fy**2) * fxx + (1 + fx**2) * fyy) / (2 * (1 + fx**2 + fy**2) ** 1.5)


def _face_past_its_domain():
    """A valid face on the patch over [0, 1]^2 whose edges (3D curves and pcurves) bound
    [-PAST, 1] x [0, 1 + PAST]: built on the wider patch, then moved onto the segment."""
    poles = Array2_gp_Pnt(1, 3, 1, 3)
    for i in range(3):
        for j in range(3):
            poles.SetValue(
                i + 1, j + 1, gp_Pnt(10.0 * i, 10.0 * j, 4.0 * (i - 1) ** 2 + 3.0 * (j - 1) ** 2)
            )

    def knots(a, b):
        k = Array1_double(1, 2)
        k.SetValue(1, a)
        k.SetValue(2, b)
        return k

    mults = Array1_int(1, 2)
    mults.SetValue(1, 3)
    mults.SetValue(2, 3)
    wide = Geom_BSplineSurface(poles, knots(-0.1, 1.0), knots(0.0, 1.1), mults, mults, 2, 2)
    segment = wide.Copy()
    segment.Segment(0.0, 1.0, 0.0, 1.0)
    on_wide = BRepBuilderAPI_MakeFace(wide, -PAST, 1.0, 0.0, 1.0 + PAST, 1e-7).Face()
    builder = BRep_Builder()
    face = TopoDS_Face()
    builder.MakeFace(face, segment, TopLoc_Location(), 1e-7)
    wire = TopExp_Explorer(on_wide, TopAbs_WIRE).Current()
    edges = TopExp_Explorer(wire, TopAbs_EDGE)
    while edges.More():
        edge = TopoDS.Edge(edges.Current())
        edges.Next()
        builder.UpdateEdge(edge, BRep_Tool.CurveOnSurface_s(edge, on_wide, 0.0, 0.0), face, 1e-7)
    builder.Add(face, wire)
    assert BRepCheck_Analyzer(face).IsValid()
    return face


def test_a_face_past_its_domain_is_drawn_where_it_is(tmp_path):
    BRepTools.Write_s(_face_past_its_domain(), str(tmp_path / "face.brep"))
    scene = tmp_path / "scene.toml"
    scene.write_text(
        '[[surface]]\ntype = "cad"\nfile = "face.brep"\n'
        '[shape]\nfunction = "mean"\ndisplay = "colormap"\n'
        '[render]\nwidth = 160\nheight = 120\nspp = 4\nlighting = "flat"\n'
        "[camera]\norigin = [10, 10, 100]\ntarget = [10, 10, 0]\nup = [0, 1, 0]\nfov = 14\n"
    )
    render(load_scene(scene)).write(tmp_path / "out.exr")
    ch, _ = read_exr(tmp_path / "out.exr")
    hit = ch["patch"] >= 0
    x, y, z = (ch[k][hit].astype(float) for k in ("P.X", "P.Y", "P.Z"))
    u, v = ch["u"][hit].astype(float), ch["v"][hit].astype(float)
    # the strips past the domain (x < 20 * 0.1 / 1.1, y > 20 / 1.1) are drawn, at the
    # kernel's parameters there (clamped, they were drawn on the domain's edge, u >= 0)
    edge_x, edge_y = SIDE * 0.1 / 1.1, SIDE / 1.1
    assert np.count_nonzero(x < edge_x - 0.2) > 200
    assert np.count_nonzero(y > edge_y + 0.2) > 200
    assert u.min() < -0.5 * PAST and v.max() > 1 + 0.5 * PAST
    # every hit on the surface, with its exact mean curvature (f), past the domain too
    np.testing.assert_allclose(z, _height(x, y), rtol=0, atol=1e-5)
    np.testing.assert_allclose(np.abs(ch["f"][hit]), _mean_curvature(x, y), rtol=1e-4)
    # the parameters name the point: x and y are linear in u and v on the wide patch
    np.testing.assert_allclose(x, SIDE * (u + 0.1) / 1.1, rtol=0, atol=1e-4)
    np.testing.assert_allclose(y, SIDE * v / 1.1, rtol=0, atol=1e-4)
