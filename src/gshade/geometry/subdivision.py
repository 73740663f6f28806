"""Catmull–Clark subdivision surfaces: exact limit patches of a quad control mesh.

Kiciak, appendix A.6 ("generalised B-spline surfaces of arbitrary topology"); E. Catmull,
J. Clark, *Recursively generated B-spline surfaces on arbitrary topological meshes*, CAD 10
(1978); J. Stam, *Exact evaluation of Catmull–Clark subdivision surfaces at arbitrary
parameter values*, SIGGRAPH 1998.

One refinement step (:func:`catmull_clark`) of a quad mesh with vertices v, faces and edges:

- face point   f = the centroid of the face's 4 vertices;
- edge point   e = (a + b + f_1 + f_2) / 4 for an interior edge ab between faces 1, 2,
  and (a + b) / 2 for a boundary edge;
- vertex point v' = (Q + 2 R + (n - 3) v) / n for an interior vertex of valence n, with Q
  the mean of the n adjacent face points and R the mean of the n incident edge midpoints;
  (b_1 + 6 v + b_2) / 8 for a boundary vertex with boundary neighbours b_1, b_2 (the
  boundary curve is the cubic B-spline of the boundary polygon); and v itself for a
  corner, a boundary vertex in a single face ("edge and corner" boundary interpolation).

The limit surface is evaluated exactly, without refining the whole mesh
(:func:`subdivision_patches`):

- a face whose 4 vertices are *regular* (interior of valence 4; on the boundary in 2
  faces; a corner) is a uniform bicubic B-spline patch over its 4 x 4 control net (across a
  boundary the net is extended by the phantom points 2 b - p, which reproduce the boundary
  rules exactly), converted to a :class:`~gshade.geometry.BezierPatch`;
- a face with exactly one *extraordinary* vertex (interior of valence != 4, or on the
  boundary in 3 or more faces) is a :class:`StamPatch`, evaluated exactly by Stam's
  method: around the extraordinary vertex the square [0, 1]^2 splits into the L-shaped
  rings 2^-n <= max(u, v) <= 2^(1-n), n = 1, 2, ...; on ring n the surface consists of 3
  regular bicubic pieces whose B-spline nets are B_q A^(n-1) C, with C the local control
  points, A the local subdivision matrix and B_q picking the pieces' nets;
- if a face has more than one extraordinary vertex the mesh is refined once first (after
  one step every face has at most one).

Meshes must be quad meshes (a general polygon mesh is not accepted: one Catmull–Clark step
of it would be a quad mesh, but that changes the surface the file describes), manifold
(every edge in at most two faces, the faces around every vertex one disk or half-disk),
consistently oriented, and closed or open: open meshes follow the boundary rules above,
boundary extraordinary vertices included.  With faces counter-clockwise seen from outside,
every patch's normal p_u x p_v points outward.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import GshadeError, SurfaceDataError
from .bezier import BezierPatch
from .patch import Patch

__all__ = [
    "MeshTopology",
    "StamPatch",
    "catmull_clark",
    "check_mesh",
    "subdivision_patches",
]

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

#: Most rings stored per Stam patch; beyond them a point is the extraordinary vertex itself.
MAX_LEVELS = 200


# --------------------------------------------------------------------------- topology


class MeshTopology:
    """Half-edge connectivity of a quad mesh (no validation: see :func:`check_mesh`).

    Half-edge ``h = 4 f + k`` runs from ``faces[f, k]`` to ``faces[f, (k + 1) % 4]`` with
    its face on the left; ``twin[h]`` is the opposite half-edge, -1 on the boundary.
    """

    def __init__(self, faces: NDArray, n_vertices: int) -> None:
        self.faces = np.ascontiguousarray(faces, dtype=np.int64).reshape(-1, 4)
        self.n_vertices = int(n_vertices)
        V = max(self.n_vertices, 1)
        self.origin = self.faces.ravel()
        self.dest = np.roll(self.faces, -1, axis=1).ravel()
        key = self.origin * V + self.dest
        order = np.argsort(key, kind="stable")
        sorted_keys = key[order]
        rkey = self.dest * V + self.origin
        pos = np.clip(np.searchsorted(sorted_keys, rkey), 0, max(len(key) - 1, 0))
        found = sorted_keys[pos] == rkey if len(key) else np.zeros(0, dtype=bool)
        self.twin = np.where(found, order[pos], -1)
        #: faces around each vertex (= outgoing half-edges)
        self.face_count = np.bincount(self.origin, minlength=self.n_vertices)
        boundary = self.twin < 0
        self.boundary_vertex = np.zeros(self.n_vertices, dtype=bool)
        self.boundary_vertex[self.origin[boundary]] = True
        self.boundary_vertex[self.dest[boundary]] = True
        n, b = self.face_count, self.boundary_vertex
        #: regular for Catmull–Clark: interior of valence 4, boundary in 2 faces, corner
        self.regular = np.where(b, (n == 1) | (n == 2), n == 4) | (n == 0)

    @staticmethod
    def next(h: int) -> int:
        return h - h % 4 + (h + 1) % 4

    @staticmethod
    def prev(h: int) -> int:
        return h - h % 4 + (h + 3) % 4

    def ccw(self, h: int) -> int:
        """The next outgoing half-edge counter-clockwise around origin(h), or -1."""
        return int(self.twin[self.prev(h)])

    def cw(self, h: int) -> int:
        """The next outgoing half-edge clockwise around origin(h), or -1."""
        t = int(self.twin[h])
        return -1 if t < 0 else self.next(t)

    def fan(self, h: int) -> list[int]:
        """Outgoing half-edges around origin(h): h, then counter-clockwise, then (at the
        boundary) clockwise from h."""
        out = [h]
        g = self.ccw(h)
        while g >= 0 and g != h and len(out) <= 64:
            out.append(g)
            g = self.ccw(g)
        if g < 0:
            g = self.cw(h)
            while g >= 0 and len(out) <= 64:
                out.append(g)
                g = self.cw(g)
        return out


class _Names:
    """How messages name faces and vertices: OBJ numbering (1-based, with lines) or 0-based."""

    def __init__(self, source: str | None, face_lines: Sequence[int] | None) -> None:
        self.prefix = f"{source}: " if source else ""
        self.lines = face_lines
        self.base = 1 if face_lines is not None else 0

    def face(self, k: int) -> str:
        if self.lines is not None:
            return f"face {k + 1} (line {self.lines[k]})"
        return f"face {k}"

    def vertex(self, i: int) -> str:
        return f"vertex {int(i) + self.base}"

    def edge(self, a: int, b: int) -> str:
        return f"edge {int(a) + self.base}-{int(b) + self.base}"

    def error(self, message: str) -> SurfaceDataError:
        return SurfaceDataError(self.prefix + message)


def check_mesh(
    vertices: ArrayLike,
    faces: Iterable[Sequence[int] | NDArray[np.integer]],
    *,
    source: str | None = None,
    face_lines: Sequence[int] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Validate a quad control mesh for Catmull–Clark subdivision.

    Parameters
    ----------
    vertices : array_like, shape (n, 3)
    faces : sequence of sequences of int
        0-based vertex indices, counter-clockwise seen from outside.
    source : str, optional
        The file the mesh came from, to begin messages with.
    face_lines : sequence of int, optional
        The file line of each face: messages then name faces and vertices as in an OBJ
        file (1-based, with the line).

    Returns
    -------
    vertices : ndarray, shape (n, 3)
    faces : ndarray of int, shape (F, 4)

    Raises
    ------
    SurfaceDataError
        Naming the face, edge or vertex that is wrong: a face that is not a quad, an index
        out of range, a repeated vertex in a face, an edge in more than two faces, an edge
        used twice in the same direction (inconsistent orientation), a vertex whose faces
        form several fans (non-manifold), an interior vertex of valence 2.
    """
    names = _Names(source, face_lines)
    try:
        V = np.asarray(vertices, dtype=np.float64)
    except (TypeError, ValueError):
        raise names.error("vertices: expected an (n, 3) array of numbers") from None
    if V.ndim != 2 or V.shape[1] != 3:
        raise names.error(f"vertices: expected shape (n, 3), got {V.shape}")
    if not np.all(np.isfinite(V)):
        raise names.error("vertices: expected finite coordinates")
    faces = list(faces)
    if not faces:
        raise names.error("expected at least one face, found none")
    for k, face in enumerate(faces):
        if len(face) != 4:
            raise names.error(
                f"{names.face(k)} has {len(face)} vertices; expected a quad mesh (4 vertices "
                "per face): Catmull–Clark patches are made from quads only"
            )
    try:
        F = np.array([[int(i) for i in face] for face in faces], dtype=np.int64)
    except (TypeError, ValueError):
        raise names.error("faces: expected integer vertex indices") from None
    n = len(V)
    bad = np.nonzero((F < 0) | (F >= n))
    if bad[0].size:
        k, j = int(bad[0][0]), int(bad[1][0])
        raise names.error(
            f"{names.face(k)}: expected vertex indices from {names.base} to "
            f"{n - 1 + names.base}, found {int(F[k, j]) + names.base}"
        )
    srt = np.sort(F, axis=1)
    rep = np.nonzero((srt[:, 1:] == srt[:, :-1]).any(axis=1))[0]
    if rep.size:
        k = int(rep[0])
        raise names.error(
            f"{names.face(k)} uses a vertex twice "
            f"({', '.join(str(int(i) + names.base) for i in F[k])}); expected 4 distinct vertices"
        )
    org = F.ravel()
    dst = np.roll(F, -1, axis=1).ravel()
    lo, hi = np.minimum(org, dst), np.maximum(org, dst)
    ukey = lo * n + hi
    uniq, inverse, counts = np.unique(ukey, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    over = np.nonzero(counts > 2)[0]
    if over.size:
        e = int(over[0])
        hs = np.nonzero(inverse == e)[0]
        a, b = divmod(int(uniq[e]), n)
        raise names.error(
            f"{names.edge(a, b)} is shared by {int(counts[e])} faces "
            f"({', '.join(names.face(int(h) // 4) for h in hs)}); expected at most 2 "
            "(a manifold mesh)"
        )
    dkey = org * n + dst
    duniq, dcounts = np.unique(dkey, return_counts=True)
    twice = np.nonzero(dcounts > 1)[0]
    if twice.size:
        key = int(duniq[twice[0]])
        hs = np.nonzero(dkey == key)[0]
        a, b = divmod(key, n)
        raise names.error(
            f"{names.edge(a, b)} runs in the same direction in {names.face(int(hs[0]) // 4)} "
            f"and {names.face(int(hs[1]) // 4)}; expected consistently oriented faces (each "
            "edge once in each direction: flip one of them)"
        )
    topo = MeshTopology(F, n)
    _check_fans(topo, names)
    interior2 = np.nonzero(~topo.boundary_vertex & (topo.face_count == 2))[0]
    if interior2.size:
        raise names.error(
            f"{names.vertex(int(interior2[0]))} is an interior vertex in only 2 faces; expected "
            "at least 3 (valence 2 has no tangent plane in the limit)"
        )
    return V, F


def _check_fans(topo: MeshTopology, names: _Names) -> None:
    """Every vertex's faces must form one fan: a disk (interior) or a half-disk."""
    used = np.nonzero(topo.face_count > 0)[0]
    n_h = len(topo.origin)
    boundary_out = np.bincount(topo.origin[topo.twin < 0], minlength=topo.n_vertices)
    two = np.nonzero(boundary_out > 1)[0]
    if two.size:
        v = int(two[0])
        raise names.error(
            f"{names.vertex(v)} joins {int(boundary_out[v])} separate fans of faces (a "
            "non-manifold vertex); expected the faces around a vertex to form one disk or "
            "half-disk"
        )
    # start: the outgoing boundary half-edge at boundary vertices, any one elsewhere
    start = np.full(topo.n_vertices, -1, dtype=np.int64)
    hs = np.arange(n_h)
    start[topo.origin[::-1]] = hs[::-1]
    b = topo.twin < 0
    start[topo.origin[b]] = hs[b]
    start = start[used]
    g = start.copy()
    steps = np.ones(len(used), dtype=np.int64)
    live = np.ones(len(used), dtype=bool)
    prev = hs - hs % 4 + (hs + 3) % 4
    for _ in range(int(topo.face_count.max(initial=0))):
        nxt = np.where(live, topo.twin[prev[np.maximum(g, 0)]], -1)
        live &= (nxt >= 0) & (nxt != start)
        steps += live
        g = np.where(live, nxt, g)
    short = np.nonzero(steps != topo.face_count[used])[0]
    if short.size:
        v = int(used[short[0]])
        raise names.error(
            f"{names.vertex(v)} joins separate fans of faces (a non-manifold vertex: "
            f"{int(topo.face_count[v])} faces, {int(steps[short[0]])} of them in one fan); "
            "expected the faces around a vertex to form one disk or half-disk"
        )


# --------------------------------------------------------------------------- refinement


def _scatter(index: NDArray, values: NDArray, n: int) -> NDArray:
    """Sums of the rows of ``values`` by ``index``: shape (n, values.shape[1])."""
    out = np.empty((n, values.shape[1]))
    for c in range(values.shape[1]):
        out[:, c] = np.bincount(index, weights=values[:, c], minlength=n)
    return out


def _refine(P: NDArray, topo: MeshTopology) -> tuple[NDArray, NDArray]:
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
    """One Catmull–Clark refinement step of a quad mesh (rules in the module docstring).

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
        (:func:`check_mesh`).
    """
    V, F = check_mesh(vertices, faces)
    return _refine(V, MeshTopology(F, len(V)))


# --------------------------------------------------------------------------- control nets

#: corner j of a face: its cell in the 4 x 4 net and its edge directions e1 (along the
#: corner's outgoing half-edge) and e2 (toward the previous corner)
_CORNER_FRAMES = (
    ((1, 1), (1, 0), (0, 1)),
    ((2, 1), (0, 1), (-1, 0)),
    ((2, 2), (-1, 0), (0, -1)),
    ((1, 2), (0, -1), (1, 0)),
)
_DIRECTIONS = ((1, 0), (0, 1), (-1, 0), (0, -1))  # counter-clockwise, in a corner's frame


class _NotRegular(Exception):
    """A face's 4 x 4 net cannot be formed (an extraordinary corner, a broken grid)."""


def _net_index(topo: MeshTopology, h: int) -> NDArray:
    """Vertex indices of the 4 x 4 B-spline net of face h // 4 (cells [1:3, 1:3] are the
    face, corner origin(h) at [1, 1], u along h), -1 where the net lies beyond the boundary.
    """
    idx = np.full((4, 4), -1, dtype=np.int64)

    def put(cell: tuple[int, int], vertex: int) -> None:
        i, j = cell
        if not (0 <= i < 4 and 0 <= j < 4):
            raise _NotRegular
        if idx[i, j] >= 0 and idx[i, j] != vertex:
            raise _NotRegular
        idx[i, j] = vertex

    g0 = h
    for (oi, oj), (ai, aj), (bi, bj) in _CORNER_FRAMES:
        c = int(topo.origin[g0])
        if not topo.regular[c]:
            raise _NotRegular

        def cell(a: int, b: int, oi=oi, oj=oj, ai=ai, aj=aj, bi=bi, bj=bj) -> tuple[int, int]:
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
            raise _NotRegular
        for g, k in walk:
            d, d1 = _DIRECTIONS[k % 4], _DIRECTIONS[(k + 1) % 4]
            put(cell(*d), int(topo.dest[g]))
            put(cell(d[0] + d1[0], d[1] + d1[1]), int(topo.dest[topo.next(g)]))
            put(cell(*d1), int(topo.origin[topo.prev(g)]))
        g0 = topo.next(g0)
    return idx


def _net_points(P: NDArray, idx: NDArray) -> NDArray:
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


def _bezier_patch(P: NDArray, topo: MeshTopology, h: int) -> BezierPatch:
    net = _net_points(P, _net_index(topo, h))
    M = BSPLINE_TO_BEZIER
    return BezierPatch(np.einsum("ia,abc,jb->ijc", M, net, M))


# --------------------------------------------------------------------------- Stam patches


def _local_mesh(topo: MeshTopology, h: int) -> tuple[list[int], tuple[tuple[int, ...], ...]]:
    """The faces around the 4 corners of face h // 4, numbered canonically from h.

    Returns the global indices of the local vertices and the local faces (local vertex
    indices, each face from the corner it was reached by).  The order depends only on the
    connectivity around h, so equal neighbourhoods give equal local meshes (the signature
    of Stam's local subdivision matrix).  Local face 0 is face h // 4, starting at h.
    """
    seen_faces: dict[int, None] = {}
    local_faces = []
    ids: dict[int, int] = {}
    g0 = h
    for _ in range(4):
        for g in topo.fan(g0):
            f, s = g // 4, g % 4
            if f in seen_faces:
                continue
            seen_faces[f] = None
            row = []
            for r in range(4):
                v = int(topo.faces[f, (s + r) % 4])
                row.append(ids.setdefault(v, len(ids)))
            local_faces.append(tuple(row))
        g0 = topo.next(g0)
    return list(ids), tuple(local_faces)


@dataclass(frozen=True)
class _Scheme:
    """Stam's local subdivision matrices for one neighbourhood (one signature)."""

    A: NDArray  # (K, K): local control points one level down
    B: NDArray  # (3, 16, K): B-spline nets of the pieces q = 1, 2, 3 one level down
    limit: NDArray  # (K,): the limit-point mask (left eigenvector of A for eigenvalue 1)
    subdominant: float  # lambda: the largest |eigenvalue| of A below 1
    tangents: NDArray | None  # (2, K): left eigenvectors of the two largest below 1


_SCHEMES: dict[tuple, _Scheme | None] = {}


def _child_half_edge(q: int) -> int:
    """The half-edge (in a refined mesh) at the min corner of piece q of face 0 started at
    half-edge 0: piece 0 touches the start corner, 1 is [1/2,1]x[0,1/2], 2 is [1/2,1]^2,
    3 is [0,1/2]x[1/2,1]."""
    return 4 * q + (4 - q) % 4


def _scheme(signature: tuple) -> _Scheme | None:
    """The matrices for a local mesh, or None if its child is not alike (not self-similar)."""
    if signature in _SCHEMES:
        return _SCHEMES[signature]
    K, faces = signature
    topo = MeshTopology(np.array(faces), K)
    rows, faces1 = _refine(np.eye(K), topo)
    topo1 = MeshTopology(faces1, len(rows))
    ids, faces_child = _local_mesh(topo1, _child_half_edge(0))
    result = None
    if (len(ids), faces_child) == signature:
        A = rows[ids]
        try:
            B = np.stack(
                [
                    _net_points(rows, _net_index(topo1, _child_half_edge(q))).reshape(16, K)
                    for q in (1, 2, 3)
                ]
            )
        except _NotRegular:
            B = None
        if B is not None:
            # limit mask: l^T A = l^T, l^T 1 = 1
            M = np.vstack([A.T - np.eye(K), np.ones((1, K))])
            rhs = np.zeros(K + 1)
            rhs[-1] = 1.0
            limit = np.linalg.lstsq(M, rhs, rcond=None)[0]
            values, vectors = np.linalg.eig(A)
            order = np.argsort(-np.abs(values), kind="stable")
            subdominant = float(np.abs(values[order[1]]))
            tangents = None
            # A is diagonalisable with real eigenvalues for Catmull–Clark (Stam 1998); the
            # limit tangents are the left eigenvectors of the two largest eigenvalues < 1
            if np.abs(values.imag).max() < 1e-12 and np.linalg.cond(vectors) < 1e10:
                left = np.linalg.inv(vectors).real
                tangents = left[order[1:3]]
            result = _Scheme(A, B, limit, subdominant, tangents)
    _SCHEMES[signature] = result
    return result


def _bspline_basis(t: NDArray, order: int) -> NDArray:
    """Uniform cubic B-spline basis on [0, 1] with derivatives: shape (order + 1, len(t), 4)."""
    out = np.zeros((order + 1, t.size, 4))
    s = 1.0 - t
    t2 = t * t
    out[0] = np.stack([s * s * s, (3 * t - 6) * t2 + 4, ((-3 * t + 3) * t + 3) * t + 1, t2 * t], -1)
    out[0] /= 6.0
    if order >= 1:
        out[1] = np.stack([-0.5 * s * s, (1.5 * t - 2) * t, (-1.5 * t + 1) * t + 0.5, 0.5 * t2], -1)
    if order >= 2:
        out[2] = np.stack([s, 3 * t - 2, 1 - 3 * t, t], -1)
    if order >= 3:
        out[3] = np.array([-1.0, 3.0, -3.0, 1.0])
    return out


def _slice(index: NDArray) -> slice | None:
    """``index`` as a slice if it is a run of consecutive integers."""
    if index.size and index[-1] - index[0] == index.size - 1:
        return slice(int(index[0]), int(index[-1]) + 1)
    return None


#: Largest error of the derivatives' curvature information kept (relative to 1 / size).
DERIVATIVE_TOLERANCE = 1e-7


class StamPatch(Patch):
    """The limit surface of a Catmull–Clark face with one extraordinary vertex (Stam 1998).

    Domain [0, 1]^2 with the extraordinary vertex at (0, 0), u along the face's edge that
    leaves it.  For max(u, v) in [2^-n, 2^(1-n)] (ring n) the surface is one of three
    regular bicubic B-spline pieces: with (s, t) = (2^n u - 1, 2^n v) (piece 1),
    (2^n u - 1, 2^n v - 1) (piece 2) or (2^n u, 2^n v - 1) (piece 3),

        p(u, v) = sum_ij N_i(s) N_j(t) b^(n,q)_ij,   b^(n,q) = B_q A^(n-1) C,

    and d^(a+b) p / du^a dv^b = 2^(n (a + b)) d^(a+b) / ds^a dt^b of the piece.  A is Stam's
    local subdivision matrix (K = 2N + 8 points for an inner vertex of valence N), B_q
    picks piece q's net from the subdivided points, C are the local control points, N_i
    the uniform cubic B-splines.  The nets are computed once per patch for every ring,
    relative to the limit point p(0, 0) = l^T C (l the left eigenvector of A for
    eigenvalue 1), projecting the component of eigenvalue 1 out at every level so that the
    pieces keep their relative accuracy as they shrink like lambda^n (lambda the
    subdominant eigenvalue: 0.410 for valence 3, 0.550 for valence 5).

    At the extraordinary vertex the parametrisation is not regular: for valence 3 the
    first derivatives tend to 0, for valence 5 and more to infinity (like (2 lambda)^n), and
    the second ones are unbounded.  A float64 second derivative there carries the normal
    curvature with an absolute error of about eps / lambda^n (in 1 / size), so derivatives
    are returned down to the ring ``derivative_levels`` where that is below
    ``DERIVATIVE_TOLERANCE`` (u, v ~ 1e-7 for valence 3, 1e-10 for valence 5), positions
    down to ``levels`` where the pieces lie within round-off of the limit point.  Closer to
    the vertex, and at it, the patch returns the exact position, first derivatives 0 (so
    that :func:`~gshade.geometry.irregular_mask` marks the point irregular and
    :func:`~gshade.geometry.regularised_derivatives` takes limits from inside), and in
    p_uu, p_vv two tangents at the vertex (along the u and v directions, of the patch's
    size) whose cross product is the exact limit normal, from the left eigenvectors of A
    of the subdominant eigenvalue: the Taylor expansion of
    :func:`~gshade.geometry.unit_normal` (N ~ 2 du dv p_uu x p_vv there) then gives that
    normal, which :func:`~gshade.geometry.patch_normals` returns.  All other derivatives
    are 0 there.

    Parameters
    ----------
    points : ndarray, shape (n, 3)
        Control points of the mesh.
    topology : MeshTopology
        Its connectivity.
    half_edge : int
        The face's half-edge leaving the extraordinary vertex (4 face + corner).

    Attributes
    ----------
    valence : int
        Faces around the extraordinary vertex.
    boundary : bool
        Whether the extraordinary vertex lies on the boundary.
    limit_point, limit_normal : ndarray, shape (3,)
        p(0, 0) and the unit limit normal there.
    subdominant : float
        lambda.
    levels, derivative_levels : int
        Rings stored, rings with derivatives.
    """

    domain = ((0.0, 1.0), (0.0, 1.0))

    def __init__(self, points: NDArray, topology: MeshTopology, half_edge: int) -> None:
        ev = int(topology.origin[half_edge])
        self.valence = int(topology.face_count[ev])
        self.boundary = bool(topology.boundary_vertex[ev])
        P, topo, h = np.asarray(points, dtype=np.float64), topology, int(half_edge)
        explicit = []  # nets of rings reached by refining locally (not yet self-similar)
        scheme = None
        for _ in range(4):
            ids, faces = _local_mesh(topo, h)
            C = P[ids]
            scheme = _scheme((len(ids), faces))
            if scheme is not None:
                break
            # refine the neighbourhood once and look again one level down
            P, faces1 = _refine(C, MeshTopology(np.array(faces), len(ids)))
            topo = MeshTopology(faces1, len(P))
            h = _child_half_edge(0)
            try:
                explicit.append(
                    [_net_points(P, _net_index(topo, _child_half_edge(q))) for q in (1, 2, 3)]
                )
            except _NotRegular:
                break
        if scheme is None:
            raise GshadeError(
                f"Catmull–Clark: no self-similar neighbourhood found around the extraordinary "
                f"vertex of valence {self.valence} (half-edge {half_edge})"
            )
        self.limit_point = scheme.limit @ C
        D = C - self.limit_point
        self.size = 2.0 * float(np.linalg.norm(D, axis=1).max()) or 1.0
        nets = [np.stack(e) - self.limit_point for e in explicit]
        D0 = D
        # ring n of the self-similar part: B_q A^(n-1) D, projected off eigenvalue 1
        while len(nets) < MAX_LEVELS:
            nets.append(np.einsum("qmk,kc->qmc", scheme.B, D).reshape(3, 4, 4, 3))
            if np.abs(D).max() <= 2.0**-56 * self.size:
                break
            D = scheme.A @ D
            D -= scheme.limit @ D
        self._nets = np.stack(nets)  # (levels, 3, 4, 4, 3)
        self.levels = len(nets)
        self.subdominant = scheme.subdominant
        lam = min(max(scheme.subdominant, 1e-3), 0.999)
        keep = np.log(DERIVATIVE_TOLERANCE / np.finfo(np.float64).eps) / -np.log(lam)
        self.derivative_levels = int(np.clip(np.floor(keep) + len(explicit), 1, self.levels))
        # the tangent plane at the vertex: p_u, p_v of the innermost ring with derivatives,
        # projected onto the exact plane of the subdominant eigenvectors
        d = self._piece(self.derivative_levels, 2, np.zeros(1), np.zeros(1), 1)
        pu, pv = d[1, 0, :, 0, 0], d[0, 1, :, 0, 0]
        normal = np.cross(pu, pv)
        if scheme.tangents is not None:
            t1, t2 = scheme.tangents @ D0
            exact = np.cross(t1, t2)
            if np.linalg.norm(exact) > 1e-12 * np.linalg.norm(t1) * np.linalg.norm(t2):
                normal = exact if np.dot(exact, normal) >= 0 else -exact
        normal = normal / (np.linalg.norm(normal) or 1.0)
        self.limit_normal = normal
        e_u = pu - np.dot(pu, normal) * normal
        e_v = pv - np.dot(pv, normal) * normal
        self._tangents = (
            self.size * e_u / (np.linalg.norm(e_u) or 1.0),
            self.size * e_v / (np.linalg.norm(e_v) or 1.0),
        )

    def _piece(self, n: int, q: int, s: NDArray, t: NDArray, order: int) -> NDArray:
        """Derivatives (order+1, order+1, 3, len(s), len(t)) of piece q of ring n on the grid
        s x t, relative to the limit point."""
        net = np.ascontiguousarray(self._nets[n - 1, q - 1].transpose(2, 0, 1))  # (3, 4, 4)
        Bs = _bspline_basis(s, order)
        Bt = _bspline_basis(t, order)
        out = np.zeros((order + 1, order + 1, 3, s.size, t.size))
        for a in range(min(order, 3) + 1):
            rows = Bs[a] @ net  # (3, len(s), 4)
            for b in range(min(order - a, 3) + 1):
                np.matmul(rows, Bt[b].T, out=out[a, b])
                if a + b:
                    out[a, b] *= np.ldexp(1.0, n * (a + b))
        return out

    def _levels_of(self, x: NDArray) -> NDArray:
        """Ring of each parameter value (as max(u, v)); levels + 1 for the vertex itself."""
        _, e = np.frexp(x)
        n = np.maximum(1, 1 - e)
        return np.where(x > 0, np.minimum(n, self.levels + 1), self.levels + 1)

    def _at_vertex(self, order: int, out: NDArray) -> None:
        """The derivatives near the vertex (see the class docstring), positions aside."""
        out[:, :, :] = 0.0
        if order >= 2:
            out[2, 0] = self._tangents[0].reshape((3,) + (1,) * (out.ndim - 3))
            out[0, 2] = self._tangents[1].reshape((3,) + (1,) * (out.ndim - 3))

    def _block(self, n: int, q: int, s: NDArray, t: NDArray, order: int) -> NDArray:
        """Piece q of ring n on a grid, absolute positions; ring 0 is the vertex itself."""
        if n > self.levels:
            out = np.zeros((order + 1, order + 1, 3, s.size, t.size))
            self._at_vertex(order, out)
        elif n > self.derivative_levels:
            out = np.zeros((order + 1, order + 1, 3, s.size, t.size))
            self._at_vertex(order, out)
            out[0, 0] = self._piece(n, q, s, t, 0)[0, 0]
        else:
            out = self._piece(n, q, s, t, order)
        out[0, 0] += self.limit_point[:, None, None]
        return out

    def _derivatives_grid(self, u: NDArray, v: NDArray, order: int, buf: NDArray) -> None:
        lu, lv = self._levels_of(u), self._levels_of(v)
        top = self.levels + 1
        for n in np.unique(np.minimum.outer(lu, lv)):
            n = int(n)
            if n == top:
                I, J = np.nonzero(lu == top)[0], np.nonzero(lv == top)[0]
                buf[..., I[:, None], J[None, :]] = self._block(n, 0, I, J, order)
                continue
            In, Ig = np.nonzero(lu == n)[0], np.nonzero(lu > n)[0]
            Jn, Jg = np.nonzero(lv == n)[0], np.nonzero(lv > n)[0]
            scale = np.ldexp(1.0, n)
            for q, I, J, du, dv in ((1, In, Jg, 1, 0), (2, In, Jn, 1, 1), (3, Ig, Jn, 0, 1)):
                if I.size == 0 or J.size == 0:
                    continue
                s = np.clip(u[I] * scale - du, 0.0, 1.0)
                t = np.clip(v[J] * scale - dv, 0.0, 1.0)
                block = self._block(n, q, s, t, order)
                si, sj = _slice(I), _slice(J)
                if si is not None and sj is not None:  # sorted grids: plain slices
                    buf[..., si, sj] = block
                else:
                    buf[..., I[:, None], J[None, :]] = block

    def _derivatives_points(self, u: NDArray, v: NDArray, order: int) -> NDArray:
        n = self._levels_of(np.maximum(u, v))
        ring = np.minimum(n, self.levels)
        su, sv = np.ldexp(u, ring), np.ldexp(v, ring)
        hu, hv = su >= 1.0, sv >= 1.0  # (u, v) * 2^n lies in [0, 2]^2 minus [0, 1)^2
        q = np.where(hu & hv, 2, np.where(hu, 1, 3))
        key = (ring - 1) * 3 + (q - 1)
        # work on the points sorted by piece: contiguous runs share one net
        perm = np.argsort(key, kind="stable")
        key = key[perm]
        s = np.clip(su[perm] - hu[perm], 0.0, 1.0)
        t = np.clip(sv[perm] - hv[perm], 0.0, 1.0)
        Bs, Bt = _bspline_basis(s, order), _bspline_basis(t, order)
        nets = self._nets.reshape(-1, 16, 3)
        out = np.zeros((order + 1, order + 1, 3, u.size))
        starts = np.concatenate([[0], np.flatnonzero(np.diff(key)) + 1, [key.size]])
        for lo, hi in itertools.pairwise(starts.tolist()):
            k = int(key[lo])
            net = nets[k].reshape(4, 12)
            level = k // 3 + 1
            for a in range(min(order, 3) + 1):
                rows = (Bs[a, lo:hi] @ net).reshape(hi - lo, 4, 3)
                for b in range(min(order - a, 3) + 1):
                    value = np.einsum("pjc,pj->cp", rows, Bt[b, lo:hi])
                    if a + b:
                        value *= np.ldexp(1.0, level * (a + b))
                    out[a, b, :, lo:hi] = value
        out[0, 0] += self.limit_point[:, None]
        out[0, 0][:, n[perm] > self.levels] = self.limit_point[:, None]
        near = n[perm] > self.derivative_levels
        if near.any():
            position = out[0, 0][:, near]
            block = np.zeros((order + 1, order + 1, 3, int(near.sum())))
            self._at_vertex(order, block)
            block[0, 0] = position
            out[..., near] = block
        result = np.empty_like(out)
        result[..., perm] = out
        return result


# --------------------------------------------------------------------------- the surface


def subdivision_patches(
    vertices: ArrayLike,
    faces: Iterable[Sequence[int] | NDArray[np.integer]],
    *,
    levels: int = 0,
    source: str | None = None,
    face_lines: Sequence[int] | None = None,
) -> list[Patch]:
    """The exact Catmull–Clark limit surface of a quad mesh, as patches.

    Parameters
    ----------
    vertices : array_like, shape (n, 3)
    faces : sequence of 4 vertex indices each (0-based), counter-clockwise seen from outside
    levels : int
        Refinement steps before the patches are made (each multiplies the patch count by 4;
        the surface stays the same).
    source, face_lines
        For messages (see :func:`check_mesh`).

    Returns
    -------
    list of Patch
        One patch per face of the mesh after ``levels`` steps (and one more if a face had
        two or more extraordinary vertices), in face order: a
        :class:`~gshade.geometry.BezierPatch` (bicubic, exact) for a regular face with its
        (0, 0) corner at the face's first vertex, a :class:`StamPatch` with (0, 0) at the
        extraordinary vertex otherwise.  p_u x p_v points to the side from which the faces
        run counter-clockwise.

    Raises
    ------
    SurfaceDataError
        For meshes that are not manifold, consistently oriented quad meshes.
    """
    if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)) or levels < 0:
        raise GshadeError(f"levels: expected an integer >= 0, got {levels!r}")
    P, F = check_mesh(vertices, faces, source=source, face_lines=face_lines)
    topo = MeshTopology(F, len(P))
    for _ in range(int(levels)):
        P, F = _refine(P, topo)
        topo = MeshTopology(F, len(P))
    irregular = ~topo.regular[F]  # (F, 4)
    if (irregular.sum(axis=1) > 1).any():
        P, F = _refine(P, topo)
        topo = MeshTopology(F, len(P))
        irregular = ~topo.regular[F]
    patches: list[Patch] = []
    for f in range(len(F)):
        corners = np.nonzero(irregular[f])[0]
        if corners.size == 0:
            try:
                patches.append(_bezier_patch(P, topo, 4 * f))
                continue
            except _NotRegular:
                corners = np.array([0])
        patches.append(StamPatch(P, topo, 4 * f + int(corners[0])))
    return patches
