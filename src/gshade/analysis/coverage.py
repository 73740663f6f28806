"""Whether surface B covers surface A: the points of A beyond B's free boundary.

A point p of A whose closest point c on B is a foot point proper has p - c along B's normal
at c.  Where c lies on a boundary of B instead, p - c leaves B's normal; if that boundary is
a free one (an edge of an open sheet, a hole's rim: no other face of B continues there), p
lies beyond the end of B and its distance says nothing about how far B moved: A is not
covered there.  At an edge between two faces of B (a sharp edge, a fillet left out) B
continues, and the distance is a true deviation.

The free boundary is found on a triangle mesh of B (its vertices welded, an edge of one
triangle only: the kernel's watertight mesh of a CAD model, or patches' grids), and c is on
it when within ``near`` of one of its segments.  Plain functions on arrays.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["NORMAL_COSINE", "Segments", "free_edges", "segment_distances", "uncovered"]

#: |cos| of the angle between p - c and B's normal above which c is a foot point proper
#: (an angle within 1 degree).
NORMAL_COSINE = float(np.cos(np.radians(1.0)))


def free_edges(positions: ArrayLike, faces: ArrayLike, weld: float) -> NDArray[np.float64]:
    """The segments (m, 2, 3) of a triangle mesh's free boundary: its edges that belong to
    one triangle only, after welding vertices that round to the same point on a grid of
    ``weld`` (> 0) apart (meshes of faces or patches each with its own vertices).

    Examples
    --------
    Two triangles of a unit square, their vertices each their own: the 4 sides are free,
    the diagonal is not.

    >>> square = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 0, 0], [1, 1, 0], [0, 1, 0]]
    >>> free_edges(square, [[0, 1, 2], [3, 4, 5]], 1e-9).shape
    (4, 2, 3)
    """
    p = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if not len(f):
        return np.zeros((0, 2, 3))
    _, vertex = np.unique(np.round(p / weld), axis=0, return_inverse=True)
    vertex = vertex.ravel()
    corners = vertex[f]
    ends = np.concatenate([corners[:, [0, 1]], corners[:, [1, 2]], corners[:, [2, 0]]])
    first = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    ends.sort(axis=1)
    keep = ends[:, 0] != ends[:, 1]  # not collapsed by the weld
    ends, first = ends[keep], first[keep]
    _, where, count = np.unique(ends, axis=0, return_index=True, return_counts=True)
    lone = where[count == 1]
    return p[first[lone]]


class Segments:
    """Segments (m, 2, 3) with their middles in a k-d tree, for the distances of many
    points to them (:meth:`distances`, :meth:`middles_within`)."""

    def __init__(self, segments: NDArray) -> None:
        from scipy.spatial import cKDTree

        self.a, self.b = segments[:, 0], segments[:, 1]
        #: half the longest segment: a point within r of a segment is within r + half of
        #: its middle
        self.half = 0.5 * float(np.linalg.norm(self.b - self.a, axis=-1).max(initial=0.0))
        self.tree = cKDTree(0.5 * (self.a + self.b)) if len(segments) else None

    def middles_within(self, points: NDArray, reach: float) -> NDArray[np.float64]:
        """Each point's distance (n,) to the nearest middle if within ``reach``, else inf."""
        if self.tree is None:
            return np.full(len(points), np.inf)
        return np.asarray(self.tree.query(points, k=1, distance_upper_bound=reach)[0])

    def distances(self, points: ArrayLike, candidates: int = 8) -> NDArray:
        """The distance (n,) of each point (n, 3) to the nearest segment, exactly; inf
        without a segment.  The ``candidates`` segments whose middles are nearest first; a
        segment farther than the k-th middle less the longest half segment cannot be
        nearer, and where that does not settle it, every segment whose middle lies within
        the distance found plus the longest half segment."""
        q = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        if self.tree is None or not len(q):
            return np.full(len(q), np.inf)
        a, b = self.a, self.b
        k = min(candidates, len(a))
        apart, near = self.tree.query(q, k=k)
        near = np.asarray(near).reshape(len(q), k)
        found = _to_segments(q[:, None], a[near], b[near]).min(axis=1)
        unsure = np.flatnonzero(found > np.asarray(apart).reshape(len(q), k)[:, -1] - self.half)
        if unsure.size and k < len(a):
            lists = self.tree.query_ball_point(q[unsure], found[unsure] + self.half)
            who = np.repeat(unsure, [len(x) for x in lists])
            which = np.concatenate([np.asarray(x, dtype=np.int64) for x in lists])
            np.minimum.at(found, who, _to_segments(q[who], a[which], b[which]))
        return found


def segment_distances(points: ArrayLike, segments: NDArray, candidates: int = 8) -> NDArray:
    """The distance (n,) of each point (n, 3) to the nearest of ``segments`` (m, 2, 3),
    exactly; inf without a segment (:meth:`Segments.distances`).

    Examples
    --------
    >>> segment_distances([[0.5, 1.0, 0.0], [2.0, 0.0, 0.0]], np.array([[[0, 0, 0], [1, 0, 0]]]))
    array([1., 1.])
    """
    return Segments(np.asarray(segments, dtype=np.float64).reshape(-1, 2, 3)).distances(
        points, candidates
    )


def _to_segments(q: NDArray, a: NDArray, b: NDArray) -> NDArray:
    """The distances of points ``q`` to the segments from ``a`` to ``b`` (broadcast)."""
    ab, ap = b - a, q - a
    length2 = np.sum(ab * ab, -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.clip(np.nan_to_num(np.sum(ap * ab, -1) / length2), 0.0, 1.0)
    return np.linalg.norm(ap - t[..., None] * ab, axis=-1)


def uncovered(
    points: ArrayLike,
    closest: ArrayLike,
    normals: ArrayLike,
    boundary_distance: ArrayLike,
    near: float,
    tolerance: float,
) -> NDArray[np.bool_]:
    """Which points (n, 3) of A lie beyond B's free boundary (see the module): farther
    than ``tolerance`` from their closest points ``closest`` (n, 3) on B, p - c not along
    B's unit normals ``normals`` (n, 3) there (:data:`NORMAL_COSINE`), and c within
    ``near`` of B's free boundary (``boundary_distance`` (n,): c's distance to it,
    :func:`segment_distances` of :func:`free_edges`).

    Examples
    --------
    The plane z = 0 ending at x = 1: (2, 0, 1) is beyond it, (0.5, 0, 1) above it.

    >>> p = [[2.0, 0.0, 1.0], [0.5, 0.0, 1.0]]
    >>> c = [[1.0, 0.0, 0.0], [0.5, 0.0, 0.0]]
    >>> uncovered(p, c, [[0, 0, 1], [0, 0, 1]], [0.0, 0.5], 0.01, 1e-6).tolist()
    [True, False]
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    c = np.asarray(closest, dtype=np.float64).reshape(-1, 3)
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    gap = c - p
    length = np.linalg.norm(gap, axis=-1)
    along = np.abs(np.sum(gap * n, -1))
    off_normal = along < NORMAL_COSINE * length
    return (length > tolerance) & off_normal & (np.asarray(boundary_distance) <= near)
