"""The sign of K in two tones with the parabolic lines over it, on a torus: hyperbolic on
the inner half (rho < R), elliptic on the outer, the parabolic lines the top and bottom
circles rho = R, z = +-r."""

import numpy as np
from scipy import ndimage

import gshade
from gshade.display.colour import srgb_to_linear
from gshade.scene import parse_scene
from gshade.shape import function_bands

R, r = 2.0, 0.8
TORUS = f"""
[[surface]]
type = "torus"
major = {R}
minor = {r}
[shape]
function = "gaussian"
display = "bands"
[camera]
origin = [0, -9, 6]
target = [0, 0, 0]
up = [0, 0, 1]
fov = 40
[render]
width = 200
height = 150
spp = 4
lighting = "flat"
"""


def test_the_torus_is_hyperbolic_inside_elliptic_outside_with_its_parabolic_circles():
    image = gshade.render(parse_scene(TORUS))
    on = image["patch"] >= 0
    rho = np.hypot(image["P.X"], image["P.Y"])
    z = image["P.Z"]
    rgb = np.stack([image["R"], image["G"], image["B"]], -1)
    bands = function_bands("gaussian", {})
    hyperbolic, elliptic = (srgb_to_linear(np.asarray(c, float)) for c in bands.colours)
    pixel = 2 * 9.0 * np.tan(np.radians(20)) / 200  # a pixel's size at the torus, roughly
    # away from where the torus hides itself (a pixel there sees two places)
    inner = ndimage.binary_erosion(on & (rho < R - 3 * pixel) & (image["A"] == 1), iterations=2)
    outer = ndimage.binary_erosion(on & (rho > R + 3 * pixel) & (image["A"] == 1), iterations=2)
    assert inner.sum() > 200 and outer.sum() > 200
    assert np.abs(rgb[inner] - hyperbolic).max() < 2e-3
    assert np.abs(rgb[outer] - elliptic).max() < 2e-3
    # the parabolic circle on top (z = r, rho = R): the line is darker than either band
    top = on & (np.abs(rho - R) < 0.2 * pixel) & (z > 0)
    assert top.sum() > 10
    assert (rgb[top].sum(-1) < 0.8 * min(hyperbolic.sum(), elliptic.sum())).all()
