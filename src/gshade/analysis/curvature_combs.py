"""Curvature combs (porcupines): the exact curvature of curves on the surface — patch
boundaries, B-rep edges, knot lines — as spines along each curve, with its inflections.

A regular curve c(t) has the curvature vector (Kiciak, ch. 1; do Carmo, §1-5)

    k = (c'' - <c'', T> T) / |c'|^2,    T = c' / |c'|,    |k| = |c' x c''| / |c'|^3,

pointing to its centre of curvature.  On a surface with unit normal N it splits into the
normal part k_n N (k_n = <k, N>, the normal curvature of the surface in the direction T) and
the geodesic part k_g (N x T) (k_g = <k, N x T>).  A comb shows one of them (``curvature``:
``"space"`` k, ``"normal"`` k_n N, ``"geodesic"`` k_g (N x T)) as a spine at each sample,
from c(t) away from the centre of curvature to c(t) - scale k, and the envelope through the
spines' tips; the curve is G2 where the envelope is continuous, G3 where it has no kink.

The curve's derivatives are exact: a patch's iso-parameter line (a boundary or a knot line,
c(t) = S(u*, t)) from the patch's derivatives, a B-rep edge from the kernel's 3D curve
(:func:`gshade.cad.edges.edge_derivatives`).  An inflection — where the shown part of k
reverses, passing through zero (a planar curve's inflection; a sign change of k_n or k_g) —
is found between samples where the vectors point apart and then narrowed down on the exact
curve.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..geometry import Patch, regularised_derivatives
from ..geometry.core.differential import unit_normal
from ..scene.model import COMB_CURVATURES, COMB_LINES

__all__ = [
    "COMB_CURVATURES",
    "COMB_LINES",
    "Comb",
    "CurveFamily",
    "CurveSamples",
    "Inflection",
    "combs",
    "iso_line_family",
]

#: Points a curve is probed at to choose its number of samples.
PROBES = 9
#: Rounds refining an inflection, each probing its bracket at SPLITS - 1 points: its parameter
#: to SPLITS^-ROUNDS = 2^-48 of a sample's spacing, in few evaluations (a CAD model's edges
#: are evaluated by the kernel, one call a round).
INFLECTION_ROUNDS, INFLECTION_SPLITS = 8, 64
#: Below this fraction of the largest curvature shown, a sample's sign is noise (a line).
NOISE = 1e-9


@dataclass(frozen=True)
class CurveSamples:
    """A curve's exact derivatives at n parameters: ``derivatives`` (3, n, 3) c, c', c'';
    the scene patch it lies on and its (u, v) there (n, 2), for the surface normal."""

    derivatives: NDArray[np.float64]
    patch: int
    uv: NDArray[np.float64]


@dataclass(frozen=True)
class CurveFamily:
    """Curves evaluated together (one kernel call for a model's edges): each with a label
    and its parameter range; ``evaluate(requests)`` takes one parameter array per curve
    (by index) and returns their :class:`CurveSamples`."""

    labels: list[str]
    ranges: list[tuple[float, float]]
    evaluate: Callable[[list[tuple[int, NDArray[np.float64]]]], list[CurveSamples]]


@dataclass(frozen=True)
class Inflection:
    """Where a comb's shown curvature passes through zero: the curve's label, its parameter
    t, the 3D point and the scene patch with (u, v)."""

    label: str
    t: float
    point: tuple[float, float, float]
    patch: int
    u: float
    v: float

    def as_dict(self) -> dict[str, Any]:
        return {
            "curve": self.label,
            "t": self.t,
            "point": list(self.point),
            "patch": self.patch,
            "u": self.u,
            "v": self.v,
        }


@dataclass(frozen=True)
class Comb:
    """One curve's comb: its ``points`` (n, 3), the shown curvature ``vectors`` (n, 3) (the
    spine is -scale x vector), their signed ``values`` (n,) (|k| for ``"space"``, else k_n
    or k_g; NaN where the curve is singular), the patch and (u, v) of each point, and its
    inflections."""

    label: str
    points: NDArray[np.float64]
    vectors: NDArray[np.float64]
    values: NDArray[np.float64]
    patch: int
    uv: NDArray[np.float64]
    inflections: list[Inflection]


def _shown(samples: CurveSamples, patches: Sequence[Patch], curvature: str) -> tuple:
    """(vectors (n, 3), values (n,)) of the ``curvature`` part of k at the samples."""
    _, d1, d2 = samples.derivatives
    speed = np.linalg.norm(d1, axis=-1)
    scale = max(float(speed.max(initial=0.0)), 1e-300)
    regular = speed > 1e-9 * scale
    with np.errstate(divide="ignore", invalid="ignore"):
        tangent = d1 / speed[:, None]
        k = (d2 - np.sum(d2 * tangent, -1)[:, None] * tangent) / (speed**2)[:, None]
    k[~regular] = np.nan
    if curvature == "space":
        return k, np.linalg.norm(k, axis=-1)
    patch = patches[samples.patch]
    d = regularised_derivatives(patch, samples.uv[:, 0], samples.uv[:, 1], 2).d
    normal = unit_normal(d).n
    axis = normal if curvature == "normal" else np.cross(normal, tangent)
    value = np.sum(k * axis, -1)
    return value[:, None] * axis, value


def iso_line_family(
    patches: Sequence[Patch], lines: list[tuple[int, str, float, float, float, str]]
) -> CurveFamily:
    """Iso-parameter lines of scene patches: each (patch, ``"u"`` for u = value (running
    along v) or ``"v"``, value, t0, t1, label), c(t) = S(value, t) or S(t, value)."""

    def evaluate(requests: list[tuple[int, NDArray[np.float64]]]) -> list[CurveSamples]:
        out = []
        for index, t in requests:
            k, direction, value, *_ = lines[index]
            fixed = np.full(len(t), value)
            u, v = (fixed, t) if direction == "u" else (t, fixed)
            d = regularised_derivatives(patches[k], u, v, 2).d
            along = [d[0, 0], d[0, 1], d[0, 2]] if direction == "u" else [d[0, 0], d[1, 0], d[2, 0]]
            out.append(CurveSamples(np.stack(along), k, np.stack([u, v], -1)))
        return out

    return CurveFamily(
        [line[5] for line in lines], [(line[3], line[4]) for line in lines], evaluate
    )


def combs(
    families: Sequence[CurveFamily],
    patches: Sequence[Patch],
    samples: Callable[[NDArray[np.float64]], int] | int = 64,
    curvature: str = "space",
) -> list[Comb]:
    """The combs of every curve of ``families`` at ``samples`` parameters each (the
    middles of equal parts), with their inflections found on the exact curves.
    ``samples`` may be a function of a curve's points at :data:`PROBES` parameters (its
    ends and between) giving its count, such as one per few pixels of its image.

    Examples
    --------
    A circle of radius 2 as a rational quadratic patch's boundary: the comb is constant.

    >>> from gshade.geometry import BezierPatch
    >>> w = np.sqrt(0.5)
    >>> arc = [[2, 0, 0], [2, 2, 0], [0, 2, 0]]
    >>> points = np.array([arc, [[x, y, 1.0] for x, y, _ in arc]], float)
    >>> patch = BezierPatch(np.swapaxes(points, 0, 1), weights=[[1, 1], [w, w], [1, 1]])
    >>> family = iso_line_family([patch], [(0, "v", 0.0, 0.0, 1.0, "arc")])
    >>> comb = combs([family], [patch], samples=5)[0]
    >>> np.round(comb.values, 12).tolist()
    [0.5, 0.5, 0.5, 0.5, 0.5]
    """
    if curvature not in COMB_CURVATURES:
        raise ValueError(f"curvature: expected one of {COMB_CURVATURES}, got {curvature!r}")
    out: list[Comb] = []
    for family in families:
        if not family.ranges:
            continue
        if callable(samples):
            probes = [(c, np.linspace(t0, t1, PROBES)) for c, (t0, t1) in enumerate(family.ranges)]
            counts = [samples(s.derivatives[0]) for s in family.evaluate(probes)]
        else:
            counts = [samples] * len(family.ranges)
        requests = []
        for c, ((t0, t1), n) in enumerate(zip(family.ranges, counts, strict=True)):
            n = max(int(n), 2)
            requests.append((c, t0 + (t1 - t0) * (np.arange(n) + 0.5) / n))
        evaluated = family.evaluate(requests)
        shown = [_shown(s, patches, curvature) for s in evaluated]
        inflections = _inflections(family, requests, evaluated, shown, patches, curvature)
        for (c, _), s, (vectors, values), found in zip(
            requests, evaluated, shown, inflections, strict=True
        ):
            out.append(
                Comb(family.labels[c], s.derivatives[0], vectors, values, s.patch, s.uv, found)
            )
    return out


def _inflections(
    family: CurveFamily,
    requests: list[tuple[int, NDArray[np.float64]]],
    evaluated: list[CurveSamples],
    shown: list[tuple[NDArray, NDArray]],
    patches: Sequence[Patch],
    curvature: str,
) -> list[list[Inflection]]:
    """Each curve's inflections: between neighbouring samples whose shown vectors point
    apart (both above :data:`NOISE` of the curve's largest or of 1 / its size: a line's
    rounding is no inflection), the root of
    <vector(t), direction_i - direction_i+1> narrowed down on the exact curve (each round
    the first of :data:`INFLECTION_SPLITS` parts of the bracket where it changes sign)."""
    brackets = []  # (request, lo, hi, reference)
    for r, ((_, t), (vectors, _)) in enumerate(zip(requests, shown, strict=True)):
        size = np.linalg.norm(vectors, axis=-1)
        extent = float(np.linalg.norm(np.ptp(evaluated[r].derivatives[0], axis=0)))
        floor = NOISE * max(np.nanmax(size, initial=0.0), 1.0 / max(extent, 1e-300))
        big = np.nan_to_num(size) > floor
        apart = np.sum(vectors[:-1] * vectors[1:], -1) < 0
        with np.errstate(divide="ignore", invalid="ignore"):
            unit = vectors / size[:, None]
        for i in np.flatnonzero(apart & big[:-1] & big[1:]):
            brackets.append([r, t[i], t[i + 1], unit[i] - unit[i + 1]])
    found: list[list[Inflection]] = [[] for _ in requests]
    if not brackets:
        return found
    inner = np.arange(1, INFLECTION_SPLITS) / INFLECTION_SPLITS
    for _ in range(INFLECTION_ROUNDS):
        probes = [(requests[b[0]][0], b[1] + (b[2] - b[1]) * inner) for b in brackets]
        for b, (_, t), samples in zip(brackets, probes, family.evaluate(probes), strict=True):
            vectors = _shown(samples, patches, curvature)[0]
            before = np.flatnonzero(~(vectors @ b[3] > 0))  # the first probe past the root
            if before.size == 0:
                b[1] = t[-1]
            else:
                j = int(before[0])
                b[1], b[2] = (t[j - 1] if j else b[1]), t[j]
    roots = [(requests[b[0]][0], np.array([0.5 * (b[1] + b[2])])) for b in brackets]
    for b, (c, t), samples in zip(brackets, roots, family.evaluate(roots), strict=True):
        point = samples.derivatives[0, 0]
        u, v = samples.uv[0]
        found[b[0]].append(
            Inflection(
                family.labels[c],
                float(t[0]),
                (float(point[0]), float(point[1]), float(point[2])),
                samples.patch,
                float(u),
                float(v),
            )
        )
    return found
