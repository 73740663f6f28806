"""Rendering: exactness of the shape-function channel, stripe parity, channels, determinism."""

import numpy as np
import pytest

import gshade
from gshade.io import read_exr
from gshade.scene import parse_scene

from ..support.scenes_text import SPHERE

TORUS = """
[[surface]]
type = "torus"
major = 2.0
minor = 0.7
[shape]
function = "gaussian"
display = "colormap"
[camera]
type = "orthographic"
origin = [0, -6, 5]
target = [0, 0, 0]
up = [0, 0, 1]
width = 6.5
[render]
width = 320
height = 240
spp = 4
lighting = "flat"
"""


def interior(A, margin=2):
    """Pixels fully covered, with their neighbours (away from the silhouette)."""
    ok = A == 1.0
    for axis in (0, 1):
        for shift in range(1, margin + 1):
            ok &= np.roll(A, shift, axis) == 1.0
            ok &= np.roll(A, -shift, axis) == 1.0
    return ok


@pytest.fixture(scope="module")
def sphere_image():
    return gshade.render(parse_scene(SPHERE))


def sphere_isophote_at(x, z):
    """<n, l> for the unit sphere seen along +y at image-plane point (x, z), n = p_u x p_v
    (inward), l = (0, -1, 0): the visible point is (x, -sqrt(1 - x^2 - z^2), z)."""
    return -np.sqrt(np.maximum(1 - x**2 - z**2, 0))


def test_sphere_isophotes_equal_the_exact_values(sphere_image):
    img = sphere_image
    ok = interior(img["A"])
    assert ok.sum() > 150_000
    P = np.stack([img[f"P.{c}"] for c in "XYZ"], -1)
    N = np.stack([img[f"N.{c}"] for c in "XYZ"], -1)
    # P lies on the sphere and N is its (inward, p_u x p_v) unit normal
    np.testing.assert_allclose(np.linalg.norm(P[ok], axis=-1), 1.0, atol=1e-5)
    np.testing.assert_allclose(N[ok], -P[ok], atol=1e-5)
    # f is <n, l> exact where the ray through the pixel centre meets the sphere (the
    # analytic sphere gives the oracle), and at P's own normal N
    step = 2.2 / 512
    cols, rows = np.meshgrid(np.arange(512), np.arange(512))
    x0, z0 = -1.1 + (cols + 0.5) * step, 1.1 - (rows + 0.5) * step
    np.testing.assert_allclose(img["f"][ok], sphere_isophote_at(x0, z0)[ok], atol=2e-6)
    np.testing.assert_allclose(img["f"][ok], (N @ np.array([0, -1, 0]))[ok], atol=2e-6)
    # f.mean is the mean over the pixel's samples: flat renders sample the centres of 2 x 2
    # strata where the picture needs more than the centre sample (within the pixel f is
    # nearly linear, so the centre sample's value is that mean up to the curvature term)
    mean = (
        sum(
            sphere_isophote_at(x0 + dx * step, z0 + dz * step)
            for dx in (-0.25, 0.25)
            for dz in (-0.25, 0.25)
        )
        / 4
    )
    assert np.abs(img["f.mean"][ok] - mean[ok]).max() < 1e-3
    assert np.abs(img["f.mean"][ok] - img["f"][ok]).max() > 1e-6  # not the centre value


def test_sphere_stripes_follow_the_parity_of_f_without_facets(sphere_image):
    img = sphere_image
    ok = interior(img["A"])
    # period 0.125 in f: dark for the first half of each period (duty 0.5)
    s = img["f"] / 0.125
    frac = s - np.floor(s)
    away = ok & (np.minimum(np.abs(frac - 0.5), np.minimum(frac, 1 - frac)) > 0.1)
    dark = frac < 0.5
    grey = img["R"]
    assert np.all(grey[away & dark] < 0.1)
    assert np.all(grey[away & ~dark] > 0.8)


def test_torus_gaussian_curvature_channel():
    img = gshade.render(parse_scene(TORUS), spp=1)  # one sample, at the pixel centre
    ok = interior(img["A"])
    assert ok.sum() > 10_000
    x, y = img["P.X"][ok], img["P.Y"][ok]
    rho = np.hypot(x, y)
    cos_v = (rho - 2.0) / 0.7
    K = cos_v / (0.7 * (2.0 + 0.7 * cos_v))
    err = np.abs(img["f"][ok] - K)
    # f is exact at P (the pixel centre's hit): only float32 storage and K from float32 P
    assert np.all(err <= 1e-5 * np.maximum(np.abs(K), 0.05 * np.abs(K).max()))


def test_channels_header_and_files(tmp_path):
    scene = parse_scene(SPHERE.replace("512", "64"))
    img = gshade.render(scene, spp=2)
    assert img.shape == (64, 64)
    exr, png = tmp_path / "s.exr", tmp_path / "s.png"
    img.write_exr(exr)
    img.write_png(png)
    channels, header = read_exr(exr)
    assert set(channels) == set(gshade.rendering.rendered_image.CHANNELS)
    assert header["scene_hash"] == scene.text_hash
    assert header["variant"] in ("llvm_ad_rgb", "scalar_rgb")
    assert png.stat().st_size > 500
    patch = channels["patch"]
    assert set(np.unique(patch)) <= {-1.0, 0.0}
    assert np.all(channels["f"][channels["A"] == 0] == 0)


def test_renders_are_bit_identical():
    scene = parse_scene(SPHERE.replace("512", "48").replace('"flat"', '"lit"'))
    a, b = gshade.render(scene), gshade.render(scene)
    for name in a.channels:
        assert np.array_equal(a[name], b[name]), name


STAGES = [
    "setup",
    "tessellate",
    "textures",
    "statistics",
    "scene",
    "render",
    "supersample",
    "exact_channels",
]


def test_timings_name_the_stages():
    """benchmarks/bench_render.py reads these names."""
    scene = parse_scene(SPHERE.replace("512", "24"))
    assert list(gshade.render(scene, spp=1).timings) == STAGES
    with_junctions = gshade.render(scene, spp=1, junctions=True).timings
    assert list(with_junctions) == [STAGES[0], "junctions", *STAGES[1:]]


def test_the_integrator_and_the_pixel_sensor_are_mitsuba_plugins_by_name():
    import mitsuba as mi

    from gshade.rendering.integrator import SHAPE_FILM, SHAPE_PLUGIN
    from gshade.rendering.pixel_sensor import PIXELS_PLUGIN

    gshade.render(parse_scene(SPHERE.replace("512", "8")), spp=4)  # registers them
    shape = mi.load_dict({"type": SHAPE_PLUGIN})
    assert list(shape.aov_names()) == list(SHAPE_FILM[4:]) == ["f", "x", "y", "flags", "f_x", "f_y"]
    film = {"type": "hdrfilm", "width": 2, "height": 1}
    assert "PixelSensor" in str(mi.load_dict({"type": PIXELS_PLUGIN, "film": film}))


def test_the_plugins_are_their_methods_on_the_variants_base():
    """variant_class copies a plugin's methods onto the variant's Mitsuba class (nanobind
    takes one base): the class has them and the variant's parts, and no method calls a
    zero-argument super(), which would name the methods' class, not the variant's."""
    import inspect

    import mitsuba as mi

    from gshade.rendering.plugins import PLUGINS, use_variant, variant_class

    variant = use_variant("auto")
    for methods, base in ((m, b) for _, m, b in PLUGINS.values()):
        cls = variant_class(methods, base, mi)
        assert issubclass(cls, getattr(mi, base)) and cls.__name__ == methods.__name__
        assert cls.mi is mi and cls.scalar == variant.startswith("scalar")
        for name, member in inspect.getmembers(methods, inspect.isfunction):
            assert getattr(cls, name) is member
            assert "__class__" not in member.__code__.co_freevars, name
