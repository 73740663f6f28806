"""Bézier curves and tensor-product Bézier patches, polynomial or rational (Kiciak, A.1–A.2).

p(u, v) = sum_i sum_j B_i^m(s) B_j^n(t) w_ij P_ij / sum_i sum_j B_i^m(s) B_j^n(t) w_ij,
with s, t the parameters mapped affinely from the domain onto [0, 1].
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ...errors import GshadeError
from ..core.bernstein import elevate_degree
from ..core.patch import (
    BasisCurve,
    BernsteinBasis,
    TensorProductPatch,
    validate_points,
    validate_weights,
)

if TYPE_CHECKING:
    from ..core.patch import Domain

__all__ = ["BezierCurve", "BezierPatch"]


def _validate_interval(interval: Iterable[float], name: str) -> tuple[float, float]:
    try:
        a, b = (float(x) for x in interval)
    except (TypeError, ValueError):
        raise GshadeError(f"{name}: expected a pair (start, end), got {interval!r}") from None
    if not (np.isfinite(a) and np.isfinite(b) and a < b):
        raise GshadeError(f"{name}: expected finite start < end, got ({a!r}, {b!r})")
    return a, b


class BezierCurve(BasisCurve):
    """Bézier curve of degree n = len(points) - 1, optionally rational.

    Parameters
    ----------
    points : array_like, shape (n + 1, dim)
        Control points, dim = 2 or 3.
    weights : array_like, shape (n + 1,), optional
        Positive weights; the curve is rational if given.
    domain : (float, float)
        Parameter interval, default (0, 1).

    Examples
    --------
    A quarter of the unit circle: a rational quadratic with weights 1, cos 45°, 1.

    >>> import numpy as np
    >>> from gshade.geometry import BezierCurve
    >>> quarter = BezierCurve([[1, 0], [1, 1], [0, 1]], weights=[1, np.sqrt(0.5), 1])
    >>> np.round(quarter([0.0, 0.5, 1.0]), 12).tolist()
    [[1.0, 0.0], [0.707106781187, 0.707106781187], [0.0, 1.0]]
    >>> np.round(np.linalg.norm(quarter(np.linspace(0.0, 1.0, 5)), axis=-1), 12).tolist()
    [1.0, 1.0, 1.0, 1.0, 1.0]
    """

    def __init__(
        self,
        points: ArrayLike,
        weights: ArrayLike | None = None,
        domain: tuple[float, float] = (0.0, 1.0),
    ) -> None:
        P = validate_points(points, 1, "Bézier curve")
        w = validate_weights(weights, P.shape[:1], "Bézier curve")
        self.domain = _validate_interval(domain, "domain")
        super().__init__(BernsteinBasis(P.shape[0] - 1, self.domain), P, w)

    @property
    def degree(self) -> int:
        return self.points.shape[0] - 1

    def elevated(self, degree: int) -> BezierCurve:
        """The same curve with its degree raised to ``degree`` (>= the current degree)."""
        if degree < self.degree:
            raise GshadeError(f"degree: expected >= {self.degree}, got {degree}")
        h = elevate_degree(self._net, degree - self.degree)
        if self.weights is None:
            return BezierCurve(h, domain=self.domain)
        return BezierCurve(h[:, :-1] / h[:, -1:], h[:, -1], domain=self.domain)


class BezierPatch(TensorProductPatch):
    """Tensor-product Bézier patch of degree (m, n), optionally rational.

    Parameters
    ----------
    points : array_like, shape (m + 1, n + 1, 3)
        Control net; ``points[i, j]`` multiplies B_i^m(u) B_j^n(v).
    weights : array_like, shape (m + 1, n + 1), optional
        Positive weights; the patch is rational if given.
    domain : ((u0, u1), (v0, v1))
        Parameter rectangle, default the unit square.

    Examples
    --------
    The bilinear patch z = uv: its point and first derivatives at (0.5, 0.5).

    >>> from gshade.geometry import BezierPatch
    >>> saddle = BezierPatch([[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 1]]])
    >>> saddle(0.5, 0.5).tolist()
    [0.5, 0.5, 0.25]
    >>> d = saddle.derivatives(0.5, 0.5, order=1)  # d[i, j]: d^(i+j)p / du^i dv^j
    >>> d[1, 0].tolist(), d[0, 1].tolist()
    ([1.0, 0.0, 0.5], [0.0, 1.0, 0.5])
    >>> saddle.elevated((3, 2)).points.shape  # the same surface, a finer net
    (4, 3, 3)
    """

    def __init__(
        self,
        points: ArrayLike,
        weights: ArrayLike | None = None,
        domain: Domain = ((0.0, 1.0), (0.0, 1.0)),
    ) -> None:
        P = validate_points(points, 2, "Bézier patch")
        w = validate_weights(weights, P.shape[:2], "Bézier patch")
        try:
            du, dv = domain
        except (TypeError, ValueError):
            raise GshadeError(f"domain: expected ((u0, u1), (v0, v1)), got {domain!r}") from None
        self.domain = (_validate_interval(du, "domain u"), _validate_interval(dv, "domain v"))
        m, n = P.shape[0] - 1, P.shape[1] - 1
        super().__init__(BernsteinBasis(m, self.domain[0]), BernsteinBasis(n, self.domain[1]), P, w)

    @property
    def degree(self) -> tuple[int, int]:
        return self.points.shape[0] - 1, self.points.shape[1] - 1

    def elevated(self, degree: tuple[int, int]) -> BezierPatch:
        """The same patch with its degrees raised to ``degree`` (each >= the current one)."""
        m, n = self.degree
        if degree[0] < m or degree[1] < n:
            raise GshadeError(f"degree: expected each >= {(m, n)}, got {tuple(degree)}")
        h = elevate_degree(self._net, degree[0] - m, axis=0)
        h = elevate_degree(h, degree[1] - n, axis=1)
        if self.weights is None:
            return BezierPatch(h, domain=self.domain)
        return BezierPatch(h[..., :-1] / h[..., -1:], h[..., -1], domain=self.domain)

    def boundary(self, side: str) -> BezierCurve:
        """The boundary curve on side 'u0', 'u1', 'v0' or 'v1' (e.g. 'v0' is p(u, v0))."""
        sel: dict[str, tuple[int | slice, int | slice]] = {
            "u0": (0, slice(None)),
            "u1": (-1, slice(None)),
            "v0": (slice(None), 0),
            "v1": (slice(None), -1),
        }
        if side not in sel:
            raise GshadeError(f"side: expected one of u0, u1, v0, v1, got {side!r}")
        idx = sel[side]
        dom = self.domain[1] if side[0] == "u" else self.domain[0]
        w = None if self.weights is None else self.weights[idx]
        return BezierCurve(self.points[idx], w, domain=dom)
