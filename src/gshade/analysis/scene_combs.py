"""The curves a scene's combs run along, by body (:data:`COMB_CURVES`): the patches'
boundaries (each shared side once, collapsed sides left out) and their interior knot lines;
a CAD model's B-rep edges (seams and poles left out) and its faces' knot lines inside their
trims; the planar sections of either (:mod:`gshade.analysis.section_curves`).  Their
combs, one scale for all, and the numbers a render reports
(:mod:`gshade.analysis.curvature_combs`)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from ..geometry import Patch
from ..geometry.patches.bspline import BSplinePatch
from ..scene.bodies import CadFaces, PatchBody
from .curvature_combs import Comb, CurveFamily, CurveSamples, combs, iso_line_family
from .knot_lines import KNOT_LINE_KINDS, clipped_box, inside_loops, interior_knots
from .section_curves import SectionPlanes, SectionRegion, section_family

if TYPE_CHECKING:
    from ..scene.model import Scene

__all__ = [
    "COMB_CURVES",
    "LONGEST_SPINE",
    "comb_scale",
    "comb_summary",
    "scene_combs",
    "section_normal",
]

#: Points each knot line of a trimmed face is probed at for its parts inside the trim.
TRIM_PROBES = 257
#: An automatic scale's spine at the SCALE_PERCENTILE-th percentile of the curvatures
#: shown, relative to the scene's diagonal (a percentile, so that a few tight bends do not
#: flatten every other comb; their spines are cut at :data:`LONGEST_SPINE`)
SPINE_LENGTH, SCALE_PERCENTILE = 0.05, 50
#: The longest spine drawn, relative to the scene's diagonal
LONGEST_SPINE = 0.1


def _patch_curves(
    members: list[tuple[Any, int]],
    lines: tuple[str, ...],
    diagonal: float,
    planes: SectionPlanes | None,
    scene_patches: Sequence[Patch],
) -> list[CurveFamily]:
    """The boundaries of the patch surfaces' patches (each shared or collapsed side once
    or not at all) and the B-spline patches' interior knot lines, as iso-parameter lines;
    the patches' planar sections."""
    patches = [p for surface, _ in members for p in surface.patches]
    index = [start + k for surface, start in members for k in range(len(surface.patches))]
    sections = []
    if planes is not None:
        regions = [SectionRegion(i, scene_patches[i].domain, None, f"patch {i}") for i in index]
        sections.append(section_family(scene_patches, regions, planes))
    found: list[tuple[int, str, float, float, float, str]] = []
    seen: set[tuple] = set()
    probe = np.array([0.25, 0.5, 0.75])
    for k, patch in enumerate(patches):
        (u0, u1), (v0, v1) = patch.domain
        sides = [("u", u0, v0, v1), ("u", u1, v0, v1), ("v", v0, u0, u1), ("v", v1, u0, u1)]
        if "edges" in lines:
            for direction, value, t0, t1 in sides:
                t = t0 + (t1 - t0) * probe
                fixed = np.full(3, value)
                points = patch(fixed, t) if direction == "u" else patch(t, fixed)
                points = np.asarray(points).reshape(3, 3)
                if np.ptp(points, axis=0).max() <= 1e-9 * diagonal:
                    continue  # a collapsed side: a pole
                key = tuple(sorted(map(tuple, np.round(points / (1e-7 * diagonal)))))
                if key in seen:
                    continue
                seen.add(key)
                name = f"patch {index[k]} {direction}={value:.6g}"
                found.append((k, direction, value, t0, t1, name))
        if "knots" in lines and isinstance(patch, BSplinePatch):
            for axis, direction in enumerate("uv"):
                (lo, hi), (t0, t1) = patch.domain[axis], patch.domain[1 - axis]
                for knot, _ in interior_knots(patch.knots[axis], patch.degree[axis], lo, hi):
                    name = f"patch {index[k]} knot {direction}={knot:.6g}"
                    found.append((k, direction, knot, t0, t1, name))
    family = iso_line_family(patches, found)
    renumbered = CurveFamily(family.labels, family.ranges, _renumbered(family, index))
    return [renumbered, *sections]


def _renumbered(family: CurveFamily, index: list[int]) -> Callable:
    def evaluate(requests: list[tuple[int, NDArray[np.float64]]]) -> list[CurveSamples]:
        return [
            CurveSamples(s.derivatives, index[s.patch], s.uv) for s in family.evaluate(requests)
        ]

    return evaluate


def _cad_curves(
    members: list[tuple[Any, int]],
    lines: tuple[str, ...],
    diagonal: float,
    planes: SectionPlanes | None,
    scene_patches: Sequence[Patch],
) -> list[CurveFamily]:
    """Each CAD surface's B-rep edges (from the kernel's exact curves), its B-spline
    faces' interior knot lines and its planar sections, in the parts inside the trims."""
    from ..cad.edges import edge_derivatives, edge_ranges

    out = []
    for surface, start in members:
        cad: CadFaces = surface.body
        place = {face: k for k, face in enumerate(cad.faces)}
        if "edges" in lines:
            try:
                ranges = edge_ranges(cad.model, list(cad.faces))
            except GshadeError as exc:
                raise GshadeError(f"{surface.source}: {exc}") from None
            out.append(_edge_family(cad, int(start), place, ranges, edge_derivatives))
        if "knots" in lines:
            out.append(_face_knot_family(cad, int(start), surface.patches))
        if planes is not None:
            regions = [_face_region(cad, k, int(start)) for k in range(len(cad.faces))]
            out.append(section_family(scene_patches, regions, planes))
    return out


def _face_region(cad: CadFaces, k: int, start: int) -> SectionRegion:
    """The region of the face at place ``k`` for its sections: its trimmed part of its
    box, in its scene patch's (u, v)."""
    index = cad.faces[k]
    face = cad.model.face(index)
    box = clipped_box(face.box, face.patch.domain)
    if cad.swapped[k]:
        box = (box[1], box[0])
    inside = None
    if face.trimmed and face.loops:

        def inside(uv: NDArray[np.float64]) -> NDArray[np.bool_]:
            return inside_loops(face.loops, cad.patch_uv(k, uv))

    return SectionRegion(start + k, box, inside, f"face {index}")


def _edge_family(
    cad: CadFaces, start: int, place: dict[int, int], ranges: list, derivatives: Callable
) -> CurveFamily:
    def evaluate(requests: list[tuple[int, NDArray[np.float64]]]) -> list[CurveSamples]:
        asked = [(ranges[c][0], ranges[c][1], t) for c, t in requests]
        out = []
        for (c, _), (d, uv) in zip(requests, derivatives(cad.model, asked), strict=True):
            k = place[ranges[c][1]]
            out.append(CurveSamples(d, start + k, cad.patch_uv(k, uv)))
        return out

    labels = [f"edge {e} (face {f})" for e, f, *_ in ranges]
    return CurveFamily(labels, [(t0, t1) for *_, t0, t1 in ranges], evaluate)


def _face_knot_family(cad: CadFaces, start: int, patches: Sequence[Patch]) -> CurveFamily:
    """The knot lines of the faces in their scene patches' (u, v): each part of the line
    inside the face's trimming loops (probed at :data:`TRIM_PROBES` points) a curve."""
    found: list[tuple[int, str, float, float, float, str]] = []
    for k, index in enumerate(cad.faces):
        face = cad.model.face(index)
        patch = face.patch
        if face.kind not in KNOT_LINE_KINDS or not isinstance(patch, BSplinePatch):
            continue
        box = clipped_box(face.box, patch.domain)
        for axis, direction in enumerate("uv"):
            (lo, hi), (a, b) = box[axis], box[1 - axis]
            for knot, _ in interior_knots(patch.knots[axis], patch.degree[axis], lo, hi):
                t = np.linspace(a, b, TRIM_PROBES)
                fixed = np.full(TRIM_PROBES, knot)
                uv = np.stack([fixed, t] if direction == "u" else [t, fixed], -1)
                inside = inside_loops(face.loops, uv) if face.trimmed and face.loops else None
                runs = [(a, b)] if inside is None else _runs(t, inside)
                on = ("v" if direction == "u" else "u") if cad.swapped[k] else direction
                for t0, t1 in runs:
                    name = f"face {index} knot {direction}={knot:.6g}"
                    found.append((k, on, knot, t0, t1, name))
    family = iso_line_family(list(patches), found)
    return CurveFamily(
        family.labels, family.ranges, _renumbered(family, [start + k for k in range(len(patches))])
    )


def _runs(t: NDArray, inside: NDArray) -> list[tuple[float, float]]:
    """The parameter ranges of the runs of ``inside`` samples (two samples at least)."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], inside.astype(np.int8), [0]])))
    return [
        (float(t[a]), float(t[b - 1]))
        for a, b in zip(edges[::2], edges[1::2], strict=True)
        if b - a > 1
    ]


#: The curves a body's surfaces give combs: ``curves(members, lines, diagonal, planes,
#: patches) -> families``, ``members`` the surfaces of that body each with the scene's index
#: of its first patch, ``lines`` those of :data:`~gshade.analysis.curvature_combs.COMB_LINES`
#: asked, ``planes`` the sections' :class:`~gshade.analysis.section_curves.SectionPlanes`
#: (None without ``"sections"``), ``patches`` the scene's.
COMB_CURVES: dict[type, Callable[..., list[CurveFamily]]] = {
    PatchBody: _patch_curves,
    CadFaces: _cad_curves,
}


def scene_combs(
    scene: Scene,
    *,
    lines: tuple[str, ...] = ("edges", "knots"),
    curvature: str = "space",
    samples: Callable[[NDArray[np.float64]], int] | int = 64,
    sections: int = 8,
    section_direction: Sequence[float] | None = None,
) -> list[Comb]:
    """The combs of a scene's curves (:data:`COMB_CURVES`), ``samples`` each (or a
    function of a curve's probed points giving its count:
    :func:`~gshade.analysis.curvature_combs.combs`).  With ``"sections"`` in ``lines``,
    the cuts by ``sections`` planes perpendicular to ``section_direction`` (None: the
    shape function's ``direction`` where it has one, else z) spread over the scene."""
    from .scene_junctions import scene_diagonal

    diagonal = scene_diagonal(scene)
    planes = None
    if "sections" in lines:
        points = np.vstack([s.body.size_points(s.patches) for s in scene.surfaces])
        direction = section_direction or section_normal(scene)
        planes = SectionPlanes.spread(direction, points, sections)
    members: dict[type, list[tuple[Any, int]]] = {}
    start = 0
    for surface in scene.surfaces:
        members.setdefault(type(surface.body), []).append((surface, start))
        start += len(surface.patches)
    families = [
        family
        for kind, surfaces in members.items()
        for family in COMB_CURVES[kind](surfaces, lines, diagonal, planes, scene.patches)
    ]
    return combs(families, scene.patches, samples, curvature)


def section_normal(scene: Scene) -> tuple[float, ...]:
    """The default normal of the comb sections' planes: the shape function's
    ``direction`` parameter (the sections' normal, a pull direction) where it has one,
    else z."""
    from ..shape.registry import SHAPE_FUNCTIONS

    parameters = SHAPE_FUNCTIONS[scene.shape.function].parameters
    if "direction" not in parameters:
        return (0.0, 0.0, 1.0)
    given = scene.shape.params_for(scene.shape.function).get("direction")
    return tuple(given if given is not None else parameters["direction"].default)


def comb_scale(found: Sequence[Comb], diagonal: float) -> float:
    """The automatic scale: spines of the :data:`SCALE_PERCENTILE`-th percentile of the
    nonzero |shown curvature| are :data:`SPINE_LENGTH` of the diagonal long (1 where every
    comb is flat)."""
    values = np.concatenate([np.abs(c.values) for c in found] + [np.zeros(0)])
    values = values[np.isfinite(values) & (values > 0)]
    top = float(np.percentile(values, SCALE_PERCENTILE)) if values.size else 0.0
    return SPINE_LENGTH * diagonal / top if top > 0 else 1.0


def comb_summary(found: Sequence[Comb], curvature: str, scale: float) -> dict[str, Any]:
    """The combs' numbers: what they show, the scale, the curves, the largest |value| and
    where it is, and the inflections."""
    best: dict[str, Any] | None = None
    for comb in found:
        size = np.abs(comb.values)
        if not np.isfinite(size).any():
            continue
        i = int(np.nanargmax(size))
        if best is None or size[i] > abs(best["value"]):
            best = {
                "value": float(comb.values[i]),
                "curve": comb.label,
                "point": comb.points[i].tolist(),
                "patch": comb.patch,
                "u": float(comb.uv[i, 0]),
                "v": float(comb.uv[i, 1]),
            }
    return {
        "curvature": curvature,
        "scale": scale,
        "curves": len(found),
        "max": best,
        "inflections": [i.as_dict() for c in found for i in c.inflections],
    }
