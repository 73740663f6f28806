"""Piecewise cubic spline bases given arc by arc in Bézier form: what the β- and γ-spline
bases share (Kiciak §2.3).

A basis over n control points d_0..d_(n-1) has S = n - 3 arcs over breaks
b_0 < b_1 < ... < b_S; arc a depends on d_a..d_(a+3), its Bézier points being
M[a] @ (d_a, .., d_(a+3)).  Stored as ``segment_coefficients``: basis function r of arc a is
sum_k M[a, k, r] B_k(x) in powers of the local x = (t - b_a) / (b_(a+1) - b_a).  The shape
parameters of such bases come one per interior junction, or one for all
(:func:`junction_values`).
"""

from __future__ import annotations

from collections.abc import Callable
from numbers import Real
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...errors import GshadeError
from ..core.patch import show_value

__all__ = [
    "BERNSTEIN_TO_POWER",
    "PiecewiseCubicBasis",
    "arc_bezier_matrices",
    "junction_values",
    "non_negative",
    "positive",
]

#: ``BERNSTEIN_TO_POWER[k, j]``: coefficient of x^j in the cubic Bernstein polynomial B_k.
BERNSTEIN_TO_POWER = np.array(
    [[1.0, -3.0, 3.0, -1.0], [0.0, 3.0, -6.0, 3.0], [0.0, 0.0, 3.0, -3.0], [0.0, 0.0, 0.0, 1.0]]
)
_POWER_TO_BERNSTEIN = np.linalg.inv(BERNSTEIN_TO_POWER)


def positive(v: NDArray) -> NDArray:
    """v > 0 (a shape parameter's test for :func:`junction_values`)."""
    return v > 0


def non_negative(v: NDArray) -> NDArray:
    """v >= 0."""
    return v >= 0


def junction_values(
    value: Any,
    count: int,
    name: str,
    n_points: int,
    what: str,
    ok: Callable[[NDArray[np.float64]], NDArray[np.bool_]],
) -> float | NDArray[np.float64]:
    """A global shape parameter (a float) or ``count`` per-junction values (an array), each
    finite and ``ok`` (``what`` says how: "> 0", ">= 0 (the tension)", ...)."""
    per = (
        f"one per interior junction ({n_points} control points)"
        if count
        else f"but {n_points} control points have no interior junction"
    )
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, (Real, np.number)) and not isinstance(value, bool):
        x = float(value)
        if not (np.isfinite(x) and ok(np.array(x))):
            raise GshadeError(f"{name}: expected a number {what}, got {show_value(value)}")
        return x
    try:
        v = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        v = None
    if v is None or v.ndim != 1:
        raise GshadeError(
            f"{name}: expected a number {what} or a list of {count} such numbers ({per}), "
            f"got {show_value(value)}"
        )
    if v.shape[0] != count or count == 0:
        raise GshadeError(
            f"{name}: expected a number {what} or a list of {count} such numbers ({per}), "
            f"got {v.shape[0]} numbers"
        )
    bad = ~(np.isfinite(v) & ok(v))
    if np.any(bad):
        j = int(np.flatnonzero(bad)[0])
        raise GshadeError(
            f"{name}: expected numbers {what}, got {float(v[j])!r} at junction {j + 1} (of {count})"
        )
    return v


def arc_bezier_matrices(s: NDArray, r: NDArray, w_start: NDArray, w_end: NDArray) -> NDArray:
    """The arcs' Bézier matrices M (S, 4, 4) of a G2 cubic spline built on its control legs
    (Kiciak §2.3: the β- and γ-splines alike).

    Arc k's inner Bézier points lie on its leg d_(k+1) d_(k+2) at the fractions ``s[k]`` and
    ``r[k]``: b_1 = (1 - s) d_(k+1) + s d_(k+2), b_2 = (1 - r) d_(k+1) + r d_(k+2); its end
    points divide the segments between neighbouring arcs' inner points, b_0 = w b'_2 +
    (1 - w) b_1 (b'_2 the previous arc's b_2, w = ``w_start``) and b_3 = w b_2 + (1 - w)
    b''_1 (the next arc's b_1, w = ``w_end``).  ``s`` and ``r`` hold arcs -1..S (S + 2
    values: one beyond each end), ``w_start`` and ``w_end`` the S arcs'.  The Bézier points
    of arc i are ``M[i] @ (d_i, d_(i+1), d_(i+2), d_(i+3))``.

    Examples
    --------
    The uniform cubic B-spline: legs cut in thirds, ends at the midpoints.

    >>> third, half = np.full(3, 1 / 3), np.full(1, 0.5)
    >>> arc_bezier_matrices(third, 2 * third, half, half)[0] * 6
    array([[1., 4., 1., 0.],
           [0., 4., 2., 0.],
           [0., 2., 4., 0.],
           [0., 1., 4., 1.]])
    """
    S = len(w_start)
    i = np.arange(S)
    M = np.zeros((S, 4, 4))
    M[i, 1, 1], M[i, 1, 2] = 1 - s[i + 1], s[i + 1]
    M[i, 2, 1], M[i, 2, 2] = 1 - r[i + 1], r[i + 1]
    M[i, 0, 0] = w_start * (1 - r[i])
    M[i, 0, 1] = w_start * r[i] + (1 - w_start) * (1 - s[i + 1])
    M[i, 0, 2] = (1 - w_start) * s[i + 1]
    M[i, 3, 1] = w_end * (1 - r[i + 1])
    M[i, 3, 2] = w_end * r[i + 1] + (1 - w_end) * (1 - s[i + 2])
    M[i, 3, 3] = (1 - w_end) * s[i + 2]
    return M


class PiecewiseCubicBasis:
    """The evaluation of a piecewise cubic basis from its arcs' Bézier matrices (module
    docstring).  Subclasses set ``n_points``, and call :meth:`_set_arcs`."""

    degree = 3
    n_points: int
    segment_coefficients: NDArray[np.float64]

    def _set_arcs(self, M: NDArray[np.float64], breaks: NDArray[np.float64]) -> None:
        """Arc a's Bézier points are M[a] @ (d_a, .., d_(a+3)), over [breaks[a], breaks[a+1]]."""
        self._set_coefficients(np.einsum("akr,kj->arj", M, BERNSTEIN_TO_POWER), breaks)

    def _set_coefficients(self, coefficients: NDArray, breaks: NDArray[np.float64]) -> None:
        """Basis function r of arc a is sum_j coefficients[a, r, j] x^j."""
        self.segment_coefficients = coefficients
        self._breaks = np.asarray(breaks, dtype=np.float64)
        self._lengths = np.diff(self._breaks)

    def bezier_matrices(self) -> NDArray:
        """M, shape (S, 4, 4): arc a's Bézier points are M[a] @ (d_a, .., d_(a+3))."""
        return np.einsum("arj,jk->akr", self.segment_coefficients, _POWER_TO_BERNSTEIN)

    def bezier_operator(self) -> NDArray:
        """The (3S + 1, n) matrix from control points to the piecewise Bézier net."""
        M = self.bezier_matrices()
        S = M.shape[0]
        out = np.zeros((3 * S + 1, self.n_points))
        for a in range(S):
            out[3 * a : 3 * a + 4, a : a + 4] = M[a]  # the shared junction point: arc a's
        return out

    def bspline_knots(self) -> NDArray:
        """Knot vector of the same curve as a cubic B-spline with triple interior knots."""
        b = self._breaks
        return np.concatenate([[b[0]] * 4, np.repeat(b[1:-1], 3), [b[-1]] * 4])

    def local(self, t: NDArray, order: int) -> tuple[NDArray, NDArray]:
        t = np.asarray(t, dtype=np.float64)
        seg = np.searchsorted(self._breaks, t, side="right") - 1
        seg = np.clip(seg, 0, self.n_points - 4).astype(np.intp)
        h = self._lengths[seg]
        x = (t - self._breaks[seg]) / h
        out = np.zeros((order + 1, t.size, 4))
        c = self.segment_coefficients[seg]  # (N, 4 basis functions, 4 powers of x)
        scale = np.ones_like(h)
        for k in range(min(order, 3) + 1):
            acc = np.zeros((t.size, 4))
            for power in range(3, -1, -1):  # Horner; d^k/dt^k = h^-k d^k/dx^k
                acc = acc * x[:, None] + c[:, :, power]
            out[k] = acc * scale[:, None]
            c = np.concatenate([c[:, :, 1:] * np.arange(1, 4), np.zeros((*c.shape[:2], 1))], -1)
            scale = scale / h
        return seg, out

    def dense(self, t: NDArray, order: int) -> NDArray:
        first, ders = self.local(t, order)
        out = np.zeros((order + 1, first.size, self.n_points))
        rows = np.arange(first.size)[:, None]
        out[:, rows, first[:, None] + np.arange(4)] = ders
        return out
