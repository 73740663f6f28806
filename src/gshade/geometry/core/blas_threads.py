"""One BLAS thread for gshade's own matrix products, whatever the caller's thread pool.

The evaluation's contractions (a basis matrix times a control net, per derivative) are
small matrix products: one BLAS thread does each in well under a millisecond.  With
OpenBLAS's default pool (one thread per core) they are split across all cores, which gains
nothing here and costs a great deal on a busy machine: every product waits for its slowest
thread, and a thread that shares a core with another process waits for a time slice
(benchmarks/bench_geometry.py measures it beside a busy process).

:func:`single_threaded_blas` wraps the public evaluation entry points: while one of them
runs, the BLAS libraries that threadpoolctl found in the process on first use (numpy's
among them, loaded with numpy; gshade's products run in it) are limited to one thread, and
their previous settings are restored when the outermost call returns (or raises).  Nothing
is changed at import time and no environment variable is set: the caller's pool is the
caller's before and after every call.

Calls nest and may run in several threads at once: the first call to enter saves and limits
the pools, the last to leave restores them (a counter under a lock), so a limit is never
left behind by interleaved calls.  While a gshade evaluation runs, the pool is one thread
for the whole process (BLAS thread counts are process-wide), so another thread's large
product at that moment runs single-threaded too; it is restored when gshade's call ends.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable
from types import TracebackType
from typing import Any, ParamSpec, TypeVar

__all__ = ["BlasSingleThread", "blas_single_thread", "single_threaded_blas"]

P = ParamSpec("P")
R = TypeVar("R")


class BlasSingleThread:
    """A reentrant, thread-aware context manager: one BLAS thread while inside.

    The BLAS libraries are looked up once, on first use (threadpoolctl's
    ``ThreadpoolController``, about a millisecond); after that entering and leaving costs a
    few microseconds (reading each library's thread count, and setting it only if it is not
    already 1).
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._depth = 0
        self._libs: list[Any] | None = None
        self._saved: list[tuple[Any, int]] = []

    def libraries(self) -> list[Any]:
        """threadpoolctl's controllers of the BLAS libraries loaded (found on first use)."""
        if self._libs is None:
            from threadpoolctl import ThreadpoolController

            self._libs = list(ThreadpoolController().select(user_api="blas").lib_controllers)
        return self._libs

    def __enter__(self) -> BlasSingleThread:
        with self._lock:
            if self._depth == 0:
                saved = []
                try:
                    for lib in self.libraries():
                        n = lib.get_num_threads()
                        if n is not None and n != 1:
                            lib.set_num_threads(1)
                            saved.append((lib, n))
                except BaseException:
                    for lib, n in saved:
                        lib.set_num_threads(n)
                    raise
                self._saved = saved
            self._depth += 1
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        with self._lock:
            self._depth -= 1
            if self._depth == 0:
                saved, self._saved = self._saved, []
                for lib, n in saved:
                    lib.set_num_threads(n)


#: The process's limiter, shared by all of gshade's evaluation entry points.
blas_single_thread = BlasSingleThread()


def single_threaded_blas(fn: Callable[P, R]) -> Callable[P, R]:
    """Decorator: run ``fn`` with one BLAS thread (see the module docstring)."""

    @functools.wraps(fn)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        with blas_single_thread:
            return fn(*args, **kwargs)

    return wrapper
