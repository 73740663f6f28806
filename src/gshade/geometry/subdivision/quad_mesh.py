"""Quad control meshes: half-edge connectivity and its validation.

The control mesh of a Catmull–Clark surface (Kiciak A.6; Catmull & Clark 1978) must be a
quad mesh, manifold (every edge in at most two faces, the faces around every vertex one
disk or half-disk), consistently oriented (every edge once in each direction), with no
interior vertex of valence 2; it may be closed or open.  A general polygon mesh is not
accepted: one Catmull–Clark step would make it a quad mesh, but that changes the surface
the file describes.  A vertex is *regular* for Catmull–Clark when it is interior of valence
4, on the boundary in 2 faces, or a corner (in 1 face).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...errors import SurfaceDataError

__all__ = ["MeshTopology", "validate_mesh"]


class MeshTopology:
    """Half-edge connectivity of a quad mesh (no validation: see :func:`validate_mesh`).

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


class MessageNames:
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


def validate_mesh(
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
    names = MessageNames(source, face_lines)
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
    _validate_fans(topo, names)
    interior2 = np.nonzero(~topo.boundary_vertex & (topo.face_count == 2))[0]
    if interior2.size:
        raise names.error(
            f"{names.vertex(int(interior2[0]))} is an interior vertex in only 2 faces; expected "
            "at least 3 (valence 2 has no tangent plane in the limit)"
        )
    return V, F


def _validate_fans(topo: MeshTopology, names: MessageNames) -> None:
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
