"""``--legend``: the PNG carries its legend below the picture, whose pixels stay as they
were; the colour bar's colours are the picture's colour map."""

from __future__ import annotations

import numpy as np
import PIL.Image

from gshade.app.cli import main
from gshade.display.colour import Legend, colour_map
from gshade.display.legend_strip import with_legend


def test_the_strip_goes_under_the_picture_and_leaves_it_alone():
    rng = np.random.default_rng(0)
    rgb, alpha = rng.random((30, 240, 3)), rng.random((30, 240))
    legend = Legend("mean", 2, "colormap", (-2.0, 2.0), "viridis", units="1/mm")
    out, a = with_legend(rgb, alpha, legend)
    assert out.shape[1] == 240 and out.shape[0] > 30 + 20
    assert np.array_equal(out[:30], rgb) and np.array_equal(a[:30], alpha)
    assert (a[30:] == 1).all()
    # the bar's middle row runs through the map: its colours are the map's, left to right
    strip = out[30:]
    x = np.arange(30, 210)
    t = (x + 0.5 - 0.08 * 240) / (0.84 * 240)  # the bar spans 8 % to 92 % of the width
    row = strip[6, x]
    expected = colour_map(-2 + 4 * t, value_range=(-2, 2), cmap="viridis").rgb
    assert np.abs(row - expected).max() < 0.05
    # and it is no bar without a colour map: only text (dark pixels) on white
    plain, _ = with_legend(rgb, alpha, Legend("isophotes", 1, "stripes", period=0.1))
    assert plain.shape[0] < out.shape[0]


def test_render_legend_needs_a_png(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text('[[surface]]\ntype = "sphere"\n[render]\nwidth = 40\nheight = 30\n')
    assert main(["render", str(scene), "-o", str(tmp_path / "s.exr"), "--legend"]) == 2
    assert "--legend" in capsys.readouterr().err
    assert not (tmp_path / "s.exr").exists()
    png = tmp_path / "s.png"
    code = main(
        ["render", str(scene), "-o", str(tmp_path / "s.exr"), "--png", str(png), "--legend"]
    )
    assert code == 0
    width, height = PIL.Image.open(png).size
    assert width == 40 and height > 30
