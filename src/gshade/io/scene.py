"""Scene files (TOML): the surfaces, the shape function and its display, camera and render.

The keys are a public contract::

    name = "teapot-isophotes"          # optional, default: the file's stem
    [[surface]]                        # one or more
    type = "newell"                    # newell|bezier|bspline|coons|sphere|torus|cylinder
    file = "data/teapot.txt"           # newell: relative to the scene file; up = "z" | "y" | "x"
    # bezier:   points = [[[x, y, z], ...], ...], weights = [[...], ...] (optional)
    # bspline:  degree = [p, q], knots_u = [...], knots_v = [...], points, weights (optional)
    # coons:    v0, v1, u0, u1 = Bézier control points of p(u, 0), p(u, 1), p(0, v), p(1, v);
    #           cross_v0, cross_v1, cross_u0, cross_u1 (optional: bicubic blending)
    # sphere:   radius = 1;  torus: major = 2, minor = 0.5;  cylinder: radius = 1, height = 1
    # subdivision: file = "data/cube.obj" (a quad mesh, relative to the scene file),
    #           levels = 0 (refinement steps before the patches are made, 0 to 4)
    [shape]
    function = "isophotes"             # a name in gshade.shape.SHAPE_FUNCTIONS
    light = [0, 0, 1]                  # the function's parameters, by name
    display = "stripes"                # stripes | colormap | both
    period = 0.1                       # or stripes = 20 (count over the value range), not both
    duty = 0.5                         # in (0, 1)
    phase = 0.0
    range = [-1, 1]                    # colour-map range (default automatic)
    colormap = "viridis"               # a matplotlib colour map
    colour_function = "mean"           # display = "both": colour from this function
    [camera]
    type = "perspective"               # perspective | orthographic
    origin = [6, -8, 5]                # omit origin / target to frame the surfaces automatically
    target = [0, 0, 1.5]
    up = [0, 0, 1]
    fov = 30                           # perspective: horizontal, degrees
    width = 2.0                        # orthographic: view width in scene units
    [render]
    width = 1024, height = 768, spp = 16, lighting = "lit" (| "flat"), seed = 0,
    variant = "auto" (| "llvm_ad_rgb" | "scalar_rgb" | "cuda_ad_rgb"), tessellation (vertices
    per patch side), chord_tolerance = 1e-3 (relative to the bounding-box diagonal),
    texture_resolution (texels per patch side)
    [check]                            # for `gshade check`: width, height, spp, channels,
                                       # fail, failpercent, hardfail, warn, warnpercent

Every error is a :class:`~gshade.errors.GshadeError` whose one-line message names the
file, the table and key, what was expected and what was found, e.g.
``scene.toml: [camera] fov: expected a number in (0, 180), got "wide"``.
"""

from __future__ import annotations

import copy
import difflib
import hashlib
import json
import math
import os
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

from ..errors import GshadeError
from ..geometry import (
    BetaSplinePatch,
    BezierCurve,
    BezierPatch,
    BSplinePatch,
    CoonsPatch,
    Patch,
    cylinder,
    sphere,
    torus,
)
from ..geometry.geometric_splines import ENDS as NU_ENDS
from ..geometry.geometric_splines import NuSplinePatch
from ..geometry.junctions import junction_patch
from ..geometry.regularity import degenerate_patch
from ..geometry.subdivision import subdivision_patches
from ..limits import (
    MAX_DEGREE,
    MAX_IMAGE_SIDE,
    MAX_MAGNITUDE,
    MAX_NESTING,
    MAX_PATCHES,
    MAX_SCENE_FILE_BYTES,
    MAX_SEED,
    MAX_SPP,
    MAX_STRING,
    MAX_SUBDIVISION_LEVELS,
    MAX_TESSELLATION,
    MAX_TEXTURE_RESOLUTION,
    MIN_CHORD_TOLERANCE,
)
from ..shape.functions import SHAPE_FUNCTIONS
from .files import read_bytes
from .newell import read_newell
from .obj import read_obj_mesh
from .outputs import output_name

__all__ = [
    "CAMERA_TYPES",
    "DISPLAYS",
    "LIGHTINGS",
    "SURFACE_TYPES",
    "VARIANTS",
    "Camera",
    "RenderSettings",
    "Scene",
    "Shape",
    "Surface",
    "check_render_settings",
    "load_scene",
    "parse_overrides",
    "parse_scene",
]

SURFACE_TYPES = (
    "newell",
    "bezier",
    "bspline",
    "coons",
    "sphere",
    "torus",
    "cylinder",
    "betaspline",
    "nuspline",
    "junction",
    "subdivision",
)
DISPLAYS = ("stripes", "colormap", "both")
LIGHTINGS = ("lit", "flat")
VARIANTS = ("auto", "llvm_ad_rgb", "scalar_rgb", "cuda_ad_rgb")
CAMERA_TYPES = ("perspective", "orthographic")
NEWELL_UP = ("z", "y", "x")
#: Environment variable: further folders (separated by os.pathsep) that surface data files
#: may lie in besides the scene file's own folder.
DATA_PATH_VARIABLE = "GSHADE_DATA_PATH"

_SURFACE_KEYS = {
    "newell": ("file", "up"),
    "bezier": ("points", "weights"),
    "bspline": ("degree", "knots_u", "knots_v", "points", "weights"),
    "coons": ("v0", "v1", "u0", "u1", "cross_v0", "cross_v1", "cross_u0", "cross_u1"),
    "sphere": ("radius",),
    "torus": ("major", "minor"),
    "cylinder": ("radius", "height"),
    "betaspline": ("points", "beta1", "beta2", "beta1_u", "beta2_u", "beta1_v", "beta2_v"),
    "nuspline": ("points", "nu_u", "nu_v", "knots_u", "knots_v", "ends"),
    "junction": ("points", "continuity", "alpha", "beta", "gamma", "delta", "epsilon", "zeta"),
    "subdivision": ("file", "levels"),
}
_TOP_KEYS = ("name", "surface", "shape", "camera", "render", "check", "sweep")
_SHAPE_KEYS = (
    "function",
    "display",
    "period",
    "stripes",
    "duty",
    "phase",
    "range",
    "colormap",
    "colour_function",
)
_CAMERA_KEYS = ("type", "origin", "target", "up", "fov", "width")
_RENDER_KEYS = (
    "width",
    "height",
    "spp",
    "lighting",
    "variant",
    "seed",
    "tessellation",
    "chord_tolerance",
    "texture_resolution",
    "junctions",
)
_CHECK_KEYS = (
    "width",
    "height",
    "spp",
    "channels",
    "fail",
    "failpercent",
    "hardfail",
    "warn",
    "warnpercent",
    "statistical",
    "runs",
)
_SECTION_KEYS = {
    "shape": _SHAPE_KEYS,
    "camera": _CAMERA_KEYS,
    "render": _RENDER_KEYS,
    "check": _CHECK_KEYS,
}
_DEFAULT_FUNCTION = "isophotes"
#: Shortest direction vector (light, view up, ...) accepted: normalising it stays exact.
_MIN_DIRECTION = 1e-12
_DEFAULT_STRIPES = 20.0
_MISSING: Any = object()


# --------------------------------------------------------------------------- the scene


@dataclass(frozen=True)
class Surface:
    """One ``[[surface]]``: its type, its patches and where it was defined.

    ``source`` is the location used in messages, e.g. ``scene.toml: [[surface]] 1 (newell)``.
    """

    kind: str
    patches: tuple[Patch, ...] = field(repr=False)
    source: str


@dataclass(frozen=True)
class Shape:
    """The ``[shape]`` table: which shape function, its parameters, and how it is shown.

    ``params`` holds the parameters given in the file (validated; vectors as tuples of
    floats) for ``function`` and, with ``display = "both"``, ``colour_function``; the
    functions' own defaults apply to the rest (see :meth:`params_for`).  Exactly one of
    ``period`` and ``stripes`` is set.
    """

    function: str
    params: dict[str, Any]
    display: str
    period: float | None
    stripes: float | None
    duty: float
    phase: float
    value_range: tuple[float, float] | None
    colormap: str | None
    colour_function: str | None

    def params_for(self, function: str) -> dict[str, Any]:
        """The parameters in :attr:`params` that the shape function ``function`` takes."""
        names = SHAPE_FUNCTIONS[function].parameters
        return {k: v for k, v in self.params.items() if k in names}


@dataclass(frozen=True)
class Camera:
    """The ``[camera]`` table.  ``origin`` / ``target`` None: the renderer frames the scene."""

    type: str
    origin: tuple[float, float, float] | None
    target: tuple[float, float, float] | None
    up: tuple[float, float, float]
    fov: float
    width: float | None


@dataclass(frozen=True)
class RenderSettings:
    """The ``[render]`` table.  ``tessellation`` / ``texture_resolution`` None: automatic."""

    width: int
    height: int
    spp: int
    lighting: str
    variant: str
    seed: int
    tessellation: int | None
    chord_tolerance: float
    texture_resolution: int | None
    junctions: bool = False


@dataclass(frozen=True)
class Scene:
    """A validated scene file.

    ``check`` holds the ``[check]`` table's keys as given (``channels`` as a tuple);
    ``data_files`` the surface data files read (resolved paths); ``text_hash`` the sha256
    of the scene's parsed contents (after overrides) and of the data files' bytes.
    """

    name: str
    path: Path | None
    surfaces: tuple[Surface, ...]
    shape: Shape
    camera: Camera
    render: RenderSettings
    check: dict[str, Any]
    data_files: tuple[Path, ...]
    text_hash: str
    #: ``[sweep]``: dotted scene key -> the values ``gshade batch`` renders the scene with
    sweep: dict[str, tuple[Any, ...]] = field(default_factory=dict)

    @property
    def patches(self) -> tuple[Patch, ...]:
        """All patches of all surfaces, in order."""
        return tuple(p for s in self.surfaces for p in s.patches)


# --------------------------------------------------------------------------- messages


def _show(value: Any, limit: int = 60) -> str:
    """A value as it would look in TOML, shortened."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, str):
        text = json.dumps(value, ensure_ascii=False)
    elif isinstance(value, (int, float)):
        text = repr(value)
    elif isinstance(value, list):
        text = "[" + ", ".join(_show(v, limit) for v in value) + "]"
    elif isinstance(value, dict):
        text = "a table {" + ", ".join(value) + "}"
    else:
        text = f"{value} ({type(value).__name__})"
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _one_of(choices: Sequence[str]) -> str:
    return ", ".join(json.dumps(c) for c in choices)


def _suggest(word: str, candidates: Sequence[str]) -> str:
    close = difflib.get_close_matches(word, list(candidates), n=1)
    return f"; did you mean {json.dumps(close[0])}?" if close else ""


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _is_int(x: Any) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


class _Table:
    """Typed access to one TOML table, raising errors that name the file, table and key."""

    def __init__(self, file: str, prefix: str, data: dict[str, Any]) -> None:
        self.file = file
        self.prefix = prefix  # "[camera] ", "[[surface]] 2 (bspline): " or ""
        self.data = data

    def error(self, key: str, message: str) -> GshadeError:
        return GshadeError(f"{self.file}: {self.prefix}{key}: {message}")

    def reject_unknown(self, allowed: Sequence[str], hint: str = "") -> None:
        for key in self.data:
            if key not in allowed:
                raise self.error(
                    key,
                    f"unknown key{_suggest(key, allowed)} (expected one of: "
                    f"{', '.join(allowed)}{hint})",
                )

    def raw(self, key: str, default: Any = _MISSING, expected: str = "") -> Any:
        if key in self.data:
            return self.data[key]
        if default is _MISSING:
            raise self.error(key, f"missing; expected {expected}")
        return default

    def number(
        self,
        key: str,
        default: Any = _MISSING,
        *,
        lo: float | None = None,
        hi: float | None = None,
        closed: bool = False,
        expected: str | None = None,
    ) -> Any:
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
        if not _is_number(x) or not math.isfinite(x):
            raise self.error(key, f"expected {expected}, got {_show(x)}")
        below = lo is not None and (x < lo if closed else x <= lo)
        above = hi is not None and (x > hi if closed else x >= hi)
        if below or above:
            raise self.error(key, f"expected {expected}, got {_show(x)}")
        return float(x)

    def integer(
        self, key: str, default: Any = _MISSING, *, minimum: int = 1, maximum: int | None = None
    ) -> Any:
        expected = {0: "an integer >= 0", 1: "a positive integer"}.get(
            minimum, f"an integer >= {minimum}"
        )
        if maximum is not None:
            expected = f"an integer from {minimum} to {maximum}"
        x = self.raw(key, default, expected)
        if x is default and key not in self.data:
            return x
        if not _is_int(x) or x < minimum or (maximum is not None and x > maximum):
            raise self.error(key, f"expected {expected}, got {_show(x)}")
        return int(x)

    def boolean(self, key: str, default: Any = _MISSING) -> Any:
        value = self.raw(key, default, "true or false")
        if not isinstance(value, bool):
            raise self.error(key, f"expected true or false, got {_show(value)}")
        return value

    def choice(self, key: str, choices: Sequence[str], default: Any = _MISSING) -> Any:
        expected = f"one of {_one_of(choices)}"
        x = self.raw(key, default, expected)
        if x is default and key not in self.data:
            return x
        if x not in choices or not isinstance(x, str):
            suggestion = _suggest(x, choices) if isinstance(x, str) else ""
            raise self.error(key, f"expected {expected}, got {_show(x)}{suggestion}")
        return x

    def string(self, key: str, default: Any = _MISSING, expected: str = "a string") -> Any:
        x = self.raw(key, default, expected)
        if x is default and key not in self.data:
            return x
        if not isinstance(x, str) or not x:
            raise self.error(key, f"expected {expected}, got {_show(x)}")
        return x

    def vector(
        self, key: str, default: Any = _MISSING, *, nonzero: bool = False, what: str = ""
    ) -> Any:
        expected = f"3 numbers [x, y, z]{what}"
        x = self.raw(key, default, expected)
        if x is default and key not in self.data:
            return x
        if (
            not isinstance(x, list)
            or len(x) != 3
            or not all(_is_number(c) and math.isfinite(c) for c in x)
        ):
            raise self.error(key, f"expected {expected}, got {_show(x)}")
        if nonzero and not math.hypot(*x) >= _MIN_DIRECTION:
            raise self.error(
                key,
                f"expected a direction [x, y, z] of length at least {_MIN_DIRECTION:g}, "
                f"got {_show(x)}",
            )
        return (float(x[0]), float(x[1]), float(x[2]))

    def array(self, key: str, levels: Sequence[str], length: int | None = None) -> np.ndarray:
        """Nested lists of numbers, ``len(levels)`` deep, rectangular; ``levels[k]`` says
        what level k holds (for messages); innermost lists of ``length`` numbers if given."""
        x = self.raw(key, expected=levels[0])

        def walk(v: Any, depth: int, where: str) -> None:
            if depth == len(levels):
                if not _is_number(v) or not math.isfinite(v):
                    raise self.error(where, f"expected a finite number, got {_show(v)}")
                return
            if not isinstance(v, list) or not v:
                raise self.error(where, f"expected {levels[depth]}, got {_show(v)}")
            if depth == len(levels) - 1 and length is not None and len(v) != length:
                raise self.error(where, f"expected {levels[depth]}, got {_show(v)}")
            for i, item in enumerate(v):
                walk(item, depth + 1, f"{where}[{i}]")

        walk(x, 0, key)
        if len(levels) == 3:
            lengths = [len(row) for row in x]
            if len(set(lengths)) > 1:
                raise self.error(
                    key,
                    f"expected {levels[0]}, every row of the same length, got rows of "
                    f"{', '.join(map(str, lengths))} points",
                )
        elif len(levels) == 2 and length is None:
            lengths = [len(row) for row in x]
            if len(set(lengths)) > 1:
                raise self.error(
                    key,
                    f"expected {levels[0]}, every row of the same length, got rows of lengths "
                    f"{', '.join(map(str, lengths))}",
                )
        return np.asarray(x, dtype=np.float64)


def _location(parts: Sequence[str | int], raw: dict[str, Any]) -> str:
    """Where a value sits, as messages name it: ``[[surface]] 2 (bezier): points[0][3]``,
    ``[camera] fov``, ``name``."""
    rest = list(parts)
    head = ""
    if len(rest) >= 2 and rest[0] == "surface" and isinstance(rest[1], int):
        table = raw["surface"][rest[1]]
        kind = table.get("type") if isinstance(table, dict) else None
        shown = f" ({kind})" if isinstance(kind, str) and kind in SURFACE_TYPES else ""
        head, rest = f"[[surface]] {rest[1] + 1}{shown}: ", rest[2:]
    elif len(rest) >= 2 and isinstance(rest[0], str) and isinstance(rest[1], str):
        head, rest = f"[{rest[0]}] ", rest[1:]
    text = ""
    for p in rest:
        text += f"[{p}]" if isinstance(p, int) else (f".{p}" if text else p)
    return (head + text).strip().rstrip(":") or "(top level)"


def _check_values(file: str, raw: dict[str, Any]) -> None:
    """Bounds every scene value must meet whatever its key: numbers finite and within
    ±MAX_MAGNITUDE (integers too: no overflow when they become floats), strings of at
    most MAX_STRING characters, keys short and printable, nesting at most MAX_NESTING
    deep.  One iterative pass, so that no depth or size of input can exhaust the stack."""
    stack: list[tuple[Any, tuple[str | int, ...]]] = [(raw, ())]
    while stack:
        value, parts = stack.pop()
        if len(parts) > MAX_NESTING:
            raise GshadeError(
                f"{file}: {_location(parts[:3], raw)}: expected arrays and tables nested at most "
                f"{MAX_NESTING} deep, got deeper ones"
            )
        if isinstance(value, dict):
            for key, item in value.items():
                if len(key) > 64 or not key.isprintable():
                    where = _location(parts, raw) if parts else "a key"
                    raise GshadeError(
                        f"{file}: {where}: expected keys of at most 64 printable characters, "
                        f"got {json.dumps(key[:40])}" + ("…" if len(key) > 40 else "")
                    )
                stack.append((item, (*parts, key)))
            stack[len(stack) - len(value) :] = reversed(stack[len(stack) - len(value) :])
        elif isinstance(value, list):  # pushed last to first: the first offender is reported
            stack.extend((value[k], (*parts, k)) for k in range(len(value) - 1, -1, -1))
        elif isinstance(value, bool):
            continue
        elif isinstance(value, (int, float)):
            if not abs(value) <= MAX_MAGNITUDE:  # NaN fails as well
                shown = _show(value) if isinstance(value, float) else _big(value)
                raise GshadeError(
                    f"{file}: {_location(parts, raw)}: expected a finite number within "
                    f"±{MAX_MAGNITUDE:g}, got {shown}"
                )
        elif isinstance(value, str) and len(value) > MAX_STRING:
            raise GshadeError(
                f"{file}: {_location(parts, raw)}: expected a string of at most {MAX_STRING} "
                f"characters, got {len(value)}"
            )


def _big(x: int) -> str:
    digits = str(abs(x))
    sign = "-" if x < 0 else ""
    return f"{sign}{digits[:3]}…({len(digits)} digits)" if len(digits) > 20 else f"{x}"


@contextmanager
def _reported(prefix: str) -> Iterator[None]:
    """Prefix the message of a GshadeError raised inside (by a patch constructor, ...)."""
    try:
        yield
    except GshadeError as exc:
        raise GshadeError(f"{prefix}{exc}") from None


def _table(file: str, raw: dict[str, Any], name: str) -> dict[str, Any]:
    value = raw.get(name, {})
    if not isinstance(value, dict):
        raise GshadeError(f"{file}: {name}: expected a table [{name}], got {_show(value)}")
    return value


# --------------------------------------------------------------------------- surfaces


def _number_or_list(t: _Table, key: str, count: int, what: str, *, positive: bool) -> Any:
    """A number (one value for all) or a list of ``count`` numbers; None if absent."""
    bound = "> 0" if positive else ">= 0"
    expected = f"a number {bound} or a list of {count} numbers {bound} ({what})"
    x = t.raw(key, None, expected)
    if x is None:
        return None

    def ok(v: Any) -> bool:
        return _is_number(v) and math.isfinite(v) and (v > 0 if positive else v >= 0)

    if ok(x):
        return float(x)
    if isinstance(x, list) and count > 0 and len(x) == count and all(ok(v) for v in x):
        return [float(v) for v in x]
    found = f" ({len(x)} numbers)" if isinstance(x, list) and len(x) != count else ""
    raise t.error(key, f"expected {expected}, got {_show(x)}{found}")


_NET = ("(m+1) rows of n+1 points [x, y, z]", "a row of points [x, y, z]", "a point [x, y, z]")
_WEIGHTS = ("(m+1) rows of n+1 positive numbers", "a row of positive numbers")
_CURVE = ("a list of Bézier control points [x, y, z]", "a point [x, y, z]")


def _bezier_net(t: _Table, key: str, levels: Sequence[str] = _NET) -> np.ndarray:
    """A Bézier control net (or, with ``_CURVE`` levels, polygon) of degree at most
    ``MAX_DEGREE`` in each direction."""
    points = t.array(key, levels, 3)
    degree = max(points.shape[:-1]) - 1
    if degree > MAX_DEGREE:
        raise t.error(
            key,
            f"expected at most {MAX_DEGREE + 1} points per row and column (degree "
            f"{MAX_DEGREE}), got degree {degree}",
        )
    return points


def _data_roots(base: Path, data_path: Sequence[str | os.PathLike] | None) -> list[Path]:
    """The folders data files may lie in: the scene's own and ``data_path`` (default: the
    environment's ``GSHADE_DATA_PATH``)."""
    if data_path is None:
        data_path = [p for p in os.environ.get(DATA_PATH_VARIABLE, "").split(os.pathsep) if p]
    roots = []
    for folder in [base, *data_path]:
        try:
            roots.append(Path(folder).resolve())
        except (OSError, ValueError, RuntimeError):
            continue
    return roots


def _data_file(t: _Table, base: Path, name: str, roots: Sequence[Path]) -> Path:
    """The data file a surface's ``file`` key names (relative to the scene file), checked to
    lie within one of ``roots`` once symbolic links are resolved."""
    data_file = base / name
    try:
        resolved = data_file.resolve()
        exists = resolved.is_file()
    except (OSError, ValueError, RuntimeError) as exc:
        raise t.error(
            "file",
            f"expected a path to an existing file, got {_show(name)} "
            f"({getattr(exc, 'strerror', None) or 'not a usable path'})",
        ) from None
    if not any(resolved.is_relative_to(root) for root in roots):
        raise t.error(
            "file",
            f"expected a file within the scene's folder {roots[0]} (or a folder in "
            f"{DATA_PATH_VARIABLE}), got {_show(name)}",
        )
    if not exists:
        raise t.error(
            "file",
            f"expected an existing file (relative to the scene file), got {_show(name)} "
            f"(no such file: {data_file})",
        )
    return data_file


def _surface(
    file: str, index: int, raw: Any, base: Path, roots: Sequence[Path]
) -> tuple[Surface, Path | None]:
    head = f"[[surface]] {index}"
    if not isinstance(raw, dict):
        raise GshadeError(f"{file}: {head}: expected a table, got {_show(raw)}")
    kind = raw.get("type", _MISSING)
    if kind is _MISSING:
        raise GshadeError(
            f"{file}: {head}: type: missing; expected one of {_one_of(SURFACE_TYPES)}"
        )
    if kind not in SURFACE_TYPES or not isinstance(kind, str):
        hint = _suggest(kind, SURFACE_TYPES) if isinstance(kind, str) else ""
        raise GshadeError(
            f"{file}: {head}: type: expected one of {_one_of(SURFACE_TYPES)}, got {_show(kind)}"
            f"{hint}"
        )
    where = f"{head} ({kind}): "
    t = _Table(file, where, raw)
    t.reject_unknown(("type", *_SURFACE_KEYS[kind]))
    data_file = None
    reported = _reported(f"{file}: {where}")
    if kind == "newell":
        name = t.string("file", expected="a path to a file in Newell's format")
        up = t.choice("up", NEWELL_UP, "z")
        data_file = _data_file(t, base, name, roots)
        with reported:
            patches = read_newell(data_file, up=up)
    elif kind == "subdivision":
        name = t.string("file", expected="a path to an OBJ file (a quad mesh)")
        levels = t.integer("levels", 0, minimum=0)
        if levels > MAX_SUBDIVISION_LEVELS:
            raise t.error(
                "levels",
                f"expected an integer from 0 to {MAX_SUBDIVISION_LEVELS} (each level multiplies "
                f"the patches by 4), got {_show(raw['levels'])}",
            )
        data_file = _data_file(t, base, name, roots)
        with reported:
            mesh = read_obj_mesh(data_file)
        if len(mesh.faces) * 4**levels > MAX_PATCHES:
            raise t.error(
                "levels",
                f"expected at most {MAX_PATCHES} patches, got {len(mesh.faces)} faces x "
                f"4^{levels} levels = {len(mesh.faces) * 4**levels}",
            )
        with _reported(f"{file}: {where}"):
            patches = subdivision_patches(
                mesh.vertices,
                mesh.faces,
                levels=levels,
                source=str(data_file),
                face_lines=mesh.face_lines,
            )
    elif kind == "bezier":
        points = _bezier_net(t, "points")
        weights = t.array("weights", _WEIGHTS) if "weights" in raw else None
        with reported:
            patches = [BezierPatch(points, weights)]
    elif kind == "bspline":
        degree = t.raw("degree", expected="[p, q], two integers >= 1")
        if not (
            isinstance(degree, list)
            and len(degree) == 2
            and all(_is_int(d) and 1 <= d <= MAX_DEGREE for d in degree)
        ):
            raise t.error(
                "degree",
                f"expected [p, q], two integers from 1 to {MAX_DEGREE}, got {_show(degree)}",
            )
        knots = [
            t.array(k, (f"a list of knots ({d}: number of points + degree + 1 numbers)",))
            for k, d in (("knots_u", "u"), ("knots_v", "v"))
        ]
        points = t.array("points", _NET, 3)
        weights = t.array("weights", _WEIGHTS) if "weights" in raw else None
        with reported:
            patches = [BSplinePatch(points, tuple(degree), tuple(knots), weights)]
    elif kind == "coons":
        curves = {}
        for key in _SURFACE_KEYS["coons"]:
            if key in ("v0", "v1", "u0", "u1") or key in raw:
                points = _bezier_net(t, key, _CURVE)
                with _reported(f"{file}: {where}{key}: "):
                    curves[key] = BezierCurve(points)
        with reported:
            patches = [CoonsPatch(**curves)]
    elif kind == "junction":
        points = _bezier_net(t, "points")
        continuity = t.choice("continuity", ("G0", "G1", "G2", "G3"))
        connection = {
            key: t.number(key, default)
            for key, default in (
                ("alpha", 0.0),
                ("beta", 1.0),
                ("gamma", 0.0),
                ("delta", 0.0),
                ("epsilon", 0.0),
                ("zeta", 0.0),
            )
        }
        with reported:
            first = BezierPatch(points)
            patches = [first, junction_patch(first, continuity, **connection)]
    elif kind == "betaspline":
        points = t.array("points", _NET, 3)
        if min(points.shape[:2]) < 4:
            raise t.error(
                "points",
                f"expected at least 4 rows of at least 4 points (a cubic β-spline), got "
                f"{points.shape[0]} rows of {points.shape[1]}",
            )
        beta1 = t.number("beta1", 1.0, lo=0)
        beta2 = t.number("beta2", 0.0, lo=0, closed=True)
        per_direction = {}
        for d, rows in (("u", points.shape[0]), ("v", points.shape[1])):
            what = f"one per interior junction in {d}: {'rows' if d == 'u' else 'points per row'}"
            what += f" ({rows}) - 4"
            for key, positive in ((f"beta1_{d}", True), (f"beta2_{d}", False)):
                per_direction[key] = _number_or_list(t, key, rows - 4, what, positive=positive)
        with reported:
            patches = [BetaSplinePatch(points, beta1, beta2, **per_direction)]
    elif kind == "nuspline":
        points = t.array("points", _NET, 3)
        ends = t.raw("ends", "natural")
        if not (
            ends in NU_ENDS
            or (isinstance(ends, list) and len(ends) == 2 and all(e in NU_ENDS for e in ends))
        ):
            raise t.error(
                "ends",
                f"expected one of {_one_of(NU_ENDS)} or a pair [u, v] of them, got {_show(ends)}",
            )
        closed = [e == "closed" for e in ([ends] * 2 if isinstance(ends, str) else ends)]
        given: dict[str, Any] = {"ends": tuple(ends) if isinstance(ends, list) else ends}
        for k, d in enumerate("uv"):
            count = points.shape[k]
            rows = "rows" if d == "u" else "points per row"
            if f"knots_{d}" in raw:
                wrap = " + 1, closed" if closed[k] else ""
                expected = f"a list of {count + closed[k]} increasing knots ({count} {rows}{wrap})"
                given[f"knots_{d}"] = t.array(f"knots_{d}", (expected,))
            nu = _number_or_list(
                t, f"nu_{d}", count, f"one per knot: {count} {rows}", positive=False
            )
            given[f"nu_{d}"] = 0.0 if nu is None else nu
        with reported:
            patches = [NuSplinePatch(points, **given)]
    elif kind == "sphere":
        radius = t.number("radius", 1.0, lo=0)
        patches = [sphere(radius)]
    elif kind == "torus":
        major = t.number("major", 2.0, lo=0)
        minor = t.number("minor", 0.5, lo=0)
        with reported:
            patches = [torus(major, minor)]
    else:  # cylinder
        radius = t.number("radius", 1.0, lo=0)
        height = t.number("height", 1.0, lo=0)
        patches = [cylinder(radius, height)]
    return Surface(kind, tuple(patches), f"{file}: {head} ({kind})"), data_file


# --------------------------------------------------------------------------- tables


def _function_names(shape: dict[str, Any]) -> list[str]:
    """The known shape functions a [shape] table selects (function, colour_function)."""
    names = [shape.get("function", _DEFAULT_FUNCTION), shape.get("colour_function")]
    return [n for n in names if isinstance(n, str) and n in SHAPE_FUNCTIONS]


def _shape_keys(shape: dict[str, Any]) -> tuple[str, ...]:
    params = [p for n in _function_names(shape) for p in SHAPE_FUNCTIONS[n].parameters]
    return (*_SHAPE_KEYS, *dict.fromkeys(params))


def _parameter(t: _Table, fn: str, name: str) -> Any:
    spec = SHAPE_FUNCTIONS[fn].parameters[name]
    what = f" (parameter of {fn}: {spec.help})"
    if spec.kind == "choice":
        return t.choice(name, spec.choices)
    if spec.kind in ("direction", "vector"):
        return t.vector(name, nonzero=True, what=what)
    if spec.kind == "point":
        return t.vector(name, what=what)
    return t.number(name, expected=f"a number{what}")


def _shape(file: str, raw: dict[str, Any]) -> Shape:
    t = _Table(file, "[shape] ", raw)
    function = t.choice("function", tuple(SHAPE_FUNCTIONS), _DEFAULT_FUNCTION)
    colour_function = t.choice("colour_function", tuple(SHAPE_FUNCTIONS), None)
    functions = [function] + ([colour_function] if colour_function else [])
    t.reject_unknown(
        _shape_keys(raw),
        f"; parameters of {' and '.join(functions)}: "
        + (", ".join(p for f in functions for p in SHAPE_FUNCTIONS[f].parameters) or "none"),
    )
    params = {}
    for key in raw:
        if key not in _SHAPE_KEYS:
            for fn in functions:
                if key in SHAPE_FUNCTIONS[fn].parameters:
                    params[key] = _parameter(t, fn, key)
    display = t.choice("display", DISPLAYS, "stripes")
    period = t.number("period", None, lo=0)
    stripes = t.number("stripes", None, lo=0)
    if period is not None and stripes is not None:
        raise t.error(
            "stripes",
            f"expected either period or stripes, not both, got period = {_show(raw['period'])} "
            f"and stripes = {_show(raw['stripes'])}",
        )
    if period is None and stripes is None:
        stripes = _DEFAULT_STRIPES
    duty = t.number("duty", 0.5, lo=0, hi=1)
    phase = t.number("phase", 0.0)
    value_range = None
    if "range" in raw:
        r = raw["range"]
        if not (
            isinstance(r, list)
            and len(r) == 2
            and all(_is_number(x) and math.isfinite(x) for x in r)
        ):
            raise t.error("range", f"expected [min, max], two numbers, got {_show(r)}")
        if not r[0] < r[1]:
            raise t.error("range", f"expected [min, max] with min < max, got {_show(r)}")
        value_range = (float(r[0]), float(r[1]))
    colormap = t.string("colormap", None, expected="the name of a matplotlib colour map")
    if colormap is not None:
        import matplotlib

        if colormap not in matplotlib.colormaps:
            raise t.error(
                "colormap",
                f'expected the name of a matplotlib colour map (e.g. "viridis"), got '
                f"{_show(colormap)}{_suggest(colormap, list(matplotlib.colormaps))}",
            )
    return Shape(
        function,
        params,
        display,
        period,
        stripes,
        duty,
        phase,
        value_range,
        colormap,
        colour_function,
    )


def _camera(file: str, raw: dict[str, Any]) -> Camera:
    t = _Table(file, "[camera] ", raw)
    t.reject_unknown(_CAMERA_KEYS)
    kind = t.choice("type", CAMERA_TYPES, "perspective")
    origin = t.vector("origin", None)
    target = t.vector("target", None)
    up = t.vector("up", (0.0, 0.0, 1.0), nonzero=True)
    fov = t.number("fov", 30.0, lo=1e-3, hi=180)
    width = t.number("width", None, lo=1e-12)
    if origin is not None and target is not None:
        view = np.subtract(target, origin)
        if not np.any(view):
            raise t.error(
                "target", f"expected a point other than origin, got {_show(raw['target'])}"
            )
        if np.linalg.norm(np.cross(view, up)) <= 1e-9 * np.linalg.norm(view) * np.linalg.norm(up):
            raise t.error(
                "up",
                f"expected a direction not parallel to target - origin {view.tolist()}, "
                f"got {_show(raw.get('up', [0, 0, 1]))}",
            )
    return Camera(kind, origin, target, up, fov, width)


def _render(file: str, raw: dict[str, Any]) -> RenderSettings:
    t = _Table(file, "[render] ", raw)
    t.reject_unknown(_RENDER_KEYS)
    return RenderSettings(
        width=t.integer("width", 1024, maximum=MAX_IMAGE_SIDE),
        height=t.integer("height", 768, maximum=MAX_IMAGE_SIDE),
        spp=t.integer("spp", 16, maximum=MAX_SPP),
        lighting=t.choice("lighting", LIGHTINGS, "lit"),
        variant=t.choice("variant", VARIANTS, "auto"),
        seed=t.integer("seed", 0, minimum=0, maximum=MAX_SEED),
        tessellation=t.integer("tessellation", None, minimum=2, maximum=MAX_TESSELLATION),
        chord_tolerance=t.number(
            "chord_tolerance", 1e-3, lo=MIN_CHORD_TOLERANCE, hi=1, closed=True
        ),
        texture_resolution=t.integer(
            "texture_resolution", None, minimum=1, maximum=MAX_TEXTURE_RESOLUTION
        ),
        junctions=t.boolean("junctions", False),
    )


def check_render_settings(settings: RenderSettings, source: str = "render") -> RenderSettings:
    """Render settings built in Python (``gshade.render(scene, width=...)``) checked as the
    ``[render]`` table is; ``source`` names them in messages."""
    from dataclasses import asdict

    return _render(source, {k: v for k, v in asdict(settings).items() if v is not None})


def _check(file: str, raw: dict[str, Any]) -> dict[str, Any]:
    t = _Table(file, "[check] ", raw)
    t.reject_unknown(_CHECK_KEYS)
    out: dict[str, Any] = {}
    for key in raw:
        if key in ("width", "height"):
            out[key] = t.integer(key, maximum=MAX_IMAGE_SIDE)
        elif key == "spp":
            out[key] = t.integer(key, maximum=MAX_SPP)
        elif key == "runs":
            out[key] = t.integer(key, maximum=64)
        elif key == "statistical":
            out[key] = t.boolean(key)
        elif key == "channels":
            c = raw[key]
            if not (isinstance(c, list) and c and all(isinstance(s, str) and s for s in c)):
                raise t.error(key, f"expected a list of channel names (strings), got {_show(c)}")
            out[key] = tuple(c)
        elif key in ("failpercent", "warnpercent"):
            out[key] = t.number(key, lo=0, hi=100, closed=True)
        else:
            out[key] = t.number(key, lo=0, closed=True)
    return out


def _sweep(file: str, raw: dict[str, Any], prefix: str = "") -> dict[str, tuple[Any, ...]]:
    """``[sweep]``: dotted keys (quoted, ``"shape.function" = [...]``, or nested tables) to
    non-empty lists of values; the keys are checked when a batch applies them."""
    out: dict[str, tuple[Any, ...]] = {}
    for key, value in raw.items():
        dotted = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(_sweep(file, value, f"{dotted}."))
        elif isinstance(value, list) and value:
            if "." not in dotted:
                raise GshadeError(
                    f"{file}: [sweep] {dotted}: expected a dotted scene key such as "
                    f'"shape.function", got {dotted!r}'
                )
            out[dotted] = tuple(value)
        else:
            raise GshadeError(
                f"{file}: [sweep] {dotted}: expected a non-empty list of values, got {_show(value)}"
            )
    return out


# --------------------------------------------------------------------------- overrides


def _parse_value(text: str) -> Any:
    try:
        parsed = tomllib.loads(f"x = {text}")
    except (tomllib.TOMLDecodeError, ValueError, RecursionError):
        return text
    return parsed["x"] if list(parsed) == ["x"] else text


def parse_overrides(items: Sequence[str]) -> dict[str, Any]:
    """Parse ``--set key=value`` items into overrides for :func:`load_scene`.

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
        If an item has no ``=`` or its key is empty or malformed.
    """
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = str(item).partition("=")
        key = key.strip()
        if not sep or not key or any(not part.strip() for part in key.split(".")):
            raise GshadeError(
                f"--set {item}: expected key=value with a dotted key, e.g. shape.period=0.05"
            )
        out[".".join(part.strip() for part in key.split("."))] = _parse_value(value.strip())
    return out


_FUNCTION_KEYS = ("shape.function", "shape.colour_function")
_EXCLUSIVE = {"shape.period": "shape.stripes", "shape.stripes": "shape.period"}


def _apply_overrides(file: str, raw: dict[str, Any], overrides: dict[str, Any]) -> dict[str, Any]:
    """The scene dict with the overrides applied (checking that their keys exist)."""
    raw = copy.deepcopy(raw)
    sections = ("name", *_SECTION_KEYS, "surface.N")

    def fail(key: str, message: str) -> GshadeError:
        return GshadeError(f"{file}: --set {key}: {message}")

    def section(key: str, name: str) -> dict[str, Any]:
        table = raw.setdefault(name, {})
        if not isinstance(table, dict):
            raise fail(key, f"expected [{name}] to be a table in the scene, got {_show(table)}")
        return table

    shape = raw.get("shape", {})
    before = set(_function_names(shape)) if isinstance(shape, dict) else set()
    # The functions first: they decide which shape parameters are keys.
    ordered = sorted(overrides.items(), key=lambda kv: kv[0] not in _FUNCTION_KEYS)
    for key, value in ordered:
        parts = key.split(".")
        if parts == ["name"]:
            raw["name"] = value
        elif parts[0] in _SECTION_KEYS and len(parts) == 2:
            table = section(key, parts[0])
            allowed = _shape_keys(table) if parts[0] == "shape" else _SECTION_KEYS[parts[0]]
            if parts[1] not in allowed:
                raise fail(
                    key,
                    f"unknown key {json.dumps(parts[1])} in [{parts[0]}]"
                    f"{_suggest(parts[1], allowed)} (expected one of: {', '.join(allowed)})",
                )
            table[parts[1]] = value
            other = _EXCLUSIVE.get(key)
            if other is not None and other not in overrides:
                table.pop(other.split(".")[1], None)  # period replaces stripes, and vice versa
        elif parts[0] == "surface" and len(parts) == 3:
            surfaces = raw.get("surface")
            count = len(surfaces) if isinstance(surfaces, list) else 0
            if not (parts[1].isdigit() and 1 <= int(parts[1]) <= count):
                raise fail(
                    key,
                    f"expected a surface number from 1 to {count}, got {json.dumps(parts[1])}",
                )
            surface = surfaces[int(parts[1]) - 1]
            kind = surface.get("type") if isinstance(surface, dict) else None
            allowed = ("type", *_SURFACE_KEYS.get(kind, ())) if kind in _SURFACE_KEYS else None
            if allowed is not None and parts[2] not in allowed:
                raise fail(
                    key,
                    f"unknown key {json.dumps(parts[2])} for a {kind} surface"
                    f"{_suggest(parts[2], allowed)} (expected one of: {', '.join(allowed)})",
                )
            if isinstance(surface, dict):
                surface[parts[2]] = value
        else:
            head = parts[0] if parts[0] in _SECTION_KEYS or parts[0] == "surface" else None
            if head is None:
                raise fail(
                    key,
                    f"unknown section {json.dumps(parts[0])}{_suggest(parts[0], sections)} "
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
    now = set(_function_names(shape))
    keep = {p for n in now for p in SHAPE_FUNCTIONS[n].parameters}
    stale = {p for n in before - now for p in SHAPE_FUNCTIONS[n].parameters} - keep
    for key in stale - set(_SHAPE_KEYS):
        shape.pop(key, None)


# --------------------------------------------------------------------------- loading


def _hash(raw: dict[str, Any], data_files: Sequence[Path]) -> str:
    h = hashlib.sha256(b"gshade-scene-1\0")
    text = json.dumps(raw, sort_keys=True, separators=(",", ":"), ensure_ascii=False, default=str)
    h.update(text.encode("utf-8"))
    for f in data_files:
        data = f.read_bytes()
        h.update(b"\0" + len(data).to_bytes(8, "little") + data)
    return h.hexdigest()


def _build(
    text: str,
    file: str,
    path: Path | None,
    base: Path,
    overrides: dict[str, Any] | None,
    data_path: Sequence[str | os.PathLike] | None = None,
) -> Scene:
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise GshadeError(f"{file}: invalid TOML: {exc}") from None
    except ValueError as exc:  # an integer of more than 4300 digits
        raise GshadeError(f"{file}: invalid TOML: {str(exc).split(';')[0]}") from None
    except RecursionError:
        raise GshadeError(
            f"{file}: invalid TOML: arrays or tables nested too deeply (at most {MAX_NESTING})"
        ) from None
    _check_values(file, raw)
    if overrides:
        raw = _apply_overrides(file, raw, dict(overrides))
        _check_values(file, raw)
    top = _Table(file, "", raw)
    top.reject_unknown(_TOP_KEYS)
    if "name" in raw:
        name = output_name(top.string("name", expected="a non-empty string"), f"{file}: name")
    else:
        default = path.stem if path is not None else "scene"
        name = output_name(default, f"{file}: name (the file's stem; set name = ...)")
    if "surface" not in raw:
        raise GshadeError(f"{file}: [[surface]]: missing; expected at least one [[surface]] table")
    tables = raw["surface"]
    if not isinstance(tables, list) or not tables:
        raise GshadeError(
            f"{file}: surface: expected one or more [[surface]] tables (an array of tables), "
            f"got {_show(tables)}"
        )
    # The small tables first, so that their mistakes show before surface data are read.
    shape = _shape(file, _table(file, raw, "shape"))
    camera = _camera(file, _table(file, raw, "camera"))
    render = _render(file, _table(file, raw, "render"))
    check = _check(file, _table(file, raw, "check"))
    sweep = _sweep(file, _table(file, raw, "sweep"))
    surfaces, data_files = [], []
    roots = _data_roots(base, data_path)
    count = 0
    for index, table in enumerate(tables, start=1):
        surface, data_file = _surface(file, index, table, base, roots)
        surfaces.append(surface)
        if data_file is not None and data_file.resolve() not in data_files:
            data_files.append(data_file.resolve())
        count += len(surface.patches)
        if count > MAX_PATCHES:
            raise GshadeError(
                f"{surface.source}: expected at most {MAX_PATCHES} patches in a scene, got "
                f"{count} by this surface"
            )
        bad = degenerate_patch(surface.patches)
        if bad is not None:
            which = f" patch {bad[0]}" if len(surface.patches) > 1 else ""
            raise GshadeError(f"{surface.source}:{which} degenerate: {bad[1]}")
    return Scene(
        name=name,
        path=path,
        surfaces=tuple(surfaces),
        shape=shape,
        camera=camera,
        render=render,
        check=check,
        data_files=tuple(data_files),
        text_hash=_hash(raw, data_files),
        sweep=sweep,
    )


def load_scene(
    path: str | os.PathLike,
    overrides: dict[str, object] | None = None,
    *,
    data_path: Sequence[str | os.PathLike] | None = None,
) -> Scene:
    """Read and validate a scene file.

    Parameters
    ----------
    path : path-like
        The TOML scene file (a regular file of at most 16 MB); surface data files are found
        relative to its directory, and must lie within it (symbolic links resolved).
    overrides : dict, optional
        Dotted key -> value (see :func:`parse_overrides`), applied to the file's contents
        before validation.  When an override changes ``shape.function`` (or
        ``shape.colour_function``), the file's parameters that only the replaced function
        takes are dropped.
    data_path : sequence of path-like, optional
        Further folders data files may lie in; default: those in the environment variable
        ``GSHADE_DATA_PATH`` (separated by ``os.pathsep``).

    Returns
    -------
    Scene

    Raises
    ------
    GshadeError
        One line naming the file, the table and key, what was expected and what was found.
    """
    path = Path(path)
    file = str(path)
    data = read_bytes(path, "a scene file (TOML)", limit=MAX_SCENE_FILE_BYTES)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise GshadeError(
            f"{file}: expected a UTF-8 text file (TOML), got byte {data[exc.start]:#04x} at "
            f"offset {exc.start}"
        ) from None
    return _build(text, file, path, path.parent, overrides, data_path)


def parse_scene(
    text: str,
    *,
    source: str = "<string>",
    base: str | os.PathLike = ".",
    overrides: dict[str, object] | None = None,
    data_path: Sequence[str | os.PathLike] | None = None,
) -> Scene:
    """Validate a scene given as TOML text (``Scene.path`` is None, the default name "scene").

    ``source`` names the text in messages; data files are found relative to ``base`` (and
    must lie within it or ``data_path``).  See :func:`load_scene`.
    """
    return _build(text, source, None, Path(base), overrides, data_path)
