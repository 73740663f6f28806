"""Overrides: ``key=value`` items with dotted scene keys (:func:`parse_overrides`), and
applying them to a scene file's contents before it is validated.

Their errors name the override (``override shape.period: ...``)."""

from __future__ import annotations

import copy
import json
import sys
from collections.abc import Sequence
from typing import Any

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

from ..errors import GshadeError, show, suggest
from ..shape.functions import SHAPE_FUNCTIONS
from .sections import SECTION_KEYS, SHAPE_KEYS, function_names, shape_keys
from .surfaces import SURFACES

__all__ = ["apply_overrides", "parse_overrides"]


def _parse_value(text: str) -> Any:
    try:
        parsed = tomllib.loads(f"x = {text}")
    except (tomllib.TOMLDecodeError, ValueError, RecursionError):
        return text
    return parsed["x"] if list(parsed) == ["x"] else text


def parse_overrides(items: Sequence[str]) -> dict[str, Any]:
    """Parse ``key=value`` items into overrides for :func:`load_scene`.

    Parameters
    ----------
    items : sequence of str
        ``key=value`` with a dotted key (``shape.period``, ``camera.origin``, ``name``,
        ``surface.2.radius`` with a 1-based surface index).  The value is read as a TOML
        value (``0.05``, ``[1, 2, 3]``, ``"text"``, ``true``), or else taken as a plain
        string (``shape.function=mean``).

    Returns
    -------
    dict
        Dotted key -> value, in order (a later item for the same key wins).

    Raises
    ------
    GshadeError
        If an item has no ``=`` or its key is empty or malformed (``override ITEM: ...``).
    """
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = str(item).partition("=")
        key = key.strip()
        if not sep or not key or any(not part.strip() for part in key.split(".")):
            raise GshadeError(
                f"override {item}: expected key=value with a dotted key, e.g. shape.period=0.05"
            )
        out[".".join(part.strip() for part in key.split("."))] = _parse_value(value.strip())
    return out


_FUNCTION_KEYS = ("shape.function", "shape.colour_function")
_EXCLUSIVE = {"shape.period": "shape.stripes", "shape.stripes": "shape.period"}


def apply_overrides(file: str, raw: dict[str, Any], overrides: dict[str, Any]) -> dict[str, Any]:
    """The scene dict with the overrides applied (checking that their keys exist); errors
    read ``FILE: override KEY: ...``."""
    raw = copy.deepcopy(raw)
    sections = ("name", *SECTION_KEYS, "surface.N")

    def fail(key: str, message: str) -> GshadeError:
        return GshadeError(f"{file}: override {key}: {message}")

    def section(key: str, name: str) -> dict[str, Any]:
        table = raw.setdefault(name, {})
        if not isinstance(table, dict):
            raise fail(key, f"expected [{name}] to be a table in the scene, got {show(table)}")
        return table

    shape = raw.get("shape", {})
    before = set(function_names(shape)) if isinstance(shape, dict) else set()
    # The functions first: they decide which shape parameters are keys.
    ordered = sorted(overrides.items(), key=lambda kv: kv[0] not in _FUNCTION_KEYS)
    for key, value in ordered:
        parts = key.split(".")
        if parts == ["name"]:
            raw["name"] = value
        elif parts[0] in SECTION_KEYS and len(parts) == 2:
            table = section(key, parts[0])
            allowed = shape_keys(table) if parts[0] == "shape" else tuple(SECTION_KEYS[parts[0]])
            if parts[1] not in allowed:
                raise fail(
                    key,
                    f"unknown key {json.dumps(parts[1])} in [{parts[0]}]"
                    f"{suggest(parts[1], allowed)} (expected one of: {', '.join(allowed)})",
                )
            table[parts[1]] = value
            other = _EXCLUSIVE.get(key)
            if other is not None and other not in overrides:
                table.pop(other.split(".")[1], None)  # period replaces stripes, and vice versa
        elif parts[0] == "surface" and len(parts) == 3:
            surfaces = raw.get("surface")
            if not isinstance(surfaces, list):
                surfaces = []
            count = len(surfaces)
            if not (parts[1].isdigit() and 1 <= int(parts[1]) <= count):
                raise fail(
                    key,
                    f"expected a surface number from 1 to {count}, got {json.dumps(parts[1])}",
                )
            surface = surfaces[int(parts[1]) - 1]
            kind = surface.get("type") if isinstance(surface, dict) else None
            # type = [1] is reported later
            if isinstance(kind, str) and kind in SURFACES:
                keys = ("type", *SURFACES[kind].keys)
                if parts[2] not in keys:
                    raise fail(
                        key,
                        f"unknown key {json.dumps(parts[2])} for a {kind} surface"
                        f"{suggest(parts[2], keys)} (expected one of: {', '.join(keys)})",
                    )
            if isinstance(surface, dict):
                surface[parts[2]] = value
        else:
            head = parts[0] if parts[0] in SECTION_KEYS or parts[0] == "surface" else None
            if head is None:
                raise fail(
                    key,
                    f"unknown section {json.dumps(parts[0])}{suggest(parts[0], sections)} "
                    f"(expected one of: {', '.join(sections)})",
                )
            form = "surface.N.key" if head == "surface" else f"{head}.key"
            raise fail(key, f"expected a key of the form {form}, got {json.dumps(key)}")
        if key in _FUNCTION_KEYS and isinstance(raw.get("shape"), dict):
            _drop_stale_parameters(raw["shape"], before)
    return raw


def _drop_stale_parameters(shape: dict[str, Any], before: set[str]) -> None:
    """After an override changed the shape function(s), drop the file's parameters that
    only the functions it replaced take (misspelt keys stay, to be reported)."""
    now = set(function_names(shape))
    keep = {p for n in now for p in SHAPE_FUNCTIONS[n].parameters}
    stale = {p for n in before - now for p in SHAPE_FUNCTIONS[n].parameters} - keep
    for key in stale - set(SHAPE_KEYS):
        shape.pop(key, None)
