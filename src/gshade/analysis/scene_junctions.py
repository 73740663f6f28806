"""The junctions of a whole scene: each surface's measured by its body
(:mod:`gshade.scene.bodies`; :data:`JUNCTIONS`): the patches' junctions of all patch surfaces
together (:mod:`gshade.analysis.continuity`), each CAD model's B-rep edges
(:mod:`gshade.analysis.edge_continuity`) and knot lines (:mod:`gshade.analysis.knot_lines`);
the edges a left-out face leaves unmeasured; and the scene's size, which the tolerances
scale with."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import GshadeError
from ..scene.bodies import CadFaces, PatchBody
from .continuity import Junction, Tolerances, continuity_report, validate_samples
from .edge_continuity import EdgeLine, edge_report
from .knot_lines import cad_knot_lines

if TYPE_CHECKING:
    from ..scene.model import Scene

__all__ = ["JUNCTIONS", "scene_continuity", "scene_diagonal", "unmeasured_edges"]


def scene_continuity(
    scene: Scene,
    *,
    samples: int = 32,
    tolerances: Tolerances | None = None,
    lines: int = 0,
) -> tuple[list[Junction], list[EdgeLine]]:
    """The continuity report of a scene: each surface's junctions by the measure registered
    for its body (:data:`JUNCTIONS`): the junctions of the patches of all patch surfaces
    (:func:`~gshade.analysis.continuity.continuity_report`, with their knot lines), and the
    B-rep edges of each ``cad`` surface, then its faces' knot lines
    (:mod:`gshade.analysis.knot_lines`: numbered and drawn like the edges).

    Patch junctions number the scene's patches; edge rows the faces of their model.  With
    ``lines`` > 0, each edge also comes as an :class:`EdgeLine` with its parameter curves
    sampled at ``lines`` points, for drawing.  ``samples`` is checked once, before any
    junction or edge is sampled (:func:`~gshade.analysis.continuity.validate_samples`).
    """
    samples = validate_samples(samples)
    tol = tolerances or Tolerances.for_size(scene_diagonal(scene))
    members: dict[type, list[tuple[Any, int]]] = {}
    start = 0
    for surface in scene.surfaces:
        members.setdefault(type(surface.body), []).append((surface, start))
        start += len(surface.patches)
    out: list[Junction] = []
    drawn: list[EdgeLine] = []
    for kind, surfaces in members.items():
        report, lines_drawn = JUNCTIONS[kind](surfaces, samples, tol, lines)
        out.extend(report)
        drawn.extend(lines_drawn)
    return out, drawn


def _patch_junctions(
    members: list[tuple[Any, int]], samples: int, tol: Tolerances, lines: int
) -> tuple[list[Junction], list[EdgeLine]]:
    """The junctions between the patches of all the patch surfaces, and their knot lines,
    numbered as the scene numbers its patches (none drawn as edges)."""
    index = [start + k for surface, start in members for k in range(len(surface.patches))]
    patches = [p for surface, _ in members for p in surface.patches]
    out = []
    for j in continuity_report(patches, samples=samples, tolerances=tol):
        out.append(replace(j, patches=(index[j.patches[0]], index[j.patches[1]])))
    return out, []


def _cad_junctions(
    members: list[tuple[Any, int]], samples: int, tol: Tolerances, lines: int
) -> tuple[list[Junction], list[EdgeLine]]:
    """Each CAD surface's B-rep edges between its faces, then its faces' knot lines."""
    out: list[Junction] = []
    drawn: list[EdgeLine] = []
    for surface, start in members:
        cad = surface.body
        try:
            report, _ = edge_report(cad.model, list(cad.faces), samples=samples, tolerances=tol)
            if lines:
                drawn.extend(_lines(cad, int(start), report, lines))
            knots, knot_lines = cad_knot_lines(
                cad, int(start), samples=samples, tolerances=tol, lines=lines
            )
            drawn.extend(knot_lines)
        except GshadeError as exc:
            raise GshadeError(f"{surface.source}: {exc}") from None
        out.extend(report + knots)
    return out, drawn


#: How the junctions of each body's surfaces are measured:
#: ``measure(members, samples, tolerances, lines) -> (junctions, lines drawn)``, ``members``
#: the surfaces of that body, each with the scene's index of its first patch.
JUNCTIONS: dict[type, Callable[..., tuple[list[Junction], list[EdgeLine]]]] = {
    PatchBody: _patch_junctions,
    CadFaces: _cad_junctions,
}


def unmeasured_edges(scene: Scene) -> list[dict]:
    """The B-rep edges between a face that a ``cad`` surface of the scene renders and one it
    leaves out (:attr:`gshade.scene.model.CadFaces.left_out`), whose continuity is not
    measured: ``{"file", "edge", "faces": [face, left-out face], "why"}`` each, ``why`` the
    left-out face's line (:meth:`gshade.cad.LeftOutFace.line`)."""
    from ..cad.edges import edges_to_left_out

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


def _lines(cad: CadFaces, start: int, report: list[Junction], lines: int) -> list[EdgeLine]:
    """The measured edges' parameter curves in the scene patches' (u, v), densely."""
    from ..cad.edges import CadEdge, shared_edges

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
            curves.append((k, cad.patch_uv(k - start, uv)))
        out.append(EdgeLine(j.cls, curves))
    return out


def scene_diagonal(scene: Scene) -> float:
    """The scene's size: the diagonal of its surfaces' size points
    (:meth:`gshade.scene.bodies.SurfaceBody.size_points`: CAD models' bounding boxes, the
    other patches' 9 x 9 grids)."""
    pts = np.vstack([s.body.size_points(s.patches) for s in scene.surfaces])
    return float(np.linalg.norm(np.ptp(pts, axis=0)))
