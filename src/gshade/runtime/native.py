"""Native libraries' own diagnostics, captured instead of printed.

Some native libraries print to the process's standard error (or output) themselves before
they report a failure to Python: libOpenEXR prints a line per bad chunk of a corrupt file on
stderr and a warning on stdout.  gshade promises one line per error (and stdout for results
only, e.g. JSON), so such calls run inside :func:`captured_output`, and what the library
said can be added to gshade's own message.
"""

from __future__ import annotations

import io
import os
import sys
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager, redirect_stderr, redirect_stdout
from dataclasses import dataclass

__all__ = ["NativeOutput", "captured_output"]

#: Bytes of captured output kept (the rest is dropped).
MAX_CAPTURED = 64 * 1024

_LOCK = threading.RLock()


@dataclass
class NativeOutput:
    """What native code wrote inside :func:`captured_output` (filled in when the block
    ends)."""

    text: str = ""

    def line(self, marker: str = "", limit: int = 300) -> str:
        """The first non-empty line containing ``marker`` (else the first non-empty line),
        cut to ``limit`` characters; "" if nothing was written."""
        lines = [s.strip() for s in self.text.splitlines() if s.strip()]
        chosen = next((s for s in lines if marker in s), lines[0] if lines else "")
        return chosen if len(chosen) <= limit else chosen[: limit - 1] + "…"


@contextmanager
def captured_output(fds: tuple[int, ...] = (1, 2)) -> Iterator[NativeOutput]:
    """Redirect the file descriptors ``fds`` (standard output and error) to a temporary
    file, and Python's ``sys.stdout`` and ``sys.stderr`` (where bindings print, e.g. with
    pybind11's ``print``) to a buffer, for the block; yield a :class:`NativeOutput` that
    holds what was written (at most :data:`MAX_CAPTURED` bytes of each) once the block
    ends, normally or by an exception.

    Thread safety: file descriptors and ``sys.stdout`` / ``sys.stderr`` belong to the
    whole process, so while a block runs, whatever any thread writes to them is captured,
    not shown.  Blocks are serialised by a lock (re-entrant: a block may nest in the same
    thread), but other threads' writes are not stopped: keep the blocks around the native
    calls that may fail, not around long work.  A descriptor that is not open is left
    alone.
    """
    output = NativeOutput()
    with _LOCK:
        try:
            sink = tempfile.TemporaryFile()
        except OSError:  # nowhere to capture to: run the block as it is
            yield output
            return
        saved: dict[int, int] = {}
        python = io.StringIO()
        try:
            _flush()
            for fd in fds:
                try:
                    saved[fd] = os.dup(fd)
                except OSError:  # not open: nothing to redirect
                    continue
                os.dup2(sink.fileno(), fd)
            with redirect_stdout(python), redirect_stderr(python):
                yield output
        finally:
            _flush()
            for fd, copy in saved.items():
                os.dup2(copy, fd)
                os.close(copy)
            with sink:
                sink.seek(0)
                output.text = sink.read(MAX_CAPTURED).decode("utf-8", "replace")
            output.text += python.getvalue()[:MAX_CAPTURED]


def _flush() -> None:
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (AttributeError, OSError, ValueError):  # None, closed or broken
            pass
