"""The header attributes a view (:mod:`gshade.display.html_view`) shows, validated.

An EXR's header comes from whoever wrote the file (a reference in a pull request, another
program); the view trusts none of it.  Every attribute it reads is checked here for its
type, structure, sizes, finite numbers and string lengths before anything is allocated
from it: the JSON attributes ``settings`` and ``junctions`` (text length, nesting, numbers,
each field's type; the number of junctions and their patch ids bounded), the texts shown
(``scene_name``, ``legend`` ...) and every other attribute.

A bad attribute is dropped, whole, with a :class:`HeaderNote` saying which, what was
expected and what was found: the pixels are the file's content and are shown as they are;
the page (and ``gshade view``, and the check report) says what was left out.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ..errors import show
from ..limits import MAX_PATCHES, MAX_STRING

__all__ = [
    "JUNCTION_CLASSES",
    "MAX_ATTRIBUTE_TEXT",
    "MAX_JSON_DEPTH",
    "MAX_JUNCTIONS",
    "MAX_JUNCTIONS_TEXT",
    "MAX_PATCH_ID",
    "HeaderNote",
    "ViewHeader",
    "view_header",
]

#: Longest text of a plain header attribute (characters); of the JSON ``settings``.
MAX_ATTRIBUTE_TEXT = MAX_STRING
MAX_SETTINGS_TEXT = 1 << 20
#: Longest ``junctions`` text (a CAD model or 100,000 patches list many junctions).
MAX_JUNCTIONS_TEXT = 64 << 20
#: Most junctions listed; largest patch (face) id: an EXR int, and ids are float32 pixels.
MAX_JUNCTIONS = 4 * MAX_PATCHES
MAX_PATCH_ID = 2**31 - 1
#: Deepest nesting of arrays and objects in a JSON attribute (gshade writes at most 4).
MAX_JSON_DEPTH = 8
#: The continuity classes a junction may have (see gshade.analysis.continuity).
JUNCTION_CLASSES = ("none", "G0", "G1", "G2", "G3")
#: A junction's measures: a finite number, or the text of a non-finite one.
_MEASURES = ("gap", "normal_angle_deg", "curvature_jump", "curvature_gradient_jump")
_NON_FINITE = ("inf", "-inf", "nan")
_SIDES = ("u0", "u1", "v0", "v1")
#: Texts the page shows; each a string if present.
_TEXTS = ("scene_name", "legend", "gshade_version", "variant", "length_unit", "gshade:length_unit")
#: Attributes a page shows at most (an EXR may carry thousands).
MAX_ATTRIBUTES = 256
#: Extra fields of a junction (beyond its class, patches, sides or edge and measures).
_MAX_EXTRA_FIELDS = 16


class _Bad(Exception):
    """An attribute that is not as expected: what was expected, and what was found."""

    def __init__(self, expected: str, found: str) -> None:
        super().__init__(expected, found)
        self.expected, self.found = expected, found


@dataclass(frozen=True)
class HeaderNote:
    """A header attribute left out of the view: its name, what was expected and found."""

    attribute: str
    expected: str
    found: str

    def __str__(self) -> str:
        return (
            f"header {self.attribute}: expected {self.expected}, got {self.found}; shown without it"
        )


@dataclass
class ViewHeader:
    """What the view uses of a header, all validated.

    ``attributes``: the attributes as strict-JSON values (strings, finite numbers, other
    values as short texts), ``settings`` and ``junctions`` left out; ``settings``: the
    parsed render settings ({} if missing or dropped); ``junctions``: the junctions with
    two different patches; ``colours``: each class's colour, ``#rrggbb``; ``left_out``: the
    CAD faces the render left out (``left_out_faces``), a line each; ``notes``: the
    attributes dropped."""

    attributes: dict[str, object] = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    junctions: list[dict] = field(default_factory=list)
    colours: dict[str, str] = field(default_factory=dict)
    left_out: list[str] = field(default_factory=list)
    notes: list[HeaderNote] = field(default_factory=list)


def _kind(value: object) -> str:
    """A found value, shortly (never more than ~60 characters of it)."""
    if value is None:
        return "null"
    if isinstance(value, str):
        return f"the text {show(value[:60])}" + ("..." if len(value) > 60 else "")
    if isinstance(value, list):
        return show(value[:8])[:60] + ("..." if len(value) > 8 else "")
    if isinstance(value, dict):
        return f"an object of {len(value)} item{'s' if len(value) != 1 else ''}"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    return type(value).__name__


def _reject_constant(name: str) -> object:
    raise _Bad("finite numbers", name)


def _loads(text: object, limit: int) -> object:
    """JSON text (at most ``limit`` characters, finite numbers, nesting bounded)."""
    if not isinstance(text, str):
        raise _Bad("JSON text", _kind(text))
    if len(text) > limit:
        raise _Bad(f"JSON text of at most {limit} characters", f"{len(text)} characters")
    try:
        value = json.loads(text, parse_constant=_reject_constant)
    except RecursionError:
        raise _Bad(f"JSON nested at most {MAX_JSON_DEPTH} deep", "deeper nesting") from None
    except ValueError as exc:  # json.JSONDecodeError, or an integer of > 4300 digits
        raise _Bad("JSON text", f"invalid JSON ({str(exc)[:80]})") from None
    _check_plain(value, 1)
    return value


def _check_plain(value: object, depth: int) -> None:
    """Nesting, string lengths and number sizes of a parsed JSON value (iteration bounded
    by the nesting)."""
    if depth > MAX_JSON_DEPTH:
        raise _Bad(f"JSON nested at most {MAX_JSON_DEPTH} deep", "deeper nesting")
    if isinstance(value, str):
        if len(value) > MAX_STRING:
            raise _Bad(f"strings of at most {MAX_STRING} characters", f"{len(value)} characters")
    elif isinstance(value, bool) or value is None:
        return
    elif isinstance(value, float):
        if not math.isfinite(value):  # 1e400 reads as inf
            raise _Bad("finite numbers", _kind(value))
    elif isinstance(value, int):
        if not -(2**63) <= value < 2**63:
            raise _Bad("integers within ±2**63", f"an integer of {len(str(abs(value)))} digits")
    elif isinstance(value, list):
        for item in value:
            _check_plain(item, depth + 1)
    elif isinstance(value, dict):
        for key, item in value.items():
            _check_plain(key, depth + 1)
            _check_plain(item, depth + 1)


def _object(value: object, what: str) -> dict:
    if not isinstance(value, dict):
        raise _Bad(f"{what} as a JSON object", _kind(value))
    return value


def _optional(table: dict, key: str, kinds: tuple[type, ...], expected: str, where: str) -> None:
    if key in table and table[key] is not None:
        value = table[key]
        if not isinstance(value, kinds) or (isinstance(value, bool) and bool not in kinds):
            raise _Bad(f"{where}{key} {expected}", _kind(value))


def _number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _settings(text: object) -> dict:
    """The ``settings`` attribute: an object whose ``shape`` and ``render`` (if present) are
    objects with fields of the types the view uses."""
    settings = _object(_loads(text, MAX_SETTINGS_TEXT), "the settings")
    for part in ("shape", "render", "camera"):
        if part in settings and not isinstance(settings[part], dict):
            raise _Bad(f"{part} as a JSON object", _kind(settings[part]))
    shape = settings.get("shape", {})
    for key in ("function", "colour_function", "display", "colormap"):
        _optional(shape, key, (str,), "a string", "shape.")
    _optional(shape, "period", (int, float), "a number", "shape.")
    _optional(shape, "params", (dict,), "a JSON object", "shape.")
    for key in ("value_range", "range"):
        given = shape.get(key)
        if given is None:
            continue
        if (
            not (isinstance(given, list) and len(given) == 2 and all(_number(x) for x in given))
            or not given[0] < given[1]
        ):
            raise _Bad(f"shape.{key} [lo, hi], two numbers with lo < hi", _kind(given))
    render = settings.get("render", {})
    for key in ("width", "height", "spp"):
        _optional(render, key, (int,), "an integer", "render.")
    _optional(render, "lighting", (str,), "a string", "render.")
    return settings


def _patch_id(value: object) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= MAX_PATCH_ID:
        raise _Bad(f"junction patches: two integers in [0, {MAX_PATCH_ID}]", _kind(value))
    return value


def _junction(row: object, k: int) -> dict:
    j = _object(row, f"junctions[{k}]")
    if j.get("class") not in JUNCTION_CLASSES:
        raise _Bad(
            f"junctions[{k}].class one of {', '.join(JUNCTION_CLASSES)}", _kind(j.get("class"))
        )
    patches = j.get("patches")
    if not isinstance(patches, list) or len(patches) != 2:
        raise _Bad(f"junctions[{k}].patches: two patch ids", _kind(patches))
    for p in patches:
        _patch_id(p)
    if "sides" in j:
        sides = j["sides"]
        if not (isinstance(sides, list) and len(sides) == 2 and all(s in _SIDES for s in sides)):
            raise _Bad(f"junctions[{k}].sides: two of {', '.join(_SIDES)}", _kind(sides))
    if "edge" in j:
        edge = j["edge"]
        if not isinstance(edge, int) or isinstance(edge, bool) or not 0 <= edge <= MAX_PATCH_ID:
            raise _Bad(f"junctions[{k}].edge: an integer in [0, {MAX_PATCH_ID}]", _kind(edge))
    for name in _MEASURES:
        if name in j and not (_number(j[name]) or j[name] in _NON_FINITE):
            raise _Bad(f"junctions[{k}].{name}: a number or one of inf, -inf, nan", _kind(j[name]))
    extra = [key for key in j if key not in ("class", "patches", "sides", "edge", *_MEASURES)]
    if len(extra) > _MAX_EXTRA_FIELDS:
        raise _Bad(f"junctions[{k}]: at most {_MAX_EXTRA_FIELDS} further fields", f"{len(extra)}")
    for key in extra:
        value = j[key]
        if len(key) > 64 or isinstance(value, (list, dict)):
            raise _Bad(
                f"junctions[{k}]: further fields named in at most 64 characters, with a number, "
                "a string, true, false or null",
                f"{_kind(key)} = {_kind(value)}",
            )
    return j


def _junctions(text: object) -> tuple[list[dict], dict[str, str]]:
    """The ``junctions`` attribute: {"junctions": [...], "colours": {class: [r, g, b]}}."""
    from ..io.image import linear_to_srgb

    meta = _object(_loads(text, MAX_JUNCTIONS_TEXT), "the junctions")
    rows = meta.get("junctions", [])
    if not isinstance(rows, list):
        raise _Bad("junctions: an array of junctions", _kind(rows))
    if len(rows) > MAX_JUNCTIONS:
        raise _Bad(f"at most {MAX_JUNCTIONS} junctions", f"{len(rows)}")
    junctions = [_junction(row, k) for k, row in enumerate(rows)]
    given = meta.get("colours", {})
    if not isinstance(given, dict):
        raise _Bad("colours: an object class -> [r, g, b]", _kind(given))
    colours = {}
    for cls, rgb in given.items():
        if cls not in JUNCTION_CLASSES:
            raise _Bad(f"colours of the classes {', '.join(JUNCTION_CLASSES)}", _kind(cls))
        if not (isinstance(rgb, list) and len(rgb) == 3 and all(_number(x) for x in rgb)):
            raise _Bad(f"colours.{cls}: three numbers [r, g, b]", _kind(rgb))
        s = np.round(linear_to_srgb(np.asarray(rgb, float)) * 255).astype(int)
        colours[cls] = "#" + "".join(f"{int(c):02x}" for c in s)
    drawn = [j for j in junctions if j["patches"][0] != j["patches"][1]]
    return drawn, colours


def _left_out(text: object) -> list[str]:
    """The ``left_out_faces`` attribute: [{"file", "face", "why", "tried"}, ...] as lines
    ``FILE: face N left out: WHY (tried: TRIED)``."""
    rows = _loads(text, MAX_JUNCTIONS_TEXT)
    if not isinstance(rows, list):
        raise _Bad("left_out_faces: an array of faces", _kind(rows))
    if len(rows) > MAX_JUNCTIONS:
        raise _Bad(f"at most {MAX_JUNCTIONS} faces", f"{len(rows)}")
    lines = []
    for k, row in enumerate(rows):
        face = _object(row, f"left_out_faces[{k}]")
        index = face.get("face")
        if isinstance(index, bool) or not isinstance(index, int) or index < 0:
            raise _Bad(f"left_out_faces[{k}].face: an integer >= 0", _kind(index))
        texts = [face.get(key, "") for key in ("file", "why", "tried")]
        if not all(isinstance(t, str) for t in texts):
            raise _Bad(f"left_out_faces[{k}]: file, why and tried as strings", _kind(row))
        file, why, tried = texts
        lines.append(f"{file}: face {index} left out: {why} (tried: {tried})")
    return lines


def _plain_value(key: str, value: object) -> object:
    """A plain attribute as a strict-JSON value: a string of bounded length, a number (a
    non-finite one as its text), another value as its short text."""
    if isinstance(value, (np.integer, np.floating)):
        value = value.item()
    if key in _TEXTS and not isinstance(value, str):
        raise _Bad("a string", _kind(value))
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    if isinstance(value, (list, tuple, np.ndarray)) and len(value) > MAX_ATTRIBUTE_TEXT:
        raise _Bad(f"a value of at most {MAX_ATTRIBUTE_TEXT} items", f"{len(value)} items")
    text = value if isinstance(value, str) else str(value)
    if len(text) > MAX_ATTRIBUTE_TEXT:
        raise _Bad(f"a text of at most {MAX_ATTRIBUTE_TEXT} characters", f"{len(text)} characters")
    return text


def view_header(header: Mapping[str, object]) -> ViewHeader:
    """The validated header of one image (see the module's notes).

    Parameters
    ----------
    header : mapping
        The attributes as :func:`gshade.io.image.read_exr` returns them.

    Returns
    -------
    ViewHeader
        Every bad attribute left out, with a note.
    """
    out = ViewHeader()
    for number, (key, value) in enumerate(header.items()):
        name = str(key)
        if len(name) > 256:
            out.notes.append(
                HeaderNote(
                    name[:60] + "...", "a name of at most 256 characters", f"{len(name)} characters"
                )
            )
            continue
        if number >= MAX_ATTRIBUTES:
            out.notes.append(
                HeaderNote(name, f"at most {MAX_ATTRIBUTES} attributes", f"{len(header)}")
            )
            break
        try:
            if name == "settings":
                out.settings = _settings(value)
            elif name == "junctions":
                out.junctions, out.colours = _junctions(value)
            elif name == "left_out_faces":
                out.left_out = _left_out(value)
            else:
                out.attributes[name] = _plain_value(name, value)
        except _Bad as bad:
            out.notes.append(HeaderNote(name, bad.expected, bad.found))
    return out
