"""Catmull–Clark refinement of a quad mesh, and its regular faces as bicubic B-splines.

One refinement step (:func:`catmull_clark`) of a quad mesh with vertices v:

- face point   f = the centroid of the face's 4 vertices;
- edge point   e = (a + b + f_1 + f_2) / 4 for an interior edge ab between faces 1, 2,
  and (a + b) / 2 for a boundary edge;
- vertex point v' = (Q + 2 R + (n - 3) v) / n for an interior vertex of valence n, with Q
  the mean of the n adjacent face points and R the mean of the n incident edge midpoints;
  (b_1 + 6 v + b_2) / 8 for a boundary vertex with boundary neighbours b_1, b_2 (the
  boundary curve is the cubic B-spline of the boundary polygon); and v itself for a
  corner, a boundary vertex in a single face ("edge and corner" boundary interpolation).

On a face whose 4 vertices are regular the limit surface is the uniform bicubic B-spline
patch over the face's 4 x 4 control net (:func:`net_index`); across a boundary the net is
extended by the phantom points 2 b - p, which reproduce the boundary rules exactly
(:func:`net_points`).

References
----------
E. Catmull, J. Clark, "Recursively generated B-spline surfaces on arbitrary topological
meshes", *Computer-Aided Design* 10 (1978), 350–355.  Kiciak, appendix A.6.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..patches.bezier import BezierPatch
from .quad_mesh import MeshTopology, validate_mesh

__all__ = ["catmull_clark"]

#: Uniform cubic B-spline -> Bézier control points (one direction): Bez = M @ B.
BSPLINE_TO_BEZIER = (
    np.array(
        [
            [1.0, 4.0, 1.0, 0.0],
            [0.0, 4.0, 2.0, 0.0],
            [0.0, 2.0, 4.0, 0.0],
            [0.0, 1.0, 4.0, 1.0],
        ]
    )
    / 6.0
)


# --------------------------------------------------------------------------- refinement


def _scatter(index: NDArray, values: NDArray, n: int) -> NDArray:
    """Sums of the rows of ``values`` by ``index``: shape (n, values.shape[1])."""
    out = np.empty((n, values.shape[1]))
    for c in range(values.shape[1]):
        out[:, c] = np.bincount(index, weights=values[:, c], minlength=n)
    return out


def refine(P: NDArray, topo: MeshTopology) -> tuple[NDArray, NDArray]:
    """One Catmull–Clark step of points P (n, d) over ``topo``: (new points, new faces).

    New points: the n vertex points, then the E edge points (edges in the order of
    ``np.unique`` of their keys), then the F face points.  Child face 4 f + k is
    (vertex point of corner k, edge point of edge k, face point of f, edge point of edge
    k - 1): it keeps the parent's orientation, and its corner 0 is the parent's corner k.
    """
    F = topo.faces
    nF, n = len(F), topo.n_vertices
    org, dst, twin = topo.origin, topo.dest, topo.twin
    face_of = np.arange(4 * nF) // 4
    fp = P[F].mean(axis=1)  # (F, d)
    lo, hi = np.minimum(org, dst), np.maximum(org, dst)
    edge_keys, edge_of = np.unique(lo * max(n, 1) + hi, return_inverse=True)
    edge_of = edge_of.ravel()
    E = len(edge_keys)
    ea, eb = edge_keys // max(n, 1), edge_keys % max(n, 1)
    interior = np.bincount(edge_of, minlength=E) == 2
    ep = 0.5 * (P[ea] + P[eb])
    fsum = _scatter(edge_of, fp[face_of], E)
    ep[interior] = 0.5 * ep[interior] + 0.25 * fsum[interior]
    # vertex points
    valence = topo.face_count.astype(np.float64)
    safe = np.maximum(valence, 1.0)[:, None]
    Q = _scatter(org, fp[face_of], n) / safe
    nb = _scatter(org, P[dst], n)  # interior: sum of the n edge neighbours
    R = 0.5 * (P + nb / safe)
    vp = (Q + 2.0 * R + (valence[:, None] - 3.0) * P) / safe
    bnd = twin < 0
    bsum = _scatter(org[bnd], P[dst[bnd]], n) + _scatter(dst[bnd], P[org[bnd]], n)
    bcount = np.bincount(org[bnd], minlength=n) + np.bincount(dst[bnd], minlength=n)
    smooth = topo.boundary_vertex & (bcount == 2) & (topo.face_count >= 2)
    vp[smooth] = (bsum[smooth] + 6.0 * P[smooth]) / 8.0
    keep = (topo.boundary_vertex & ~smooth) | (topo.face_count == 0)  # corners, unused
    vp[keep] = P[keep]
    points = np.concatenate([vp, ep, fp])
    k = np.arange(4)
    hk = 4 * np.arange(nF)[:, None] + k  # (F, 4) half-edge of corner k
    hprev = 4 * np.arange(nF)[:, None] + (k + 3) % 4
    faces = np.stack(
        [
            F,
            n + edge_of[hk],
            np.broadcast_to(n + E + np.arange(nF)[:, None], F.shape),
            n + edge_of[hprev],
        ],
        axis=-1,
    ).reshape(-1, 4)
    return points, faces


def catmull_clark(
    vertices: ArrayLike, faces: Iterable[Sequence[int] | NDArray[np.integer]]
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """One Catmull–Clark refinement step of a quad mesh (Catmull & Clark 1978).

    New face, edge and vertex points by the rules in the module docstring.

    Parameters
    ----------
    vertices : array_like, shape (n, 3)
    faces : sequence of 4 vertex indices each (0-based), counter-clockwise

    Returns
    -------
    vertices : ndarray, shape (n + E + F, 3)
        The n vertex points (same order as the input vertices), the E edge points, the F
        face points.
    faces : ndarray of int, shape (4 F, 4)
        Child ``4 f + k`` of face f touches its corner k: (vertex point of corner k, edge
        point of edge k -> k + 1, face point, edge point of edge k - 1 -> k).

    Raises
    ------
    SurfaceDataError
        For meshes that are not manifold, consistently oriented quad meshes
        (:func:`validate_mesh`).
    """
    V, F = validate_mesh(vertices, faces)
    return refine(V, MeshTopology(F, len(V)))


# --------------------------------------------------------------------------- regular faces

#: corner j of a face: its cell in the 4 x 4 net and its edge directions e1 (along the
#: corner's outgoing half-edge) and e2 (toward the previous corner)
_CORNER_FRAMES = (
    ((1, 1), (1, 0), (0, 1)),
    ((2, 1), (0, 1), (-1, 0)),
    ((2, 2), (-1, 0), (0, -1)),
    ((1, 2), (0, -1), (1, 0)),
)
_DIRECTIONS = ((1, 0), (0, 1), (-1, 0), (0, -1))  # counter-clockwise, in a corner's frame


class NotRegular(Exception):
    """A face's 4 x 4 net cannot be formed (an extraordinary corner, a broken grid)."""


def net_index(topo: MeshTopology, h: int) -> NDArray:
    """Vertex indices of the 4 x 4 B-spline net of face h // 4 (cells [1:3, 1:3] are the
    face, corner origin(h) at [1, 1], u along h), -1 where the net lies beyond the boundary.
    """
    idx = np.full((4, 4), -1, dtype=np.int64)

    def put(cell: tuple[int, int], vertex: int) -> None:
        i, j = cell
        if not (0 <= i < 4 and 0 <= j < 4):
            raise NotRegular
        if idx[i, j] >= 0 and idx[i, j] != vertex:
            raise NotRegular
        idx[i, j] = vertex

    g0 = h
    for (oi, oj), (ai, aj), (bi, bj) in _CORNER_FRAMES:
        c = int(topo.origin[g0])
        if not topo.regular[c]:
            raise NotRegular

        def cell(
            a: int,
            b: int,
            oi: int = oi,
            oj: int = oj,
            ai: int = ai,
            aj: int = aj,
            bi: int = bi,
            bj: int = bj,
        ) -> tuple[int, int]:
            return (oi + a * ai + b * bi, oj + a * aj + b * bj)

        put(cell(0, 0), c)
        walk = [(g0, k) for k in range(1)]
        g, k = topo.ccw(g0), 1
        while g >= 0 and g != g0:
            walk.append((g, k))
            g, k = topo.ccw(g), k + 1
        if g < 0:
            g, k = topo.cw(g0), -1
            while g >= 0:
                walk.append((g, k))
                g, k = topo.cw(g), k - 1
        if len(walk) > 4:
            raise NotRegular
        for g, k in walk:
            d, d1 = _DIRECTIONS[k % 4], _DIRECTIONS[(k + 1) % 4]
            put(cell(*d), int(topo.dest[g]))
            put(cell(d[0] + d1[0], d[1] + d1[1]), int(topo.dest[topo.next(g)]))
            put(cell(*d1), int(topo.origin[topo.prev(g)]))
        g0 = topo.next(g0)
    return idx


def net_points(P: NDArray, idx: NDArray) -> NDArray:
    """The 4 x 4 net (4, 4, d) of points P (n, d), phantom points 2 b - p beyond the boundary.

    Extrapolating linearly across a boundary edge reproduces Catmull–Clark's boundary rules
    (the boundary curve is the cubic B-spline of the boundary polygon, corners stay fixed)
    in the tensor-product rules, so the B-spline patch over the extended net is the exact
    limit surface.
    """
    net = np.zeros((4, 4, P.shape[1]))
    have = idx >= 0
    net[have] = P[idx[have]]
    inner = {0: (1, 2), 3: (2, 1)}
    for i in (0, 3):  # beyond the sides u = 0, u = 1
        for j in (1, 2):
            if not have[i, j]:
                a, b = inner[i]
                net[i, j] = 2 * net[a, j] - net[b, j]
    for j in (0, 3):  # beyond the sides v = 0, v = 1
        for i in (1, 2):
            if not have[i, j]:
                a, b = inner[j]
                net[i, j] = 2 * net[i, a] - net[i, b]
    for i in (0, 3):
        for j in (0, 3):
            if have[i, j]:
                continue
            ai, bi = inner[i]
            aj, bj = inner[j]
            if have[i, aj] and have[i, bj]:  # the v-neighbours are real: extrapolate in v
                net[i, j] = 2 * net[i, aj] - net[i, bj]
            else:
                net[i, j] = 2 * net[ai, j] - net[bi, j]
    return net


def regular_patch(P: NDArray, topo: MeshTopology, h: int) -> BezierPatch:
    """The limit surface over regular face h // 4 (corner origin(h) at (0, 0), u along h):
    the bicubic Bézier patch M N M^T of its B-spline net N, M = ``BSPLINE_TO_BEZIER``.

    Raises :class:`NotRegular` if the face has no 4 x 4 net.
    """
    net = net_points(P, net_index(topo, h))
    M = BSPLINE_TO_BEZIER
    return BezierPatch(np.einsum("ia,abc,jb->ijc", M, net, M))
