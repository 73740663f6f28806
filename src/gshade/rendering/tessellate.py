"""Tessellation: patches -> one watertight triangle mesh carrying exact data.

Every patch is sampled on the same (n x n) grid of its normalised parameters, so that two
patches sharing an edge sample it at the same points; the few positions that still differ by
round-off are welded to one value (bit-identical), so the ray tracer sees no cracks.
Vertex normals are the exact unit normals (limits at collapsed edges), and each vertex
carries its patch parameters (u, v) and patch index.  Triangles that collapse to zero area
(at a collapsed patch edge) are dropped.

The resolution comes from a chord-error bound: a bilinear cell of size h x h (normalised
parameters) deviates from the surface by at most h^2 / 8 (|p_ss| + 2 |p_st| + |p_tt|).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from ..geometry import Patch, patch_normals, unit_normal
from ..geometry.core.differential import derivative_scales
from ..geometry.core.patch import unit_to_domain
from ..geometry.evaluation.patch_groups import domain_spans, grid_derivatives
from ..geometry.evaluation.spline_batches import batch_derivatives
from ..scene.bodies import CadFaces

__all__ = ["TriangleMesh", "chord_resolution", "max_chord_resolution", "tessellate"]

MAX_RESOLUTION = 512
#: The finest deflection the kernel's mesher is asked for, relative to the model's diagonal:
#: a tenth of a pixel of the largest image (16384 pixels) seeing the whole model.  The
#: shading is exact whatever the mesh; a finer mesh would only cost time and memory.
MIN_FACE_DEFLECTION = 6e-6
#: The kernel's own smallest length (Open CASCADE's Precision::Confusion): the mesher
#: refuses a deflection below it.
KERNEL_CONFUSION = 1e-7


@dataclass(frozen=True)
class TriangleMesh:
    """A triangle mesh with per-vertex exact normals, patch parameters and patch index.

    ``params`` are the normalised parameters (s, t) in [0, 1]^2 of each vertex's patch
    (u = u0 + s (u1 - u0), v = v0 + t (v1 - v0)); ``resolution`` is the grid size per patch.
    """

    positions: NDArray[np.float64]
    normals: NDArray[np.float64]
    params: NDArray[np.float64]
    patch: NDArray[np.int32]
    faces: NDArray[np.int32]
    resolution: int

    @property
    def bounds(self) -> tuple[NDArray, NDArray]:
        return self.positions.min(axis=0), self.positions.max(axis=0)


def _normalised_second_derivatives(
    patches: list[Patch] | tuple[Patch, ...], samples: int = 9
) -> NDArray:
    """Per patch, max over a sample grid of |p_ss| + 2 |p_st| + |p_tt| in normalised
    parameters."""
    d = grid_derivatives(patches, np.linspace(0.0, 1.0, samples), 2)
    spans = domain_spans(patches)
    du = spans[:, 0, None, None]
    dv = spans[:, 1, None, None]
    norm = np.linalg.norm
    total = (
        norm(d[:, 2, 0], axis=-1) * du * du
        + 2 * norm(d[:, 1, 1], axis=-1) * du * dv
        + norm(d[:, 0, 2], axis=-1) * dv * dv
    )
    return total.reshape(len(patches), -1).max(axis=1)


def max_chord_resolution(patches: Sequence[Patch], tolerance: float) -> int:
    """Grid points per side so that the chord error of every patch stays below
    ``tolerance``: a bilinear cell of h x h deviates by at most h^2 / 8 times the bound."""
    if not tolerance > 0:
        raise GshadeError(f"chord_tolerance: expected a positive number, got {tolerance!r}")
    bound = float(_normalised_second_derivatives(list(patches)).max())
    cells = int(np.ceil(np.sqrt(bound / (8.0 * tolerance)))) if bound > 0 else 1
    return int(np.clip(cells + 1, 2, MAX_RESOLUTION))


def chord_resolution(patch: Patch, tolerance: float) -> int:
    """Grid points per side so that the chord error of one patch stays below ``tolerance``."""
    return max_chord_resolution([patch], tolerance)


def _grid_faces(n: int) -> NDArray[np.int32]:
    """Two triangles per cell of an n x n vertex grid (row-major, index = i * n + j)."""
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = (i * n + j).ravel()
    b, c, d = a + n, a + n + 1, a + 1
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).astype(np.int32)


def _weld(positions: NDArray, boundary: NDArray, tolerance: float) -> None:
    """Make boundary positions closer than ``tolerance`` bit-identical, in place.

    Positions are grouped by the cell of a grid of spacing ``tolerance`` they fall in, and
    each group takes its first member's position; a second pass on a grid shifted by half a
    cell catches the pairs that straddled a cell border in the first.
    """
    idx = np.flatnonzero(boundary)
    for shift in (0.0, 0.5):
        keys = np.floor(positions[idx] / tolerance + shift).astype(np.int64)
        _, first, label = np.unique(keys, axis=0, return_index=True, return_inverse=True)
        positions[idx] = positions[idx[first[label.ravel()]]]


def tessellate(patches: list[Patch] | tuple[Patch, ...], resolution: int) -> TriangleMesh:
    """Tessellate patches on a common n x n grid of normalised parameters.

    Parameters
    ----------
    patches : sequence of Patch
    resolution : int
        Grid points per patch side (>= 2); use :func:`chord_resolution` to choose it.
    """
    n = int(resolution)
    if n < 2:
        raise GshadeError(f"tessellation: expected at least 2 vertices per side, got {resolution}")
    if not patches:
        raise GshadeError("tessellation: expected at least one patch")
    s = np.linspace(0.0, 1.0, n)
    st = np.stack(np.meshgrid(s, s, indexing="ij"), -1).reshape(-1, 2)
    d = grid_derivatives(patches, s, 1)  # (patches, 2, 2, n, n, 3)
    normal = unit_normal(np.moveaxis(d, 0, 2))
    normals = normal.n
    for k in np.flatnonzero(~normal.regular.all(axis=(1, 2))):
        # limits at collapsed edges need higher derivatives and the way into the domain
        patch = patches[k]
        a, b = np.nonzero(~normal.regular[k])
        u, v = unit_to_domain(patch.domain, s[a], s[b])
        normals[k, a, b] = patch_normals(patch, u, v).n
    P = d[:, 0, 0].reshape(-1, 3).copy()
    scale = float(np.ptp(P, axis=0).max()) or 1.0
    on_edge = np.zeros((n, n), dtype=bool)
    on_edge[[0, -1], :] = True
    on_edge[:, [0, -1]] = True
    _weld(P, np.tile(on_edge.ravel(), len(patches)), 1e-9 * scale)
    F = (_grid_faces(n)[None] + (n * n * np.arange(len(patches)))[:, None, None]).reshape(-1, 3)
    area = np.linalg.norm(np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]]), axis=1)
    F = F[area > 1e-14 * scale * scale]
    return TriangleMesh(
        positions=P,
        normals=normals.reshape(-1, 3),
        params=np.tile(st, (len(patches), 1)),
        patch=np.repeat(np.arange(len(patches), dtype=np.int32), n * n),
        faces=F,
        resolution=n,
    )


def tessellate_faces(
    cad: CadFaces, patches: Sequence[Patch], deflection: float
) -> tuple[TriangleMesh, list, list[str]]:
    """The trimmed faces of a ``cad`` surface (:class:`gshade.scene.bodies.CadFaces`) as a
    triangle mesh from the kernel's mesher (:func:`gshade.cad.mesh.mesh_faces`), within
    ``deflection`` (model units) of the faces, but no finer than :data:`MIN_FACE_DEFLECTION`
    of the model's diagonal (nor the kernel's :data:`KERNEL_CONFUSION`).

    ``patches`` are the surface's patches (one a face, over its box, u and v swapped for the
    faces in ``cad.swapped``): the vertices' params are the kernel's (u, v) normalised to the
    face's box ((v, u) on a swapped face), their normals the exact unit normals of the patch
    there, and their patch index the face's place in ``cad.faces``.  Also returned: the
    faces the mesher left without triangles (:class:`gshade.cad.LeftOutFace`; on a
    ``strict`` surface they are a GshadeError instead) and the mesher's notes (faces meshed
    at another deflection).
    """
    from ..cad.mesh import mesh_faces

    lo, hi = cad.model.bounds
    diagonal = float(np.linalg.norm(np.asarray(hi) - np.asarray(lo)))
    floor = MIN_FACE_DEFLECTION * diagonal if np.isfinite(diagonal) else 0.0
    m = mesh_faces(cad.model, max(deflection, floor, 2 * KERNEL_CONFUSION), faces=cad.faces)
    if m.left_out and cad.strict:
        from ..cad import strict_refusal

        raise strict_refusal(cad.model.path, m.left_out)
    place = {face: k for k, face in enumerate(cad.faces)}
    index = np.array([place[int(f)] for f in m.face], dtype=np.int64)
    uv = cad.patch_uv(index, m.uv)
    domains = np.array([p.domain for p in patches], dtype=np.float64)[index]
    lo, hi = domains[:, :, 0], domains[:, :, 1]
    params = np.clip((uv - lo) / (hi - lo), 0.0, 1.0)
    u, v = lo[:, 0] + params[:, 0] * (hi - lo)[:, 0], lo[:, 1] + params[:, 1] * (hi - lo)[:, 1]
    # the faces' first derivatives all at once; each face's regularity on its own scale,
    # and the limits at its irregular points (poles) from its own higher derivatives
    d = batch_derivatives(patches, index, u, v, 1)
    normal = unit_normal(d, scale=derivative_scales(d, index))
    normals = normal.n
    irregular = np.flatnonzero(~normal.regular)
    for k in np.unique(index[irregular]):
        irr = irregular[index[irregular] == k]
        normals[irr] = patch_normals(patches[int(k)], u[irr], v[irr]).n
    P = np.ascontiguousarray(m.positions, dtype=np.float64)
    F = m.triangles
    scale = float(np.ptp(P, axis=0).max()) if len(P) else 1.0
    if len(F):
        area = np.linalg.norm(np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]]), axis=1)
        F = F[area > 1e-14 * scale * scale]
    mesh = TriangleMesh(
        P, normals, params, index.astype(np.int32), np.ascontiguousarray(F, np.int32), 0
    )
    return mesh, list(m.left_out), list(m.notes)


def join_meshes(
    meshes: list[tuple[TriangleMesh, NDArray[np.int32]]], resolution: int
) -> TriangleMesh:
    """One mesh of several, each with the global patch index of each of its patches (one
    whose patches are the scene's, in order, as it is: no copy)."""
    if len(meshes) == 1:
        mesh, global_index = meshes[0]
        if np.array_equal(global_index, np.arange(len(global_index))):
            return replace(
                mesh,
                patch=mesh.patch.astype(np.int32, copy=False),
                faces=mesh.faces.astype(np.int32, copy=False),
                resolution=resolution,
            )
    offset = 0
    parts = []
    for mesh, global_index in meshes:
        parts.append((mesh, global_index[mesh.patch], mesh.faces + offset))
        offset += len(mesh.positions)
    return TriangleMesh(
        positions=np.concatenate([m.positions for m, _, _ in parts]),
        normals=np.concatenate([m.normals for m, _, _ in parts]),
        params=np.concatenate([m.params for m, _, _ in parts]),
        patch=np.concatenate([p for _, p, _ in parts]).astype(np.int32),
        faces=np.concatenate([f for _, _, f in parts]).astype(np.int32),
        resolution=resolution,
    )
