"""Scene files: every surface type, defaults, overrides, the hash, and bad input."""

import shutil

import numpy as np
import pytest

from gshade import GshadeError
from gshade.display import validate_colormap, validate_range
from gshade.geometry import BezierPatch, BSplinePatch, CoonsPatch
from gshade.scene import Camera, load_scene, parse_overrides, parse_scene
from gshade.shape import SHAPE_FUNCTIONS, validate_parameter

from ..support.paths import ROOT, TEAPOT

FULL = ROOT / "tests" / "data" / "all_surfaces.toml"
SPHERE = '[[surface]]\ntype = "sphere"\n'


@pytest.fixture(autouse=True)
def teapot_data_allowed(monkeypatch):
    """FULL's Newell surface reads the teapot in scenes/data, outside FULL's own folder."""
    monkeypatch.setenv("GSHADE_DATA_PATH", str(TEAPOT.parent))


def write(tmp_path, text, name="scene.toml"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def grid(n=7):
    return np.linspace(0, 1, n)[:, None], np.linspace(0, 1, n)[None, :]


# --------------------------------------------------------------------------- valid scenes


def test_full_scene_has_every_surface_type():
    scene = load_scene(FULL)
    assert scene.name == "all-surfaces"
    assert scene.path == FULL
    kinds = [s.kind for s in scene.surfaces]
    assert kinds == ["newell", "bezier", "bspline", "coons", "sphere", "torus", "cylinder"]
    assert [len(s.patches) for s in scene.surfaces] == [32, 1, 1, 1, 1, 1, 1]
    assert len(scene.patches) == 38
    assert scene.patches[32] is scene.surfaces[1].patches[0]
    assert scene.surfaces[3].source == f"{FULL}: [[surface]] 4 (coons)"
    assert scene.data_files == (TEAPOT.resolve(),)

    bezier, bspline, coons, sph, tor, cyl = (s.patches[0] for s in scene.surfaces[1:])
    assert isinstance(bezier, BezierPatch) and bezier.degree == (3, 3)
    assert isinstance(bspline, BSplinePatch) and bspline.degree == (2, 3) and bspline.rational
    np.testing.assert_array_equal(bspline.knots[0], [0, 0, 0, 0.4, 1, 1, 1])
    assert isinstance(coons, CoonsPatch) and coons.bicubic
    u, v = grid()
    # The bicubic Coons patch of a bicubic patch's boundary data is that patch.
    np.testing.assert_allclose(coons(u, v), bezier(u, v), atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(sph(u, v), axis=-1), 2.0, rtol=1e-12)
    p = tor(u, v)
    np.testing.assert_allclose(np.hypot(np.hypot(p[..., 0], p[..., 1]) - 3, p[..., 2]), 1.0)
    p = cyl(u, v)
    np.testing.assert_allclose(np.hypot(p[..., 0], p[..., 1]), 0.5)
    assert p[..., 2].min() == pytest.approx(0) and p[..., 2].max() == pytest.approx(2)


def test_full_scene_tables():
    scene = load_scene(FULL)
    shape = scene.shape
    assert shape.function == "reflection_lines"
    assert shape.params == {
        "eye_point": (0.0, -10.0, 5.0),
        "form": "plane",
        "origin": (0.0, 0.0, 10.0),
        "a1": (1.0, 0.0, 0.0),
        "a2": (0.0, 1.0, 0.0),
    }
    assert shape.params_for("mean") == {}
    assert shape.params_for("reflection_lines") == shape.params
    assert (shape.display, shape.colour_function, shape.colormap) == ("both", "mean", "viridis")
    assert (shape.period, shape.stripes, shape.duty, shape.phase) == (0.25, None, 0.4, 0.1)
    assert shape.value_range == (-1.0, 1.0)
    cam = scene.camera
    assert (cam.type, cam.origin, cam.target, cam.up) == (
        "perspective",
        (6.0, -8.0, 5.0),
        (0.0, 0.0, 1.5),
        (0.0, 0.0, 1.0),
    )
    assert (cam.fov, cam.width) == (35.0, 2.0)
    r = scene.render
    assert (r.width, r.height, r.spp, r.lighting, r.variant, r.seed) == (
        640,
        480,
        4,
        "flat",
        "scalar_rgb",
        7,
    )
    assert (r.tessellation, r.chord_tolerance, r.texture_resolution) == (24, 1e-4, 32)
    assert scene.check == {
        "width": 320,
        "height": 240,
        "spp": 8,
        "channels": ("R", "G", "B"),
        "fail": 0.05,
        "failpercent": 1.0,
        "hardfail": 0.5,
        "warn": 0.01,
        "warnpercent": 5.5,
    }


def test_defaults(tmp_path):
    scene = load_scene(write(tmp_path, SPHERE, "my-sphere.toml"))
    assert scene.name == "my-sphere"
    assert scene.data_files == ()
    s = scene.shape
    assert (s.function, s.params, s.display) == ("isophotes", {}, "stripes")
    assert (s.period, s.stripes, s.duty, s.phase) == (None, 20.0, 0.5, 0.0)
    assert (s.value_range, s.colormap, s.colour_function) == (None, None, None)
    c = scene.camera
    assert (c.type, c.origin, c.target, c.up, c.fov, c.width) == (
        "perspective",
        None,
        None,
        (0.0, 0.0, 1.0),
        30.0,
        None,
    )
    r = scene.render
    assert (r.width, r.height, r.spp, r.lighting, r.variant, r.seed) == (
        1024,
        768,
        16,
        "lit",
        "auto",
        0,
    )
    assert (r.tessellation, r.chord_tolerance, r.texture_resolution) == (None, 1e-3, None)
    assert scene.check == {}
    np.testing.assert_allclose(np.linalg.norm(scene.patches[0](*grid()), axis=-1), 1.0)


def test_surface_defaults_and_newell_up(tmp_path):
    shutil.copy(TEAPOT, tmp_path / "pot.txt")
    text = (
        '[[surface]]\ntype = "torus"\n[[surface]]\ntype = "cylinder"\n'
        '[[surface]]\ntype = "newell"\nfile = "pot.txt"\nup = "y"\n'
    )
    scene = load_scene(write(tmp_path, text))
    u, v = grid()
    p = scene.patches[0](u, v)
    np.testing.assert_allclose(np.hypot(np.hypot(p[..., 0], p[..., 1]) - 2, p[..., 2]), 0.5)
    assert np.ptp(scene.patches[1](u, v)[..., 2]) == pytest.approx(1.0)
    # y-up data (x, y, z) become (x, -z, y)
    z_up = load_scene(FULL).surfaces[0].patches[0].points
    np.testing.assert_allclose(scene.patches[2].points[..., 2], z_up[..., 1])


def test_parse_scene_from_text():
    scene = parse_scene(SPHERE + '[shape]\nfunction = "gaussian"\n')
    assert scene.path is None and scene.name == "scene"
    assert scene.shape.function == "gaussian"


def test_every_shape_function_and_its_parameters_are_accepted(tmp_path):
    """Each function with every parameter given (directions apart from one another: the
    rules between parameters are checked when the scene loads)."""
    directions = [[1, 2, 3], [3, -1, 0.5], [0, 1, -2]]
    values = {"choice": None, "point": [0, 0, 20], "vector": [0, 1, 1]}
    for name, fn in SHAPE_FUNCTIONS.items():
        lines = [f'function = "{name}"']
        given = iter(directions)
        for pname, spec in fn.parameters.items():
            value = (
                spec.choices[-1] if spec.kind in ("choice", "file") else values.get(spec.kind, 1.0)
            )
            if spec.kind == "direction":
                value = next(given)
            lines.append(f"{pname} = {value!r}".replace("'", '"'))
        scene = load_scene(write(tmp_path, SPHERE + "[shape]\n" + "\n".join(lines) + "\n"))
        assert scene.shape.function == name
        assert set(scene.shape.params) == set(fn.parameters)


# --------------------------------------------------------------------------- overrides


def test_parse_overrides_values():
    items = [
        "shape.period=0.05",
        "render.width=640",
        "camera.origin=[1, 2, 3]",
        "name=foo",
        "shape.function=mean",
        'shape.colormap="viridis"',
        " render.variant = scalar_rgb ",
        "camera.fov=1e1",
        "name=two words",  # a later item wins
        "check.channels=['R', 'G']",
        "shape.light=[0,0,1]\nname = 'x'",  # not one TOML value: kept as text
        "render.seed=",
    ]
    assert parse_overrides(items) == {
        "shape.period": 0.05,
        "render.width": 640,
        "camera.origin": [1, 2, 3],
        "name": "two words",
        "shape.function": "mean",
        "shape.colormap": "viridis",
        "render.variant": "scalar_rgb",
        "camera.fov": 10.0,
        "check.channels": ["R", "G"],
        "shape.light": "[0,0,1]\nname = 'x'",
        "render.seed": "",
    }


@pytest.mark.parametrize("item", ["shape.period", "=3", "shape..period=1", ".x=1", "a.=1"])
def test_parse_overrides_errors(item):
    with pytest.raises(GshadeError, match=r"^override .*expected key=value"):
        parse_overrides([item])


def test_overrides_apply_before_validation():
    overrides = parse_overrides(
        [
            "name=foo",
            "render.width=640",
            "camera.origin=[1,2,3]",
            "camera.target=[0,0,0]",
            "shape.period=0.05",
            "shape.eye_point=[0, -20, 5]",
            "check.spp=2",
            "surface.5.radius=3",
        ]
    )
    scene = load_scene(FULL, overrides)
    assert scene.name == "foo"
    assert scene.render.width == 640 and scene.render.height == 480
    assert scene.camera.origin == (1.0, 2.0, 3.0) and scene.camera.target == (0.0, 0.0, 0.0)
    assert scene.shape.period == 0.05
    assert scene.shape.params["eye_point"] == (0.0, -20.0, 5.0)
    assert scene.check["spp"] == 2
    np.testing.assert_allclose(np.linalg.norm(scene.patches[35](*grid()), axis=-1), 3.0)
    with pytest.raises(GshadeError, match=r"\[render\] width: expected an integer from 1 to 16384"):
        load_scene(FULL, {"render.width": 0})


def test_override_creates_missing_tables(tmp_path):
    scene = load_scene(write(tmp_path, SPHERE), {"render.spp": 2, "check.warn": 0.1})
    assert scene.render.spp == 2 and scene.check == {"warn": 0.1}


def test_override_period_replaces_stripes_and_back(tmp_path):
    path = write(tmp_path, SPHERE + "[shape]\nstripes = 10\n")
    scene = load_scene(path, {"shape.period": 0.5})
    assert (scene.shape.period, scene.shape.stripes) == (0.5, None)
    path = write(tmp_path, SPHERE + "[shape]\nperiod = 0.1\n")
    scene = load_scene(path, {"shape.stripes": 5})
    assert (scene.shape.period, scene.shape.stripes) == (None, 5.0)
    with pytest.raises(GshadeError, match="either period or stripes, not both"):
        load_scene(path, {"shape.stripes": 5, "shape.period": 0.1})


def test_override_of_the_function_drops_the_old_functions_parameters(tmp_path):
    path = write(tmp_path, SPHERE + '[shape]\nfunction = "isophotes"\nlight = [1, 0, 1]\n')
    scene = load_scene(path, parse_overrides(["shape.function=mean"]))
    assert scene.shape.function == "mean" and scene.shape.params == {}
    # the new function's parameters may be set in the same breath
    scene = load_scene(
        path, parse_overrides(["shape.direction=[1,0,0]", "shape.function=planar_sections"])
    )
    assert scene.shape.params == {"direction": (1.0, 0.0, 0.0)}
    # a misspelt key in the file is still reported
    path = write(tmp_path, SPHERE + "[shape]\nlihgt = [1, 0, 1]\n")
    with pytest.raises(GshadeError, match="lihgt: unknown key"):
        load_scene(path, {"shape.function": "mean"})


@pytest.mark.parametrize(
    ("key", "message"),
    [
        (
            "camera.fob",
            r'override camera.fob: unknown key "fob" in \[camera\]; did you mean "fov"\?',
        ),
        ("camra.fov", r'override camra.fov: unknown section "camra"; did you mean "camera"\?'),
        ("shape.lihgt", r'unknown key "lihgt" in \[shape\]; did you mean "light"\?.*light, form'),
        ("shape.direction", r'unknown key "direction" in \[shape\]'),  # not an isophotes param
        ("render", r"override render: expected a key of the form render.key"),
        ("render.width.x", r"override render.width.x: expected a key of the form render.key"),
        ("surface.9.radius", r"override surface.9.radius: expected a surface number from 1 to 1"),
        ("surface.1.radus", r'unknown key "radus" for a sphere surface; did you mean "radius"'),
        ("surface.radius", r"expected a key of the form surface.N.key"),
    ],
)
def test_override_errors(tmp_path, key, message):
    path = write(tmp_path, SPHERE)
    with pytest.raises(GshadeError, match=message) as info:
        load_scene(path, {key: 1})
    assert str(info.value).startswith(f"{path}: override {key}: ")


# --------------------------------------------------------------------------- the hash


def test_hash_follows_contents_overrides_and_data_files(tmp_path):
    shutil.copy(TEAPOT, tmp_path / "pot.txt")
    text = '[[surface]]\ntype = "newell"\nfile = "pot.txt"\n[render]\nspp = 4\n'
    path = write(tmp_path, text)
    h = load_scene(path).text_hash
    assert len(h) == 64 and h == load_scene(path).text_hash
    # comments, layout and the order of keys do not matter; values do
    same = '# teapot\n[render]\nspp   =   4\n[[surface]]\nfile = "pot.txt"\ntype = "newell"\n'
    assert load_scene(write(tmp_path, same, "other.toml")).text_hash == h
    assert load_scene(path, {"render.spp": 8}).text_hash != h
    assert load_scene(path, {"render.spp": 4}).text_hash == h
    # a change in the data file changes the hash
    data = (tmp_path / "pot.txt").read_text()
    (tmp_path / "pot.txt").write_text(data.replace("1.4,0.0,2.4", "1.4,0.0,2.5", 1))
    assert (tmp_path / "pot.txt").read_text() != data
    assert load_scene(path).text_hash != h


# --------------------------------------------------------------------------- bad input

NET = "[[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]]"
BSPLINE = '[[surface]]\ntype = "bspline"\ndegree = [1, 1]\npoints = ' + NET + "\n"
JUNCTION = '[[surface]]\ntype = "junction"\npoints = ' + NET + "\n"
NUSPLINE = '[[surface]]\ntype = "nuspline"\npoints = ' + NET + "\n"
BETASPLINE = (
    '[[surface]]\ntype = "betaspline"\npoints = '
    + str([[[i, j, (i * j) % 2] for j in range(4)] for i in range(5)])
    + "\n"
)
CURVES = (
    "v0 = [[0, 0, 0], [1, 0, 0]]\nv1 = [[0, 1, 0], [1, 1, 0]]\nu0 = [[0, 0, 0], [0, 1, 0]]\n"
    "u1 = [[1, 0, 0], [1, 1, 0]]\n"
)

BAD = {
    # syntax
    "toml syntax": ("name = \n", r"invalid TOML: Invalid value \(at line 1, column 8\)"),
    "toml duplicate key": (SPHERE + "radius = 1\nradius = 2\n", r"invalid TOML: .*line 4"),
    # missing required keys
    "no surface": ('name = "x"\n', r"\[\[surface\]\]: missing; expected at least one"),
    "surface is a table": ('[surface]\ntype = "sphere"\n', r"surface: expected one or more \[\["),
    "surface type missing": ("[[surface]]\nradius = 1\n", r"\[\[surface\]\] 1: type: missing"),
    "surface type unknown": (
        SPHERE + '[[surface]]\ntype = "sphare"\n',
        r'\[\[surface\]\] 2: type: expected one of "newell", .*got "sphare"; did you mean "sphere"',
    ),
    "bspline without knots": (
        BSPLINE,
        r"\[\[surface\]\] 1 \(bspline\): knots_u: missing; expected a list of knots",
    ),
    "bezier without points": (
        '[[surface]]\ntype = "bezier"\n',
        r"\[\[surface\]\] 1 \(bezier\): points: missing; expected \(m\+1\) rows",
    ),
    "newell without file": ('[[surface]]\ntype = "newell"\n', r"\(newell\): file: missing"),
    "coons without u1": (
        '[[surface]]\ntype = "coons"\n' + CURVES.split("u1")[0],
        r"\(coons\): u1: missing",
    ),
    # misspelt keys
    "misspelt table": (
        SPHERE + "[camra]\nfov = 3\n",
        r": camra: unknown key; did you mean \"camera\"",
    ),
    "misspelt camera key": (
        SPHERE + "[camera]\nfob = 3\n",
        r'\[camera\] fob: unknown key; did you mean "fov"',
    ),
    "misspelt render key": (
        SPHERE + "[render]\nssp = 3\n",
        r'\[render\] ssp: unknown key; did you mean "spp"',
    ),
    "misspelt surface key": (
        SPHERE + "radus = 3\n",
        r'\[\[surface\]\] 1 \(sphere\): radus: unknown key; did you mean "radius"',
    ),
    "misspelt shape parameter": (
        SPHERE + "[shape]\nlihgt = [0, 0, 1]\n",
        r'\[shape\] lihgt: unknown key; did you mean "light"\? \(expected one of: function, .*; '
        r"parameters of isophotes: light, form\)",
    ),
    "misspelt check key": (
        SPHERE + "[check]\nfailpercnt = 3\n",
        r'\[check\] failpercnt: unknown key; did you mean "failpercent"',
    ),
    "bspline knots misspelt": (
        BSPLINE + "knot_u = [0, 0, 1, 1]\n",
        r'knot_u: unknown key; did you mean "knots_u"',
    ),
    # wrong types
    "fov a string": (
        SPHERE + '[camera]\nfov = "wide"\n',
        r'\[camera\] fov: expected a number in \(0.001, 180\), got "wide"$',
    ),
    "fov out of range": (
        SPHERE + "[camera]\nfov = 180\n",
        r"fov: expected a number in \(0.001, 180\), got 180",
    ),
    "origin too short": (
        SPHERE + "[camera]\norigin = [1, 2]\n",
        r"\[camera\] origin: expected 3 numbers \[x, y, z\], got \[1, 2\]",
    ),
    "up zero": (
        SPHERE + "[camera]\nup = [0, 0, 0]\n",
        r"\[camera\] up: expected a direction \[x, y, z\] of length at least 1e-12",
    ),
    "target at origin": (
        SPHERE + "[camera]\norigin = [1, 1, 1]\ntarget = [1, 1, 1]\n",
        r"\[camera\] target: expected a point other than origin",
    ),
    "up along the view": (
        SPHERE + "[camera]\norigin = [0, 0, 5]\ntarget = [0, 0, 0]\n",
        r"\[camera\] up: expected a direction not parallel to target - origin",
    ),
    "camera width negative": (
        SPHERE + "[camera]\nwidth = -2\n",
        r"\[camera\] width: expected a number > 1e-12, got -2",
    ),
    "name a number": ("name = 3\n" + SPHERE, r": name: expected a non-empty string, got 3"),
    "shape a string": (
        SPHERE + 'shape = "x"\n',
        r"\[\[surface\]\] 1 \(sphere\): shape: unknown key",
    ),
    "top-level shape not a table": (
        'shape = "x"\n' + SPHERE,
        r": shape: expected a table \[shape\], got \"x\"",
    ),
    "radius a string": (
        SPHERE + 'radius = "big"\n',
        r'\(sphere\): radius: expected a positive number, got "big"',
    ),
    "radius a boolean": (
        SPHERE + "radius = true\n",
        r"radius: expected a positive number, got true",
    ),
    "radius infinite": (
        SPHERE + "radius = inf\n",
        r"radius: expected a finite number within ±1e\+15",
    ),
    "point with a string": (
        '[[surface]]\ntype = "bezier"\n'
        'points = [[[0, 0, 0], [0, 1, "a"]], [[1, 0, 0], [1, 1, 0]]]\n',
        r'\(bezier\): points\[0\]\[1\]\[2\]: expected a finite number, got "a"',
    ),
    "point of 2 numbers": (
        '[[surface]]\ntype = "bezier"\npoints = [[[0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]]\n',
        r"points\[0\]\[0\]: expected a point \[x, y, z\], got \[0, 0\]",
    ),
    "ragged net": (
        '[[surface]]\ntype = "bezier"\npoints = [[[0, 0, 0], [0, 1, 0]], [[1, 0, 0]]]\n',
        r"points: expected \(m\+1\) rows of n\+1 points \[x, y, z\], every row of the same "
        r"length, got rows of 2, 1 points",
    ),
    "net of one row": (
        '[[surface]]\ntype = "bezier"\npoints = [[[0, 0, 0], [0, 1, 0]]]\n',
        r"\(bezier\): points: expected at least 2 control points per direction",
    ),
    "weights wrong shape": (
        '[[surface]]\ntype = "bezier"\npoints = ' + NET + "\nweights = [[1, 1]]\n",
        r"\(bezier\): weights: expected shape \(2, 2\) for the Bézier patch, got \(1, 2\)",
    ),
    "weights not positive": (
        '[[surface]]\ntype = "bezier"\npoints = ' + NET + "\nweights = [[1, 1], [1, 0]]\n",
        r"\(bezier\): weights: expected positive finite numbers, got 0.0",
    ),
    "degree a number": (
        BSPLINE.replace("[1, 1]", "3") + "knots_u = [0, 0, 1, 1]\nknots_v = [0, 0, 1, 1]\n",
        r"\(bspline\): degree: expected \[p, q\], two integers from 1 to 20, got 3",
    ),
    "knots wrong count": (
        BSPLINE + "knots_u = [0, 0, 1]\nknots_v = [0, 0, 1, 1]\n",
        r"\[\[surface\]\] 1 \(bspline\): knots_u: expected 4 knots for 2 control points of "
        r"degree 1",
    ),
    "knots decreasing": (
        BSPLINE + "knots_u = [0, 0, 1, 1]\nknots_v = [0, 1, 0, 1]\n",
        r"\(bspline\): knots_v: expected a non-decreasing sequence",
    ),
    "coons without all cross derivatives": (
        '[[surface]]\ntype = "coons"\n' + CURVES + "cross_v0 = [[0, 0, 1], [0, 0, 1]]\n",
        r"\(coons\): Coons patch: bicubic blending needs all four .* missing cross_u0",
    ),
    "coons corners disagree": (
        '[[surface]]\ntype = "coons"\n' + CURVES.replace("u1 = [[1, 0, 0]", "u1 = [[1, 0, 5]"),
        r"\[\[surface\]\] 1 \(coons\): Coons patch: .*",
    ),
    "coons curve of one point": (
        '[[surface]]\ntype = "coons"\n'
        + CURVES.replace("v0 = [[0, 0, 0], [1, 0, 0]]", "v0 = [[0, 0, 0]]"),
        r"\(coons\): v0: points: expected at least 2 control points",
    ),
    "torus minor > major": (
        '[[surface]]\ntype = "torus"\nmajor = 1\nminor = 2\n',
        r"\[\[surface\]\] 1 \(torus\): torus: expected 0 < minor < major",
    ),
    "newell up unknown": (
        '[[surface]]\ntype = "newell"\nfile = "x.txt"\nup = "w"\n',
        r'\(newell\): up: expected one of "z", "y", "x", got "w"',
    ),
    # shape
    "unknown function": (
        SPHERE + '[shape]\nfunction = "isophote"\n',
        r'\[shape\] function: expected one of "planar_sections", "isophotes", .*got "isophote"; '
        r'did you mean "isophotes"',
    ),
    "unknown colour function": (
        SPHERE + '[shape]\ncolour_function = "curvature"\n',
        r'\[shape\] colour_function: expected one of .*got "curvature"',
    ),
    "parameter of the wrong function": (
        SPHERE + "[shape]\ndirection = [0, 0, 1]\n",
        r"\[shape\] direction: unknown key .*parameters of isophotes: light, form",
    ),
    "light zero": (
        SPHERE + "[shape]\nlight = [0, 0, 0]\n",
        r"\[shape\] light: expected a direction \[x, y, z\] of length at least 1e-12, got \[0, 0",
    ),
    "light a string": (
        SPHERE + '[shape]\nlight = "up"\n',
        r"\[shape\] light: expected 3 numbers \[x, y, z\] \(parameter of isophotes: light "
        r'direction l\), got "up"',
    ),
    "form unknown": (
        SPHERE + '[shape]\nform = "sin"\n',
        r'\[shape\] form: expected one of "cos", "angle", got "sin"',
    ),
    "display unknown": (
        SPHERE + '[shape]\ndisplay = "zebra"\n',
        r'\[shape\] display: expected one of "stripes", "colormap", "both", "bands", got "zebra"',
    ),
    "period and stripes": (
        SPHERE + "[shape]\nperiod = 0.1\nstripes = 20\n",
        r"\[shape\] stripes: expected either period or stripes, not both, got period = 0.1 "
        r"and stripes = 20",
    ),
    "period zero": (
        SPHERE + "[shape]\nperiod = 0\n",
        r"\[shape\] period: expected a positive number, got 0",
    ),
    "duty one": (
        SPHERE + "[shape]\nduty = 1\n",
        r"\[shape\] duty: expected a number in \(0, 1\), got 1",
    ),
    "range reversed": (
        SPHERE + "[shape]\nrange = [1, -1]\n",
        r"\[shape\] range: expected \[min, max\] with min < max, got \[1, -1\]",
    ),
    "range equal": (
        SPHERE + "[shape]\nrange = [1, 1]\n",
        r"range: expected \[min, max\] with min < max",
    ),
    "range one number": (
        SPHERE + "[shape]\nrange = [1]\n",
        r"\[shape\] range: expected \[min, max\], two numbers, got \[1\]",
    ),
    "colormap unknown": (
        SPHERE + '[shape]\ncolormap = "viridus"\n',
        r'\[shape\] colormap: expected the name of a matplotlib colour map .*got "viridus"; '
        r'did you mean "viridis"',
    ),
    # camera and render choices
    "camera type unknown": (
        SPHERE + '[camera]\ntype = "fisheye"\n',
        r'\[camera\] type: expected one of "perspective", "orthographic", got "fisheye"',
    ),
    "lighting unknown": (
        SPHERE + '[render]\nlighting = "dark"\n',
        r'\[render\] lighting: expected one of "lit", "flat", "soft", got "dark"',
    ),
    "variant unknown": (
        SPHERE + '[render]\nvariant = "cuda_rgb"\n',
        r'\[render\] variant: expected one of "auto", "llvm_ad_rgb", "scalar_rgb", "cuda_ad_rgb", '
        r'got "cuda_rgb"',
    ),
    "spp zero": (
        SPHERE + "[render]\nspp = 0\n",
        r"\[render\] spp: expected an integer from 1 to 4096, got 0",
    ),
    "width negative": (
        SPHERE + "[render]\nwidth = -640\n",
        r"\[render\] width: expected an integer from 1 to 16384, got -640",
    ),
    "height a float": (
        SPHERE + "[render]\nheight = 480.5\n",
        r"\[render\] height: expected an integer from 1 to 16384, got 480.5",
    ),
    "width a string": (
        SPHERE + '[render]\nwidth = "640"\n',
        r'\[render\] width: expected an integer from 1 to 16384, got "640"',
    ),
    "seed negative": (
        SPHERE + "[render]\nseed = -1\n",
        r"\[render\] seed: expected an integer from 0 to 4294967295, got -1",
    ),
    "tessellation one": (
        SPHERE + "[render]\ntessellation = 1\n",
        r"\[render\] tessellation: expected an integer from 2 to 1024, got 1",
    ),
    "chord tolerance zero": (
        SPHERE + "[render]\nchord_tolerance = 0\n",
        r"\[render\] chord_tolerance: expected a number in \[1e-09, 1\], got 0",
    ),
    # check
    "check channels a string": (
        SPHERE + '[check]\nchannels = "RGB"\n',
        r'\[check\] channels: expected a list of channel names \(strings\), got "RGB"',
    ),
    "check channels numbers": (
        SPHERE + "[check]\nchannels = [1, 2]\n",
        r"\[check\] channels: expected a list of channel names",
    ),
    "check percent": (
        SPHERE + "[check]\nfailpercent = 200\n",
        r"\[check\] failpercent: expected a number in \[0, 100\], got 200",
    ),
    "check fail a string": (
        SPHERE + '[check]\nfail = "x"\n',
        r'\[check\] fail: expected a number >= 0, got "x"',
    ),
    "check spp": (
        SPHERE + "[check]\nspp = 0.5\n",
        r"\[check\] spp: expected an integer from 1 to 4096, got 0.5",
    ),
    # the types are the scene's to check, the domains the patch constructors' (named by key)
    "junction class unknown": (
        JUNCTION + 'continuity = "G5"\n',
        r"\(junction\): continuity: expected one of G0, G1, G2, G3, got 'G5'$",
    ),
    "junction class a number": (
        JUNCTION + "continuity = 2\n",
        r'\(junction\): continuity: expected one of "G0", .*, got 2$',
    ),
    "nuspline ends unknown": (
        NUSPLINE + 'ends = "open"\n',
        r"\(nuspline\): ends: expected one of \"natural\", \"closed\" or a pair \[u, v\] of them, "
        r"got 'open'$",
    ),
    "nuspline ends numbers": (
        NUSPLINE + "ends = [1, 2]\n",
        r'\(nuspline\): ends: expected one of "natural", "closed" or a pair \[u, v\] of them',
    ),
    "nuspline tensions count": (
        NUSPLINE + "nu_u = [0, 0, 0]\n",
        r"\(nuspline\): nu_u: expected numbers >= 0: one number or a list of 2 .*got 3 numbers",
    ),
    "nuspline tensions a string": (
        NUSPLINE + 'nu_v = "x"\n',
        r'\(nuspline\): nu_v: expected a number or a list of numbers .*got "x"$',
    ),
    "betaspline net too small": (
        '[[surface]]\ntype = "betaspline"\npoints = ' + NET + "\n",
        r"\(betaspline\): points: expected at least 4 control points per direction",
    ),
    "betaspline bias per junction": (
        BETASPLINE + "beta1_u = [1, 1]\n",
        r"\(betaspline\): beta1_u: expected a number > 0 \(the bias\) or a list of 1 .*got 2",
    ),
    "betaspline tension negative": (
        BETASPLINE + "beta2 = -1\n",
        r"\(betaspline\): beta2: expected a number >= 0 \(the tension\), got -1",
    ),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_input(tmp_path, case):
    text, message = BAD[case]
    path = write(tmp_path, text)
    with pytest.raises(GshadeError, match=message) as info:
        load_scene(path)
    text = str(info.value)
    assert text.startswith(f"{path}: "), text
    assert "\n" not in text
    assert isinstance(info.value, ValueError)


def _toml(value) -> str:
    return repr(value).replace("'", '"').replace("(", "[").replace(")", "]")


#: (table, keys and values written to the scene, the library's check of the same values, what
#: the loaded scene holds of them): rules written once, in the library, that the scene applies
#: to its values
ONE_RULE = [
    *(
        ("shape", {"range": r}, lambda r=r: validate_range(r), lambda s: s.shape.value_range)
        for r in ([1, 1], [2, 1], [0.0, -0.0], [0, 5e-324], [-1.5, 2])
    ),
    *(
        ("shape", {"colormap": c}, lambda c=c: validate_colormap(c), lambda s: s.shape.colormap)
        for c in ("viridis", "viridus", "Viridis", "coolwarm")
    ),
    *(
        (
            "shape",
            {"function": fn, key: v},
            lambda f=fn, k=key, v=v: validate_parameter(f, k, v),
            lambda s, k=key: s.shape.params[k],
        )
        for fn, key, values in (
            ("isophotes", "light", ([0, 0, 0], [1e-13, 0, 0], [0, 1e-12, 0], [0, 0, 1])),
            ("isophotes", "form", ("cos", "sine", "Angle")),
            ("planar_sections", "direction", ([0, 0, 0], [0, 0, 9.9e-13], [1, 2, 3])),
        )
        for v in values
    ),
    *(
        (
            "camera",
            {"origin": o, "target": t, "up": u},
            lambda o=o, t=t, u=u: Camera("perspective", o, t, u, 30.0, None),
            lambda s: s.camera,
        )
        for o, t, u in (
            ([1, 1, 1], [1, 1, 1], [0, 0, 1]),
            ([0, 0, 5], [0, 0, 0], [0, 0, 1]),
            ([0, 0, 5], [0, 0, 0], [0, 1e-12, 1]),
            ([0, 0, 5], [0, 0, 0], [0, 0, 0]),
            ([0, 0, 5], [0, 0, 0], [0, 9e-13, 0]),
            ([0, -5, 0], [0, 0, 0], [0, 0, 1]),
        )
    ),
]


@pytest.mark.parametrize(("table", "values", "library", "loaded"), ONE_RULE)
def test_the_scene_refuses_what_the_library_refuses_with_its_message(
    table, values, library, loaded
):
    """One rule: the scene passes its values to the library's check and names its file and
    table before the library's message; what the library accepts, the scene loads (as
    written: a direction is made a unit vector where the function is evaluated)."""
    text = SPHERE + f"[{table}]\n" + "".join(f"{k} = {_toml(v)}\n" for k, v in values.items())
    try:
        expected = library()
    except GshadeError as exc:
        with pytest.raises(GshadeError) as info:
            parse_scene(text)
        assert str(info.value) == f"<string>: [{table}] {exc}"
    else:
        got = loaded(parse_scene(text))
        if table == "camera":  # the scene's camera is the library's, and perspective
            assert (got.origin, got.target, got.up) == (
                expected.origin,
                expected.target,
                expected.up,
            )
        else:
            (written,) = (v for k, v in values.items() if k != "function")
            np.testing.assert_array_equal(np.asarray(got), np.asarray(written, dtype=object))
            assert expected is not None


def test_newell_file_missing(tmp_path):
    path = write(tmp_path, '[[surface]]\ntype = "newell"\nfile = "data/teapot.txt"\n')
    with pytest.raises(GshadeError) as info:
        load_scene(path)
    assert str(info.value) == (
        f"{path}: [[surface]] 1 (newell): file: expected an existing file (relative to the "
        f'scene file), got "data/teapot.txt" (no such file: {tmp_path / "data" / "teapot.txt"})'
    )


def test_newell_file_unparsable(tmp_path):
    (tmp_path / "bad.txt").write_text("1\n1, 2, 3\n")
    path = write(tmp_path, SPHERE + '[[surface]]\ntype = "newell"\nfile = "bad.txt"\n')
    with pytest.raises(GshadeError) as info:
        load_scene(path)
    assert str(info.value).startswith(
        f"{path}: [[surface]] 2 (newell): {tmp_path / 'bad.txt'}, line 2: "
    )
    assert "expected 16 vertex indices" in str(info.value)


def test_scene_file_missing_unreadable_or_not_text(tmp_path):
    with pytest.raises(GshadeError, match=r"nope.toml: no such file"):
        load_scene(tmp_path / "nope.toml")
    with pytest.raises(
        GshadeError, match=r": expected a scene file \(TOML\) \(a regular file\), got a directory"
    ):
        load_scene(tmp_path)
    path = tmp_path / "binary.toml"
    path.write_bytes(b'name = "\xff"\n')
    with pytest.raises(
        GshadeError, match=r"binary.toml: expected a UTF-8 text file .* 0xff at offset 8"
    ):
        load_scene(path)


WRONG_VALUES = ["x", "", 0, -1, 1.5, True, [], [1], [1, 2, 3], [[1, 2, 3]], {"a": 1}, [[["a"]]]]


@pytest.mark.parametrize(
    "key",
    [
        "name",
        *(f"shape.{k}" for k in ("function", "display", "period", "duty", "phase", "range")),
        *(f"shape.{k}" for k in ("colormap", "colour_function", "eye_point", "form", "a1")),
        *(f"camera.{k}" for k in ("type", "origin", "target", "up", "fov", "width")),
        *(f"render.{k}" for k in ("width", "spp", "lighting", "variant", "seed", "tessellation")),
        *(f"render.{k}" for k in ("chord_tolerance", "texture_resolution")),
        *(f"check.{k}" for k in ("width", "channels", "fail", "warnpercent")),
        *(f"surface.1.{k}" for k in ("type", "file", "up")),
        *(f"surface.2.{k}" for k in ("points", "weights")),
        *(f"surface.3.{k}" for k in ("degree", "knots_u", "points", "weights")),
        *(f"surface.4.{k}" for k in ("v0", "cross_u1")),
        "surface.5.radius",
        "surface.6.minor",
        "surface.7.height",
    ],
)
def test_any_wrong_value_gives_a_gshade_error(key):
    """Whatever the value, a wrong one is a one-line GshadeError naming the file and key."""
    for value in WRONG_VALUES:
        try:
            load_scene(FULL, {key: value})
        except GshadeError as exc:
            text = str(exc)
            assert text.startswith(f"{FULL}: "), text
            assert "\n" not in text
            assert key.rsplit(".", 1)[-1] in text, text


def test_bands_are_checked_when_the_scene_loads():
    """display = "bands" needs a function with bands, with their parameters' own rules."""
    shape = parse_scene(SPHERE + '[shape]\nfunction = "draft_angle"\ndisplay = "bands"\n').shape
    assert (shape.display, shape.function) == ("bands", "draft_angle")
    with pytest.raises(GshadeError, match=r'\[shape\] display: "bands" expected a function with'):
        parse_scene(SPHERE + '[shape]\nfunction = "mean"\ndisplay = "bands"\n')
    with pytest.raises(GshadeError, match=r"\[shape\] draft_angle: min_angle: expected degrees"):
        parse_scene(
            SPHERE + '[shape]\nfunction = "draft_angle"\ndisplay = "bands"\nmin_angle = 90\n'
        )


@pytest.mark.parametrize(
    "shape, message",
    [
        ('function = "draft_angle"\nmin_angle = 120', "draft_angle: min_angle: expected degrees"),
        ('function = "min_radius"\nlimit = -2', "min_radius: limit: expected a positive length"),
        (
            'function = "reflection_lines"\nform = "infinity"\naxis = [0, 0, 1]\n'
            "reference = [0, 0, -3]",
            "reflection_lines: reference: expected a direction not parallel to axis",
        ),
        (
            'function = "isophotes"\ndisplay = "both"\ncolour_function = "draft_angle"\n'
            "min_angle = 95",
            "draft_angle: min_angle",
        ),
    ],
)
def test_the_rules_between_parameters_are_checked_when_the_scene_loads(tmp_path, shape, message):
    """Whatever the display: one line naming the file and the table, before any render."""
    path = write(tmp_path, SPHERE + "[shape]\n" + shape + "\n")
    with pytest.raises(GshadeError) as caught:
        load_scene(path)
    text = str(caught.value)
    assert text.startswith(f"{path}: [shape] ") and message in text and "\n" not in text


def test_comb_sections_keys(tmp_path):
    """The sections' planes: a count and a nonzero normal (a tuple, as the Python API and
    ``gshade check`` hand a resolved setting back, or a TOML list)."""
    path = write(tmp_path, SPHERE)
    render = load_scene(path, {"render.comb_section_direction": (1, 0, 0)}).render
    assert (render.comb_sections, render.comb_section_direction) == (8, (1.0, 0.0, 0.0))
    assert load_scene(path).render.comb_section_direction is None
    with pytest.raises(GshadeError, match=r"comb_section_direction: expected a direction"):
        load_scene(path, {"render.comb_section_direction": [0, 0, 0]})
    with pytest.raises(GshadeError, match=r"comb_sections: expected an integer from 1 to 256"):
        load_scene(path, {"render.comb_sections": 0})
    with pytest.raises(GshadeError, match=r"comb_lines: expected a list of"):
        load_scene(path, {"render.comb_lines": ["sections", "sections"]})
