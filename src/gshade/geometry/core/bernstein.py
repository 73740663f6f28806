"""Bernstein polynomials: basis values with derivatives, de Casteljau, degree elevation, the
derivative map on coefficients and the Gram matrix.

The Bernstein polynomials of degree n are B_i^n(t) = C(n, i) t^i (1 - t)^(n - i), i = 0..n
(Kiciak, Appendix A.1).  Their derivatives follow from
d/dt B_i^n = n (B_{i-1}^{n-1} - B_i^{n-1}).
"""

from __future__ import annotations

from math import comb

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "bernstein_basis",
    "de_casteljau",
    "derivative_matrix",
    "elevate_degree",
    "gram_matrix",
]


def bernstein_basis(degree: int, t: ArrayLike, order: int = 0) -> NDArray[np.float64]:
    """Values and derivatives of the Bernstein basis of the given degree.

    Parameters
    ----------
    degree : int
        Polynomial degree n >= 0.
    t : array_like
        Parameters (any shape).
    order : int
        Highest derivative order returned.

    Returns
    -------
    ndarray, shape (order + 1, *t.shape, degree + 1)
        Entry ``[k, ..., i]`` is the k-th derivative of B_i^n at t.
    """
    t = np.asarray(t, dtype=np.float64)
    n = degree
    flat = t.ravel()
    s = 1.0 - flat
    # Lower-degree bases B^d for d = n - order .. n by the triangular recurrence
    # B_i^d = s B_i^{d-1} + t B_{i-1}^{d-1}, index-major (d + 1, N) so every step works on
    # contiguous rows; the k-th derivative of B^n is
    # n!/(n-k)! * sum_j (-1)^(k-j) C(k, j) B_{i-j}^{n-k}.
    lower = {0: np.ones((1, flat.size))}
    basis = lower[0]
    for d in range(1, n + 1):
        nxt = np.empty((d + 1, flat.size))
        np.multiply(basis, s, out=nxt[:d])
        nxt[d] = 0.0
        nxt[1:] += basis * flat
        basis = lower[d] = nxt
    out = np.zeros((order + 1, n + 1, flat.size))
    for k in range(min(order, n) + 1):
        low = lower[n - k]
        factor = 1.0
        for j in range(k):
            factor *= n - j
        coeff = 1.0
        for j in range(k + 1):
            sign = -1.0 if (k - j) % 2 else 1.0  # (-1)^(k-j) C(k, j)
            out[k, j : j + n - k + 1] += (factor * sign * coeff) * low
            coeff = coeff * (k - j) / (j + 1)
    return np.moveaxis(out, 1, -1).reshape((order + 1, *t.shape, n + 1))


def de_casteljau(points: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
    """Point of a Bézier curve by de Casteljau's algorithm (repeated linear interpolation).

    Parameters
    ----------
    points : array_like, shape (n + 1, dim)
        Control points.
    t : array_like
        Parameters (any shape).

    Returns
    -------
    ndarray, shape (*t.shape, dim)
    """
    pts = np.asarray(points, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)[..., None, None]
    work = np.broadcast_to(pts, (*t.shape[:-2], *pts.shape)).copy()
    for r in range(1, pts.shape[0]):
        work = (1.0 - t) * work[..., :-1, :] + t * work[..., 1:, :]
        del r
    return work[..., 0, :]


def elevate_degree(coeffs: ArrayLike, times: int = 1, axis: int = 0) -> NDArray[np.float64]:
    """Raise the degree of Bernstein coefficients without changing the polynomial.

    c'_i = (i / (n + 1)) c_{i-1} + (1 - i / (n + 1)) c_i, applied ``times`` times along ``axis``.
    """
    c = np.moveaxis(np.asarray(coeffs, dtype=np.float64), axis, 0)
    for _ in range(times):
        n = c.shape[0] - 1
        a = (np.arange(n + 2) / (n + 1)).reshape((-1,) + (1,) * (c.ndim - 1))
        nxt = np.zeros((n + 2, *c.shape[1:]))
        nxt[1:] += a[1:] * c
        nxt[:-1] += (1.0 - a[:-1]) * c
        c = nxt
    return np.moveaxis(c, 0, axis)


def gram_matrix(m: int) -> NDArray[np.float64]:
    """The Gram matrix of the Bernstein basis of degree m on [0, 1].

    G[i, j] = int_0^1 B_i^m(t) B_j^m(t) dt = C(m, i) C(m, j) / ((2m + 1) C(2m, i + j)),
    since B_i^m B_j^m = C(m,i) C(m,j) / C(2m, i+j) B_(i+j)^(2m) and every B^(2m)
    integrates to 1 / (2m + 1).

    Returns
    -------
    ndarray, shape (m + 1, m + 1)
    """
    return np.array(
        [
            [comb(m, i) * comb(m, j) / ((2 * m + 1) * comb(2 * m, i + j)) for j in range(m + 1)]
            for i in range(m + 1)
        ]
    )


def derivative_matrix(m: int, order: int = 1) -> NDArray[np.float64]:
    """The map from Bernstein coefficients of a degree-m polynomial to those of its
    ``order``-th derivative (degree m - order): d/dt sum c_i B_i^m = m sum (c_(i+1) - c_i)
    B_i^(m-1), repeated.

    Returns
    -------
    ndarray, shape (m - order + 1, m + 1)
    """
    D = np.eye(m + 1)
    for k in range(order):
        d = m - k
        step = d * (np.eye(d, d + 1, 1) - np.eye(d, d + 1))
        D = step @ D
    return D
