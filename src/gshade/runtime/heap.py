"""The C heap of a gshade process: freed arrays kept for the next ones.

glibc's ``malloc`` gives every block above its mmap threshold (128 KiB at first, raised to
the largest block freed, at most 32 MiB) pages of its own, and hands them back to the system
when the block is freed; the next array of that size gets fresh pages, which the kernel
zero-fills on first touch.  A render allocates and frees arrays of tens of MiB (a
derivative array of every covered pixel, a texture atlas) many times over, so a fresh
process spends a fifth of its time in page faults (system time; the stage runs of
``benchmarks/bench_peer.py``).  :func:`keep_freed_memory` makes ``malloc`` keep them: every
block from the heap (an mmap threshold of 1 GiB), freed memory kept up to 256 MiB at the
heap's top, the heap grown 64 MiB at a time.  The process's peak resident memory grows a
little (RESULTS.md gives it); the memory is the system's again when the process ends.

Only the command line and its worker processes call it, once at their start: importing
gshade, or calling :func:`gshade.render` from a program, leaves ``malloc`` as the program
set it.  Elsewhere than on glibc it does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import sys

__all__ = ["HEAP_SETTINGS", "keep_freed_memory"]

#: glibc's mallopt parameters (malloc.h) and the values set: M_MMAP_THRESHOLD, M_TRIM_THRESHOLD,
#: M_TOP_PAD, in bytes.
HEAP_SETTINGS = ((-3, 1 << 30), (-1, 256 << 20), (-2, 64 << 20))


def keep_freed_memory() -> bool:
    """Have glibc's ``malloc`` keep freed blocks for reuse (see the module's text); whether
    every setting took (False off glibc).

    Examples
    --------
    The settings, by mallopt parameter (a call changes the process: the command line's):

    >>> [value >> 20 for _, value in HEAP_SETTINGS]  # MiB
    [1024, 256, 64]
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):  # not glibc (musl has no mallopt)
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return all(mallopt(parameter, value) == 1 for parameter, value in HEAP_SETTINGS)
