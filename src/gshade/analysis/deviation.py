"""Geometric deviation: how far the points of one surface lie from another, signed, and the
numbers a CAD-kernel team signs off on (issue 30).

For a point p of surface A with A's oriented unit normal n, the signed deviation from
surface B is

    d(p) = sign(<c - p, n>) |c - p|,    c the point of B nearest to p

(:func:`gshade.analysis.closest_points.closest_points`, exact up to rounding): positive
where B lies on the side A's normal points to (outside a solid), negative inside.  Its
summary: the largest |d| and where it is, the mean, the RMS, the 95th percentile of |d|
and the fraction within a tolerance, with the counts they are over.  Plain functions on
arrays.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..geometry import Patch
from .closest_points import ClosestPoints, closest_points
from .surface_samples import Samples

__all__ = [
    "RELATIVE_TOLERANCE",
    "TANGENT",
    "Deviation",
    "deviation_rows",
    "deviation_summary",
    "signed",
    "signed_deviation",
]

#: The default tolerance of a deviation (``gshade deviation``, ``[check] deviation``),
#: relative to A's size (its bounding box's diagonal): far above the exact distances'
#: rounding, far below a modelling change.
RELATIVE_TOLERANCE = 1e-6
#: |cos| of the angle between c - p and the normal below which c - p is tangent: d > 0.
TANGENT = 1e-9


@dataclass(frozen=True)
class Deviation:
    """The signed deviation ``distance`` (n,) of each point, and the closest points on
    the other surface (:class:`~gshade.analysis.closest_points.ClosestPoints`)."""

    distance: NDArray[np.float64]
    closest: ClosestPoints


def signed_deviation(
    points: ArrayLike,
    normals: ArrayLike,
    patches: Sequence[Patch],
    samples: Samples | None = None,
    **trims: Any,
) -> Deviation:
    """The signed deviation of ``points`` (n, 3), whose surface's unit normals are
    ``normals`` (n, 3), from the surface of ``patches`` (see the module; ``samples``: its
    points for the coarse search, :class:`~gshade.analysis.surface_samples.Samples`;
    ``trims``: ``inside`` and ``boundary`` of trimmed patches, as
    :func:`~gshade.analysis.closest_points.closest_points` takes them).  A point on B
    (distance 0) counts as positive.

    Examples
    --------
    The sphere of radius 2 against the sphere of radius 2.5, outward normals: 0.5.

    >>> from gshade.geometry import sphere
    >>> p = np.array([[0.0, 0.0, 2.0], [1.2, 1.6, 0.0]])
    >>> found = signed_deviation(p, p / 2, [sphere(2.5)])
    >>> np.round(found.distance, 12).tolist()
    [0.5, 0.5]
    >>> np.round(signed_deviation(p, p / 2, [sphere(1.5)]).distance, 12).tolist()
    [-0.5, -0.5]
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    return signed(p, n, closest_points(patches, p, samples=samples, **trims))


def signed(points: NDArray, normals: NDArray, closest: ClosestPoints) -> Deviation:
    """The distances to the ``closest`` points signed by the unit ``normals`` at ``points``
    (n, 3): negative where <c - p, n> < 0, positive elsewhere, also where c - p is
    tangent (|<c - p, n>| <= :data:`TANGENT` |c - p|: a closest point on an edge beside
    p, whose side is rounding's; one sign, no speckle).

    Examples
    --------
    >>> found = ClosestPoints(np.array([[0, 0, -1.0], [1, 0, 1e-17]]), np.zeros(2, int),
    ...                       np.zeros((2, 2)), np.array([1.0, 1.0]))
    >>> signed(np.zeros((2, 3)), np.array([[0, 0, 1.0]] * 2), found).distance.tolist()
    [-1.0, 1.0]
    """
    side = np.sum((closest.point - points) * normals, axis=-1)
    below = side < -TANGENT * closest.distance
    return Deviation(np.where(below, -closest.distance, closest.distance), closest)


def deviation_summary(
    distance: ArrayLike, tolerance: float, points: ArrayLike | None = None
) -> dict[str, Any]:
    """The numbers of signed deviations ``distance`` (n,) against ``tolerance`` (>= 0):
    ``count``, ``max_abs`` with its ``index`` (and ``point`` where ``points`` (n, 3) are
    given), ``min`` and ``max`` (signed), ``mean``, ``rms``, ``p95`` (of |d|, numpy's
    ``inverted_cdf``) and ``within`` (the fraction with |d| <= tolerance); None values
    for no point.

    Examples
    --------
    >>> s = deviation_summary([0.1, -0.3, 0.2, 0.0], 0.25)
    >>> s["max_abs"], s["index"], s["within"], round(s["rms"], 6)
    (0.3, 1, 0.75, 0.187083)
    """
    d = np.asarray(distance, dtype=np.float64).ravel()
    if d.size == 0:
        return {"count": 0, "tolerance": tolerance, "max_abs": None, "index": None}
    size = np.abs(d)
    k = int(np.argmax(size))
    out: dict[str, Any] = {
        "count": int(d.size),
        "tolerance": float(tolerance),
        "max_abs": float(size[k]),
        "index": k,
        "min": float(d.min()),
        "max": float(d.max()),
        "mean": float(d.mean()),
        "rms": float(np.sqrt(np.mean(d * d))),
        "p95": float(np.percentile(size, 95, method="inverted_cdf")),
        "within": float(np.mean(size <= tolerance)),
    }
    if points is not None:
        out["point"] = np.asarray(points, dtype=np.float64).reshape(-1, 3)[k].tolist()
    return out


def deviation_rows(summary: dict[str, Any], a: str) -> list[tuple[str, str]]:
    """The numbers of a :func:`deviation_summary` (with ``b``, and where measured in a
    picture ``pixel``, ``patch_a``, ``patch_b``; ``beyond``: points beyond B's free
    boundary) of surface ``a`` as (label, text) rows, for tables.

    Examples
    --------
    >>> s = deviation_summary([0.1, -0.3], 0.25, [[0, 0, 0], [1, 2, 3]])
    >>> dict(deviation_rows({**s, "b": "b"}, "a"))["max |d|"]
    '0.3 at (1, 2, 3)'
    """
    d = summary
    rows = [("tolerance", f"{d['tolerance']:.6g}"), ("points", str(d["count"]))]
    if d.get("beyond"):
        share = 100 * d.get("beyond_fraction", 0.0)
        rows.append(("beyond B's free boundary", f"{d['beyond']} ({share:.3g} %), not counted"))
    if d["count"]:
        x, y, z = d["point"]
        where = f" at ({x:.9g}, {y:.9g}, {z:.9g})"
        if "pixel" in d:
            where += f", pixel ({d['pixel'][0]}, {d['pixel'][1]})"
        rows.append(("max |d|", f"{d['max_abs']:.9g}{where}"))
        if "patch_a" in d:
            rows.append(("faces", f"{d['patch_a']} of {a}, {d['patch_b']} of {d.get('b', 'B')}"))
        rows += [
            ("min, max d", f"{d['min']:.6g}, {d['max']:.6g}"),
            ("mean", f"{d['mean']:.6g}"),
            ("RMS", f"{d['rms']:.6g}"),
            ("95 % of |d|", f"{d['p95']:.6g}"),
            ("within ±tolerance", f"{100 * d['within']:.4g} %"),
        ]
    return rows
