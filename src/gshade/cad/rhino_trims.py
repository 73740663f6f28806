"""A Rhino ``.3dm`` model's trims as gshade recovers them, before the kernel's shape is
built from them (:mod:`gshade.cad.rhino` recovers, :mod:`gshade.cad.rhino_brep` builds):
each loop's trims (:class:`Trim`: its edge, sense, end vertices, samples), each Brep's
(:class:`BrepPart`), the edges' samples (:func:`edge_points`), the loop's parameters handed
to its trims (:func:`split_trims`), a face's box shrunk to its loops (:func:`trimmed_box`),
and what a file without surfaces holds (:func:`found`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["BrepPart", "Trim", "edge_points", "found", "split_trims", "trimmed_box"]

#: Edge samples per span and degree, and their bounds, for the recovered trimming loops.
_SAMPLES_PER_SPAN = 4
_MIN_SAMPLES, _MAX_SAMPLES = 9, 200
#: Chord midpoints within this fraction of an edge's size from the curve, at most so many
#: points an edge.
_CHORD_TOLERANCE, _MAX_EDGE_POINTS = 1e-4, 4000


@dataclass
class Trim:
    """One trim of a loop, as recovered in the face's (u, v).

    Attributes
    ----------
    edge : int
        The Brep edge's index; -1 for a singular trim (a pole).
    reversed : bool
        True when the trim runs against its edge.
    vertices : (int, int)
        The Brep vertices at the trim's start and end (in the trim's sense).
    t : ndarray (n,)
        The edge parameters of the samples, increasing (the edge's sense).
    uv : ndarray (n, 2)
        The samples' parameters on the face at ``t`` (the edge's sense); for a singular
        trim the two ends of the segment it is in (u, v), in the trim's sense.
    """

    edge: int
    reversed: bool
    vertices: tuple[int, int]
    t: NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    uv: NDArray[np.float64] = field(default_factory=lambda: np.empty((0, 2)))


@dataclass
class BrepPart:
    """A Brep of the file: the rhino3dm object, its edges' samples (edge index -> (t, xyz))
    and its faces as (model face index, loops of trims, outer loop first)."""

    brep: Any
    samples: dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]]
    faces: list[tuple[int, list[list[Trim]]]] = field(default_factory=list)


def split_trims(
    trims: list[Trim], uv: NDArray[np.float64], free: NDArray[np.intp] | None = None
) -> None:
    """Hand each trim its piece of the loop's parameters (in its edge's sense); a singular
    trim the segment from the previous trim's end to the next one's start.

    ``free`` (per point of the loop; -1 off the poles) names, at a pole, the direction along
    which the surface does not move: there a trim's point takes that parameter from its
    nearest point off the pole in the same trim (the trim's own limit at the pole, not the
    next trim's), so that the trim's pcurve runs on without a jump and the singular trim
    spans the gap between the trims' ends."""
    at = 0
    for trim in trims:
        if trim.edge >= 0:
            piece = uv[at : at + len(trim.t)].copy()
            if free is not None:
                loose = free[at : at + len(trim.t)]
                away = np.flatnonzero(loose < 0)
                if away.size:
                    for k in np.flatnonzero(loose >= 0):
                        j = away[np.argmin(np.abs(away - k))]
                        piece[k, loose[k]] = piece[j, loose[k]]
            at += len(trim.t)
            trim.uv = piece[::-1].copy() if trim.reversed else piece
    m = len(trims)
    for i, trim in enumerate(trims):
        if trim.edge < 0:
            prev = next(trims[(i - j) % m] for j in range(1, m + 1) if trims[(i - j) % m].edge >= 0)
            succ = next(trims[(i + j) % m] for j in range(1, m + 1) if trims[(i + j) % m].edge >= 0)
            end = prev.uv[0] if prev.reversed else prev.uv[-1]
            start = succ.uv[-1] if succ.reversed else succ.uv[0]
            trim.uv = np.array([end, start])


def edge_points(edge: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Parameters t and points C(t) along an edge curve, both ends included, dense enough
    that every chord's midpoint lies within ``_CHORD_TOLERANCE`` of the edge's size from the
    curve (intervals halved where it does not, up to ``_MAX_EDGE_POINTS`` points)."""
    d = edge.Domain
    n = int(edge.SpanCount) * int(edge.Degree) * _SAMPLES_PER_SPAN
    n = min(max(n, _MIN_SAMPLES), _MAX_SAMPLES)
    ts = np.linspace(d.T0, d.T1, n)
    pts = np.array([_xyz(edge.PointAt(float(t))) for t in ts])
    size = float(np.linalg.norm(np.ptp(pts, axis=0))) or 1.0
    while len(ts) < _MAX_EDGE_POINTS:
        mid_t = 0.5 * (ts[:-1] + ts[1:])
        mid = np.array([_xyz(edge.PointAt(float(t))) for t in mid_t])
        split = np.linalg.norm(mid - 0.5 * (pts[:-1] + pts[1:]), axis=1) > _CHORD_TOLERANCE * size
        if not split.any():
            break
        at = np.flatnonzero(split) + 1  # insert after the interval's start
        ts = np.insert(ts, at, mid_t[split])
        pts = np.insert(pts, at, mid[split], axis=0)
    return ts, pts


def _xyz(p: Any) -> NDArray[np.float64]:
    return np.array([p.X, p.Y, p.Z], dtype=np.float64)


def found(model: Any) -> str:
    """What a file without surfaces holds, in a few words: "only 1 brep object without
    faces", "only 2 curve objects, 1 mesh object"."""
    kinds: dict[tuple[str, str], int] = {}
    for obj in model.Objects:
        geom = obj.Geometry if obj is not None else None
        name = "nothing" if geom is None else str(geom.ObjectType).split(".")[-1].lower()
        faces = getattr(geom, "Faces", None)
        empty = name == "brep" and faces is not None and len(faces) == 0
        key = (name, " without faces" if empty else "")
        kinds[key] = kinds.get(key, 0) + 1
    if not kinds:
        return "no objects"
    return "only " + ", ".join(
        f"{n} {k} object{'s' * (n > 1)}{rest}" for (k, rest), n in sorted(kinds.items())
    )


def trimmed_box(box: Any, loops: list[NDArray[np.float64]]) -> Any:
    """The face's box shrunk to its loops' bounding box (widened by 1e-3 of its size): a
    small face on a big plane gets the box of its trimmed region, not the plane's."""
    if not loops:
        return box
    pts = np.concatenate(loops)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 1e-3 * (hi - lo)
    out = []
    for d in (0, 1):
        a, b = max(box[d][0], lo[d] - pad[d]), min(box[d][1], hi[d] + pad[d])
        out.append((float(a), float(b)) if b - a > 1e-9 * (box[d][1] - box[d][0]) else box[d])
    return tuple(out)
