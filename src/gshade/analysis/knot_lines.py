"""Interior knot lines of B-spline patches and faces as junctions (Kiciak, ch. 1–2).

A B-spline patch of degree (p, q) is a union of polynomial (or rational) pieces, one per
pair of knot spans.  Across an interior knot u* of multiplicity m the pieces meet with
parametric continuity C^(p - m) (Kiciak, ch. 1–2; Piegl & Tiller, §2.2): where p - m < 3 the
iso-parameter line u = u* is a junction exactly like a patch boundary, and it is measured
and classed as one (:mod:`gshade.analysis.continuity`: gap, normal angle, curvature jump,
curvature-gradient jump; the class is geometric, so a C1 knot line may well be G2).

The two pieces' one-sided derivatives at the knot come from the patch over the knot span on
each side, [u_prev, u*] and [u*, u_next]: by local support, a span's own p + 1 rows of
control points and 2p + 2 knots are a B-spline that is the patch there (no knot insertion:
cheap for large nets); each piece evaluated at its own end is the left or right limit,
where the whole patch would give the right one only.

CAD faces (``cad`` surfaces) count the knot lines of the model's own B-spline surfaces
(kinds ``bspline`` and ``bezier``; the NURBS forms of planes, quadrics and kernel
conversions have knots of the conversion, not of the design) strictly inside the face's
parameter box, and only their part inside the trimming loops: a line outside the trimmed
region is not listed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..geometry.patches.bspline import BSplinePatch
from .continuity import Junction, Tolerances, classify
from .junction_measures import compare_sides, junction_fields, side_derivatives, side_geometry

if TYPE_CHECKING:
    from collections.abc import Sequence

    from ..cad.model import CadFace
    from ..geometry import Patch
    from ..scene.bodies import CadFaces

__all__ = [
    "KNOT_LINE_KINDS",
    "KnotLine",
    "cad_knot_lines",
    "clipped_box",
    "inside_loops",
    "interior_knots",
    "knot_line_measures",
    "one_sided_pieces",
    "patch_knot_lines",
]

#: The CAD face kinds whose knots are the design's (see the module's docstring).
KNOT_LINE_KINDS = ("bspline", "bezier")
#: Knot lines are junctions where the parametric continuity C^(p - m) is below C^3.
SMOOTH_ORDER = 3
#: Knots within this fraction of the range of an end are on the boundary, not interior.
END_MARGIN = 1e-9
#: Points tested per sample along a trimmed face's knot line (its part inside the loops).
TRIM_PROBES = 16


@dataclass(frozen=True)
class KnotLine:
    """Where a knot-line junction is: ``direction`` ``"u"`` for the line u = ``knot`` (it
    runs along v), ``"v"`` for v = ``knot``; the knot's ``multiplicity`` m and the patch's
    ``degree`` p in that direction (parametric continuity C^(p - m) across the line);
    ``on`` ``"patch"`` (a scene's patch) or ``"face"`` (a CAD model's face)."""

    direction: str
    knot: float
    multiplicity: int
    degree: int
    on: str = "patch"

    @property
    def parametric_continuity(self) -> int:
        """p - m: the pieces' parametric continuity order across the line (-1: apart)."""
        return self.degree - self.multiplicity

    def as_dict(self, number: int) -> dict:
        """The JSON fields of the line on patch (or face) ``number``."""
        return {
            self.on: number,
            "direction": self.direction,
            "knot": self.knot,
            "multiplicity": self.multiplicity,
            "degree": self.degree,
            "parametric_continuity": self.parametric_continuity,
        }

    def label(self) -> str:
        """The text table's cell, e.g. ``u=0.5``."""
        return f"{self.direction}={self.knot:<5.3g}"


def interior_knots(knots: NDArray, degree: int, lo: float, hi: float) -> list[tuple[float, int]]:
    """(u*, m) of every distinct knot strictly inside (lo, hi) whose multiplicity m leaves
    the pieces less than C^3 apart: p - m < 3 (Kiciak, ch. 1–2).  Knots within
    :data:`END_MARGIN` of the range of an end are left out (a boundary, not a knot line)."""
    values, counts = np.unique(np.asarray(knots, dtype=np.float64), return_counts=True)
    margin = END_MARGIN * (hi - lo)
    keep = (values > lo + margin) & (values < hi - margin) & (degree - counts < SMOOTH_ORDER)
    return [(float(x), int(m)) for x, m in zip(values[keep], counts[keep], strict=True)]


def one_sided_pieces(
    patch: BSplinePatch, direction: str, knot: float
) -> tuple[BSplinePatch, BSplinePatch]:
    """The polynomial pieces on both sides of the interior knot line u = u*: the patch over
    the knot span [u_prev, u*] and over [u*, u_next] in ``direction`` (u_prev, u_next the
    neighbouring distinct knots), over its whole domain in the other.

    By local support (Piegl & Tiller, §2.2; Kiciak, ch. 1–2) the span [U_k, U_k+1) takes only
    the points P_(k-p) .. P_k and the knots U_(k-p) .. U_(k+p+1): those alone are a
    B-spline whose domain is that span and which equals the patch there, derivatives
    included.  So each piece's derivatives at its end u* are the one-sided limits
    d^k/du^k p(u* -) and p(u* +); the patch itself, evaluated in the span to the right of
    a knot, gives the right one only.
    """
    left, right = _side_spans(patch, direction, knot)
    return _span_piece(patch, direction, left), _span_piece(patch, direction, right)


def _side_spans(patch: BSplinePatch, direction: str, knot: float) -> tuple[int, int]:
    """The knot spans left and right of the knot line u = u* (indices into the knots)."""
    U = patch.knots[0 if direction == "u" else 1]
    return int(np.searchsorted(U, knot, "left")) - 1, int(np.searchsorted(U, knot, "right")) - 1


def _span_piece(patch: BSplinePatch, direction: str, k: int) -> BSplinePatch:
    """The patch over its knot span k in ``direction`` (see :func:`one_sided_pieces`)."""
    axis = 0 if direction == "u" else 1
    p = patch.degree[axis]
    rows = slice(k - p, k + 1)
    knots = [patch.knots[0], patch.knots[1]]
    knots[axis] = patch.knots[axis][k - p : k + p + 2]
    points = np.moveaxis(np.moveaxis(patch.points, axis, 0)[rows], 0, axis)
    w = None
    if patch.weights is not None:
        w = np.moveaxis(np.moveaxis(patch.weights, axis, 0)[rows], 0, axis)
    return BSplinePatch(points, patch.degree, tuple(knots), w)


def knot_line_measures(
    patch: BSplinePatch,
    lines: list[tuple[str, float]],
    along: list[NDArray],
) -> list[dict]:
    """The four junction measures of each knot line (direction, u*) at its parameters
    ``along`` it (the other parameter, the same count S for every line), with their
    round-off and where each is largest.

    Both pieces' derivatives to order 3 (:func:`one_sided_pieces`, each in its own scaled
    parametrisation and regularised where irregular:
    :func:`gshade.analysis.junction_measures.side_derivatives`) at (u*, t_s), or (t_s, v*),
    give, as for patch boundaries (:func:`gshade.analysis.junction_measures.compare_sides`;
    Kiciak, ch. 2–3): the gap |p(u*-) - p(u*+)|, the normal angle (both pieces oriented by
    the patch's p_u x p_v), the exact largest jump of the normal curvature (the shape
    operators' difference) and the jump of the surface gradients of the mean and Gaussian
    curvatures.  ``max_at``: ``t`` the fraction of the patch's other parameter range,
    ``uv`` the patch's parameters.
    """
    if not lines:
        return []
    count, samples = len(lines), len(along[0])
    uvs = []
    asked: dict[tuple[str, int], list[tuple[int, int]]] = {}  # span piece -> (line, side)
    for m, ((direction, knot), t) in enumerate(zip(lines, along, strict=True)):
        fixed = np.full_like(t, knot)
        uvs.append(np.stack((fixed, t) if direction == "u" else (t, fixed), axis=-1))
        for side, span in enumerate(_side_spans(patch, direction, knot)):
            asked.setdefault((direction, span), []).append((m, side))
    # each span's piece once, at the ends of both its knot lines (a line's right side is
    # the next line's left)
    sides: list[list] = [[None] * count, [None] * count]  # per side, each line's d, error
    for (direction, span), users in asked.items():
        at = np.concatenate([uvs[m] for m, _ in users])
        d, error, _ = side_derivatives(_span_piece(patch, direction, span), at[:, 0], at[:, 1], 3)
        for c, (m, side) in enumerate(users):
            part = slice(c * samples, (c + 1) * samples)
            sides[side][m] = (d[:, :, part], error[:, :, part])
    shape = (count, samples)
    geometry = [
        side_geometry(
            np.concatenate([d for d, _ in side], axis=2).reshape(4, 4, *shape, 3),
            np.concatenate([e for _, e in side], axis=2).reshape(4, 4, *shape),
        )
        for side in sides
    ]
    d_left = geometry[0].d
    runs_along_v = np.array([direction == "u" for direction, _ in lines])[:, None, None]
    tangent = np.where(runs_along_v, d_left[0, 1], d_left[1, 0])  # along the line
    cmp = compare_sides(geometry[0], geometry[1], tangent)
    uv = np.stack(uvs)
    out = []
    for m, (direction, _) in enumerate(lines):
        lo, hi = patch.domain[1 if direction == "u" else 0]
        t = (uv[m, :, 1 if direction == "u" else 0] - lo) / (hi - lo)
        measures, round_off, where = junction_fields(cmp, m, t, d_left[0, 0], uv)
        out.append({**measures, "round_off": round_off, "max_at": where})
    return out


#: Knot lines x samples measured at a time: bounds the derivative arrays (as for patches).
_CHUNK_POINTS = 2**15


def _measured(
    patch: BSplinePatch,
    number: int,
    found: list[tuple[str, float, int, NDArray]],
    tol: Tolerances,
    on: str,
) -> list[Junction]:
    """Junctions of the knot lines (direction, u*, m, parameters along) of one patch."""
    out = []
    samples = len(found[0][3]) if found else 1
    chunk = max(1, _CHUNK_POINTS // samples)
    for a in range(0, len(found), chunk):
        part = found[a : a + chunk]
        lines = [(d, x) for d, x, _, _ in part]
        measures = knot_line_measures(patch, lines, [t for *_, t in part])
        for (direction, knot, m, _), measure in zip(part, measures, strict=True):
            degree = patch.degree[0 if direction == "u" else 1]
            line = KnotLine(direction, knot, m, degree, on)
            out.append(
                Junction(
                    (number, number),
                    None,
                    False,
                    classify(measure, tol, measure["round_off"]),
                    samples=samples,
                    knot=line,
                    **measure,
                )
            )
    return out


def _spread(lo: float, hi: float, samples: int) -> NDArray:
    """``samples`` parameters in the middles of equal parts of [lo, hi]."""
    return lo + (hi - lo) * (np.arange(samples) + 0.5) / samples


def patch_knot_lines(
    patches: Sequence[Patch], *, samples: int, tolerances: Tolerances
) -> list[Junction]:
    """The interior knot lines of the B-spline patches among ``patches`` (:func:`interior_knots`
    of each direction, over the whole patch), measured at ``samples`` points each along the
    line (the middles of equal parts) and classed; ``patches`` the patch numbers."""
    out: list[Junction] = []
    for number, patch in enumerate(patches):
        if not isinstance(patch, BSplinePatch):
            continue
        found = []
        for axis, direction in enumerate("uv"):
            (lo, hi), other = patch.domain[axis], patch.domain[1 - axis]
            for knot, m in interior_knots(patch.knots[axis], patch.degree[axis], lo, hi):
                found.append((direction, knot, m, _spread(*other, samples)))
        out.extend(_measured(patch, number, found, tolerances, "patch"))
    return out


def inside_loops(loops: list[NDArray], uv: NDArray) -> NDArray[np.bool_]:
    """Whether each point (n, 2) lies in the trimmed region: inside an odd number of the
    face's loops (the outer loop and its holes; as :func:`gshade.cad.trimmed_points`)."""
    from matplotlib.path import Path as Polygon

    around = np.zeros(len(uv), dtype=int)
    for loop in loops:
        around += Polygon(loop).contains_points(uv)
    return around % 2 == 1


def trimmed_along(
    face: CadFace, direction: str, knot: float, lo: float, hi: float, samples: int
) -> NDArray | None:
    """``samples`` parameters along the knot line of a CAD face spread over its part inside
    the trimming loops (None when no part is): the line [lo, hi] cut in ``samples`` x
    :data:`TRIM_PROBES` cells, those whose middle is inside kept, and the samples at the
    middles of equal parts of the kept cells' total length."""
    if not face.trimmed or not face.loops:
        return _spread(lo, hi, samples)
    cells = samples * TRIM_PROBES
    middle = _spread(lo, hi, cells)
    fixed = np.full(cells, knot)
    uv = np.stack([fixed, middle] if direction == "u" else [middle, fixed], axis=-1)
    kept = np.flatnonzero(inside_loops(face.loops, uv))
    if len(kept) == 0:
        return None
    position = (np.arange(samples) + 0.5) / samples * len(kept)  # in kept cells' lengths
    cell = np.minimum(position.astype(int), len(kept) - 1)
    width = (hi - lo) / cells
    return lo + (kept[cell] + (position - cell)) * width


def clipped_box(
    box: tuple[tuple[float, float], tuple[float, float]],
    dom: tuple[tuple[float, float], tuple[float, float]],
) -> tuple[tuple[float, float], tuple[float, float]]:
    """A face's parameter box clipped into its patch's domain."""
    (u0, u1), (v0, v1) = box
    (a0, a1), (b0, b1) = dom
    return (max(u0, a0), min(u1, a1)), (max(v0, b0), min(v1, b1))


def cad_knot_lines(
    cad: CadFaces, start: int, *, samples: int, tolerances: Tolerances, lines: int = 0
) -> tuple[list[Junction], list]:
    """The knot lines of a ``cad`` surface's faces (:class:`gshade.scene.model.CadFaces`:
    the model, the faces rendered), measured along their parts inside the trimmed regions
    (:func:`trimmed_along`) and classed; ``patches`` the model's face numbers, like its
    B-rep edges.

    With ``lines`` > 0 each also comes as an
    :class:`~gshade.analysis.edge_continuity.EdgeLine` to draw: the iso-parameter line
    across the face's box at ``lines`` points, in the scene patch's (u, v) (its patch
    ``start`` + k for the k-th face, u and v swapped where the patch is); drawn on the
    face's own pixels only, it shows just the part inside the trim.
    """
    from .edge_continuity import EdgeLine

    out: list[Junction] = []
    drawn: list[EdgeLine] = []
    for k, index in enumerate(cad.faces):
        face = cad.model.face(index)
        patch = face.patch
        if face.kind not in KNOT_LINE_KINDS or not isinstance(patch, BSplinePatch):
            continue
        box = clipped_box(face.box, patch.domain)  # as the scene's patch of the face
        found = []
        for axis, direction in enumerate("uv"):
            (lo, hi), (a, b) = box[axis], box[1 - axis]
            for knot, m in interior_knots(patch.knots[axis], patch.degree[axis], lo, hi):
                t = trimmed_along(face, direction, knot, a, b, samples)
                if t is not None:
                    found.append((direction, knot, m, t))
        junctions = _measured(patch, index, found, tolerances, "face")
        out.extend(junctions)
        if lines:
            for junction in junctions:
                line = junction.knot
                assert line is not None
                (a, b) = box[1 if line.direction == "u" else 0]
                t = np.linspace(a, b, lines)
                fixed = np.full(lines, line.knot)
                uv = np.stack([fixed, t] if line.direction == "u" else [t, fixed], axis=-1)
                drawn.append(EdgeLine(junction.cls, [(start + k, cad.patch_uv(k, uv))]))
    return out, drawn
