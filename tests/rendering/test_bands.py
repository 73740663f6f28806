"""``display = "bands"``: the analyses' flat colours, exact on a kernel-made drafted block,
anti-aliased as the numpy formula says, with the parting line drawn."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("OCP")

from scipy import ndimage

from gshade.display.bands import band_colours
from gshade.display.colour import srgb_to_linear
from gshade.errors import GshadeError
from gshade.rendering import render
from gshade.scene import load_scene
from gshade.shape import function_bands

from ..support.cad_parts import BLOCK_DRAFTS, sphere_cap, tapered_block, write_shape

MIN_ANGLE = 2.0

SCENE = """
[[surface]]
type = "cad"
file = "{file}"

[shape]
function = "draft_angle"
display = "bands"
direction = [0, 0, 1]
min_angle = {min_angle}

[camera]
origin = {origin}
target = [0, 0, 3]
up = [0, 0, 1]
fov = 40

[render]
width = {width}
height = {height}
spp = {spp}
lighting = "flat"
"""


@pytest.fixture(scope="module")
def parts(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("bands")
    write_shape(tapered_block(), folder / "block.step")
    write_shape(sphere_cap(h=-3.0), folder / "cap.step")  # latitudes -37 to 90
    return folder


def _scene(folder: Path, file: str, origin, width=200, height=150, spp=4, name="s.toml"):
    text = SCENE.format(
        file=file, min_angle=MIN_ANGLE, origin=list(origin), width=width, height=height, spp=spp
    )
    path = folder / name
    path.write_text(text)
    return load_scene(path)


def _band_colour(draft: float) -> np.ndarray:
    bands = function_bands("draft_angle", {"min_angle": MIN_ANGLE})
    k = int(np.searchsorted(bands.edges, draft, side="right"))  # at an edge: the band above
    return srgb_to_linear(np.asarray(bands.colours[k], dtype=np.float64))


@pytest.mark.parametrize("origin", [(40, -45, 30), (-40, 45, 30)])
def test_each_drafted_side_is_its_exact_draft_in_one_colour(parts, origin):
    """The block's sides lean by 3, 1, 0 and -2 degrees (the kernel built them so): f is
    that draft on every pixel of the side, and the side is one flat colour, its band's: 3 and
    the top (90) enough, 1 and 0 (a wall exactly along the pull: on the edge, the band above)
    too little, -2 undercut."""
    image = render(_scene(parts, "block.step", origin))
    A, patch, f = image["A"], image["patch"], image["f"]
    N = np.stack([image["N.X"], image["N.Y"], image["N.Z"]], -1)
    rgb = np.stack([image["R"], image["G"], image["B"]], -1)
    inside = ndimage.binary_erosion(A == 1, iterations=2)
    core = inside & (ndimage.minimum_filter(patch, 5) == ndimage.maximum_filter(patch, 5))
    sides = {(1, 0): BLOCK_DRAFTS[0], (-1, 0): BLOCK_DRAFTS[1], (0, 1): BLOCK_DRAFTS[2]}
    sides[(0, -1)] = BLOCK_DRAFTS[3]
    seen = []
    for face in np.unique(patch[core]):
        on = core & (patch == face)
        n = N[on].mean(0)
        if n[2] > 0.9:
            draft = 90.0
        else:
            draft = sides[tuple(round(float(c)) for c in n[:2] / np.abs(n[:2]).max())]
        seen.append(draft)
        np.testing.assert_allclose(f[on], draft, atol=2e-5)
        assert len(np.unique(rgb[on], axis=0)) == 1, f"draft {draft}: one colour"
        np.testing.assert_allclose(rgb[on][0], _band_colour(draft), atol=2e-6)
    assert len(seen) == 3 and 90.0 in seen


def test_the_bands_are_the_numpy_formula_over_each_pixel(parts):
    """One sample per pixel (at its centre, its footprint the whole pixel): the picture is
    band_colours of the exact f there and of its change across the pixel, f_x and f_y (as
    the renderer's own differences), to the renderer's single precision."""
    scene = _scene(parts, "cap.step", (16, -18, 4), width=160, height=120, spp=1)
    image = render(scene, aovs=("draft_angle",))
    A, f = image["A"], image["f"]
    rgb = np.stack([image["R"], image["G"], image["B"]], -1)
    inside = ndimage.binary_erosion(A == 1, iterations=2)
    fx = np.zeros_like(f)
    fy = np.zeros_like(f)
    fx[:, 1:-1] = (f[:, 2:] - f[:, :-2]) / 2
    fy[1:-1, :] = (f[2:, :] - f[:-2, :]) / 2
    bands = function_bands("draft_angle", {"min_angle": MIN_ANGLE})
    expected = band_colours(f, fx, fy, bands)
    error = np.abs(rgb - expected).max(-1)[inside]
    assert error.max() < 0.03 and np.median(error) < 1e-6
    # the parting line (draft 0, the equator) is drawn over the bands: darker than any band
    on_line = inside & (np.abs(f) < 0.25 * np.hypot(fx, fy))
    darkest = min(srgb_to_linear(np.asarray(c, float)).sum() for c in bands.colours)
    assert on_line.sum() > 20
    assert (rgb[on_line].sum(-1) < 0.8 * darkest).all()


def test_bands_need_a_function_with_bands(parts, tmp_path):
    text = SCENE.format(
        file=parts / "block.step", min_angle=1, origin=[40, -45, 30], width=8, height=8, spp=1
    ).replace('"draft_angle"', '"mean"')
    path = tmp_path / "mean.toml"
    path.write_text(text.replace("min_angle = 1\n", "").replace("direction = [0, 0, 1]\n", ""))
    with pytest.raises(GshadeError, match=r'display: "bands" expected a function with bands'):
        load_scene(path)
