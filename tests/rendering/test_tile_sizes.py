"""Per-patch texture tiles (issue 27 point 3): a small patch costs what its pixels cost, a
few patches all keep the largest one's tile (the pictures before 0.8), and the picture does
not change with the tiles."""

from __future__ import annotations

import json

import numpy as np
import pytest

from gshade.io import read_exr
from gshade.rendering import render
from gshade.rendering.atlas import BLOCK, Atlas
from gshade.scene import load_scene


def _bump(x0: float, y0: float, size: float) -> str:
    """A bicubic Bezier bump over [x0, x0 + size]^2, as a ``[[surface]]`` table."""
    rows = []
    for i in range(4):
        row = []
        for j in range(4):
            z = 0.3 * size * (1.0 if i in (1, 2) and j in (1, 2) else 0.0) + 0.05 * size * i * j / 9
            row.append(f"[{x0 + size * i / 3:.6g}, {y0 + size * j / 3:.6g}, {z:.6g}]")
        rows.append("[" + ", ".join(row) + "]")
    return '[[surface]]\ntype = "bezier"\npoints = [' + ", ".join(rows) + "]\n"


def _scene(tmp_path, small: int, texture_resolution: int | None = None):
    """One large bump and ``small`` tiny ones beside it, isophote stripes, flat."""
    text = _bump(0.0, 0.0, 10.0)
    for k in range(small):
        text += _bump(11.0 + 0.5 * (k % 10), 0.5 * (k // 10), 0.4)
    text += '[shape]\nfunction = "isophotes"\ndisplay = "stripes"\nperiod = 0.1\n'
    text += '[render]\nwidth = 320\nheight = 240\nspp = 4\nlighting = "flat"\n'
    if texture_resolution:
        text += f"texture_resolution = {texture_resolution}\n"
    text += "[camera]\norigin = [8, -14, 16]\ntarget = [8, 3, 0]\nup = [0, 0, 1]\nfov = 45\n"
    path = tmp_path / f"scene-{small}-{texture_resolution}.toml"
    path.write_text(text)
    return path


def _settings(tmp_path, path) -> tuple[dict, dict]:
    out = tmp_path / (path.stem + ".exr")
    render(load_scene(path)).write(out)
    channels, header = read_exr(out)
    return channels, json.loads(header["settings"])


def test_small_patches_get_small_tiles_and_the_same_picture(tmp_path):
    path = _scene(tmp_path, 300)
    channels, settings = _settings(tmp_path, path)
    largest = settings["texture_tile"]
    # 301 tiles of the largest size would be 301 T^2 texels; the tiny bumps take few
    assert settings["texture_texels"] < 0.1 * 301 * largest**2
    assert settings["texture_texels"] <= 2 * 320 * 240 + 301 * BLOCK**2
    # the same picture as with every tile the largest one's size (the rule before 0.8)
    uniform, same = _settings(tmp_path, _scene(tmp_path, 300, largest))
    assert same["texture_texels"] == 301 * largest**2
    hit = (channels["A"] > 0) | (uniform["A"] > 0)
    for c in "RGB":
        diff = np.abs(channels[c] - uniform[c])[hit]
        assert np.mean(diff > 0.02) < 1e-3, c
        assert diff.max() < 0.1, c


def test_a_few_patches_all_keep_the_largest_tile(tmp_path):
    _, settings = _settings(tmp_path, _scene(tmp_path, 3))
    assert settings["texture_texels"] == 4 * settings["texture_tile"] ** 2


@pytest.mark.parametrize(
    "sizes", [[8, 8, 8], [64, 8, 16, 8, 8, 24], [512, 8], [(8, 64), (64, 8), (16, 8), (8, 8)]]
)
def test_tiles_of_several_sizes_do_not_overlap(sizes):
    atlas = Atlas.for_tiles(sizes)
    sizes = [(T, T) if np.ndim(T) == 0 else T for T in sizes]
    owner = np.full((atlas.height, atlas.width), -1)
    for k in range(len(sizes)):
        rows, cols = atlas.tile_slices(k)
        assert (owner[rows, cols] == -1).all()
        owner[rows, cols] = k
        assert owner[rows, cols].shape == (sizes[k][1], sizes[k][0])  # rows x columns
    # each block names the tile it lies in
    blocks = atlas.patch_of_block.reshape(atlas.height // atlas.block, -1)
    ours = owner[:: atlas.block, :: atlas.block]
    np.testing.assert_array_equal(blocks[ours >= 0], ours[ours >= 0])


def test_a_long_thin_patch_gets_a_long_thin_tile(tmp_path):
    """A strip 40 long and 0.4 wide beside 300 tiny bumps: its tile is long along the
    strip and short across (a square one would take its length squared)."""
    from gshade.rendering.pipeline import _settings as render_settings
    from gshade.rendering.sizing import frame, tile_sizes

    strip = (
        "["
        + ", ".join(
            "["
            + ", ".join(f"[{40 * i / 3:.6g}, {-2 + 0.4 * j / 3:.6g}, 0]" for j in range(4))
            + "]"
            for i in range(4)
        )
        + "]"
    )
    path = _scene(tmp_path, 300)
    text = path.read_text().replace(
        "[shape]", f'[[surface]]\ntype = "bezier"\npoints = {strip}\n[shape]'
    )
    path.write_text(text)
    scene = load_scene(path)
    settings, where = render_settings(scene)
    sizes = tile_sizes(scene, frame(scene, settings, where))
    S, T = sizes[-1]  # the strip's: s runs along it
    assert S >= 4 * T
    assert not (sizes % BLOCK).any()
