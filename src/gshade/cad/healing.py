"""A model's shape checked and healed by the kernel: which faces are invalid, and why.

The kernel's checks (``BRepCheck_Analyzer``) look at the whole shape once (a few hundredths
of a second on models of 40-100 faces); the faces are looked at one by one only when that
fails.  When some face is invalid, the kernel's healing (``ShapeFix_Shape``: the wires'
missing parameter or 3D curves, small edges, gaps and self-intersections, their order and
orientation, missing seams, the faces' and shells' orientation) runs on the whole shape, so
that an edge it repairs is repaired in both faces that share it.  Its result is kept when it
leaves fewer faces invalid; what it changed is said a line a face.  The faces still invalid
are left out by the reader (:class:`gshade.cad.LeftOutFace`), the rest are rendered.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from OCP.BRep import BRep_Tool
from OCP.BRepCheck import BRepCheck_Analyzer, BRepCheck_Face, BRepCheck_Status, BRepCheck_Wire
from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
from OCP.ShapeFix import ShapeFix_Shape
from OCP.TopAbs import TopAbs_EDGE, TopAbs_WIRE
from OCP.TopExp import TopExp_Explorer
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import TopoDS, TopoDS_Edge, TopoDS_Shape

from ..runtime.native import captured_output
from .kernel import shape_faces

__all__ = ["HEALING", "Healing", "heal", "invalid_faces"]

#: What was tried on a face that is still invalid, as the warnings say it.
HEALING = "the kernel's healing (ShapeFix_Shape)"

#: What the kernel's checks (BRepCheck) report, in words.
_INVALID = {
    "BRepCheck_SelfIntersectingWire": "a trimming wire intersects itself",
    "BRepCheck_IntersectingWires": "its trimming wires intersect each other",
    "BRepCheck_InvalidImbricationOfWires": "its trimming wires are wrongly nested",
    "BRepCheck_NotClosed": "a trimming wire is not closed",
    "BRepCheck_BadOrientationOfSubshape": "a trimming wire runs the wrong way",
}


@dataclass
class Healing:
    """A shape after the checks and the healing.

    Attributes
    ----------
    shape : TopoDS_Shape
        The shape to read the faces of: healed when the healing helped, else as given.
    faces : list of TopoDS_Face
        Its faces in the kernel's traversal order (their numbers are the model's).
    invalid : dict of int to str
        The faces still invalid, by number, with what is wrong with each.
    changes : list of str
        What the healing changed, one line each (``face N: healed, valid now (was: ...)``).
    """

    shape: TopoDS_Shape
    faces: list
    invalid: dict[int, str] = field(default_factory=dict)
    changes: list[str] = field(default_factory=list)


def invalid_faces(shape: TopoDS_Shape, faces: list | None = None) -> dict[int, str]:
    """The faces of ``shape`` (``faces``: its :func:`shape_faces`) that the kernel's checks
    find invalid, by number, each with what is wrong with it in a few words; empty when the
    whole shape passes (checked first, at once)."""
    with captured_output():
        if BRepCheck_Analyzer(shape).IsValid():
            return {}
        faces = shape_faces(shape) if faces is None else faces
        return {
            index: why_invalid(face)
            for index, face in enumerate(faces)
            if not BRepCheck_Analyzer(face).IsValid()
        }


def heal(shape: TopoDS_Shape, faces: list | None = None) -> Healing:
    """The shape with its invalid faces healed where the kernel can (see the module).

    The healing runs only when some face is invalid, and its result is kept only when it
    leaves fewer faces invalid than there were; a shape whose faces all pass is returned as
    it is (its faces and their numbers unchanged).
    """
    faces = shape_faces(shape) if faces is None else faces
    invalid = invalid_faces(shape, faces)
    if not invalid:
        return Healing(shape, faces)
    try:
        with captured_output():
            fixer = ShapeFix_Shape(shape)
            fixer.Perform()
            healed = fixer.Shape()
    except Exception as exc:  # the kernel's own failure: the faces stay as they are
        text = (str(exc).strip().splitlines() or [""])[0]
        failed = f"the kernel's healing failed ({type(exc).__name__}{': ' * bool(text)}{text})"
        return Healing(shape, faces, invalid, [failed])
    if healed.IsNull():
        return Healing(shape, faces, invalid, ["the kernel's healing gave an empty shape"])
    healed_faces = shape_faces(healed)
    still = invalid_faces(healed, healed_faces)
    if len(still) >= len(invalid) or not healed_faces:
        return Healing(shape, faces, invalid, [])
    return Healing(healed, healed_faces, still, _changes(invalid, still, len(faces), healed_faces))


def _changes(before: dict[int, str], after: dict[int, str], count: int, faces: list) -> list[str]:
    """What the healing changed, a line a face: by number where it kept the faces' count
    (and so their order), else the new count."""
    if len(faces) != count:
        return [
            f"the kernel's healing made {len(before) - len(after)} of {len(before)} invalid "
            f"faces valid; the model has {len(faces)} faces now (it had {count}: faces split "
            "or removed, numbered anew)"
        ]
    return [
        f"face {i}: healed, valid now (was: {why})" for i, why in before.items() if i not in after
    ]


def why_invalid(face: Any) -> str:
    """What the kernel finds wrong with an invalid face, in a few words."""
    missing = _no_surface(face)
    if missing is not None:
        return missing
    ok = BRepCheck_Status.BRepCheck_NoError
    try:
        checks = BRepCheck_Face(face)
        statuses = [checks.IntersectWires(True), checks.ClassifyWires(True)]
        wires = []
        explorer = TopExp_Explorer(face, TopAbs_WIRE)
        while explorer.More():
            wire = BRepCheck_Wire(TopoDS.Wire(explorer.Current()))
            e1, e2 = TopoDS_Edge(), TopoDS_Edge()
            statuses += [wire.Closed(True), wire.SelfIntersect(face, e1, e2, True)]
            wires.append(wire)
            explorer.Next()
        # then what is wrong only once the wires are whole: their ends in (u, v), their sense
        statuses += [wire.Closed2d(face, True) for wire in wires]
        statuses += [checks.OrientationOfWires(True)]
        statuses += [wire.Orientation(face, True) for wire in wires]
    except Exception:  # the checks themselves fail on some faces
        statuses = []
    for status in statuses:
        if status != ok:
            return _INVALID.get(status.name, status.name.removeprefix("BRepCheck_"))
    off = _off_surface(face)
    if off is not None:
        return off
    return "BRepCheck finds it invalid"


def _no_surface(face: Any) -> str | None:
    """'a triangle mesh, no exact surface' for a face the kernel holds only as triangles (a
    tessellated STEP AP242 face), 'no surface' for one with neither; None for a face with a
    surface."""
    try:
        if BRep_Tool.Surface_s(face) is not None:
            return None
        mesh = BRep_Tool.Triangulation_s(face, TopLoc_Location())
    except Exception:  # the kernel's own error: the face is not this kind of broken
        return None
    if mesh is not None:
        return "a triangle mesh, no exact surface (a tessellated face)"
    return "no surface"


def _off_surface(face: Any) -> str | None:
    """What is wrong with the first edge of the face that has no curve on the face's surface
    or no 3D curve (a pole's edge needs none), or whose 3D curve's midpoint lies farther from
    the surface than the edge's tolerance ('edge k lies d off ...'); None when none is."""
    try:
        surface = BRep_Tool.Surface_s(face)
        explorer = TopExp_Explorer(face, TopAbs_EDGE)
        k = -1
        while explorer.More():
            edge = TopoDS.Edge(explorer.Current())
            explorer.Next()
            k += 1
            if BRep_Tool.CurveOnSurface_s(edge, face, 0.0, 0.0) is None:
                return f"edge {k} has no curve on the face's surface"
            if BRep_Tool.Degenerated_s(edge):  # a pole: no 3D curve of its own
                continue
            curve = BRep_Tool.Curve_s(edge, 0.0, 0.0)
            if curve is None:
                return f"edge {k} has no 3D curve"
            t0, t1 = BRep_Tool.Range_s(edge)
            projection = GeomAPI_ProjectPointOnSurf(curve.Value(0.5 * (t0 + t1)), surface)
            tol = BRep_Tool.Tolerance_s(edge)
            if projection.NbPoints() and projection.LowerDistance() > tol:
                return (
                    f"edge {k} lies {projection.LowerDistance():.3g} off the face's surface, "
                    f"tolerance {tol:.3g}"
                )
    except Exception:
        return None
    return None
