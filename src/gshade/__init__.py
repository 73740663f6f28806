"""gshade: pictures and numbers of the shape quality of parametric surfaces.

The public API mirrors the command line: ``gshade.load_scene(path)``,
``gshade.render(scene, **overrides)`` (an image with the EXR channels, ``.write_exr`` and
``.write_png``) and ``gshade.compare(test, reference, ...)`` (metrics and an idiff verdict).
The packages follow the pipeline, data flowing one way: ``gshade.scene`` (scene files) →
``gshade.geometry`` (exact patches and their differential geometry) → ``gshade.shape`` (shape
functions) → ``gshade.display`` (stripes, colour maps) → ``gshade.rendering`` (tessellation,
textures, Mitsuba, exact channels); beside them ``gshade.analysis`` (continuity at
junctions), ``gshade.regression`` (comparisons and reference checks), ``gshade.io`` (surface
data, images, outputs), ``gshade.runtime`` (LLVM, Mitsuba variant, array backends) and
``gshade.app`` (the command line, batch, figures).

Importing gshade changes nothing in the process.  gshade points Dr.Jit at a usable libLLVM
when it first imports Dr.Jit or Mitsuba itself; a program that imports ``drjit`` or
``mitsuba`` before that calls :func:`gshade.runtime.setup` first.
"""

from __future__ import annotations

__version__ = "0.11.0"

from typing import TYPE_CHECKING

from .errors import GshadeError

if TYPE_CHECKING:
    from collections.abc import Callable
    from typing import Any

__all__ = ["GshadeError", "__version__", "compare", "load_scene", "render"]


def __getattr__(name: str) -> Callable[..., Any]:
    # lazy: importing gshade stays cheap; Mitsuba and the kernels load when first used
    if name == "render":
        from .rendering import render

        return render
    if name == "compare":
        from .regression.comparison import compare

        return compare
    if name == "load_scene":
        from .scene import load_scene

        return load_scene
    raise AttributeError(f"module 'gshade' has no attribute {name!r}")
