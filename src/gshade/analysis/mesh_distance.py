"""Closest points on a triangle mesh or in a point cloud: the reference B of a geometric
deviation may be a scan or an STL export instead of exact surfaces (issue 30).

A point cloud: the nearest point, by a k-d tree (:class:`scipy.spatial.cKDTree`).

A triangle mesh: every triangle is covered by samples (:func:`triangle_samples`), each
with a ``reach`` such that every point of the triangle lies within the reach of one of
its samples: the centroid for a triangle no larger than the chosen reach, else the
centres of a grid of cells along two of its sides (a sliver gets a row of samples along
its length).  The samples go into a k-d tree.  For a query q, the triangles of its K
nearest samples are candidates; one is measured exactly (:func:`nearest_on_triangles`)
only if its sample's distance less its reach is below the best distance so far.  A
triangle none of whose samples is among the K lies at least ``d_K - reach_max`` from q
(``d_K`` the K-th sample's distance): where the best distance found is at most that, the
answer is proven; elsewhere K doubles for the queries not proven, until each is (at
worst when K reaches the number of samples: the whole mesh).  The answer is exact to
rounding whatever the mesh; a query near the surface costs a few candidates, one d times
the triangles' size away costs about d times more.  The queries are searched in Morton
order (:func:`morton_order`), neighbours after each other, which halves the k-d tree's time.

The reach is the smallest at least the :data:`REACH_QUANTILE` of the triangles' sizes
for which the samples stay within :data:`SAMPLE_BUDGET` per triangle: an even mesh gets
one sample a triangle, a CAD export's long slivers beside fine triangles get rows.

trimesh's ``triangles.closest_point`` is not used for the pairs: it compares with an
absolute 1e-13 and misplaces the nearest point of triangles smaller than about 1e-4
(measured: a third of 200,000 random pairs at that scale), and it gives no (s, t).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import GshadeError
from ..limits import MAX_MAGNITUDE
from .closest_points import ClosestPoints

__all__ = [
    "FIRST_CANDIDATES",
    "SAMPLE_BUDGET",
    "TriangleSamples",
    "cloud_closest_points",
    "mesh_closest_points",
    "morton_order",
    "nearest_on_triangles",
    "triangle_samples",
]

#: Samples per triangle on average at most (the covering of :func:`triangle_samples`),
#: and more samples than triangles at most (memory: 40 bytes a sample, and the tree's).
SAMPLE_BUDGET = 8
MORE_SAMPLES = 2**22
#: Nearest samples first asked for each query (doubled for the queries not yet proven).
FIRST_CANDIDATES = 8
#: The quantile of the triangles' sizes below which no reach is taken (the covering then
#: cuts only the larger triangles, a tenth of an even mesh).
REACH_QUANTILE = 0.9
#: sqrt(area) times this is an equilateral triangle's centroid-to-corner distance.
FAT = float(np.sqrt(4.0 / (3.0 * np.sqrt(3.0))))
#: Queries searched at once, and query-triangle pairs measured at once (memory: about
#: 200 bytes each).
QUERIES_AT_ONCE = 2**17
PAIRS_AT_ONCE = 2**17


def nearest_on_triangles(
    triangles: ArrayLike, points: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The point of each triangle nearest to its point, pair by pair.

    The plane's foot point where it lies inside the triangle, else the nearest of the
    three sides' (each clamped to its segment): every candidate is a point of the
    triangle, so a degenerate triangle (a segment, a point) is measured as what it is.

    Parameters
    ----------
    triangles : array_like, shape (n, 3, 3)
        The corners A, B, C of each triangle.
    points : array_like, shape (n, 3)

    Returns
    -------
    st : ndarray, shape (n, 2)
        The barycentric (s, t) of each nearest point: A + s (B - A) + t (C - A).
    distance : ndarray, shape (n,)

    Examples
    --------
    >>> tri = [[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]] * 3
    >>> st, d = nearest_on_triangles(tri, [[0.25, 0.25, 2.0], [2.0, -1.0, 0.0], [1.0, 1.0, 0.0]])
    >>> st.tolist(), d.tolist()
    ([[0.25, 0.25], [1.0, 0.0], [0.5, 0.5]], [2.0, 1.4142135623730951, 0.7071067811865476])
    """
    tri = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    st, gap2 = _Triangles(tri).nearest(np.arange(len(tri)), p)
    return st, np.sqrt(gap2)


class _Triangles:
    """Triangles' corner A, sides AB, AC, their plane's unit normal, the vectors whose dot
    products with P - A give the plane's foot point's (s, t), and the sides' inverse
    squared lengths, as rows (21, m) of one array: a batch of pairs gathers them at once
    and computes on contiguous rows."""

    def __init__(self, tri: NDArray[np.float64]) -> None:
        a = tri[:, 0]
        ab, ac = tri[:, 1] - a, tri[:, 2] - a
        n = np.cross(ab, ac)
        nn = np.einsum("ij,ij->i", n, n)
        # s = <(P - A) x AC, n> / |n|^2 = <P - A, AC x n> / |n|^2 (Lagrange's identity: no
        # cancellation on slivers); NaN for a degenerate triangle, which is never inside
        flat = ~(nn > np.finfo(np.float64).tiny)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            u = np.cross(ac, n) / nn[:, None]
            v = np.cross(n, ab) / nn[:, None]
            unit = n / np.sqrt(nn)[:, None]
        u[flat] = v[flat] = unit[flat] = np.nan
        inverse = np.stack([_inverse(ab), _inverse(ac), _inverse(ac - ab)])
        self.rows = np.ascontiguousarray(
            np.concatenate([a.T, ab.T, ac.T, unit.T, u.T, v.T, inverse])
        )

    def nearest(
        self, index: NDArray[np.intp], p: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(s, t) (n, 2) of the point of triangle ``index[i]`` nearest to ``p[i]``, and
        the squared distance (n,)."""
        g = np.take(self.rows, index, axis=1)
        ab, ac, unit, u, v = g[3:6], g[6:9], g[9:12], g[12:15], g[15:18]
        ap = np.ascontiguousarray(p.T) - g[0:3]
        # the plane's foot point, where it is inside
        s_in, t_in = _dots(ap, u), _dots(ap, v)
        with np.errstate(invalid="ignore"):
            inside = (s_in >= 0) & (t_in >= 0) & (s_in + t_in <= 1)
        # the sides' nearest points, each clamped to its segment: A + s AB, A + t AC, B + w BC
        s_ab = np.clip(_dots(ap, ab) * g[18], 0.0, 1.0)
        t_ac = np.clip(_dots(ap, ac) * g[19], 0.0, 1.0)
        bp, bc = ap - ab, ac - ab
        w_bc = np.clip(_dots(bp, bc) * g[20], 0.0, 1.0)
        gap_ab, gap_ac, gap_bc = _gap2(ap, s_ab, ab), _gap2(ap, t_ac, ac), _gap2(bp, w_bc, bc)
        on_ab = (gap_ab <= gap_ac) & (gap_ab <= gap_bc)
        on_ac = ~on_ab & (gap_ac <= gap_bc)
        s = np.where(on_ab, s_ab, np.where(on_ac, 0.0, 1.0 - w_bc))
        t = np.where(on_ab, 0.0, np.where(on_ac, t_ac, w_bc))
        gap = np.minimum(np.minimum(gap_ab, gap_ac), gap_bc)
        # inside: the foot point is the nearest point (the sides' were measured for the
        # degenerate triangles and the rounding at the sides)
        height = _dots(ap, unit)
        with np.errstate(invalid="ignore"):
            inside &= height * height <= gap
        s, t = np.where(inside, s_in, s), np.where(inside, t_in, t)
        gap = np.where(inside, height * height, gap)
        return np.stack([s, t], axis=-1), gap


def _inverse(side: NDArray[np.float64]) -> NDArray[np.float64]:
    """1 / |side|^2 (m,); 0 for a side of length 0 (its start is its nearest point)."""
    length2 = np.einsum("ij,ij->i", side, side)
    out = np.zeros_like(length2)
    np.divide(1.0, length2, out=out, where=length2 > np.finfo(np.float64).tiny)
    return out


def _dots(x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    """Dot products of the columns of (3, n) arrays."""
    out = x[0] * y[0]
    out += x[1] * y[1]
    out += x[2] * y[2]
    return out


def _gap2(
    start: NDArray[np.float64], w: NDArray[np.float64], side: NDArray[np.float64]
) -> NDArray[np.float64]:
    """|start - w side|^2 (3, n), from the residual (no cancellation near the surface)."""
    r = start - w * side
    return _dots(r, r)


@dataclass(frozen=True)
class TriangleSamples:
    """Points covering a mesh's triangles: ``points`` (k, 3), the triangle ``owner`` (k,)
    of each and its ``reach`` (k,): every point of a triangle lies within its samples'
    reach of one of them; ``reach_max``: the largest."""

    points: NDArray[np.float64]
    owner: NDArray[np.int64]
    reach: NDArray[np.float64]
    reach_max: float


def triangle_samples(triangles: ArrayLike, budget: int = SAMPLE_BUDGET) -> TriangleSamples:
    """Samples covering ``triangles`` (m, 3, 3) (see the module): about ``budget`` x m of
    them at most (m + :data:`MORE_SAMPLES` at most), at least one per triangle.

    A triangle within the chosen reach of its centroid is sampled there.  A larger one
    is cut into a grid of parallelograms along the two sides of its corner whose sides'
    product is least, |AB| / n1 by |AC| / n2 with n1, n2 the sides' lengths over the
    reach rounded up; each cell that meets the triangle is sampled at its centre, within
    half its longer diagonal of each of its points.  A sliver gets a row of samples along
    its length, not a square of them.

    Examples
    --------
    One triangle: its centroid.  Beside small triangles: a grid of 3 cells along the
    right angle's sides (the fourth lies beyond its hypotenuse).

    >>> big = [[0.0, 0.0, 0.0], [6.0, 0.0, 0.0], [0.0, 6.0, 0.0]]
    >>> triangle_samples([big]).points.tolist()
    [[2.0, 2.0, 0.0]]
    >>> small = [[0.0, 0.0, 1.0], [3.0, 0.0, 1.0], [0.0, 3.0, 1.0]]
    >>> found = triangle_samples([big, small, small, small])
    >>> found.owner.tolist(), found.points[found.owner == 0].tolist()
    ([0, 0, 0, 1, 2, 3], [[1.5, 1.5, 0.0], [1.5, 4.5, 0.0], [4.5, 1.5, 0.0]])
    >>> round(found.reach_max, 6)
    2.236068
    """
    tri = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
    m = len(tri)
    centroid = tri.mean(axis=1)
    radius = np.linalg.norm(tri - centroid[:, None], axis=-1).max(axis=1)
    # each triangle's grid corner: the one whose two sides' lengths have the least product
    corner_sides = [
        (tri[:, (k + 1) % 3] - tri[:, k], tri[:, (k + 2) % 3] - tri[:, k]) for k in range(3)
    ]
    lengths = np.array(
        [[np.linalg.norm(u, axis=1), np.linalg.norm(v, axis=1)] for u, v in corner_sides]
    )
    corner = np.argmin(lengths[:, 0] * lengths[:, 1], axis=0)  # (m,)
    rows = np.arange(m)
    a = tri[rows, corner]
    ab = np.stack([u for u, _ in corner_sides])[corner, rows]
    ac = np.stack([v for _, v in corner_sides])[corner, rows]
    la, lb = lengths[corner, 0, rows], lengths[corner, 1, rows]
    area = 0.5 * np.linalg.norm(np.cross(ab, ac), axis=1)
    # a triangle's own size: its centroid's reach, or for a sliver (whose reach is half its
    # length) twice an equilateral triangle's of its area
    size = np.minimum(radius, 2 * FAT * np.sqrt(area))
    reach = _reach(radius, la, lb, size, m + min((max(1, budget) - 1) * m, MORE_SAMPLES))
    gridded = np.flatnonzero(radius > reach) if reach > 0 else np.zeros(0, np.intp)
    single = np.setdiff1d(rows, gridded)
    points, owners, reaches = [centroid[single]], [single], [radius[single]]
    if gridded.size:
        # a side of length 0 (a segment's) still has one cell across
        n1 = np.maximum(1, np.ceil(la[gridded] / reach)).astype(np.int64)
        n2 = np.maximum(1, np.ceil(lb[gridded] / reach)).astype(np.int64)
        which = np.repeat(np.arange(gridded.size), n1 * n2)
        cell = np.arange(which.size) - np.repeat(np.cumsum(n1 * n2) - n1 * n2, n1 * n2)
        i, j = cell // n2[which], cell % n2[which]
        meets = i * n2[which] + j * n1[which] < n1[which] * n2[which]
        which, i, j = which[meets], i[meets], j[meets]
        g = gridded[which]
        s, t = (i + 0.5) / n1[which], (j + 0.5) / n2[which]
        points.append(a[g] + s[:, None] * ab[g] + t[:, None] * ac[g])
        owners.append(g)
        du, dv = ab[gridded] / n1[:, None], ac[gridded] / n2[:, None]
        half = 0.5 * np.maximum(np.linalg.norm(du + dv, axis=1), np.linalg.norm(du - dv, axis=1))
        reaches.append(half[which])
    owner = np.concatenate(owners).astype(np.int64)
    each = np.concatenate(reaches)
    order = np.argsort(owner, kind="stable")
    return TriangleSamples(
        np.concatenate(points)[order], owner[order], each[order], float(each.max()) if m else 0.0
    )


def _reach(
    radius: NDArray[np.float64],
    la: NDArray[np.float64],
    lb: NDArray[np.float64],
    size: NDArray[np.float64],
    budget: int,
) -> float:
    """The smallest reach, at least the :data:`REACH_QUANTILE` of the triangles' sizes,
    for which their samples (one each within it, else a grid's cells) number about
    ``budget`` at most."""
    if radius.size == 0 or not np.any(radius > 0):
        return 0.0
    lo, hi = float(np.quantile(size, REACH_QUANTILE)), float(radius.max())
    if not lo > 0:
        lo = float(radius[radius > 0].min())

    def count(h: float) -> float:
        big = radius > h
        n1, n2 = np.maximum(1, np.ceil(la[big] / h)), np.maximum(1, np.ceil(lb[big] / h))
        return float(np.count_nonzero(~big) + np.sum((n1 + 1) * (n2 + 1) / 2))

    if count(lo) <= budget:
        return lo
    for _ in range(60):  # bisection in log: the count falls as h grows, count(hi) = m
        mid = float(np.sqrt(lo * hi))
        if count(mid) <= budget:
            hi = mid
        else:
            lo = mid
        if hi <= lo * 1.01:
            break
    return hi


def mesh_closest_points(
    vertices: ArrayLike,
    faces: ArrayLike,
    queries: ArrayLike,
    *,
    samples: TriangleSamples | None = None,
    workers: int = 1,
) -> ClosestPoints:
    """The points of a triangle mesh nearest to each of ``queries`` (see the module).

    Parameters
    ----------
    vertices : array_like, shape (n, 3)
    faces : array_like of int, shape (m, 3)
        0-based vertex indices of each triangle; m >= 1.
    queries : array_like, shape (q, 3)
    samples : TriangleSamples, optional
        :func:`triangle_samples` of the mesh's triangles, made once for several calls.
    workers : int
        Threads of the k-d tree's searches (-1: all cores).

    Returns
    -------
    ClosestPoints
        ``point`` (q, 3) on the mesh, ``patch``: the triangle's index, ``uv``: the
        barycentric (s, t) of the point in it (A + s (B - A) + t (C - A)), ``distance``.

    Raises
    ------
    GshadeError
        Arrays of the wrong shape, coordinates that are not finite numbers within
        ±MAX_MAGNITUDE, or face indices outside the vertices (checked before any of
        them reaches compiled code).

    Examples
    --------
    A unit square of two triangles; a point above it and one beside it:

    >>> V = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]
    >>> F = [[0, 1, 2], [0, 2, 3]]
    >>> found = mesh_closest_points(V, F, [[0.2, 0.7, 0.5], [3.0, 0.5, 0.0]])
    >>> found.patch.tolist(), found.distance.tolist()
    ([1, 0], [0.5, 2.0])
    >>> found.point.tolist(), np.round(found.uv, 12).tolist()
    ([[0.2, 0.7, 0.0], [1.0, 0.5, 0.0]], [[0.2, 0.5], [0.5, 0.5]])
    """
    from scipy.spatial import cKDTree

    V = _points(vertices, "vertices", least=1)
    F = _faces(faces, len(V))
    q = _points(queries, "queries", least=0)
    tri = V[F]
    found = samples if samples is not None else triangle_samples(tri)
    if len(found.owner) == 0 or int(found.owner.max()) >= len(F) or found.owner.min() < 0:
        raise GshadeError("samples: expected the triangle_samples of these faces")
    tree = cKDTree(found.points, balanced_tree=False)
    search = _Search(tree, found, _Triangles(tri), workers)
    gap2, face, st = np.full(len(q), np.inf), np.zeros(len(q), np.int64), np.zeros((len(q), 2))
    order = morton_order(q)  # neighbours searched one after another: the tree's cache kept
    for start in range(0, len(q), QUERIES_AT_ONCE):
        part = order[start : start + QUERIES_AT_ONCE]
        gap2[part], face[part], st[part] = search.nearest(q[part])
    point = tri[face, 0] + st[:, :1] * (tri[face, 1] - tri[face, 0])
    point += st[:, 1:] * (tri[face, 2] - tri[face, 0])
    return ClosestPoints(point, face, st, np.sqrt(gap2))


class _Search:
    """The proven nearest triangles of a batch of queries (see the module)."""

    def __init__(
        self, tree: Any, samples: TriangleSamples, triangles: _Triangles, workers: int
    ) -> None:
        self.tree, self.samples, self.triangles, self.workers = tree, samples, triangles, workers
        self.total = len(samples.points)

    def nearest(
        self, q: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
        """Squared distance (n,), triangle (n,) and (s, t) (n, 2) of each query's nearest
        point."""
        n = len(q)
        gap2, face, st = np.full(n, np.inf), np.zeros(n, np.int64), np.zeros((n, 2))
        asked = np.arange(n)
        k, done = min(FIRST_CANDIDATES, self.total), 0
        while asked.size:
            dist, index = self.tree.query(q[asked], k=k, workers=self.workers)
            dist = np.asarray(dist).reshape(len(asked), k)
            index = np.asarray(index).reshape(len(asked), k)
            if done == 0:  # each query's nearest sample's triangle: a first bound
                self._measure(q, asked, index[:, 0], gap2, face, st)
                done = 1
            # a new candidate is measured only where its triangle may be nearer than the
            # best so far: a triangle lies at least a sample's distance - its reach away
            new, reach = index[:, done:], self.samples.reach[index[:, done:]]
            rows, cols = np.nonzero(dist[:, done:] - reach < np.sqrt(gap2[asked])[:, None])
            self._measure(q, asked[rows], new[rows, cols], gap2, face, st)
            if k >= self.total:
                break
            # a triangle none of whose samples is among the k nearest lies at least the
            # k-th's distance - the largest reach away: the queries it does not prove
            asked = asked[np.sqrt(gap2[asked]) > dist[:, -1] - self.samples.reach_max]
            k, done = min(2 * k, self.total), k
        return gap2, face, st

    def _measure(
        self,
        q: NDArray[np.float64],
        which: NDArray[np.intp],
        sample: NDArray[np.intp],
        gap2: NDArray[np.float64],
        face: NDArray[np.int64],
        st: NDArray[np.float64],
    ) -> None:
        """Measure query ``which[i]`` against the triangle of ``sample[i]`` (a query may
        come several times), keeping each query's nearest."""
        for start in range(0, len(which), PAIRS_AT_ONCE):
            w = which[start : start + PAIRS_AT_ONCE]
            f = self.samples.owner[sample[start : start + PAIRS_AT_ONCE]]
            found_st, found = self.triangles.nearest(f, q[w])
            least = np.full(len(gap2), np.inf)
            np.minimum.at(least, w, found)
            win = found < gap2[w]
            win &= found == least[w]
            gap2[w[win]], face[w[win]], st[w[win]] = found[win], f[win], found_st[win]


def cloud_closest_points(
    points: ArrayLike, queries: ArrayLike, *, workers: int = 1
) -> ClosestPoints:
    """The points of a point cloud nearest to each of ``queries`` (a k-d tree search).

    Parameters
    ----------
    points : array_like, shape (n, 3)
        The cloud; n >= 1.
    queries : array_like, shape (q, 3)
    workers : int
        Threads of the k-d tree's search (-1: all cores).

    Returns
    -------
    ClosestPoints
        ``point`` (q, 3): the nearest point of the cloud, ``patch``: its index,
        ``uv``: zeros (q, 2), ``distance``.

    Raises
    ------
    GshadeError
        Arrays of the wrong shape or coordinates that are not finite numbers within
        ±MAX_MAGNITUDE.

    Examples
    --------
    >>> found = cloud_closest_points([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], [[0.9, 0.0, 0.3]])
    >>> found.patch.tolist(), found.point.tolist(), round(float(found.distance[0]), 12)
    ([1], [[1.0, 0.0, 0.0]], 0.316227766017)
    """
    from scipy.spatial import cKDTree

    P = _points(points, "points", least=1)
    q = _points(queries, "queries", least=0)
    if len(q) == 0:
        return ClosestPoints(np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros(0))
    order = morton_order(q)
    found_distance, found_index = cKDTree(P, balanced_tree=False).query(
        q[order], k=1, workers=workers
    )
    index, distance = np.empty(len(q), np.int64), np.empty(len(q))
    index[order] = np.asarray(found_index, dtype=np.int64).reshape(-1)
    distance[order] = np.asarray(found_distance, dtype=np.float64).reshape(-1)
    return ClosestPoints(P[index], index, np.zeros((len(q), 2)), distance)


def morton_order(points: NDArray[np.float64]) -> NDArray[np.intp]:
    """The order of ``points`` (n, 3) along a Z-order (Morton) curve through their bounding
    box, at 2^21 steps a side: points near each other come near each other.

    Examples
    --------
    >>> morton_order(np.array([[1.0, 1.0, 1.0], [0.0, 0.0, 0.0], [0.9, 1.0, 1.0]])).tolist()
    [1, 2, 0]
    """
    if len(points) == 0:
        return np.zeros(0, dtype=np.intp)
    low = points.min(axis=0)
    span = float(np.max(points.max(axis=0) - low))
    unit = (points - low) / span if span > 0 else np.zeros_like(points)  # in [0, 1]
    cells = np.clip(unit * (2**21 - 1), 0, 2**21 - 1).astype(np.uint64)
    code = np.zeros(len(points), dtype=np.uint64)
    for axis in range(3):
        code |= _spread(cells[:, axis]) << np.uint64(axis)
    return np.argsort(code, kind="stable")


def _spread(x: NDArray[np.uint64]) -> NDArray[np.uint64]:
    """The 21 low bits of ``x`` moved to every third bit."""
    for shift, mask in (
        (32, 0x1F00000000FFFF),
        (16, 0x1F0000FF0000FF),
        (8, 0x100F00F00F00F00F),
        (4, 0x10C30C30C30C30C3),
        (2, 0x1249249249249249),
    ):
        x = (x | (x << np.uint64(shift))) & np.uint64(mask)
    return x


def _points(value: ArrayLike, name: str, least: int) -> NDArray[np.float64]:
    """``value`` as an (n, 3) float array of n >= ``least`` finite coordinates within
    ±MAX_MAGNITUDE; GshadeError naming ``name`` otherwise."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise GshadeError(f"{name}: expected an array of numbers of shape (n, 3)") from None
    if array.ndim != 2 or array.shape[1] != 3 or len(array) < least:
        raise GshadeError(
            f"{name}: expected an array of shape (n, 3) with n >= {least}, got shape {array.shape}"
        )
    if not np.all(np.abs(array) <= MAX_MAGNITUDE):  # NaN fails too
        bad = int(np.count_nonzero(~(np.abs(array) <= MAX_MAGNITUDE)))
        raise GshadeError(
            f"{name}: expected finite coordinates within ±{MAX_MAGNITUDE:g}, found {bad} "
            "that are not"
        )
    return np.ascontiguousarray(array)


def _faces(value: ArrayLike, count: int) -> NDArray[np.int64]:
    """``value`` as an (m, 3) int64 array of m >= 1 indices in [0, count)."""
    array = np.asarray(value)
    if array.ndim != 2 or array.shape[1] != 3 or len(array) < 1:
        raise GshadeError(
            f"faces: expected an array of shape (m, 3) with m >= 1, got shape {array.shape}"
        )
    if array.dtype.kind not in "iu":
        raise GshadeError(f"faces: expected integer vertex indices, got {array.dtype}")
    low, high = int(array.min()), int(array.max())
    if low < 0 or high >= count:
        raise GshadeError(
            f"faces: expected vertex indices from 0 to {count - 1}, found "
            f"{low if low < 0 else high}"
        )
    return array.astype(np.int64)
