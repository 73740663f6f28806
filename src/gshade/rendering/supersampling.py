"""Which pixels need more than one sample: where the picture is discontinuous.

A shape picture is smooth almost everywhere: f, its stripes (box-filtered exactly over the
pixel's footprint, :func:`gshade.display.colour.coverage_formula`), its colour map and the
``lit`` shading all vary smoothly across a pixel inside a patch, so one sample at the pixel
centre, filtering over the whole pixel, gives the pixel's value up to second-order terms
(the mean over ``spp`` symmetric samples differs from it by the curvature of the picture
across the pixel).  What one sample cannot average is a jump inside the pixel:

* the outline of a surface and the edges where one part hides another: every such edge in
  the image is the projection of a *silhouette edge* of the rendered mesh (its two triangles
  face opposite ways as seen from the eye) or of a *boundary edge* (one triangle; patches'
  edges where they are not welded, trimmed outlines): :func:`silhouette_pixels` marks the
  pixels those edges cross, so that even features thinner than a pixel are found;
* between the samples at neighbouring pixel centres (:func:`discontinuous_pixels`): a ray
  that hits and one that misses, two different patches (a crease, or f jumping at a G0 or G1
  junction), a shadow edge or the edge of a region where f is undefined (the integrator's
  ``flags``), or f jumping by more than its slopes allow (a branch cut).  Where f bends
  strongly within a pixel (its derivatives differ between neighbours: narrow curved stripes,
  their tips), one linear footprint is not enough either.

These pixels get ``spp`` samples (:mod:`gshade.rendering.pixel_sensor`), the others keep
their centre sample.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..display.bands import LINE_WIDTH
from .atlas import Atlas
from .camera import View
from .integrator import SHAPE_FILM
from .tessellate import TriangleMesh

if TYPE_CHECKING:
    from ..shape import Bands

__all__ = ["discontinuous_pixels", "silhouette_pixels"]

#: f jumps between neighbouring pixel centres when it changes by more than this many times
#: the sum of their slopes |df/dx| + |df/dy| (a smooth f changes by at most about one)
JUMP = 2.0
#: f bends within a pixel when its derivatives change between neighbours by more than this
#: many visible changes: its second-order term over half a pixel, |d2f| / 8, is then more than
#: ten of them, and one sample's linear footprint would misplace stripes and colours
BEND = 80.0
#: ... and near a stripe edge, by more than this many (the edge's place moves visibly), or by
#: more than this fraction of the footprint's span |df/dx| + |df/dy| (where f is nearly flat,
#: at an extremum on an edge, a small bend moves the edge across much of the pixel)
EDGE_BEND, EDGE_CURVE = 8.0, 0.08
#: a colour-mapped f spans more than this many visible changes over a pixel: its colours'
#: mean is no longer the colour at the centre
SPREAD = 10.0
#: samples per pixel along a projected edge (then the marks grow by a pixel each way)
EDGE_SAMPLES_PER_PIXEL = 2

#: neighbour offsets (rows, columns) whose pairs cover all 8-neighbours once
_NEIGHBOURS = ((0, 1), (1, 0), (1, 1), (1, -1))


def discontinuous_pixels(
    centres: NDArray,
    atlas: Atlas,
    visible_change: float,
    stripes: tuple[float, float, float] | None = None,
    bands: Bands | None = None,
) -> NDArray:
    """Pixels (H, W) whose centre sample differs discontinuously from a neighbour's.

    Parameters
    ----------
    centres : ndarray, shape (H, W, channels)
        The film of one sample at each pixel centre, channels
        :data:`gshade.rendering.integrator.SHAPE_FILM`.
    atlas : Atlas
        The atlas the samples' ``x``, ``y`` address (the patch of each hit).
    visible_change : float
        A change of f too small to see (it never counts as a jump).
    stripes : (period, phase, duty), optional
        The stripes f is shown with: a pixel whose footprint, widened by f's bending,
        reaches a stripe edge needs more samples where f bends visibly.  Without stripes f
        is colour-mapped, which has no exact filter: a pixel over which f spans more than
        SPREAD visible changes needs more samples.
    bands : Bands, optional
        The bands f is shown with (``display = "bands"``): their edges and lines count as
        stripe edges do (a line as its two sides).
    """
    marked = np.zeros(centres.shape[:2], bool)
    rows, cols = np.nonzero(centres[..., SHAPE_FILM.index("A")] > 0.5)
    if rows.size:  # the hits' box and a pixel around it: no pair outside it has a hit
        box = (
            slice(max(rows.min() - 1, 0), rows.max() + 2),
            slice(max(cols.min() - 1, 0), cols.max() + 2),
        )
        marked[box] = _discontinuous(centres[box], atlas, visible_change, stripes, bands)
    return marked


def _discontinuous(
    centres: NDArray,
    atlas: Atlas,
    visible_change: float,
    stripes: tuple[float, float, float] | None,
    bands: Bands | None = None,
) -> NDArray:
    """:func:`discontinuous_pixels` of a film."""
    hit = centres[..., SHAPE_FILM.index("A")] > 0.5
    patch = np.full(hit.shape, -1, dtype=np.int64)
    xy = centres[..., [SHAPE_FILM.index("x"), SHAPE_FILM.index("y")]][hit]
    patch[hit] = atlas.locate(xy.astype(np.float64))[0]
    flags = centres[..., SHAPE_FILM.index("flags")]
    f, fx, fy = (centres[..., SHAPE_FILM.index(c)] for c in ("f", "f_x", "f_y"))
    slope = np.abs(fx) + np.abs(fy)
    near_edge = None
    if stripes is not None:  # f's distance to the nearest stripe edge
        period, phase, duty = stripes
        t = np.mod(f / period + phase, 1.0)
        near_edge = period * np.minimum(np.minimum(t, np.abs(t - duty)), 1.0 - t)
    if bands is not None:  # f's distance to the nearest band edge or side of a line
        near_edge = np.full(f.shape, np.inf)
        for level in bands.edges:
            near_edge = np.minimum(near_edge, np.abs(f - level))
        half_line = 0.5 * LINE_WIDTH * np.hypot(fx, fy)
        for level in bands.lines:
            near_edge = np.minimum(near_edge, np.abs(np.abs(f - level) - half_line))
    if near_edge is None:
        marked = hit & (slope > SPREAD * visible_change)
    else:
        marked = np.zeros(hit.shape, bool)
    for dy, dx in _NEIGHBOURS:
        a, b = _pair(hit.shape, dy, dx)
        both = hit[a] & hit[b]
        bend = np.abs(fx[a] - fx[b]) + np.abs(fy[a] - fy[b])
        bends = bend > BEND * visible_change
        if near_edge is not None:  # the quadratic term moves an edge across the pixel
            reach = 0.5 * np.maximum(slope[a], slope[b]) + 0.25 * bend
            at_edge = np.minimum(near_edge[a], near_edge[b]) < reach
            wide = np.maximum(slope[a], slope[b])
            bends |= at_edge & (bend > np.minimum(EDGE_BEND * visible_change, EDGE_CURVE * wide))
        jump = (hit[a] != hit[b]) | (
            both
            & (
                (patch[a] != patch[b])
                | (flags[a] != flags[b])
                | (np.abs(f[a] - f[b]) > JUMP * (slope[a] + slope[b]) + visible_change)
                | bends
            )
        )
        marked[a] |= jump
        marked[b] |= jump
    return marked


def _pair(shape: tuple[int, ...], dy: int, dx: int) -> tuple[tuple[slice, slice], ...]:
    """Slices a, b of an (H, W) image such that b[i] is a[i]'s neighbour at (dy, dx)."""
    H, W = shape[:2]
    rows_a, rows_b = slice(0, H - dy), slice(dy, H)
    cols_a = slice(max(0, -dx), W - max(0, dx))
    cols_b = slice(max(0, dx), W - max(0, -dx))
    return (rows_a, cols_a), (rows_b, cols_b)


def silhouette_pixels(mesh: TriangleMesh, view: View) -> NDArray:
    """Pixels (H, W) crossed by the projection of a silhouette or boundary edge of the mesh
    (vertices at equal positions welded), and their 8-neighbours."""
    H, W = view.image_height, view.image_width
    marked = np.zeros((H, W), bool)
    _, first, vertex = np.unique(_row_keys(mesh.positions), return_index=True, return_inverse=True)
    faces = vertex.reshape(-1)[mesh.faces]
    c0, c1, c2 = (mesh.positions[mesh.faces[:, k]] for k in range(3))
    normal = np.cross(c1 - c0, c2 - c0)
    if view.type == "orthographic":
        towards = np.broadcast_to(view.forward, normal.shape)
    else:
        towards = c0 - view.origin
    front = np.einsum("ij,ij->i", normal, towards) < 0
    ends = _silhouette_edges(faces, front, len(mesh.positions))
    if not len(ends):
        return marked
    points = mesh.positions[first[ends.ravel()]]
    x, y, z = (c.reshape(-1, 2) for c in view.camera_coordinates(points))
    if view.type != "orthographic":  # the parts of edges in front of the eye
        near = 1e-6 * float(np.linalg.norm(view.target - view.origin))
        x, y, z = _clip_to_front(x, y, z, near)
    cols, rows = view.image_positions(x, y, z)
    cols, rows = _clip_to_box(cols, rows, (-1.0, W + 1.0), (-1.0, H + 1.0))
    r, c = _rasterise(cols, rows, W, H)
    marked[r, c] = True
    return _grow(marked)


def _row_keys(positions: NDArray) -> NDArray:
    """One hashable key per row of a float array (its bytes), for welding equal positions."""
    rows = np.ascontiguousarray(positions, dtype=np.float64)
    return rows.view(np.dtype((np.void, rows.dtype.itemsize * rows.shape[1]))).ravel()


def _silhouette_edges(faces: NDArray, front: NDArray, n_vertices: int) -> NDArray:
    """Edges (m, 2) of one triangle, of more than two, or between a front- and a back-facing
    triangle."""
    a = faces[:, [0, 1, 2]].ravel()
    b = faces[:, [1, 2, 0]].ravel()
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo.astype(np.int64) * n_vertices + hi
    order = np.argsort(key, kind="stable")
    key, facing = key[order], np.repeat(front, 3)[order]
    starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    counts = np.diff(np.r_[starts, key.size])
    fronts = np.add.reduceat(facing.astype(np.int64), starts)
    keep = (counts != 2) | (fronts == 1)
    edge = key[starts[keep]]
    return np.stack([edge // n_vertices, edge % n_vertices], -1)


def _clip_to_front(
    x: NDArray, y: NDArray, z: NDArray, near: float
) -> tuple[NDArray, NDArray, NDArray]:
    """Segments ((m, 2) end coordinates) cut to their parts with z >= near; those wholly
    behind dropped."""
    keep = (z >= near).any(axis=1)
    x, y, z = x[keep].copy(), y[keep].copy(), z[keep].copy()
    for end, other in ((0, 1), (1, 0)):
        behind = z[:, end] < near
        t = (near - z[behind, end]) / (z[behind, other] - z[behind, end])
        for c in (x, y):
            c[behind, end] += t * (c[behind, other] - c[behind, end])
        z[behind, end] = near
    return x, y, z


def _clip_to_box(
    cols: NDArray,
    rows: NDArray,
    col_range: tuple[float, float],
    row_range: tuple[float, float],
) -> tuple[NDArray, NDArray]:
    """Segments ((m, 2) end positions) cut to a box (Liang-Barsky); those outside dropped."""
    c0, dc = cols[:, 0], cols[:, 1] - cols[:, 0]
    r0, dr = rows[:, 0], rows[:, 1] - rows[:, 0]
    t0, t1 = np.zeros(len(c0)), np.ones(len(c0))
    with np.errstate(divide="ignore", invalid="ignore"):
        for start, delta, (lo, hi) in ((c0, dc, col_range), (r0, dr, row_range)):
            for p, q in ((-delta, start - lo), (delta, hi - start)):
                t = q / p
                parallel = p == 0
                t0 = np.where(~parallel & (p < 0), np.maximum(t0, t), t0)
                t1 = np.where(~parallel & (p > 0), np.minimum(t1, t), t1)
                t1 = np.where(parallel & (q < 0), -1.0, t1)  # parallel and outside
    keep = t0 <= t1
    c0, dc, r0, dr, t0, t1 = (a[keep] for a in (c0, dc, r0, dr, t0, t1))
    cols = np.stack([c0 + t0 * dc, c0 + t1 * dc], -1)
    rows = np.stack([r0 + t0 * dr, r0 + t1 * dr], -1)
    return cols, rows


def _rasterise(cols: NDArray, rows: NDArray, W: int, H: int) -> tuple[NDArray, NDArray]:
    """Pixels (rows, columns) of samples every 1/EDGE_SAMPLES_PER_PIXEL pixel along the
    segments (cols, rows: (m, 2) end positions), within the image."""
    c0, c1 = cols[:, 0], cols[:, 1]
    r0, r1 = rows[:, 0], rows[:, 1]
    length = np.maximum(np.abs(c1 - c0), np.abs(r1 - r0))
    steps = np.ceil(length * EDGE_SAMPLES_PER_PIXEL).astype(np.int64) + 1
    segment = np.repeat(np.arange(len(steps)), steps)
    first = np.repeat(np.cumsum(steps) - steps, steps)
    t = (np.arange(segment.size) - first) / np.maximum(steps[segment] - 1, 1)
    c = np.floor(c0[segment] + t * (c1 - c0)[segment]).astype(np.int64)
    r = np.floor(r0[segment] + t * (r1 - r0)[segment]).astype(np.int64)
    inside = (c >= 0) & (c < W) & (r >= 0) & (r < H)
    return r[inside], c[inside]


def _grow(marked: NDArray) -> NDArray:
    """The marked pixels and their 8-neighbours."""
    out = marked.copy()
    for dy, dx in _NEIGHBOURS:
        a, b = _pair(marked.shape, dy, dx)
        out[a] |= marked[b]
        out[b] |= marked[a]
    return out
