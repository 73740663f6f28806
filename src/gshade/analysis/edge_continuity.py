"""Continuity along the B-rep edges of CAD models, measured, and of scenes mixing them.

Every edge shared by two faces (:func:`gshade.cad.edges.shared_edges`: seams, poles and
free edges are no junctions) is sampled at the same edge parameters on both faces'
parameter curves, and at each pair of points both faces' exact derivatives give the four
measures of :mod:`gshade.analysis.continuity` (gap, normal angle, normal-curvature jump,
curvature-gradient jump; Kiciak, ch. 2–3) and so the class G0–G3.  A designed sharp edge
is G0 with its angle.

A valid B-rep's faces meet within each edge's own tolerance, not exactly: each face's
points lie within the kernel's tolerance of the edge (or within the distance accuracy the
file declares, :attr:`gshade.cad.CadModel.precision`, where that is larger), so an edge's
G0 tolerance is the larger of the given one and twice that.

Each face is measured by its own one-sided derivatives from inside it: an edge that lies on
a knot line of the face's B-spline, its points on the knot or within that distance of it (a
face that ends on a knot, or whose pcurve runs a tolerance past one), is evaluated on the
polynomial piece on the side where the face lies (:func:`inside_spans`), continued where a
point lies a sliver beyond it.  Each pair of faces also says whether the faces'
orientations agree along the edge (``orientation``: ``consistent`` or ``inconsistent``,
from :attr:`gshade.cad.edges.CadEdge.consistent`).
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..geometry.core.knots import find_spans
from ..geometry.core.patch import Patch
from ..geometry.patches.bspline import BSplinePatch
from .continuity import Junction, Tolerances, classify, validate_samples
from .junction_measures import (
    SideGeometry,
    centred,
    compare_sides,
    derivative_scales,
    junction_fields,
    side_derivatives,
    side_geometry,
)

if TYPE_CHECKING:
    from ..cad.model import CadModel

__all__ = [
    "EdgeLine",
    "edge_report",
    "inside_pieces",
    "inside_spans",
]


@dataclass
class EdgeLine:
    """Where to draw one measured B-rep edge in a rendered scene: its class and, per face,
    the scene's patch number and the edge's parameter curve in that patch's (u, v)."""

    cls: str
    curves: list[tuple[int, NDArray[np.float64]]]


def edge_report(
    model: CadModel,
    faces: list[int] | None = None,
    *,
    samples: int = 32,
    tolerances: Tolerances | None = None,
) -> tuple[list[Junction], list]:
    """Every B-rep edge between two of the model's faces (of ``faces``, default all),
    measured and classified.

    Parameters
    ----------
    model : gshade.cad.CadModel
        A model read with its kernel shape (STEP, IGES, BREP).
    faces : list of int, optional
        The face numbers whose shared edges are measured.
    samples : int
        Points per edge, 1 to :data:`gshade.limits.MAX_CONTINUITY_SAMPLES` (checked before
        the kernel is asked for any edge).
    tolerances : Tolerances, optional
        Default: :meth:`Tolerances.for_size` of the model's bounding-box diagonal.

    Returns
    -------
    junctions : list of Junction
        One per edge and pair of faces, ``edge`` its number, ``patches`` the face numbers;
        ``max_at``'s ``t`` is the fraction along the edge as sampled, (k + 1/2) / samples
        (the kernel's edge parameter t0 + t (t1 - t0)), ``uv`` the first face's patch's.
    edges : list of gshade.cad.edges.CadEdge
        The sampled edges, in the same order.

    Notes
    -----
    Normals are the faces' outward normals (p_u x p_v turned on a reversed face,
    :attr:`gshade.cad.CadFace.reversed`), so the angle runs from 0 to 180 degrees and a
    fold is G0; ``orientation`` says whether the two faces' orientations agree along the
    edge (a fold has consistent ones; faces that continue each other with opposite outward
    normals, inconsistent ones).  Each face is evaluated where its pcurve says, also a
    little outside its patch's domain, the end pieces continued as the kernel does
    (:func:`gshade.analysis.junction_measures.side_derivatives`), and along a knot line
    (within the edge's tolerance) by the piece on the face's side (:func:`inside_spans`).
    """
    from ..cad.edges import shared_edges

    samples = validate_samples(samples)
    lo, hi = model.bounds
    tol = tolerances or Tolerances.for_size(float(np.linalg.norm(hi - lo)))
    edges = shared_edges(model, samples, faces)
    if not edges:
        return [], []
    # edges at a time: bounded temporaries (~768 bytes per edge and sample), as for patches
    chunk = max(1, _CHUNK_POINTS // samples)
    kept: dict[int, _Face] = {}  # each face's scales and patches, once
    rows = []
    for a in range(0, len(edges), chunk):
        rows.extend(_measure_edges(model, edges[a : a + chunk], samples, kept))
    out = []
    for (measures, round_off, where), edge in zip(rows, edges, strict=True):
        own = replace(tol, g0=max(tol.g0, 2.0 * max(edge.tolerance, model.precision)))
        out.append(
            Junction(
                edge.faces,
                None,
                False,
                classify(measures, own, round_off),
                samples=samples,
                edge=edge.index,
                round_off=round_off,
                max_at=where,
                orientation=_ORIENTATION[edge.consistent],
                **measures,
            )
        )
    return out, edges


#: CadEdge.consistent -> the row's ``orientation``.
_ORIENTATION = {True: "consistent", False: "inconsistent", None: None}


#: Edge samples measured at a time (edges x samples): bounds the derivative arrays.
_CHUNK_POINTS = 2**15


@dataclass
class _Face:
    """What :func:`edge_report` keeps of a face while it measures: its derivative scales
    (:func:`~gshade.analysis.junction_measures.derivative_scales`, grown where points are
    faster), its patch about its own centre and that centre
    (:func:`~gshade.analysis.junction_measures.centred`), and that patch restricted to
    boxes of knot spans, by box (:func:`inside_spans`).  The scales and patches are kept
    with the face's patch while it lives (:data:`_KEPT`): measured again, a model's faces
    are not scaled, moved or restricted again."""

    scales: tuple[float, float]
    patch: Patch
    origin: NDArray | None
    pieces: dict = field(default_factory=dict)

    @classmethod
    def of(cls, patch: Patch) -> _Face:
        if patch not in _KEPT:
            _KEPT[patch] = (derivative_scales(patch), *centred(patch), {})
        return cls(*_KEPT[patch])

    def restricted(self, box: tuple, within: tuple | None = None) -> BSplinePatch:
        """The patch (or its restriction to the box ``within``) restricted to ``box``."""
        key = (within, box)
        if key not in self.pieces:
            outer: Any = self.patch if within is None else self.pieces[(None, within)]
            self.pieces[key] = outer.restricted(box)
        return self.pieces[key]


def _measure_edges(
    model: CadModel, edges: list, samples: int, kept: dict[int, _Face]
) -> list[tuple[dict, dict, dict]]:
    """Each edge's measures, round-off and ``max_at``
    (:func:`~gshade.analysis.junction_measures.junction_fields`); ``kept`` holds what is
    kept of each face (:class:`_Face`, filled in as faces come)."""
    geometry = _face_geometry(model, edges, samples, kept)
    count = len(edges)
    d = np.empty((2, 4, 4, count, samples, 3))
    n, h, k, r = (np.empty((2, count, samples, w)) for w in (3, 3, 3, 4))
    along = np.empty((count, samples, 3))
    for side in (0, 1):
        for m, edge in enumerate(edges):
            g, (su, sv) = geometry[(edge.faces[side], m)]
            d[side, :, :, m], n[side, m], h[side, m], k[side, m], r[side, m] = g
            if side == 0:
                # the edge's tangent on face i: p_u du/dt + p_v dv/dt (scaled p_u: times s_u)
                duv = _tangent(edge.uv[0])
                along[m] = g.d[1, 0] * (su * duv[:, :1]) + g.d[0, 1] * (sv * duv[:, 1:])
    cmp = compare_sides(
        SideGeometry(d[0], n[0], h[0], k[0], r[0]),
        SideGeometry(d[1], n[1], h[1], k[1], r[1]),
        along,
    )
    t = (np.arange(samples) + 0.5) / samples
    uv = np.stack([e.uv[0] for e in edges])
    return [junction_fields(cmp, m, t, d[0, 0, 0], uv) for m in range(count)]


def _tangent(uv: NDArray[np.float64]) -> NDArray[np.float64]:
    """d(u, v)/dk along the samples (one-sided at the ends; a lone sample: none)."""
    if len(uv) < 2:
        return np.zeros_like(uv)
    return np.gradient(uv, axis=0)


def _face_geometry(model: CadModel, edges: list, samples: int, kept: dict[int, _Face]) -> dict:
    """(face, edge) -> the face's geometry at the edge's points on it
    (:class:`~gshade.analysis.junction_measures.SideGeometry`, outward normals) and its
    derivative scales: each face's derivatives evaluated once, at the points of all its
    edges, each in its own scaled parametrisation (edges along a knot line by the piece on
    the face's side, :func:`inside_spans`), then the normals and curvatures of all faces in
    one batch."""
    points: dict[int, list[tuple[int, NDArray, NDArray, float]]] = {}
    for m, edge in enumerate(edges):
        # a face's point within this distance of a knot line lies on it, as on the edge
        reach = max(edge.tolerance, model.precision)
        for side in (0, 1):
            item = (m, edge.uv[side], edge.inward[side], reach)
            points.setdefault(edge.faces[side], []).append(item)
    derivatives, errors, turns = [], [], []
    for f, items in points.items():
        face = model.face(f)
        if f not in kept:
            kept[f] = _Face.of(face.patch)  # evaluated about its own centre
        one = kept[f]
        uv = np.concatenate([q for _, q, _, _ in items])
        if face.kind in _ANALYTIC:  # one exact surface across its arcs' knots
            # the pcurve's own (u, v), also a little past the domain: the end pieces continued
            u, v = uv[:, 0], uv[:, 1]
            dk, ek, one.scales = side_derivatives(one.patch, u, v, 3, one.scales, one.origin)
        else:
            dk, ek = _inside_derivatives(one, uv, items, samples)
        derivatives.append(dk)
        errors.append(ek)
        turns.append(np.full(len(uv), -1.0 if face.reversed else 1.0))
    g = side_geometry(
        np.concatenate(derivatives, axis=2), np.concatenate(errors, axis=2), np.concatenate(turns)
    )
    out = {}
    start = 0
    for f, items in points.items():
        for m, *_ in items:
            s = slice(start, start + samples)
            part = SideGeometry(
                g.d[:, :, s], g.n[s], g.mean_gradient[s], g.gauss_gradient[s], g.round_off[s]
            )
            out[(f, m)] = (part, kept[f].scales)
            start += samples
    return out


#: A face's patch -> its derivative scales, its patch about its own centre, that centre
#: and its restrictions to boxes of knot spans (:class:`_Face`), while the patch lives.
_KEPT: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()

#: Kinds of faces whose patches' knots join arcs of one exact surface (geometrically
#: smooth across them): every span is the face's, the span rule has nothing to choose.
_ANALYTIC = frozenset({"plane", "cylinder", "cone", "sphere", "torus"})


def _inside_derivatives(
    one: _Face, uv: NDArray, items: list, samples: int
) -> tuple[NDArray, NDArray]:
    """A face's derivatives and their round-off at its edges' points ``uv`` (its scales
    updated), each point on the knot span inside the face (:func:`inside_spans`)."""
    patch: Any = one.patch
    inward = np.concatenate([w for _, _, w, _ in items])
    distance = np.repeat([r for *_, r in items], [len(q) for _, q, _, _ in items])
    # the edges on a knot line (their points at least this close to it: over the face's
    # largest speeds) on the face's side, where one box of spans evaluates all the points
    # (a face ending on a knot): the patch restricted to it, at once
    nearest = _nearest_knots(patch, uv)
    low = distance[:, None] / np.array(one.scales)
    spans = inside_spans(patch, uv, inward, low, nearest, samples)
    box = None if spans is None else _covering_box(patch, uv, spans)
    if box is not None:
        patch = one.restricted(box)
        nearest = _nearest_knots(patch, uv)
    # the pcurve's own (u, v), also a little past the domain: the end pieces continued
    dk, ek, one.scales = side_derivatives(patch, uv[:, 0], uv[:, 1], 3, one.scales, one.origin)
    # then with the points' own speeds: what is still on a knot, piece by piece (at a
    # pole, no speed: on a knot only at it)
    reach = np.zeros(uv.shape)
    for k, (i, j) in enumerate(((1, 0), (0, 1))):
        if np.isfinite(nearest[1][:, k]).any():  # the direction has interior knots
            speed = np.sqrt(np.einsum("ni,ni->n", dk[i, j], dk[i, j])) * one.scales[k]
            np.divide(distance, speed, out=reach[:, k], where=speed > 0)
    close = (nearest[1] <= reach).any()  # usually none but those seen to above
    moves = inside_pieces(patch, uv, inward, reach, nearest, samples) if close else []
    for piece_box, at in moves:
        piece = one.restricted(piece_box, box)
        u, v = uv[at, 0], uv[at, 1]
        dp, ep, grown = side_derivatives(piece, u, v, 3, one.scales, one.origin)
        if grown != one.scales:  # the piece is faster there: all in its scales
            dk, ek = _rescaled(dk, ek, one.scales, grown)
            one.scales = grown
        dk[:, :, at], ek[:, :, at] = dp, ep
    return dk, ek


def inside_spans(
    patch: BSplinePatch,
    uv: NDArray,
    inward: NDArray,
    reach: NDArray,
    nearest: tuple[NDArray, NDArray] | None = None,
    run: int = 1,
) -> tuple[NDArray[np.intp], NDArray[np.intp]] | None:
    """The knot spans (u, v) to evaluate a face's edge points on, inside the face: per
    point the index k of the u span [U_k, U_k+1] and the v span's, or None where every
    point keeps its own (:func:`gshade.geometry.core.knots.find_spans`).

    Parameters
    ----------
    patch : BSplinePatch
        The face's surface.
    uv : ndarray (N, 2)
        The points, in the patch's parameters.
    inward : ndarray (N, 2)
        The directions into the face there (:attr:`gshade.cad.edges.CadEdge.inward`;
        only the signs of the components matter).
    reach : ndarray (N, 2)
        Per point and parameter, how far from a knot (in that parameter) the point counts
        as on it: the distance within which the face's points lie on its edges (the edge's
        tolerance), over the face's speed |p_u| or |p_v| there.
    nearest : (ndarray (N, 2), ndarray (N, 2)), optional
        The points' nearest interior knots and their distances (:func:`_nearest_knots`),
        where known.
    run : int
        The points come in runs of this many, each an edge's samples (N a multiple).

    Notes
    -----
    An edge on an interior knot line u = K (every point of its run on K, or within
    ``reach`` of it, at least a few ulps, with the face on one side) takes the span
    beside K on the face's side (where ``inward`` has a positive u component, the span
    after K; negative, the span before it).  Other points keep their own span, as the
    patch evaluates it: an edge that crosses the knot line has the face on both sides.
    So a face is measured by its one-sided derivatives from inside: across a C0 knot
    the pieces' tangent planes differ, and the piece beyond a face that ends on a knot
    is not the face's (the kernel's adaptor picks the inside piece only for a parameter
    exactly at its box's end).
    """
    knot, apart = _nearest_knots(patch, uv) if nearest is None else nearest
    on = (apart <= reach) & (inward != 0)
    if not on.any():
        return None
    if run > 1:  # whole edges only: each point on the run's knot, the face on one side
        edges = (-1, run, 2)
        first = np.s_[:, :1]
        side = np.sign(inward).reshape(edges)
        along = on.reshape(edges).all(axis=1)
        along &= (knot.reshape(edges) == knot.reshape(edges)[first]).all(axis=1)
        along &= (side == side[first]).all(axis=1)
        on = np.repeat(along, run, axis=0)
        if not on.any():
            return None
    chosen: list = [None, None]
    for k, (knots, degree) in enumerate(zip(patch.knots, patch.degree, strict=True)):
        at = on[:, k]
        if not at.any():
            continue
        # the span after the knot (its first U_k = K) or the one before it (U_k+1 = K)
        span = np.where(
            inward[at, k] > 0,
            np.searchsorted(knots, knot[at, k], side="right") - 1,
            np.searchsorted(knots, knot[at, k], side="left") - 1,
        )
        spans = find_spans(knots, degree, uv[:, k])
        if (spans[at] == span).all():
            continue
        spans[at] = span
        chosen[k] = spans
    if chosen[0] is None and chosen[1] is None:
        return None
    return tuple(  # type: ignore[return-value]
        find_spans(knots, degree, uv[:, k]) if spans is None else spans
        for k, (spans, knots, degree) in enumerate(
            zip(chosen, patch.knots, patch.degree, strict=True)
        )
    )


def _nearest_knots(patch: BSplinePatch, uv: NDArray) -> tuple[NDArray, NDArray]:
    """Per point and parameter, the nearest interior knot of the patch (N, 2) and how far
    the point lies from it, less a few ulps of the domain (N, 2; inf without one)."""
    knot = np.zeros(uv.shape)
    apart = np.full(uv.shape, np.inf)
    for k, (knots, degree) in enumerate(zip(patch.knots, patch.degree, strict=True)):
        start, end = knots[degree], knots[len(knots) - degree - 1]  # the domain
        inner = knots[degree + 1 : len(knots) - degree - 1]
        inner = inner[(inner > start) & (inner < end)]
        if len(inner):
            gaps = np.abs(uv[:, k, None] - inner)
            nearest = gaps.argmin(axis=1)
            knot[:, k] = inner[nearest]
            ulps = 8 * np.finfo(np.float64).eps * max(abs(start), abs(end))
            apart[:, k] = gaps[np.arange(len(uv)), nearest] - ulps
    return knot, apart


def inside_pieces(
    patch: BSplinePatch,
    uv: NDArray,
    inward: NDArray,
    reach: NDArray,
    nearest: tuple[NDArray, NDArray] | None = None,
    run: int = 1,
) -> list[tuple[tuple[tuple[float, float], tuple[float, float]], NDArray[np.intp]]]:
    """The points of a face's edges that its patch evaluates on a piece outside the face,
    and the piece inside it (:func:`inside_spans`, same parameters): ``[(box, points),
    ...]``, ``box`` the knot span pair ((u0, u1), (v0, v1)) of the piece to evaluate
    ``uv[points]`` on (continued past its box where the points lie beyond it)."""
    spans = inside_spans(patch, uv, inward, reach, nearest, run)
    if spans is None:
        return []
    own = [
        find_spans(knots, p, uv[:, k])
        for k, (knots, p) in enumerate(zip(patch.knots, patch.degree, strict=True))
    ]
    moved = np.flatnonzero((spans[0] != own[0]) | (spans[1] != own[1]))
    (U, V), out = patch.knots, []
    pairs = np.stack([spans[0][moved], spans[1][moved]], axis=-1)
    for a, b in np.unique(pairs, axis=0):
        box = ((float(U[a]), float(U[a + 1])), (float(V[b]), float(V[b + 1])))
        out.append((box, moved[(pairs[:, 0] == a) & (pairs[:, 1] == b)]))
    return out


def _covering_box(
    patch: BSplinePatch, uv: NDArray, spans: tuple[NDArray, NDArray]
) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """The box of knot spans on which the patch restricted to it evaluates every point on
    its span of ``spans`` (points before the box's first span on that span, continued,
    after its last on the last), or None where no box does (a face on both sides of a
    knot line it also ends on)."""
    box = []
    for k, (knots, degree) in enumerate(zip(patch.knots, patch.degree, strict=True)):
        first, last = int(spans[k].min()), int(spans[k].max())
        restricted = np.clip(find_spans(knots, degree, uv[:, k]), first, last)
        if not (restricted == spans[k]).all():
            return None
        box.append((float(knots[first]), float(knots[last + 1])))
    return box[0], box[1]


def _rescaled(d: NDArray, error: NDArray, old: tuple, new: tuple) -> tuple[NDArray, NDArray]:
    """Scaled derivatives (and their round-off) of scales ``old`` in scales ``new``."""
    power = np.arange(d.shape[0])
    factor = (old[0] / new[0]) ** power[:, None] * (old[1] / new[1]) ** power[None, :]
    return d * factor[:, :, None, None], error * factor[:, :, None]
