"""`gshade figure`: multi-panel figures with titles, colour bars, periods and metadata."""

import json
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from gshade import GshadeError
from gshade.app.figure import load_figure_spec, make_figure

from ..support.paths import ROOT

SPEC = """
title = "test"
rows = ["{scene}", "{scene}"]
row_labels = ["a", "b"]
width = 64
height = 48
spp = 1
same_range = true
[[column]]
label = "isophotes"
set = {{ "shape.function" = "isophotes", "shape.period" = 0.1 }}
[[column]]
label = "mean"
set = {{ "shape.function" = "mean", "shape.display" = "colormap" }}
[[column]]
label = "mean again"
set = {{ "shape.function" = "mean", "shape.display" = "colormap", "render.lighting" = "lit" }}
"""


@pytest.fixture
def spec(tmp_path):
    path = tmp_path / "fig.toml"
    path.write_text(SPEC.format(scene=ROOT / "scenes" / "sphere-isophotes.toml"))
    return path


@pytest.mark.parametrize("fmt", ["png", "pdf", "svg"])
def test_figure_in_every_format_records_its_scenes(spec, tmp_path, fmt):
    loaded = load_figure_spec(spec)
    out = make_figure(loaded, tmp_path / f"fig.{fmt}")
    data = out.read_bytes()
    assert len(loaded.hashes) == 6  # 2 rows x 3 columns
    if fmt == "png":
        image = Image.open(out)
        assert image.info["Software"].startswith("gshade")
        assert next(iter(loaded.hashes.values())) in image.info["Description"]
        assert image.size[0] > 1500  # 300 dpi
    elif fmt == "pdf":
        assert data.startswith(b"%PDF") and b"gshade" in data
    else:
        assert b"<svg" in data and b"<image" in data and b"scene_hashes" in data


RANGE_SPEC = """
rows = ["{r1}", "{r4}"]
row_labels = ["r1", "r4"]
width = 64
height = 48
spp = 1
same_range = true
[[column]]
label = "isophotes"
set = {{ "shape.function" = "isophotes", "shape.period" = 0.1 }}
[[column]]
label = "mean"
set = {{ "shape.function" = "mean", "shape.display" = "colormap" }}
[[column]]
label = "mean r2"
set = {{ "shape.function" = "mean", "shape.display" = "colormap", "surface.1.radius" = 2 }}
[[column]]
label = "gaussian r2"
set = {{ "shape.function" = "gaussian", "shape.display" = "colormap", "surface.1.radius" = 2 }}
[[column]]
label = "mean fixed"
set = {{ "shape.function" = "mean", "shape.display" = "colormap", "shape.range" = [-3, 3] }}
"""


def test_same_range_shares_each_rows_range_among_panels_of_one_function(tmp_path, monkeypatch):
    """Spheres: |H| = 1/r and K = 1/r^2 everywhere, so every panel's own automatic range is
    known (signed functions: +-max |f|).  With same_range, a row's panels of one function
    share the range covering all of them (per row, not per figure); another function, a
    panel with a fixed range and a striped panel keep their own.  Checked on what the
    figure draws: the colour bars' limits, and the panels' pixels against the colour map."""
    import matplotlib
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    sphere = (ROOT / "scenes" / "sphere-isophotes.toml").read_text()
    assert "radius = 1.0" in sphere
    rows = {}
    for r in (1.0, 4.0):
        path = tmp_path / f"sphere-r{r:g}.toml"
        path.write_text(sphere.replace("radius = 1.0", f"radius = {r!r}"))
        rows[f"r{r:g}"] = path
    spec_path = tmp_path / "ranges.toml"
    spec_path.write_text(RANGE_SPEC.format(r1=rows["r1"], r4=rows["r4"]))

    bars, pictures = {}, {}
    imshow, colorbar = Axes.imshow, Figure.colorbar

    def record_imshow(ax, data, *args, **kwargs):
        pictures[ax] = np.array(data)
        return imshow(ax, data, *args, **kwargs)

    def record_colorbar(fig, mappable, *args, **kwargs):
        bars[kwargs["ax"]] = (mappable.norm.vmin, mappable.norm.vmax, mappable.cmap.name)
        return colorbar(fig, mappable, *args, **kwargs)

    monkeypatch.setattr(Axes, "imshow", record_imshow)
    monkeypatch.setattr(Figure, "colorbar", record_colorbar)
    make_figure(load_figure_spec(spec_path), tmp_path / "ranges.png")

    titles = {ax.get_title(): ax for ax in pictures}
    assert len(titles) == 10  # 2 rows x 5 columns
    # (function, radius) of each colour-mapped panel; the row's radius unless set
    panels = {"mean": ("mean", None), "mean r2": ("mean", 2.0), "gaussian r2": ("gaussian", 2.0)}
    for row, r_row in (("r1", 1.0), ("r4", 4.0)):
        assert titles[f"{row}: isophotes"] not in bars  # stripes: no colour bar
        assert bars[titles[f"{row}: mean fixed"]][:2] == (-3.0, 3.0)  # its own, fixed
        # the mean panels of this row: |H| = 1/r_row and 1/2; shared: the larger
        shared = max(1.0 / r_row, 1.0 / 2.0)
        expected = {"mean": shared, "mean r2": shared, "gaussian r2": 1.0 / 2.0**2}
        for column, (function, r) in panels.items():
            ax = titles[f"{row}: {column}"]
            lo, hi, cmap = bars[ax]
            m = expected[column]
            assert (lo, hi) == (pytest.approx(-m, rel=1e-5), pytest.approx(m, rel=1e-5)), (
                row,
                column,
            )
            # the picture uses the bar's range: the centre pixel (on the sphere) has the
            # colour of f = +-1/r (mean) or 1/r^2 (gaussian) on that bar
            r = r_row if r is None else r
            f = 1.0 / r if function == "mean" else 1.0 / r**2
            signs = (-1.0, 1.0) if function == "mean" else (1.0,)
            centre = pictures[ax][24, 32]
            colours = [
                np.array(matplotlib.colormaps[cmap]((s * f - lo) / (hi - lo))[:3]) for s in signs
            ]
            assert min(np.abs(centre - c).max() for c in colours) < 0.02, (row, column, centre)


def test_bad_specs_name_the_key(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('rows = ["nothing.toml"]\n')
    with pytest.raises(GshadeError, match="rows: no such scene file"):
        load_figure_spec(bad)
    bad.write_text('title = "x"\nrows = [1,\n  2 3]\n')
    with pytest.raises(GshadeError, match=r"bad.toml: invalid TOML: .*\(at line 3, column 5\)"):
        load_figure_spec(bad)
    with pytest.raises(GshadeError, match=r"expected a figure spec .*got a directory"):
        load_figure_spec(tmp_path)
    bad.write_text("rows = []\n")
    with pytest.raises(GshadeError, match="rows: expected a list of scene files"):
        load_figure_spec(bad)
    bad.write_text(f'rows = ["{ROOT / "scenes" / "sphere-isophotes.toml"}"]\ncolumns = 3\n')
    with pytest.raises(GshadeError, match="columns: unknown key"):
        load_figure_spec(bad)
    result = subprocess.run(
        [sys.executable, "-m", "gshade", "figure", str(bad), "-o", str(tmp_path / "x.gif")],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1


def test_the_order_ladder_spec_loads():
    spec = load_figure_spec(ROOT / "scenes" / "figures" / "order-ladder.toml")
    assert [c.overrides["shape.function"] for c in spec.columns] == [
        "planar_sections",
        "isophotes",
        "reflection_lines",
        "environment",
        "mean",
    ]


@pytest.mark.parametrize(
    "path", sorted((ROOT / "scenes" / "figures").glob("*.toml")), ids=lambda p: p.stem
)
def test_every_figure_spec_and_its_panels_load(path):
    """Every shipped figure spec parses, and every panel's scene loads with its column's
    overrides (the rendering is test_figure_in_every_format's)."""
    from gshade.scene import load_scene

    spec = load_figure_spec(path)
    assert len(spec.row_labels) == len(spec.rows)
    for row in spec.rows:
        for column in spec.columns:
            assert load_scene(row, column.overrides).patches


# --------------------------------------------------------------------------- framing, cameras,
# junctions (issue 17, point 5)

FRAMED_SPEC = """
rows = [{rows}]
width = 96
height = 64
spp = 1
{extra}
[[column]]
label = "isophotes"
set = {{ "shape.function" = "isophotes", "shape.period" = 0.1 }}
[[column]]
label = "mean"
set = {{ "shape.function" = "mean", "shape.display" = "colormap" }}
{columns}
"""


def _automatic_sphere(tmp_path):
    """sphere-isophotes with an automatic perspective camera (no origin, no target)."""
    text = (ROOT / "scenes" / "sphere-isophotes.toml").read_text()
    camera = text[text.index("[camera]") : text.index("[render]")]
    path = tmp_path / "sphere-auto.toml"
    path.write_text(text.replace(camera, '[camera]\ntype = "perspective"\nfov = 40\n\n'))
    return path


def _rendered(spec_path, tmp_path, monkeypatch):
    """Make the figure; return its panels' rendered images in order, and the notes written
    under the panels (the axes' x labels)."""
    from matplotlib.axes import Axes

    import gshade.rendering

    images, notes = [], []
    render, set_xlabel = gshade.rendering.render, Axes.set_xlabel

    def record_render(scene, **kwargs):
        images.append(render(scene, **kwargs))
        return images[-1]

    def record_xlabel(ax, text, *args, **kwargs):
        notes.append(text)
        return set_xlabel(ax, text, *args, **kwargs)

    monkeypatch.setattr(gshade.rendering, "render", record_render)
    monkeypatch.setattr(Axes, "set_xlabel", record_xlabel)
    spec = load_figure_spec(spec_path)
    make_figure(spec, tmp_path / f"{spec_path.stem}.png")
    return spec, images, notes


def _coverage_box(image):
    """First and one-past-last covered column and row (coverage A > 0)."""
    a = image.alpha > 0
    cols, rows = np.flatnonzero(a.any(axis=0)), np.flatnonzero(a.any(axis=1))
    return cols[0], cols[-1] + 1, rows[0], rows[-1] + 1


def _camera(image):
    return json.loads(image.metadata["settings"])["camera"]


def _fills_to_margin(image, margin, tolerance=1.0):
    """The covered box touches the margin on one axis (both sides, within ``tolerance``
    pixels) and lies within it on the other."""
    h, w = image.alpha.shape
    c0, c1, r0, r1 = _coverage_box(image)
    touches = [
        abs(lo - margin * n) <= tolerance and abs(hi - (1 - margin) * n) <= tolerance
        for lo, hi, n in ((c0, c1, w), (r0, r1, h))
    ]
    within = [
        lo >= margin * n - tolerance and hi <= (1 - margin) * n + tolerance
        for lo, hi, n in ((c0, c1, w), (r0, r1, h))
    ]
    return any(touches) and all(within)


def test_tight_framing_fills_each_panel_up_to_the_margin(tmp_path, monkeypatch):
    """Three rows: a perspective camera given in the scene (two patch pairs filling about a
    third of the scene's own picture), an orthographic one given in the scene (a sphere) and
    an automatic perspective one.  With frame = "tight" every panel's coverage box touches
    the margin on one axis and lies within it on the other; with frame = "scene" the first
    row's does not.  One camera per row: a row's panels are rendered with identical
    cameras (the EXR header's settings)."""
    rows = [
        ROOT / "scenes" / "junctions-isophotes.toml",
        ROOT / "scenes" / "sphere-isophotes.toml",
        _automatic_sphere(tmp_path),
    ]
    quoted = ", ".join(f'"{r}"' for r in rows)
    tight = tmp_path / "tight.toml"
    tight.write_text(FRAMED_SPEC.format(rows=quoted, extra="margin = 0.1", columns=""))
    spec, images, _ = _rendered(tight, tmp_path, monkeypatch)
    assert spec.frame == "tight" and len(images) == 6
    for r in range(3):
        a, b = images[2 * r], images[2 * r + 1]
        assert _camera(a) == _camera(b), r  # one camera per row, to the last bit
        for image in (a, b):
            assert _fills_to_margin(image, 0.1), (r, _coverage_box(image))
    assert _camera(images[0])["origin"] == [4.4, -4.6, 5.2]  # the scene's eye, turned
    assert _camera(images[2])["type"] == "orthographic"

    scene = tmp_path / "scene.toml"
    scene.write_text(FRAMED_SPEC.format(rows=f'"{rows[0]}"', extra='frame = "scene"', columns=""))
    _, framed, _ = _rendered(scene, tmp_path, monkeypatch)
    assert _camera(framed[0]) == _camera(framed[1])
    assert _camera(framed[0])["fov"] == 76 and not _fills_to_margin(framed[0], 0.02)
    scene.write_text(FRAMED_SPEC.format(rows=f'"{rows[0]}"', extra="margin = 0.02", columns=""))
    _, fitted, _ = _rendered(scene, tmp_path, monkeypatch)
    assert _fills_to_margin(fitted[0], 0.02)
    c0, c1, r0, r1 = _coverage_box(framed[0])
    t0, t1, s0, s1 = _coverage_box(fitted[0])
    assert (t1 - t0) * (s1 - s0) > 1.2 * (c1 - c0) * (r1 - r0)  # the tight panel is fuller


def test_one_camera_frames_the_union_of_a_rows_surfaces(tmp_path, monkeypatch):
    """A column that shrinks the sphere: the row's camera is fitted on both spheres, so the
    large one fills the panel to the margin and the small one sits at the same place at
    half the size."""
    sphere = ROOT / "scenes" / "sphere-isophotes.toml"
    path = tmp_path / "union.toml"
    half = '[[column]]\nlabel = "r/2"\nset = { "surface.1.radius" = 0.5 }'
    path.write_text(FRAMED_SPEC.format(rows=f'"{sphere}"', extra="", columns=half))
    _, images, _ = _rendered(path, tmp_path, monkeypatch)
    assert len({json.dumps(_camera(i), sort_keys=True) for i in images}) == 1
    assert _fills_to_margin(images[0], 0.05)
    c0, c1, r0, r1 = _coverage_box(images[2])
    assert abs((r1 - r0) - 0.45 * 64) <= 2 and abs((c0 + c1) / 2 - 48) <= 1


def test_junctions_in_a_column(tmp_path, monkeypatch):
    """``junctions = true`` or ``"render.junctions" = true`` in a column draws that column's
    junctions (the G1 seam orange, the G2 seam green) and names them under the panel; the
    other columns stay without."""
    columns = (
        '[[column]]\nlabel = "seams"\njunctions = true\n'
        '[[column]]\nlabel = "seams, set"\nset = { "render.junctions" = true }'
    )
    row = ROOT / "scenes" / "junctions-isophotes.toml"
    path = tmp_path / "junctions.toml"
    path.write_text(FRAMED_SPEC.format(rows=f'"{row}"', extra="", columns=columns))
    spec, images, notes = _rendered(path, tmp_path, monkeypatch)
    assert [c.overrides.get("render.junctions") for c in spec.columns] == [None, None, True, True]
    drawn = ["junctions" in i.metadata for i in images]
    assert drawn == [False, False, True, True]
    assert sum("junctions: G1 orange, G2 green" in n for n in notes) == 2
    for image in images[2:]:
        rgb = image.rgb
        orange = (rgb[..., 0] > 0.9) & (np.abs(rgb[..., 1] - 0.42) < 0.1) & (rgb[..., 2] < 0.1)
        assert orange.sum() >= 10  # the G1 seam, drawn


def test_combs_and_parabolic_lines_in_a_column(tmp_path, monkeypatch):
    """``combs = true`` and ``parabolic = true`` in a column draw those overlays over its
    panels, and the notes under them say what they show (the combs' scale, the umbilics)."""
    columns = '[[column]]\nlabel = "combs"\ncombs = true\n[[column]]\nparabolic = true'
    row = ROOT / "scenes" / "junctions-isophotes.toml"
    path = tmp_path / "overlays.toml"
    path.write_text(FRAMED_SPEC.format(rows=f'"{row}"', extra="", columns=columns))
    spec, images, notes = _rendered(path, tmp_path, monkeypatch)
    notes = [n.replace("\n", " ") for n in notes]  # wrapped to the panel's width
    assert [c.overrides.get("render.combs") for c in spec.columns] == [None, None, True, None]
    assert ["combs" in i.metadata for i in images] == [False, False, True, False]
    assert sum("combs: space curvature, spine = " in n for n in notes) == 1
    assert sum("parabolic lines in magenta" in n for n in notes) == 1


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ("margin = 0.5", r"margin: expected a number in \[0, 0.45\]"),
        ('margin = "tight"', "margin: expected a number"),
        ("margin = true", "margin: expected a number"),
        ('frame = "loose"', "frame: expected one of: 'tight', 'scene', got 'loose'"),
        ("camera = 3", "camera: expected a table"),
        ("camera = { fovv = 3 }", "camera: fovv: unknown key"),
        (
            '[[column]]\nset = { "camera.fov" = 20 }',
            r"\[\[column\]\] 1: set: camera.fov: a row has one camera",
        ),
        (
            "[[column]]\nset = { camera = { origin = [0, -5, 0] } }",
            r"\[\[column\]\] 1: set: camera.origin: a row has one camera",
        ),
        (
            '[[column]]\nset = { "render.width" = 20 }',
            r"\[\[column\]\] 1: set: render.width: every panel has the spec's size",
        ),
        ('[[column]]\njunctions = "yes"', r"\[\[column\]\] 1: junctions: expected true or false"),
        ("[[column]]\ncombs = 1", r"\[\[column\]\] 1: combs: expected true or false, got 1"),
        (
            '[[column]]\nparabolic = false\nset = { "render.parabolic" = true }',
            r"\[\[column\]\] 1: parabolic: contradicts set's render.parabolic",
        ),
        (
            '[[column]]\njunctions = true\nset = { "render.junctions" = false }',
            r"\[\[column\]\] 1: junctions: contradicts",
        ),
    ],
)
def test_bad_framing_keys_name_the_file_and_key(tmp_path, extra, message):
    bad = tmp_path / "bad.toml"
    bad.write_text(f'rows = ["{ROOT / "scenes" / "sphere-isophotes.toml"}"]\n{extra}\n')
    with pytest.raises(GshadeError, match=message) as info:
        load_figure_spec(bad)
    assert str(info.value).startswith(f"{bad}: ") and "\n" not in str(info.value)


def test_a_perspective_eye_among_the_surfaces_is_refused(tmp_path):
    """No field of view shows surfaces around the eye: the row is named, one line."""
    path = tmp_path / "inside.toml"
    sphere = ROOT / "scenes" / "sphere-isophotes.toml"
    path.write_text(
        f'rows = ["{sphere}"]\nwidth = 32\nheight = 24\nspp = 1\n'
        'camera = { type = "perspective", origin = [0, 0, 0], target = [0, 1, 0], fov = 60 }\n'
    )
    with pytest.raises(GshadeError, match=r"inside.toml: frame: row .*sphere-isophotes.toml: "):
        make_figure(load_figure_spec(path), tmp_path / "inside.png")


@pytest.mark.parametrize(
    ("extra", "key", "reason"),
    [
        ('title = "$\\\\frac{$"', "title", r"Expected \frac{num}{den}"),
        ('row_labels = ["$\\\\undefinedmacro{x}$"]', "row_labels[0]", "Unknown symbol"),
        ('[[column]]\nlabel = "$x^$"', "[[column]] 1 label", "Expected"),
    ],
)
def test_a_bad_mathtext_names_the_spec_and_key(tmp_path, capsys, extra, key, reason):
    """Was "fig.png: cannot write the file: <the parser's lines>" after every panel was
    rendered: now refused when the spec loads, naming the spec, the key and the reason."""
    bad = tmp_path / "bad.toml"
    sphere = ROOT / "scenes" / "sphere-isophotes.toml"
    bad.write_text(f'rows = ["{sphere}"]\nwidth = 16\nheight = 12\nspp = 1\n{extra}\n')
    with pytest.raises(GshadeError) as info:
        load_figure_spec(bad)
    message = str(info.value)
    assert message.startswith(f"{bad}: {key}: expected text matplotlib can typeset")
    assert reason in message and "\n" not in message
    from gshade.app.cli import main

    assert main(["figure", str(bad), "-o", str(tmp_path / "fig.png")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and f"{key}: expected text" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml"]


def test_a_panel_title_made_of_a_row_and_a_column_label_is_checked(tmp_path):
    """Each label alone is plain text (one $), the panel's title "ROW: COLUMN" is not."""
    sphere = ROOT / "scenes" / "sphere-isophotes.toml"
    bad = tmp_path / "bad.toml"
    bad.write_text(
        f'rows = ["{sphere}", "{sphere}"]\nrow_labels = ["a $\\\\frac{{", "b"]\n'
        '[[column]]\nlabel = "c $"\n'
    )
    with pytest.raises(GshadeError, match=r"row_labels\[0\] with \[\[column\]\] 1 label"):
        load_figure_spec(bad)
    good = tmp_path / "good.toml"  # dollars that make no mathtext, and good mathtext, pass
    good.write_text(
        f'rows = ["{sphere}"]\ntitle = "$x^2$ costs $5"\nrow_labels = ["$\\\\alpha$"]\n'
    )
    assert load_figure_spec(good).title == "$x^2$ costs $5"


def test_a_camera_error_names_the_spec_and_row(tmp_path):
    """The camera's eye at the automatic target (the surfaces' centre) named no file."""
    ball = tmp_path / "ball.toml"
    ball.write_text('[[surface]]\ntype = "sphere"\nradius = 1.0\n')
    spec = tmp_path / "spec.toml"
    camera = "camera = { origin = [0, 0, 0] }"
    spec.write_text(f'rows = ["ball.toml"]\nwidth = 16\nheight = 12\nspp = 1\n{camera}\n')
    from gshade.app.figure import row_camera

    loaded = load_figure_spec(spec)
    with pytest.raises(GshadeError) as info:
        row_camera(loaded, loaded.rows[0])
    assert str(info.value).startswith(f"{spec}: row {loaded.rows[0]}: [camera] (target automatic")
