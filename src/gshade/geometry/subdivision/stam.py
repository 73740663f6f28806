"""The exact limit surface of a Catmull–Clark quad mesh, as patches (Stam's method).

:func:`subdivision_patches` evaluates the limit surface exactly, without refining the whole
mesh:

- a face whose 4 vertices are regular is a uniform bicubic B-spline patch over its 4 x 4
  control net (phantom points beyond the boundary), converted to a
  :class:`~gshade.geometry.BezierPatch` (:mod:`~gshade.geometry.subdivision.catmull_clark`);
- a face with exactly one *extraordinary* vertex (interior of valence != 4, or on the
  boundary in 3 or more faces) is a :class:`StamPatch`: around the extraordinary vertex the
  square [0, 1]^2 splits into the L-shaped rings 2^-n <= max(u, v) <= 2^(1-n),
  n = 1, 2, ...; on ring n the surface consists of 3 regular bicubic pieces whose B-spline
  nets are B_q A^(n-1) C, with C the local control points, A the local subdivision matrix
  and B_q picking the pieces' nets;
- if a face has more than one extraordinary vertex the mesh is refined once first (after
  one step every face has at most one).

Meshes must be valid quad meshes (:func:`~gshade.geometry.subdivision.quad_mesh.validate_mesh`),
closed or open; with faces counter-clockwise seen from outside, every patch's normal p_u x p_v
points outward.

References
----------
J. Stam, "Exact evaluation of Catmull–Clark subdivision surfaces at arbitrary parameter
values", *SIGGRAPH '98* (1998), 395–404.  E. Catmull, J. Clark, *Computer-Aided Design* 10
(1978), 350–355.  Kiciak, appendix A.6.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...errors import GshadeError
from ..core.patch import Patch
from .catmull_clark import NotRegular, net_index, net_points, refine, regular_patch
from .quad_mesh import MeshTopology, validate_mesh

__all__ = ["StamPatch", "face_patches", "subdivision_patches"]

#: Most rings stored per Stam patch; beyond them a point is the extraordinary vertex itself.
MAX_LEVELS = 200


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
    rows, faces1 = refine(np.eye(K), topo)
    topo1 = MeshTopology(faces1, len(rows))
    ids, faces_child = _local_mesh(topo1, _child_half_edge(0))
    result = None
    if (len(ids), faces_child) == signature:
        A = rows[ids]
        try:
            B = np.stack(
                [
                    net_points(rows, net_index(topo1, _child_half_edge(q))).reshape(16, K)
                    for q in (1, 2, 3)
                ]
            )
        except NotRegular:
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
    normal, which :func:`~gshade.geometry.core.patch_normals` returns.  All other derivatives
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
            P, faces1 = refine(C, MeshTopology(np.array(faces), len(ids)))
            topo = MeshTopology(faces1, len(P))
            h = _child_half_edge(0)
            try:
                explicit.append(
                    [net_points(P, net_index(topo, _child_half_edge(q))) for q in (1, 2, 3)]
                )
            except NotRegular:
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
        For messages (see :func:`validate_mesh`).

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
    P, F = validate_mesh(vertices, faces, source=source, face_lines=face_lines)
    topo = MeshTopology(F, len(P))
    for _ in range(int(levels)):
        P, F = refine(P, topo)
        topo = MeshTopology(F, len(P))
    if (~topo.regular[F]).sum(axis=1).max() > 1:
        P, F = refine(P, topo)
        topo = MeshTopology(F, len(P))
    return face_patches(P, topo, range(len(F)))


def face_patches(P: NDArray, topo: MeshTopology, faces: Iterable[int]) -> list[Patch]:
    """The exact limit patches of the given faces of a valid mesh (points ``P``), each face
    with at most one extraordinary vertex: a bicubic :class:`~gshade.geometry.BezierPatch`
    where the face is regular, else a :class:`StamPatch` (see :func:`subdivision_patches`)."""
    irregular = ~topo.regular[topo.faces]
    patches: list[Patch] = []
    for f in faces:
        corners = np.nonzero(irregular[f])[0]
        if corners.size == 0:
            try:
                patches.append(regular_patch(P, topo, 4 * f))
                continue
            except NotRegular:
                corners = np.array([0])
        patches.append(StamPatch(P, topo, 4 * f + int(corners[0])))
    return patches
