"""The Python API people find: ``dir(gshade)``, ``gshade.render``'s keywords and their
errors, and a RenderedImage's arrays and its pictures for Jupyter (PNG, the HTML page)."""

from __future__ import annotations

import html.parser
import io
import json
import subprocess
import sys

import numpy as np
import PIL.Image
import pytest

import gshade
from gshade import GshadeError

SPHERE = 'name = "s"\n[[surface]]\ntype = "sphere"\nradius = 1\n'
SMALL = {"width": 48, "height": 36, "spp": 4}  # 4: the silhouette partly covers pixels
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def sphere_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("api") / "s.toml"
    path.write_text(SPHERE)
    return path


@pytest.fixture(scope="module")
def image(sphere_file):
    return gshade.render(sphere_file, **SMALL)


def _settings(image):
    return json.loads(image.metadata["settings"])


def _raised(*args, **kwargs) -> str:
    with pytest.raises(GshadeError) as caught:
        gshade.render(*args, **kwargs)
    return str(caught.value)


# --------------------------------------------------------------------------- the package


def test_dir_lists_every_public_name_and_each_resolves():
    names = dir(gshade)
    assert "render" in names
    for name in gshade.__all__:
        assert name in names
        assert getattr(gshade, name) is not None
    assert {"render", "load_scene", "compare", "RenderedImage"} <= set(gshade.__all__)
    assert callable(gshade.render) and isinstance(gshade.RenderedImage, type)
    with pytest.raises(AttributeError, match="no attribute 'rendr'"):
        _ = gshade.rendr


def test_importing_gshade_loads_no_renderer():
    code = "import gshade, sys; print('mitsuba' in sys.modules, 'drjit' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["False", "False"]


# --------------------------------------------------------------------------- render's keywords


def test_width_height_and_spp_set_the_image(sphere_file):
    image = gshade.render(sphere_file, width=40, height=24, spp=4)
    assert image.shape == (24, 40)
    render = _settings(image)["render"]
    assert (render["width"], render["height"], render["spp"]) == (40, 24, 4)


def test_function_and_display_set_the_shape(sphere_file, image):
    assert image.metadata["legend"].startswith("isophotes")  # the scene's default
    mean = gshade.render(sphere_file, function="mean", display="colormap", **SMALL)
    assert mean.metadata["legend"].startswith("mean")
    shape = _settings(mean)["shape"]
    assert (shape["function"], shape["display"]) == ("mean", "colormap")
    assert np.allclose(mean.f[mean["patch"] >= 0], 1.0, atol=1e-5)  # a unit sphere's H


def test_camera_sets_the_view_and_changes_the_picture(sphere_file, image):
    eye = gshade.render(
        gshade.load_scene(sphere_file),
        camera={"origin": np.array([0.0, -6.0, 0.0]), "target": (0, 0, 0), "fov": 40},
        **SMALL,
    )
    camera = _settings(eye)["camera"]
    assert camera["origin"] == [0.0, -6.0, 0.0] and camera["fov"] == 40.0
    assert not np.allclose(eye.rgb, image.rgb)
    # the sphere's points seen from -y: its y < 0 half
    on = eye["patch"] >= 0
    assert on.any() and (eye.P[on][:, 1] < 0.05).all()
    flat = gshade.render(sphere_file, camera={"type": "orthographic", "width": 3.0}, **SMALL)
    assert _settings(flat)["camera"]["type"] == "orthographic"


def test_set_still_sets_dotted_keys_from_a_path_and_a_scene(sphere_file):
    by_path = gshade.render(sphere_file, set={"shape.period": 0.05, "surface.1.radius": 2}, **SMALL)
    assert _settings(by_path)["shape"]["period"] == 0.05
    on = by_path["patch"] >= 0
    assert np.allclose(np.linalg.norm(by_path.P[on], axis=-1), 2.0, atol=1e-4)
    scene = gshade.load_scene(sphere_file)
    by_scene = gshade.render(scene, set={"shape.period": 0.05, "render.width": 20}, width=30)
    assert _settings(by_scene)["shape"]["period"] == 0.05
    assert by_scene.shape[1] == 30  # the keyword wins over set
    message = _raised(scene, set={"surface.1.radius": 2})
    assert message.startswith("render(): set: surface.1.radius: expected a key of [shape]")


def test_the_other_render_settings_still_apply(sphere_file):
    image = gshade.render(sphere_file, lighting="flat", seed=3, aovs=["gaussian"], **SMALL)
    render = _settings(image)["render"]
    assert (render["lighting"], render["seed"]) == ("flat", 3)
    assert "gaussian" in image.channels


@pytest.mark.parametrize("loaded", [False, True], ids=["path", "scene"])
def test_a_misspelt_keyword_is_one_line_with_did_you_mean(sphere_file, loaded):
    scene = gshade.load_scene(sphere_file) if loaded else sphere_file
    assert _raised(scene, widht=48) == "render: unknown setting 'widht'; did you mean \"width\"?"
    assert _raised(scene, fucntion="mean").endswith('did you mean "function"?')
    assert _raised(scene, period=0.1).endswith('did you mean set={"shape.period": ...}?')
    message = _raised(scene, zzz=1)
    assert "\n" not in message and "(expected one of: function, display, camera" in message


@pytest.mark.parametrize("loaded", [False, True], ids=["path", "scene"])
def test_a_wrong_value_names_its_key_expected_and_found(sphere_file, loaded):
    scene = gshade.load_scene(sphere_file) if loaded else sphere_file
    where = "render()" if loaded else str(sphere_file)
    assert _raised(scene, width="wide") == (
        f'{where}: [render] width: expected an integer from 1 to 16384, got "wide"'
    )
    assert _raised(scene, camera={"origin": "here"}).startswith(
        f'{where}: [camera] origin: expected 3 numbers [x, y, z], got "here"'
    )
    assert _raised(scene, function="mena").endswith('got "mena"; did you mean "mean"?')
    assert _raised(scene, junctions=1) == (
        f"{where}: [render] junctions: expected true or false, got 1"
    )
    assert "orgin" in _raised(scene, camera={"orgin": [1, 2, 3]})
    assert _raised(scene, camera=[1, 2]).startswith("render: camera: expected a mapping")
    assert _raised(scene, set=["shape.period=1"]).startswith("render: set: expected a mapping")


# --------------------------------------------------------------------------- RenderedImage


def test_the_arrays_have_the_image_shape(image):
    H, W = image.shape
    on = image["patch"] >= 0
    assert image.f.shape == (H, W) and image.f.dtype == np.float32
    for array in (image.P, image.N, image.rgb, image.srgb):
        assert array.shape == (H, W, 3) and array.dtype == np.float32
    np.testing.assert_array_equal(image.P[..., 2], image["P.Z"])
    np.testing.assert_array_equal(image.N[..., 0], image["N.X"])
    assert 0 < on.sum() < H * W
    assert np.allclose(np.linalg.norm(image.P[on], axis=-1), 1.0, atol=1e-5)
    # a unit sphere's normal is ±P (the sign: the parametrisation's p_u x p_v)
    assert np.allclose(np.abs((image.N[on] * image.P[on]).sum(-1)), 1.0, atol=1e-5)
    assert not image.P[~on].any() and not image.N[~on].any() and not image.f[~on].any()
    assert 0 <= image.srgb.min() and image.srgb.max() <= 1
    assert not image.srgb[image.alpha == 0].any()
    np.testing.assert_array_equal(image.rgb[..., 1], image["G"])  # linear, as the EXR


def test_srgb_is_what_the_png_shows(image, tmp_path):
    image.write_png(tmp_path / "s.png")
    with PIL.Image.open(tmp_path / "s.png") as png:
        written = np.asarray(png.convert("RGBA"), dtype=np.float64) / 255
    assert ((image.alpha > 0) & (image.alpha < 1)).any()  # straight colour there, as the PNG's
    np.testing.assert_allclose(image.srgb, written[..., :3], atol=1 / 255 + 1e-7)
    np.testing.assert_array_equal(image.srgba, np.round(written * 255).astype(np.uint8))
    on = image.alpha > 0.5  # sRGB-encoded, not linear: mid-greys are brighter
    assert (image.srgb[on] >= image.rgb[on] - 1e-6).all()
    assert (image.srgb[on] > image.rgb[on] + 0.05).any()


def test_repr_png_is_the_png(image, tmp_path):
    data = image._repr_png_()
    assert data.startswith(PNG_SIGNATURE)
    with PIL.Image.open(io.BytesIO(data)) as png:
        assert png.size == (48, 36)
        decoded = np.asarray(png.convert("RGBA"))
    image.write_png(tmp_path / "s.png")
    with PIL.Image.open(tmp_path / "s.png") as png:
        np.testing.assert_array_equal(decoded, np.asarray(png.convert("RGBA")))


class _Frames(html.parser.HTMLParser):
    """The iframes' attributes (their values unescaped)."""

    def __init__(self) -> None:
        super().__init__()
        self.frames: list[dict[str, str | None]] = []

    def handle_starttag(self, tag, attrs):
        if tag == "iframe":
            self.frames.append(dict(attrs))


def test_repr_html_is_the_page_render_html_writes(sphere_file, image, tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "gshade", "render", sphere_file, "--html", "s.html"]
        + [f"--{key}={value}" for key, value in SMALL.items()],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stderr
    markup = image._repr_html_()
    frames = _Frames()
    frames.feed(markup)
    assert len(frames.frames) == 1 and markup.startswith("<iframe srcdoc=")
    assert frames.frames[0]["srcdoc"] == (tmp_path / "s.html").read_text(encoding="utf-8")
    assert '<script type="application/json"' not in markup  # escaped: inert outside the frame
