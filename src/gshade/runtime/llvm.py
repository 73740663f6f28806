"""Finding a libLLVM that Dr.Jit's LLVM backend can use.

Dr.Jit JIT-compiles its CPU kernels (Mitsuba's ``llvm_ad_rgb`` variant, and gshade's own
shape-function kernels) with a libLLVM loaded at run time.  LLVM 15 or 16 aborts the whole
process on Mitsuba's first kernel (``Cannot select ... fmaximum``; see the project's design
notes), so gshade looks for libLLVM >= 17 itself — the ``karellen-llvm-core`` wheel installed
with gshade puts one into the environment — and points Dr.Jit at it with
``DRJIT_LIBLLVM_PATH`` before it imports Dr.Jit (:func:`point_drjit_at_llvm`, the one place
gshade sets that variable; :func:`import_drjit` is how gshade imports Dr.Jit).  Importing
gshade sets nothing: a program that imports ``drjit`` or ``mitsuba`` itself before gshade
does calls :func:`gshade.runtime.setup` first.
"""

from __future__ import annotations

import glob
import os
import re
import sys
from functools import lru_cache
from pathlib import Path
from types import ModuleType

__all__ = [
    "MIN_LLVM",
    "drjit_llvm_ready",
    "find_llvm",
    "import_drjit",
    "llvm_version",
    "point_drjit_at_llvm",
]

MIN_LLVM = 17


def llvm_version(path: str | os.PathLike) -> int | None:
    """Major version of a libLLVM from its file name (libLLVM.so.23.1, libLLVM-19.so, ...)."""
    name = Path(path).name
    match = re.match(r"libLLVM(?:-(\d+))?(?:[.\d]*)\.so(?:\.(\d+))?", name)
    if not match:
        return None
    major = match.group(1) or match.group(2)
    return int(major) if major else None


def _candidates() -> list[str]:
    prefixes = dict.fromkeys([sys.prefix, sys.base_prefix, "/usr/local", "/usr"])
    patterns = []
    for prefix in prefixes:
        patterns += [f"{prefix}/lib/libLLVM*.so*", f"{prefix}/lib64/libLLVM*.so*"]
    patterns += [
        "/usr/lib/llvm-*/lib/libLLVM*.so*",
        "/usr/lib/*-linux-gnu/libLLVM*.so*",
        "/opt/homebrew/opt/llvm/lib/libLLVM*.dylib",
        "/usr/local/opt/llvm/lib/libLLVM*.dylib",
    ]
    found = []
    for pattern in patterns:
        found += sorted(glob.glob(pattern))
    return found


@lru_cache(maxsize=1)
def find_llvm() -> str | None:
    """Path of the newest libLLVM >= 17 found, or DRJIT_LIBLLVM_PATH if the user set it."""
    chosen = os.environ.get("DRJIT_LIBLLVM_PATH")
    if chosen:
        return chosen
    best: tuple[int, str] | None = None
    for path in _candidates():
        version = llvm_version(path)
        if version is not None and version >= MIN_LLVM and (best is None or version > best[0]):
            best = (version, path)
    return best[1] if best else None


def point_drjit_at_llvm() -> None:
    """Set ``DRJIT_LIBLLVM_PATH`` to the libLLVM :func:`find_llvm` finds, unless Dr.Jit is
    imported already (it has chosen) or the variable is set (the user has); idempotent."""
    if "drjit" not in sys.modules and "DRJIT_LIBLLVM_PATH" not in os.environ:
        llvm = find_llvm()
        if llvm is not None:
            os.environ["DRJIT_LIBLLVM_PATH"] = llvm


def import_drjit() -> ModuleType:
    """Dr.Jit, imported after :func:`point_drjit_at_llvm`: how gshade imports it."""
    point_drjit_at_llvm()
    import drjit

    return drjit


@lru_cache(maxsize=1)
def drjit_llvm_ready() -> bool:
    """Whether Dr.Jit's LLVM backend is usable here: a libLLVM >= 17 was found, and Dr.Jit
    has loaded it (not an older one, which it may have if it was imported before gshade)."""
    if find_llvm() is None and "DRJIT_LIBLLVM_PATH" not in os.environ:
        return False
    try:
        dr = import_drjit()
        return bool(dr.has_backend(dr.JitBackend.LLVM)) and dr.detail.llvm_version()[0] >= MIN_LLVM
    except (ImportError, AttributeError, RuntimeError):
        return False
