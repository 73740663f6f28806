"""The B-rep edges of a CAD model where two faces meet, as points on both faces' parameters.

An edge of a sewn B-rep carries one parameter t and, on each face it bounds, a parameter
curve (pcurve) c_f(t) in that face's (u, v); the kernel keeps them "same parameter", so
S_f(c_f(t)) and S_g(c_g(t)) are the same point of the edge up to the edge's tolerance.
Sampling both pcurves at the same t therefore pairs the points of the two faces along the
edge, which is what continuity across the edge is measured on
(:mod:`gshade.analysis.edge_continuity`) and what junction lines are drawn along.

Each sample also carries the direction into the face across the edge, in the face's
(u, v) (the side where the face's material lies), and each pair of faces whether their
orientations agree along the edge (:attr:`CadEdge.consistent`).

Not junctions: seams (an edge bounding one face twice, as on a periodic face), degenerate
edges (a pole), free edges (one face).  An edge shared by more than two faces (non-manifold)
gives every pair.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from .model import CadModel
from .process import kernel_operation

__all__ = ["CadEdge", "edge_derivatives", "edge_ranges", "edges_to_left_out", "shared_edges"]


@dataclass
class CadEdge:
    """An edge where two faces meet, sampled at the same edge parameters on both.

    Attributes
    ----------
    index : int
        The edge's number in the model (0-based, in the kernel's map of edges).
    faces : (int, int)
        The two faces' numbers in the model.
    uv : (ndarray (n, 2), ndarray (n, 2))
        The points on each face's pcurve, in that face's (u, v), at the same n parameters
        t_k = t0 + (k + 1/2) / n (t1 - t0) along the edge.
    tolerance : float
        The kernel's tolerance of the edge (model units): how far the two faces' points
        may lie apart in a valid B-rep.
    inward : (ndarray (n, 2), ndarray (n, 2))
        At each point, a direction in each face's (u, v) across its pcurve toward the side
        where the face lies (the pcurve's tangent turned a quarter; not of unit length;
        zero where unknown): the face's material is left of its boundary run as the face
        runs it, seen from its outward normal.  In the kernel's parameters; a patch's
        parameters (:meth:`gshade.cad.CadFace.to_patch`) increase with them, so the
        signs of the components hold there too.
    consistent : bool or None
        Whether the two faces' orientations agree across the edge: their boundaries run
        along it in opposite directions, as in any consistently oriented shell.  False
        where both run it the same way (one face's outward normal points to the inside
        of the other's); None where a face holds the edge more than once.
    """

    index: int
    faces: tuple[int, int]
    uv: tuple[NDArray[np.float64], NDArray[np.float64]]
    tolerance: float
    inward: tuple[NDArray[np.float64], NDArray[np.float64]]
    consistent: bool | None


@kernel_operation("sampling its edges")
def shared_edges(
    model: CadModel, samples: int = 32, faces: list[int] | None = None
) -> list[CadEdge]:
    """Every edge shared by two of the model's faces (of ``faces``, default all), sampled
    at ``samples`` parameters along it on both faces' pcurves.

    Raises
    ------
    GshadeError
        One line naming the file: a model without a kernel shape, or an edge whose
        parameter curves the kernel cannot evaluate.
    """
    if model.brep is None:
        raise GshadeError(f"{model.path}: the model has no kernel shape to find edges in")
    try:
        return _shared_edges(model, samples, faces)
    except GshadeError:
        raise
    except Exception as exc:
        raise GshadeError(
            f"{model.path}: the kernel failed on the edges' parameter curves ({exc})"
        ) from None


@kernel_operation("finding its edges")
def edges_to_left_out(
    model: CadModel, faces: list[int], left_out: list[int]
) -> list[tuple[int, int, int]]:
    """The edges between one of the faces ``faces`` and one of the faces ``left_out`` (both
    numbered as the model's): (edge number, face, left-out face) each, in the numbering of
    :func:`shared_edges`."""
    if model.brep is None or not left_out:
        return []
    wanted, lost = set(faces), set(left_out)
    out: list[tuple[int, int, int]] = []
    for e, _, sharing in _edge_faces(model):
        numbers = sorted({f for f, *_ in sharing})
        out.extend((e, i, j) for i in numbers if i in wanted for j in numbers if j in lost)
    return out


def _edge_faces(model: CadModel) -> Iterator[tuple[int, Any, list[tuple[int, Any, Any]]]]:
    """Each edge of the model's shape that is no pole: its number (0-based, in the kernel's
    map of edges), the edge, and the faces it bounds other than as a seam, (number, face,
    sense) with sense the edge's orientation in the face as the shape holds it (None where
    the face holds the edge more than once)."""
    from OCP.BRep import BRep_Tool
    from OCP.collections import (
        IndexedDataMap_TopoDS_Shape_List_TopoDS_Shape_TopTools_ShapeMapHasher as EdgeFaces,
    )
    from OCP.collections import IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher as ShapeMap
    from OCP.TopAbs import TopAbs_EDGE as EDGE
    from OCP.TopAbs import TopAbs_FACE as FACE
    from OCP.TopExp import TopExp, TopExp_Explorer
    from OCP.TopoDS import TopoDS

    face_map = ShapeMap()
    TopExp.MapShapes_s(model.brep, FACE, face_map)
    numbers = model.kernel_numbers()
    number: dict[int, int] = {}  # the map's index -> the model's face number (first seen)
    explorer, position = TopExp_Explorer(model.brep, FACE), 0
    while explorer.More() and position < len(numbers):
        number.setdefault(face_map.FindIndex(explorer.Current()), numbers[position])
        explorer.Next()
        position += 1
    edge_faces = EdgeFaces()
    TopExp.MapShapesAndUniqueAncestors_s(model.brep, EDGE, FACE, edge_faces)
    senses: dict[int, dict[int, Any]] = {}  # face map index -> edge index -> orientation

    def sense(face: Any, index: int, e: int) -> Any:
        if index not in senses:  # each face's edges once: their orientations in it
            found: dict[int, Any] = {}
            explorer = TopExp_Explorer(face, EDGE)
            while explorer.More():
                k = edge_faces.FindIndex(explorer.Current())
                found[k] = None if k in found else explorer.Current().Orientation()
                explorer.Next()
            senses[index] = found
        return senses[index].get(e)

    for e in range(1, edge_faces.Extent() + 1):
        edge = TopoDS.Edge(edge_faces.FindKey(e))
        if BRep_Tool.Degenerated_s(edge):
            continue
        sharing = []
        for shape in edge_faces.FindFromIndex(e):
            face = TopoDS.Face(shape)
            index = face_map.FindIndex(face)
            f = number.get(index)
            if f is not None and not BRep_Tool.IsClosed_s(edge, face):
                sharing.append((f, face, sense(face, index, e)))
        yield e - 1, edge, sharing


def _shared_edges(model: CadModel, samples: int, faces: list[int] | None) -> list[CadEdge]:
    from OCP.BRep import BRep_Tool

    usable = {face.index: face for face in model.faces}
    wanted = set(usable) if faces is None else set(faces) & set(usable)
    fraction = (np.arange(samples) + 0.5) / samples
    out = []
    for e, edge, sharing in _edge_faces(model):
        mine = [(f, face, sense) for f, face, sense in sharing if f in wanted]
        if len(mine) < 2:
            continue
        tolerance = float(BRep_Tool.Tolerance_s(edge))
        curves = {f: _pcurve_points(edge, face, sense, fraction) for f, face, sense in mine}
        points = {f: usable[f].to_patch(uv) for f, (uv, _) in curves.items()}
        for a in range(len(mine)):
            for b in range(a + 1, len(mine)):
                (i, _, sense_i), (j, _, sense_j) = mine[a], mine[b]
                if i == j:
                    continue
                consistent = None if None in (sense_i, sense_j) else sense_i != sense_j
                out.append(
                    CadEdge(
                        e,
                        (i, j),
                        (points[i], points[j]),
                        tolerance,
                        (curves[i][1], curves[j][1]),
                        consistent,
                    )
                )
    return out


def _pcurve_points(
    edge: Any, face: Any, sense: Any, fraction: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The edge's pcurve on the face at t0 + fraction (t1 - t0), as (n, 2) (u, v), and
    directions (n, 2) into the face there: the pcurve's tangent turned a quarter to the
    left where the face, taken forward (its normal p_u x p_v), runs the edge forward
    (``sense``, the edge's orientation in the face as the shape holds it), to the right
    where it runs it backward (zero where ``sense`` is None)."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve2d
    from OCP.gp import gp_Pnt2d, gp_Vec2d

    curve = BRepAdaptor_Curve2d(edge, face)
    t0, t1 = curve.FirstParameter(), curve.LastParameter()
    out = np.empty((len(fraction), 4))  # u, v, and the tangent turned left
    p, d = gp_Pnt2d(), gp_Vec2d()
    for k, s in enumerate(fraction.tolist()):
        curve.D1(t0 + s * (t1 - t0), p, d)
        out[k] = p.X(), p.Y(), -d.Y(), d.X()
    # FORWARD 0, REVERSED 1 (INTERNAL, EXTERNAL: no side)
    turn = int(face.Orientation())
    left = 0.0 if sense is None or int(sense) > 1 or turn > 1 else 1.0 - 2.0 * (int(sense) ^ turn)
    out[:, 2:] *= left
    return out[:, :2], out[:, 2:]


@kernel_operation("finding its edges' curves")
def edge_ranges(model: CadModel, faces: list[int]) -> list[tuple[int, int, float, float]]:
    """Each edge of the model that bounds one of ``faces`` other than as a seam (no pole):
    (edge number, face, t0, t1), the face the first of ``faces`` among those it bounds and
    [t0, t1] the edge's parameter range (as :func:`shared_edges` numbers them)."""
    if model.brep is None:
        raise GshadeError(f"{model.path}: the model has no kernel shape to find edges in")
    from OCP.BRepAdaptor import BRepAdaptor_Curve

    wanted = set(faces)
    out = []
    for e, edge, sharing in _edge_faces(model):
        mine = sorted(f for f, *_ in sharing if f in wanted)
        if mine:
            curve = BRepAdaptor_Curve(edge)
            out.append((e, mine[0], float(curve.FirstParameter()), float(curve.LastParameter())))
    return out


#: The last model's edges by number, with the faces each bounds: (model, edges).  A model's
#: combs evaluate its edges ten times (their samples, then each round refining inflections).
_RECENT: list[tuple[CadModel, dict[int, tuple[Any, dict[int, Any]]]]] = []


def _edges_by_number(model: CadModel) -> dict[int, tuple[Any, dict[int, Any]]]:
    """Each edge of :func:`_edge_faces` by its number: (edge, face number -> face)."""
    for held, edges in _RECENT:
        if held is model:
            return edges
    edges = {
        e: (edge, {f: face for f, face, _ in sharing}) for e, edge, sharing in _edge_faces(model)
    }
    _RECENT[:] = [(model, edges)]
    return edges


@kernel_operation("evaluating its edges' curves")
def edge_derivatives(
    model: CadModel, requests: list[tuple[int, int, NDArray[np.float64]]]
) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """The exact derivatives of edges: for each request (edge number, face, parameters t
    (n,)), an array (3, n, 3) of the edge's points c(t), c'(t) and c''(t) (its 3D curve,
    placed), and its pcurve's points on the face (n, 2), in the face's patch's parameters
    (:meth:`gshade.cad.CadFace.to_patch`)."""
    if model.brep is None:
        raise GshadeError(f"{model.path}: the model has no kernel shape to find edges in")
    from OCP.BRepAdaptor import BRepAdaptor_Curve, BRepAdaptor_Curve2d
    from OCP.gp import gp_Pnt, gp_Vec

    found = _edges_by_number(model)
    usable = {face.index: face for face in model.faces}
    out = []
    p, d1, d2 = gp_Pnt(), gp_Vec(), gp_Vec()
    for e, f, t in requests:
        edge, on = found[e]
        curve, pcurve = BRepAdaptor_Curve(edge), BRepAdaptor_Curve2d(edge, on[f])
        derivatives = np.empty((3, len(t), 3))
        uv = np.empty((len(t), 2))
        for k, x in enumerate(np.asarray(t, dtype=np.float64).tolist()):
            curve.D2(x, p, d1, d2)
            derivatives[:, k] = (
                (p.X(), p.Y(), p.Z()),
                (d1.X(), d1.Y(), d1.Z()),
                (d2.X(), d2.Y(), d2.Z()),
            )
            q = pcurve.Value(x)
            uv[k] = q.X(), q.Y()
        out.append((derivatives, usable[f].to_patch(uv)))
    return out
