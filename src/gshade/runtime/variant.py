"""Choosing Mitsuba's variant, and finding an LLVM that Dr.Jit can use.

Mitsuba's ``llvm_ad_rgb`` variant JIT-compiles its kernels with the system's libLLVM, and
LLVM 15 or 16 aborts the whole process on the first kernel (``Cannot select ... fmaximum``,
observed with drjit 1.5).  gshade therefore looks for libLLVM >= 17 itself — the
``karellen-llvm-core`` wheel installed with gshade puts one into the environment — and points
Dr.Jit at it with ``DRJIT_LIBLLVM_PATH`` before Mitsuba is imported.  With none, ``auto``
falls back to ``scalar_rgb`` with one warning.

Switching to an ``llvm_`` or ``cuda_`` variant, Mitsuba (re)loads the package
:data:`PYTHON_INTEGRATORS`: its differentiable integrators written in Python (``prb``,
``prbvolpath``, ``direct_projective`` ...), whose ``@dr.syntax`` rewrites and recompiles their
source, a sixth of a second.  gshade renders with its own integrator and Mitsuba's native
plugins, so its own processes (the command line, its batch workers) call
:func:`leave_out_python_integrators` once: their variants are then set without that package.
Importing gshade, or calling :func:`gshade.render` from a program, loads variants as Mitsuba
does.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import sys
import warnings
from functools import cache
from types import ModuleType
from typing import TYPE_CHECKING

from ..errors import GshadeError
from .llvm import MIN_LLVM, find_llvm, import_drjit, llvm_version, point_drjit_at_llvm

if TYPE_CHECKING:
    from collections.abc import Sequence

__all__ = [
    "MIN_LLVM",
    "PYTHON_INTEGRATORS",
    "VARIANTS",
    "find_llvm",
    "leave_out_python_integrators",
    "llvm_version",
    "mitsuba",
    "resolve_variant",
    "select_variant",
]

VARIANTS = ("auto", "llvm_ad_rgb", "scalar_rgb", "cuda_ad_rgb")

#: The package of Mitsuba's Python integrators, reloaded by ``mitsuba.set_variant``.
PYTHON_INTEGRATORS = "mitsuba.python.ad.integrators"

#: Whether this process sets variants without :data:`PYTHON_INTEGRATORS` (see the module).
_leaving_out = [False]


@cache
def resolve_variant(requested: str = "auto") -> str:
    """The Mitsuba variant that ``requested`` means here (auto | llvm_ad_rgb | scalar_rgb |
    cuda_ad_rgb).

    ``auto`` gives ``llvm_ad_rgb`` when a libLLVM >= 17 is found and otherwise
    ``scalar_rgb``, with one warning.  Raises GshadeError for an unknown name or an explicit
    ``llvm_ad_rgb`` without a usable LLVM.
    """
    if requested not in VARIANTS:
        raise GshadeError(f"variant: expected one of {', '.join(VARIANTS)}, got {requested!r}")
    if requested not in ("auto", "llvm_ad_rgb"):
        return requested
    llvm = find_llvm()
    if llvm is None:
        if requested == "llvm_ad_rgb":
            raise GshadeError(
                f"variant: llvm_ad_rgb needs libLLVM >= {MIN_LLVM}, and none was found; "
                "install karellen-llvm-core or set DRJIT_LIBLLVM_PATH"
            )
        warnings.warn(
            f"gshade: no libLLVM >= {MIN_LLVM} found (install karellen-llvm-core or set "
            "DRJIT_LIBLLVM_PATH); rendering with the much slower scalar_rgb variant",
            RuntimeWarning,
            stacklevel=3,
        )
        return "scalar_rgb"
    return "llvm_ad_rgb"


def select_variant(requested: str = "auto") -> str:
    """Resolve ``requested`` (:func:`resolve_variant`) and make it Mitsuba's active variant."""
    variant = resolve_variant(requested)
    mi = mitsuba()
    if mi.variant() == variant:
        return variant
    if variant == "llvm_ad_rgb":
        dr = import_drjit()
        loaded = dr.detail.llvm_version()[0]
        if loaded < MIN_LLVM:  # Dr.Jit was imported before gshade could point it elsewhere
            message = (
                f"Dr.Jit has loaded libLLVM {loaded}, which aborts on Mitsuba's kernels "
                f"(it needs >= {MIN_LLVM}); call gshade.runtime.setup() before importing "
                "drjit or mitsuba, or set DRJIT_LIBLLVM_PATH"
            )
            if requested == "llvm_ad_rgb":
                raise GshadeError(f"variant: {message}")
            warnings.warn(
                f"gshade: {message}; rendering with scalar_rgb", RuntimeWarning, stacklevel=2
            )
            variant = "scalar_rgb"
            if mi.variant() == variant:
                return variant
    try:
        _set_variant(mi, variant)
    except (ImportError, AttributeError, RuntimeError) as exc:
        raise GshadeError(f"variant: {variant} is not available here ({exc})") from None
    if variant == "cuda_ad_rgb":
        dr = import_drjit()
        try:
            dr.eval(mi.Float(1.0) + 1.0)
        except RuntimeError as exc:
            raise GshadeError(f"variant: cuda_ad_rgb cannot run here ({exc})") from None
    return variant


def leave_out_python_integrators() -> None:
    """From now on, set Mitsuba's variants in this process without its Python integrators
    (:data:`PYTHON_INTEGRATORS`; see the module): for gshade's own processes only.

    Examples
    --------
    The package left out:

    >>> PYTHON_INTEGRATORS
    'mitsuba.python.ad.integrators'
    """
    _leaving_out[0] = True


class _NothingToReload(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Found first for :data:`PYTHON_INTEGRATORS` while a variant is set: reloading the
    package then runs nothing."""

    def find_spec(
        self, name: str, path: Sequence[str] | None, target: ModuleType | None = None
    ) -> importlib.machinery.ModuleSpec | None:
        if name != PYTHON_INTEGRATORS:
            return None
        return importlib.machinery.ModuleSpec(name, self, is_package=True)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> None:
        return None  # the package's own module object is reloaded in place

    def exec_module(self, module: ModuleType) -> None:
        pass


def _set_variant(mi: ModuleType, variant: str) -> None:
    """``mi.set_variant(variant)``, without reloading :data:`PYTHON_INTEGRATORS` where this
    process leaves them out (:func:`leave_out_python_integrators`); the package's module
    object is as it was afterwards."""
    package = sys.modules.get(PYTHON_INTEGRATORS)
    if not _leaving_out[0] or package is None:
        mi.set_variant(variant)
        return
    spec, finder = package.__spec__, _NothingToReload()
    sys.meta_path.insert(0, finder)
    try:
        mi.set_variant(variant)
    finally:
        sys.meta_path.remove(finder)
        package.__spec__ = spec


def mitsuba() -> ModuleType:
    """Mitsuba, imported after :func:`gshade.runtime.llvm.point_drjit_at_llvm` (Mitsuba
    imports Dr.Jit): how gshade imports it."""
    point_drjit_at_llvm()
    import mitsuba as mi

    return mi
