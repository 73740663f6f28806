"""The ``[shape]``, ``[camera]``, ``[render]``, ``[check]`` and ``[sweep]`` tables: each
one's keys, declared once (the parser's allowed keys and defaults, and ``gshade keys``'s
listing), and its parser."""

from __future__ import annotations

import math
from dataclasses import asdict
from pathlib import Path
from typing import Any

from ..display import validate_colormap, validate_range
from ..errors import GshadeError, one_of, show, suggest
from ..limits import (
    MAX_COMB_SECTIONS,
    MAX_IMAGE_SIDE,
    MAX_SEED,
    MAX_SPP,
    MAX_TESSELLATION,
    MAX_TEXTURE_RESOLUTION,
    MIN_CHORD_TOLERANCE,
    MIN_DIRECTION,
)
from ..shape import SHAPE_FUNCTIONS, checked_parameters, function_bands, validate_parameter
from .data_files import DataFiles, data_roots
from .model import (
    CAMERA_TYPES,
    COMB_CURVATURES,
    COMB_LINES,
    DISPLAYS,
    LIGHTINGS,
    SAMPLINGS,
    VARIANTS,
    Camera,
    RenderSettings,
    Shape,
)
from .tables import Key, Table, alternatives, declare_keys, is_number

__all__ = [
    "CAMERA_KEYS",
    "CHECK_KEYS",
    "RENDER_KEYS",
    "SECTION_KEYS",
    "SHAPE_KEYS",
    "function_names",
    "parse_camera",
    "parse_check",
    "parse_render",
    "parse_shape",
    "parse_sweep",
    "shape_keys",
    "validate_render_settings",
]

_FUNCTIONS = "a name in `gshade shapes`"
SHAPE_KEYS = declare_keys(
    Key("function", _FUNCTIONS, "isophotes", "the shape function"),
    Key("display", alternatives(DISPLAYS), "stripes", "how its values are shown"),
    Key("period", "number > 0", None, "stripes: distance in f from one dark stripe to the next"),
    Key(
        "stripes",
        "number > 0",
        20.0,
        "or: the stripe count over the value range",
        "20 if no period",
    ),
    Key("duty", "number in (0, 1)", 0.5, "the dark fraction of each period"),
    Key("phase", "number", 0.0, "in periods"),
    Key("range", "[min, max], min < max", None, "the colour-map range", "automatic"),
    Key("colormap", "a matplotlib colour map", None, "colour map", "viridis, coolwarm if signed"),
    Key("colour_function", _FUNCTIONS, None, 'display = "both": colour from this function'),
)
CAMERA_KEYS = declare_keys(
    Key("type", alternatives(CAMERA_TYPES), "perspective", "the projection"),
    Key("origin", "[x, y, z]", None, "the eye point", "automatic (frames the surfaces)"),
    Key("target", "[x, y, z], not origin", None, "the point looked at", "automatic"),
    # written as a scene file would (Camera keeps floats): a message shows it as [0, 0, 1]
    Key("up", "direction [x, y, z]", (0, 0, 1), "the view's up, not along the view"),
    Key("fov", "number in (0.001, 180)", 30.0, "perspective: horizontal field of view, degrees"),
    Key("width", "number > 1e-12", None, "orthographic: view width in scene units", "automatic"),
)
RENDER_KEYS = declare_keys(
    Key("width", f"integer 1–{MAX_IMAGE_SIDE}", 1024, "image width in pixels"),
    Key("height", f"integer 1–{MAX_IMAGE_SIDE}", 768, "image height in pixels"),
    Key("spp", f"integer 1–{MAX_SPP}", 16, "samples per pixel"),
    Key(
        "lighting",
        alternatives(LIGHTINGS),
        "lit",
        "lit: diffuse under a head light and a key light with a shadow ray, no noise; flat: the "
        "exact colours; soft: as lit with random sky occlusion (grainy, differs by variant)",
    ),
    Key(
        "sampling",
        alternatives(SAMPLINGS),
        "edges",
        "edges: spp samples where the picture is discontinuous (silhouettes, patch boundaries, "
        "shadow edges), one at the centre elsewhere (stripes are filtered exactly); uniform: spp "
        "everywhere (soft lighting always)",
    ),
    Key("variant", alternatives(VARIANTS), "auto", "the Mitsuba variant"),
    Key("seed", f"integer 0–{MAX_SEED}", 0, "the sampler's seed"),
    Key(
        "tessellation",
        f"integer 2–{MAX_TESSELLATION}",
        None,
        "vertices per patch side",
        "automatic (from the chord error)",
    ),
    Key(
        "chord_tolerance",
        f"number in [{MIN_CHORD_TOLERANCE:g}, 1]",
        1e-3,
        "relative to the bounding-box diagonal (and ≤ half a pixel)",
    ),
    Key(
        "texture_resolution",
        f"integer 1–{MAX_TEXTURE_RESOLUTION}",
        None,
        "texels per patch side",
        "automatic (from the screen size)",
    ),
    Key("junctions", "true | false", False, "draw the junctions coloured by continuity class"),
    Key("parabolic", "true | false", False, "draw the parabolic lines (K = 0) over the picture"),
    Key(
        "combs",
        "true | false",
        False,
        "draw curvature combs (porcupines) along the edges and knot lines, with inflections",
    ),
    Key(
        "comb_curvature",
        alternatives(COMB_CURVATURES),
        "space",
        "the combs' curvature: the curve's (space), its normal or its geodesic part",
    ),
    Key(
        "comb_lines",
        f"list of {', '.join(COMB_LINES)}",
        ("edges",),
        "the curves with combs: patch boundaries and B-rep edges, knot lines, planar sections",
    ),
    Key(
        "comb_sections",
        f"integer 1–{MAX_COMB_SECTIONS}",
        8,
        "planes of the comb_lines' sections, spread evenly over the scene",
    ),
    Key(
        "comb_section_direction",
        "[x, y, z] (nonzero)",
        None,
        "normal of the sections' planes",
        "the shape function's direction where it has one (planar_sections, draft_angle), else z",
    ),
    Key(
        "comb_scale",
        "number > 0",
        None,
        "spine length per unit of curvature (length²)",
        "automatic (the median's spine 5 % of the diagonal)",
    ),
    Key(
        "aovs",
        "list of shape function names",
        (),
        "extra EXR channels: each function's exact value at the pixel centres",
        "none",
    ),
)
#: gshade check's settings; the defaults are those of gshade.regression.check (CHECK_DEFAULTS and
#: DEFAULT_THRESHOLDS), which the parser leaves out: [check] keeps the keys given.
_THRESHOLD = "number ≥ 0"
_PERCENT = "number in [0, 100]"
CHECK_KEYS = declare_keys(
    Key("width", f"integer 1–{MAX_IMAGE_SIDE}", 160, "image width of the check render"),
    Key("height", f"integer 1–{MAX_IMAGE_SIDE}", 120, "image height of the check render"),
    Key("spp", f"integer 1–{MAX_SPP}", 4, "samples per pixel of the check render"),
    Key(
        "channels",
        "a list of channel names",
        ("R", "G", "B", "A", "f"),
        "the channels compared",
        '["R", "G", "B", "A", "f"]; statistical: ["R", "G", "B"]',
    ),
    Key("fail", _THRESHOLD, 0.02, "per-pixel failure threshold"),
    Key("failpercent", _PERCENT, 0.05, "% of the pixels allowed over fail"),
    Key("hardfail", _THRESHOLD, math.inf, "any pixel over this fails"),
    Key("warn", _THRESHOLD, 1e-3, "per-pixel warning threshold"),
    Key("warnpercent", _PERCENT, 0.0, "% of the pixels allowed over warn"),
    Key("statistical", "true | false", False, "compare by a z-test over several renders"),
    Key("runs", "integer 1–64", 4, "statistical: renders of the scene (at least 2)"),
    Key(
        "reference_model",
        "path to a scene file or a CAD file",
        None,
        "geometry to measure the scene's surfaces against (relative to the scene file): the "
        "check fails when they deviate from it by more than deviation",
        "none",
    ),
    Key(
        "deviation",
        _THRESHOLD,
        None,
        "reference_model: the largest |d| allowed, in model units",
        "1e-6 of the scene's bounding-box diagonal",
    ),
)
#: The tables of one-level keys, in the order messages list them.
SECTION_KEYS = {
    "shape": SHAPE_KEYS,
    "camera": CAMERA_KEYS,
    "render": RENDER_KEYS,
    "check": CHECK_KEYS,
}


# --------------------------------------------------------------------------- [shape]


def function_names(shape: dict[str, Any]) -> list[str]:
    """The known shape functions a [shape] table selects (function, colour_function)."""
    names = [shape.get("function", SHAPE_KEYS["function"].default), shape.get("colour_function")]
    return [n for n in names if isinstance(n, str) and n in SHAPE_FUNCTIONS]


def shape_keys(shape: dict[str, Any]) -> tuple[str, ...]:
    """The keys a [shape] table may have: the declared ones and its functions' parameters."""
    params = [p for n in function_names(shape) for p in SHAPE_FUNCTIONS[n].parameters]
    return (*SHAPE_KEYS, *dict.fromkeys(params))


def _parameter(t: Table, fn: str, name: str, files: DataFiles) -> Any:
    """A shape-function parameter: its TOML type checked here, its value by the registry; a
    ``file`` parameter's path found by ``files`` (relative to the scene file, within its
    folder or one in ``GSHADE_DATA_PATH``) and kept as that path."""
    spec = SHAPE_FUNCTIONS[fn].parameters[name]
    what = f" (parameter of {fn}: {spec.help})"
    value = t.data[name]
    if spec.kind in ("direction", "vector", "point"):
        value = t.vector(name, what=what)
    elif spec.kind == "number":
        value = t.number(name, expected=f"a number{what}")
    with t.reported():
        validate_parameter(fn, name, t.data[name])
    if spec.kind == "file" and value not in spec.choices:
        value = str(files.find(t, value, name))
    return value


def parse_shape(file: str, raw: dict[str, Any], files: DataFiles | None = None) -> Shape:
    """The ``[shape]`` table of the scene ``file``; ``files``: where the paths its
    parameters name may lie (default: relative to ``file``'s folder, within it or a folder
    in ``GSHADE_DATA_PATH``)."""
    t = Table(file, "[shape] ", raw, SHAPE_KEYS)
    if files is None:
        base = Path(file).parent
        files = DataFiles(base, data_roots(base, None))
    function = t.choice("function", tuple(SHAPE_FUNCTIONS))
    colour_function = t.choice("colour_function", tuple(SHAPE_FUNCTIONS))
    functions = [function] + ([colour_function] if colour_function else [])
    t.reject_unknown(
        shape_keys(raw),
        f"; parameters of {' and '.join(functions)}: "
        + (", ".join(p for f in functions for p in SHAPE_FUNCTIONS[f].parameters) or "none"),
    )
    params = {}
    for key in raw:
        if key not in SHAPE_KEYS:
            for fn in functions:
                if key in SHAPE_FUNCTIONS[fn].parameters:
                    params[key] = _parameter(t, fn, key, files)
    for fn in functions:  # the rules between parameters (axis not along reference ...)
        with t.reported():
            checked_parameters(
                fn, {k: v for k, v in params.items() if k in SHAPE_FUNCTIONS[fn].parameters}
            )
    display = t.choice("display", DISPLAYS)
    if SHAPE_FUNCTIONS[function].reflection and display != SHAPE_KEYS["display"].default:
        raise t.error(
            "display",
            f"expected no display with {function} (it draws the reflected map itself), "
            f"got {show(display)}",
        )
    if colour_function and SHAPE_FUNCTIONS[colour_function].reflection:
        raise t.error(
            "colour_function",
            f"expected a function with values to colour-map, got {show(colour_function)} "
            "(a reflection the renderer draws)",
        )
    if display == "bands":
        with t.reported():
            function_bands(function, params)
    period = t.number("period", lo=0)
    stripes = t.number("stripes", None, lo=0)
    if period is not None and stripes is not None:
        raise t.error(
            "stripes",
            f"expected either period or stripes, not both, got period = {show(raw['period'])} "
            f"and stripes = {show(raw['stripes'])}",
        )
    if period is None and stripes is None:
        stripes = SHAPE_KEYS["stripes"].default
    duty = t.number("duty", lo=0, hi=1)
    phase = t.number("phase")
    value_range = None
    if "range" in raw:
        r = raw["range"]
        if not (isinstance(r, list) and len(r) == 2 and all(is_number(x) for x in r)):
            raise t.error("range", f"expected [min, max], two numbers, got {show(r)}")
        with t.reported():
            value_range = validate_range(r)
    colormap = t.string("colormap", expected="the name of a matplotlib colour map")
    if colormap is not None:
        with t.reported():
            validate_colormap(colormap)
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


# --------------------------------------------------------------------------- [camera], [render]


def parse_camera(file: str, raw: dict[str, Any]) -> Camera:
    t = Table(file, "[camera] ", raw, CAMERA_KEYS)
    t.reject_unknown()
    kind = t.choice("type", CAMERA_TYPES)
    # TOML types here; the vectors' rules (up a direction, target not origin, up not along
    # the view) are Camera's, which is handed the values as written so that its messages
    # show them so
    for key in ("origin", "target", "up"):
        t.vector(key)
    fov = t.number("fov", lo=1e-3, hi=180)
    width = t.number("width", lo=1e-12)
    with t.reported():
        return Camera(kind, t.raw("origin"), t.raw("target"), t.raw("up"), fov, width)


def parse_render(file: str, raw: dict[str, Any]) -> RenderSettings:
    t = Table(file, "[render] ", raw, RENDER_KEYS)
    t.reject_unknown()
    return RenderSettings(
        width=t.integer("width", maximum=MAX_IMAGE_SIDE),
        height=t.integer("height", maximum=MAX_IMAGE_SIDE),
        spp=t.integer("spp", maximum=MAX_SPP),
        lighting=t.choice("lighting", LIGHTINGS),
        sampling=t.choice("sampling", SAMPLINGS),
        variant=t.choice("variant", VARIANTS),
        seed=t.integer("seed", minimum=0, maximum=MAX_SEED),
        tessellation=t.integer("tessellation", minimum=2, maximum=MAX_TESSELLATION),
        chord_tolerance=t.number("chord_tolerance", lo=MIN_CHORD_TOLERANCE, hi=1, closed=True),
        texture_resolution=t.integer(
            "texture_resolution", minimum=1, maximum=MAX_TEXTURE_RESOLUTION
        ),
        junctions=t.boolean("junctions"),
        aovs=_aovs(t),
        parabolic=t.boolean("parabolic"),
        combs=t.boolean("combs"),
        comb_curvature=t.choice("comb_curvature", COMB_CURVATURES),
        comb_lines=_comb_lines(t),
        comb_scale=t.number("comb_scale", lo=0),
        comb_sections=t.integer("comb_sections", maximum=MAX_COMB_SECTIONS),
        comb_section_direction=_section_direction(t),
    )


def _section_direction(t: Table) -> tuple[float, float, float] | None:
    """``render.comb_section_direction``: a direction (length at least MIN_DIRECTION)."""
    direction = t.vector("comb_section_direction", what=" (nonzero)")
    if direction is not None and not math.hypot(*direction) >= MIN_DIRECTION:
        raise t.error(
            "comb_section_direction",
            f"expected a direction [x, y, z] of length at least {MIN_DIRECTION:g}, "
            f"got {show(t.raw('comb_section_direction'))}",
        )
    return direction


def _comb_lines(t: Table) -> tuple[str, ...]:
    """``render.comb_lines``: a list of distinct names of COMB_LINES."""
    names = t.raw("comb_lines")
    expected = f"a list of {one_of(COMB_LINES)}, each once"
    if (
        not isinstance(names, (list, tuple))
        or not all(isinstance(n, str) and n in COMB_LINES for n in names)
        or len(set(names)) != len(names)
    ):
        raise t.error("comb_lines", f"expected {expected}, got {show(names)}")
    return tuple(names)


def _aovs(t: Table) -> tuple[str, ...]:
    """``render.aovs``: distinct shape-function names (extra channels of exact values)."""
    names = t.raw("aovs")
    if not isinstance(names, (list, tuple)) or not all(isinstance(n, str) for n in names):
        raise t.error("aovs", f"expected a list of shape function names, got {show(names)}")
    valued = tuple(name for name, fn in SHAPE_FUNCTIONS.items() if not fn.reflection)
    for name in names:
        if name not in valued:
            raise t.error(
                "aovs",
                f"expected names of {one_of(valued)}, got {show(name)}" + suggest(name, valued),
            )
    if len(set(names)) != len(names):
        raise t.error("aovs", f"expected each name once, got {show(names)}")
    return tuple(names)


def validate_render_settings(settings: RenderSettings, source: str = "render") -> RenderSettings:
    """Render settings built in Python (``gshade.render(scene, width=...)``) checked as the
    ``[render]`` table is; ``source`` names them in messages."""
    return parse_render(source, {k: v for k, v in asdict(settings).items() if v is not None})


# --------------------------------------------------------------------------- [check], [sweep]


def parse_check(file: str, raw: dict[str, Any], files: DataFiles | None = None) -> dict[str, Any]:
    """The ``[check]`` keys given, checked (``gshade check`` supplies the defaults).

    ``reference_model`` is found as a surface's data file is, by ``files`` (default: relative
    to ``file``'s folder, within it or a folder in ``GSHADE_DATA_PATH``): its value is the
    file's path; ``deviation`` needs it."""
    t = Table(file, "[check] ", raw)
    t.reject_unknown(tuple(CHECK_KEYS))
    if "deviation" in raw and "reference_model" not in raw:
        raise t.error(
            "deviation",
            f"expected together with reference_model (the geometry it is measured against), "
            f"got deviation = {show(raw['deviation'])} alone",
        )
    out: dict[str, Any] = {}
    for key in raw:
        if key == "reference_model":
            name = t.string(key, expected="a path to a scene file (TOML) or a CAD file")
            if files is None:
                base = Path(file).parent
                files = DataFiles(base, data_roots(base, None))
            out[key] = files.find(t, name, key)
        elif key in ("width", "height"):
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
                raise t.error(key, f"expected a list of channel names (strings), got {show(c)}")
            out[key] = tuple(c)
        elif key in ("failpercent", "warnpercent"):
            out[key] = t.number(key, lo=0, hi=100, closed=True)
        else:
            out[key] = t.number(key, lo=0, closed=True)
    return out


def parse_sweep(file: str, raw: dict[str, Any], prefix: str = "") -> dict[str, tuple[Any, ...]]:
    """``[sweep]``: dotted keys (quoted, ``"shape.function" = [...]``, or nested tables) to
    non-empty lists of values; the keys are checked when a batch applies them."""
    out: dict[str, tuple[Any, ...]] = {}
    for key, value in raw.items():
        dotted = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(parse_sweep(file, value, f"{dotted}."))
        elif isinstance(value, list) and value:
            if "." not in dotted:
                raise GshadeError(
                    f"{file}: [sweep] {dotted}: expected a dotted scene key such as "
                    f'"shape.function", got {dotted!r}'
                )
            out[dotted] = tuple(value)
        else:
            raise GshadeError(
                f"{file}: [sweep] {dotted}: expected a non-empty list of values, got {show(value)}"
            )
    return out
