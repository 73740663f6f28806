"""numpy arrays handed to Dr.Jit at an address its kernels can be reused for.

Dr.Jit maps a contiguous numpy array into a kernel without copying it, and the kernel it
compiles says whether each input is aligned to a whole vector of lanes (a 128-byte
boundary) or not.  numpy's small arrays lie wherever ``malloc`` put them, so one formula
run twice on arrays of the same size is two different kernels, a compilation (tens of
milliseconds) each time.  :func:`drjit_array` copies the values to a 128-byte boundary first:
every run of a formula is then the same kernel, compiled once.

Examples
--------
>>> import numpy as np
>>> values = aligned(np.arange(5.0))
>>> values.ctypes.data % ALIGNMENT, values.tolist()
(0, [0.0, 1.0, 2.0, 3.0, 4.0])
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["ALIGNMENT", "aligned", "drjit_array"]

#: The boundary, in bytes, of the arrays handed to Dr.Jit: 16 float64 lanes (AVX-512).
ALIGNMENT = 128


def aligned(values: ArrayLike, dtype: Any = None) -> NDArray:
    """A contiguous 1-D copy of ``values`` (as ``dtype``) that starts on an
    :data:`ALIGNMENT`-byte boundary."""
    source = np.asarray(values, dtype=dtype)
    if source.ndim != 1:
        source = source.reshape(-1)
    raw = np.empty(source.nbytes + ALIGNMENT, dtype=np.uint8)
    start = -raw.ctypes.data % ALIGNMENT
    out = raw[start : start + source.nbytes].view(source.dtype)
    out[...] = source
    return out


def drjit_array(kind: Any, values: ArrayLike, dtype: Any = None) -> Any:
    """The Dr.Jit array of type ``kind`` (``drjit.llvm.Float64``, ``mi.Float`` ...) holding
    ``values``, from an :func:`aligned` copy."""
    return kind(aligned(values, dtype))
