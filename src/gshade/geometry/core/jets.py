"""First-order jets on whole arrays, for the shape-function kernels.

A jet ``Jet(f, f_u, f_v)`` is a value with its partial derivatives in u and v.  Arithmetic
on jets applies the chain rule, so a shape function written once as a formula in the surface
derivatives yields its exact parametric gradient too (forward-mode differentiation, exact to
round-off — no finite differences).

The components are arrays of one *backend*: numpy, or Dr.Jit's LLVM arrays, where the whole
formula is traced lazily and compiled into one vectorised, multithreaded kernel (and cached on
disk).  :class:`Backend` (gshade's one protocol of array operations,
:class:`gshade.runtime.backend.ArrayOps`) holds the few elementary functions the formulas
need; everything else is operator arithmetic, which both array types share.  A vector is a
tuple of three jets.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ...runtime.backend import NUMPY, ArrayOps

__all__ = [
    "NUMPY",
    "Backend",
    "Jet",
    "arccos",
    "arctan2",
    "cross",
    "dot",
    "jabs",
    "sqrt",
]


#: the array operations of one backend (numpy or Dr.Jit): gshade's one protocol for them
Backend = ArrayOps


class Jet:
    """A value with its first partial derivatives: (f, f_u, f_v)."""

    __slots__ = ("f", "u", "v")
    __array_ufunc__ = None  # numpy arrays on the left defer to the jet's reflected operators

    def __init__(self, f: Any, u: Any, v: Any) -> None:
        self.f, self.u, self.v = f, u, v

    def __add__(self, b: Any) -> Jet:
        if isinstance(b, Jet):
            return Jet(self.f + b.f, self.u + b.u, self.v + b.v)
        return Jet(self.f + b, self.u, self.v)

    __radd__ = __add__

    def __sub__(self, b: Any) -> Jet:
        if isinstance(b, Jet):
            return Jet(self.f - b.f, self.u - b.u, self.v - b.v)
        return Jet(self.f - b, self.u, self.v)

    def __rsub__(self, a: Any) -> Jet:
        return Jet(a - self.f, -self.u, -self.v)

    def __neg__(self) -> Jet:
        return Jet(-self.f, -self.u, -self.v)

    def __mul__(self, b: Any) -> Jet:
        if isinstance(b, Jet):
            return Jet(self.f * b.f, self.u * b.f + self.f * b.u, self.v * b.f + self.f * b.v)
        return Jet(self.f * b, self.u * b, self.v * b)

    __rmul__ = __mul__

    def __truediv__(self, b: Any) -> Jet:
        if isinstance(b, Jet):
            inv = 1.0 / b.f
            q = self.f * inv
            return Jet(q, (self.u - q * b.u) * inv, (self.v - q * b.v) * inv)
        inv = 1.0 / b
        return Jet(self.f * inv, self.u * inv, self.v * inv)

    def __rtruediv__(self, a: Any) -> Jet:
        inv = 1.0 / self.f
        q = a * inv
        return Jet(q, -q * self.u * inv, -q * self.v * inv)


def sqrt(a: Jet, xp: Backend) -> Jet:
    """sqrt(max(a, 0)); the derivative is taken as 0 where a <= 0."""
    r = xp.sqrt(xp.maximum(a.f, 0.0))
    s = xp.select(r > 0.0, 0.5 / r, 0.0)
    return Jet(r, s * a.u, s * a.v)


def jabs(a: Jet, xp: Backend) -> Jet:
    sign = xp.select(a.f < 0.0, -1.0, 1.0)
    return Jet(a.f * sign, a.u * sign, a.v * sign)


def arccos(a: Jet, xp: Backend) -> Jet:
    """arccos of a clipped to [-1, 1]; the (infinite) derivative at ±1 is taken as 0."""
    c = xp.minimum(xp.maximum(a.f, -1.0), 1.0)
    s = xp.sqrt(1.0 - c * c)
    g = xp.select(s > 0.0, -1.0 / s, 0.0)
    return Jet(xp.acos(c), g * a.u, g * a.v)


def arctan2(y: Jet, x: Jet, xp: Backend) -> Jet:
    """atan2(y, x), with d atan2 = (x dy - y dx) / (x^2 + y^2)."""
    r2 = x.f * x.f + y.f * y.f
    inv = xp.select(r2 > 0.0, 1.0 / r2, 0.0)
    return Jet(xp.atan2(y.f, x.f), (x.f * y.u - y.f * x.u) * inv, (x.f * y.v - y.f * x.v) * inv)


def dot(a: Sequence[Any], b: Sequence[Any]) -> Jet:
    """<a, b> for vectors of jets, or of jets and constants."""
    if not isinstance(a[0], Jet):  # constants go right: Dr.Jit arrays do not defer to jets
        a, b = b, a
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a: Sequence[Any], b: Sequence[Any]) -> tuple[Jet, ...]:
    """a x b for vectors of jets, or of jets and constants."""
    if not isinstance(a[0], Jet):
        return tuple(-c for c in cross(b, a))
    return (
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    )
