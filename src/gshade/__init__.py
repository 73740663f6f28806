"""gshade: pictures and numbers of the shape quality of parametric surfaces."""

from .errors import GshadeError

__version__ = "0.1.0"

__all__ = ["GshadeError", "__version__"]
