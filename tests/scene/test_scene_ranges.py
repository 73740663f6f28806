"""The bounds of the scene's numbers, at their edges: just inside accepted, just outside refused
with one GshadeError naming the table and key.

The bounds are the documented contract (docs/reference/scene_files.rst and the table
"Numbers and sizes" of docs/how_to/untrusted.rst), written out here rather than read from
gshade, so that loosening or dropping a check in the parser turns a row red.  Open bounds are
tested at the bound itself (refused) and at the next float inside it (accepted); closed ones
at the bound (accepted) and at the next float or integer outside it (refused).
"""

from __future__ import annotations

import json
import math
import re

import pytest

from gshade import GshadeError
from gshade.scene import parse_scene

from ..support.paths import ROOT

SPHERE = '[[surface]]\ntype = "sphere"\n'
DATA = ROOT / "scenes" / "data"  # cube.obj, for the subdivision surface

TINY = 5e-324  # the smallest positive float


def up(x: float) -> float:
    return math.nextafter(x, math.inf)


def down(x: float) -> float:
    return math.nextafter(x, -math.inf)


def toml(value) -> str:
    """A TOML value: floats by repr (round trip exact), strings quoted, lists nested."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml(v) for v in value) + "]"
    return str(value)


def table_scene(table: str, key: str, value) -> str:
    return f"{SPHERE}[{table}]\n{key} = {toml(value)}\n"


# --------------------------------------------------------------------------- [render] [camera]
# [shape] [check]: (table, key, value just inside, values just outside)

TABLE_BOUNDS = [
    # [render]: width, height 1-16384; spp 1-4096; seed 0-2^32-1; tessellation 2-1024;
    # texture_resolution 1-512; chord_tolerance [1e-9, 1]
    ("render", "width", [1, 16384], [0, -1, 16385, 16.0]),
    ("render", "height", [1, 16384], [0, 16385]),
    ("render", "spp", [1, 4096], [0, 4097, 4.0]),
    ("render", "seed", [0, 2**32 - 1], [-1, 2**32]),
    ("render", "tessellation", [2, 1024], [1, 1025]),
    ("render", "texture_resolution", [1, 512], [0, 513]),
    ("render", "chord_tolerance", [1e-9, 1.0], [down(1e-9), up(1.0), 0.0]),
    # [camera]: fov in (0.001, 180) degrees; orthographic width > 1e-12
    ("camera", "fov", [up(1e-3), down(180.0), 30], [1e-3, 180, up(180.0), 0, -30]),
    ("camera", "width", [up(1e-12), 1e15], [1e-12, 0, -1.0]),
    # [shape]: duty in (0, 1); period, stripes > 0; phase any number (within +-1e15)
    ("shape", "duty", [TINY, down(1.0)], [0, 1, 0.0, 1.0, -0.5, 1.5]),
    ("shape", "period", [TINY, 1e15], [0, 0.0, -0.1]),
    ("shape", "stripes", [TINY, 1e15], [0, -1]),
    ("shape", "phase", [-1e15, 1e15, 0], [up(1e15), down(-1e15), 10**15 + 1]),
    # [check]: width, height, spp as [render]; runs 1-64; percentages [0, 100];
    # thresholds >= 0
    ("check", "width", [1, 16384], [0, 16385]),
    ("check", "height", [1, 16384], [0, 16385]),
    ("check", "spp", [1, 4096], [0, 4097]),
    ("check", "runs", [1, 64], [0, 65]),
    ("check", "failpercent", [0, 100, 0.0, 100.0], [-TINY, up(100.0)]),
    ("check", "warnpercent", [0, 100.0], [-TINY, up(100.0)]),
    ("check", "fail", [0, 0.0, 1e15], [-TINY]),
    ("check", "warn", [0.0], [-TINY]),
    ("check", "hardfail", [0.0], [-TINY]),
]


def _parsed(scene, table: str, key: str):
    if table == "check":
        return scene.check[key]
    return getattr(getattr(scene, table), key)


@pytest.mark.parametrize(
    ("table", "key", "value"),
    [(t, k, v) for t, k, inside, _ in TABLE_BOUNDS for v in inside],
    ids=lambda x: repr(x) if isinstance(x, float) else None,
)
def test_just_inside_is_accepted(table, key, value):
    scene = parse_scene(table_scene(table, key, value))
    assert _parsed(scene, table, key) == value


@pytest.mark.parametrize(
    ("table", "key", "value"),
    [(t, k, v) for t, k, _, outside in TABLE_BOUNDS for v in outside],
    ids=lambda x: repr(x) if isinstance(x, float) else None,
)
def test_just_outside_is_refused_naming_the_key(table, key, value):
    with pytest.raises(GshadeError, match=rf"^<string>: \[{table}\] {key}: expected") as exc:
        parse_scene(table_scene(table, key, value))
    assert "\n" not in str(exc.value)


def test_a_colour_range_must_not_be_empty():
    for r in ([-1.0, up(-1.0)], [0, TINY], [-1e15, 1e15]):
        assert parse_scene(table_scene("shape", "range", r)).shape.value_range == tuple(r)
    for r in ([1, 1], [0.0, -0.0], [2, 1]):
        with pytest.raises(GshadeError, match=r"\[shape\] range: expected \[min, max\]"):
            parse_scene(table_scene("shape", "range", r))


# --------------------------------------------------------------------------- surfaces


def _grid(rows: int, cols: int) -> list:
    """A planar net of rows x cols points (regular everywhere)."""
    return [[[float(i), float(j), 0.0] for j in range(cols)] for i in range(rows)]


def _surface(kind: str, **keys) -> str:
    lines = [f'type = "{kind}"'] + [f"{k} = {toml(v)}" for k, v in keys.items()]
    return "[[surface]]\n" + "\n".join(lines) + "\n"


def _bspline(p: int, q: int) -> dict:
    rows, cols = max(p, 0) + 1, max(q, 0) + 1
    return {
        "degree": [p, q],
        "knots_u": [0.0] * rows + [1.0] * rows,
        "knots_v": [0.0] * cols + [1.0] * cols,
        "points": _grid(rows, cols),
    }


# (surface text, the key the refusal must name); sizes: radius, major, minor, height > 0,
# minor < major; subdivision levels 0-4; Bézier degree (per direction) and B-spline degree
# at most 20; β-spline beta1 > 0, beta2 >= 0; ν-spline tensions >= 0
SURFACE_INSIDE = {
    "sphere radius tiny": _surface("sphere", radius=1e-12),
    "sphere radius 1e15": _surface("sphere", radius=1e15),
    "torus minor just below major": _surface("torus", major=2.0, minor=down(2.0)),
    "cylinder tiny": _surface("cylinder", radius=1e-9, height=1e-9),
    "subdivision levels 0": _surface("subdivision", file="cube.obj", levels=0),
    "subdivision levels 4": _surface("subdivision", file="cube.obj", levels=4),
    "bezier degree 20": _surface("bezier", points=_grid(21, 2)),
    "bezier degree 20 in v": _surface("bezier", points=_grid(2, 21)),
    "bspline degree 20": _surface("bspline", **_bspline(20, 1)),
    "bspline degree 1": _surface("bspline", **_bspline(1, 20)),
    "betaspline beta2 0": _surface("betaspline", points=_grid(4, 4), beta1=1.0, beta2=0.0),
    "betaspline beta1 small": _surface("betaspline", points=_grid(4, 4), beta1=1e-6),
    "betaspline beta1_u small": _surface("betaspline", points=_grid(5, 4), beta1_u=1e-6),
    "betaspline beta2_u 0": _surface("betaspline", points=_grid(5, 4), beta2_u=[0.0]),
    "nuspline nu 0": _surface("nuspline", points=_grid(4, 4), nu_u=0.0, nu_v=[0.0] * 4),
}
SURFACE_OUTSIDE = {
    "sphere radius 0": (_surface("sphere", radius=0), "radius"),
    "sphere radius -0.0": (_surface("sphere", radius=-0.0), "radius"),
    "sphere radius -1": (_surface("sphere", radius=-1.0), "radius"),
    "sphere radius over 1e15": (_surface("sphere", radius=up(1e15)), "radius"),
    "torus major 0": (_surface("torus", major=0, minor=0.5), "major"),
    "torus minor 0": (_surface("torus", major=2.0, minor=0.0), "minor"),
    "torus minor = major": (_surface("torus", major=2.0, minor=2.0), "torus: expected 0 < minor"),
    "torus minor > major": (_surface("torus", major=2.0, minor=up(2.0)), "torus: expected 0 <"),
    "cylinder radius 0": (_surface("cylinder", radius=0.0), "radius"),
    "cylinder height 0": (_surface("cylinder", height=0), "height"),
    "cylinder height -1": (_surface("cylinder", height=-1.0), "height"),
    "subdivision levels -1": (_surface("subdivision", file="cube.obj", levels=-1), "levels"),
    "subdivision levels 5": (_surface("subdivision", file="cube.obj", levels=5), "levels"),
    "bezier degree 21": (_surface("bezier", points=_grid(22, 2)), "points"),
    "bezier degree 21 in v": (_surface("bezier", points=_grid(2, 22)), "points"),
    "bspline degree 21": (_surface("bspline", **_bspline(21, 1)), "degree"),
    "bspline degree 0": (_surface("bspline", **_bspline(0, 1)), "degree"),
    "betaspline beta1 0": (_surface("betaspline", points=_grid(4, 4), beta1=0.0), "beta1"),
    "betaspline beta2 < 0": (_surface("betaspline", points=_grid(4, 4), beta2=-TINY), "beta2"),
    "betaspline beta1_u 0": (_surface("betaspline", points=_grid(5, 4), beta1_u=[0.0]), "beta1_u"),
    "betaspline beta2_v < 0": (
        _surface("betaspline", points=_grid(4, 5), beta2_v=-TINY),
        "beta2_v",
    ),
    "betaspline 3 rows": (_surface("betaspline", points=_grid(3, 4)), "points"),
    "nuspline nu_u < 0": (_surface("nuspline", points=_grid(4, 4), nu_u=-TINY), "nu_u"),
    "nuspline nu_v < 0": (
        _surface("nuspline", points=_grid(4, 4), nu_v=[0.0, 0.0, -TINY, 0.0]),
        "nu_v",
    ),
}


@pytest.mark.parametrize("case", list(SURFACE_INSIDE))
def test_surface_just_inside_is_accepted(case):
    scene = parse_scene(SURFACE_INSIDE[case], base=DATA)
    assert scene.patches


@pytest.mark.parametrize("case", list(SURFACE_OUTSIDE))
def test_surface_just_outside_is_refused_naming_the_key(case):
    text, key = SURFACE_OUTSIDE[case]
    kind = re.search(r'type = "(\w+)"', text).group(1)
    with pytest.raises(GshadeError) as exc:
        parse_scene(text, base=DATA)
    message = str(exc.value)
    assert message.startswith(f"<string>: [[surface]] 1 ({kind}): {key}"), message
    assert "\n" not in message


def test_subdivision_patch_count_is_bounded(tmp_path):
    """At most 100,000 patches: faces x 4^levels, refused before anything is refined."""
    n = 391  # a strip of 391 quads: 391 x 4^4 = 100,096 patches
    vertices = [f"v {i} {j} 0" for i in range(n + 1) for j in range(2)]
    faces = [f"f {2 * i + 1} {2 * i + 3} {2 * i + 4} {2 * i + 2}" for i in range(n)]
    (tmp_path / "strip.obj").write_text("\n".join(vertices + faces) + "\n")
    text = _surface("subdivision", file="strip.obj", levels=4)
    with pytest.raises(GshadeError, match=r"\(subdivision\): levels: expected at most 100000"):
        parse_scene(text, base=tmp_path)


# --------------------------------------------------------------------------- any value


@pytest.mark.parametrize(
    ("text", "accepted"),
    [
        (f"{SPHERE}[camera]\norigin = [1e15, -1e15, 0]\n", True),
        (f"{SPHERE}[camera]\norigin = [{up(1e15)!r}, 0, 0]\n", False),
        (f"{SPHERE}[camera]\norigin = [0, {down(-1e15)!r}, 0]\n", False),
        (f"{SPHERE}[camera]\norigin = [0, 0, 1000000000000001]\n", False),
    ],
)
def test_any_number_lies_within_1e15(text, accepted):
    if accepted:
        assert parse_scene(text).camera.origin[0] == 1e15
    else:
        with pytest.raises(GshadeError, match=r"\[camera\] origin\[\d\]: expected a finite number"):
            parse_scene(text)


def test_strings_nesting_and_names_at_their_limits():
    channels = "[check]\nchannels = [{}]\n"
    assert parse_scene(SPHERE + channels.format(toml("x" * 4096))).check["channels"][0]
    with pytest.raises(GshadeError, match=r"\[check\] channels\[0\]: expected a string of at most"):
        parse_scene(SPHERE + channels.format(toml("x" * 4097)))
    # [sweep] keeps its lists as given: "sweep", the key and 6 arrays make 8 levels
    sweep = '[sweep]\n"shape.phase" = {}\n'
    assert parse_scene(SPHERE + sweep.format("[" * 6 + "0" + "]" * 6)).sweep
    with pytest.raises(GshadeError, match=r"expected arrays and tables nested at most 8 deep"):
        parse_scene(SPHERE + sweep.format("[" * 7 + "0" + "]" * 7))
    # names: at most 200 bytes of UTF-8
    assert parse_scene(f"name = {toml('é' * 100)}\n{SPHERE}").name == "é" * 100
    with pytest.raises(GshadeError, match=r"^<string>: name: expected a name of at most 200 bytes"):
        parse_scene(f"name = {toml('é' * 100 + 'a')}\n{SPHERE}")


# --------------------------------------------------------------------------- samples per render


class _Reached(Exception):
    """Raised where the render goes on after its size checks."""


@pytest.mark.parametrize(
    ("width", "height", "spp", "accepted"),
    [
        (16384, 16384, 4, True),  # 2^30 samples
        (16384, 16384, 5, False),  # spp rounds up to 16
        (1024, 1024, 257, True),  # spp 257 rounds up to 1024: 2^30
        (1025, 1024, 257, False),  # 1025 x 1024 x 1024 > 2^30
        (1024, 1025, 256, True),  # 256 is a power of 4
    ],
)
def test_samples_per_render_at_most_2_to_the_30(monkeypatch, width, height, spp, accepted):
    """width x height x spp (spp rounded up to a power of 4, as Mitsuba samples) <= 2^30,
    checked when rendering, before anything is set up."""
    from gshade.rendering import pipeline, render

    def reached(*args, **kwargs):
        raise _Reached

    monkeypatch.setattr(pipeline, "use_variant", reached)
    scene = parse_scene(SPHERE)
    if accepted:
        with pytest.raises(_Reached):
            render(scene, width=width, height=height, spp=spp)
    else:
        with pytest.raises(GshadeError, match=r"\[render\] width x height x spp: expected at most"):
            render(scene, width=width, height=height, spp=spp)
