"""Scene files: kept for compatibility; the reader lives in :mod:`gshade.scene`."""

from ..scene import *  # noqa: F403
from ..scene import __all__  # noqa: F401
