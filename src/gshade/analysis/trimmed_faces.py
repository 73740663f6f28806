"""Closest points on a scene's trimmed CAD faces: which (u, v) of a patch lie inside its
face's trimming loops, and the points of the faces' boundaries nearest to given points.

A trimmed face is the part of its surface inside its loops.  The closest point of such a
face to a point q is either a foot point of its surface inside the loops
(:func:`gshade.analysis.closest_points.closest_points` keeps only those) or a point of its
boundary, where the distance to q restricted to the boundary curve c(t) is least:

    t <- t - <c', r> / (<c', c'> + <c'', r>),    r = c(t) - q

(Newton's method on <c'(t), r> = 0, with <c', c'> alone where the sum is not positive), from
the nearest of the curves' samples, t held in the curve's range.  The curves are the model's
B-rep edges, exact, where the kernel holds the model (:func:`gshade.cad.edge_derivatives`);
otherwise (a Rhino model) the loops' polylines in (u, v), each side a straight line of the
face's parameters on the exact surface: then within the loops' tolerance of the trim.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import NDArray

from .closest_points import ClosestPoints
from .coverage import Segments
from .knot_lines import inside_loops

if TYPE_CHECKING:
    from ..scene.model import Scene

__all__ = [
    "EDGE_SAMPLES",
    "BoundarySearch",
    "TrimTest",
    "boundary_search",
    "face_places",
    "trim_test",
]

#: Samples of each boundary curve for the coarse search, and Newton steps along it.
EDGE_SAMPLES, CURVE_STEPS = 33, 12

#: How far from a face's loops, in their tolerances, a point counts as on the face.
BAND = 2.0
#: The most pieces a face's loops are cut in for that test.
BAND_PIECES = 20_000

#: (index, uv) -> whether each point lies inside its face's trims
TrimTest = Callable[[NDArray[np.int64], NDArray[np.float64]], NDArray[np.bool_]]
#: queries (n, 3) -> their closest points on the faces' boundaries
BoundarySearch = Callable[[NDArray[np.float64]], ClosestPoints]


def face_places(scene: Scene) -> dict[int, tuple[Any, int]]:
    """Each scene patch that is a CAD model's face: its index -> (the
    :class:`~gshade.scene.bodies.CadFaces` body, its place in the body's faces)."""
    from ..scene.bodies import CadFaces

    places: dict[int, tuple[Any, int]] = {}
    start = 0
    for surface in scene.surfaces:
        if isinstance(surface.body, CadFaces):
            for k in range(len(surface.patches)):
                places[start + k] = (surface.body, k)
        start += len(surface.patches)
    return places


def _trimmed(scene: Scene) -> dict[int, tuple[Any, int, Any]]:
    """The patches whose faces are trimmed: index -> (body, place, face)."""
    out = {}
    for k, (body, place) in face_places(scene).items():
        face = body.model.face(body.faces[place])
        if face.trimmed and face.loops:
            out[k] = (body, place, face)
    return out


def trim_test(scene: Scene) -> TrimTest | None:
    """Whether points (u, v) (n, 2) of the scene's patches ``index`` (n,) lie inside their
    faces' trimming loops (:func:`gshade.analysis.knot_lines.inside_loops`; a patch that is
    no trimmed face: everywhere); None where no patch is trimmed."""
    trimmed = _trimmed(scene)
    if not trimmed:
        return None

    sides: dict[int, _TrimBand] = {}  # each face's loops' sides, when asked

    def inside(index: NDArray[np.int64], uv: NDArray[np.float64]) -> NDArray[np.bool_]:
        out = np.ones(len(index), dtype=bool)
        for k in np.unique(index).tolist():
            if k in trimmed:
                body, place, face = trimmed[k]
                at = np.flatnonzero(index == k)
                on_face = body.patch_uv(place, uv[at])
                inner = inside_loops(face.loops, on_face)
                # the loops are polylines within their tolerance of the trims: a point
                # that near them is on the face too
                near = np.flatnonzero(~inner)
                if near.size:
                    if k not in sides:
                        sides[k] = _TrimBand(face.loops, BAND * face.loop_tolerance)
                    inner[near] = sides[k].near(on_face[near])
                out[at] = inner
        return out

    return inside


class _TrimBand:
    """The points within ``reach`` of a face's loops (closed polylines in (u, v)): their
    sides cut in pieces at most 4 ``reach`` long (at most :data:`BAND_PIECES` of them); a
    point with a piece's middle within ``reach`` is near, one with none within ``reach``
    plus half a piece is not, the others measured (:class:`~gshade.analysis.coverage.Segments`)."""

    def __init__(self, loops: list[NDArray], reach: float) -> None:
        ends = []
        for loop in loops:
            ring = np.asarray(loop, dtype=np.float64).reshape(-1, 2)
            ring = np.r_[ring, ring[:1]]
            ends.append(np.stack([ring[:-1], ring[1:]], axis=1))
        sides = np.concatenate(ends) if ends else np.zeros((0, 2, 2))
        length = np.linalg.norm(sides[:, 1] - sides[:, 0], axis=-1)
        self.piece = max(4 * reach, float(length.sum()) / BAND_PIECES, 1e-300)
        cuts = np.maximum(np.ceil(length / self.piece), 1).astype(np.int64)
        side = np.repeat(np.arange(len(sides)), cuts)
        t = np.arange(side.size) - np.repeat(np.cumsum(cuts) - cuts, cuts)
        a, b = sides[side, 0], sides[side, 1] - sides[side, 0]
        lo, hi = (t / cuts[side])[:, None], ((t + 1) / cuts[side])[:, None]
        pieces = np.stack([a + lo * b, a + hi * b], axis=1)
        self.pieces = Segments(np.concatenate([pieces, np.zeros((len(pieces), 2, 1))], axis=-1))
        self.reach = reach

    def near(self, uv: NDArray) -> NDArray[np.bool_]:
        """Whether each point (n, 2) lies within the band's reach of the loops."""
        flat = np.c_[uv, np.zeros(len(uv))]
        apart = self.pieces.middles_within(flat, self.reach + self.piece / 2)
        out = apart <= self.reach
        ask = np.flatnonzero(np.isfinite(apart) & ~out)
        out[ask] = self.pieces.distances(flat[ask]) <= self.reach
        return out


class _Curves(Protocol):
    """Boundary curves: ``evaluate(curve, t)`` gives each point's derivatives (3, n, 3)
    (c, c', c''), its patch (n,) and (u, v) there (n, 2); ``range`` (m, 2) each curve's
    parameter range."""

    range: NDArray[np.float64]

    def evaluate(self, curve: NDArray, t: NDArray) -> tuple[NDArray, NDArray, NDArray]: ...


class _Edges:
    """A kernel model's B-rep edges around its trimmed faces, exact."""

    def __init__(self, body: Any, first: int, faces: list[int]) -> None:
        from ..cad.edges import edge_ranges

        self.body = body
        place = {f: k for k, f in enumerate(body.faces)}
        found = edge_ranges(body.model, [body.faces[k] for k in faces])
        self.edges = [(e, f) for e, f, _, _ in found]
        self.patch = np.array([first + place[f] for _, f in self.edges], dtype=np.int64)
        self.place = np.array([place[f] for _, f in self.edges], dtype=np.int64)
        self.range = np.array([(t0, t1) for *_, t0, t1 in found], dtype=np.float64).reshape(-1, 2)

    def evaluate(self, curve: NDArray, t: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        from ..cad.edges import edge_derivatives

        d, uv = np.empty((3, len(t), 3)), np.empty((len(t), 2))
        groups = [np.flatnonzero(curve == c) for c in np.unique(curve).tolist()]
        found = edge_derivatives(
            self.body.model, [(*self.edges[curve[at[0]]], t[at]) for at in groups]
        )
        for at, (derivatives, on_face) in zip(groups, found, strict=True):
            d[:, at], uv[at] = derivatives, on_face
        return d, self.patch[curve], self.body.patch_uv(self.place[curve], uv)


class _LoopSides:
    """The sides of trimmed faces' loop polylines, each a straight line in (u, v) on the
    exact surface, t in [0, 1]."""

    def __init__(self, patches: list[Any], faces: dict[int, tuple[Any, int, Any]]) -> None:
        from ..geometry.evaluation.patch_cells import ManyPatches

        self.many = ManyPatches(patches, drjit=False)
        starts, ends, owner = [], [], []
        for k, (body, place, face) in faces.items():
            for loop in face.loops:
                uv = body.patch_uv(place, np.asarray(loop, dtype=np.float64))
                starts.append(uv[:-1])
                ends.append(uv[1:])
                owner.append(np.full(len(uv) - 1, k))
        self.start, self.end = np.concatenate(starts), np.concatenate(ends)
        self.patch = np.concatenate(owner).astype(np.int64)
        self.range = np.tile([0.0, 1.0], (len(self.patch), 1))

    def evaluate(self, curve: NDArray, t: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        step = self.end[curve] - self.start[curve]
        uv = self.start[curve] + t[:, None] * step
        s = self.many.derivatives(self.patch[curve], uv[:, 0], uv[:, 1], 2)
        du, dv = step[:, :1], step[:, 1:]
        d = np.stack(
            [
                s[0, 0],
                s[1, 0] * du + s[0, 1] * dv,
                s[2, 0] * du * du + 2 * s[1, 1] * du * dv + s[0, 2] * dv * dv,
            ]
        )
        return d, self.patch[curve], uv


def boundary_search(scene: Scene) -> BoundarySearch | None:
    """The closest points on the boundaries of the scene's trimmed faces (see the module)
    for queries (n, 3), as :class:`~gshade.analysis.closest_points.ClosestPoints`; None
    where no face is trimmed."""
    trimmed = _trimmed(scene)
    if not trimmed:
        return None
    curves: list[_Curves] = []
    bodies: dict[int, tuple[Any, int, list[int]]] = {}
    loose: dict[int, tuple[Any, int, Any]] = {}
    for k, (body, place, face) in trimmed.items():
        if body.model.brep is not None:
            first = k - place
            bodies.setdefault(id(body), (body, first, []))[2].append(place)
        else:
            loose[k] = (body, place, face)
    curves += [_Edges(body, first, places) for body, first, places in bodies.values()]
    if loose:
        curves.append(_LoopSides(list(scene.patches), loose))
    # each family's samples and their k-d tree, made once for every call
    families = [(c, _CurveSamples(c)) for c in curves if len(c.range)]

    def search(queries: NDArray[np.float64]) -> ClosestPoints:
        q = np.asarray(queries, dtype=np.float64).reshape(-1, 3)
        best = ClosestPoints(
            np.zeros_like(q),
            np.full(len(q), -1, np.int64),
            np.zeros((len(q), 2)),
            np.full(len(q), np.inf),
        )
        for family, sampled in families:
            _nearest_on_curves(family, sampled, q, best)
        return best

    return search


class _CurveSamples:
    """:data:`EDGE_SAMPLES` points of each of ``curves``, evenly in its parameter: each
    one's curve and parameter, and their k-d tree."""

    def __init__(self, curves: _Curves) -> None:
        from scipy.spatial import cKDTree

        m = len(curves.range)
        self.curve = np.repeat(np.arange(m), EDGE_SAMPLES)
        fraction = np.tile(np.linspace(0.0, 1.0, EDGE_SAMPLES), m)
        lo, hi = curves.range[self.curve, 0], curves.range[self.curve, 1]
        self.t = lo + fraction * (hi - lo)
        self.tree = cKDTree(curves.evaluate(self.curve, self.t)[0][0])


def _nearest_on_curves(
    curves: _Curves, sampled: _CurveSamples, q: NDArray, best: ClosestPoints
) -> None:
    """The closest points of ``curves`` to ``q``, by Newton's method along each curve from
    the two nearest of its samples (``sampled``; see the module); nearer ones kept in
    ``best``."""
    curve, t_samples = sampled.curve, sampled.t
    k = min(2, len(curve))
    _, nearest = sampled.tree.query(q, k=k)
    nearest = np.asarray(nearest).reshape(len(q), k)
    who = np.repeat(np.arange(len(q)), k)
    start = nearest.ravel()
    on, t = curve[start], t_samples[start].copy()
    low, high = curves.range[on, 0], curves.range[on, 1]
    d, patch, uv = curves.evaluate(on, t)
    gap = np.linalg.norm(d[0] - q[who], axis=-1)
    active = np.arange(len(t))
    scale = np.ones(len(t))  # a step that does not bring the point nearer is shortened
    for _ in range(CURVE_STEPS):
        if not active.size:
            break
        target = q[who[active]]
        r = d[0, active] - target
        g = np.sum(d[1, active] * r, -1)
        speed = np.sum(d[1, active] ** 2, -1)
        h = speed + np.sum(d[2, active] * r, -1)
        h = np.where(h > 0, h, speed)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.nan_to_num(-g / h) * scale[active]
        moved = np.clip(t[active] + step, low[active], high[active])
        nd, n_patch, n_uv = curves.evaluate(on[active], moved)
        after = np.linalg.norm(nd[0] - target, axis=-1)
        nearer = after <= gap[active] * (1 + 1e-12) + 1e-15 * np.abs(target).max(-1)
        keep = active[nearer]
        t[keep], gap[keep] = moved[nearer], after[nearer]
        d[:, keep], patch[keep], uv[keep] = nd[:, nearer], n_patch[nearer], n_uv[nearer]
        scale[keep] = 1.0
        scale[active[~nearer]] *= 0.25
        moving = np.abs(step) > 1e-15 * (high - low)[active]
        active = active[moving & (scale[active] > 1e-9)]
    order = np.lexsort((gap, who))
    lead = order[np.r_[True, who[order][1:] != who[order][:-1]]]
    better = lead[gap[lead] < best.distance[who[lead]]]
    take = who[better]
    best.point[take], best.patch[take] = d[0, better], patch[better]
    best.uv[take], best.distance[take] = uv[better], gap[better]
