"""Write the CAD parts of the ``bracket-*`` scenes, ``scenes/data/bracket.step``, and of the
``drafted-block-*`` scenes, ``scenes/data/drafted_block.step``.

An L-shaped angle bracket built with Open CASCADE (cadquery-ocp), in mm:

- one extruded L profile (in the x-z plane, extruded 40 along y): a base plate 70 long and
  8 thick (0 <= x <= 70, 0 <= z <= 8) and an upright plate 8 thick and 50 high
  (0 <= x <= 8, 0 <= z <= 50);
- the inner corner between the plates (the edge x = z = 8) filleted at r = 10 and the outer
  corner (x = z = 0) at r = 18, so that the bend keeps the plates' thickness 8: two
  cylinders meeting the plates tangentially (G1 edges, where the curvature jumps by 1/r);
- the base plate's two free vertical corners (x = 70) and the upright's two top corners
  (z = 50) rounded at r = 8 (more G1 edges);
- two holes of diameter 9 through the base plate and one of diameter 11 through the
  upright (sharp G0 edges, at 90 degrees).

The drafted block: a solid ruled between the square |x|, |y| <= 20 at z = 0 and its top at
z = 16, whose sides facing +x, -x, +y, -y lean in by 3, 1, 0 and -2 degrees (the last leans
out: an undercut for the pull direction +z), so that their draft angles about +z are exactly
those; 6 planar faces.

The bracket is one valid solid of 17 faces (8 planes, 9 cylinders) and 42 edges shared by
two faces: 12 G1 (the six fillets' edges) and 30 sharp G0 ones.  The STEP file's header
(name, time stamp, author, organisation, originating system) is fixed, so that the file is
byte-identical on every run.

Run from the repository root: ``python scenes/make_cad_scenes.py``.
"""

import contextlib
import math
import os
import sys
from pathlib import Path

from OCP.APIHeaderSection import APIHeaderSection_MakeHeader
from OCP.BRep import BRep_Tool
from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace, BRepBuilderAPI_MakePolygon
from OCP.BRepCheck import BRepCheck_Analyzer
from OCP.BRepFilletAPI import BRepFilletAPI_MakeFillet
from OCP.BRepOffsetAPI import BRepOffsetAPI_ThruSections
from OCP.BRepPrimAPI import BRepPrimAPI_MakeCylinder, BRepPrimAPI_MakePrism
from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt, gp_Vec
from OCP.IFSelect import IFSelect_RetDone
from OCP.Interface import Interface_Static
from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
from OCP.TCollection import TCollection_HAsciiString
from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
from OCP.TopExp import TopExp_Explorer
from OCP.TopoDS import TopoDS

HERE = Path(__file__).resolve().parent
OUT = HERE / "data" / "bracket.step"
DRAFTED = HERE / "data" / "drafted_block.step"

LENGTH = 70.0  # the base plate along x
HEIGHT = 50.0  # the upright along z
DEPTH = 40.0  # the extrusion along y
THICK = 8.0  # both plates
INNER = 10.0  # the inner bend's fillet radius
CORNER = 8.0  # the free corners' radius
#: Holes: (centre, axis direction, diameter); they go right through their plate.
HOLES = (
    ((48.0, 11.0, -1.0), (0.0, 0.0, 1.0), 9.0),
    ((48.0, 29.0, -1.0), (0.0, 0.0, 1.0), 9.0),
    ((-1.0, 20.0, 34.0), (1.0, 0.0, 0.0), 11.0),
)


def edges(shape):
    explorer = TopExp_Explorer(shape, TopAbs_EDGE)
    while explorer.More():
        yield TopoDS.Edge(explorer.Current())
        explorer.Next()


def straight_along(edge, axis: int):
    """The edge's first end point (x, y, z) if it is a straight segment parallel to coordinate
    ``axis``, else None."""
    curve = BRep_Tool.Curve_s(edge, 0.0, 1.0)
    first, last = BRep_Tool.Range_s(edge)
    a, b = curve.Value(first), curve.Value(last)
    a, b = (a.X(), a.Y(), a.Z()), (b.X(), b.Y(), b.Z())
    others = [k for k in range(3) if k != axis]
    if all(abs(a[k] - b[k]) < 1e-9 for k in others) and abs(a[axis] - b[axis]) > 1e-9:
        return a
    return None


def bracket():
    # The L profile in the plane y = 0, counter-clockwise seen from -y (outward normal -y).
    corners = [
        (0.0, 0.0),
        (LENGTH, 0.0),
        (LENGTH, THICK),
        (THICK, THICK),
        (THICK, HEIGHT),
        (0.0, HEIGHT),
    ]
    polygon = BRepBuilderAPI_MakePolygon()
    for x, z in corners:
        polygon.Add(gp_Pnt(x, 0.0, z))
    polygon.Close()
    profile = BRepBuilderAPI_MakeFace(polygon.Wire()).Face()
    solid = BRepPrimAPI_MakePrism(profile, gp_Vec(0.0, DEPTH, 0.0)).Shape()

    # The bend: inner corner at r, outer corner at r + thickness (the same centre line).
    bend = BRepFilletAPI_MakeFillet(solid)
    for edge in edges(solid):
        p = straight_along(edge, 1)
        if p is None:
            continue
        if abs(p[0] - THICK) < 1e-9 and abs(p[2] - THICK) < 1e-9:
            bend.Add(INNER, edge)
        elif abs(p[0]) < 1e-9 and abs(p[2]) < 1e-9:
            bend.Add(INNER + THICK, edge)
    solid = bend.Shape()

    # The free corners: the base plate's vertical edges at x = LENGTH and the upright's
    # horizontal edges at z = HEIGHT that run through the thickness (along x).
    corners = BRepFilletAPI_MakeFillet(solid)
    for edge in edges(solid):
        p = straight_along(edge, 2)
        if p is not None and abs(p[0] - LENGTH) < 1e-9:
            corners.Add(CORNER, edge)
            continue
        p = straight_along(edge, 0)
        if p is not None and abs(p[2] - HEIGHT) < 1e-9:
            corners.Add(CORNER, edge)
    solid = corners.Shape()

    for centre, axis, diameter in HOLES:
        frame = gp_Ax2(gp_Pnt(*centre), gp_Dir(*axis))
        drill = BRepPrimAPI_MakeCylinder(frame, diameter / 2, THICK + 2.0).Shape()
        solid = BRepAlgoAPI_Cut(solid, drill).Shape()

    assert BRepCheck_Analyzer(solid).IsValid()
    return solid


#: the drafted block's sides facing +x, -x, +y, -y: their drafts (degrees, pull +z)
DRAFTS = (3.0, 1.0, 0.0, -2.0)
BLOCK_HALF, BLOCK_HEIGHT = 20.0, 16.0


def drafted_block():
    inset = [BLOCK_HEIGHT * math.tan(math.radians(d)) for d in DRAFTS]
    h = BLOCK_HALF
    bottom = [(-h, -h), (h, -h), (h, h), (-h, h)]
    px, nx, py, ny = h - inset[0], -h + inset[1], h - inset[2], -h + inset[3]
    top = [(nx, ny), (px, ny), (px, py), (nx, py)]
    sections = BRepOffsetAPI_ThruSections(True, True)
    for z, corners in ((0.0, bottom), (BLOCK_HEIGHT, top)):
        polygon = BRepBuilderAPI_MakePolygon()
        for x, y in corners:
            polygon.Add(gp_Pnt(x, y, z))
        polygon.Close()
        sections.AddWire(polygon.Wire())
    sections.Build()
    shape = sections.Shape()
    assert BRepCheck_Analyzer(shape).IsValid() and count_faces(shape) == 6
    return shape


def count_faces(shape) -> int:
    explorer, n = TopExp_Explorer(shape, TopAbs_FACE), 0
    while explorer.More():
        n += 1
        explorer.Next()
    return n


@contextlib.contextmanager
def quiet():
    """Silence the kernel's banners on stdout (file descriptor 1)."""
    sys.stdout.flush()
    saved = os.dup(1)
    with open(os.devnull, "w") as null:
        os.dup2(null.fileno(), 1)
        try:
            yield
        finally:
            sys.stdout.flush()
            os.dup2(saved, 1)
            os.close(saved)


def write_step(shape, path: Path, name: str = "bracket"):
    Interface_Static.SetCVal_s("write.step.unit", "MM")
    Interface_Static.SetCVal_s("write.step.schema", "AP214IS")
    writer = STEPControl_Writer()
    with quiet():
        assert writer.Transfer(shape, STEPControl_AsIs) == IFSelect_RetDone
    header = APIHeaderSection_MakeHeader(writer.Model())
    header.SetName(TCollection_HAsciiString(name))
    header.SetTimeStamp(TCollection_HAsciiString("2026-01-01T00:00:00"))
    header.SetAuthorValue(1, TCollection_HAsciiString("gshade"))
    header.SetOrganizationValue(1, TCollection_HAsciiString("gshade"))
    header.SetOriginatingSystem(TCollection_HAsciiString("scenes/make_cad_scenes.py"))
    header.SetAuthorisation(TCollection_HAsciiString(""))
    with quiet():
        assert writer.Write(str(path)) == IFSelect_RetDone


def main():
    for make, path in ((bracket, OUT), (drafted_block, DRAFTED)):
        shape = make()
        write_step(shape, path, path.stem)
        print(f"{path.relative_to(HERE.parent)}: {count_faces(shape)} faces")


if __name__ == "__main__":
    main()
