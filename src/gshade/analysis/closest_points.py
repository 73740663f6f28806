"""Closest points on exact surfaces: for each query point q, the point S_k(u, v) of a set of
patches nearest to it, with its patch and (u, v).

A coarse search first: every patch sampled on a grid of its domain
(:func:`gshade.analysis.surface_samples.grid_samples`), the samples in a k-d tree
(:class:`scipy.spatial.cKDTree`), the :data:`CANDIDATES` nearest samples of q each a start
of Newton's method on the exact surface
(:func:`gshade.analysis.foot_points.foot_parameters`).  Last, every patch the nearest
samples did not lead to is asked where it can come nearer: its samples are grouped in
blocks (:class:`~gshade.analysis.surface_samples.Blocks`), each boxed and widened by two
of its cell diagonals, and every block whose box lies nearer to q than the best point found
is a start of its own, asked once for a tile of queries near each other
(:func:`_block_round`).  The nearest of the foot points is the answer.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..geometry import Patch
from .foot_points import SurfacePatches, foot_parameters
from .surface_samples import Blocks, Samples, grid_samples

__all__ = ["CANDIDATES", "ON_SURFACE", "TILE", "ClosestPoints", "closest_points"]

#: Nearest samples each query starts Newton's method from (on their patches).
CANDIDATES = 4
#: A query this near a foot point, relative to the patches' size, is on the surface: no
#: patch can hold a nearer point worth the search.
ON_SURFACE = 1e-13
#: Queries near each other (along a Morton curve) asked for the last round's blocks at once.
TILE = 16
#: A tile's widest reach from its centre, in its queries' distances to their nearest
#: samples (wider, Newton's method from one start may end at other minima for the centre
#: and for a query: the tile split in 4, then in single queries).
TILE_SPREAD = 3.0
#: The sizes of the groups of queries (each a multiple of the next) the blocks near them
#: are found for, largest first (:func:`_near_blocks`).
GROUPS = (1024, 256, 64, 16, 4, 1)


@dataclass(frozen=True)
class ClosestPoints:
    """Each query's closest point ``point`` (n, 3) on the patches, its ``patch`` (n,),
    its parameters ``uv`` (n, 2) there and the ``distance`` (n,)."""

    point: NDArray[np.float64]
    patch: NDArray[np.int64]
    uv: NDArray[np.float64]
    distance: NDArray[np.float64]


def closest_points(
    patches: Sequence[Patch],
    queries: ArrayLike,
    *,
    samples: Samples | None = None,
    candidates: int = CANDIDATES,
    inside: Callable[[NDArray[np.int64], NDArray[np.float64]], NDArray[np.bool_]] | None = None,
    boundary: Callable[[NDArray[np.float64]], ClosestPoints] | None = None,
) -> ClosestPoints:
    """The points of ``patches`` nearest to each of ``queries`` (n, 3): from the
    ``candidates`` nearest of the ``samples`` (default :func:`grid_samples`), Newton's
    method on the exact patches (:func:`foot_points`), then from the middle of every block
    of another patch whose box comes nearer (see the module), the nearest foot point kept.

    Trimmed patches: ``inside(index, uv)`` says which (u, v) of patches ``index`` are
    part of the surface (a foot point elsewhere is none), and ``boundary(queries)`` gives
    the closest points on the trims' curves
    (:func:`gshade.analysis.trimmed_faces.boundary_search`), asked for the queries a foot
    point outside the trims was found for.

    Examples
    --------
    >>> from gshade.geometry import sphere
    >>> found = closest_points([sphere(2.0)], [[0.0, 3.0, 4.0]])
    >>> (np.round(found.point, 12) + 0.0).tolist(), round(float(found.distance[0]), 12)
    ([[0.0, 1.2, 1.6]], 3.0)
    """
    from scipy.spatial import cKDTree

    q = np.asarray(queries, dtype=np.float64).reshape(-1, 3)
    samples = samples if samples is not None else grid_samples(patches)
    points, owner = samples.points, samples.patch
    tree = cKDTree(points)
    surfaces = SurfacePatches(patches)
    size = float(np.linalg.norm(np.ptp(points, axis=0)))
    best = ClosestPoints(
        np.zeros_like(q), np.zeros(len(q), np.int64), np.zeros((len(q), 2)), np.full(len(q), np.inf)
    )
    if not len(q):
        return best
    k = min(candidates, len(points))
    distance, nearest = tree.query(q, k=k)
    nearest = np.asarray(nearest).reshape(len(q), k)
    spacing = np.asarray(distance).reshape(len(q), k)
    outside = _first_round(surfaces, q, samples, best, nearest, inside)
    if boundary is not None and outside.any():  # the closest points on the trims' curves
        _merge(best, np.flatnonzero(outside), boundary(q[outside]))
    # the last round: every block of a patch the query has not asked whose box comes
    # nearer than the best point found (or than its nearest sample, a point of the
    # surface), Newton's method from the block's middle; a query on the surface (to
    # rounding) has its answer.  Asked for tiles of queries near each other at once
    # (:func:`_block_round`)
    m = len(patches)
    asked = np.unique(np.arange(len(q))[:, None] * m + owner[nearest])
    unsure = np.flatnonzero(best.distance > ON_SURFACE * size)
    reach = np.minimum(best.distance, spacing[:, 0])
    who, patch, start = _block_round(
        surfaces, samples.blocks, q, unsure, reach, spacing[:, 0], best
    )
    new = ~np.isin(who * m + patch, asked)
    who, patch, start = who[new], patch[new], start[new]
    if who.size:
        out = _tried(surfaces, q, who, patch, start, best, inside)
        fresh = np.setdiff1d(who[out], np.flatnonzero(outside))
        if boundary is not None and fresh.size:
            _merge(best, fresh, boundary(q[fresh]))
    return best


def _tried(
    surfaces: SurfacePatches,
    q: NDArray,
    who: NDArray,
    on: NDArray,
    start: NDArray,
    best: ClosestPoints,
    inside: Callable[[NDArray[np.int64], NDArray[np.float64]], NDArray[np.bool_]] | None,
) -> NDArray[np.bool_]:
    """Newton's method for queries ``who`` on patches ``on`` from ``start`` (u, v), all at
    once; each query's nearest foot point inside the trims kept in ``best`` where nearer.
    Which of the feet lie outside the trims and nearer than the best point found (there,
    the face's own closest point may be on its trims' curves; a foot outside and farther
    bounds the face's distance from below: nothing nearer there)."""
    feet, distance = foot_parameters(surfaces, on, q[who], start)
    out = np.zeros(len(who), dtype=bool)
    unbounded = distance.copy()
    if inside is not None:
        out = ~inside(on, feet)
        distance[out] = np.inf
    order = np.lexsort((distance, who))  # each query's nearest foot point first
    lead = order[np.r_[True, who[order][1:] != who[order][:-1]]]
    lead = lead[distance[lead] < best.distance[who[lead]]]
    point = surfaces.derivatives(on[lead], feet[lead], 0)[0, 0]
    _merge(best, who[lead], ClosestPoints(point, on[lead], feet[lead], distance[lead]))
    return out & (unbounded < best.distance[who])


def _block_round(
    surfaces: SurfacePatches,
    blocks: Blocks,
    q: NDArray,
    unsure: NDArray,
    reach: NDArray,
    spacing: NDArray,
    best: ClosestPoints,
) -> tuple[NDArray, NDArray, NDArray]:
    """The starts of the last round: (query, patch, (u, v)) for the queries ``unsure``.

    The queries in tiles of :data:`TILE` along a Morton curve (near each other in space),
    each tile a ball (its centre c, radius rho); the nearest blocks of each patch whose box
    comes within the tile's largest ``reach`` + rho of c (:func:`_near_blocks`) Newton's
    method from its middle for c, its foot f at distance D; a patch farther than that from
    c is at least D - |q - c| from a query q of the tile (the distance is 1-Lipschitz), so
    only the queries with D - |q - c| below their best distance start from f."""
    if not unsure.size:
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty, np.zeros((0, 2))
    order = unsure[np.argsort(_morton(q[unsure]), kind="stable")]
    label = np.arange(order.size)
    for size in (4, TILE):  # tiles wider than their queries' sample spacing split in 4
        label = _split(label, order, q, spacing, size)
    first = np.flatnonzero(np.r_[True, label[1:] != label[:-1]])
    count, centre, apart, radius = _balls(q[order], first)
    tiles, block = _near_blocks(blocks, centre, np.maximum.reduceat(reach[order], first) + radius)
    patch = blocks.patch[block]
    feet, distance = foot_parameters(surfaces, patch, centre[tiles], blocks.uv[block])
    # every pair (tile, block) for each member of the tile
    pair = np.repeat(np.arange(tiles.size), count[tiles])
    offset = np.arange(pair.size) - np.repeat(np.cumsum(count[tiles]) - count[tiles], count[tiles])
    at = first[tiles[pair]] + offset
    who = order[at]
    # a foot farther than the block's box reaches left the block for another minimum:
    # no bound there, the block's middle the start of each member
    here = centre[tiles]
    far = np.maximum(np.abs(blocks.lo[block] - here), np.abs(blocks.hi[block] - here))
    left = distance > np.linalg.norm(far, axis=-1)
    feet[left] = blocks.uv[block[left]]
    distance[left] = -np.inf
    keep = distance[pair] - apart[at] < best.distance[who]
    return who[keep], patch[pair[keep]], feet[pair[keep]]


def _split(label: NDArray, order: NDArray, q: NDArray, spacing: NDArray, size: int) -> NDArray:
    """Tiles of ``size`` consecutive queries ``order`` where they are within their
    largest ``spacing`` of their centre, else ``label`` (a tile a query: its own)."""
    tile = np.arange(order.size) // size
    first = np.arange(0, order.size, size)
    radius = _balls(q[order], first)[3]
    small = radius <= TILE_SPREAD * np.maximum.reduceat(spacing[order], first)
    return np.where(small[tile], (size + 1) * order.size + tile, label)


def _balls(points: NDArray, first: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """The groups of consecutive points (n, 3) starting at ``first`` as balls: each
    group's count and centre (its points' mean), each point's distance from its group's
    centre, and each group's radius (the largest of those)."""
    count = np.diff(np.r_[first, len(points)])
    centre = np.add.reduceat(points, first) / count[:, None]
    apart = np.linalg.norm(points - centre[np.repeat(np.arange(first.size), count)], axis=-1)
    return count, centre, apart, np.maximum.reduceat(apart, first)


def _morton(points: NDArray) -> NDArray[np.uint64]:
    """The points' (n, 3) places along a Morton (Z-order) curve through their box, 21 bits
    an axis: near places, near points."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    scale = (2**21 - 1) / np.maximum(hi - lo, 1e-300)
    cell = ((points - lo) * scale).astype(np.uint64)
    code = np.zeros(len(points), dtype=np.uint64)
    for bit in range(21):
        for axis in range(3):
            code |= ((cell[:, axis] >> np.uint64(bit)) & np.uint64(1)) << np.uint64(3 * bit + axis)
    return code


def _near_blocks(blocks: Blocks, q: NDArray, reach: NDArray) -> tuple[NDArray, NDArray]:
    """The (query, block) pairs whose box comes within ``reach`` (n,) of the query ``q``
    (n, 3), the nearest box of each patch (all of the nearest where several tie).  The
    queries (in Morton order: consecutive ones near each other) in groups of
    :data:`GROUPS` sizes, each group a ball; the boxes within a group's largest reach of
    its ball, then those of them within each of its smaller groups' reach, down to the
    queries'."""
    pairs = None
    for size, larger in zip(GROUPS, (0, *GROUPS[:-1]), strict=True):
        first = np.arange(0, len(q), size)
        _, centre, _, radius = _balls(q, first)
        within = np.maximum.reduceat(reach, first) + radius
        if pairs is None:  # every box for the largest groups
            group = np.repeat(np.arange(first.size), len(blocks.lo))
            block = np.tile(np.arange(len(blocks.lo)), first.size)
        else:  # the boxes of a group's parent for each of its groups
            parent, block = pairs
            per = larger // size
            group = np.repeat(parent * per, per) + np.tile(np.arange(per), parent.size)
            block = np.repeat(block, per)
            kept = group < first.size
            group, block = group[kept], block[kept]
        near = _box_distances(blocks, block, centre[group]) < within[group]
        pairs = (group[near], block[near])
    assert pairs is not None
    who, block = pairs
    apart = _box_distances(blocks, block, q[who])
    # for each query the nearest box of each patch, every one of them where several are
    # as near (a query inside several boxes of a patch: which one's middle leads Newton's
    # method to the patch's nearest point is not known)
    order = np.lexsort((apart, blocks.patch[block], who))
    key = who[order] * (blocks.patch.max(initial=0) + 1) + blocks.patch[block[order]]
    lead = np.r_[True, key[1:] != key[:-1]]
    nearest = np.maximum.accumulate(np.where(lead, np.arange(order.size), 0))
    chosen = order[apart[order] <= apart[order[nearest]]]
    return who[chosen], block[chosen]


def _box_distances(blocks: Blocks, block: NDArray, points: NDArray) -> NDArray[np.float64]:
    """The distances (n,) of points (n, 3) to the boxes ``block`` (n,)."""
    gap = np.maximum(np.maximum(blocks.lo[block] - points, points - blocks.hi[block]), 0.0)
    return np.linalg.norm(gap, axis=-1)


def _merge(best: ClosestPoints, ask: NDArray, found: ClosestPoints) -> None:
    """``found`` for queries ``ask`` kept in ``best`` where nearer."""
    nearer = found.distance < best.distance[ask]
    take = ask[nearer]
    best.point[take], best.patch[take] = found.point[nearer], found.patch[nearer]
    best.uv[take], best.distance[take] = found.uv[nearer], found.distance[nearer]


def _first_round(
    surfaces: SurfacePatches,
    q: NDArray,
    samples: Samples,
    best: ClosestPoints,
    nearest: NDArray,
    inside: Callable[[NDArray[np.int64], NDArray[np.float64]], NDArray[np.bool_]] | None,
) -> NDArray[np.bool_]:
    """Newton's method from each query's ``nearest`` samples but those within a cell of a
    nearer one on its patch (one start per sheet: a patch folding back, a tube, has its
    nearest samples on several), all patches at once; the nearer foot points inside the
    trims (``inside``) kept in ``best``.  Whether each query found one outside them
    (:func:`_tried`)."""
    owner, uv = samples.patch, samples.uv
    patch = owner[nearest]
    first = np.ones(patch.shape, dtype=bool)
    cell = samples.cell[patch]
    for j in range(1, patch.shape[1]):
        for i in range(j):
            near = np.all(np.abs(uv[nearest[:, i]] - uv[nearest[:, j]]) <= cell[:, j], -1)
            first[:, j] &= ~(first[:, i] & (patch[:, i] == patch[:, j]) & near)
    rows, js = np.nonzero(first)
    who, sample = rows, nearest[rows, js]
    out = _tried(surfaces, q, who, owner[sample], uv[sample], best, inside)
    outside = np.zeros(len(q), dtype=bool)
    outside[who[out]] = True
    return outside
