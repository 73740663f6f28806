"""First-order jets for compiled shape-function kernels.

A jet is a tuple (f, f_u, f_v): a value with its partial derivatives in u and v.  The
functions below apply the chain rule, so a shape function written once as a formula in the
surface derivatives yields its exact parametric gradient too (forward-mode
differentiation, exact to round-off — no finite differences).  They are compiled with
numba and inlined into the per-point kernels of :mod:`gshade.shape.kernels`.

A vector is a tuple of three jets.  ``vec(d, i, j, k)`` reads the jet of the derivative
d^(i+j)p / du^i dv^j at point k: its own value and the next derivatives in u and v.
"""

from __future__ import annotations

import math

from numba import njit

__all__ = [
    "add",
    "arccos",
    "arctan2",
    "const",
    "cross",
    "cross_const",
    "div",
    "dot",
    "dot_const",
    "jabs",
    "mul",
    "scale",
    "shift",
    "sqrt",
    "sub",
    "vec",
    "vsub_const",
]


@njit(cache=True)
def const(x):
    return (x, 0.0, 0.0)


@njit(cache=True)
def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@njit(cache=True)
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@njit(cache=True)
def mul(a, b):
    return (a[0] * b[0], a[1] * b[0] + a[0] * b[1], a[2] * b[0] + a[0] * b[2])


@njit(cache=True)
def scale(a, s):
    """s a for a number s."""
    return (a[0] * s, a[1] * s, a[2] * s)


@njit(cache=True)
def shift(a, s):
    """a + s for a number s."""
    return (a[0] + s, a[1], a[2])


@njit(cache=True)
def div(a, b):
    inv = 1.0 / b[0]
    q = a[0] * inv
    return (q, (a[1] - q * b[1]) * inv, (a[2] - q * b[2]) * inv)


@njit(cache=True)
def sqrt(a):
    """sqrt(max(a, 0)); the derivative is taken as 0 where a <= 0."""
    r = math.sqrt(max(a[0], 0.0))
    s = 0.5 / r if r > 0.0 else 0.0
    return (r, s * a[1], s * a[2])


@njit(cache=True)
def jabs(a):
    if a[0] < 0.0:
        return (-a[0], -a[1], -a[2])
    return a


@njit(cache=True)
def arccos(a):
    """arccos of a clipped to [-1, 1]; the (infinite) derivative at ±1 is taken as 0."""
    c = min(1.0, max(-1.0, a[0]))
    s = math.sqrt(1.0 - c * c)
    g = -1.0 / s if s > 0.0 else 0.0
    return (math.acos(c), g * a[1], g * a[2])


@njit(cache=True)
def arctan2(y, x):
    """atan2(y, x), with d atan2 = (x dy - y dx) / (x^2 + y^2)."""
    r2 = x[0] * x[0] + y[0] * y[0]
    inv = 1.0 / r2 if r2 > 0.0 else 0.0
    return (
        math.atan2(y[0], x[0]),
        (x[0] * y[1] - y[0] * x[1]) * inv,
        (x[0] * y[2] - y[0] * x[2]) * inv,
    )


@njit(cache=True)
def dot(a, b):
    return add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]))


@njit(cache=True)
def dot_const(a, c):
    """<a, c> for a constant 3-vector c (an array)."""
    return add(add(scale(a[0], c[0]), scale(a[1], c[1])), scale(a[2], c[2]))


@njit(cache=True)
def cross(a, b):
    return (
        sub(mul(a[1], b[2]), mul(a[2], b[1])),
        sub(mul(a[2], b[0]), mul(a[0], b[2])),
        sub(mul(a[0], b[1]), mul(a[1], b[0])),
    )


@njit(cache=True)
def cross_const(a, c):
    """a x c for a constant 3-vector c."""
    return (
        sub(scale(a[1], c[2]), scale(a[2], c[1])),
        sub(scale(a[2], c[0]), scale(a[0], c[2])),
        sub(scale(a[0], c[1]), scale(a[1], c[0])),
    )


@njit(cache=True)
def vsub_const(a, c):
    """a - c for a constant 3-vector c."""
    return (shift(a[0], -c[0]), shift(a[1], -c[1]), shift(a[2], -c[2]))


@njit(cache=True)
def vec(d, i, j, k):
    """The jet of d^(i+j)p / du^i dv^j at point k of a derivatives array (.., .., n, 3)."""
    return (
        (d[i, j, k, 0], d[i + 1, j, k, 0], d[i, j + 1, k, 0]),
        (d[i, j, k, 1], d[i + 1, j, k, 1], d[i, j + 1, k, 1]),
        (d[i, j, k, 2], d[i + 1, j, k, 2], d[i, j + 1, k, 2]),
    )
