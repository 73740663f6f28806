"""The trimmed faces of a CAD model as one watertight triangle mesh, from Open CASCADE's mesher.

The kernel meshes the model's NURBS-converted shape (``CadModel.brep``) with
``BRepMesh_IncrementalMesh``: its nodes carry the converted faces' parameters (u, v), which
are those of each :class:`~gshade.cad.CadFace`'s exact patch, and the nodes on an edge
shared by two faces are the same (bit-identical) in both.  Each face gets its own vertices:

- interior nodes are placed at the exact surface point S(u, v) of the face's patch (the
  kernel's own node differs from it by round-off);
- boundary nodes (on a face's edges, seams and poles) keep the kernel's node, so that the
  faces meeting at an edge meet at the same points: the patches of two faces evaluated at
  their own (u, v) of a shared node differ by up to the file's edge tolerance, which would
  open cracks.

Triangles are oriented along the faces' outward normals (p_u x p_v, flipped for reversed
faces); those with two corners at the same point (at a pole) are dropped.  Only plain
arrays come out; :mod:`gshade.rendering` wraps them for display.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from .model import CadModel, LeftOutFace
from .process import kernel_operation

__all__ = ["FaceMesh", "mesh_faces"]


@dataclass(frozen=True)
class FaceMesh:
    """Triangles of a model's faces, each face with its own vertices.

    Attributes
    ----------
    positions : ndarray (n, 3)
        Vertex positions: S(u, v) of the face's exact patch inside a face, the kernel's node
        on the face's boundary (shared with the neighbouring face, bit-identical).
    uv : ndarray (n, 2)
        The vertices' parameters (u, v) on their face's patch.
    face : ndarray (n,) of int32
        The vertices' face indices (``CadFace.index``).
    triangles : ndarray (m, 3) of int32
        Vertex indices, ordered so that (p1 - p0) x (p2 - p0) points out of the face.
    boundary : ndarray (n,) of bool
        True for vertices on their face's boundary (placed at the kernel's node).
    node_gap : float
        The largest distance between S(u, v) and the kernel's node over interior vertices.
    left_out : list of LeftOutFace
        The faces asked for that have no triangles here (the mesher gave none, or failed on
        them, or the reader left them out), in order.
    notes : list of str
        How faces that the mesher left empty at first were meshed, a line each.
    """

    positions: NDArray[np.float64]
    uv: NDArray[np.float64]
    face: NDArray[np.int32]
    triangles: NDArray[np.int32]
    boundary: NDArray[np.bool_]
    node_gap: float
    left_out: list[LeftOutFace] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


@kernel_operation("meshing it")
def mesh_faces(
    model: CadModel,
    deflection: float,
    angle: float = 0.5,
    faces: Sequence[int] | None = None,
) -> FaceMesh:
    """Mesh a model's trimmed faces with the kernel's mesher.

    Parameters
    ----------
    model : CadModel
        Read from a STEP, IGES or BREP file (it holds the kernel's shape).
    deflection : float
        The largest distance between a triangle and the surface (model units).
    angle : float
        The largest angle (radians) between neighbouring triangles' normals.
    faces : sequence of int, optional
        Mesh only these faces (default: all the model's usable faces); faces among them
        share their edges' nodes.

    Returns
    -------
    FaceMesh
        The faces' triangles; a face the mesher gives no triangles (or fails on), or that
        the reader left out, is in its ``left_out`` instead, and the others are meshed.

    Raises
    ------
    GshadeError
        One line naming the file: no kernel shape, bad parameters, a face number out of
        range.
    """
    from .kernel import exception_text, shape_faces

    path = model.path
    if model.brep is None:
        raise GshadeError(f"{path}: meshing needs the kernel's shape (STEP, IGES or BREP files)")
    if not (np.isfinite(deflection) and deflection > 0):
        raise GshadeError(f"deflection: expected a positive number, got {deflection!r}")
    if not (np.isfinite(angle) and angle > 0):
        raise GshadeError(f"angle: expected a positive number of radians, got {angle!r}")
    shape: Any = model.brep
    numbers = model.kernel_numbers()
    in_shape = shape_faces(shape)
    if len(in_shape) != len(numbers):
        raise GshadeError(
            f"{path}: the kernel's shape has {len(in_shape)} faces for {len(numbers)}"
        )
    kernel_faces = dict(zip(numbers, in_shape, strict=True))
    usable = {face.index: face for face in model.faces if face.index in kernel_faces}
    asked = list(usable) if faces is None else [int(i) for i in faces]
    for i in asked:
        if not 0 <= i < model.face_count:
            raise GshadeError(f"{path}: no face {i} (the model has {model.face_count})")
    left_out: dict[int, LeftOutFace | None] = {
        i: model.reason_left_out(i) for i in asked if i not in usable
    }
    chosen = [i for i in dict.fromkeys(asked) if i in usable]
    try:
        _mesh(kernel_faces, chosen, deflection, angle)
    except Exception:  # the mesher failed on the whole: face by face
        for i in chosen:
            try:
                _mesh(kernel_faces, [i], deflection, angle)
            except Exception as exc:
                left_out[i] = LeftOutFace(
                    i, f"the kernel's mesher failed ({exception_text(exc)})", MESHING
                )
    notes = []
    for i in chosen:  # a face the mesher left empty: alone, at other deflections
        if i not in left_out and not _triangles(kernel_faces[i]):
            factor = _remeshed(kernel_faces[i], deflection, angle)
            if factor is not None:
                notes.append(
                    f"face {i}: meshed alone at {factor:g} times the deflection (the mesher "
                    "gave it no triangles at the deflection asked for)"
                )
    raw = []
    for i in chosen:
        if i in left_out:
            continue
        try:
            raw.append((i, _face_nodes(kernel_faces[i], usable[i])))
        except GshadeError as exc:
            left_out[i] = LeftOutFace(i, str(exc), MESHING)
        except Exception as exc:
            left_out[i] = LeftOutFace(i, f"the kernel failed ({exception_text(exc)})", MESHING)
    # every face's nodes on its exact surface at once, at the node's own (u, v), past the
    # domain too (a trim straying by a tolerance): the end pieces continued, as the kernel
    # evaluates (and the edge measures); points and speeds
    d_all = _node_derivatives([usable[i].patch for i, _ in raw], [r for _, r in raw])
    parts = []
    count = 0
    at = 0
    for i, (nodes, uv, triangles, boundary) in raw:
        d = d_all[:, :, at : at + len(nodes)]
        at += len(nodes)
        try:
            part = _on_surface(d, nodes, uv, triangles, boundary, usable[i].patch)
        except GshadeError as exc:
            left_out[i] = LeftOutFace(i, str(exc), MESHING)
            continue
        parts.append((part, count, i))
        count += len(part[0])
    said = [f for i, f in left_out.items() if f is not None]
    if not parts:
        return FaceMesh(
            np.empty((0, 3)),
            np.empty((0, 2)),
            np.empty(0, np.int32),
            np.empty((0, 3), np.int32),
            np.empty(0, bool),
            0.0,
            said,
            notes,
        )
    return FaceMesh(
        positions=np.concatenate([p[0] for p, _, _ in parts]),
        uv=np.concatenate([p[1] for p, _, _ in parts]),
        face=np.concatenate([np.full(len(p[0]), i, np.int32) for p, _, i in parts]),
        triangles=np.concatenate([p[2] + offset for p, offset, _ in parts]).astype(np.int32),
        boundary=np.concatenate([p[3] for p, _, _ in parts]),
        node_gap=max(p[4] for p, _, _ in parts),
        left_out=said,
        notes=notes,
    )


#: The deflections, as factors of the one asked for, at which a face the mesher left
#: without triangles is meshed again, alone, in this order.
REMESH_FACTORS = (2.0, 4.0, 0.5, 8.0, 16.0, 0.25, 32.0, 64.0)
#: What was tried on a face left without triangles, as the warnings say it.
MESHING = (
    "meshing it with the kernel's mesher, with the model and alone at "
    f"{min(REMESH_FACTORS):g} to {max(REMESH_FACTORS):g} times the deflection"
)


def _triangles(face: Any) -> int:
    """The number of triangles of the face's stored mesh (0 without one)."""
    from OCP.BRep import BRep_Tool
    from OCP.TopLoc import TopLoc_Location

    triangulation = BRep_Tool.Triangulation_s(face, TopLoc_Location())
    return 0 if triangulation is None else int(triangulation.NbTriangles())


def _remeshed(face: Any, deflection: float, angle: float) -> float | None:
    """Mesh the face alone at each of :data:`REMESH_FACTORS` times the deflection until the
    mesher gives it triangles: the factor that did, or None.  (Its boundary nodes are then
    its own, not its neighbours': a crack of the order of the deflection may open there,
    where the face would otherwise be missing.)"""
    for factor in REMESH_FACTORS:
        try:
            _mesh({0: face}, [0], factor * deflection, angle)
        except Exception:
            continue
        if _triangles(face):
            return factor
    return None


def _mesh(kernel_faces: dict, chosen: list[int], deflection: float, angle: float) -> None:
    """Mesh the faces ``chosen`` of ``kernel_faces`` with the kernel's mesher (its meshes
    stored on the faces); faces among them share their edges' nodes."""
    from OCP.BRep import BRep_Builder
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.BRepTools import BRepTools
    from OCP.TopoDS import TopoDS_Compound

    target = TopoDS_Compound()
    builder = BRep_Builder()
    builder.MakeCompound(target)
    for i in chosen:
        builder.Add(target, kernel_faces[i])
    BRepTools.Clean_s(target)  # the deflection asked for, not an earlier mesh's
    mesher = BRepMesh_IncrementalMesh(target, float(deflection), False, float(angle), True)
    if not mesher.IsDone():
        raise RuntimeError("not done")


def _face_nodes(face: Any, cad: Any) -> tuple:
    """One face's triangulation: its nodes (n, 3), their uv in the face's patch's parameters
    (:meth:`gshade.cad.CadFace.to_patch`), its triangles (m, 3, oriented with the face)
    and which nodes lie on its boundary."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_REVERSED
    from OCP.TopLoc import TopLoc_Location

    location = TopLoc_Location()
    triangulation = BRep_Tool.Triangulation_s(face, location)
    if triangulation is None or triangulation.NbTriangles() == 0:
        raise GshadeError("the kernel's mesher gave no triangles")
    if not triangulation.HasUVNodes():
        raise GshadeError("the kernel's mesh has no (u, v) at its nodes")
    transform = location.Transformation()
    n, m = triangulation.NbNodes(), triangulation.NbTriangles()
    nodes = np.empty((n, 3))
    uv = np.empty((n, 2))
    for k in range(n):
        p = triangulation.Node(k + 1).Transformed(transform)
        nodes[k] = p.X(), p.Y(), p.Z()
        q = triangulation.UVNode(k + 1)
        uv[k] = q.X(), q.Y()
    triangles = np.array([triangulation.Triangle(k + 1).Get() for k in range(m)], np.int64) - 1
    if triangles.min() < 0 or triangles.max() >= n:
        raise GshadeError("the kernel's mesh refers to missing nodes")
    if face.Orientation() == TopAbs_REVERSED:
        triangles = triangles[:, ::-1]
    return nodes, cad.to_patch(uv), triangles, _boundary(triangles, n)


def _node_derivatives(patches: list, raw: list[tuple]) -> NDArray:
    """The first derivatives (2, 2, N, 3) of the faces' surfaces at all their nodes, past
    the domains too (:func:`gshade.geometry.evaluation.spline_batches.batch_derivatives`)."""
    from ..geometry.evaluation.spline_batches import batch_derivatives

    if not raw:
        return np.empty((2, 2, 0, 3))
    index = np.concatenate([np.full(len(r[0]), k) for k, r in enumerate(raw)])
    uv = np.concatenate([r[1] for r in raw])
    return batch_derivatives(patches, index, uv[:, 0], uv[:, 1], 1, beyond=True)


def _on_surface(
    d: NDArray, nodes: NDArray, uv: NDArray, triangles: NDArray, boundary: NDArray, patch: Any
) -> tuple:
    """One face's (positions, uv, triangles, boundary, node_gap): its nodes moved onto the
    exact surface (``d``: its derivatives there), boundary nodes kept where the mesher put
    them (shared with the neighbour), poles split."""
    exact = d[0, 0]
    nodes, exact, uv, triangles, boundary = _split_poles(d, nodes, exact, uv, triangles, boundary)
    gaps = np.linalg.norm(exact - nodes, axis=1)[~boundary]
    positions = np.where(boundary[:, None], nodes, exact)
    gap = float(gaps.max()) if gaps.size else 0.0
    corners = positions[triangles]
    same = (corners[:, [0, 1, 2]] == corners[:, [1, 2, 0]]).all(axis=2).any(axis=1)
    triangles = triangles[~same]  # collapsed at a pole: two corners are the same node
    return positions, uv, np.ascontiguousarray(triangles, np.int32), boundary, gap


def _split_poles(
    d: NDArray, nodes: NDArray, exact: NDArray, uv: NDArray, triangles: NDArray, boundary: NDArray
) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray]:
    """A pole node (where p_u or p_v vanishes, by the patch's derivatives ``d`` at the
    nodes: the sphere's apex, a cone's tip) once per triangle around it, its free parameter
    that of the triangle's other corners (their mean): one node for all would spread its one
    (u, v) over every triangle of the fan, and the (u, v) inside them, which start the exact
    channels' Newton steps, would be wrong.  The copies are boundary nodes at the pole."""
    speed = np.linalg.norm(np.stack([d[1, 0], d[0, 1]]), axis=-1)  # |p_u|, |p_v| per node
    scale = float(speed.max()) if speed.size else 0.0
    free = speed < 1e-9 * scale  # (2, n): the parameter that does not move the point
    pole = free.any(axis=0)
    corner = pole[triangles]
    split = corner.any(axis=1) & ~corner.all(axis=1)
    if not split.any():
        return nodes, exact, uv, triangles, boundary
    rows, cols = np.nonzero(corner & split[:, None])
    others = ~corner[rows]  # the triangle's corners that are not poles
    mean = (uv[triangles[rows]] * others[..., None]).sum(axis=1) / others.sum(axis=1)[:, None]
    old = triangles[rows, cols]
    new_uv = uv[old].copy()
    for k in (0, 1):  # along the free parameter, the other corners' mean
        new_uv[:, k] = np.where(free[k, old], mean[:, k], new_uv[:, k])
    triangles = triangles.copy()
    triangles[rows, cols] = len(nodes) + np.arange(len(rows))
    return (
        np.concatenate([nodes, nodes[old]]),
        np.concatenate([exact, exact[old]]),
        np.concatenate([uv, new_uv]),
        triangles,
        np.concatenate([boundary, np.ones(len(rows), bool)]),
    )


def _boundary(triangles: NDArray[np.int64], n: int) -> NDArray[np.bool_]:
    """The nodes on edges used by one triangle only (the face's edges, seams and poles)."""
    edges = np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    keys = edges[:, 0] * n + edges[:, 1]
    unique, counts = np.unique(keys, return_counts=True)
    single = unique[counts == 1]
    out = np.zeros(n, bool)
    out[single // n] = True
    out[single % n] = True
    return out
