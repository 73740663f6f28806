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
from functools import cached_property
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import NDArray

from ..analysis.deviation import Deviation, signed
from .deviation_measure import (
    PreparedSurfaces,
    covered_summary,
    measured_deviation,
    patch_numbers,
    sample_mesh,
    surface_samples,
    triangle_points,
)

if TYPE_CHECKING:
    from ..io.meshes import MeshData
    from ..scene.model import Scene
    from .tessellate import TriangleMesh

__all__ = [
    "CloudReference",
    "MeshReference",
    "Reference",
    "SurfaceReference",
    "read_reference",
    "surface_numbers",
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
    :func:`gshade.rendering.deviation_measure.measured_deviation`), its sample mesh and
    search made once for every measure."""

    scene: Scene

    @property
    def name(self) -> str:
        return self.scene.name

    @property
    def data_files(self) -> tuple[Any, ...]:
        return tuple(self.scene.data_files)

    @cached_property
    def mesh(self) -> TriangleMesh:
        return sample_mesh(self.scene)

    @cached_property
    def prepared(self) -> PreparedSurfaces:
        return PreparedSurfaces(self.scene, self.mesh)

    def measure(
        self, P: NDArray, N: NDArray, tolerance: float
    ) -> tuple[Deviation, NDArray[np.bool_]]:
        return measured_deviation(P, N, self.prepared, tolerance)

    def numbers(self, part: NDArray[np.int64]) -> NDArray[np.int64]:
        return patch_numbers(self.scene)[part]

    def samples(self, count: int) -> tuple[NDArray, NDArray]:
        return surface_samples(self.scene, count, mesh=self.mesh)


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


def surface_numbers(
    a: Scene, b: Reference, tolerance: float, count: int, *, whole: bool, symmetric: bool
) -> dict[str, Any]:
    """Over A's whole surface, independently of any view: with ``whole`` its numbers
    against B (``"whole"``: :func:`~gshade.rendering.deviation_measure.covered_summary` of
    ``count`` :func:`~gshade.rendering.deviation_measure.surface_samples` of A, with
    ``samples``), with ``symmetric`` the Hausdorff distance, sampled (``"hausdorff"``: the
    largest distance of those samples of A to B, ``a_to_b``, of B's samples to A's exact
    surfaces, ``b_to_a``, the larger, ``both``, and ``samples``); A's samples measured
    once for both."""
    out: dict[str, Any] = {}
    if not (whole or symmetric):
        return out
    surfaces = SurfaceReference(a)
    P, N = surfaces.samples(count)
    found, beyond = b.measure(P, N, tolerance)
    if whole:
        out["whole"], _ = covered_summary(found, beyond, tolerance, P, b.name)
        out["whole"]["samples"] = len(P)
    if symmetric:
        Q, M = b.samples(count)
        back, _ = surfaces.measure(Q, M, 0.0)
        h = {"samples": count, "a_to_b": _largest(found), "b_to_a": _largest(back)}
        h["both"] = max(h["a_to_b"], h["b_to_a"])
        out["hausdorff"] = h
    return out


def _largest(found: Deviation) -> float:
    """The largest |d| of a deviation (0 without a point)."""
    return float(np.abs(found.distance).max(initial=0.0))
