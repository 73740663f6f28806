"""One protocol of array operations, for formulas written once for numpy and Dr.Jit arrays.

gshade writes several formulas once and runs them on two array libraries: the shape
functions' jets (:mod:`gshade.geometry.core.jets`: numpy, or Dr.Jit's LLVM arrays traced into one
kernel), the stripe filter (:func:`gshade.display.colour.coverage_formula`: numpy, and Dr.Jit
in the renderer's integrator), the atlas addressing and lookups
(:mod:`gshade.rendering.atlas`) and the Newton step onto the exact surface
(:mod:`gshade.rendering.newton`).  Arithmetic operators are common to both libraries;
:class:`ArrayOps` holds everything else they need.

Minimum and maximum are compare-and-select (``select(a < b, a, b)``, so a NaN operand gives
the second one) unless an instance says otherwise: Dr.Jit lowers ``dr.minimum`` to LLVM's
``fminimum``, which some LLVM versions cannot compile for x86 in every kernel (the process
aborts: "Cannot select ... fminimum"; see :mod:`gshade.runtime.llvm`).

3-vectors are whatever the library's formulas hold: rows of an (N, 3) array for numpy, a
Dr.Jit 3-vector (``mi.Vector3f``, ``Array3f64``) for Dr.Jit.  ``dot`` and ``cross`` of the
Dr.Jit instances are Dr.Jit's own (fused multiply-adds) unless ``fused=False``: then they are
written out, sums of products from left to right, as numpy's are.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from typing import TYPE_CHECKING, Any

import numpy as np

from .llvm import import_drjit

if TYPE_CHECKING:
    from numpy.typing import ArrayLike, NDArray

__all__ = ["NUMPY", "NUMPY_NAN", "ArrayOps", "cross3", "dot3", "drjit_ops"]

#: an elementwise operation of one array library
Op = Callable[..., Any]


def dot3(a: Any, b: Any) -> Any:
    """<a, b> = a0 b0 + a1 b1 + a2 b2, summed from left to right (no fused multiply-add)."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross3(a: Any, b: Any) -> Any:
    """a x b, each coordinate a difference of two products (no fused multiply-add)."""
    return type(a)(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def _row_dot(a: NDArray, b: NDArray) -> NDArray:
    """<a, b> of each row of two (N, 3) arrays."""
    return np.einsum("ij,ij->i", a, b)


def _row_scale(t: NDArray, v: NDArray) -> NDArray:
    """Each row of the (N, 3) array v times the matching number of t (N,)."""
    return t[:, None] * v


def _take(table: ArrayLike, index: ArrayLike) -> NDArray:
    """numpy's table[index] at float indices."""
    return np.asarray(table)[np.asarray(index).astype(np.int64)]


def _drjit_gather(table: Any, index: Any) -> Any:
    """Dr.Jit's gather of ``table`` (an array of the variant) at float indices."""
    dr = import_drjit()

    return dr.gather(type(table), table, dr.uint32_array_t(type(index))(index))


def _scalar_gather(table: Any, index: float) -> Any:
    """A scalar variant's gather: the table (a sequence) at one whole float index."""
    return table[int(index)]


def _times(t: Any, v: Any) -> Any:
    return t * v


class ArrayOps:
    """The elementwise operations of one array library (numpy or Dr.Jit).

    The first seven are positional (name, sqrt, acos, atan2, abs, isfinite, select); the rest
    default to the library's own when ``name`` is "numpy" or "drjit".  ``select(mask, a, b)``
    is a where ``mask`` holds and b elsewhere; ``scale(t, v)`` multiplies the 3-vectors v by
    the numbers t; ``gather(table, index)`` is the table's entries at the (whole, float)
    indices.
    """

    __slots__ = (
        "abs",
        "acos",
        "atan2",
        "cross",
        "dot",
        "floor",
        "gather",
        "isfinite",
        "logical_not",
        "maximum",
        "minimum",
        "name",
        "scale",
        "select",
        "sqrt",
    )

    def __init__(
        self,
        name: str,
        sqrt: Op,
        acos: Op,
        atan2: Op,
        abs: Op,
        isfinite: Op,
        select: Op,
        *,
        floor: Op | None = None,
        logical_not: Op | None = None,
        minimum: Op | None = None,
        maximum: Op | None = None,
        dot: Op | None = None,
        cross: Op | None = None,
        scale: Op | None = None,
        gather: Op | None = None,
    ) -> None:
        missing = None in (floor, logical_not, dot, cross, scale, gather)
        library = _library_defaults(name) if missing else {}
        self.name = name
        self.sqrt, self.acos, self.atan2, self.abs = sqrt, acos, atan2, abs
        self.isfinite, self.select = isfinite, select
        self.floor: Op = library["floor"] if floor is None else floor
        self.logical_not: Op = library["logical_not"] if logical_not is None else logical_not
        self.dot: Op = library["dot"] if dot is None else dot
        self.cross: Op = library["cross"] if cross is None else cross
        self.scale: Op = library["scale"] if scale is None else scale
        self.gather: Op = library["gather"] if gather is None else gather
        self.minimum: Op = (lambda a, b: select(a < b, a, b)) if minimum is None else minimum
        self.maximum: Op = (lambda a, b: select(a > b, a, b)) if maximum is None else maximum

    def clip(self, x: Any, lo: Any, hi: Any) -> Any:
        """min(max(x, lo), hi) with this library's minimum and maximum."""
        return self.minimum(self.maximum(x, lo), hi)

    def __repr__(self) -> str:
        return f"ArrayOps({self.name!r})"


def _library_defaults(name: str) -> dict[str, Op]:
    """The operations beyond the first seven, for the library ``name``."""
    if name == "numpy":
        return {
            "floor": np.floor,
            "logical_not": np.logical_not,
            "dot": _row_dot,
            "cross": np.cross,
            "scale": _row_scale,
            "gather": _take,
        }
    if name == "drjit":
        dr = import_drjit()

        return {
            "floor": dr.floor,
            "logical_not": lambda m: ~m,
            "dot": dr.dot,
            "cross": dr.cross,
            "scale": _times,
            "gather": _drjit_gather,
        }
    raise ValueError(f"ArrayOps: no default operations for {name!r}; give them all")


#: numpy arrays, with compare-and-select minimum and maximum (as Dr.Jit's)
NUMPY = ArrayOps("numpy", np.sqrt, np.arccos, np.arctan2, np.abs, np.isfinite, np.where)

#: numpy arrays, with minimum and maximum that propagate NaN (``np.minimum``,
#: ``np.maximum``): the public numpy stripe filter keeps an undefined value visible as NaN
NUMPY_NAN = ArrayOps(
    "numpy",
    np.sqrt,
    np.arccos,
    np.arctan2,
    np.abs,
    np.isfinite,
    np.where,
    minimum=np.minimum,
    maximum=np.maximum,
)


@cache
def drjit_ops(scalar: bool = False, fused: bool = True) -> ArrayOps:
    """The operations for Dr.Jit arrays; ``scalar`` for Mitsuba's scalar variants (Python
    numbers and booleans), ``fused=False`` for dot and cross products written out
    (:func:`dot3`, :func:`cross3`) instead of Dr.Jit's fused multiply-adds."""
    dr = import_drjit()

    return ArrayOps(
        "drjit",
        dr.sqrt,
        dr.acos,
        dr.atan2,
        dr.abs,
        dr.isfinite,
        dr.select,
        logical_not=(lambda m: not m) if scalar else (lambda m: ~m),
        dot=dr.dot if fused else dot3,
        cross=dr.cross if fused else cross3,
        gather=_scalar_gather if scalar else _drjit_gather,
    )
