"""The scene-key reference (``gshade keys``), made from the declarations the parsers use:
every table, its keys, what each accepts, its default and what it means."""

from __future__ import annotations

import itertools
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass, field

from .load import TOP_KEYS
from .sections import CAMERA_KEYS, CHECK_KEYS, RENDER_KEYS, SHAPE_KEYS
from .surfaces import SURFACES, TYPE_KEY
from .tables import Key

__all__ = ["KeyTable", "key_tables", "scene_keys"]


@dataclass(frozen=True)
class KeyTable:
    """One table of the reference: its heading (``[render]``, ``[[surface]] type =
    "bezier"``), what it is, its keys, and a note on keys not declared one by one."""

    heading: str
    description: str
    keys: dict[str, Key] = field(default_factory=dict)
    note: str = ""


def key_tables() -> list[KeyTable]:
    """The tables of a scene file, in the order the reference lists them."""
    tables = [
        KeyTable("(top level)", "", TOP_KEYS),
        KeyTable("[[surface]]", "one or more; the keys of each type follow", {"type": TYPE_KEY}),
    ]
    tables += [
        KeyTable(f'[[surface]] type = "{name}"', spec.description, spec.keys)
        for name, spec in SURFACES.items()
    ]
    for name, keys in (("shape", SHAPE_KEYS), ("camera", CAMERA_KEYS), ("render", RENDER_KEYS)):
        note = "" if name != "shape" else "and the functions' parameters, by name"
        tables.append(KeyTable(f"[{name}]", TOP_KEYS[name].description, keys, note))
    tables.append(KeyTable("[check]", TOP_KEYS["check"].description, CHECK_KEYS))
    tables.append(
        KeyTable(
            "[sweep]",
            TOP_KEYS["sweep"].description,
            note='"table.key" = [values]: a dotted key such as "shape.period", one render a value',
        )
    )
    return tables


#: Column widths of the reference: key, type and range, default; the meaning fills the rest.
_WIDTHS = (22, 32, 18)
_LINE = 110


def _row(cells: Sequence[str]) -> list[str]:
    """One key's lines: each cell wrapped within its column."""
    widths = (*_WIDTHS, _LINE - 2 - sum(w + 2 for w in _WIDTHS))
    wrapped = [
        textwrap.wrap(c, w, break_on_hyphens=False) or [""]
        for c, w in zip(cells, widths, strict=True)
    ]
    return [
        ("  " + "  ".join(f"{part:<{w}}" for part, w in zip(parts, widths, strict=True))).rstrip()
        for parts in itertools.zip_longest(*wrapped, fillvalue="")
    ]


def scene_keys() -> str:
    """The reference as text: each table's heading and what it is, then its keys (name,
    type and range, default, meaning)."""
    lines = _row(("key", "type and range", "default", "meaning"))
    for table in key_tables():
        lines += ["", f"{table.heading}  {table.description}".rstrip()]
        for key in table.keys.values():
            lines += _row((key.name, key.accepts, key.default_text, key.description))
        if table.note:
            lines.append(f"  … {table.note}")
    return "\n".join(lines)
