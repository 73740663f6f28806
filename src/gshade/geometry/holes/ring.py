"""The n-sided hole around an extraordinary vertex of a Catmull–Clark mesh, and its boundary
data: the first step toward filling it with G1 / G2 patches (Kiciak ch. 5; Hahn 1989).

Away from its extraordinary vertices (EVs) the Catmull–Clark limit surface is a set of
bicubic B-spline patches, C2 across their edges (Catmull & Clark 1978); at an interior EV of
valence n != 4 the n faces around it are not (Stam 1998 evaluates them exactly, as infinitely
many rings of bicubic pieces).  Here those n faces are cut out as the *hole*; what surrounds
it stays bicubic, and the hole is described by the data a filling needs: its boundary
curves and the cross-boundary derivatives of the surrounding patches.

Topology.  Let v be the EV and h_0, ..., h_(n-1) its outgoing half-edges, counter-clockwise
(seen from the side where the faces run counter-clockwise: the outward side of a closed
mesh), h_i in hole face F_i = (v, e_i, f_i, e_(i+1)) with e_i the end of h_i (edge
neighbours of v) and f_i the vertex opposite v (indices mod n).  The hole's boundary is the
closed loop of 2n mesh edges

    f_(n-1) -> e_0 -> f_0 -> e_1 -> f_1 -> ... -> e_(n-1) -> f_(n-1),

*segment* 2i being f_(i-1) -> e_i and segment 2i + 1 being e_i -> f_i, the *loop corners*
c_(2i) = f_(i-1), c_(2i+1) = e_i (segment j runs from c_j to c_(j+1)).  The loop runs
counter-clockwise around the hole seen from the normal side (the hole on its left).  As a
region the hole is n-sided: side i is the pair of segments (2i, 2i + 1), the curve
f_(i-1) -> e_i -> f_i through the outer end of the EV's i-th edge, and its n corners are
the f_i.

Regular surroundings.  Across segment j lies a face G_j outside the hole.  Its limit surface is
an exact bicubic patch if its 4 x 4 B-spline net (the face and the ring of faces around it)
exists with regular corners (:func:`~gshade.geometry.subdivision.catmull_clark.net_index`, here
with no phantom points: all 16 points real).  This holds if the EV's 2-ring is regular (e_i, f_i
and the far corners of the G_j interior of valence 4, no mesh boundary within reach).  If it
does not, :func:`find_holes` refines the whole mesh once
(:func:`~gshade.geometry.subdivision.catmull_clark.refine`; the surface does not change, the
hole shrinks to a quarter and the surrounding faces are the children of v's faces at the e_i,
whose other corners are edge and face points, always of valence 4: only the e_i still need to be
interior of valence 4, another EV opposite v in a face is harmless), and if that is not enough
(an EV adjacent to v, or an e_i on the mesh boundary), twice: then every corner of the
surrounding faces is a new point inside v's faces and the surroundings are regular for any
interior EV.  Vertex points come first in the refined point list, so v keeps its index.

Boundary data.  G_j's patch is stored as the bicubic Bézier patch S_j(u, v) = sum B_a(u)
B_b(v) N_ab, N = M B M^T (B the B-spline net, M the B-spline-to-Bézier matrix), oriented
so that

- S_j(0, t), t in [0, 1], is segment j, from c_j (t = 0) to c_(j+1) (t = 1);
- u runs from the boundary outward, away from the hole, with the same speed as the mesh's
  uniform parametrisation; S_u x S_v points to the normal side, as for every gshade patch.

With w = -u (pointing INTO the hole) the boundary data of segment j are the cubic Bézier
curves, control points indexed by b:

    boundary  b_j(t)   = S_j(0, t):                      N_0b
    cross1    d1_j(t)  = d/dw S_j(-w, t) = -S_u(0, t):   3 (N_0b - N_1b)
    cross2    d2_j(t)  = d^2/dw^2 S_j(-w, t) = S_uu(0, t): 6 (N_0b - 2 N_1b + N_2b)

The limit surface is C2 across the edge with the uniform parametrisations matching, so
these are also the derivatives of the limit surface *inside* the hole (Stam's patch p of
F_i, u along h_i: d1 = -p_u(1, t), d2 = p_uu(1, t) on segment 2i + 1, e_i -> f_i;
d1 = -p_v(1 - t, 1), d2 = p_vv(1 - t, 1) on segment 2i + 2, f_i -> e_(i+1)):
a filling patch F(t, w) over segment j with F(t, 0) = b_j, F_w(t, 0) = d1_j (and
F_ww = d2_j) joins the surroundings C1 (C2), and F_t x F_w points to the normal side.

Corners.  At the loop corners e_i the loop continues along one grid line of a regular
region: segments 2i and 2i + 1 join C2 with equal parametric speed, d1 joins C1 and d2
C0 (the surface is C2 there).  At the hole's corners f_i (a quarter turn of the
parametrisation; with j = 2i + 1 the segment ending there and k = j + 1 the one starting
there)

    b_k'(0) = d1_j(1),   d1_k(0) = -b_j'(1),   b_k''(0) = d2_j(1),   d2_k(0) = b_j''(1),
    d1_k'(0) = -d1_j'(1)   (the twist p_uv of F_i at f_i),

the compatibility conditions a filling must respect at its corners (Kiciak ch. 5).  The
corner points are the limit points (16 c + 4 sum e + sum f) / 36 of the (regular) corner
vertices; the segments share them bitwise.

References
----------
E. Catmull, J. Clark, "Recursively generated B-spline surfaces on arbitrary topological
meshes", *Computer-Aided Design* 10 (1978), 350–355.  J. Stam, "Exact evaluation of
Catmull–Clark subdivision surfaces at arbitrary parameter values", *SIGGRAPH '98* (1998),
395–404.  J. Hahn, "Filling polygonal holes with rectangular patches", in *Theory and
Practice of Geometric Modeling*, Springer (1989), 81–91.  Kiciak, chapter 5, appendix A.6.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...errors import SurfaceDataError
from ..patches.bezier import BezierPatch
from ..subdivision.catmull_clark import NotRegular, net_index, refine, regular_patch
from ..subdivision.quad_mesh import MeshTopology, MessageNames, validate_mesh

__all__ = ["Hole", "extraordinary_vertices", "find_holes", "hole_around"]

#: Refinements after which the surroundings of any interior EV are regular.
MAX_REFINEMENTS = 2


@dataclass(frozen=True, eq=False)
class Hole:
    """The n faces around an interior vertex, cut out of a Catmull–Clark limit surface.

    Conventions (loop order, segment and corner numbering, parameter directions) are in the
    module docstring: segment 2i runs f_(i-1) -> e_i, segment 2i + 1 runs e_i -> f_i,
    counter-clockwise around the hole seen from the normal side; cross derivatives point
    into the hole.  Arrays are read-only.

    Attributes
    ----------
    vertex : int
        The vertex (an index into ``points``, the same as in the mesh given).
    n : int
        Its valence: faces around it, sides of the hole.
    refinements : int
        Catmull–Clark steps applied to the mesh given before the hole was cut (0, 1, 2).
    points : ndarray, shape (N, 3)
        Control points of the mesh the hole lives in (after ``refinements`` steps).
    faces : ndarray of int, shape (F, 4)
        Its faces.
    half_edges : ndarray of int, shape (n,)
        h_i = 4 F_i + k: the half-edge leaving ``vertex`` in hole face i, counter-clockwise.
    corner_vertices : ndarray of int, shape (2n,)
        The loop corners c_j as vertices: f_(n-1), e_0, f_0, e_1, ..., e_(n-1).
    corners : ndarray, shape (2n, 3)
        Their limit points.
    patches : tuple of BezierPatch
        The 2n surrounding bicubic patches S_j, one per segment, S_j(0, t) = segment j,
        u outward.
    boundary, cross1, cross2 : ndarray, shape (2n, 4, 3)
        Cubic Bézier control points of b_j(t), d1_j(t) = -S_u(0, t) and
        d2_j(t) = S_uu(0, t), t in [0, 1] from c_j to c_(j+1).
    """

    vertex: int
    n: int
    refinements: int
    points: NDArray[np.float64]
    faces: NDArray[np.int64]
    half_edges: NDArray[np.int64]
    corner_vertices: NDArray[np.int64]
    corners: NDArray[np.float64]
    patches: tuple[BezierPatch, ...]
    boundary: NDArray[np.float64]
    cross1: NDArray[np.float64]
    cross2: NDArray[np.float64]

    @property
    def hole_faces(self) -> NDArray[np.int64]:
        """Indices (into ``faces``) of the n faces of the hole, counter-clockwise."""
        return self.half_edges // 4

    @property
    def side_corners(self) -> NDArray[np.float64]:
        """The n corners of the hole as an n-sided region: the limit points of f_(i-1),
        shape (n, 3); side i runs from side corner i to side corner i + 1."""
        return self.corners[0::2]


def extraordinary_vertices(topology: MeshTopology, *, names: MessageNames | None = None) -> NDArray:
    """The interior vertices of valence other than 4, in index order.

    Parameters
    ----------
    topology : MeshTopology
    names : optional
        How messages name vertices (OBJ numbering); 0-based indices by default.

    Returns
    -------
    ndarray of int

    Raises
    ------
    SurfaceDataError
        For an extraordinary vertex on the mesh boundary (in 3 or more faces, on an open
        edge): no n-sided hole can be cut around it.
    """
    names = names or MessageNames(None, None)
    count, bnd = topology.face_count, topology.boundary_vertex
    on_boundary = np.nonzero(bnd & (count >= 3))[0]
    if on_boundary.size:
        v = int(on_boundary[0])
        raise names.error(
            f"{names.vertex(v)} is an extraordinary vertex on the mesh boundary (in "
            f"{int(count[v])} faces, on an open edge); expected extraordinary vertices "
            "inside the mesh: a hole is the closed ring of faces around one"
        )
    return np.nonzero(~bnd & (count > 0) & (count != 4))[0]


def _ring(topology: MeshTopology, vertex: int) -> list[int]:
    """Outgoing half-edges of an interior vertex, counter-clockwise from the lowest."""
    out = np.nonzero(topology.origin == vertex)[0]
    if out.size == 0 or topology.boundary_vertex[vertex]:
        raise SurfaceDataError(
            f"vertex {vertex}: expected an interior vertex of the mesh, "
            + ("found one on its boundary" if out.size else "found one in no face")
        )
    return topology.fan(int(out[0]))


def _segments(topology: MeshTopology, ring: Sequence[int]) -> list[int]:
    """The 2n boundary half-edges of the hole in loop order (hole faces on their left)."""
    out = []
    for i, h in enumerate(ring):
        prev = ring[i - 1]
        out += [topology.next(topology.next(prev)), topology.next(h)]
    return out


def _outer_half_edges(topology: MeshTopology, vertex: int) -> list[int] | None:
    """For each segment, the half-edge of the surrounding face that leaves the segment's
    start c_j away from the hole, or None if the surroundings are not regular."""
    ring = _ring(topology, vertex)
    segments = _segments(topology, ring)
    starts = [int(topology.origin[g]) for g in segments]
    if len(set(starts)) != len(starts) or vertex in starts:
        return None  # the loop touches itself: not a disk of 2n edges
    hole = {h // 4 for h in ring}
    out = []
    for g in segments:
        t = int(topology.twin[g])
        if t < 0 or t // 4 in hole:
            return None
        h = topology.next(t)  # leaves c_j; the face's previous corner is c_(j+1)
        try:
            idx = net_index(topology, h)
        except NotRegular:
            return None
        if (idx < 0).any():
            return None  # phantom points: the surroundings reach the mesh boundary
        out.append(h)
    return out


def hole_around(
    points: ArrayLike, topology: MeshTopology, vertex: int, *, refinements: int = 0
) -> Hole:
    """The hole formed by the faces around ``vertex``, whose surroundings must be regular.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Control points of a valid quad mesh
        (:func:`~gshade.geometry.subdivision.quad_mesh.validate_mesh`).
    topology : MeshTopology
        Its connectivity.
    vertex : int
        An interior vertex (any valence >= 3; 4 gives a 4-sided hole in a regular region).
    refinements : int
        Recorded in the result: the steps that made ``points`` from the mesh given.

    Returns
    -------
    Hole

    Raises
    ------
    SurfaceDataError
        If the vertex is not interior, or the faces across the hole's boundary are not all
        regular with 4 x 4 nets of real points (:func:`find_holes` refines until they are).
    """
    P = np.array(points, dtype=np.float64)  # a copy: the hole's arrays are read-only
    P.flags.writeable = False
    return _cut(P, topology, int(vertex), int(refinements))


def _cut(P: NDArray, topology: MeshTopology, vertex: int, refinements: int) -> Hole:
    """:func:`hole_around` on read-only points (shared by the holes of one mesh)."""
    outer = _outer_half_edges(topology, vertex)
    if outer is None:
        raise SurfaceDataError(
            f"vertex {vertex}: expected regular faces (4 x 4 B-spline nets, no extraordinary "
            "or boundary vertex) across the boundary of the faces around it; refine the mesh "
            "first (find_holes does)"
        )
    ring = _ring(topology, vertex)
    segments = _segments(topology, ring)
    patches = tuple(regular_patch(P, topology, h) for h in outer)
    nets = np.stack([p.points for p in patches])  # (2n, 4, 4, 3): [j, u, v]
    corners = nets[:, 0, 0].copy()  # limit points (16 c + 4 sum e + sum f) / 36
    boundary = nets[:, 0].copy()
    boundary[:, 0] = corners
    boundary[:, 3] = np.roll(corners, -1, axis=0)  # bitwise shared ends
    cross1 = 3.0 * (nets[:, 0] - nets[:, 1])
    cross2 = 6.0 * (nets[:, 0] - 2.0 * nets[:, 1] + nets[:, 2])
    faces = topology.faces.view()
    arrays = {
        "faces": faces,
        "half_edges": np.array(ring, dtype=np.int64),
        "corner_vertices": topology.origin[np.array(segments)].astype(np.int64),
        "corners": corners,
        "boundary": boundary,
        "cross1": cross1,
        "cross2": cross2,
    }
    for a in arrays.values():
        a.flags.writeable = False
    return Hole(
        vertex=vertex, n=len(ring), refinements=refinements, points=P, patches=patches, **arrays
    )


def find_holes(
    vertices: ArrayLike,
    faces: Iterable[Sequence[int] | NDArray[np.integer]],
    *,
    source: str | None = None,
    face_lines: Sequence[int] | None = None,
) -> list[Hole]:
    """The holes around all extraordinary vertices of a Catmull–Clark quad mesh.

    The mesh is refined 0, 1 or 2 times (the fewest after which every extraordinary vertex
    has regular surroundings; see the module docstring), the same number for all, so that
    the holes share one mesh (``points`` and ``faces`` are then the same arrays).

    Parameters
    ----------
    vertices : array_like, shape (n, 3)
    faces : sequence of 4 vertex indices each (0-based), counter-clockwise seen from outside
    source, face_lines
        For messages (see :func:`~gshade.geometry.subdivision.quad_mesh.validate_mesh`).

    Returns
    -------
    list of Hole
        One per interior vertex of valence != 4, in vertex order; empty for a mesh without
        extraordinary vertices.

    Raises
    ------
    SurfaceDataError
        For an invalid mesh, or an extraordinary vertex on the mesh boundary (named).
    """
    names = MessageNames(source, face_lines)
    P, F = validate_mesh(vertices, faces, source=source, face_lines=face_lines)
    topo = MeshTopology(F, len(P))
    evs = extraordinary_vertices(topo, names=names)
    if evs.size == 0:
        return []
    for k in range(MAX_REFINEMENTS + 1):
        if all(_outer_half_edges(topo, int(v)) is not None for v in evs):
            break
        if k == MAX_REFINEMENTS:  # pragma: no cover - interior EVs are regular by then
            raise names.error("could not isolate the extraordinary vertices")
        P, F = refine(P, topo)
        topo = MeshTopology(F, len(P))
    P.flags.writeable = False
    return [_cut(P, topo, int(v), k) for v in evs]
