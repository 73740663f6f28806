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

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from ..geometry import Patch, patch_normals

__all__ = ["TriangleMesh", "chord_resolution", "tessellate"]

MAX_RESOLUTION = 512


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


def _normalised_second_derivatives(patch: Patch, samples: int = 9) -> float:
    """max over a sample grid of |p_ss| + 2 |p_st| + |p_tt| in normalised parameters."""
    (u0, u1), (v0, v1) = patch.domain
    u, v = patch.parameter_grid(samples, samples)
    d = patch.derivatives(u, v, 2)
    du, dv = u1 - u0, v1 - v0
    norm = np.linalg.norm
    total = (
        norm(d[2, 0], axis=-1) * du * du
        + 2 * norm(d[1, 1], axis=-1) * du * dv
        + norm(d[0, 2], axis=-1) * dv * dv
    )
    return float(total.max())


def chord_resolution(patch: Patch, tolerance: float) -> int:
    """Grid points per side so that the chord error stays below ``tolerance``."""
    if not tolerance > 0:
        raise GshadeError(f"chord_tolerance: expected a positive number, got {tolerance!r}")
    bound = _normalised_second_derivatives(patch)
    cells = int(np.ceil(np.sqrt(bound / (8.0 * tolerance)))) if bound > 0 else 1
    return int(np.clip(cells + 1, 2, MAX_RESOLUTION))


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
    positions, normals, patch_ids, faces = [], [], [], []
    grid_faces = _grid_faces(n)
    for k, patch in enumerate(patches):
        (u0, u1), (v0, v1) = patch.domain
        u = (u0 + (u1 - u0) * s)[:, None]
        v = (v0 + (v1 - v0) * s)[None, :]
        normal = patch_normals(patch, u, v)
        p = patch(u, v).reshape(-1, 3)
        positions.append(p)
        normals.append(normal.n.reshape(-1, 3))
        patch_ids.append(np.full(n * n, k, dtype=np.int32))
        faces.append(grid_faces + k * n * n)
    P = np.concatenate(positions)
    scale = float(np.ptp(P, axis=0).max()) or 1.0
    on_edge = np.zeros((n, n), dtype=bool)
    on_edge[[0, -1], :] = True
    on_edge[:, [0, -1]] = True
    _weld(P, np.tile(on_edge.ravel(), len(patches)), 1e-9 * scale)
    F = np.concatenate(faces)
    area = np.linalg.norm(np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]]), axis=1)
    F = F[area > 1e-14 * scale * scale]
    return TriangleMesh(
        positions=P,
        normals=np.concatenate(normals),
        params=np.tile(st, (len(patches), 1)),
        patch=np.concatenate(patch_ids),
        faces=F,
        resolution=n,
    )
