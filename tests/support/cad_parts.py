"""Parts built with the CAD kernel at test time, shared by the CAD tests (never outside files)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

pytest.importorskip("OCP")

from OCP.BRep import BRep_Builder
from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
from OCP.BRepBuilderAPI import (
    BRepBuilderAPI_MakeEdge,
    BRepBuilderAPI_MakeFace,
    BRepBuilderAPI_MakePolygon,
    BRepBuilderAPI_MakeWire,
    BRepBuilderAPI_Sewing,
)
from OCP.BRepFilletAPI import BRepFilletAPI_MakeFillet
from OCP.BRepOffsetAPI import BRepOffsetAPI_ThruSections
from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder, BRepPrimAPI_MakeSphere
from OCP.BRepTools import BRepTools
from OCP.collections import Array1_double, Array1_int, Array2_gp_Pnt, HArray1_gp_Pnt
from OCP.Geom import Geom_BSplineSurface, Geom_Circle, Geom_Plane
from OCP.GeomAPI import GeomAPI_Interpolate, GeomAPI_PointsToBSplineSurface
from OCP.gp import gp_Ax2, gp_Ax3, gp_Dir, gp_Pln, gp_Pnt
from OCP.TopAbs import TopAbs_EDGE
from OCP.TopExp import TopExp_Explorer
from OCP.TopoDS import TopoDS, TopoDS_Compound, TopoDS_Face

#: The box's sides and the fillet radius of :func:`filleted_box`.
BOX_SIZE = (10.0, 20.0, 30.0)
FILLET_RADIUS = 2.0

#: :func:`sphere_cap`: the sphere's radius (centre at the origin) and the cutting plane z = h.
SPHERE_RADIUS = 5.0
CAP_PLANE = 1.0

#: :func:`holed_bspline_face`: the sheet spans [0, SHEET] x [0, SHEET] in (x, y); the hole is
#: the vertical cylinder of radius HOLE_RADIUS around HOLE_CENTRE (x, y).
SHEET = 20.0
HOLE_CENTRE = (10.0, 10.0)
HOLE_RADIUS = 4.0

#: :func:`loft`: its sections' heights z.
LOFT_HEIGHTS = (0.0, 6.0, 12.0)

#: :func:`split_bspline_face`: the parameter u where the surface is split into two faces.
SPLIT_AT = 0.5


def filleted_box(size=BOX_SIZE, r: float = FILLET_RADIUS):
    """A box with all 12 edges filleted at r: 6 planes, 12 exact cylinders, 8 sphere corners."""
    box = BRepPrimAPI_MakeBox(*size).Shape()
    fillet = BRepFilletAPI_MakeFillet(box)
    explorer = TopExp_Explorer(box, TopAbs_EDGE)
    while explorer.More():
        fillet.Add(r, TopoDS.Edge(explorer.Current()))
        explorer.Next()
    return fillet.Shape()


#: :func:`tapered_block`: the drafts (degrees, pull +z) of its sides facing +x, -x, +y, -y
#: (negative: an undercut), its half-width at z = 0 and its height
BLOCK_DRAFTS = (3.0, 1.0, 0.0, -2.0)
BLOCK_HALF, BLOCK_HEIGHT = 10.0, 8.0


def tapered_block(drafts=BLOCK_DRAFTS, half: float = BLOCK_HALF, height: float = BLOCK_HEIGHT):
    """A solid ruled between the square |x|, |y| <= half at z = 0 and its top at z = height,
    whose sides facing +x, -x, +y, -y lean in by their draft (a side leaning in by d faces
    up by d: its draft about +z is exactly d; a negative one leans out: an undercut)."""
    inset = [height * math.tan(math.radians(d)) for d in drafts]
    px, nx, py, ny = half - inset[0], -half + inset[1], half - inset[2], -half + inset[3]
    bottom = [(-half, -half), (half, -half), (half, half), (-half, half)]
    top = [(nx, ny), (px, ny), (px, py), (nx, py)]
    sections = BRepOffsetAPI_ThruSections(True, True)
    for z, corners in ((0.0, bottom), (height, top)):
        polygon = BRepBuilderAPI_MakePolygon()
        for x, y in corners:
            polygon.Add(gp_Pnt(x, y, z))
        polygon.Close()
        sections.AddWire(polygon.Wire())
    sections.Build()
    return sections.Shape()


def sphere_cap(radius: float = SPHERE_RADIUS, h: float = CAP_PLANE):
    """The part z >= h of the sphere of ``radius`` around the origin (a solid): one sphere face
    trimmed by the circle z = h, rho = sqrt(radius² - h²), and the flat disc closing it."""
    sphere = BRepPrimAPI_MakeSphere(radius).Shape()
    below = BRepPrimAPI_MakeBox(
        gp_Pnt(-2 * radius, -2 * radius, -2 * radius), gp_Pnt(2 * radius, 2 * radius, h)
    ).Shape()
    return BRepAlgoAPI_Cut(sphere, below).Shape()


def _bspline_surface(heights, size: float = SHEET, knots=(0.0, 0.35, 1.0)):
    """A polynomial bicubic B-spline surface over the domain [0, 1]², with one interior knot
    per direction; its poles form a regular grid over [0, size]² in (x, y) with the
    ``heights`` (5 x 5) in z."""
    n, p = 5, 3
    poles = Array2_gp_Pnt(1, n, 1, n)
    for i in range(n):
        for j in range(n):
            x, y = size * i / (n - 1), size * j / (n - 1)
            poles.SetValue(i + 1, j + 1, gp_Pnt(x, y, float(heights[i][j])))
    values, mults = Array1_double(1, len(knots)), Array1_int(1, len(knots))
    for k, t in enumerate(knots):
        values.SetValue(k + 1, float(t))
        mults.SetValue(k + 1, p + 1 if k in (0, len(knots) - 1) else 1)
    return Geom_BSplineSurface(poles, values, values, mults, mults, p, p, False, False)


#: z of the poles of :func:`holed_bspline_face` and :func:`split_bspline_face` (a saddle-ish
#: sheet with a bump: curved everywhere, no plane).
SHEET_HEIGHTS = (
    (0.0, 1.0, 2.0, 1.0, 0.0),
    (1.0, 3.0, 2.5, 2.0, 1.0),
    (2.0, 2.0, 5.0, 3.0, 1.5),
    (1.0, 2.5, 3.0, 1.0, 2.0),
    (0.0, 0.5, 1.5, 2.0, 3.0),
)


def holed_bspline_face(radius: float = HOLE_RADIUS):
    """A curved B-spline face over [0, SHEET]² in (x, y) with a circular hole: the vertical
    cylinder of ``radius`` around HOLE_CENTRE cut out of it (the hole's outline seen along z
    is that circle exactly; its edges get pcurves from the Boolean)."""
    face = BRepBuilderAPI_MakeFace(_bspline_surface(SHEET_HEIGHTS), 1e-7).Face()
    axis = gp_Ax2(gp_Pnt(*HOLE_CENTRE, -20.0), gp_Dir(0.0, 0.0, 1.0))
    return BRepAlgoAPI_Cut(face, BRepPrimAPI_MakeCylinder(axis, radius, 50.0).Shape()).Shape()


def _wobbly_section(z: float, radius: float, n: int = 12):
    """A closed, periodic B-spline curve through n points of a wobbly circle at height z."""
    points = HArray1_gp_Pnt(1, n)
    for k in range(n):
        t = 2 * math.pi * k / n
        r = radius * (1.0 + 0.15 * math.cos(3 * t))
        points.SetValue(k + 1, gp_Pnt(r * math.cos(t), r * math.sin(t), z))
    interpolate = GeomAPI_Interpolate(points, True, 1e-9)
    interpolate.Perform()
    return BRepBuilderAPI_MakeWire(BRepBuilderAPI_MakeEdge(interpolate.Curve()).Edge()).Wire()


def _circle(z: float, radius: float):
    circle = Geom_Circle(gp_Ax2(gp_Pnt(0.0, 0.0, z), gp_Dir(0.0, 0.0, 1.0)), radius)
    return BRepBuilderAPI_MakeWire(BRepBuilderAPI_MakeEdge(circle).Edge()).Wire()


def loft():
    """A closed solid lofted (smooth, not ruled) through a circle of radius 6 at z = 0, a
    periodic B-spline section (a wobbly circle of radius about 4) at z = 6 and a circle of
    radius 5 at z = 12: one B-spline side face and two plane caps."""
    z0, z1, z2 = LOFT_HEIGHTS
    sections = BRepOffsetAPI_ThruSections(True, False, 1e-6)
    sections.AddWire(_circle(z0, 6.0))
    sections.AddWire(_wobbly_section(z1, 4.0))
    sections.AddWire(_circle(z2, 5.0))
    sections.Build()
    return sections.Shape()


def bspline_sheet():
    """The surface of :func:`split_bspline_face` as one face (its whole domain [0, 1]²)."""
    return BRepBuilderAPI_MakeFace(_bspline_surface(SHEET_HEIGHTS), 1e-7).Face()


def split_bspline_face(at: float = SPLIT_AT):
    """One curved B-spline surface (SHEET_HEIGHTS, domain [0, 1]²) as two faces, u <= ``at``
    and u >= ``at``, sewn into one shell along their shared edge: the surface is C2 (cubic,
    simple knots) there, so the faces meet with G2 continuity and more."""
    surface = _bspline_surface(SHEET_HEIGHTS)
    sewing = BRepBuilderAPI_Sewing(1e-6)
    for u0, u1 in ((0.0, at), (at, 1.0)):
        sewing.Add(BRepBuilderAPI_MakeFace(surface, u0, u1, 0.0, 1.0, 1e-7).Face())
    sewing.Perform()
    return sewing.SewedShape()


def split_bspline_shells(at: float = SPLIT_AT):
    """The faces of :func:`split_bspline_face`, unsewn, each in an open shell of its own (as
    STEP surface models write them): a compound of two one-face shells sharing no edge."""
    from OCP.BRep import BRep_Builder
    from OCP.TopoDS import TopoDS_Shell

    surface = _bspline_surface(SHEET_HEIGHTS)
    builder, compound = BRep_Builder(), TopoDS_Compound()
    builder.MakeCompound(compound)
    for u0, u1 in ((0.0, at), (at, 1.0)):
        shell = TopoDS_Shell()
        builder.MakeShell(shell)
        builder.Add(shell, BRepBuilderAPI_MakeFace(surface, u0, u1, 0.0, 1.0, 1e-7).Face())
        builder.Add(compound, shell)
    return compound


def write_shape(shape, path: Path) -> Path:
    """The shape as a STEP, IGES (``.igs``) or BREP file, by the suffix; the writers'
    banners silenced."""
    from OCP.IGESControl import IGESControl_Writer
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    from gshade.runtime.native import captured_output

    with captured_output():
        if path.suffix == ".step":
            writer = STEPControl_Writer()
            writer.Transfer(shape, STEPControl_AsIs)
            writer.Write(str(path))
        elif path.suffix == ".igs":
            iges = IGESControl_Writer("MM", 1)
            iges.AddShape(shape)
            iges.ComputeModel()
            iges.Write(str(path))
        else:
            BRepTools.Write_s(shape, str(path))
    return path


def open_wire():
    """A face on the plane z = 0 bounded (by hand) by an open polyline: a trimming wire that
    is not closed, which the kernel's healing does not repair."""
    polygon = BRepBuilderAPI_MakePolygon()
    for p in ((0, 0, 0), (10, 0, 0), (10, 10, 0)):
        polygon.Add(gp_Pnt(*p))
    face, builder = TopoDS_Face(), BRep_Builder()
    builder.MakeFace(face, Geom_Plane(gp_Pln()), 1e-7)
    builder.Add(face, polygon.Wire())
    return face


def no_pcurves():
    """A wavy B-spline face bounded by its four boundary iso-curves as 3D edges only (built
    with BRep_Builder: no curves on the surface), which the kernel's checks reject and its
    healing repairs (it computes the curves on the surface)."""
    points = Array2_gp_Pnt(1, 4, 1, 4)
    for i in range(4):
        for j in range(4):
            points.SetValue(i + 1, j + 1, gp_Pnt(10 * i, 10 * j, 3 * math.sin(i) * math.cos(j)))
    surface = GeomAPI_PointsToBSplineSurface(points).Surface()
    u0, u1, v0, v1 = surface.Bounds()
    wire = BRepBuilderAPI_MakeWire()
    for curve in (surface.VIso(v0), surface.UIso(u1), surface.VIso(v1), surface.UIso(u0)):
        wire.Add(BRepBuilderAPI_MakeEdge(curve).Edge())
    face, builder = TopoDS_Face(), BRep_Builder()
    builder.MakeFace(face, surface, 1e-7)
    builder.Add(face, wire.Wire())
    return face, surface


def back_to_back(size: float = 1.0):
    """Two coincident squares in z = 0, normals +z and -z, sewn along their four edges."""
    sewing = BRepBuilderAPI_Sewing(1e-6)
    for normal, (v0, v1) in ((1.0, (0.0, size)), (-1.0, (-size, 0.0))):
        plane = Geom_Plane(gp_Ax3(gp_Pnt(0, 0, 0), gp_Dir(0, 0, normal), gp_Dir(1, 0, 0)))
        sewing.Add(BRepBuilderAPI_MakeFace(plane, 0.0, size, v0, v1, 1e-7).Face())
    sewing.Perform()
    return sewing.SewedShape()
