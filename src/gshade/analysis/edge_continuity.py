"""Continuity along the B-rep edges of CAD models, measured, and of scenes mixing them.

Every edge shared by two faces (:func:`gshade.io.cad_edges.shared_edges`: seams, poles and
free edges are no junctions) is sampled at the same edge parameters on both faces'
parameter curves, and at each pair of points both faces' exact derivatives give the four
measures of :mod:`gshade.analysis.continuity` (gap, normal angle, normal-curvature jump,
curvature-gradient jump; Kiciak, ch. 2–3) and so the class G0–G3.  A designed sharp edge
is G0 with its angle.

A valid B-rep's faces meet within each edge's own tolerance, not exactly: each face's
points lie within the kernel's tolerance of the edge (or within the distance accuracy the
file declares, :attr:`gshade.io.cad.CadModel.precision`, where that is larger), so an edge's
G0 tolerance is the larger of the given one and twice that.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from .continuity import Junction, Tolerances, classify, continuity_report, validate_samples
from .junction_measures import (
    SideGeometry,
    compare_sides,
    derivative_scales,
    junction_fields,
    side_derivatives,
    side_geometry,
)
from .knot_lines import cad_knot_lines

__all__ = ["EdgeLine", "edge_report", "scene_continuity", "scene_diagonal", "unmeasured_edges"]


@dataclass
class EdgeLine:
    """Where to draw one measured B-rep edge in a rendered scene: its class and, per face,
    the scene's patch number and the edge's parameter curve in that patch's (u, v)."""

    cls: str
    curves: list[tuple[int, NDArray[np.float64]]]


def edge_report(
    model,
    faces: list[int] | None = None,
    *,
    samples: int = 32,
    tolerances: Tolerances | None = None,
) -> tuple[list[Junction], list]:
    """Every B-rep edge between two of the model's faces (of ``faces``, default all),
    measured and classified.

    Parameters
    ----------
    model : gshade.io.cad.CadModel
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
    edges : list of gshade.io.cad_edges.CadEdge
        The sampled edges, in the same order.

    Notes
    -----
    Normals are the faces' outward normals (p_u x p_v turned on a reversed face,
    :attr:`gshade.io.cad.CadFace.reversed`), so the angle runs from 0 to 180 degrees and a
    fold is G0.  Each face is evaluated where its pcurve says, also a little outside its
    patch's domain, the end pieces continued as the kernel does
    (:func:`gshade.analysis.junction_measures.side_derivatives`).
    """
    from ..io.cad_edges import shared_edges

    samples = validate_samples(samples)
    lo, hi = model.bounds
    tol = tolerances or Tolerances.for_size(float(np.linalg.norm(hi - lo)))
    edges = shared_edges(model, samples, faces)
    if not edges:
        return [], []
    # edges at a time: bounded temporaries (~768 bytes per edge and sample), as for patches
    chunk = max(1, _CHUNK_POINTS // samples)
    scales: dict[int, tuple[float, float]] = {}  # each face's derivative scales, once
    rows = []
    for a in range(0, len(edges), chunk):
        rows.extend(_measure_edges(model, edges[a : a + chunk], samples, scales))
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
                **measures,
            )
        )
    return out, edges


#: Edge samples measured at a time (edges x samples): bounds the derivative arrays.
_CHUNK_POINTS = 2**15


def _measure_edges(
    model, edges: list, samples: int, scales: dict[int, tuple[float, float]]
) -> list[tuple[dict, dict, dict]]:
    """Each edge's measures, round-off and ``max_at``
    (:func:`~gshade.analysis.junction_measures.junction_fields`); ``scales`` holds each
    face's derivative scales (filled in as faces come)."""
    geometry = _face_geometry(model, edges, samples, scales)
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


def _face_geometry(
    model, edges: list, samples: int, scales: dict[int, tuple[float, float]]
) -> dict:
    """(face, edge) -> the face's geometry at the edge's points on it
    (:class:`~gshade.analysis.junction_measures.SideGeometry`, outward normals) and its
    derivative scales: each face's derivatives evaluated once, at the points of all its
    edges, each in its own scaled parametrisation, then the normals and curvatures of all
    faces in one batch."""
    points: dict[int, list[tuple[int, NDArray[np.float64]]]] = {}
    for m, edge in enumerate(edges):
        for side in (0, 1):
            points.setdefault(edge.faces[side], []).append((m, edge.uv[side]))
    derivatives, errors, turns = [], [], []
    for f, items in points.items():
        face = model.face(f)
        if f not in scales:
            scales[f] = derivative_scales(face.patch)
        uv = np.concatenate([q for _, q in items])
        # the pcurve's own (u, v), also a little past the domain: the end pieces continued
        dk, ek, scales[f] = side_derivatives(face.patch, uv[:, 0], uv[:, 1], 3, scales[f])
        derivatives.append(dk)
        errors.append(ek)
        turns.append(np.full(len(uv), -1.0 if face.reversed else 1.0))
    g = side_geometry(
        np.concatenate(derivatives, axis=2), np.concatenate(errors, axis=2), np.concatenate(turns)
    )
    out = {}
    start = 0
    for f, items in points.items():
        for m, _ in items:
            s = slice(start, start + samples)
            part = SideGeometry(
                g.d[:, :, s], g.n[s], g.mean_gradient[s], g.gauss_gradient[s], g.round_off[s]
            )
            out[(f, m)] = (part, scales[f])
            start += samples
    return out


def scene_continuity(
    scene,
    *,
    samples: int = 32,
    tolerances: Tolerances | None = None,
    lines: int = 0,
) -> tuple[list[Junction], list[EdgeLine]]:
    """The continuity report of a scene: the junctions of its patches (not CAD faces), with
    their knot lines, and the B-rep edges of each ``cad`` surface, then its faces' knot
    lines (:mod:`gshade.analysis.knot_lines`: numbered and drawn like the edges).

    Patch junctions number the scene's patches; edge rows the faces of their model.  With
    ``lines`` > 0, each edge also comes as an :class:`EdgeLine` with its parameter curves
    sampled at ``lines`` points, for drawing.  ``samples`` is checked once, before any
    junction or edge is sampled (:func:`~gshade.analysis.continuity.validate_samples`).
    """
    samples = validate_samples(samples)
    surfaces = scene.surfaces
    tol = tolerances or Tolerances.for_size(scene_diagonal(scene))
    starts = np.cumsum([0] + [len(s.patches) for s in surfaces])
    grid = [
        i
        for s, a in zip(surfaces, starts, strict=False)
        if s.cad is None
        for i in range(a, a + len(s.patches))
    ]
    out: list[Junction] = []
    drawn: list[EdgeLine] = []
    if grid:
        patches = [scene.patches[i] for i in grid]
        for j in continuity_report(patches, samples=samples, tolerances=tol):
            out.append(replace(j, patches=(grid[j.patches[0]], grid[j.patches[1]])))
    for surface, start in zip(surfaces, starts, strict=False):
        if surface.cad is None:
            continue
        cad = surface.cad
        try:
            report, _ = edge_report(cad.model, list(cad.faces), samples=samples, tolerances=tol)
            if lines:
                drawn.extend(_lines(cad, int(start), report, lines))
            knots, knot_lines = cad_knot_lines(
                cad, int(start), samples=samples, tolerances=tol, lines=lines
            )
            report = report + knots
            drawn.extend(knot_lines)
        except GshadeError as exc:
            raise GshadeError(f"{surface.source}: {exc}") from None
        out.extend(report)
    return out, drawn


def unmeasured_edges(scene) -> list[dict]:
    """The B-rep edges between a face that a ``cad`` surface of the scene renders and one it
    leaves out (:attr:`gshade.scene.model.CadFaces.left_out`), whose continuity is not
    measured: ``{"file", "edge", "faces": [face, left-out face], "why"}`` each, ``why`` the
    left-out face's line (:meth:`gshade.io.cad.LeftOutFace.line`)."""
    from ..io.cad_edges import edges_to_left_out

    out: list[dict] = []
    for surface in scene.surfaces:
        cad = surface.cad
        if cad is None or not cad.left_out:
            continue
        lost = {face.index: face for face in cad.left_out}
        try:
            edges = edges_to_left_out(cad.model, list(cad.faces), list(lost))
        except GshadeError as exc:
            raise GshadeError(f"{surface.source}: {exc}") from None
        out.extend(
            {"file": cad.model.path.name, "edge": e, "faces": [i, j], "why": lost[j].line()}
            for e, i, j in edges
        )
    return out


def _lines(cad, start: int, report: list[Junction], lines: int) -> list[EdgeLine]:
    """The measured edges' parameter curves in the scene patches' (u, v), densely."""
    from ..io.cad_edges import CadEdge, shared_edges

    place = {face: start + k for k, face in enumerate(cad.faces)}
    dense: dict[tuple[int | None, tuple[int, int]], CadEdge] = {
        (e.index, e.faces): e for e in shared_edges(cad.model, lines, list(cad.faces))
    }
    out = []
    for j in report:
        edge = dense[(j.edge, j.patches)]
        curves = []
        for face, uv in zip(edge.faces, edge.uv, strict=True):
            k = place[face]
            curves.append((k, uv[:, ::-1] if cad.swapped[k - start] else uv))
        out.append(EdgeLine(j.cls, curves))
    return out


def scene_diagonal(scene) -> float:
    """The scene's size: CAD models' bounding boxes and the other patches' 9 x 9 grids."""
    points = []
    for surface in scene.surfaces:
        if surface.cad is not None:
            points.extend(surface.cad.model.bounds)
        else:
            points.extend(p(*p.parameter_grid(9, 9)).reshape(-1, 3) for p in surface.patches)
    pts = np.vstack([np.atleast_2d(p) for p in points])
    return float(np.linalg.norm(np.ptp(pts, axis=0)))
