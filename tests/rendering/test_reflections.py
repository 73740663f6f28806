"""Studio reflections (issue 32): the ``environment`` shape function rendered as a mirror or a
glossy conductor reflecting a lat-long map.

Oracles: the reflection direction against ``reflection_lines`` (its own jets: form
``infinity`` is the azimuth of the same r), maps whose bilinear reconstruction is exact (a
ramp in azimuth, one in the polar angle) for the convention and the rotation, the stripe
edges of a stripe map against the zebra's stripes, the geometry of a torus for occlusion,
and a picture's independence of ``spp``.
"""

from __future__ import annotations

import json
import math
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

import gshade
from gshade import GshadeError
from gshade.display.colour import DARK, LIGHT
from gshade.io.image import linear_to_srgb, write_exr
from gshade.rendering.environment_maps import stripe_map
from gshade.rendering.reflections import OCCLUDED, reflection_directions

EYE = (3.0, -4.0, 2.5)
STRIPES = 24  # a stripe every 15 degrees of azimuth; W = 1536: 64 texels a stripe


def _scene(
    folder: Path, shape: str, surface: str = 'type = "sphere"\nradius = 1.0', size=(240, 180), spp=1
) -> Path:
    text = f"""
[[surface]]
{surface}

[shape]
{shape}

[camera]
type = "perspective"
origin = {list(EYE)}
target = [0, 0, 0]
fov = 30

[render]
width = {size[0]}
height = {size[1]}
spp = {spp}
lighting = "flat"
"""
    path = folder / f"scene{abs(hash(shape + surface + str(size) + str(spp)))}.toml"
    path.write_text(text)
    return path


def _write_map(path: Path, rgb: np.ndarray) -> Path:
    write_exr(path, {c: rgb[..., k] for k, c in enumerate("RGB")})
    return path


@pytest.fixture(scope="module")
def stripes(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("stripes")
    _write_map(folder / "stripes.exr", stripe_map(STRIPES, 1536))
    return folder


def _vectors(image, name: str) -> np.ndarray:
    return np.stack([image[f"{name}.{a}"] for a in "XYZ"], -1).astype(np.float64)


# ------------------------------------------------------------------ the exact channels


def test_reflection_direction_is_the_zebras_r(stripes: Path) -> None:
    """refl.X/Y/Z: the unit r = v - 2 <v, N> N at P seen from the eye; its azimuth is
    reflection_lines' f (form infinity about +z from +x), computed from that function's own
    jets at the same points."""
    env = gshade.render(_scene(stripes, 'function = "environment"\nmap = "stripes.exr"'))
    zebra = gshade.render(
        _scene(
            stripes,
            'function = "reflection_lines"\nform = "infinity"\naxis = [0, 0, 1]\n'
            f"reference = [1, 0, 0]\neye_point = {list(EYE)}",
        )
    )
    hit = env["patch"] >= 0
    assert hit.sum() > 10000 and np.array_equal(hit, zebra["patch"] >= 0)
    r, P, N = _vectors(env, "refl")[hit], _vectors(env, "P")[hit], _vectors(env, "N")[hit]
    v = (P - EYE) / np.linalg.norm(P - EYE, axis=1, keepdims=True)
    np.testing.assert_allclose(np.linalg.norm(r, axis=1), 1.0, atol=1e-6)
    np.testing.assert_allclose(r, reflection_directions(v, N), atol=2e-6)
    off_pole = np.hypot(r[:, 0], r[:, 1]) > 0.1
    phi = np.arctan2(r[:, 1], r[:, 0])
    gap = np.angle(np.exp(1j * (phi - zebra["f"][hit])))
    assert np.abs(gap[off_pole]).max() < 1e-5


@pytest.mark.parametrize("rotation", [0.0, 90.0, -37.5])
def test_the_maps_columns_are_the_azimuth_turned_by_rotation(tmp_path: Path, rotation) -> None:
    """A map whose value is its column's centre / W (bilinear reconstruction reproduces the
    ramp exactly): f = ((atan2(r_y, r_x) - rotation) mod 2 pi) / 2 pi away from the seam."""
    W = 256
    ramp = np.broadcast_to(((np.arange(W) + 0.5) / W)[None, :, None], (W // 2, W, 3))
    _write_map(tmp_path / "ramp.exr", np.ascontiguousarray(ramp, dtype=np.float32))
    image = gshade.render(
        _scene(tmp_path, f'function = "environment"\nmap = "ramp.exr"\nrotation = {rotation}')
    )
    hit = image["patch"] >= 0
    r = _vectors(image, "refl")[hit]
    expected = np.mod(np.arctan2(r[:, 1], r[:, 0]) - math.radians(rotation), 2 * np.pi) / (
        2 * np.pi
    )
    inside = (expected > 1.0 / W) & (expected < 1 - 1.0 / W)  # the seam's texel blends 0 and 1
    assert inside.sum() > 5000
    np.testing.assert_allclose(image["f"][hit][inside], expected[inside], atol=2e-5)


def test_the_maps_rows_are_the_polar_angle_from_plus_z(tmp_path: Path) -> None:
    W = 256
    ramp = np.broadcast_to(((np.arange(W // 2) + 0.5) / (W // 2))[:, None, None], (W // 2, W, 3))
    _write_map(tmp_path / "rows.exr", np.ascontiguousarray(ramp, dtype=np.float32))
    image = gshade.render(_scene(tmp_path, 'function = "environment"\nmap = "rows.exr"'))
    hit = image["patch"] >= 0
    r = _vectors(image, "refl")[hit]
    expected = np.arccos(np.clip(r[:, 2], -1, 1)) / np.pi
    inside = (expected > 1.0 / W) & (expected < 1 - 1.0 / W)  # rows clamp at the poles
    np.testing.assert_allclose(image["f"][hit][inside], expected[inside], atol=2e-5)


# ------------------------------------------------------------------ the picture


def _dark_share(image) -> np.ndarray:
    """Each pixel's share of the dark stripe colour (flat light: the picture is the map's)."""
    return (image.rgb[..., 0] - LIGHT[0]) / (DARK[0] - LIGHT[0])


def _row_edges(share: np.ndarray, where: np.ndarray) -> dict[int, list[float]]:
    """Where the dark share crosses 1/2 between two pixels of a row, to a fraction of a pixel."""
    edges = defaultdict(list)
    a, b = share[:, :-1], share[:, 1:]
    rows, cols = np.nonzero(where[:, :-1] & where[:, 1:] & ((a - 0.5) * (b - 0.5) < 0))
    for y, x in zip(rows, cols, strict=True):
        edges[int(y)].append(x + 0.5 + (0.5 - a[y, x]) / (b[y, x] - a[y, x]))
    return edges


def test_stripe_edges_lie_where_reflection_lines_puts_them(stripes: Path) -> None:
    """A map of 24 stripes at infinity against reflection_lines (form infinity, the same
    stripes: period 2 pi / 12, the camera at its eye point): every stripe edge of the
    mirror within half a pixel of the zebra's, where the stripes are over two footprints wide
    and away from the outline; across the zebra's wrap too (its f is an atan2 in (-pi, pi]:
    the renderer interpolates it unwrapped)."""
    from scipy.ndimage import binary_erosion

    size = (320, 240)
    env = gshade.render(_scene(stripes, 'function = "environment"\nmap = "stripes.exr"', size=size))
    zebra = gshade.render(
        _scene(
            stripes,
            'function = "reflection_lines"\nform = "infinity"\naxis = [0, 0, 1]\n'
            f"reference = [1, 0, 0]\neye_point = {list(EYE)}\nperiod = {2 * np.pi / 12}",
            size=size,
        )
    )
    f = zebra["f"].astype(np.float64)
    step = lambda axis: np.abs(np.angle(np.exp(1j * (np.roll(f, -1, axis) - f))))  # noqa: E731
    footprint = step(0) + step(1)
    covered = (env["A"] >= 1) & (zebra["A"] >= 1)
    where = binary_erosion(covered, iterations=4) & (footprint < np.pi / STRIPES)
    mirror, lines = _row_edges(_dark_share(env), where), _row_edges(_dark_share(zebra), where)
    count = sum(len(xs) for xs in mirror.values())
    assert count > 1000 and abs(count - sum(len(xs) for xs in lines.values())) < count / 50
    worst = max(min(abs(x - other) for other in lines[y]) for y in mirror for x in mirror[y])
    assert worst < 0.5


def test_a_mirror_has_no_speckle_at_any_spp(stripes: Path) -> None:
    """The map is box-filtered over each sample's footprint: one sample per pixel and 16
    give the same picture inside the outline where the stripes are over four pixels wide
    (no noise to average; where they are narrower, one footprint's box is not the pixel's
    exact mean), and two seeds the same picture."""
    shape = 'function = "environment"\nmap = "stripes.exr"'
    one = gshade.render(_scene(stripes, shape, size=(160, 120), spp=1), sampling="uniform")
    many = gshade.render(_scene(stripes, shape, size=(160, 120), spp=16), sampling="uniform")
    again = gshade.render(
        _scene(stripes, shape, size=(160, 120), spp=16), sampling="uniform", seed=7
    )
    from scipy.ndimage import binary_erosion

    phi = np.arctan2(one["refl.Y"], one["refl.X"]).astype(np.float64)
    step = lambda axis: np.abs(np.angle(np.exp(1j * (np.roll(phi, -1, axis) - phi))))  # noqa: E731
    wide = step(0) + step(1) < np.pi / STRIPES / 2
    inside = binary_erosion(one["A"] >= 1, iterations=2) & wide
    assert inside.sum() > 3000
    gap = np.abs(one.rgb - many.rgb)[inside]
    assert gap.mean() < 0.005 and np.percentile(gap, 99) < 0.04 and gap.max() < 0.1
    assert np.abs(many.rgb - again.rgb).max() < 1e-6  # the strata summed in another order


def test_self_reflection_shows_the_occluded_tone_inside_a_torus(tmp_path: Path) -> None:
    """A sphere (convex) reflects nothing of itself; a torus shows itself in its inner
    ring: the occluded tone only where the surface faces the hole (|P_xy| < the major
    radius)."""
    sphere = gshade.render(_scene(tmp_path, 'function = "environment"'), lighting="flat")
    occluded = np.all(np.isclose(sphere.rgb, OCCLUDED, atol=1e-6), axis=-1) & (sphere["A"] >= 1)
    assert not occluded.any()
    torus = gshade.render(
        _scene(tmp_path, 'function = "environment"', 'type = "torus"\nmajor = 1.0\nminor = 0.4')
    )
    occluded = np.all(np.isclose(torus.rgb, OCCLUDED, atol=1e-6), axis=-1) & (torus["A"] >= 1)
    assert occluded.sum() > 100
    radial = np.hypot(torus["P.X"], torus["P.Y"])[occluded]
    assert radial.max() < 1.0


def test_glossy_two_seeds_agree_within_one_percent(stripes: Path) -> None:
    """roughness > 0: Mitsuba's roughconductor samples the lobe; pixels are sampled until the
    seeds s and s + 1 differ by < 1 % (in sRGB) at every pixel, as the legend states; two
    such pictures from other seeds (2 and 3) agree as closely inside the outline (each is
    the mean of two seeds; without the spread rule, :func:`gshade.rendering.glossy.spread`,
    they differed by 3.3 %); the glossy picture blurs the stripes (less contrast than the
    mirror's)."""
    shape = 'function = "environment"\nmap = "stripes.exr"'
    glossy = gshade.render(_scene(stripes, shape + "\nroughness = 0.3", size=(64, 48), spp=16))
    legend = glossy.metadata["legend"]
    assert "glossy conductor (GGX alpha 0.3)" in legend
    assert "2 seeds x 256-" in legend and "differ by < 1% (sRGB) at every pixel" in legend, legend
    again = gshade.render(
        _scene(stripes, shape + "\nroughness = 0.3", size=(64, 48), spp=16), seed=2
    )
    full = (glossy["A"] >= 1) & (again["A"] >= 1)
    gap = np.abs(linear_to_srgb(glossy.rgb) - linear_to_srgb(again.rgb)).max(-1)[full]
    assert full.sum() > 1000 and np.percentile(gap, 99) < 0.01 and gap.max() < 0.015
    mirror = gshade.render(_scene(stripes, shape, size=(64, 48), spp=16))
    inside = (glossy["A"] >= 1) & (mirror["A"] >= 1)
    assert glossy.rgb[..., 0][inside].std() < 0.6 * mirror.rgb[..., 0][inside].std()


# ------------------------------------------------------------------ the scene's keys


def test_the_environment_has_no_value_without_a_view() -> None:
    with pytest.raises(GshadeError, match="environment: has no value at a point without a view"):
        gshade.shape.evaluate("environment", np.zeros((3, 3, 1, 3)))


@pytest.mark.parametrize(
    ("shape", "words"),
    [
        ('map = "missing.exr"', ["[shape] map", "no such file"]),
        ('map = "../outside.exr"', ["[shape] map", "within the scene's folder"]),
        ('map = ""', ["map", "a file's path"]),
        ("strips = 0", ["strips", "an integer in [1, 64]"]),
        ("strips = 2.5", ["strips", "an integer"]),
        ("strip_width = 90", ["strip_width", "degrees in (0, 90)"]),
        ("roughness = 2", ["roughness", "[0, 1]"]),
        ("rotation = nan", ["rotation", "finite"]),
        ('display = "colormap"', ["display", "expected no display with environment"]),
    ],
)
def test_bad_environment_keys_get_one_line(tmp_path: Path, shape: str, words) -> None:
    (tmp_path / "s").mkdir()
    (tmp_path / "outside.exr").write_bytes(b"")
    path = _scene(tmp_path / "s", f'function = "environment"\n{shape}')
    with pytest.raises(GshadeError) as exc:
        gshade.load_scene(path)
    text = str(exc.value)
    assert "\n" not in text and str(path) in text
    for word in words:
        assert word in text, text


def test_a_map_that_is_not_a_map_is_one_line_at_render(tmp_path: Path) -> None:
    (tmp_path / "fake.hdr").write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 9\n")
    path = _scene(tmp_path, 'function = "environment"\nmap = "fake.hdr"', size=(16, 12))
    with pytest.raises(GshadeError) as exc:
        gshade.render(path)
    assert "\n" not in str(exc.value) and "fake.hdr" in str(exc.value)


@pytest.mark.parametrize(
    "table",
    [
        '[shape]\nfunction = "isophotes"\ndisplay = "both"\ncolour_function = "environment"',
        '[shape]\nfunction = "mean"\n[render]\naovs = ["environment"]',
    ],
)
def test_the_environment_is_no_colour_function_and_no_aov(table: str) -> None:
    with pytest.raises(GshadeError, match="environment"):
        gshade.scene.parse_scene('[[surface]]\ntype = "sphere"\nradius = 1\n' + table)


def test_a_map_path_is_relative_to_the_scene_file(tmp_path: Path) -> None:
    (tmp_path / "maps").mkdir()
    _write_map(tmp_path / "maps" / "grey.exr", np.full((8, 16, 3), 0.5, np.float32))
    path = _scene(tmp_path, 'function = "environment"\nmap = "maps/grey.exr"', size=(32, 24))
    scene = gshade.load_scene(path)
    assert scene.shape.params["map"] == str(tmp_path / "maps" / "grey.exr")
    image = gshade.render(scene, width=40)  # the loaded scene's map is found again
    hit = image["patch"] >= 0
    np.testing.assert_allclose(image["f"][hit], 0.5, atol=1e-6)
    assert "mirror reflecting grey.exr" in image.metadata["legend"]


# ------------------------------------------------------------------ gshade lightbox


def test_gshade_lightbox_writes_the_map_the_scenes_reflect(tmp_path: Path, capsys) -> None:
    """``gshade lightbox -o`` writes the studio as an EXR; a render reflecting that file is
    the render reflecting ``map = "lightbox"``, pixel for pixel."""
    from gshade.app.cli import main

    assert main(["lightbox", "-o", str(tmp_path / "box.exr"), "--strips", "3"]) == 0
    assert "1024x512 lat-long map, lightbox: 3 strips" in capsys.readouterr().out
    built_in = gshade.render(
        _scene(tmp_path, 'function = "environment"\nstrips = 3', size=(80, 60))
    )
    from_file = gshade.render(
        _scene(tmp_path, 'function = "environment"\nmap = "box.exr"', size=(80, 60))
    )
    assert (built_in["A"] > 0).sum() > 1000
    np.testing.assert_array_equal(built_in.rgb, from_file.rgb)
    np.testing.assert_array_equal(built_in["f"], from_file["f"])


@pytest.mark.parametrize(
    ("flags", "words"),
    [
        (["-o", "box.png"], "-o: expected a file name ending in .exr"),
        (["-o", "box.exr", "--strips", "0"], "--strips: expected an integer in [1, 64]"),
        (["-o", "box.exr", "--strip-width", "95"], "--strip-width: expected degrees"),
        (["-o", "box.exr", "--width", "63"], "--width: expected an even integer"),
        (["-o", "."], "cannot write the file: it is a directory"),
    ],
)
def test_gshade_lightbox_refuses_in_one_line(tmp_path: Path, capsys, monkeypatch, flags, words):
    from gshade.app.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["lightbox", *flags]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and words in err, err
    assert not list(tmp_path.iterdir())


def test_the_environment_has_no_numbers_over_the_surface(tmp_path: Path) -> None:
    """``gshade info --stats`` of an environment scene: no value over the whole surface (not
    the numbers of the normal's textures it is drawn from); a render's numbers are those of
    its visible f, the luminance reflected."""
    from gshade.rendering.pipeline import shape_statistics

    path = _scene(tmp_path, 'function = "environment"', size=(40, 30))
    numbers = shape_statistics(path)
    assert numbers["function"] == "environment" and numbers["surface"] is None
    image = gshade.render(path)
    visible = json.loads(image.metadata["statistics"])["visible"]
    hit = image["patch"] >= 0
    assert visible["max"]["value"] == pytest.approx(float(image["f"][hit].max()), rel=1e-6)


def test_no_output_replaces_the_map(tmp_path: Path, capsys) -> None:
    """The map is one of the scene's data files: ``-o`` naming it is refused before anything
    is written, and the scene's hash follows the map's bytes."""
    from gshade.app.cli import main
    from gshade.scene.changes import scene_with_settings

    _write_map(tmp_path / "grey.exr", np.full((8, 16, 3), 0.5, np.float32))
    path = _scene(tmp_path, 'function = "environment"\nmap = "grey.exr"', size=(16, 12))
    before = (tmp_path / "grey.exr").read_bytes()
    assert main(["render", str(path), "-o", str(tmp_path / "grey.exr")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "would be replaced" in err, err
    assert (tmp_path / "grey.exr").read_bytes() == before
    scene = gshade.load_scene(path)
    assert scene.data_files == ((tmp_path / "grey.exr").resolve(),)
    _write_map(tmp_path / "grey.exr", np.full((8, 16, 3), 0.25, np.float32))
    assert gshade.load_scene(path).text_hash != scene.text_hash
    lit = scene_with_settings(scene, {"set": {"shape.map": "lightbox"}})
    assert lit.data_files == ()
