"""Derivatives of rational curves and patches from their homogeneous derivatives.

With p = P / W (P the weighted points, W the weight function), Leibniz's rule applied to
P = W p gives, for every multi-index (a, b),

    p^(a,b) = ( P^(a,b) - sum_{(k,l) != (0,0), k<=a, l<=b} C(a,k) C(b,l) W^(k,l) p^(a-k,b-l) ) / W

(the quotient rule for orders 1 and 2, carried to any order).
"""

from __future__ import annotations

from math import comb

import numpy as np
from numpy.typing import NDArray

__all__ = ["project_curve_derivatives", "project_patch_derivatives"]


def project_patch_derivatives(p: NDArray, w: NDArray, order: int) -> NDArray:
    """Turn homogeneous patch derivatives into Cartesian ones, in place.

    Parameters
    ----------
    p : ndarray, shape (order + 1, order + 1, dim, ...)
        Derivatives of the weighted points P = w p; overwritten with those of p.
    w : ndarray, shape (order + 1, order + 1, ...)
        Derivatives of the weight function.

    Returns
    -------
    ndarray
        ``p``, now holding the Cartesian derivatives.
    """
    inv_w = 1.0 / w[0, 0]
    tmp = np.empty_like(p[0, 0])
    for total in range(order + 1):
        for a in range(total + 1):
            b = total - a
            acc = p[a, b]
            for k in range(a + 1):
                for l in range(b + 1):
                    if k == 0 and l == 0:
                        continue
                    np.multiply(w[k, l], p[a - k, b - l], out=tmp)
                    c = comb(a, k) * comb(b, l)
                    if c != 1:
                        tmp *= c
                    acc -= tmp
            acc *= inv_w
    return p


def project_curve_derivatives(h: NDArray, order: int) -> NDArray:
    """Curve version of :func:`project_patch_derivatives`: ``h`` has shape (order+1, dim+1, ...)."""
    dim = h.shape[1] - 1
    w = h[:, dim]
    p = h[:, :dim]
    inv_w = 1.0 / w[0]
    for a in range(order + 1):
        for k in range(1, a + 1):
            p[a] -= comb(a, k) * w[k] * p[a - k]
        p[a] *= inv_w
    return p
