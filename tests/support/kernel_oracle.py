"""An independent oracle of continuity across the B-rep edges of CAD models: the kernel's own
local analysis (Open CASCADE's ``BRepLProp_SLProps`` and ``LocalAnalysis_SurfaceContinuity``)
at the points where two faces meet, with no gshade code at all (issue 26).

For every edge shared by two faces (``TopExp.MapShapesAndUniqueAncestors`` of edges and
faces; degenerated edges and seams, ``BRep_Tool.IsClosed(edge, face)``, are skipped; an edge
of more than two faces gives every pair), ``n`` edge parameters t_k = t0 + (k + 1/2)/n
(t1 - t0) are taken on each face's pcurve (``BRepAdaptor_Curve2d(edge, face)``), and each
face is evaluated at its (u, v) with ``BRepLProp_SLProps(BRepAdaptor_Surface(face), u, v, 2,
tol)``: the point, the normal (flipped on a ``TopAbs_REVERSED`` face: outward normals) and
the principal curvatures and directions (their signs flipped with the normal).  Per edge,
the largest over the samples of:

gap
    |P_i - P_j|.
normal angle
    the oriented angle between the outward normals, degrees, 0 to 180 (a fold or cusp, where
    the faces double back on each other, is about 180).
curvature jump
    the largest |eigenvalue| of S_i - S_j, each shape operator S = k1 d1 d1^T + k2 d2 d2^T
    (principal curvatures k, directions d, w.r.t. the outward normal; an umbilic: k (I - n
    n^T)) projected onto the plane orthogonal to the mean normal (n_i where the normals are
    opposite): the exact largest jump of the normal curvature over tangent directions.
curvature-gradient jump
    max(|grad H_i - grad H_j|, |grad K_i - grad K_j|), the surface gradients of the mean
    and Gaussian curvatures (w.r.t. the outward normals) by finite differences of the
    kernel's curvatures, 3D steps h of about 1e-3 of the edge's length (within 1e-6 and
    1e-4 of the diagonal) and h / 2, Richardson-extrapolated: central (fourth order, then
    sixth) along the pcurve's tangent, one-sided (third order, then fourth) into the face
    (the side where the face's material lies, from the edge's orientation in the face),
    turned into a tangent vector with the first fundamental form.  (With h alone, the
    one-sided difference's h^3 error read 3.7e-12 on the hammer's long edges 70 and 71,
    where both faces' gradients are 4e-15 apart, over the G3 tolerance of 6e-14.)
    Rounding in the kernel's curvatures limits it to about 1e-9 / (its step).

Two classes per edge:

``class`` (the oracle's own thresholds, gshade's defaults mirrored)
    ``none`` (gap above max(1e-7 x diagonal, 2 x the edge's tolerance, 2 x the STEP file's
    declared uncertainty)), else G0 (angle above 1e-3 degrees), G1 (curvature jump above
    1e-5 / diagonal), G2 (gradient jump above 1e-4 / diagonal²), G3.
``la_class`` (the kernel's verdict)
    the weakest over the samples of LocalAnalysis_SurfaceContinuity(surf1, u1, v1, surf2,
    u2, v2, GeomAbs_G2, ...): ``none`` unless IsC0, G0 unless IsG1, G1 unless IsG2, else G2
    (the kernel has no G3).  EpsC0 = the gap tolerance, EpsG1 = 1e-3 degrees (in radians),
    Maxlen = the diagonal, Percent the kernel's default 1 %.  The surfaces are given
    oriented (a reversed face's surface ``UReversed()``, u mapped): the kernel's G2 test uses
    signed mean curvatures.  Its G1 angle is folded into [0, 90] degrees (a fold reads as
    tangent) and its G2 test is relative (Percent of the curvature), not absolute.

``inward_dot`` tells apart what opposite normals mean: the mean over the samples of the dot
product of the two faces' directions into themselves (in each tangent plane, orthogonal to
the edge): about -1 where the faces continue each other (a smooth junction; with opposite
normals, faces whose orientations disagree), about +1 where both lie on the same side of the
edge (a fold or cusp, or two bodies' faces in contact after sewing), 0 at a right angle.
``orientation`` is ``inconsistent`` where the two faces' boundaries run along the edge the
same way: each runs it as m x n (m the direction into the face, n its outward normal: the
face on the boundary's left seen from outside), and the mean of (m1 x n1) . (m2 x n2) over
the samples is positive (opposite ways, -1, in any consistently oriented shell, folds
included); ``consistent`` otherwise.

The face's side of a knot: an edge that lies on an interior knot line of a B-spline face
(the surface under any rectangular trims), every sample on the same knot or within
max(the edge's tolerance, the STEP file's uncertainty) of it in 3D (``LocateU`` /
``LocateV`` with that over |D1U| or |D1V|), the face on one side of it, is evaluated on the
knot span on the side where the face lies (from the pcurve's direction into the face): a
copy of the surface segmented to that span (``Geom_BSplineSurface.Segment``), through
``GeomLProp_SLProps`` and ``LocalAnalysis`` on that copy, continued where a sample lies a
sliver beyond it.  Without it the kernel evaluates the span after a knot (within an ulp),
and ``BRepAdaptor_Surface`` the span inside the face's box only at the box's exact end: a
face ending on a C0 knot read the next face's piece, or a sliver of it where its pcurve ran
a tolerance past the knot (``inside_span_samples`` counts the samples so evaluated, per
face).  An edge that crosses a knot line has the face on both sides: its samples keep the
kernel's spans.

Known limits: beyond the surface's domain a face is extrapolated (its end span continued);
knots of surfaces of revolution, extrusions and offsets are not looked for; the gradient
jump's finite differences see a C0 or C1 knot within three steps of the edge as a large
gradient.

The diagonal is the model's tight bounding box (``BRepBndLib.AddOptimal``, no triangulation).
Each row also carries the edge's midpoint (on its 3D curve), so edges can be paired with
another program's rows by location when the numbering differs.
"""

from __future__ import annotations

import math
import os
import re
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from OCP.Bnd import Bnd_Box
from OCP.BRep import BRep_Builder, BRep_Tool
from OCP.BRepAdaptor import BRepAdaptor_Curve, BRepAdaptor_Curve2d, BRepAdaptor_Surface
from OCP.BRepBndLib import BRepBndLib
from OCP.BRepBuilderAPI import BRepBuilderAPI_Sewing
from OCP.BRepCheck import BRepCheck_Analyzer
from OCP.BRepLProp import BRepLProp_SLProps
from OCP.BRepTools import BRepTools
from OCP.collections import (
    IndexedDataMap_TopoDS_Shape_List_TopoDS_Shape_TopTools_ShapeMapHasher as EdgeFaceMap,
)
from OCP.collections import IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher as ShapeMap
from OCP.GCPnts import GCPnts_AbscissaPoint
from OCP.Geom import Geom_BSplineSurface, Geom_RectangularTrimmedSurface
from OCP.GeomAbs import GeomAbs_Shape
from OCP.GeomLProp import GeomLProp_SLProps
from OCP.gp import gp_Dir, gp_Pnt2d, gp_Vec2d
from OCP.IFSelect import IFSelect_RetDone
from OCP.IGESControl import IGESControl_Reader
from OCP.Interface import Interface_Static
from OCP.LocalAnalysis import LocalAnalysis_SurfaceContinuity
from OCP.ShapeFix import ShapeFix_Shape
from OCP.STEPControl import STEPControl_Reader
from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_FORWARD, TopAbs_REVERSED, TopAbs_SHELL
from OCP.TopExp import TopExp, TopExp_Explorer
from OCP.TopoDS import TopoDS, TopoDS_Shape

__all__ = [
    "CLASSES",
    "analyse_file",
    "analyse_shape",
    "diagonal_of",
    "edge_midpoints",
    "read_shape",
    "step_uncertainty",
    "tolerances_for",
]

#: The classes from weakest to strongest.
CLASSES = ("none", "G0", "G1", "G2", "G3")

#: LocalAnalysis' null-derivative threshold and the properties' resolution.
_EPS_NUL = 1e-12


# ----------------------------------------------------------------------------------------
# reading


@contextmanager
def _quiet():
    """The kernel's readers print banners on the C stdout: send fd 1 to /dev/null."""
    sys.stdout.flush()
    saved = os.dup(1)
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)
        os.close(null)


_SI_MM = {"$": 1000.0, ".KILO.": 1e6, ".CENTI.": 10.0, ".DECI.": 100.0, ".MILLI.": 1.0}
_SI_MM |= {".MICRO.": 1e-3, ".NANO.": 1e-6}
_NAMED_MM = {"INCH": 25.4, "FOOT": 304.8, "MILLIMETRE": 1.0, "METRE": 1000.0, "MM": 1.0}


def step_uncertainty(path: str | Path) -> float:
    """The largest length uncertainty a STEP file declares (UNCERTAINTY_MEASURE_WITH_UNIT
    with a LENGTH_MEASURE), in mm; 0 when none is found or its unit is not understood."""
    try:
        text = Path(path).read_bytes().decode("latin-1")
    except OSError:
        return 0.0
    worst = 0.0
    pattern = (
        r"UNCERTAINTY_MEASURE_WITH_UNIT\s*\(\s*LENGTH_MEASURE\s*\(\s*([-+.\dEe]+)\s*\)\s*,\s*#(\d+)"
    )
    for value, ref in re.findall(pattern, text, re.I):
        unit = re.search(r"#" + ref + r"\s*=\s*(.*?);", text, re.S)
        if unit is None:
            continue
        body = unit.group(1).upper()
        si = re.search(r"SI_UNIT\s*\(\s*([.$A-Z]+)\s*,\s*\.METRE\.", body)
        named = re.search(r"CONVERSION_BASED_UNIT\s*\(\s*'([A-Z]+)'", body)
        scale = _SI_MM.get(si.group(1)) if si else _NAMED_MM.get(named.group(1)) if named else None
        try:
            d = float(value) * scale if scale is not None else 0.0
        except ValueError:
            continue
        if math.isfinite(d):
            worst = max(worst, d)
    return worst


def faces_of(shape) -> list:
    """The shape's faces, in the order the kernel explores them."""
    out, explorer = [], TopExp_Explorer(shape, TopAbs_FACE)
    while explorer.More():
        out.append(TopoDS.Face(explorer.Current()))
        explorer.Next()
    return out


def _unsewn(shape) -> bool:
    """Faces in no shell, or a shell of one face among several shells."""
    if TopExp_Explorer(shape, TopAbs_FACE, TopAbs_SHELL).More():
        return True
    shells, explorer = [], TopExp_Explorer(shape, TopAbs_SHELL)
    while explorer.More():
        shells.append(len(faces_of(explorer.Current())))
        explorer.Next()
    return len(shells) > 1 and 1 in shells


def _invalid_count(shape) -> int:
    if BRepCheck_Analyzer(shape).IsValid():
        return 0
    return sum(not BRepCheck_Analyzer(f).IsValid() for f in faces_of(shape))


def read_shape(path: str | Path, heal: bool = True) -> tuple[TopoDS_Shape, dict]:
    """The file's shape (STEP and IGES in mm; BREP as it is), the faces of an IGES or STEP
    file with free faces sewn (BRepBuilderAPI_Sewing at max(1e-6 x diagonal, the largest
    edge tolerance); kept unless the sewing loses faces), and, with ``heal``, healed with
    ShapeFix_Shape only where the shape is invalid (kept only if fewer faces are invalid).
    Returns (shape, info): info has ``precision`` (the STEP file's declared uncertainty, mm,
    else 0), ``sewn``, ``healed``, ``faces``."""
    path = Path(path)
    ext = path.suffix.lower()
    info = {"file": path.name, "precision": 0.0, "sewn": False, "healed": False}
    with _quiet():
        if ext == ".brep":
            shape = TopoDS_Shape()
            if not BRepTools.Read_s(shape, str(path), BRep_Builder()):
                raise ValueError(f"{path}: BRepTools could not read it")
        else:
            if ext in (".step", ".stp"):
                reader = STEPControl_Reader()
                reader.SetSystemLengthUnit(1.0)
                info["precision"] = step_uncertainty(path)
            elif ext in (".iges", ".igs"):
                reader = IGESControl_Reader()
                Interface_Static.SetCVal_s("xstep.cascade.unit", "MM")
            else:
                raise ValueError(f"{path}: not a STEP, IGES or BREP file")
            if reader.ReadFile(str(path)) != IFSelect_RetDone:
                raise ValueError(f"{path}: the kernel could not read it")
            reader.TransferRoots()
            shape = reader.OneShape()
        count = len(faces_of(shape))
        if _unsewn(shape):  # free faces: sew
            largest = 0.0
            explorer = TopExp_Explorer(shape, TopAbs_EDGE)
            while explorer.More():
                largest = max(largest, BRep_Tool.Tolerance_s(TopoDS.Edge(explorer.Current())))
                explorer.Next()
            box = Bnd_Box()
            BRepBndLib.Add_s(shape, box, False)
            lo, hi = box.CornerMin(), box.CornerMax()
            diag = math.dist((lo.X(), lo.Y(), lo.Z()), (hi.X(), hi.Y(), hi.Z()))
            sewing = BRepBuilderAPI_Sewing(max(1e-6 * diag, largest, 1e-9))
            sewing.Add(shape)
            sewing.Perform()
            sewn = sewing.SewedShape()
            if not sewn.IsNull() and len(faces_of(sewn)) >= count:
                shape, info["sewn"] = sewn, True
        if heal:
            bad = _invalid_count(shape)
            if bad:
                fixer = ShapeFix_Shape(shape)
                fixer.Perform()
                healed = fixer.Shape()
                if not healed.IsNull() and faces_of(healed) and _invalid_count(healed) < bad:
                    shape, info["healed"] = healed, True
    info["faces"] = len(faces_of(shape))
    return shape, info


def diagonal_of(shape) -> float:
    """The diagonal of the shape's tight bounding box (exact geometry, no triangulation)."""
    box = Bnd_Box()
    BRepBndLib.AddOptimal_s(shape, box, False, False)
    lo, hi = box.CornerMin(), box.CornerMax()
    return math.dist((lo.X(), lo.Y(), lo.Z()), (hi.X(), hi.Y(), hi.Z()))


def tolerances_for(diagonal: float) -> dict:
    """gshade's default tolerances for a model of this size (docs/concepts/continuity.rst):
    gap, angle (degrees), curvature jump, curvature-gradient jump."""
    d = diagonal or 1.0
    return {"g0": 1e-7 * d, "g1": 1e-3, "g2": 1e-5 / d, "g3": 1e-4 / d**2}


# ----------------------------------------------------------------------------------------
# the edges


def _edge_faces(shape):
    """(edge number, edge, [(face number, face), ...]) for each non-degenerated edge; the
    faces it bounds other than as a seam, numbered in TopExp_Explorer order (first seen)."""
    face_map = ShapeMap()
    TopExp.MapShapes_s(shape, TopAbs_FACE, face_map)
    number: dict[int, int] = {}
    explorer, position = TopExp_Explorer(shape, TopAbs_FACE), 0
    while explorer.More():
        number.setdefault(face_map.FindIndex(explorer.Current()), position)
        explorer.Next()
        position += 1
    edge_faces = EdgeFaceMap()
    TopExp.MapShapesAndUniqueAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, edge_faces)
    for e in range(1, edge_faces.Extent() + 1):
        edge = TopoDS.Edge(edge_faces.FindKey(e))
        if BRep_Tool.Degenerated_s(edge):
            continue
        sharing = []
        for item in edge_faces.FindFromIndex(e):
            face = TopoDS.Face(item)
            f = number.get(face_map.FindIndex(face))
            if f is not None and not BRep_Tool.IsClosed_s(edge, face):
                sharing.append((f, face))
        yield e - 1, edge, sharing


def _midpoint(edge, face=None) -> list[float]:
    """The point halfway along the edge by arc length (so a reparametrised copy of the edge,
    as a NURBS conversion makes, has the same one): on its 3D curve, else on the face
    through its pcurve (at the parameter's middle)."""
    try:
        curve = BRepAdaptor_Curve(edge)
        t0, t1 = curve.FirstParameter(), curve.LastParameter()
        t = 0.5 * (t0 + t1)
        try:
            length = GCPnts_AbscissaPoint.Length_s(curve, t0, t1)
            half = GCPnts_AbscissaPoint(curve, 0.5 * length, t0)
            if half.IsDone():
                t = half.Parameter()
        except Exception:
            pass
        p = curve.Value(t)
    except Exception:
        if face is None:
            return [math.nan] * 3
        c2 = BRepAdaptor_Curve2d(edge, face)
        q = c2.Value(0.5 * (c2.FirstParameter() + c2.LastParameter()))
        p = BRepAdaptor_Surface(face).Value(q.X(), q.Y())
    return [p.X(), p.Y(), p.Z()]


def edge_midpoints(shape) -> list[dict]:
    """Every edge shared by two faces: {"edge", "faces", "midpoint"} (no measuring)."""
    out = []
    for e, edge, sharing in _edge_faces(shape):
        for a in range(len(sharing)):
            for b in range(a + 1, len(sharing)):
                if sharing[a][0] != sharing[b][0]:
                    faces = [sharing[a][0], sharing[b][0]]
                    out.append(
                        {"edge": e, "faces": faces, "midpoint": _midpoint(edge, sharing[a][1])}
                    )
    return out


def _vec(v) -> np.ndarray:
    return np.array([v.X(), v.Y(), v.Z()], dtype=float)


def _bspline_of(face):
    """The face's surface as a located Geom_BSplineSurface (under any rectangular trims), or
    None for other surfaces."""
    surface = BRep_Tool.Surface_s(face)
    while isinstance(surface, Geom_RectangularTrimmedSurface):
        surface = surface.BasisSurface()
    return surface if isinstance(surface, Geom_BSplineSurface) else None


def _knot_span(surface, direction: int, t: float, reach: float):
    """Where parameter t lies among the surface's distinct knots (1-based) in ``direction``
    (0: u, 1: v): the knot span (i, i + 1) the kernel's own evaluation takes there (the span
    after a knot at it), the interior knot t is on (``LocateU``'s tolerance ``reach``) or
    None, the knots' count, and the shift that brings t into the period of a periodic
    surface."""
    if direction == 0:
        locate, count, knot = surface.LocateU, surface.NbUKnots(), surface.UKnot
        periodic = surface.IsUPeriodic()
    else:
        locate, count, knot = surface.LocateV, surface.NbVKnots(), surface.VKnot
        periodic = surface.IsVPeriodic()
    shift = 0.0
    if periodic:
        first, period = knot(1), knot(count) - knot(1)
        shift = first + math.fmod(t - first, period) - t
        if t + shift < first:
            shift += period
    i1, i2 = locate(t + shift, 0.0, False)
    if i1 < 1:
        own = (1, 2)
    elif i2 > count:
        own = (count - 1, count)
    elif i1 == i2:
        own = (i1, i1 + 1) if i1 < count else (i1 - 1, i1)
    else:
        own = (i1, i2)
    j1, j2 = locate(t + shift, reach, False)
    on = j1 if j1 == j2 and 1 < j1 < count else None
    return own, on, shift


class _Side:
    """One face along one edge: its adaptor, orientation sign, and the geometry at the
    edge's samples.  Where the edge lies on an interior knot line of a B-spline face (every
    sample on the same knot, within ``reach`` of it in model units, the face on one side),
    the face is evaluated on the knot span on its side: a copy of its surface segmented to
    that span, continued where a sample lies a sliver beyond it.  (An edge that crosses a
    knot line has the face on both sides: its samples keep the kernel's spans.)"""

    def __init__(self, edge, face, fractions: np.ndarray, reach: float = 0.0):
        self.face = face
        self.sign = -1.0 if face.Orientation() == TopAbs_REVERSED else 1.0
        self.surface = BRepAdaptor_Surface(face)
        self.whole = BRep_Tool.Surface_s(face)
        curve = BRepAdaptor_Curve2d(edge, face)
        t0, t1 = curve.FirstParameter(), curve.LastParameter()
        self.uv = np.empty((len(fractions), 2))
        self.duv = np.empty((len(fractions), 2))  # d(u, v)/dt of the pcurve
        for k, s in enumerate(fractions.tolist()):
            p, d = gp_Pnt2d(), gp_Vec2d()
            curve.D1(t0 + s * (t1 - t0), p, d)
            self.uv[k] = p.X(), p.Y()
            self.duv[k] = d.X(), d.Y()
        # the material lies left of the pcurve (in the surface's own (u, v)) where the edge
        # is FORWARD in the FORWARD face, right of it where REVERSED
        self.left = 1.0
        explorer = TopExp_Explorer(face.Oriented(TopAbs_FORWARD), TopAbs_EDGE)
        while explorer.More():
            if explorer.Current().IsSame(edge):
                self.left = -1.0 if explorer.Current().Orientation() == TopAbs_REVERSED else 1.0
                break
            explorer.Next()
        # per sample: None (the adaptor) or (the span's piece, u shift, v shift)
        self.pieces: list = [None] * len(fractions)
        self.moved = 0
        bspline = _bspline_of(face)
        if bspline is None:
            return
        located = []  # per sample and direction: (own span, knot on or None, shift)
        for u, v in self.uv:
            pr = BRepLProp_SLProps(self.surface, u, v, 1, _EPS_NUL)
            row = []
            for d, (t, speed) in enumerate(((u, pr.D1U()), (v, pr.D1V()))):
                size = speed.Magnitude()
                row.append(_knot_span(bspline, d, t, reach / size if size > 0 else 0.0))
            located.append(row)
        into = np.sign(self.left * np.stack([-self.duv[:, 1], self.duv[:, 0]], axis=-1))
        spans: list[list] = [[row[d][0] for row in located] for d in (0, 1)]
        for d in (0, 1):
            knots = {row[d][1] for row in located}
            sides = set(into[:, d].tolist())
            if len(knots) == 1 and None not in knots and len(sides) == 1 and 0.0 not in sides:
                (j,) = knots
                spans[d] = [(j, j + 1) if sides == {1.0} else (j - 1, j)] * len(located)
                self.moved = len(located)
        if not self.moved:
            return
        cache: dict = {}
        for k, row in enumerate(located):
            key = (spans[0][k], spans[1][k])
            if key not in cache:
                piece = bspline.Copy()
                (a, b), (c, e) = key
                piece.Segment(
                    bspline.UKnot(a), bspline.UKnot(b), bspline.VKnot(c), bspline.VKnot(e)
                )
                cache[key] = piece
            self.pieces[k] = (cache[key], row[0][2], row[1][2])

    def props(self, u: float, v: float, k: int | None = None):
        """The local properties at (u, v), on sample k's knot span where it has its own."""
        piece = self.pieces[k] if k is not None else None
        if piece is None:
            return BRepLProp_SLProps(self.surface, u, v, 2, _EPS_NUL)
        surface, du, dv = piece
        return GeomLProp_SLProps(surface, u + du, v + dv, 2, _EPS_NUL)

    def geom(self, k: int):
        """The Geom surface sample k is evaluated on, and the shifts of its (u, v)."""
        piece = self.pieces[k]
        return (self.whole, 0.0, 0.0) if piece is None else piece

    def point(self, k: int) -> dict:
        """Point, outward normal, shape operator (3 x 3) at sample k."""
        u, v = self.uv[k]
        pr = self.props(u, v, k)
        out = {
            "p": _vec(pr.Value()),
            "n": None,
            "S": None,
            "pu": _vec(pr.D1U()),
            "pv": _vec(pr.D1V()),
        }
        if not pr.IsNormalDefined():
            return out
        n = self.sign * _vec(pr.Normal())
        out["n"] = n
        if pr.IsCurvatureDefined():
            kmax, kmin = self.sign * pr.MaxCurvature(), self.sign * pr.MinCurvature()
            if pr.IsUmbilic():
                k = 0.5 * (kmax + kmin)
                out["S"] = k * (np.eye(3) - np.outer(n, n))
            else:
                dmax, dmin = gp_Dir(), gp_Dir()
                pr.CurvatureDirections(dmax, dmin)
                a, b = _vec(dmax), _vec(dmin)
                out["S"] = kmax * np.outer(a, a) + kmin * np.outer(b, b)
        return out

    def _hk(self, u: float, v: float, k: int) -> tuple[float, float] | None:
        pr = self.props(u, v, k)
        if not (pr.IsNormalDefined() and pr.IsCurvatureDefined()):
            return None
        return self.sign * pr.MeanCurvature(), pr.GaussianCurvature()

    def inward(self, k: int, pu, pv) -> np.ndarray | None:
        """The unit 3D direction at sample k orthogonal to the edge, in the face's tangent
        plane, pointing into the face."""
        J = np.stack([pu, pv], axis=1)
        along = J @ self.duv[k]
        a = self.duv[k]
        into = J @ (self.left * np.array([-a[1], a[0]]))
        if not np.linalg.norm(along) > 0:
            return None
        along = along / np.linalg.norm(along)
        into = into - np.dot(into, along) * along
        size = np.linalg.norm(into)
        return into / size if size > 0 else None

    def gradients(self, k: int, step: float, pu, pv) -> tuple[np.ndarray, np.ndarray] | None:
        """The surface gradients of H and K at sample k (3-vectors), by finite differences
        with 3D steps of ``step`` and ``step / 2``, Richardson-extrapolated: central (4th
        order, then 6th) along the pcurve's tangent, one-sided (3rd order, then 4th) into
        the face across it."""
        u, v = self.uv[k]
        a = self.duv[k]
        J = np.stack([pu, pv], axis=1)  # 3 x 2
        speed = np.linalg.norm(J @ a)
        if not speed > 0:
            return None
        a = a / speed  # unit 3D speed along the edge
        b = self.left * np.array([-a[1], a[0]])  # into the face, in (u, v)
        sb = np.linalg.norm(J @ b)
        if not sb > 0:
            return None
        b = b / sb
        here = self._hk(u, v, k)
        if here is None:
            return None
        vals = {("b", 0, h): np.array(here) for h in (step, 0.5 * step)}
        for h in (step, 0.5 * step):
            for name, c in (("a", -2), ("a", -1), ("a", 1), ("a", 2), ("b", 1), ("b", 2), ("b", 3)):
                du, dv = c * h * (a if name == "a" else b)
                r = self._hk(u + du, v + dv, k)
                if r is None:
                    return None
                vals[(name, c, h)] = np.array(r)

        def along(h: float):  # fourth-order central along the edge
            f = [vals[("a", c, h)] for c in (-2, -1, 1, 2)]
            return (f[0] - 8 * f[1] + 8 * f[2] - f[3]) / (12 * h)

        def into(h: float):  # third-order one-sided into the face
            f = [vals[("b", c, h)] for c in (0, 1, 2, 3)]
            return (-11 * f[0] + 18 * f[1] - 9 * f[2] + 2 * f[3]) / (6 * h)

        # the truncation errors (h^4 and h^3) extrapolated away from the two steps
        da = (16 * along(0.5 * step) - along(step)) / 15
        db = (8 * into(0.5 * step) - into(step)) / 7
        # directional derivatives along (u, v) directions a and b -> (f_u, f_v)
        M = np.stack([a, b])  # rows: directions
        try:
            fuv = np.linalg.solve(M, np.stack([da, db]))  # 2 x 2: rows u, v; cols H, K
        except np.linalg.LinAlgError:
            return None
        G = J.T @ J
        grads = J @ np.linalg.solve(G, fuv)  # 3 x 2
        return grads[:, 0], grads[:, 1]


def _angle(n1: np.ndarray, n2: np.ndarray) -> float:
    """The oriented angle between two unit vectors, degrees (atan2: accurate near 0, 180)."""
    return math.degrees(math.atan2(np.linalg.norm(np.cross(n1, n2)), float(np.dot(n1, n2))))


def _jump(S1: np.ndarray, S2: np.ndarray, n1: np.ndarray, n2: np.ndarray) -> float:
    """The largest |eigenvalue| of S1 - S2 on the plane orthogonal to the mean normal."""
    m = n1 + n2
    m = m / np.linalg.norm(m) if np.linalg.norm(m) > 1e-8 else n1
    seed = np.eye(3)[int(np.argmin(np.abs(m)))]
    e1 = np.cross(m, seed)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(m, e1)
    P = np.stack([e1, e2], axis=1)
    D = P.T @ (S1 - S2) @ P
    D = 0.5 * (D + D.T)
    return float(np.abs(np.linalg.eigvalsh(D)).max())


def _oriented_surface(side: _Side, k: int, cache: dict):
    """The Geom surface sample k of a side is evaluated on (the face's, or its knot span's
    piece), with its normal outward (a reversed face's surface u-reversed), and the sample's
    (u, v) on it."""
    surface, du, dv = side.geom(k)
    u, v = side.uv[k]
    if side.face.Orientation() != TopAbs_REVERSED:
        return surface, u + du, v + dv
    if id(surface) not in cache:
        cache[id(surface)] = (surface, surface.UReversed())  # the first keeps the id alive
    return cache[id(surface)][1], surface.UReversedParameter(u + du), v + dv


def _local_analysis(s1: _Side, s2: _Side, eps_c0: float, diagonal: float) -> dict:
    """LocalAnalysis_SurfaceContinuity at every sample: the weakest class, the largest
    C0Value, G1Angle (degrees) and G2CurvatureGap, and the samples it could not analyse."""
    eps_g1 = math.radians(1e-3)
    worst, c0, g1, g2, failed = 4, 0.0, 0.0, 0.0, 0
    cache: dict = {}
    for k in range(len(s1.uv)):
        surf1, u1, v1 = _oriented_surface(s1, k, cache)
        surf2, u2, v2 = _oriented_surface(s2, k, cache)
        try:
            la = LocalAnalysis_SurfaceContinuity(
                surf1,
                u1,
                v1,
                surf2,
                u2,
                v2,
                GeomAbs_Shape.GeomAbs_G2,
                _EPS_NUL,
                eps_c0,
                1e-3,
                1e-3,
                eps_g1,
                0.01,
                diagonal,
            )
            if not la.IsDone():
                raise RuntimeError("not done")
            c0 = max(c0, la.C0Value())
            g1 = max(g1, math.degrees(la.G1Angle()))
            g2 = max(g2, la.G2CurvatureGap())
            level = 3 if la.IsG2() else 2 if la.IsG1() else 1 if la.IsC0() else 0
        except Exception:
            failed += 1
            try:  # at least G1
                la = LocalAnalysis_SurfaceContinuity(
                    surf1,
                    u1,
                    v1,
                    surf2,
                    u2,
                    v2,
                    GeomAbs_Shape.GeomAbs_G1,
                    _EPS_NUL,
                    eps_c0,
                    1e-3,
                    1e-3,
                    eps_g1,
                    0.01,
                    diagonal,
                )
                c0 = max(c0, la.C0Value())
                g1 = max(g1, math.degrees(la.G1Angle()))
                level = 2 if la.IsG1() else 1 if la.IsC0() else 0
            except Exception:
                continue
        worst = min(worst, level)
    return {
        "la_class": CLASSES[min(worst, 3)] if failed < len(s1.uv) or worst < 4 else None,
        "la_c0_value": c0,
        "la_g1_angle_deg": g1,
        "la_g2_curvature_gap": g2,
        "la_failed_samples": failed,
    }


def _classify(m: dict, tol: dict, g0: float) -> str:
    if not m["gap"] <= g0:
        return "none"
    if not m["normal_angle_deg"] <= tol["g1"]:
        return "G0"
    if not m["curvature_jump"] <= tol["g2"]:
        return "G1"
    if not m["curvature_gradient_jump"] <= tol["g3"]:
        return "G2"
    return "G3"


def _measure(edge, f1, f2, samples: int, diagonal: float, tol: dict, precision: float, la: bool):
    fractions = (np.arange(samples) + 0.5) / samples
    tolerance = float(BRep_Tool.Tolerance_s(edge))
    reach = max(tolerance, precision)  # the faces' points lie within this of the edge
    s1, s2 = _Side(edge, f1[1], fractions, reach), _Side(edge, f2[1], fractions, reach)
    gap = angle = jump = gradient = 0.0
    undefined = 0
    pts, geometry = [], []
    for k in range(samples):
        a, b = s1.point(k), s2.point(k)
        geometry.append((a, b))
        pts.append(a["p"])
        gap = max(gap, float(np.linalg.norm(a["p"] - b["p"])))
        if a["n"] is None or b["n"] is None:
            undefined += 1
            continue
        angle = max(angle, _angle(a["n"], b["n"]))
        if a["S"] is not None and b["S"] is not None:
            jump = max(jump, _jump(a["S"], b["S"], a["n"], b["n"]))
        else:
            undefined += 1
    length = (
        float(sum(np.linalg.norm(np.diff(np.array(pts), axis=0), axis=1))) if samples > 1 else 0.0
    )
    step = min(max(1e-3 * length, 1e-6 * diagonal), 1e-4 * diagonal) if diagonal > 0 else 1e-6
    dots, runs = [], []
    for k, (a, b) in enumerate(geometry):
        t1, t2 = s1.inward(k, a["pu"], a["pv"]), s2.inward(k, b["pu"], b["pv"])
        if t1 is not None and t2 is not None:
            dots.append(float(np.dot(t1, t2)))
            if a["n"] is not None and b["n"] is not None:
                # each face's boundary runs along the edge as t = inward x outward normal
                # (the face on its left, seen from outside): opposite ways where the
                # orientations agree, whatever the angle
                runs.append(float(np.dot(np.cross(t1, a["n"]), np.cross(t2, b["n"]))))
        g1 = s1.gradients(k, step, a["pu"], a["pv"])
        g2 = s2.gradients(k, step, b["pu"], b["pv"])
        if g1 is None or g2 is None:
            continue
        gradient = max(
            gradient, float(np.linalg.norm(g1[0] - g2[0])), float(np.linalg.norm(g1[1] - g2[1]))
        )
    g0 = max(tol["g0"], 2.0 * max(tolerance, precision))
    row = {
        "edge": None,
        "faces": [f1[0], f2[0]],
        "gap": gap,
        "normal_angle_deg": angle,
        "curvature_jump": jump,
        "curvature_gradient_jump": gradient,
        "edge_tolerance": tolerance,
        "g0_tolerance": g0,
        "undefined_samples": undefined,
        # the faces' directions into themselves across the edge: -1 where they continue
        # each other (a smooth junction, or faces whose orientations disagree when the
        # normals are opposite), +1 where they lie on the same side (a fold or cusp)
        "inward_dot": float(np.mean(dots)) if dots else None,
        # "inconsistent": both faces' boundaries run the edge the same way (one face's
        # outward normal is the other's inward one); None without normals and directions
        "orientation": (
            None if not runs else "inconsistent" if np.mean(runs) > 0 else "consistent"
        ),
        # samples evaluated on the knot span on the face's side instead of the kernel's
        "inside_span_samples": [s1.moved, s2.moved],
        "samples": samples,
        "length": length,
    }
    row["class"] = _classify(row, tol, g0)
    if la:
        row.update(_local_analysis(s1, s2, g0, diagonal))
    return row


def analyse_shape(
    shape,
    samples: int = 32,
    precision: float = 0.0,
    diagonal: float | None = None,
    local_analysis: bool = True,
) -> dict:
    """Every edge between two faces of the shape, measured and classed (see the module):
    {"diagonal", "tolerances", "edges": [row, ...]}; a row has "edge", "faces", "class",
    "la_class", the four measures, the LocalAnalysis values, "midpoint", "g0_tolerance"."""
    diagonal = diagonal_of(shape) if diagonal is None else diagonal
    tol = tolerances_for(diagonal)
    rows = []
    for e, edge, sharing in _edge_faces(shape):
        for a in range(len(sharing)):
            for b in range(a + 1, len(sharing)):
                if sharing[a][0] == sharing[b][0]:
                    continue
                try:
                    row = _measure(
                        edge,
                        sharing[a],
                        sharing[b],
                        samples,
                        diagonal,
                        tol,
                        precision,
                        local_analysis,
                    )
                except Exception as exc:  # the kernel failed on this edge
                    row = {
                        "faces": [sharing[a][0], sharing[b][0]],
                        "class": None,
                        "error": f"{type(exc).__name__}: {exc}",
                    }
                row["edge"] = e
                row["midpoint"] = _midpoint(edge, sharing[a][1])
                rows.append(row)
    return {"diagonal": diagonal, "precision": precision, "tolerances": tol, "edges": rows}


def analyse_file(path: str | Path, samples: int = 32, local_analysis: bool = True) -> dict:
    """:func:`analyse_shape` of the file's shape (:func:`read_shape`), with its read info."""
    shape, info = read_shape(path)
    out = analyse_shape(shape, samples, info["precision"], local_analysis=local_analysis)
    out["read"] = info
    return out


if __name__ == "__main__":  # python tests/support/kernel_oracle.py FILE [SAMPLES]
    import json

    result = analyse_file(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 32)
    print(json.dumps(result, indent=1))
