"""Errors raised by gshade.

Every error that bad input can cause is a :class:`GshadeError`, a subclass of
:class:`ValueError` whose message says what was expected and what was given.
"""

from __future__ import annotations

__all__ = ["GshadeError", "ParameterDomainError", "SurfaceDataError"]


class GshadeError(ValueError):
    """Bad input to gshade: the message names the item, what was expected and what was found."""


class ParameterDomainError(GshadeError):
    """A parameter lies outside a patch's or curve's parameter domain."""


class SurfaceDataError(GshadeError):
    """A surface data file (e.g. Newell's teapot format) could not be read."""
