"""An Open CASCADE B-rep for a Rhino ``.3dm`` model, built from openNURBS's own topology.

rhino3dm gives each Brep's faces (exact NURBS surfaces), edges (exact 3D NURBS curves),
vertices and loops of trims (edge index, sense, end vertices), but no 2D trimming curves.
:mod:`gshade.cad.rhino` recovers each trim in the face's (u, v) by point inversion, at the
edge curve's own parameters t_k; here the kernel's shape is assembled from those pieces,
with the file's topology, so that it needs no sewing:

- one ``Geom_BSplineSurface`` per face from its :class:`BSplinePatch` (the same poles,
  weights, knots and multiplicities: exact);
- one ``TopoDS_Vertex`` per Brep vertex and one ``TopoDS_Edge`` per Brep edge, on the edge's
  exact NURBS curve C(t) (or, where openNURBS's NURBS form does not match the edge's
  parametrisation within 1e-9 of its size, a cubic interpolating the edge's samples);
- on every face that uses an edge, a pcurve c(t) that traces the face's point nearest C(t)
  to 1e-12 of the model (:mod:`gshade.cad.rhino_pcurves`, all faces' trims at once, started
  from the recovered (u_k, v_k)), two of them on a seam; where that fit fails, the cubic
  B-spline that interpolates the (u_k, v_k) at the same t_k (``Geom2dAPI_Interpolate``; a
  polyline if that fails); singular trims at poles become degenerated edges on the segment
  between their neighbours' ends;
- wires in the trims' order and sense, faces reversed where the Brep face is, one shell per
  Brep; a fitted edge keeps its pcurves (same parameter, its tolerance 1.5 times the
  largest |S(c(t)) - C(t)| measured on them: the faces' own distance from the edge), the
  others are fitted by ``BRepLib.SameParameter``, which sets their tolerances from the
  measured deviation.

Faces come out in the model's order (checked): an edge shared by two faces is one
``TopoDS_Edge`` in both, as the watertight mesher and the continuity along edges need.
Free surface objects become untrimmed faces over their whole domain.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray
from OCP.BRep import BRep_Builder
from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
from OCP.BRepLib import BRepLib
from OCP.collections import (
    Array1_double,
    Array1_gp_Pnt,
    Array1_gp_Pnt2d,
    Array1_int,
    Array2_double,
    Array2_gp_Pnt,
    HArray1_double,
    HArray1_gp_Pnt,
    HArray1_gp_Pnt2d,
)
from OCP.Geom import Geom_BSplineCurve, Geom_BSplineSurface
from OCP.Geom2d import Geom2d_BSplineCurve
from OCP.Geom2dAPI import Geom2dAPI_Interpolate
from OCP.GeomAPI import GeomAPI_Interpolate
from OCP.gp import gp_Pnt, gp_Pnt2d
from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import (
    TopoDS_Compound,
    TopoDS_Edge,
    TopoDS_Face,
    TopoDS_Shell,
    TopoDS_Vertex,
    TopoDS_Wire,
)

from ..errors import GshadeError
from ..geometry.patches.bspline import BSplinePatch
from ..runtime.native import captured_output
from . import rhino_pcurves as pc
from .kernel import exception_text, shape_faces
from .model import CadFace, LeftOutFace
from .rhino_trims import BrepPart, Trim

if TYPE_CHECKING:
    from collections.abc import Callable

__all__ = ["build_brep"]

#: Starting tolerance of edges and vertices, relative to the model's size (SameParameter
#: raises it to the measured deviation).
_START_TOLERANCE = 1e-7
#: openNURBS's NURBS form of an edge is used when it matches the edge's samples within this
#: fraction of the model's size.
_CURVE_MATCH = 1e-9
#: An edge's tolerance over the largest |S(c(t)) - C(t)| measured on its fitted pcurves.
_MARGIN = 1.5


def build_brep(
    path: Path, faces: list[CadFace], parts: list[BrepPart | int]
) -> tuple[Any, list[int], list[LeftOutFace]]:
    """The model's faces as one compound of shells (a Brep each) and free faces.

    Parameters
    ----------
    path : Path
        The file, for messages.
    faces : list of CadFace
        The model's faces, in the order of their numbers.
    parts : list
        In the file's order: a :class:`BrepPart`, or the number of a free surface's face.

    Returns
    -------
    shape, built, left_out
        The compound; the numbers of its faces, in its order; the faces the kernel could not
        build (:class:`gshade.cad.LeftOutFace`), left out of it.

    Raises
    ------
    GshadeError
        One line naming the file where the kernel fails on the whole.
    """
    lo = np.min([f.patch.points.reshape(-1, 3).min(axis=0) for f in faces], axis=0)
    hi = np.max([f.patch.points.reshape(-1, 3).max(axis=0) for f in faces], axis=0)
    tol = _START_TOLERANCE * max(float(np.linalg.norm(hi - lo)), 1e-9)
    builder = BRep_Builder()
    compound = TopoDS_Compound()
    builder.MakeCompound(compound)
    by_number = {face.index: face for face in faces}
    built: list[Any] = []
    numbers: list[int] = []
    left_out: list[LeftOutFace] = []
    breps = {
        id(part): _BrepFaces(part, by_number, builder, tol)
        for part in parts
        if not isinstance(part, int)
    }
    jobs = [job for brep in breps.values() for job in brep.prepare()]
    fitted = _fit(jobs, tol / _START_TOLERANCE)
    for part in parts:
        if isinstance(part, int):
            try:
                face = _free_face(by_number[part], tol)
            except Exception as exc:
                left_out.append(
                    LeftOutFace(part, f"the kernel failed ({exception_text(exc)})", _BUILDING)
                )
                continue
            builder.Add(compound, face)
            built.append(face)
            numbers.append(part)
            continue
        shell = TopoDS_Shell()
        builder.MakeShell(shell)
        made, lost = breps[id(part)].finish(fitted)
        for number, face in made:
            builder.Add(shell, face)
            built.append(face)
            numbers.append(number)
        left_out.extend(lost)
        builder.Add(compound, shell)
    try:
        with captured_output():
            BRepLib.SameParameter_s(compound, tol, False)
            BRepLib.UpdateTolerances_s(compound, False)
    except Exception as exc:
        raise GshadeError(
            f"{path}: the kernel could not fit the trims ({exception_text(exc)})"
        ) from None

    order = shape_faces(compound)
    if len(order) != len(built) or not all(a.IsSame(b) for a, b in zip(order, built, strict=True)):
        raise GshadeError(f"{path}: the kernel's shape lost the order of the faces")
    return compound, numbers, left_out


#: What was tried on a face the kernel could not build.
_BUILDING = "building it on the kernel from its surface and trims"


def _knots(full: NDArray[np.float64]) -> tuple[Any, Any]:
    """A full knot sequence as OCCT's distinct knots and multiplicities."""
    values, counts = np.unique(full, return_counts=True)
    knots = Array1_double(1, len(values))
    mults = Array1_int(1, len(values))
    for i, (k, m) in enumerate(zip(values, counts, strict=True)):
        knots.SetValue(i + 1, float(k))
        mults.SetValue(i + 1, int(m))
    return knots, mults


def surface(patch: BSplinePatch) -> Any:
    """The patch as a ``Geom_BSplineSurface``: the same poles, weights, knots (exact)."""
    nu, nv = patch.points.shape[:2]
    poles = Array2_gp_Pnt(1, nu, 1, nv)
    for i in range(nu):
        for j in range(nv):
            poles.SetValue(i + 1, j + 1, gp_Pnt(*map(float, patch.points[i, j])))
    ku, mu = _knots(np.asarray(patch.knots[0], dtype=float))
    kv, mv = _knots(np.asarray(patch.knots[1], dtype=float))
    p, q = patch.degree
    if patch.weights is None:
        return Geom_BSplineSurface(poles, ku, kv, mu, mv, p, q, False, False)
    weights = Array2_double(1, nu, 1, nv)
    for i in range(nu):
        for j in range(nv):
            weights.SetValue(i + 1, j + 1, float(patch.weights[i, j]))
    return Geom_BSplineSurface(poles, weights, ku, kv, mu, mv, p, q, False, False)


def _free_face(face: CadFace, tol: float) -> Any:
    """An untrimmed face over the patch's whole domain."""
    (u0, u1), (v0, v1) = face.patch.domain
    out = BRepBuilderAPI_MakeFace(surface(face.patch), u0, u1, v0, v1, tol).Face()
    return out.Reversed() if face.reversed else out


def _edge_curve(nurbs: Any, t: NDArray[np.float64], xyz: NDArray[np.float64], tol: float) -> Any:
    """The edge's NURBS form as a ``Geom_BSplineCurve`` when it matches the samples (the
    edge's own parametrisation), else the cubic interpolating them at their parameters."""
    try:
        n, p = len(nurbs.Points), int(nurbs.Order) - 1
        h = np.array([[c.X, c.Y, c.Z, c.W] for c in (nurbs.Points[i] for i in range(n))])
        k = np.asarray(nurbs.Knots.ToList(), dtype=float)
        full = np.concatenate([k[:1], k, k[-1:]])
        knots, mults = _knots(full)
        poles = Array1_gp_Pnt(1, n)
        rational = bool(nurbs.IsRational)
        xyz_h = h[:, :3] / h[:, 3:] if rational else h[:, :3]
        for i in range(n):
            poles.SetValue(i + 1, gp_Pnt(*map(float, xyz_h[i])))
        if rational:
            w = Array1_double(1, n)
            for i in range(n):
                w.SetValue(i + 1, float(h[i, 3]))
            curve = Geom_BSplineCurve(poles, w, knots, mults, p, False)
        else:
            curve = Geom_BSplineCurve(poles, knots, mults, p, False)
        at = np.array([[q.X(), q.Y(), q.Z()] for q in (curve.Value(float(s)) for s in t)])
        if np.abs(at - xyz).max() <= tol:
            return curve
    except Exception:  # an unusable NURBS form: interpolate the samples instead
        pass
    points = HArray1_gp_Pnt(1, len(t))
    params = HArray1_double(1, len(t))
    for i, (s, q) in enumerate(zip(t, xyz, strict=True)):
        points.SetValue(i + 1, gp_Pnt(*map(float, q)))
        params.SetValue(i + 1, float(s))
    fit = GeomAPI_Interpolate(points, params, False, 1e-12)
    fit.Perform()
    return fit.Curve()


def _pcurve(t: NDArray[np.float64], uv: NDArray[np.float64]) -> Any:
    """The cubic through (u_k, v_k) at t_k (``Geom2dAPI_Interpolate``), or the polyline
    (degree 1, knots t_k) where the interpolation fails."""
    n = len(t)
    if n >= 3:
        try:
            points = HArray1_gp_Pnt2d(1, n)
            params = HArray1_double(1, n)
            for i in range(n):
                points.SetValue(i + 1, gp_Pnt2d(float(uv[i, 0]), float(uv[i, 1])))
                params.SetValue(i + 1, float(t[i]))
            fit = Geom2dAPI_Interpolate(points, params, False, 1e-14)
            fit.Perform()
            if fit.IsDone():
                return fit.Curve()
        except Exception:  # confused points: the polyline below
            pass
    poles = Array1_gp_Pnt2d(1, n)
    for i in range(n):
        poles.SetValue(i + 1, gp_Pnt2d(float(uv[i, 0]), float(uv[i, 1])))
    knots = Array1_double(1, n)
    mults = Array1_int(1, n)
    for i in range(n):
        knots.SetValue(i + 1, float(t[i]))
        mults.SetValue(i + 1, 2 if i in (0, n - 1) else 1)
    return Geom2d_BSplineCurve(poles, knots, mults, 1, False)


class _BrepFaces:
    """A Brep's faces on the kernel, sharing their vertices and edges: the edges made first
    (:meth:`prepare`, which hands out the pcurves to fit), the faces once the pcurves are
    fitted (:meth:`finish`)."""

    def __init__(self, part: BrepPart, faces: dict[int, CadFace], builder: Any, tol: float):
        self.part, self.faces, self.builder, self.tol = part, faces, builder, tol
        self.match = _CURVE_MATCH / _START_TOLERANCE * tol
        self.vertices: dict[int, Any] = {}
        self.edges: dict[int, Any] = {}
        self.ranges: dict[int, tuple[float, float]] = {}
        self.curves: dict[int, Any] = {}
        self.ready: list[tuple[int, list[list[Trim]], list[Trim]]] = []
        self.left_out: list[LeftOutFace] = []

    def vertex(self, k: int) -> Any:
        if k not in self.vertices:
            loc = self.part.brep.Vertices[k].Location
            v = TopoDS_Vertex()
            self.builder.MakeVertex(v, gp_Pnt(loc.X, loc.Y, loc.Z), self.tol)
            self.vertices[k] = v
        return self.vertices[k]

    def edge(self, trim: Trim) -> Any:
        k = trim.edge
        if k not in self.edges:
            t, xyz = self.part.samples[k]
            curve = _edge_curve(self.part.brep.Edges[k].ToNurbsCurve(), t, xyz, self.match)
            e = TopoDS_Edge()
            self.builder.MakeEdge(e, curve, self.tol)
            start, end = trim.vertices[::-1] if trim.reversed else trim.vertices
            self.builder.Add(e, self.vertex(start).Oriented(TopAbs_FORWARD))
            self.builder.Add(e, self.vertex(end).Oriented(TopAbs_REVERSED))
            self.builder.Range(e, float(t[0]), float(t[-1]))
            self.edges[k] = e
            self.curves[k] = curve
            self.ranges[k] = (float(t[0]), float(t[-1]))
        return self.edges[k]

    def prepare(self) -> list[tuple[Any, list[tuple[Trim, Any]]]]:
        """Make the edges, face by face (a face whose edges the kernel cannot make is left
        out); the pcurves to fit: per face, its patch and the trims that need one (a seam's
        both, else an edge's first), of at least two samples."""
        jobs = []
        for index, loops in self.part.faces:
            try:
                needed = _needed(loops, self.edge)
            except Exception as exc:
                self.left_out.append(_left_out(index, exc))
                continue
            self.ready.append((index, loops, needed))
            trims = [(x, self.curves[x.edge]) for x in needed if len(x.t) >= 2]
            jobs.append((self.faces[index].patch, trims))
        return jobs

    def finish(self, fitted: dict[int, Any]) -> tuple[list[tuple[int, Any]], list[LeftOutFace]]:
        """The faces, (number, face) each, on the pcurves ``fitted`` (by ``id`` of the trim:
        :class:`.rhino_pcurves.Pcurve`; the others the samples' cubics); and those the
        kernel could not build, left out.  A fitted edge's tolerance is the largest distance
        measured between its pcurves' images and its curve (no SameParameter refit)."""
        apart: dict[int, float] = {}  # the edge's measured |S(c(t)) - C(t)|
        unfitted: set[int] = set()
        out = []
        for index, loops, needed in self.ready:
            pcurves = {}
            for trim in needed:
                fit = fitted.get(id(trim))
                if fit is None:
                    unfitted.add(trim.edge)
                    pcurves[id(trim)] = _pcurve(trim.t, trim.uv)
                else:
                    apart[trim.edge] = max(apart.get(trim.edge, 0.0), fit.apart)
                    pcurves[id(trim)] = fit.curve
            try:
                face = _face(
                    self.faces[index],
                    loops,
                    self.builder,
                    self.tol,
                    self.edge,
                    self.vertex,
                    pcurves,
                )
                out.append((index, face))
            except Exception as exc:
                self.left_out.append(_left_out(index, exc))
        for k, e in self.edges.items():
            self.builder.Range(e, *self.ranges[k])
            if k in unfitted or k not in apart:  # the kernel fits these
                self.builder.SameParameter(e, False)
            else:  # the pcurves trace the edge: its tolerance is their measured distance
                self.builder.UpdateEdge(e, max(self.tol, _MARGIN * apart[k]))
                self.builder.SameParameter(e, True)
                self.builder.SameRange(e, True)
        return out, self.left_out


def _left_out(index: int, exc: Exception) -> LeftOutFace:
    if isinstance(exc, GshadeError):
        return LeftOutFace(index, str(exc), _BUILDING)
    return LeftOutFace(index, f"the kernel failed ({exception_text(exc)})", _BUILDING)


def _fit(jobs: list[tuple[Any, list[tuple[Trim, Any]]]], size: float) -> dict[int, Any]:
    """The pcurves of the jobs' trims (:func:`.rhino_pcurves.fit_faces`: all faces at
    once; where that fails, face by face; a face the fit cannot do is left to the samples'
    cubics), by ``id`` of the trim."""
    out: dict[int, Any] = {}

    def run(some: list[tuple[Any, list[tuple[Trim, Any]]]]) -> None:
        faces = [(patch, [(c, x.t, x.uv) for x, c in trims]) for patch, trims in some]
        for (_, trims), fits in zip(some, pc.fit_faces(faces, size), strict=True):
            out.update((id(x), fit) for (x, _), fit in zip(trims, fits, strict=True))

    jobs = [job for job in jobs if job[1]]
    try:
        run(jobs)
    except Exception:  # find the faces it fails on
        for job in jobs:
            try:
                run([job])
            except Exception:  # this face's trims: the samples' cubics
                pass
    return out


def _needed(loops: list[list[Trim]], edge: Callable[[Trim], Any]) -> list[Trim]:
    """The trims of a face that need a pcurve (a seam's both, the forward one first, else
    an edge's first), their edges made (``edge``: the kernel edge of a trim)."""
    seams: dict[int, list[Trim]] = {}
    for loop in loops:
        for trim in loop:
            if trim.edge >= 0:
                seams.setdefault(trim.edge, []).append(trim)
    needed = []
    for uses in seams.values():
        edge(uses[0])
        seam = len(uses) == 2 and uses[0].reversed != uses[1].reversed
        needed.extend(uses if seam else uses[:1])
    return needed


def _face(
    cad: CadFace,
    loops: list[list[Trim]],
    builder: Any,
    tol: float,
    edge: Callable[[Trim], Any],
    vertex: Callable[[int], Any],
    pcurve: dict[int, Any],
) -> Any:
    """One face on its exact surface, bounded by wires of the shared edges (``pcurve``: the
    pcurves of the trims that need one, by ``id``)."""
    face = TopoDS_Face()
    builder.MakeFace(face, surface(cad.patch), TopLoc_Location(), tol)
    seams: dict[int, list[Trim]] = {}
    for loop in loops:
        for trim in loop:
            if trim.edge >= 0:
                seams.setdefault(trim.edge, []).append(trim)
    for loop in loops:
        wire = TopoDS_Wire()
        builder.MakeWire(wire)
        for trim in loop:
            if trim.edge < 0:
                e = _degenerated(trim, builder, tol, vertex)
                t, uv = _segment(trim.uv)
                builder.UpdateEdge(e, _pcurve(t, uv), face, tol)
                builder.Range(e, float(t[0]), float(t[1]))
                builder.Add(wire, e.Oriented(TopAbs_FORWARD))
                continue
            else:
                e = edge(trim)
                uses = seams[trim.edge]
                if len(uses) == 2 and uses[0].reversed != uses[1].reversed:
                    if trim is uses[0]:  # a seam: both pcurves at once, the forward one first
                        fwd, rev = (uses[1], uses[0]) if uses[0].reversed else uses
                        builder.UpdateEdge(e, pcurve[id(fwd)], pcurve[id(rev)], face, tol)
                elif trim is uses[0]:
                    builder.UpdateEdge(e, pcurve[id(trim)], face, tol)
            builder.Add(wire, e.Oriented(TopAbs_REVERSED if trim.reversed else TopAbs_FORWARD))
        builder.Add(face, wire)
    return face.Reversed() if cad.reversed else face


def _segment(ends: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A straight segment between two (u, v) points, parametrised by arc length."""
    length = float(np.linalg.norm(ends[1] - ends[0])) or 1e-12
    return np.array([0.0, length]), ends[:2]


def _degenerated(trim: Trim, builder: Any, tol: float, vertex: Callable[[int], Any]) -> Any:
    """A degenerated edge (a pole) at the trim's vertex."""
    e = TopoDS_Edge()
    builder.MakeEdge(e)
    v = vertex(trim.vertices[0])
    builder.Add(e, v.Oriented(TopAbs_FORWARD))
    builder.Add(e, v.Oriented(TopAbs_REVERSED))
    builder.Degenerated(e, True)
    return e
