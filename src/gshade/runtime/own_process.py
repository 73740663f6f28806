"""What gshade's own processes set at their start, and a program that imports gshade keeps.

The command line and its batch workers are processes gshade owns: there

- glibc's ``malloc`` keeps freed arrays for the next ones
  (:func:`gshade.runtime.heap.keep_freed_memory`), and
- Mitsuba's variants are set without its Python integrators, which gshade never renders with
  (:func:`gshade.runtime.variant.leave_out_python_integrators`).

Importing gshade, or calling :func:`gshade.render` from a program, changes neither.
"""

from __future__ import annotations

from .heap import keep_freed_memory
from .variant import leave_out_python_integrators

__all__ = ["configure_own_process"]


def configure_own_process() -> None:
    """Set what a process of gshade's own sets (see the module): once, at its start."""
    keep_freed_memory()
    leave_out_python_integrators()
