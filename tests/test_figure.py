"""`gshade figure`: multi-panel figures with titles, colour bars, periods and metadata."""

import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from gshade import GshadeError
from gshade.app.figure import load_figure_spec, make_figure

from .conftest import ROOT

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
