"""Deterministic mutations of the project's scenes, for tests/hostile/test_fuzz.py and
tests/support/hostile_run.py.

Every scene in ``scenes/*.toml`` is parsed (tomllib), its render settings made small
(``SMALL_RENDER``), mutated as a dict and written back with the small TOML writer below
(:func:`dumps`), or mutated as text for the syntax-level cases (truncation, raw NUL, bad
UTF-8, 5000-digit numbers, 3000 nested ``[``).  ``mutations(count, seed)`` gives
``(label, toml_text)`` pairs; ``cases(count, seed)`` the same as :class:`Case` records with the
mutation kind and whether it set a render size.  Case ``i`` depends only on ``(seed, i)``, so
a shorter run is a prefix of a longer one.  Write a variant with :func:`write_variant` (it
copies ``scenes/data/`` beside the scene, so that ``file = "data/teapot.txt"`` resolves).

A text may hold raw bytes that are not UTF-8 as lone surrogates (``"\\udcff"``, Python's
surrogateescape); :func:`write_variant` writes them as those bytes.
"""

from __future__ import annotations

import copy
import datetime
import math
import os
import random
import re
import shutil
import signal
import sys
from contextlib import contextmanager
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = [
    "CASE_TIMEOUT",
    "SIZE_KEYS",
    "SMALL_RENDER",
    "Case",
    "CaseTimeout",
    "Raw",
    "alarm",
    "cases",
    "dumps",
    "listing",
    "mutations",
    "probes",
    "rss_of",
    "write_variant",
]

ROOT = Path(__file__).resolve().parents[2]  # tests/support/ -> the checkout
SCENES = ROOT / "scenes"
DATA = SCENES / "data"
#: Render settings every variant gets before it is mutated (unless the mutation sets them).
SMALL_RENDER = {"width": 32, "height": 24, "spp": 1, "lighting": "flat"}
#: Render settings that size the work: a mutation setting one of them is a "size" case.
SIZE_KEYS = ("width", "height", "spp", "tessellation")
NAN, INF = float("nan"), float("inf")
BIG = 10**400  # 400 digits, written as digits


class Raw(str):
    """A TOML value written verbatim (for values tomllib would not give back, e.g. 5000 digits)."""


@dataclass(frozen=True)
class Case:
    label: str  # "0042-teapot-mean-number:render.width=nan" (ASCII)
    text: str  # the TOML text (lone surrogates = raw bytes, see write_variant)
    stem: str  # the scene it was made from: the variant's file name
    kind: str  # the mutation kind
    size: bool  # the mutation set render width, height, spp or tessellation


# --------------------------------------------------------------------------- the writer

_BARE = re.compile(r"[A-Za-z0-9_-]+\Z")
_ESCAPES = {
    '"': '\\"',
    "\\": "\\\\",
    "\n": "\\n",
    "\t": "\\t",
    "\r": "\\r",
    "\b": "\\b",
    "\f": "\\f",
}


def _string(s: str) -> str:
    out = []
    for ch in s:
        o = ord(ch)
        if ch in _ESCAPES:
            out.append(_ESCAPES[ch])
        elif o < 0x20 or o == 0x7F:
            out.append(f"\\u{o:04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _key(k: str) -> str:
    return k if _BARE.match(k) else _string(k)


def _value(v: Any) -> str:
    if isinstance(v, Raw):
        return str(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)  # round-trips; 1e+308, 5e-324, -0.0 are TOML floats
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, (datetime.datetime, datetime.date, datetime.time)):
        return v.isoformat()
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        if not v:
            return "{}"
        return "{ " + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {type(v).__name__} as TOML")


def _is_tables(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(t, dict) for t in v)


def dumps(doc: dict[str, Any]) -> str:
    """A TOML document: top-level scalars and arrays first, then ``[tables]`` and
    ``[[arrays of tables]]``; tables inside tables are written inline."""
    lines = [
        f"{_key(k)} = {_value(v)}"
        for k, v in doc.items()
        if not isinstance(v, dict) and not _is_tables(v)
    ]
    for k, v in doc.items():
        if isinstance(v, dict):
            lines += ["", f"[{_key(k)}]"] + [f"{_key(a)} = {_value(b)}" for a, b in v.items()]
        elif _is_tables(v):
            for table in v:
                lines += ["", f"[[{_key(k)}]]"]
                lines += [f"{_key(a)} = {_value(b)}" for a, b in table.items()]
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- paths in a doc


def _walk(obj: Any, path: tuple = ()):
    """(path, value) for every node below obj (not obj itself), depth first."""
    items = (
        obj.items() if isinstance(obj, dict) else enumerate(obj) if isinstance(obj, list) else ()
    )
    for k, v in items:
        yield (*path, k), v
        yield from _walk(v, (*path, k))


def _get(doc: Any, path: tuple) -> Any:
    for k in path:
        doc = doc[k]
    return doc


def _set(doc: Any, path: tuple, value: Any) -> None:
    _get(doc, path[:-1])[path[-1]] = value


def _where(path: tuple) -> str:
    return ".".join(str(p) for p in path)


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _short(v: Any) -> str:
    """An ASCII rendering of a value for labels."""
    if isinstance(v, float) and (math.isnan(v) or math.isinf(v)):
        text = repr(v)
    elif isinstance(v, int) and not isinstance(v, bool) and abs(v) >= 10**15:
        text = f"{'-' if v < 0 else ''}{len(str(abs(v)))}digits"
    else:
        text = _value(v) if not isinstance(v, Raw) else f"raw{len(v)}"
    text = ascii(text)[1:-1] if not text.isascii() else text
    text = re.sub(r"\s+", "", text)
    return text if len(text) <= 28 else text[:27] + "~"


def _surfaces(doc: dict) -> list:
    s = doc.get("surface")
    return s if isinstance(s, list) else []


# --------------------------------------------------------------------------- value pools

NUMBERS = [
    NAN, INF, -INF, 1e308, -1e308, 5e-324, -5e-324, -0.0, 0, 0.0, -1, -2.5, 1e-300, 1e300,
    1e16, 2**31, 2**53 + 1, 2**63, 2**64, -(2**63), BIG, -BIG, 1e15, 3,
]  # fmt: skip
OTHER_TYPES = [
    "text", "", 1, 2.5, True, False, [], [1, 2, 3], [[1]], [[[0, 0, 0]]], {"x": 1}, {},
    datetime.datetime(1979, 5, 27, 7, 32, tzinfo=datetime.timezone.utc),
    datetime.date(2024, 1, 1), datetime.time(7, 32),
]  # fmt: skip
SIZE_SMALL = {
    "width": [1, 2, 3, 5, 16, 31],
    "height": [1, 2, 3, 7, 24],
    "spp": [1, 2, 3, 4, 5, 16, 17],
    "tessellation": [2, 3, 4, 9, 33],
}
SIZE_ABSURD = {
    "width": [10**8, 2**31 - 1, 2**31, 2**32 + 1, 2**53, 2**63 - 1, 2**64, 10**18, BIG],
    "height": [10**8, 2**31, 2**32 + 1, 2**63 - 1, 10**18, BIG],
    "spp": [10**7, 2**31, 2**40, 2**63 - 1, 2**64, BIG],
    "tessellation": [10**6, 2**31, 2**63 - 1, BIG],
}
SIZE_INVALID = [0, -1, -(2**63), -BIG, 1.5, 32.0, NAN, INF, 1e308, "32", True, [32], ""]
SETTINGS = {
    "seed": [0, 1, 2**32 - 1, 2**32, 2**63, 2**64, BIG, -1, 1.5, NAN, "0"],
    "chord_tolerance": [1e-300, 5e-324, 1e-12, 1e-9, 0.5, 1.0, 10.0, 1e300, 1e308, INF, NAN, 0, -1],
    "texture_resolution": [1, 2, 3, 512, 513, 10**6, 2**31, 2**63, BIG, 0, -1, NAN, 1.5],
    "lighting": ["lit", "LIT", "", "flat\x00", 1, ["flat"]],
    "variant": ["scalar_rgb", "cuda_ad_rgb", "llvm_ad_rgb", "mono", "", "auto\n"],
    "junctions": [True, 1, "yes"],
}  # fmt: skip
VECTORS = [
    [NAN, 0, 0], [INF, 0, 1], [1e308, 1e308, 1e308], [-1e308, 0, 1e308], [0, 0, 0], [1, 2],
    [1, 2, 3, 4], [[1, 2, 3]], "up", [1e-300, 0, 0], [5e-324, 5e-324, 5e-324],
    [1e-200, 1e-200, 1e-200], [1e200, 1e200, 1e200], [1e15, 1e15, 1e15], [BIG, 0, 0],
    [1e20, -1e20, 1e20], [], [True, False, True],
]  # fmt: skip
FUNCTIONS = [
    "isophotes", "reflection_lines", "highlight_lines", "planar_sections",
    "parametrisation_quality", "gaussian", "mean", "max_principal", "min_principal",
    "absolute", "rms", "nope", "", "Isophotes",
]  # fmt: skip
NAMES = [
    "x" * 300, "y" * 5000, "a/b", "../../etc/passwd", "..", ".", "/", "nul\x00byte",
    "\x01\x1b[31mred\x7f", "emoji\U0001f600\U0001fad6", "\u202eevil.exr", "tab\tname",
    "line\nbreak", "", " ", "CON", "\u540d\u524d", "a\\b", "%s%n", "${HOME}", "-o", "--help",
    "\u0301\u200b\ufeff", "\U0010ffff",
]  # fmt: skip
KEYS = ["colour", "widht", "\U0001f600", "a.b", "", " ", "\x00", "k" * 300, "surface", "type"]


def _pick_size_value(rng: random.Random, key: str) -> Any:
    pool = rng.choice([SIZE_SMALL[key], SIZE_ABSURD[key], SIZE_ABSURD[key], SIZE_INVALID])
    return rng.choice(pool)


# --------------------------------------------------------------------------- mutations
# Each takes (doc, rng) and returns a description (for the label), None if it does not
# apply, or ("text", new_text, description) to replace the written text.  A description
# starting with "size:" marks a size case.


def _m_delete(doc, rng):
    keys = [p for p, _ in _walk(doc) if isinstance(_get(doc, p[:-1]), dict)]
    path = rng.choice(keys)
    del _get(doc, path[:-1])[path[-1]]
    return _where(path)


def _m_wrong_type(doc, rng):
    paths = [p for p, _ in _walk(doc)]
    path = rng.choice(paths)
    old = _get(doc, path)
    value = rng.choice([v for v in OTHER_TYPES if type(v) is not type(old)])
    _set(doc, path, copy.deepcopy(value))
    size = len(path) == 2 and path[0] == "render" and path[1] in SIZE_KEYS
    return ("size:" if size else "") + f"{_where(path)}={_short(value)}"


def _m_number(doc, rng):
    leaves = [(p, v) for p, v in _walk(doc) if _is_number(v)]
    geometry = [p for p, _ in leaves if p[0] == "surface"]
    other = [p for p, _ in leaves if p[0] != "surface"]
    pool = geometry if geometry and (not other or rng.random() < 0.6) else other
    if not pool:
        return None
    path = rng.choice(pool)
    value = rng.choice(NUMBERS)
    _set(doc, path, value)
    size = len(path) == 2 and path[0] == "render" and path[1] in SIZE_KEYS
    return ("size:" if size else "") + f"{_where(path)}={_short(value)}"


def _m_settings(doc, rng):
    render = doc.setdefault("render", {})
    if not isinstance(render, dict):
        return None
    key = rng.choice([*SIZE_KEYS, *SIZE_KEYS, *SETTINGS])
    if key in SIZE_KEYS:
        if rng.random() < 0.15 and key in ("width", "height"):
            side = rng.choice([2**15, 2**16, 10**5])
            render["width"] = render["height"] = side
            return f"size:render.width=height={side}"
        value = _pick_size_value(rng, key)
        render[key] = value
        return f"size:render.{key}={_short(value)}"
    value = rng.choice(SETTINGS[key])
    render[key] = value
    return f"render.{key}={_short(value)}"


def _m_camera(doc, rng):
    camera = doc.setdefault("camera", {})
    if not isinstance(camera, dict):
        return None
    op = rng.randrange(7)
    if op == 0:
        key, value = rng.choice(["origin", "target", "up"]), copy.deepcopy(rng.choice(VECTORS))
        camera[key] = value
    elif op == 1:
        camera["origin"] = camera["target"] = [1.0, 2.0, 3.0]
        return "camera.origin=target"
    elif op == 2:
        camera["origin"], camera["target"] = [0, 0, 5], [0, 0, 0]
        camera["up"] = rng.choice([[0, 0, 1], [0, 0, -3], [0, 1e-12, 1]])
        return f"camera.up-parallel={_short(camera['up'])}"
    elif op == 3:
        key, value = (
            "fov",
            rng.choice([0, 1e-300, 5e-324, 1e-6, 179.9999999, 180, 360, -30, NAN, INF, 1e308]),
        )
        camera["fov"] = value
    elif op == 4:
        camera["type"] = "orthographic"
        key, value = "width", rng.choice([0, 1e-300, 5e-324, 1e300, 1e308, -2, NAN, None])
        if value is None:
            camera.pop("width", None)
            return "camera.type=orthographic,no-width"
        camera["width"] = value
    elif op == 5:
        key, value = "type", rng.choice(["orthographic", "fisheye", "", 1, "Perspective"])
        camera["type"] = value
    else:
        camera.pop("target", None)
        key, value = "origin", rng.choice([[1e-9, 0, 0], [0, 0, 0], [1e300, 0, 0], [3, -4, 2]])
        camera["origin"] = value
        return f"camera.origin-only={_short(value)}"
    return f"camera.{key}={_short(value)}"


def _m_shape(doc, rng):
    shape = doc.setdefault("shape", {})
    if not isinstance(shape, dict):
        return None
    vectors = [k for k, v in shape.items() if isinstance(v, list) and k != "range"]
    choices = {
        "function": FUNCTIONS,
        "colour_function": FUNCTIONS,
        "display": ["stripes", "colormap", "both", "", "STRIPES", 0],
        "period": [1e-300, 5e-324, 1e300, 1e308, 0, -1, NAN, INF, 1e-12],
        "stripes": [1e308, 1e-300, 5e-324, 0, -3, NAN, 1e12],
        "duty": [0, 1, 0.999999999999, 1e-300, NAN, -0.5, 2],
        "phase": [1e308, NAN, 1e20, -1e300, INF],
        "range": [[1, 1], [2, 1], [NAN, 1], [-1e308, 1e308], [0, 5e-324], [1], [], [0, INF]],
        "colormap": ["nope", "", "viridis_r", "Viridis", 7],
        "form": ["angle", "cosine", "distance", "infinity", "plane", "nope", ""],
    }
    key = rng.choice([*choices, *(vectors * 3)])
    if key in choices:
        value = copy.deepcopy(rng.choice(choices[key]))
        if key == "function" and rng.random() < 0.5:  # a clean switch: drop the old parameters
            for k in list(shape):
                if k not in choices:
                    del shape[k]
    else:
        value = copy.deepcopy(rng.choice(VECTORS))
    shape[key] = value
    return f"shape.{key}={_short(value)}"


def _m_ragged(doc, rng):
    nested = [p for p, v in _walk(doc) if isinstance(v, list) and v and isinstance(v[0], list)]
    flat = [p for p, v in _walk(doc) if isinstance(v, list) and len(p) >= 2]
    if not flat:
        return None
    op = rng.randrange(9)
    if op in (0, 1, 2) and nested:  # one inner list shorter / longer / empty
        path = rng.choice(nested)
        outer = _get(doc, path)
        i = rng.randrange(len(outer))
        inner = outer[i]
        if not isinstance(inner, list):
            return None
        if op == 0 and inner:
            inner.pop()
            what = "shorter"
        elif op == 1:
            inner.append(copy.deepcopy(inner[-1]) if inner else 0)
            what = "longer"
        else:
            outer[i] = []
            what = "empty"
        return f"{_where(path)}[{i}]:{what}"
    path = rng.choice(flat)
    value = _get(doc, path)
    if op == 3:
        _set(doc, path, [])
        what = "[]"
    elif op == 4:
        _set(doc, path, [[[value]]])
        what = "over-deep"
    elif op == 5:
        _set(doc, path, [x for v in value for x in (v if isinstance(v, list) else [v])])
        what = "flattened"
    elif op == 6 and value:
        i = rng.randrange(len(value))
        value[i] = copy.deepcopy(
            rng.choice([[1.0, 2.0], [1, 2, 3, 4], 7, [[1, 2, 3]], [], "p", [[]]])
        )
        what = f"[{i}]={_short(value[i])}"
    elif op == 7:
        value.extend(copy.deepcopy(value))
        what = "doubled"
    else:
        _set(doc, path, [value, 5])
        what = "mixed-depth"
    return f"{_where(path)}:{what}"


def _grid(rows: int, cols: int, fn) -> list:
    return [[list(fn(i, j)) for j in range(cols)] for i in range(rows)]


def _m_degenerate(doc, rng):
    surfaces = _surfaces(doc)
    if not surfaces:
        return None
    index = rng.randrange(len(surfaces))
    s = surfaces[index]
    if not isinstance(s, dict):
        return None
    kind = s.get("type")
    where = f"surface.{index}"
    if kind in ("bezier", "bspline", "betaspline", "nuspline", "junction") and isinstance(
        s.get("points"), list
    ):
        pts = s["points"]
        rows = len(pts)
        cols = len(pts[0]) if rows and isinstance(pts[0], list) else 4
        op = rng.randrange(9)
        if op == 0:
            s["points"] = _grid(rows, cols, lambda i, j: (1.0, 2.0, 3.0))
            return f"{where}.points:all-equal"
        if op == 1:
            s["points"] = _grid(rows, cols, lambda i, j: (i + j, 2 * (i + j), -(i + j)))
            return f"{where}.points:collinear"
        if op == 2:
            s["points"] = _grid(rows, cols, lambda i, j: (float(i), 0.0, 0.0))
            return f"{where}.points:rows-collapsed"
        if op == 3:
            s["points"] = [copy.deepcopy(pts[0])] if rows else [[[0, 0, 0]]]
            return f"{where}.points:one-row"
        if op == 4:
            s["points"] = [[[0, 0, 0]]]
            return f"{where}.points:one-point"
        if op == 5:
            s["points"] = _grid(rows, cols, lambda i, j: (i * 1e-300, j * 1e-300, 0.0))
            return f"{where}.points:tiny-1e-300"
        if op == 6:
            s["points"] = _grid(rows, cols, lambda i, j: (i * 1e300, j * 1e300, (i * j) * 1e300))
            return f"{where}.points:huge-1e300"
        if op == 7:
            value = rng.choice([0, -1, 1e-300, 1e300, NAN])
            s["weights"] = [[value] * cols for _ in range(rows)]
            return f"{where}.weights:all={_short(value)}"
        if kind == "bspline":
            sub = rng.randrange(5)
            if sub == 0:
                s["knots_u"] = [0.0] * len(s.get("knots_u", [0] * 8))
                return f"{where}.knots_u:all-zero"
            if sub == 1:
                s["knots_u"] = sorted(s.get("knots_u", [0, 1]), reverse=True)
                return f"{where}.knots_u:decreasing"
            if sub == 2:
                s["degree"] = rng.choice([[0, 0], [10, 10], [-1, 2], [3], [2**63, 2]])
                return f"{where}.degree={_short(s['degree'])}"
            if sub == 3:
                k = s.get("knots_v", [0, 1])
                s["knots_v"] = k[:1] + [0.5] * 6 + k[1:]
                return f"{where}.knots_v:multiplicity-6"
            s["knots_u"] = list(s.get("knots_u", []))[:-1]
            return f"{where}.knots_u:one-short"
        s["points"] = [*_grid(rows, cols, lambda i, j: (i, j, 0.0)), [[0, 0, 0]] * cols]
        return f"{where}.points:folded-row"
    if kind == "coons":
        op = rng.randrange(4)
        if op == 0:
            s["v0"] = [[0, 0, 0]]
            return f"{where}.v0:one-point"
        if op == 1:
            s["u1"] = [[9, 9, 9], [10, 10, 10]]
            return f"{where}.u1:corners-mismatch"
        if op == 2:
            for k in ("v0", "v1", "u0", "u1"):
                s[k] = [[0, 0, 0], [0, 0, 0]]
            return f"{where}:all-curves-a-point"
        s["cross_v0"] = [[0, 0, 1]] * 12
        return f"{where}.cross_v0:degree-11"
    if kind == "subdivision":
        value = rng.choice([4, 5, -1, 2**63, "data", "data/teapot.txt", "/dev/zero", "../x.obj"])
        key = "levels" if isinstance(value, int) else "file"
        s[key] = value
        return f"{where}.{key}={_short(value)}"
    if kind == "newell":
        value = rng.choice(["data/cube.obj", "data/README.md", "", "data", "nope.txt", "/dev/zero"])
        key, value = rng.choice([("file", value), ("up", rng.choice(["w", "Z", "", "-z"]))])
        s[key] = value
        return f"{where}.{key}={_short(value)}"
    # sphere and anything else: replace by a zero-size / degenerate quadric
    new = rng.choice(
        [
            {"type": "sphere", "radius": rng.choice([0, 5e-324, 1e-300, 1e300, 1e308])},
            {"type": "torus", "major": 1.0, "minor": rng.choice([1.0, 2.0, 1e-300, 0, 5e-324])},
            {"type": "torus", "major": rng.choice([0, 1e-300, 1e300]), "minor": 0.5},
            {"type": "cylinder", "radius": rng.choice([5e-324, 1e-300, 1]), "height": 1e-300},
        ]
    )
    surfaces[index] = new
    return f"{where}={new['type']}:" + ",".join(
        f"{k}={_short(v)}" for k, v in new.items() if k != "type"
    )


def _m_zero_sphere(doc, rng):
    radius = rng.choice([0, 0.0, -0.0, 5e-324, 1e-300, 1e-160])
    surfaces = doc.get("surface")
    if not isinstance(surfaces, list):
        return None
    surfaces.append({"type": "sphere", "radius": radius})
    return f"surface+=sphere(radius={_short(radius)})"


def _m_name(doc, rng):
    value = rng.choice(NAMES)
    doc["name"] = value
    return f"name={_short(value)}"


def _m_unknown_key(doc, rng):
    tables = [("",)] + [(k,) for k, v in doc.items() if isinstance(v, dict)]
    tables += [("surface", i) for i, s in enumerate(_surfaces(doc)) if isinstance(s, dict)]
    table = rng.choice(tables)
    target = doc if table == ("",) else _get(doc, table)
    key = rng.choice(KEYS)
    if key in target:
        key = key + "2"
    target[key] = rng.choice([1, "x", [1, 2], {"a": 1}, True])
    return f"{_where(table) or 'top'}+{_short(key)}"


def _m_table_type(doc, rng):
    key = rng.choice(["surface", "surface", "shape", "camera", "render", "check", "sweep", "name"])
    value = copy.deepcopy(rng.choice([5, "s", [], [1, 2], {}, [{}], [[]], True, [{"type": 1}]]))
    doc[key] = value
    return f"{key}={_short(value)}"


def _m_check_sweep(doc, rng):
    if rng.random() < 0.5:
        key = rng.choice(["width", "height", "spp", "channels", "fail", "failpercent", "runs"])
        value = rng.choice([BIG, -1, NAN, [], [""], ["R", 1], 101, 0, "all"])
        doc["check"] = {key: value}
        return f"check.{key}={_short(value)}"
    key = rng.choice(["shape.function", "render.width", "a", "shape..x", "surface.1.radius"])
    value = rng.choice([[], ["isophotes", 1], [10**9], [BIG], "mean", [NAN]])
    doc["sweep"] = {key: value}
    return f"sweep.{_short(key)}={_short(value)}"


def _m_duplicate(doc, rng):
    surfaces = _surfaces(doc)
    if not surfaces:
        return None
    k = rng.choice([2, 3, 10, 40])
    doc["surface"] = [copy.deepcopy(s) for _ in range(k) for s in surfaces]
    return f"surface*{k}"


def _bezier(rows: int, cols: int) -> dict:
    return {
        "type": "bezier",
        "points": _grid(
            rows, cols, lambda i, j: (i / (rows - 1), j / max(cols - 1, 1), 0.3 * math.sin(i + j))
        ),
    }


def _m_high_degree(doc, rng):
    surfaces = doc.get("surface")
    if not isinstance(surfaces, list) or not surfaces:
        return None
    op = rng.randrange(3)
    if op == 0:
        new, what = _bezier(41, 4), "bezier-40x3"
    elif op == 1:
        new, what = _bezier(41, 41), "bezier-40x40"
    else:
        new = _bezier(44, 4)  # 44 rows, degree 40: 85 knots
        new.update(type="bspline", degree=[40, 3], knots_v=[0, 0, 0, 0, 1, 1, 1, 1])
        new["knots_u"] = [0.0] * 41 + [0.3, 0.6, 0.8] + [1.0] * 41
        what = "bspline-degree-40"
    surfaces[rng.randrange(len(surfaces))] = new
    return what


# --------------------------------------------------------------------------- text mutations


_NUMBER_LINE = re.compile(r"^([A-Za-z_][\w-]*) = (-?\d[\d.e+-]*)$", re.MULTILINE)


def _t_huge(text, rng):
    lines = list(_NUMBER_LINE.finditer(text))
    digits = "9" * 5000 if rng.random() < 0.5 else "1" + "0" * 4999
    if lines and rng.random() < 0.7:
        m = rng.choice(lines)
        value = rng.choice([digits, "-" + digits, digits + ".5", digits + "e0"])
        new = text[: m.start(2)] + value + text[m.end(2) :]
        return new, f"text:{m.group(1)}=5000digits" + ("-float" if "." in value else "")
    new = re.sub(r"\[\[?[-+]?\d[\d.]*", lambda m: m.group(0)[: m.group(0).rindex("[") + 1] + digits,
                 text, count=1)  # fmt: skip
    return new, "text:first-point=5000digits"


def _t_deep(text, rng):
    op = rng.randrange(5)
    depth = 3000
    if op == 0:
        value, what = "[" * depth + "]" * depth, "balanced-array"
    elif op == 1:
        value, what = "[" * depth, "unbalanced-array"
    elif op == 2:
        value, what = "{a = " * depth + "1" + " }" * depth, "inline-tables"
    elif op == 3:
        return text + "\n[sweep]\n" + "a." * depth + "b = [1]\n", "text:sweep-dotted-key-3000"
    else:
        return "x" + ".x" * depth + " = 1\n" + text, "text:top-dotted-key-3000"
    key = rng.choice(["name", "deep"])
    return f"{key} = {value}\n" + text, f"text:{key}={what}-3000"


def _t_syntax(text, rng):
    op = rng.randrange(14)
    lines = text.split("\n")
    if op == 0:
        cut = rng.randrange(1, len(text))
        return text[:cut], f"text:truncated@{cut}"
    if op == 1:
        i = rng.randrange(len(lines))
        return "\n".join(lines[:i] + lines[i + 1 :]), f"text:line{i + 1}-deleted"
    if op == 2:
        keyed = [i for i, line in enumerate(lines) if " = " in line]
        i = rng.choice(keyed)
        return "\n".join(lines[: i + 1] + lines[i:]), f"text:line{i + 1}-twice"
    if op == 3:
        i = rng.randrange(len(text))
        return text[:i] + "\x00" + text[i:], f"text:raw-NUL@{i}"
    if op == 4:
        i = rng.randrange(len(text))
        return text[:i] + "\udcff\udcfe" + text[i:], f"text:bad-utf8@{i}"
    if op == 5:
        return "\ufeff" + text, "text:BOM"
    if op == 6:
        return text.replace("\n", "\r\n"), "text:CRLF"
    if op == 7:
        return 'name = "unterminated\n' + text, "text:unterminated-string"
    if op == 8:
        return text + "\n[[surface]]\n", "text:empty-surface-table"
    if op == 9:
        return text + "\n[render]\nwidth = 8\n", "text:render-table-twice"
    if op == 10:
        i = rng.randrange(len(text))
        ch = rng.choice(list('[]{}="\\#,.'))
        return text[:i] + ch + text[i + 1 :], f"text:char@{i}={ch!r}"
    if op == 11:
        return 'name = "\\uD800"\n' + text, "text:surrogate-escape"
    if op == 12:
        return 'name = "\\x41"\n' + text, "text:invalid-escape"
    return text + "\n" + "#" * 100_000 + "\n", "text:100k-comment"


_DICT_KINDS = {
    "delete": (_m_delete, 8),
    "wrong_type": (_m_wrong_type, 10),
    "number": (_m_number, 14),
    "settings": (_m_settings, 10),
    "camera": (_m_camera, 5),
    "shape": (_m_shape, 6),
    "ragged": (_m_ragged, 9),
    "degenerate": (_m_degenerate, 9),
    "zero_sphere": (_m_zero_sphere, 1),
    "name": (_m_name, 6),
    "unknown_key": (_m_unknown_key, 3),
    "table_type": (_m_table_type, 3),
    "check_sweep": (_m_check_sweep, 2),
    "duplicate": (_m_duplicate, 3),
    "high_degree": (_m_high_degree, 3),
}
_TEXT_KINDS = {
    "huge_text": (_t_huge, 2),
    "deep_text": (_t_deep, 2),
    "syntax": (_t_syntax, 6),
}
_ALL = {**_DICT_KINDS, **_TEXT_KINDS}


@lru_cache(maxsize=1)
def _bases() -> tuple[tuple[str, dict], ...]:
    out = []
    for path in sorted(SCENES.glob("*.toml")):
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
        render = doc.setdefault("render", {})
        render.update(SMALL_RENDER)
        out.append((path.stem, doc))
    return tuple(out)


def _clean(text: str) -> str:
    text = ascii(text)[1:-1] if not text.isascii() else text
    text = re.sub(r"[^\x21-\x7e]", "_", text)
    return text if len(text) <= 70 else text[:69] + "~"


def cases(count: int, seed: int = 1) -> list[Case]:
    """``count`` mutated scenes; case ``i`` depends only on ``(seed, i)``."""
    out = []
    kinds = list(_ALL)
    weights = [_ALL[k][1] for k in kinds]
    for i in range(count):
        rng = random.Random(f"gshade-fuzz:{seed}:{i}")
        stem, base = rng.choice(_bases())
        order = [rng.choices(kinds, weights)[0], *rng.sample(kinds, len(kinds))]
        for kind in order:
            doc = copy.deepcopy(base)
            fn = _ALL[kind][0]
            if kind in _TEXT_KINDS:
                text, what = fn(dumps(doc), rng)
            else:
                what = fn(doc, rng)
                if what is None:
                    continue
                text = dumps(doc)
            break
        size = what.startswith("size:")
        what = what.removeprefix("size:")
        label = f"{i:04d}-{stem}-{kind}:{_clean(what)}"
        out.append(Case(label, text, stem, kind, size))
    return out


def _probe_list() -> list[tuple[str, str, Any]]:
    """(scene stem, description, edit): the issue's named cases, always the same."""

    def render(**kw):
        return lambda d: d["render"].update(kw)

    def surface(**kw):
        return lambda d: d["surface"][0].update(kw)

    def text(fn):
        return ("text", fn)

    deep = "[" * 3000
    return [
        ("junction-g2", "size:render.width=100000000", render(width=10**8)),
        ("junction-g2", "size:render.height=2147483648", render(height=2**31)),
        ("junction-g2", "size:render.spp=1099511627776", render(spp=2**40)),
        ("junction-g2", "size:render.tessellation=1000000", render(tessellation=10**6)),
        ("junction-g2", "size:render.tessellation=401digits", render(tessellation=BIG)),
        ("junction-g2", "size:render.width=height=65536", render(width=65536, height=65536)),
        ("junction-g2", "render.texture_resolution=401digits", render(texture_resolution=BIG)),
        ("junction-g2", "render.seed=18446744073709551616", render(seed=2**64)),
        ("coons-mean", "render.chord_tolerance=5e-324", render(chord_tolerance=5e-324)),
        (
            "teapot-mean",
            "camera.fov=1e-300",
            lambda d: d.setdefault("camera", {}).update(fov=1e-300),
        ),
        (
            "teapot-isophotes",
            "text:render.spp=5000digits",
            text(lambda t: re.sub(r"(?m)^spp = .*$", "spp = " + "9" * 5000, t)),
        ),
        (
            "teapot-isophotes",
            "text:name=3000-nested-arrays",
            text(lambda t: f"name = {deep}{']' * 3000}\n" + t),
        ),
        (
            "teapot-isophotes",
            "text:name=3000-open-brackets",
            text(lambda t: f"name = {deep}\n" + t),
        ),
        (
            "junction-g2",
            "surface.0=bezier-40x40",
            lambda d: d["surface"].__setitem__(0, _bezier(41, 41)),
        ),
        ("sphere-isophotes", "surface.0.radius=5e-324", surface(radius=5e-324)),
        ("sphere-isophotes", "surface.0.radius=0", surface(radius=0)),
        (
            "junction-g2",
            "surface.0.points:all-equal",
            surface(points=_grid(4, 4, lambda i, j: (1, 2, 3))),
        ),
        (
            "junctions-mean",
            "surface.0.points.1:ragged",
            lambda d: d["surface"][0]["points"][1].pop(),
        ),
        ("teapot-isophotes", "name=300-chars", lambda d: d.update(name="n" * 300)),
        (
            "teapot-isophotes",
            "name=NUL-RTL-emoji",
            lambda d: d.update(name="a\x00\u202e\U0001f600/../b"),
        ),
        ("teapot-isophotes", "name=../../x", lambda d: d.update(name="../../x")),
        ("teapot-isophotes", "surface*40", lambda d: d.update(surface=d["surface"] * 40)),
        ("teapot-isophotes", "top+unknown-key", lambda d: d.update(colour="red")),
        ("junction-g2", "surface.0-type", lambda d: d["surface"][0].pop("type")),
        ("subdivision-cube-mean", "surface.0.levels=4", surface(levels=4)),
        # found by the hostile run (SIGSEGV in the render at 5f3a0ed)
        (
            "teapot-gaussian",
            "camera.origin-only=[0,0,0]",
            lambda d: d.setdefault("camera", {}).update(origin=[0, 0, 0]),
        ),
        (
            "subdivision-valence-zebra",
            "camera.fov=1e-300",
            lambda d: d.setdefault("camera", {}).update(fov=1e-300),
        ),
    ]


def probes() -> list[Case]:
    """The mutations the issue names, one each (labels ``P01-...``), independent of the seed."""
    bases = dict(_bases())
    out = []
    for n, (stem, what, edit) in enumerate(_probe_list(), start=1):
        doc = copy.deepcopy(bases[stem])
        if isinstance(edit, tuple):
            kind, text = "probe_text", edit[1](dumps(doc))
        else:
            edit(doc)
            kind, text = "probe", dumps(doc)
        size = what.startswith("size:")
        what = what.removeprefix("size:")
        out.append(Case(f"P{n:02d}-{stem}-{kind}:{_clean(what)}", text, stem, kind, size))
    return out


def mutations(count: int, seed: int = 1) -> list[tuple[str, str]]:
    """``count`` (label, toml_text) pairs; see :func:`cases`."""
    return [(c.label, c.text) for c in cases(count, seed)]


def write_variant(folder: str | Path, case: Case | tuple[str, str], stem: str = "scene") -> Path:
    """Write a variant as ``folder/<stem>.toml`` with a copy of ``scenes/data/`` beside it;
    lone surrogates in the text become the raw bytes they stand for."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    text = case.text if isinstance(case, Case) else case[1]
    if isinstance(case, Case):
        stem = case.stem
    if not (folder / "data").exists():
        shutil.copytree(DATA, folder / "data")
    path = folder / f"{stem}.toml"
    path.write_bytes(text.encode("utf-8", "surrogateescape"))
    return path


if __name__ == "__main__":  # print the labels (and, with --text N, one variant's text)
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=50)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--text", type=int, default=None, help="print case N's text")
    parser.add_argument("--probes", action="store_true", help="the fixed probes first")
    args = parser.parse_args()
    all_cases = (probes() if args.probes else []) + cases(args.count, args.seed)
    if args.text is not None:
        sys.stdout.write(all_cases[args.text].text.encode("utf-8", "surrogateescape").decode(
            "utf-8", "replace"))  # fmt: skip
    else:
        for c in all_cases:
            print(("S " if c.size else "  ") + c.label)


def listing(folder: Path) -> dict[str, tuple[int, int]]:
    """Every file below ``folder`` with its size and modification time (to tell what a run
    wrote)."""
    return {
        str(p.relative_to(folder)): (p.stat().st_size, p.stat().st_mtime_ns)
        for p in folder.rglob("*")
        if p.is_file()
    }


def rss_of(pid: int) -> int:
    """A process's resident memory in bytes (0 once it is gone)."""
    try:
        with open(f"/proc/{pid}/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


#: Seconds a fuzzed case may run (a hang guard, not a speed test).
CASE_TIMEOUT = float(os.environ.get("GSHADE_FUZZ_TIMEOUT", "300"))


class CaseTimeout(BaseException):
    """Raised by SIGALRM (a BaseException: ``except Exception`` in gshade must not eat it)."""


@contextmanager
def alarm(seconds: float):
    """Raise :class:`CaseTimeout` in this (main) thread after ``seconds``."""

    def on_alarm(signum, frame):
        raise CaseTimeout(f"still running after {seconds:g} s")

    old = signal.signal(signal.SIGALRM, on_alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
