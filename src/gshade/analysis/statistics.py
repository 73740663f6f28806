"""Numbers with every picture: a shape function's minimum, maximum, mean and percentiles over
a set of samples, each extreme with where it is (patch or face, (u, v), the 3D point).

Two sets of samples are summarised for a render (:mod:`gshade.rendering.statistics`): the
visible surface, one sample per covered pixel (the exact value at the pixel's centre hit),
and the whole surface, independently of the view (the texture grid of every patch or trimmed
face, weighted by the surface area each grid point stands for, its extremes polished on the
exact surface).  Plain functions on arrays.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "BINS",
    "PERCENTILES",
    "Extreme",
    "ValueStatistics",
    "summarised",
    "value_statistics",
    "weighted_percentiles",
]

#: the percentiles given with every summary
PERCENTILES = (1, 5, 25, 50, 75, 95, 99)
#: Bins the weights of many samples are summed in to find their percentiles.
BINS = 4096


@dataclass(frozen=True)
class Extreme:
    """A value and where it is: the ``patch`` (the scene's patch, or the CAD face's number),
    its parameters (``u``, ``v``) and the 3D ``point``."""

    value: float
    patch: int
    u: float
    v: float
    point: tuple[float, float, float]

    def as_dict(self) -> dict[str, Any]:
        return {
            "value": self.value,
            "patch": self.patch,
            "u": self.u,
            "v": self.v,
            "point": list(self.point),
        }


@dataclass(frozen=True)
class ValueStatistics:
    """A summary of a function's values over ``count`` samples: ``minimum`` and ``maximum``
    (with where they are), the ``mean`` and ``percentiles`` (percent -> value; weighted by
    area where the samples were), and how many samples at singular points were left out of
    the extremes."""

    count: int
    minimum: Extreme
    maximum: Extreme
    mean: float
    percentiles: dict[int, float]
    #: samples at singular points of the parametrisation (poles, collapsed edges) left out
    #: of the extremes (:func:`summarised`)
    singular: int = 0

    def as_dict(self) -> dict[str, Any]:
        return {
            "count": self.count,
            "min": self.minimum.as_dict(),
            "max": self.maximum.as_dict(),
            "mean": self.mean,
            "percentiles": {str(k): v for k, v in self.percentiles.items()},
            "singular": self.singular,
        }

    def text(self, label: str = "patch") -> str:
        """One line, e.g. 'min -0.5 (patch 3, u 0.1, v 0.2), max 0.5 (...), mean 0.01,
        median 0.02'."""

        def at(e: Extreme) -> str:
            return f"{e.value:.6g} ({label} {e.patch}, u {e.u:.6g}, v {e.v:.6g})"

        median = self.percentiles.get(50, float("nan"))
        return (
            f"min {at(self.minimum)}, max {at(self.maximum)}, mean {self.mean:.6g}, "
            f"median {median:.6g}"
        )


def weighted_percentiles(
    values: ArrayLike, percents: ArrayLike, weights: ArrayLike | None = None
) -> NDArray[np.float64]:
    """Percentiles of ``values``, each sample counting by its weight (its share of the surface
    area): the smallest value at or below which that percentage of the weight lies (numpy's
    ``inverted_cdf`` percentiles, which take weights; a sample of weight 3 counts as three).

    Many weighted samples are not sorted: their weights are summed in :data:`BINS` bins of
    equal width, and only the bin holding a percentile is sorted to find it (the same
    sample as a full sort, the sums taken in another order).

    Examples
    --------
    >>> weighted_percentiles([1.0, 2.0, 3.0], [0, 50, 100]).tolist()
    [1.0, 2.0, 3.0]
    >>> weighted_percentiles([1.0, 2.0], [50, 90], [3.0, 1.0]).tolist()  # 1: 3/4 of the area
    [1.0, 2.0]
    """
    v = np.asarray(values, dtype=np.float64).ravel()
    w = None if weights is None else np.asarray(weights, dtype=np.float64).ravel()
    q = np.asarray(percents, dtype=np.float64)
    if w is None or v.size <= BINS or np.any(q <= 0):
        return np.asarray(np.percentile(v, q, weights=w, method="inverted_cdf"), dtype=np.float64)
    lo, hi = float(v.min()), float(v.max())
    if not lo < hi:
        return np.full(q.shape, lo)
    bin_of = np.minimum(((v - lo) * (BINS / (hi - lo))).astype(np.int64), BINS - 1)
    below = np.cumsum(np.bincount(bin_of, w, BINS))
    total = below[-1]
    out = np.empty(q.size)
    for i, target in enumerate(q.ravel() / 100.0):  # as numpy: the cdf (sum / total) >= q
        k = min(int(np.searchsorted(below / total, target, side="left")), BINS - 1)
        inside = bin_of == k
        order = np.argsort(v[inside], kind="stable")
        reached = ((below[k - 1] if k else 0.0) + np.cumsum(w[inside][order])) / total
        j = min(int(np.searchsorted(reached, target, side="left")), order.size - 1)
        out[i] = v[inside][order][j]
    return out.reshape(q.shape)


def summarised(
    values: ArrayLike,
    place: Callable[[int], Extreme],
    weights: ArrayLike | None = None,
    regular: ArrayLike | None = None,
) -> ValueStatistics | None:
    """The summary of samples ``values`` (n,), each weighing ``weights`` (n,: its area;
    default equal), ``place(k)`` the :class:`Extreme` of sample k (asked for the two
    extremes only); None for no sample.  With ``regular`` (n, bool), the extremes are
    those of the samples where the parametrisation is regular (where there are any): at a
    pole or collapsed edge a value is a limit that may not exist (a curvature unbounded
    there); the others count as :attr:`ValueStatistics.singular`.

    Examples
    --------
    >>> s = summarised([1.0, 9e9, 2.0], lambda k: Extreme(k, k, 0, 0, (0, 0, 0)),
    ...                regular=[True, False, True])
    >>> s.maximum.value, s.singular
    (2, 1)
    """
    f = np.asarray(values, dtype=np.float64).ravel()
    if f.size == 0:
        return None
    w = None if weights is None else np.asarray(weights, dtype=np.float64).ravel()
    if w is not None and not w.sum() > 0:  # no area anywhere: every sample counts alike
        w = None
    mean = float(np.average(f, weights=w))
    found = weighted_percentiles(f, PERCENTILES, w)
    percentiles = {k: float(x) for k, x in zip(PERCENTILES, found, strict=True)}
    candidates = np.arange(f.size)
    if regular is not None and np.any(regular):
        candidates = np.flatnonzero(np.asarray(regular, dtype=bool).ravel())
    lowest = int(candidates[np.argmin(f[candidates])])
    highest = int(candidates[np.argmax(f[candidates])])
    return ValueStatistics(
        f.size, place(lowest), place(highest), mean, percentiles, f.size - candidates.size
    )


def value_statistics(
    values: ArrayLike,
    patch: ArrayLike,
    u: ArrayLike,
    v: ArrayLike,
    points: ArrayLike,
    weights: ArrayLike | None = None,
) -> ValueStatistics | None:
    """The summary of samples ``values`` (n,) taken at ``points`` (n, 3) on patches ``patch``
    (n,) at parameters ``u``, ``v`` (n,), each weighing ``weights`` (n,: its area; default
    equal); None for no sample.

    Examples
    --------
    >>> s = value_statistics([0.5, -1.0, 2.0], [0, 0, 1], [0.1, 0.2, 0.3], [0, 0, 1],
    ...                      [[0, 0, 0], [1, 0, 0], [2, 0, 0]])
    >>> s.minimum.value, s.minimum.point, s.maximum.patch, round(s.mean, 6)
    (-1.0, (1.0, 0.0, 0.0), 1, 0.5)
    """
    f = np.asarray(values, dtype=np.float64).ravel()
    patch = np.asarray(patch).ravel()
    u, v = np.asarray(u, dtype=np.float64).ravel(), np.asarray(v, dtype=np.float64).ravel()
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)

    def place(k: int) -> Extreme:
        point = (float(p[k, 0]), float(p[k, 1]), float(p[k, 2]))
        return Extreme(float(f[k]), int(patch[k]), float(u[k]), float(v[k]), point)

    return summarised(f, place, weights)
