"""gshade: pictures and numbers of the shape quality of parametric surfaces.

The public API mirrors the command line: ``gshade.load_scene(path)``,
``gshade.render(scene, **overrides)`` (an image with the EXR channels, ``.write_exr`` and
``.write_png``) and ``gshade.compare(test, reference, ...)`` (metrics and an idiff verdict).
Building blocks live in ``gshade.geometry`` (patches and their differential geometry),
``gshade.shape`` (shape functions and colours), ``gshade.io`` (scene files, surface data,
images), ``gshade.rendering``, ``gshade.regression.comparison`` and ``gshade.regression.check``.
"""

__version__ = "0.2.0"

from .errors import GshadeError
from .runtime.llvm import prepare_llvm

prepare_llvm()  # before anything imports Dr.Jit

__all__ = ["GshadeError", "__version__", "compare", "load_scene", "render"]


def __getattr__(name: str):
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
