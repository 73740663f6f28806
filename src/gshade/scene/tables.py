"""TOML files and typed access to their tables, with one-line messages that name the file,
the table and key, what was expected and what was found; and :class:`Key`, the
declaration of a table's key (what it accepts, its default, what it means) that the
parsers read their allowed keys and defaults from and ``gshade keys`` lists."""

from __future__ import annotations

import json
import math
import os
import sys
from collections.abc import Iterator, Mapping, Sequence
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

from ..errors import GshadeError, one_of, show, suggest
from ..limits import MAX_NESTING, MAX_SCENE_FILE_BYTES

__all__ = [
    "REQUIRED",
    "Key",
    "Table",
    "alternatives",
    "declare_keys",
    "is_int",
    "is_number",
    "parse_toml",
    "read_toml",
    "toml_value",
]


#: The default of a key that must be given.
REQUIRED: Any = object()
#: A getter's default argument: the key's declared default (REQUIRED if undeclared).
_DECLARED: Any = object()


def parse_toml(text: str, file: str) -> dict[str, Any]:
    """TOML text as a dict; ``file`` names it in messages.

    Raises
    ------
    GshadeError
        ``FILE: invalid TOML: ...`` in one line, with the line and column where the parser
        gives them (also for integers of more than 4300 digits and for nesting too deep for
        the parser).
    """
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise GshadeError(f"{file}: invalid TOML: {exc}") from None
    except ValueError as exc:  # an integer of more than 4300 digits
        raise GshadeError(f"{file}: invalid TOML: {str(exc).split(';')[0]}") from None
    except RecursionError:
        raise GshadeError(
            f"{file}: invalid TOML: arrays or tables nested too deeply (at most {MAX_NESTING})"
        ) from None


def read_toml(
    path: str | os.PathLike, expected: str, limit: int = MAX_SCENE_FILE_BYTES
) -> dict[str, Any]:
    """A TOML file as a dict: a regular file of at most ``limit`` bytes, UTF-8 text.

    Parameters
    ----------
    path : path-like
    expected : str
        What the file should be, for messages (``"a scene file (TOML)"``).
    limit : int
        The largest file accepted, in bytes.

    Raises
    ------
    GshadeError
        One line naming the file: it does not exist, is not a regular file, is too large,
        is not UTF-8 (the offset of the first bad byte) or not TOML (see :func:`parse_toml`).
    """
    from ..io.files import read_bytes

    path = Path(path)
    data = read_bytes(path, expected, limit=limit)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise GshadeError(
            f"{path}: expected a UTF-8 text file (TOML), got byte {data[exc.start]:#04x} at "
            f"offset {exc.start}"
        ) from None
    return parse_toml(text, str(path))


@dataclass(frozen=True)
class Key:
    """One key of a scene table, declared once.

    ``accepts`` says what values it takes (type and range); ``default`` is its value when
    absent (:data:`REQUIRED`: it must be given; None: no value); ``shown`` the default as
    ``gshade keys`` lists it where the value alone would not say it (e.g. "automatic").
    """

    name: str
    accepts: str
    default: Any
    description: str
    shown: str = ""

    @property
    def default_text(self) -> str:
        if self.shown:
            return self.shown
        if self.default is REQUIRED:
            return "required"
        if self.default is None:
            return "none"
        return toml_value(self.default)


def declare_keys(*keys: Key) -> dict[str, Key]:
    """A table's declared keys by name, in the order given (the order messages list them)."""
    return {k.name: k for k in keys}


def alternatives(choices: Sequence[str]) -> str:
    """Choices as ``gshade keys`` lists them: ``"lit" | "flat"``."""
    return " | ".join(json.dumps(c) for c in choices)


def toml_value(value: Any) -> str:
    """A default as it would be written in TOML: ``30``, ``0.001``, ``"lit"``, ``[0, 0, 1]``."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "inf" if value == math.inf else f"{value:g}"
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return json.dumps(value) if isinstance(value, str) else str(value)


def is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def is_int(x: Any) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


@contextmanager
def reported(prefix: str) -> Iterator[None]:
    """Prefix the message of a GshadeError raised inside (by a patch constructor, ...)."""
    try:
        yield
    except GshadeError as exc:
        raise GshadeError(f"{prefix}{exc}") from None


class Table:
    """Typed access to one TOML table, raising errors that name the file, table and key.

    A getter's ``default`` is the value returned when the key is absent (REQUIRED: it must
    be given); left out, it is the default declared in ``keys``.
    """

    def __init__(
        self, file: str, prefix: str, data: dict[str, Any], keys: Mapping[str, Key] | None = None
    ) -> None:
        self.file = file
        self.prefix = prefix  # "[camera] ", "[[surface]] 2 (bspline): " or ""
        self.data = data
        self.keys = keys or {}

    def error(self, key: str, message: str) -> GshadeError:
        return GshadeError(f"{self.file}: {self.prefix}{key}: {message}")

    def reported(self, key: str = "") -> AbstractContextManager[None]:
        """Prefix the messages raised inside with this table (and ``key``)."""
        return reported(f"{self.file}: {self.prefix}{key}{': ' if key else ''}")

    def reject_unknown(self, allowed: Sequence[str] | None = None, hint: str = "") -> None:
        """Refuse a key not in ``allowed`` (default: the declared keys)."""
        allowed = tuple(self.keys) if allowed is None else allowed
        for key in self.data:
            if key not in allowed:
                raise self.error(
                    key,
                    f"unknown key{suggest(key, allowed)} (expected one of: "
                    f"{', '.join(allowed)}{hint})",
                )

    def _default(self, key: str, default: Any) -> Any:
        if default is not _DECLARED:
            return default
        declared = self.keys.get(key)
        return REQUIRED if declared is None else declared.default

    def raw(self, key: str, default: Any = _DECLARED, expected: str = "") -> Any:
        if key in self.data:
            return self.data[key]
        default = self._default(key, default)
        if default is REQUIRED:
            raise self.error(key, f"missing; expected {expected}")
        return default

    def number(
        self,
        key: str,
        default: Any = _DECLARED,
        *,
        lo: float | None = None,
        hi: float | None = None,
        closed: bool = False,
        expected: str | None = None,
    ) -> Any:
        default = self._default(key, default)
        if expected is None:
            if lo is not None and hi is not None:
                a, b = ("[", "]") if closed else ("(", ")")
                expected = f"a number in {a}{lo:g}, {hi:g}{b}"
            elif lo == 0:
                expected = "a number >= 0" if closed else "a positive number"
            elif lo is not None:
                expected = f"a number {'>=' if closed else '>'} {lo:g}"
            else:
                expected = "a number"
        x = self.raw(key, default, expected)
        if x is default and key not in self.data:
            return x
        if not is_number(x) or not math.isfinite(x):
            raise self.error(key, f"expected {expected}, got {show(x)}")
        below = lo is not None and (x < lo if closed else x <= lo)
        above = hi is not None and (x > hi if closed else x >= hi)
        if below or above:
            raise self.error(key, f"expected {expected}, got {show(x)}")
        return float(x)

    def integer(
        self,
        key: str,
        default: Any = _DECLARED,
        *,
        minimum: int | None = 1,
        maximum: int | None = None,
    ) -> Any:
        """An integer in [minimum, maximum]; ``minimum`` None: any integer (the bounds are
        the library's to check)."""
        default = self._default(key, default)
        if minimum is None:
            expected = "an integer"
        elif maximum is not None:
            expected = f"an integer from {minimum} to {maximum}"
        else:
            expected = {0: "an integer >= 0", 1: "a positive integer"}.get(
                minimum, f"an integer >= {minimum}"
            )
        x = self.raw(key, default, expected)
        if x is default and key not in self.data:
            return x
        if not (
            is_int(x) and (minimum is None or x >= minimum) and (maximum is None or x <= maximum)
        ):
            raise self.error(key, f"expected {expected}, got {show(x)}")
        return int(x)

    def boolean(self, key: str, default: Any = _DECLARED) -> Any:
        value = self.raw(key, default, "true or false")
        if not isinstance(value, bool):
            raise self.error(key, f"expected true or false, got {show(value)}")
        return value

    def choice(self, key: str, choices: Sequence[str], default: Any = _DECLARED) -> Any:
        default = self._default(key, default)
        expected = f"one of {one_of(choices)}"
        x = self.raw(key, default, expected)
        if x is default and key not in self.data:
            return x
        if x not in choices or not isinstance(x, str):
            suggestion = suggest(x, choices) if isinstance(x, str) else ""
            raise self.error(key, f"expected {expected}, got {show(x)}{suggestion}")
        return x

    def string(self, key: str, default: Any = _DECLARED, expected: str = "a string") -> Any:
        default = self._default(key, default)
        x = self.raw(key, default, expected)
        if x is default and key not in self.data:
            return x
        if not isinstance(x, str) or not x:
            raise self.error(key, f"expected {expected}, got {show(x)}")
        return x

    def vector(self, key: str, default: Any = _DECLARED, *, what: str = "") -> Any:
        """3 finite numbers, as a tuple of floats (what they may be is the library's to
        check: a direction's length, ...)."""
        default = self._default(key, default)
        expected = f"3 numbers [x, y, z]{what}"
        x = self.raw(key, default, expected)
        if x is default and key not in self.data:
            return x
        if (
            not isinstance(x, (list, tuple))
            or len(x) != 3
            or not all(is_number(c) and math.isfinite(c) for c in x)
        ):
            raise self.error(key, f"expected {expected}, got {show(x)}")
        return (float(x[0]), float(x[1]), float(x[2]))

    def array(self, key: str, levels: Sequence[str], length: int | None = None) -> np.ndarray:
        """Nested lists of numbers, ``len(levels)`` deep, rectangular; ``levels[k]`` says
        what level k holds (for messages); innermost lists of ``length`` numbers if given.
        Always required: read an optional array only when it is present."""
        x = self.raw(key, REQUIRED, levels[0])

        def walk(v: Any, depth: int, where: str) -> None:
            if depth == len(levels):
                if not is_number(v) or not math.isfinite(v):
                    raise self.error(where, f"expected a finite number, got {show(v)}")
                return
            if not isinstance(v, list) or not v:
                raise self.error(where, f"expected {levels[depth]}, got {show(v)}")
            if depth == len(levels) - 1 and length is not None and len(v) != length:
                raise self.error(where, f"expected {levels[depth]}, got {show(v)}")
            for i, item in enumerate(v):
                walk(item, depth + 1, f"{where}[{i}]")

        walk(x, 0, key)
        if len(levels) == 3 or (len(levels) == 2 and length is None):
            lengths = ", ".join(str(len(row)) for row in x)
            if len({len(row) for row in x}) > 1:
                rows = f"{lengths} points" if len(levels) == 3 else f"lengths {lengths}"
                raise self.error(
                    key, f"expected {levels[0]}, every row of the same length, got rows of {rows}"
                )
        return np.asarray(x, dtype=np.float64)
