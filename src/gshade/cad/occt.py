"""STEP, IGES and BREP files as exact faces, read with Open CASCADE (cadquery-ocp).

The whole shape is converted to NURBS once (``BRepBuilderAPI_NurbsConvert``): planes,
quadrics, tori, B-spline, Bézier, revolution and extrusion surfaces come out exact (quadrics
in a rational parametrisation of their own, so each face's box and loops are those of the
*converted* face); offset and other surfaces are approximated and carry their measured error.

Coordinates are in millimetres: the STEP and IGES readers convert the file's length unit to
the session unit, which is set to mm here.  A BREP file carries no unit (``"unknown"``).
"""

from __future__ import annotations

import itertools
import re
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from OCP.Bnd import Bnd_Box
from OCP.BRep import BRep_Builder, BRep_Tool
from OCP.BRepAdaptor import BRepAdaptor_Curve2d, BRepAdaptor_Surface
from OCP.BRepBndLib import BRepBndLib
from OCP.BRepBuilderAPI import BRepBuilderAPI_NurbsConvert, BRepBuilderAPI_Sewing
from OCP.BRepTools import BRepTools, BRepTools_WireExplorer
from OCP.GeomAbs import GeomAbs_Line, GeomAbs_SurfaceType
from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
from OCP.GeomConvert import GeomConvert
from OCP.gp import gp_Pnt
from OCP.IFSelect import IFSelect_RetDone
from OCP.IGESControl import IGESControl_Reader
from OCP.Interface import Interface_Static
from OCP.STEPControl import STEPControl_Reader
from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_REVERSED, TopAbs_SHELL, TopAbs_WIRE
from OCP.TopExp import TopExp_Explorer
from OCP.TopoDS import TopoDS, TopoDS_Shape

from ..errors import GshadeError
from ..geometry.patches.bspline import BSplinePatch
from ..geometry.patches.revolution import TURN_OVERSHOOT
from ..io.files import read_bytes
from ..limits import MAX_DATA_FILE_BYTES
from ..runtime.native import captured_output
from .healing import HEALING, heal
from .kernel import exception_text, shape_faces
from .model import (
    CadFace,
    CadModel,
    LeftOutFace,
    arc_map,
    faces_bounds,
    faces_extents,
    no_usable_face,
    usable,
)
from .quadrics import analytic_patch, builds
from .step_accuracy import step_uncertainty

__all__ = ["LOOP_TOLERANCE", "read"]

#: Trimming-loop polylines deviate from the exact curves by less than this fraction of the
#: face's parameter box (its larger side), in (u, v).
LOOP_TOLERANCE = 1e-4

_KINDS = {
    GeomAbs_SurfaceType.GeomAbs_Plane: "plane",
    GeomAbs_SurfaceType.GeomAbs_Cylinder: "cylinder",
    GeomAbs_SurfaceType.GeomAbs_Cone: "cone",
    GeomAbs_SurfaceType.GeomAbs_Sphere: "sphere",
    GeomAbs_SurfaceType.GeomAbs_Torus: "torus",
    GeomAbs_SurfaceType.GeomAbs_BSplineSurface: "bspline",
    GeomAbs_SurfaceType.GeomAbs_BezierSurface: "bezier",
    GeomAbs_SurfaceType.GeomAbs_SurfaceOfRevolution: "revolution",
    GeomAbs_SurfaceType.GeomAbs_SurfaceOfExtrusion: "extrusion",
    GeomAbs_SurfaceType.GeomAbs_OffsetSurface: "offset",
}
_EXACT = {"plane", "cylinder", "cone", "sphere", "torus", "bspline", "bezier"}
_EXACT |= {"revolution", "extrusion"}
_NAMES = {".step": "a STEP file", ".stp": "a STEP file", ".iges": "an IGES file"}
_NAMES |= {".igs": "an IGES file", ".brep": "a BREP file"}

#: Points along a trimming curve before it is refined where it bends.
PCURVE_SAMPLES = 9


def read(path: str | Path, sew: bool | None = None, tolerance: float | None = None) -> CadModel:
    """Read a STEP, IGES or BREP file into exact faces (see :func:`gshade.cad.read_cad`).

    Raises
    ------
    GshadeError
        One line naming the file (and the face, where one fails).
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in _NAMES:
        raise GshadeError(f"{path}: expected a STEP, IGES or BREP file, got {ext or '(none)'!r}")
    _check_file(path, ext)
    shape, unit = _read_shape(path, ext)
    faces = shape_faces(shape)
    if not faces:
        raise GshadeError(
            f"{path}: holds no surfaces (only wireframe, point or mesh entities, or nothing)"
        )
    if sew or (sew is None and _has_free_faces(shape)):
        rough = _rough_bounds(shape, path)
        diagonal = float(np.linalg.norm(rough[1] - rough[0]))
        tol = tolerance if tolerance is not None else _sew_tolerance(shape, diagonal)
        healing = heal(_sew(shape, path, tol))
        if sew and not healing.faces:
            raise GshadeError(f"{path}: holds no surfaces once its faces are sewn")
        lost = len(healing.faces) < len(faces)
        if sew is None and (lost or healing.invalid):  # sewn by choice: unless it spoilt faces
            unsewn = heal(shape, faces)
            if lost or len(unsewn.invalid) < len(healing.invalid):
                unsewn.changes.append(
                    f"read unsewn: sewing kept {len(healing.faces)} of the {len(faces)} faces"
                    if lost
                    else f"read unsewn: sewn, {len(healing.invalid)} faces are invalid, "
                    f"unsewn {len(unsewn.invalid)}"
                )
                healing = unsewn
    else:
        healing = heal(shape, faces)
    shape, faces = healing.shape, healing.faces
    left_out = {i: LeftOutFace(i, why, HEALING) for i, why in healing.invalid.items()}
    if all(_own(face) for face in faces):  # exact NURBS without the kernel's help
        converted, nurbs = shape, faces
    else:
        converted = _converted(shape, path)
        nurbs = shape_faces(converted)
    if len(nurbs) != len(faces):
        raise GshadeError(f"{path}: the NURBS conversion gave {len(nurbs)} faces for {len(faces)}")
    out = []
    for index, (face, conv) in enumerate(zip(faces, nurbs, strict=True)):
        if index in left_out:
            continue
        try:
            out.append(usable(_face(index, face, conv, own=converted is shape)))
        except GshadeError as exc:
            left_out[index] = LeftOutFace(index, str(exc), "reading its surface and trims")
        except Exception as exc:
            left_out[index] = LeftOutFace(
                index, f"the kernel failed ({exception_text(exc)})", "reading its surface and trims"
            )
    if not out:
        raise no_usable_face(path, [left_out[i] for i in sorted(left_out)])
    faces_extents(out)  # kept with the model (and the cached read)
    precision = step_uncertainty(path) if ext in (".step", ".stp") else 0.0
    return CadModel(
        path=path,
        faces=out,
        unit=unit,
        bounds=faces_bounds(out),
        brep=converted,
        precision=precision,
        left_out=[left_out[i] for i in sorted(left_out)],
        notes=healing.changes,
    )


#: A STEP file's start: its ISO-10303-21 line, after white space and comments (ISO 10303-21
#: allows ``/* ... */`` anywhere outside a string; some writers put their banner first).
_STEP_START = re.compile(rb"\s*(?:/\*.*?\*/\s*)*ISO-10303-21", re.DOTALL)


def _check_file(path: Path, ext: str) -> None:
    """Refuse what is not a regular, bounded file of the right format, before the kernel."""
    expected = _NAMES[ext]
    head = read_bytes(path, expected, size=4096, limit=MAX_DATA_FILE_BYTES)
    if not head.strip():
        raise GshadeError(f"{path}: expected {expected}, got an empty file")
    if ext in (".step", ".stp"):
        if not _STEP_START.match(head):
            raise GshadeError(f"{path}: not a STEP file (no ISO-10303-21 header)")
        with open(path, "rb") as f:
            f.seek(max(path.stat().st_size - 4096, 0))
            tail = f.read()
        if b"END-ISO-10303-21" not in tail:
            raise GshadeError(f"{path}: truncated STEP file (no END-ISO-10303-21 at the end)")
    elif ext in (".iges", ".igs"):
        first = head.splitlines()[0].rstrip(b"\r\n") if head.splitlines() else b""
        if len(first) < 73 or first[72:73] not in (b"S", b"G", b"C"):
            raise GshadeError(f"{path}: not an IGES file (no 80-column start section)")
        with open(path, "rb") as f:
            f.seek(max(path.stat().st_size - 400, 0))
            lines = f.read().splitlines()
        if not lines or lines[-1].rstrip()[72:73] != b"T":
            raise GshadeError(f"{path}: truncated IGES file (no terminate section at the end)")
    elif b"CASCADE Topology" not in head:
        raise GshadeError(f"{path}: not a BREP file (no 'CASCADE Topology' header)")


def _read_shape(path: Path, ext: str) -> tuple[TopoDS_Shape, str]:
    """The file's shape, and the unit of its coordinates."""
    try:
        with captured_output() as said:
            if ext == ".brep":
                shape = TopoDS_Shape()
                ok = BRepTools.Read_s(shape, str(path), BRep_Builder())
                return _nonempty(shape if ok else None, path, said.line()), "unknown"
            if ext in (".step", ".stp"):
                reader: Any = STEPControl_Reader()
                reader.SetSystemLengthUnit(1.0)  # coordinates in mm
            else:
                reader = IGESControl_Reader()
                Interface_Static.SetCVal_s("xstep.cascade.unit", "MM")
            if reader.ReadFile(str(path)) != IFSelect_RetDone:
                return _nonempty(None, path, said.line("rror")), "mm"
            reader.TransferRoots()
            shape = reader.OneShape() if reader.NbShapes() else None
    except GshadeError:
        raise
    except Exception as exc:
        raise GshadeError(
            f"{path}: the kernel could not read the file ({exception_text(exc)})"
        ) from None
    return _nonempty(shape, path, ""), "mm"


def _nonempty(shape: TopoDS_Shape | None, path: Path, said: str) -> TopoDS_Shape:
    """The shape, or a one-line error for a file that gave none."""
    if shape is None:
        raise GshadeError(
            f"{path}: the kernel could not read the file" + (f" ({said})" if said else "")
        )
    if shape.IsNull():
        raise GshadeError(f"{path}: holds no shapes the kernel can transfer")
    return shape


def _has_free_faces(shape: TopoDS_Shape) -> bool:
    """True when some face lies in no shell (unsewn faces, as IGES files usually hold), or
    alone in a shell of its own beside other faces (a STEP surface model written as one
    open shell a face: its faces share no edge until sewn)."""
    if TopExp_Explorer(shape, TopAbs_FACE, TopAbs_SHELL).More():
        return True
    sizes = []
    shells = TopExp_Explorer(shape, TopAbs_SHELL)
    while shells.More():
        faces = TopExp_Explorer(shells.Current(), TopAbs_FACE)
        sizes.append(0)
        while faces.More() and sizes[-1] < 2:
            sizes[-1] += 1
            faces.Next()
        shells.Next()
    return len(sizes) > 1 and min(sizes) == 1


def _sew_tolerance(shape: TopoDS_Shape, diagonal: float) -> float:
    """1e-6 of the model's size, or the largest edge tolerance (the file's precision)."""
    largest = 0.0
    explorer = TopExp_Explorer(shape, TopAbs_EDGE)
    while explorer.More():
        largest = max(largest, BRep_Tool.Tolerance_s(TopoDS.Edge(explorer.Current())))
        explorer.Next()
    return max(1e-6 * diagonal, largest, 1e-9)


def _sew(shape: TopoDS_Shape, path: Path, tolerance: float) -> TopoDS_Shape:
    """The shape's faces sewn into shells."""
    try:
        with captured_output():
            sewing = BRepBuilderAPI_Sewing(tolerance)
            sewing.Add(shape)
            sewing.Perform()
            sewn = sewing.SewedShape()
    except Exception as exc:
        raise GshadeError(f"{path}: sewing the faces failed ({exception_text(exc)})") from None
    return shape if sewn.IsNull() else sewn


def _rough_bounds(
    shape: TopoDS_Shape, path: Path
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A box (lo, hi) around the model, quickly (the poles' and the tolerances' box: loose,
    enough to scale a sewing tolerance)."""
    try:
        box = Bnd_Box()
        BRepBndLib.Add_s(shape, box, False)
        lo, hi = box.CornerMin(), box.CornerMax()
    except Exception as exc:
        raise GshadeError(
            f"{path}: the kernel could not bound the model ({exception_text(exc)})"
        ) from None
    return np.array([lo.X(), lo.Y(), lo.Z()]), np.array([hi.X(), hi.Y(), hi.Z()])


def _array1(a: Any) -> NDArray[np.float64]:
    return np.array([a.Value(i) for i in range(a.Lower(), a.Upper() + 1)], dtype=float)


def _patch(surface: Any) -> BSplinePatch:
    """A ``Geom_BSplineSurface`` as a :class:`BSplinePatch` (periodic ones unrolled)."""
    if surface.IsUPeriodic() or surface.IsVPeriodic():
        surface = surface.Copy()
        if surface.IsUPeriodic():
            surface.SetUNotPeriodic()
        if surface.IsVPeriodic():
            surface.SetVNotPeriodic()
    nu, nv = surface.NbUPoles(), surface.NbVPoles()
    points = np.empty((nu, nv, 3))
    for i in range(nu):
        for j in range(nv):
            p = surface.Pole(i + 1, j + 1)
            points[i, j] = p.X(), p.Y(), p.Z()
    weights = None
    if surface.IsURational() or surface.IsVRational():
        # never the no-argument Weights(): it crashes the bindings for rational surfaces
        w = surface.WeightsArray()
        weights = np.array(
            [[w.Value(i + 1, j + 1) for j in range(nv)] for i in range(nu)], dtype=float
        )
    knots = (_array1(surface.UKnotSequence()), _array1(surface.VKnotSequence()))
    return BSplinePatch(points, (surface.UDegree(), surface.VDegree()), knots, weights)


def _kind(face: Any) -> str:
    """The kernel's surface type of a face (see :data:`_KINDS`)."""
    return _KINDS.get(BRepAdaptor_Surface(face).GetType(), "other")


def _own(face: Any) -> bool:
    """Whether gshade reads the face's surface exactly without the kernel's conversion."""
    kind = _kind(face)
    return kind in ("bspline", "bezier") or builds(kind, BRepAdaptor_Surface(face))


def _converted(shape: TopoDS_Shape, path: Path) -> TopoDS_Shape:
    """The shape with every face's surface (and its trimming curves) converted to NURBS by
    the kernel, for surfaces gshade does not build itself (revolution, extrusion, offset)."""
    try:
        with captured_output():
            return BRepBuilderAPI_NurbsConvert(shape, True).Shape()
    except Exception as exc:
        raise GshadeError(
            f"{path}: the kernel could not convert the faces to NURBS ({exception_text(exc)})"
        ) from None


def _face(index: int, face: Any, conv: Any, own: bool = False) -> CadFace:
    """One face: its kind (from the original), patch, box and loops (from the converted,
    or, with ``own``, from the original itself (``conv``): then planes and quadrics are built by
    :func:`gshade.cad.quadrics.analytic_patch`, B-spline and Bezier surfaces taken as
    they are)."""
    kind = _kind(face)
    u0, u1, v0, v1 = BRepTools.UVBounds_s(conv)
    box = ((float(u0), float(u1)), (float(v0), float(v1)))
    adaptor = BRepAdaptor_Surface(face)
    _refuse_turns(box, adaptor)
    arcs: Any = (None, None)
    if own and kind not in ("bspline", "bezier"):
        patch, arcs = analytic_patch(kind, adaptor, box)
    else:
        surface = BRep_Tool.Surface_s(conv)
        if type(surface).__name__ != "Geom_BSplineSurface":
            surface = GeomConvert.SurfaceToBSplineSurface_s(surface)
        patch = _patch(surface)
    exact = kind in _EXACT
    error = 0.0 if exact else _error(patch, box, face)
    loops, tol = _loops(conv, box)
    loops = [arc_map(loop, arcs) for loop in loops]  # the kernel's (u, v): the patch's
    area = (u1 - u0) * (v1 - v0)
    trimmed = len(loops) != 1 or abs(abs(_area(loops[0])) - area) > 1e-6 * area
    return CadFace(
        index=index,
        kind=kind,
        patch=patch,
        box=box,
        reversed=face.Orientation() == TopAbs_REVERSED,
        exact=exact,
        error=error,
        loops=loops,
        loop_tolerance=tol,
        trimmed=bool(trimmed),
        arcs=arcs,
    )


def _refuse_turns(box: tuple, surface: Any) -> None:
    """Raise GshadeError if the face's trims wind round its periodic surface (``surface``,
    its BRepAdaptor_Surface) more than once
    (by over :data:`~gshade.geometry.patches.revolution.TURN_OVERSHOOT` of a turn: edges that turn
    through 4 pi round a pin, a helical strip): the kernel's mesher joins its nodes across
    the turns, through the surface, so the face is left out, said in these words."""
    periods = (
        surface.UPeriod() if surface.IsUPeriodic() else None,
        surface.VPeriod() if surface.IsVPeriodic() else None,
    )
    for name, (lo, hi), period in zip("uv", box, periods, strict=True):
        if period is not None and hi - lo > period * (1 + TURN_OVERSHOOT):
            raise GshadeError(
                f"its trims wind {(hi - lo) / period:.3g} times round its surface in {name} "
                f"({lo:.6g} to {hi:.6g}; gshade renders a face of at most one turn)"
            )


def _error(patch: BSplinePatch, box: tuple, face: Any, n: int = 7) -> float:
    """The largest distance from the patch (at an n x n grid of the box) to the original
    face's surface (by projection: the parametrisations may differ)."""
    surface = BRep_Tool.Surface_s(face)
    worst = 0.0
    for u in np.linspace(box[0][0], box[0][1], n):
        for v in np.linspace(box[1][0], box[1][1], n):
            p = patch.derivatives(u, v, 0)[0, 0]
            projection = GeomAPI_ProjectPointOnSurf(gp_Pnt(*map(float, p)), surface)
            if projection.NbPoints():
                worst = max(worst, float(projection.LowerDistance()))
    return worst


def _area(loop: NDArray[np.float64]) -> float:
    """Signed area of a closed polyline (shoelace)."""
    x, y = loop[:, 0], loop[:, 1]
    return 0.5 * float(np.dot(x[:-1], y[1:]) - np.dot(x[1:], y[:-1]))


def _loops(face: Any, box: tuple) -> tuple[list[NDArray[np.float64]], float]:
    """The face's trimming loops in (u, v), outer first, and their tolerance."""
    size = max(box[0][1] - box[0][0], box[1][1] - box[1][0], 1e-300)
    tol = LOOP_TOLERANCE * size
    outer = BRepTools.OuterWire_s(face)
    wires = [outer] if not outer.IsNull() else []
    explorer = TopExp_Explorer(face, TopAbs_WIRE)
    while explorer.More():
        wire = TopoDS.Wire(explorer.Current())
        if not wire.IsSame(outer):
            wires.append(wire)
        explorer.Next()
    loops = []
    for wire in wires:
        points: list[NDArray[np.float64]] = []
        edges = BRepTools_WireExplorer(wire, face)
        while edges.More():
            points.extend(_edge_points(edges.Current(), face, tol))
            edges.Next()
        if points:
            points.append(points[0])
            loops.append(np.array(points))
    return loops, tol


def _edge_points(edge: Any, face: Any, tol: float) -> list[NDArray[np.float64]]:
    """An edge's 2D curve as points (without its last), within ``tol`` of the curve, in the
    wire's direction."""
    curve = BRepAdaptor_Curve2d(edge, face)
    t0, t1 = curve.FirstParameter(), curve.LastParameter()

    def at(t: float) -> NDArray[np.float64]:
        p = curve.Value(t)
        return np.array([p.X(), p.Y()])

    if curve.GetType() == GeomAbs_Line:
        ts = [t0, t1]
    else:
        ts = list(np.linspace(t0, t1, PCURVE_SAMPLES))
        out = [ts[0]]
        for a, b in itertools.pairwise(ts):
            _refine(at, a, b, at(a), at(b), tol, out, 0)
        ts = out
    points = [at(t) for t in ts]
    if edge.Orientation() == TopAbs_REVERSED:
        points.reverse()
    return points[:-1]


def _refine(
    at: Any, a: float, b: float, pa: Any, pb: Any, tol: float, out: list, depth: int
) -> None:
    """Append parameters in (a, b] so that chords stay within ``tol`` of the curve."""
    m = 0.5 * (a + b)
    pm = at(m)
    if depth < 12 and np.linalg.norm(pm - 0.5 * (pa + pb)) > tol:
        _refine(at, a, m, pa, pm, tol, out, depth + 1)
        _refine(at, m, b, pm, pb, tol, out, depth + 1)
    else:
        out.append(b)
