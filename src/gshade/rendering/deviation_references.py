"""What a deviation is measured against (B of ``gshade deviation A B``, a check's
``reference_model``): a scene's exact surfaces, a triangle mesh or a point cloud, each a
:class:`Reference` that measures points of A, numbers its parts and samples itself; read by
:func:`read_reference` from a file, the kind chosen by its suffix (one table:
:data:`gshade.io.meshes.READERS` for meshes and clouds, else a scene or CAD file).

Against a mesh the distance is exact to its triangles
(:func:`gshade.analysis.mesh_distance.mesh_closest_points`), against a cloud to its nearest
point; both signed by A's normal as against surfaces.  A mesh's free boundary (its edges
of one triangle, vertices welded) is where it may not cover A
(:func:`gshade.analysis.coverage.uncovered`); a cloud has none.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import NDArray

from ..analysis.deviation import Deviation, deviation_summary, signed
from .deviation_measure import (
    SURFACE_SAMPLES,
    measured_deviation,
    patch_numbers,
    surface_samples,
    triangle_points,
)

if TYPE_CHECKING:
    from ..io.meshes import MeshData
    from ..scene.model import Scene

__all__ = [
    "CloudReference",
    "MeshReference",
    "Reference",
    "SurfaceReference",
    "hausdorff",
    "read_reference",
    "whole_deviation",
]


class Reference(Protocol):
    """B: its ``name``; ``measure(P, N, tolerance)``: the signed deviation of points P (n, 3)
    of A with unit normals N and which of them lie beyond B; ``numbers(part)``: the
    numbers the picture gives B's parts (faces, triangles, points); ``samples(count)``:
    about ``count`` points of B and their normals, spread by area; ``data_files``: the
    files B was read from besides its own (a scene's surfaces' files)."""

    @property
    def name(self) -> str: ...

    @property
    def data_files(self) -> tuple[Any, ...]: ...

    def measure(
        self, P: NDArray, N: NDArray, tolerance: float
    ) -> tuple[Deviation, NDArray[np.bool_]]: ...

    def numbers(self, part: NDArray[np.int64]) -> NDArray[np.int64]: ...

    def samples(self, count: int) -> tuple[NDArray, NDArray]: ...


@dataclass(frozen=True)
class SurfaceReference:
    """A scene's exact surfaces (trims, their edges and its free boundary heeded:
    :func:`gshade.rendering.deviation_measure.measured_deviation`)."""

    scene: Scene

    @property
    def name(self) -> str:
        return self.scene.name

    @property
    def data_files(self) -> tuple[Any, ...]:
        return tuple(self.scene.data_files)

    def measure(
        self, P: NDArray, N: NDArray, tolerance: float
    ) -> tuple[Deviation, NDArray[np.bool_]]:
        return measured_deviation(P, N, self.scene, tolerance)

    def numbers(self, part: NDArray[np.int64]) -> NDArray[np.int64]:
        return patch_numbers(self.scene)[part]

    def samples(self, count: int) -> tuple[NDArray, NDArray]:
        return surface_samples(self.scene, count)


@dataclass(frozen=True)
class _MeshFile:
    """A mesh or cloud file: named as its file, its parts (triangles, points) numbered as
    it holds them."""

    mesh: MeshData
    data_files: tuple[Any, ...] = ()

    @property
    def name(self) -> str:
        return self.mesh.name

    def numbers(self, part: NDArray[np.int64]) -> NDArray[np.int64]:
        return np.asarray(part, dtype=np.int64)


@dataclass(frozen=True)
class MeshReference(_MeshFile):
    """A triangle mesh: exact distances to its triangles; its parts are its triangles."""

    def measure(
        self, P: NDArray, N: NDArray, tolerance: float
    ) -> tuple[Deviation, NDArray[np.bool_]]:
        from ..analysis.coverage import free_edges, segment_distances, uncovered
        from ..analysis.mesh_distance import mesh_closest_points
        from .deviation_measure import WELD

        v, f = self.mesh.vertices, self.mesh.faces
        found = signed(P, N, mesh_closest_points(v, f, P))
        beyond = np.zeros(len(P), dtype=bool)
        far = np.flatnonzero(found.closest.distance > tolerance)
        if far.size:
            corners = v[f[found.closest.patch[far]]]
            normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
            with np.errstate(invalid="ignore", divide="ignore"):
                normal = np.nan_to_num(normal / np.linalg.norm(normal, axis=-1, keepdims=True))
            weld = WELD * float(np.linalg.norm(np.ptp(v, axis=0)))
            edges = free_edges(v, f, weld)
            reach = segment_distances(found.closest.point[far], edges)
            point = found.closest.point[far]
            beyond[far] = uncovered(P[far], point, normal, reach, 10 * weld, tolerance)
        return found, beyond

    def samples(self, count: int, seed: int = 0) -> tuple[NDArray, NDArray]:
        corners = self.mesh.vertices[self.mesh.faces]
        face, weights = triangle_points(corners, count, seed)
        c = corners[face]
        normal = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
        unit = normal / np.linalg.norm(normal, axis=-1, keepdims=True)
        return np.einsum("nk,nkc->nc", weights, c), unit


@dataclass(frozen=True)
class CloudReference(_MeshFile):
    """A point cloud: distances to its nearest points; its parts are its points; it covers
    everything (no boundary to lie beyond)."""

    def measure(
        self, P: NDArray, N: NDArray, tolerance: float
    ) -> tuple[Deviation, NDArray[np.bool_]]:
        from ..analysis.mesh_distance import cloud_closest_points

        found = signed(P, N, cloud_closest_points(self.mesh.vertices, P))
        return found, np.zeros(len(P), dtype=bool)

    def samples(self, count: int, seed: int = 0) -> tuple[NDArray, NDArray]:
        points = self.mesh.vertices
        if len(points) > count:
            points = points[np.random.default_rng(seed).choice(len(points), count, replace=False)]
        return points, np.zeros_like(points)


def read_reference(path: str | os.PathLike, overrides: dict[str, Any] | None = None) -> Reference:
    """B from a file: a triangle mesh or a point cloud where its suffix is one of
    :data:`gshade.io.meshes.MESH_SUFFIXES` (a mesh without triangles is a cloud), else a
    scene (TOML) or CAD file (:func:`gshade.scene.load_scene`, with ``overrides``)."""
    from ..io.meshes import is_mesh_file, read_mesh
    from ..scene import load_scene

    if is_mesh_file(path):
        mesh = read_mesh(path)
        return CloudReference(mesh) if mesh.is_cloud else MeshReference(mesh)
    return SurfaceReference(load_scene(path, overrides))


def whole_deviation(
    a: Scene, b: Reference, tolerance: float, count: int = SURFACE_SAMPLES
) -> dict[str, Any]:
    """The numbers (:func:`gshade.analysis.deviation.deviation_summary`, with ``beyond``
    and ``samples``) of A's whole surface against B:
    :func:`~gshade.rendering.deviation_measure.surface_samples` of A measured by B."""
    P, N = surface_samples(a, count)
    found, beyond = b.measure(P, N, tolerance)
    covered = ~beyond
    summary = deviation_summary(found.distance[covered], tolerance, P[covered])
    summary["beyond"] = int(beyond.sum())
    summary["beyond_fraction"] = float(beyond.mean()) if beyond.size else 0.0
    summary["samples"] = len(P)
    summary["b"] = b.name
    return summary


def hausdorff(a: Scene, b: Reference, count: int = SURFACE_SAMPLES) -> dict[str, Any]:
    """The Hausdorff distance between A and B, sampled: the largest distance of
    :func:`~gshade.rendering.deviation_measure.surface_samples` of A to B (``a_to_b``),
    of B's samples to A's exact surfaces (``b_to_a``), and the larger (``both``)."""
    out: dict[str, Any] = {"samples": count}
    for key, one, other in (("a_to_b", SurfaceReference(a), b), ("b_to_a", b, SurfaceReference(a))):
        P, N = one.samples(count)
        found, _ = other.measure(P, N, 0.0)
        out[key] = float(np.abs(found.distance).max(initial=0.0))
    out["both"] = max(out["a_to_b"], out["b_to_a"])
    return out
