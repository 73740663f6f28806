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


def test_the_parabolic_lines_are_drawn_over_any_display_and_nothing_else_changes():
    """render.parabolic over the mean curvature's colour map: the picture is the same but
    within a line's width of the torus's parabolic circles (rho = R, z = +-r), which are
    drawn in PARABOLIC_COLOUR; the exact channels do not change at all."""
    from gshade.display.bands import PARABOLIC_COLOUR

    text = TORUS.replace('"gaussian"', '"mean"').replace('"bands"', '"colormap"')
    plain = gshade.render(parse_scene(text))
    lined = gshade.render(
        parse_scene(text.replace('lighting = "flat"', 'lighting = "flat"\nparabolic = true'))
    )
    for name in ("f", "P.X", "patch", "A"):
        np.testing.assert_array_equal(plain[name], lined[name])
    rgb = [np.stack([im["R"], im["G"], im["B"]], -1) for im in (plain, lined)]
    changed = np.abs(rgb[0] - rgb[1]).max(-1) > 1e-6
    rho = np.hypot(lined["P.X"], lined["P.Y"])
    pixel = 2 * 9.0 * np.tan(np.radians(20)) / 200
    # where K's sign (rho - R's) changes from a pixel to the next, and a line's width around
    outside = np.where(lined["patch"] >= 0, rho > R, False)
    inside = (lined["patch"] >= 0) & ~outside
    crossing = (outside & ndimage.binary_dilation(inside)) | (
        inside & ndimage.binary_dilation(outside)
    )
    near = ndimage.binary_dilation(crossing, iterations=2)
    # (at the silhouettes a grazing sample's footprint spans much of the surface, and may
    # reach a parabolic line as it may a stripe's edge)
    P = np.stack([lined["P.X"], lined["P.Y"], lined["P.Z"]], -1)
    jump = np.zeros(changed.shape, bool)  # where the torus hides itself: P jumps
    jump[:, 1:] |= np.linalg.norm(P[:, 1:] - P[:, :-1], axis=-1) > 5 * pixel
    jump[1:, :] |= np.linalg.norm(P[1:, :] - P[:-1, :], axis=-1) > 5 * pixel
    interior = ndimage.binary_erosion(lined["A"] == 1, iterations=2)
    interior &= ~ndimage.binary_dilation(jump, iterations=3)
    assert changed.sum() > 20 and not (changed & ~near & interior).any()
    top = (lined["patch"] >= 0) & (np.abs(rho - R) < 0.2 * pixel) & (lined["P.Z"] > 0)
    magenta = srgb_to_linear(np.asarray(PARABOLIC_COLOUR, float))
    assert top.sum() > 10
    assert np.median(np.abs(rgb[1][top] - magenta).max(-1)) < 0.1
