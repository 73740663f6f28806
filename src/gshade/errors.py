"""Errors raised by gshade, and the helpers that write their messages.

Every error that bad input can cause is a :class:`GshadeError`, a subclass of
:class:`ValueError` whose message says what was expected and what was given.  The value
given is written by :func:`show` (as it would look in TOML), the choices by :func:`one_of`
and a likely intended choice by :func:`suggest`, so that a rule checked in the library
reads the same whether a Python caller or a scene file broke it.
"""

from __future__ import annotations

import difflib
import json
from collections.abc import Sequence
from typing import Any

__all__ = [
    "GshadeError",
    "ParameterDomainError",
    "SurfaceDataError",
    "one_of",
    "show",
    "suggest",
]


class GshadeError(ValueError):
    """Bad input to gshade: the message names the item, what was expected and what was found."""


class ParameterDomainError(GshadeError):
    """A parameter lies outside a patch's or curve's parameter domain."""


class SurfaceDataError(GshadeError):
    """A surface data file (e.g. Newell's teapot format) could not be read."""


def _one_line(text: str) -> str:
    """``text`` as it is if printable, else as a JSON string (control characters escaped)."""
    return text if text.isprintable() else json.dumps(text, ensure_ascii=False)


def show(value: Any, limit: int = 60) -> str:
    """A value as it would look in TOML, shortened to ``limit`` characters: tuples and numpy
    arrays as lists, numpy scalars as plain numbers; a long list is read only as far as
    is shown."""
    if getattr(value, "ndim", None) == 0 and hasattr(value, "tolist"):
        value = value.tolist()  # a numpy scalar
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, str):
        text = json.dumps(value, ensure_ascii=False)
    elif isinstance(value, (int, float)):
        text = repr(value)
    elif isinstance(value, (list, tuple)) or getattr(value, "ndim", 0) >= 1:
        parts, length = [], -1  # the length of "[" and the parts so far, joined
        for item in value:
            parts.append(show(item, limit))
            length += len(parts[-1]) + 2
            if length > limit:  # shortened whatever follows
                break
        text = "[" + ", ".join(parts) + "]"
    elif isinstance(value, dict):  # keys from a file may hold line breaks: escaped
        text = "a table {" + ", ".join(_one_line(str(key)) for key in value) + "}"
    else:
        text = f"{_one_line(str(value))} ({type(value).__name__})"
    return text if len(text) <= limit else text[: limit - 1] + "…"


def one_of(choices: Sequence[str]) -> str:
    """Choices for a message: ``"cos", "angle"``."""
    return ", ".join(json.dumps(c) for c in choices)


def suggest(word: str, candidates: Sequence[str]) -> str:
    """``; did you mean "x"?`` for the candidate closest to ``word``, or nothing."""
    close = difflib.get_close_matches(word, list(candidates), n=1)
    return f"; did you mean {json.dumps(close[0])}?" if close else ""
