"""What gshade runs on: a libLLVM for Dr.Jit, the Mitsuba variant, array backends, native
libraries' console output captured around their calls, the cache folder and the process's
heap.

:func:`setup` is the one thing a program may need to call: before it imports ``drjit`` or
``mitsuba`` itself (gshade calls it whenever it imports them).
"""

from .llvm import point_drjit_at_llvm

__all__ = ["setup"]


def setup() -> None:
    """Prepare this process for Dr.Jit and Mitsuba as gshade uses them: point Dr.Jit at a
    libLLVM >= 17 (``DRJIT_LIBLLVM_PATH``; LLVM 15 and 16 abort on Mitsuba's kernels) unless
    Dr.Jit is imported already or the variable is set.  Idempotent; importing gshade does not
    call it.

    Examples
    --------
    >>> import gshade.runtime
    >>> gshade.runtime.setup()  # then ``import mitsuba`` finds gshade's libLLVM
    """
    point_drjit_at_llvm()
