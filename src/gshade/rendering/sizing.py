"""How fine a render is: the framing box, the mesh resolution, the texture tile, and the
checks that the surfaces' scale and the render's memory are within reach.

The mesh follows the chord-error tolerance: the smaller of ``chord_tolerance`` times the
bounding-box diagonal and half a pixel at the nearest point.  The tiles give about one texel
every :data:`PIXELS_PER_TEXEL` pixels of each patch's projected size.  Both stay within
a budget of samples that grows with the image (a camera close to or inside the surfaces asks
for more than a small image can show).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from ..limits import MIN_CHORD_TOLERANCE, gigabytes, memory_budget, render_memory
from ..scene.model import RenderSettings, Scene
from .atlas import BLOCK
from .camera import View, frame_view
from .surface_meshes import gridded_patches
from .tessellate import max_chord_resolution

__all__ = [
    "MAX_ATLAS_TEXELS",
    "MAX_TILE",
    "MAX_VERTICES",
    "MIN_EXTENT",
    "MIN_TILE",
    "NEAREST_FRACTION",
    "Framing",
    "chord_tolerance",
    "extent_points",
    "frame",
    "mesh_resolution",
    "tile_sizes",
    "validate_memory",
]

#: Smallest bounding-box diagonal rendered: the curvatures of smaller surfaces (1/length²)
#: and their gradients leave single precision.
MIN_EXTENT = 1e-9
#: Nearest depth, as a fraction of the bounding-box diagonal, that sets the tessellation's
#: and the textures' resolution: a camera inside the surfaces (or touching them) must not
#: ask for the finest mesh and atlas everywhere.
NEAREST_FRACTION = 1e-2
#: Pixels per texel of the largest patch: f is interpolated bicubically from exact values and
#: derivatives (error O(h^4)).  Dense stripes at grazing rims (zebra) still move with the
#: texel spacing, so this is a trade with the textures' memory (a texel every 3 pixels took
#: 1.8x the texels; benchmarks/RESULTS.md, "Measurements behind code choices").
PIXELS_PER_TEXEL = 4
#: Texels per pixel that tiles may take beyond each patch's own need: while all tiles of the
#: largest patch's size fit, every patch gets one (small patches then resolve their shape
#: function finely, as before 0.8); else the smaller tiles are raised alike until they fit.
TEXELS_PER_PIXEL = 2
#: Bounds on the texels per patch side, and on the whole atlas.
MIN_TILE, MAX_TILE, MAX_ATLAS_TEXELS = 8, 512, 4096 * 4096
#: The most mesh vertices of an automatic tessellation.
MAX_VERTICES = 4_000_000


def _budget(pixels: int, most: int) -> int:
    """Automatic mesh vertices or atlas texels for an image: 16 per pixel (at least 2^18,
    at most ``most``); a camera close to or inside the surfaces asks for more than a small
    image can show."""
    return int(np.clip(16 * pixels, 2**18, most))


@dataclass(frozen=True)
class Framing:
    """The surfaces' bounding box (corners ``lo``, ``hi``, diagonal ``diag``) and the view."""

    lo: NDArray
    hi: NDArray
    diag: float
    view: View


def frame(scene: Scene, settings: RenderSettings, where: str) -> Framing:
    """The bounding box of the patches (sampled on a 17 x 17 grid each; a CAD face at its
    loops and the grid points inside them), checked to be renderable in single precision,
    and the resolved camera."""
    box = extent_points(scene)
    lo, hi = box.min(axis=0), box.max(axis=0)
    diag = _validate_scale(where, lo, hi)
    try:
        view = frame_view(scene.camera, box, settings.width, settings.height)
    except GshadeError as exc:  # "[camera] ...": about the view the scene's camera gives
        raise GshadeError(f"{where}: {exc}") from None
    return Framing(lo, hi, diag, view)


def _patch_extents(scene: Scene) -> Iterator[NDArray[np.float64]]:
    """Per patch, a grid of points (a, b, 3) standing for the extent its tile covers
    (:meth:`gshade.scene.bodies.SurfaceBody.tile_extents`)."""
    for surface in scene.surfaces:
        yield from surface.body.tile_extents(surface.patches)


def extent_points(scene: Scene) -> NDArray:
    """Points standing for the surfaces' extent
    (:meth:`gshade.scene.bodies.SurfaceBody.extent_points`: a patch's 17 x 17 grid, a CAD
    face's trimmed region)."""
    return np.concatenate([s.body.extent_points(s.patches) for s in scene.surfaces])


def _nearest_distance(view: View, lo: NDArray, hi: NDArray) -> float:
    """Distance from the eye to the nearest point of the bounding box along the view axis."""
    corners = np.array(
        [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    )
    depth = (corners - view.origin) @ view.forward
    return float(max(depth.min(), NEAREST_FRACTION * np.linalg.norm(hi - lo)))


def chord_tolerance(scene: Scene, settings: RenderSettings, framing: Framing) -> float:
    """The chord-error tolerance in scene units: ``chord_tolerance`` times the diagonal, at
    most half a pixel at the nearest point, and no finer than single precision resolves (a
    tiny view must not ask for more)."""
    view, lo, hi, diag = framing.view, framing.lo, framing.hi, framing.diag
    tol = settings.chord_tolerance * diag
    if scene.camera.type == "perspective" or view.width is not None:
        tol = min(tol, 0.5 * view.pixel_size(_nearest_distance(view, lo, hi)))
    return max(tol, MIN_CHORD_TOLERANCE * diag)


def mesh_resolution(scene: Scene, settings: RenderSettings, framing: Framing) -> int:
    """Vertices per patch side: ``tessellation`` if set, else the coarsest grid within the
    chord tolerance (no finer than single precision resolves, and within the budget) of
    the patches meshed on it (:func:`gshade.rendering.surface_meshes.gridded_patches`; 2
    where none are: a CAD model's faces are meshed within the tolerance by the kernel)."""
    if settings.tessellation:
        return int(settings.tessellation)
    patches = gridded_patches(scene)
    if not patches:
        return 2
    resolution = max_chord_resolution(patches, chord_tolerance(scene, settings, framing))
    # keep the mesh within what the image can show (a few million vertices at most)
    budget = _budget(settings.width * settings.height, MAX_VERTICES)
    return min(resolution, max(2, int(np.sqrt(budget / len(patches)))))


def tile_sizes(scene: Scene, framing: Framing) -> NDArray[np.int64]:
    """Texels per tile, (columns along s, rows along t) per patch: ``texture_resolution``
    for all if set, else from the patches' projected sizes.  While every patch can have the
    largest one's square tile (about one texel every :data:`PIXELS_PER_TEXEL` pixels of its
    projected extent) within :data:`TEXELS_PER_PIXEL`, all get it, as before 0.8.  Else each
    side follows its own patch's projected length along s and t (a texel every
    :data:`PIXELS_PER_TEXEL` pixels), the shorter sides raised alike (:func:`_fill`) within
    the same texels, in multiples of :data:`gshade.rendering.atlas.BLOCK`: hundreds of small
    faces, or long thin ones, cost what their pixels cost."""
    n = len(scene.patches)
    if scene.render.texture_resolution:
        side = int(np.clip(scene.render.texture_resolution, 2, MAX_TILE))
        return np.full((n, 2), side)
    view, lo, hi = framing.view, framing.lo, framing.hi
    extents, lengths = [], []
    for grid in _patch_extents(scene):
        pts = grid.reshape(-1, 3)
        depth = float((pts.mean(axis=0) - view.origin) @ view.forward)
        depth = max(depth, NEAREST_FRACTION * float(np.linalg.norm(hi - lo)))
        pixel = view.pixel_size(depth)
        extents.append(float(np.linalg.norm(np.ptp(pts, axis=0))) / pixel)
        # the longest polyline along s (the grid's first axis) and along t
        along_s = np.linalg.norm(np.diff(grid, axis=0), axis=-1).sum(axis=0).max()
        along_t = np.linalg.norm(np.diff(grid, axis=1), axis=-1).sum(axis=1).max()
        lengths.append((along_s / pixel, along_t / pixel))
    pixels = scene.render.width * scene.render.height
    spend = TEXELS_PER_PIXEL * pixels
    budget = _budget(pixels, MAX_ATLAS_TEXELS)
    square = np.clip(np.ceil(np.asarray(extents) / PIXELS_PER_TEXEL) + 1, MIN_TILE, MAX_TILE)
    largest = max(2, min(int(square.max()), int(np.sqrt(budget / n))))
    if n * largest**2 <= spend:  # every patch the largest one's tile
        return np.full((n, 2), largest)
    own = np.clip(np.ceil(np.asarray(lengths) / PIXELS_PER_TEXEL) + 1, MIN_TILE, MAX_TILE)
    tiles = _fill(own, spend)
    total = float(tiles.prod(axis=1).sum())
    if total > budget:  # all alike, none below MIN_TILE
        tiles = BLOCK * np.floor(tiles * np.sqrt(budget / total) / BLOCK)
        tiles = np.maximum(tiles, BLOCK * np.ceil(MIN_TILE / BLOCK))
    return tiles.astype(np.int64)


def _fill(own: NDArray, texels: int) -> NDArray:
    """The tiles max(own, T*) side by side (in multiples of BLOCK) with the largest common
    side T* (at most the longest side) whose tiles hold at most ``texels`` texels (none
    raised if even the tiles ``own`` exceed it)."""
    own = BLOCK * np.ceil(own / BLOCK)
    lo, hi = 0, int(own.max()) // BLOCK  # T* = BLOCK * m, m in [lo, hi]
    while lo < hi:  # the largest m within the texels
        m = (lo + hi + 1) // 2
        if float(np.maximum(own, BLOCK * m).prod(axis=1).sum()) <= texels:
            lo = m
        else:
            hi = m - 1
    return np.maximum(own, BLOCK * lo)


def _validate_scale(where: str, lo: NDArray, hi: NDArray) -> float:
    """The bounding box's diagonal, checked to be renderable in single precision: Mitsuba
    stores positions, and gshade's textures the shape function's values, as float32."""
    diag = float(np.linalg.norm(hi - lo))
    size = float(np.abs(np.concatenate([lo, hi])).max())
    if not np.isfinite(diag) or diag < MIN_EXTENT:
        raise GshadeError(
            f"{where}: the surfaces span {diag:.3g} (bounding-box diagonal): expected at least "
            f"{MIN_EXTENT:g}, so that curvatures stay within single precision"
        )
    if diag < 1e-6 * size:
        raise GshadeError(
            f"{where}: the surfaces span {diag:.3g} at a distance {size:.3g} from the origin: "
            "expected a span of at least 1e-6 of that distance (single-precision positions)"
        )
    return diag


def validate_memory(where: str, settings: RenderSettings, vertices: int, texels: int) -> None:
    """Refuse a render whose estimated peak memory exceeds :func:`gshade.limits.memory_limit`
    (the message says what set the limit: ``GSHADE_MEMORY_LIMIT``, the machine's memory, the
    container's limit or ``ulimit -v``)."""
    pixels = settings.width * settings.height
    need = render_memory(pixels, vertices, texels)
    limit, source = memory_budget()
    if need > limit:
        raise GshadeError(
            f"{where}: the render would need about {gigabytes(need)} ({settings.width} x "
            f"{settings.height} pixels, {vertices} mesh vertices, {texels} texels); the limit is "
            f"{gigabytes(limit)} ({source})"
        )
