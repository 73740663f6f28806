"""The names of :mod:`gshade.cad`, re-exported here for 0.9 (they were in ``gshade.io.cad``
before it); to be removed in 0.10.  Import them from :mod:`gshade.cad`."""

from ..cad import *  # noqa: F403
from ..cad import __all__  # noqa: F401
