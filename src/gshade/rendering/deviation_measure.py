"""Measuring a deviation (``gshade deviation``): the points of A (every covered pixel's
exact point, or A's whole surface sampled by area), their signed distances to B's exact
surfaces with B's trims and free boundary heeded, and the Hausdorff distance both ways.

B's coarse search starts from its :func:`sample_mesh` (the kernel's mesh of a CAD model's
trimmed faces, patches on a grid) and every patch's grid samples (:func:`mesh_samples`);
foot points outside B's trims are refused and the trims' edges searched instead
(:mod:`gshade.analysis.trimmed_faces`); a point whose closest point lies on B's free
boundary, off B's normal, is beyond B (:mod:`gshade.analysis.coverage`).
"""

from __future__ import annotations

from dataclasses import replace
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..analysis.deviation import Deviation, deviation_summary, signed_deviation
from ..analysis.surface_samples import Samples, grid_samples
from ..analysis.trimmed_faces import TrimTest, boundary_search, trim_test
from .camera import View
from .tessellate import TriangleMesh

if TYPE_CHECKING:
    from ..geometry import Patch
    from ..geometry.evaluation.patch_cells import ManyPatches
    from ..scene.model import Scene

__all__ = [
    "MAX_SAMPLE_GRID",
    "SAMPLE_CHORD",
    "SAMPLE_SPACING",
    "SURFACE_SAMPLES",
    "WELD",
    "PreparedSurfaces",
    "covered_summary",
    "measured_deviation",
    "mesh_samples",
    "patch_numbers",
    "pixel_hits",
    "sample_mesh",
    "surface_samples",
    "triangle_points",
    "unit_normals",
]

#: The chord tolerance of the mesh whose vertices start the closest-point search, relative
#: to the scene's diagonal, and the most grid points a patch side (patches on a grid).
SAMPLE_CHORD, MAX_SAMPLE_GRID = 2e-3, 65
#: The spacing of every patch's grid samples at most, relative to the scene's diagonal.
SAMPLE_SPACING = 5e-3
#: The weld of B's mesh's vertices for its free boundary, relative to the diagonal.
WELD = 1e-7
#: Points of a whole surface sampled by area (``--whole``, ``--symmetric``).
SURFACE_SAMPLES = 100_000


def sample_mesh(scene: Scene) -> TriangleMesh:
    """A scene's render mesh within :data:`SAMPLE_CHORD` of its diagonal: a CAD model's
    trimmed faces by the kernel's mesher, patches on a grid of at most
    :data:`MAX_SAMPLE_GRID` points a side."""
    from ..analysis.scene_junctions import scene_diagonal
    from .surface_meshes import gridded_patches, mesh_parts
    from .tessellate import join_meshes, max_chord_resolution

    tolerance = SAMPLE_CHORD * scene_diagonal(scene)
    gridded = gridded_patches(scene)
    resolution = 2
    if gridded:
        resolution = int(np.clip(max_chord_resolution(gridded, tolerance), 5, MAX_SAMPLE_GRID))
    parts = mesh_parts(scene, resolution, tolerance, scene.name)
    return join_meshes([(part.mesh, part.index) for part in parts], resolution)


def mesh_samples(
    scene: Scene, inside: TrimTest | None = None, mesh: TriangleMesh | None = None
) -> Samples:
    """The coarse search's points of a scene: every patch's grid samples
    (:func:`~gshade.analysis.surface_samples.grid_samples`: a periodic face's seam and a
    long tube's far side have samples near them) and the vertices of its
    :func:`sample_mesh` (where a trimmed face's grid may miss its trimmed region), each
    with its patch and (u, v), and the grids' blocks; with ``inside``
    (:func:`gshade.analysis.trimmed_faces.trim_test`), the grid samples outside a face's
    trims left out.  The grids' samples are at most :data:`SAMPLE_SPACING` of the
    diagonal apart (a big face's mesh may have long triangles, its vertices far from the
    foot points of a flat region)."""
    from ..analysis.scene_junctions import scene_diagonal
    from ..geometry.core.patch import unit_to_domain

    mesh = sample_mesh(scene) if mesh is None else mesh
    patch = mesh.patch.astype(np.int64)
    domains = np.array([p.domain for p in scene.patches], dtype=np.float64)
    u, v = unit_to_domain(domains, mesh.params[:, 0], mesh.params[:, 1], patch)
    grid = grid_samples(scene.patches, spacing=SAMPLE_SPACING * scene_diagonal(scene))
    if inside is not None:
        kept = inside(grid.patch, grid.uv)
        grid = replace(grid, points=grid.points[kept], patch=grid.patch[kept], uv=grid.uv[kept])
    return Samples(
        np.concatenate([grid.points, mesh.positions]),
        np.concatenate([grid.patch, patch]),
        np.concatenate([grid.uv, np.stack([u, v], -1)]),
        grid.cell,
        grid.blocks,
    )


def pixel_hits(
    scene: Scene, channels: dict[str, NDArray], view: View
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """P and the unit normal N (n, 3) in double precision where the pixel centres' rays meet
    the surface (the channels hold them in single precision): the rays' Newton solve on the
    exact patches, started from the channels' (u, v); and each hit's patch (n,) and (u, v)
    (n, 2)."""
    from .surface_hits import surface_hits

    rows, cols = np.nonzero(channels["patch"] >= 0)
    numbers = patch_numbers(scene)
    order = np.argsort(numbers)
    index = order[np.searchsorted(numbers[order], channels["patch"][rows, cols].astype(np.int64))]
    domains = np.array([p.domain for p in scene.patches], dtype=np.float64)[index]
    # the channels' single precision may round a parameter just out of its domain
    u = np.clip(channels["u"][rows, cols].astype(np.float64), domains[:, 0, 0], domains[:, 0, 1])
    v = np.clip(channels["v"][rows, cols].astype(np.float64), domains[:, 1, 0], domains[:, 1, 1])
    u, v, d, _ = surface_hits(scene.patches, index, u, v, *view.pixel_rays(rows, cols), steps=3)
    uv = np.stack([u, v], -1)
    normal = unit_normals(scene.patches, index, uv, d)
    return d[0, 0], normal, index, uv


class PreparedSurfaces:
    """A scene's exact surfaces made ready to measure against, once for every call: its
    :func:`sample_mesh` (``mesh``, given or made), trim test, coarse-search samples
    (:func:`mesh_samples`), trims' edge search, and lazily its free boundary's segments and
    an evaluator of its patches."""

    def __init__(self, scene: Scene, mesh: TriangleMesh | None = None) -> None:
        from ..analysis.scene_junctions import scene_diagonal

        self.scene = scene
        self.mesh = sample_mesh(scene) if mesh is None else mesh
        self.inside = trim_test(scene)
        self.samples = mesh_samples(scene, self.inside, self.mesh)
        self.boundary = boundary_search(scene)
        self.diagonal = scene_diagonal(scene)

    @cached_property
    def free_edges(self) -> NDArray[np.float64]:
        """The segments (m, 2, 3) of the mesh's free boundary (vertices welded within
        :data:`WELD` of the diagonal)."""
        from ..analysis.coverage import free_edges

        return free_edges(self.mesh.positions, self.mesh.faces, WELD * self.diagonal)

    @cached_property
    def evaluator(self) -> ManyPatches:
        """The patches' derivatives at scattered points (:func:`patch_evaluator`)."""
        from .surface_hits import patch_evaluator

        return patch_evaluator(self.scene.patches)


def measured_deviation(
    P: NDArray, N: NDArray, b: PreparedSurfaces, tolerance: float
) -> tuple[Deviation, NDArray[np.bool_]]:
    """The signed deviation of points ``P`` (normals ``N``) of A from the surfaces ``b``
    (their trims and the trims' edges heeded), and which points lie beyond B's free
    boundary (:func:`gshade.analysis.coverage.uncovered`)."""
    from ..analysis.coverage import NORMAL_COSINE, segment_distances, uncovered

    found = signed_deviation(P, N, b.scene.patches, b.samples, inside=b.inside, boundary=b.boundary)
    beyond = np.zeros(len(P), dtype=bool)
    foot = found.closest
    far = np.flatnonzero(foot.distance > tolerance)
    if not far.size:
        return found, beyond
    d = b.evaluator.derivatives(foot.patch[far], foot.uv[far, 0], foot.uv[far, 1], 1)
    normal = unit_normals(b.scene.patches, foot.patch[far], foot.uv[far], d)
    gap = foot.point[far] - P[far]
    off = np.abs(np.sum(gap * normal, -1)) < NORMAL_COSINE * foot.distance[far]
    ask = far[off]
    if ask.size:
        reach = segment_distances(foot.point[ask], b.free_edges)
        near = 2 * SAMPLE_CHORD * b.diagonal
        beyond[ask] = uncovered(P[ask], foot.point[ask], normal[off], reach, near, tolerance)
    return found, beyond


def covered_summary(
    found: Deviation, beyond: NDArray[np.bool_], tolerance: float, points: NDArray, b: str
) -> tuple[dict[str, Any], NDArray[np.bool_]]:
    """The numbers (:func:`gshade.analysis.deviation.deviation_summary`) of the points
    (n, 3) not ``beyond`` B's free boundary, with ``beyond``, ``beyond_fraction`` and B's
    name ``b``; and which points they are over."""
    covered = ~beyond
    summary = deviation_summary(found.distance[covered], tolerance, points[covered])
    summary["b"] = b
    summary["beyond"] = int(beyond.sum())
    summary["beyond_fraction"] = float(beyond.mean()) if beyond.size else 0.0
    return summary, covered


def patch_numbers(scene: Scene) -> NDArray[np.int64]:
    """Each scene patch's number in the ``patch`` channel: a lone surface's own (a CAD
    model's face numbers), else the index."""
    if len(scene.surfaces) == 1:
        return np.asarray(scene.surfaces[0].body.patch_numbers(0, len(scene.patches)))
    return np.arange(len(scene.patches))


def unit_normals(
    patches: list[Patch] | tuple[Patch, ...],
    index: NDArray[np.int64],
    uv: NDArray[np.float64],
    d: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Unit normals (n, 3) of patches ``index`` at ``uv`` (n, 2) from their first
    derivatives ``d`` (>= (2, 2, n, 3)): p_u x p_v normalised, its limit where the
    parametrisation is irregular (:func:`gshade.geometry.evaluation.regularity.patch_normals`)."""
    from ..geometry.core.differential import derivative_scales, irregular_mask
    from ..geometry.evaluation.regularity import patch_normals

    normal = np.cross(d[1, 0], d[0, 1])
    irregular = irregular_mask(d[:2, :2], scale=derivative_scales(d[:2, :2], index))
    normal /= np.where(irregular, 1.0, np.linalg.norm(normal, axis=-1))[:, None]
    for k in np.unique(index[irregular]).tolist():
        at = np.flatnonzero(irregular & (index == k))
        normal[at] = patch_normals(patches[k], uv[at, 0], uv[at, 1]).n
    return normal


def triangle_points(
    corners: NDArray[np.float64], count: int, seed: int = 0
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """``count`` random points of triangles ``corners`` (m, 3, 3), uniform by area
    (a triangle chosen in proportion to its area, a point uniform in it; seeded): their
    triangles (n,) and barycentric weights (n, 3); none where the area is 0.

    Examples
    --------
    >>> corners = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 0, 1], [3, 0, 1], [0, 3, 1]]])
    >>> face, weights = triangle_points(corners.astype(float), 10_000)
    >>> round(float(np.mean(face == 1)), 1), bool(np.allclose(weights.sum(axis=1), 1))
    (0.9, True)
    """
    edges = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    area = 0.5 * np.linalg.norm(edges, axis=-1)
    total = area.sum()
    if not total > 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    rng = np.random.default_rng(seed)
    face = rng.choice(len(area), size=count, p=area / total)
    r1, r2 = rng.random(count), rng.random(count)
    flip = r1 + r2 > 1
    r1, r2 = np.where(flip, 1 - r1, r1), np.where(flip, 1 - r2, r2)
    return face.astype(np.int64), np.stack([1 - r1 - r2, r1, r2], -1)


def surface_samples(
    scene: Scene, count: int = SURFACE_SAMPLES, seed: int = 0, mesh: TriangleMesh | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """About ``count`` points (n, 3) of a scene's surfaces, spread by area independently of
    any view, and their unit normals (n, 3): random points of :func:`sample_mesh`'s
    triangles (each chosen in proportion to its area, uniform in it; seeded) moved onto
    the exact patches at their interpolated (u, v), those off a CAD face's trims left out
    (``mesh``: the scene's sample mesh where made already)."""
    from ..geometry.core.patch import unit_to_domain
    from .surface_hits import patch_evaluator

    mesh = sample_mesh(scene) if mesh is None else mesh
    face, weights = triangle_points(mesh.positions[mesh.faces], count, seed)
    if not len(face):
        return np.zeros((0, 3)), np.zeros((0, 3))
    vertices = mesh.faces[face]
    params = mesh.params[vertices]  # (n, 3, 2) in each patch's unit square
    st = np.einsum("nk,nkc->nc", weights, params)
    index = mesh.patch[vertices[:, 0]].astype(np.int64)
    domains = np.array([p.domain for p in scene.patches], dtype=np.float64)
    u, v = unit_to_domain(domains, st[:, 0], st[:, 1], index)
    uv = np.stack([u, v], -1)
    trims = trim_test(scene)
    if trims is not None:
        kept = trims(index, uv)
        index, uv = index[kept], uv[kept]
    d = patch_evaluator(scene.patches).derivatives(index, uv[:, 0], uv[:, 1], 1)
    return d[0, 0], unit_normals(scene.patches, index, uv, d)
