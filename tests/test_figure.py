"""`gshade figure`: multi-panel figures with titles, colour bars, periods and metadata."""

import subprocess
import sys

import pytest
from PIL import Image

from gshade import GshadeError
from gshade.figure import load_figure_spec, make_figure

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


def test_same_range_puts_one_colour_range_on_a_row(spec):
    from gshade.figure import _panel, _same_range

    loaded = load_figure_spec(spec)
    row = [(*_panel(loaded.rows[0], c.overrides, loaded), c) for c in loaded.columns]
    row = _same_range(loaded.rows[0], row, loaded)
    ranges = {image.legend.value_range for _, image, _ in row if image.legend.value_range}
    assert len(ranges) == 1


def test_bad_specs_name_the_key(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('rows = ["nothing.toml"]\n')
    with pytest.raises(GshadeError, match="rows: no such scene file"):
        load_figure_spec(bad)
    bad.write_text("rows = []\n")
    with pytest.raises(GshadeError, match="rows: expected a list of scene files"):
        load_figure_spec(bad)
    bad.write_text(f'rows = ["{ROOT / "scenes" / "sphere-isophotes.toml"}"]\ncolumns = 3\n')
    with pytest.raises(GshadeError, match="columns: unknown key"):
        load_figure_spec(bad)
    result = subprocess.run(
        [sys.executable, "-m", "gshade.cli", "figure", str(bad), "-o", str(tmp_path / "x.gif")],
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
