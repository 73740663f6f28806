"""gshade: pictures and numbers of the shape quality of parametric surfaces.

The public API mirrors the command line: ``gshade.load_scene(path)``,
``gshade.render(scene_or_path, function=..., width=..., camera=..., set=...)`` (a
:class:`RenderedImage`: the EXR channels, ``.f .P .N .rgb .srgb .srgba``, ``.write_exr`` and
``.write_png``; Jupyter shows it) and ``gshade.compare(test, reference, ...)`` (metrics and
an idiff verdict).
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

__version__ = "0.12.0"

import sys
from importlib import import_module
from typing import TYPE_CHECKING, Any

from .errors import GshadeError

if TYPE_CHECKING:
    from .regression.comparison import compare
    from .rendering.pipeline import render
    from .rendering.rendered_image import RenderedImage
    from .scene import load_scene

__all__ = ["GshadeError", "RenderedImage", "__version__", "compare", "load_scene", "render"]

#: The names imported when first used (importing gshade stays cheap: Mitsuba and the kernels
#: load with them), and the module that defines each.
_LAZY = {
    "RenderedImage": ".rendering.rendered_image",
    "compare": ".regression.comparison",
    "load_scene": ".scene",
    "render": ".rendering.pipeline",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module 'gshade' has no attribute {name!r}")


def __dir__() -> list[str]:
    """The public names, and the subpackages imported so far (``gshade.scene`` ...)."""
    loaded = (n for n in globals() if not n.startswith("_") and f"{__name__}.{n}" in sys.modules)
    return sorted({*__all__, *loaded})
