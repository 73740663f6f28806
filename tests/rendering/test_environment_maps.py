"""Environment maps (issue 32): the lat-long convention, exact box filtering by a summed-area
table, the built-in lightbox and stripe maps, and reading user maps (EXR, Radiance HDR),
hostile files refused in one line."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import gshade.rendering.environment_files as em
from gshade import GshadeError
from gshade.io.image import write_exr
from gshade.rendering.environment_files import read_environment_map
from gshade.rendering.environment_maps import (
    SummedArea,
    direction_to_map,
    lightbox,
    map_to_direction,
    stripe_map,
)

W, H = 16, 8


def one_line(exc: pytest.ExceptionInfo, *words: str) -> None:
    text = str(exc.value)
    assert "\n" not in text and "Traceback" not in text
    for word in words:
        assert word in text, text


# ------------------------------------------------------------------ the convention


@pytest.mark.parametrize(
    ("d", "column", "row"),
    [
        ((1, 0, 0), 0.0, H / 2),
        ((0, 1, 0), W / 4, H / 2),
        ((-1, 0, 0), W / 2, H / 2),
        ((0, -1, 0), 3 * W / 4, H / 2),
        ((0, 0, 1), 0.0, 0.0),
        ((0, 0, -1), 0.0, H),
    ],
)
def test_axis_directions(d, column, row) -> None:
    c, r = direction_to_map(np.array([d], float), W, H)
    assert c[0] == pytest.approx(column, abs=1e-12) and r[0] == pytest.approx(row, abs=1e-12)


def test_columns_stay_below_the_width() -> None:
    c, _ = direction_to_map([[1.0, -1e-300, 0.0], [1.0, -1e-17, 0.0]], W, H)
    assert np.all((c >= 0) & (c < W))


unit = st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: 0.1 < np.linalg.norm(v))


@given(st.lists(unit, min_size=1, max_size=20), st.floats(-720, 720))
def test_map_to_direction_inverts_direction_to_map(vs, rotation) -> None:
    d = np.array(vs) / np.linalg.norm(vs, axis=1, keepdims=True)
    c, r = direction_to_map(d, W, H, rotation)
    assert np.all((c >= 0) & (c < W) & (r >= 0) & (r <= H))
    np.testing.assert_allclose(map_to_direction(c, r, W, H, rotation), d, atol=1e-9)


@given(st.lists(unit, min_size=1, max_size=20), st.integers(0, 2**32 - 1))
def test_rotation_by_90_degrees_is_a_roll_by_a_quarter(vs, seed) -> None:
    image = np.random.default_rng(seed).random((H, W, 3))
    d = np.array(vs, float)
    turned = SummedArea(image).point(*direction_to_map(d, W, H, rotation=90.0))
    rolled = SummedArea(np.roll(image, W // 4, axis=1)).point(*direction_to_map(d, W, H))
    np.testing.assert_allclose(turned, rolled, atol=1e-9)


def test_texel_centres_are_their_directions() -> None:
    j, i = np.mgrid[0:H, 0:W]
    c, r = direction_to_map(map_to_direction(i + 0.5, j + 0.5, W, H), W, H)
    np.testing.assert_allclose(c, i + 0.5, atol=1e-9)
    np.testing.assert_allclose(r, j + 0.5, atol=1e-9)


# ------------------------------------------------------------------ summed-area table


def brute_mean(image: np.ndarray, c0, c1, r0, r1) -> np.ndarray:
    """The mean over the rectangle of the piecewise-constant map, columns wrapping, rows
    clamped: texel overlaps computed one texel at a time."""
    h, w = image.shape[:2]
    c1 = min(c1, c0 + w)
    r0, r1 = min(max(r0, 0), h), min(max(r1, 0), h)
    cols = [
        (ii % w, min(c1, ii + 1) - max(c0, ii)) for ii in range(int(np.floor(c0)), int(np.ceil(c1)))
    ]
    rows = [(j, min(r1, j + 1) - max(r0, j)) for j in range(h)]
    cols = [(i, x) for i, x in cols if x > 0]
    rows = [(j, x) for j, x in rows if x > 0]
    wide, high = sum(x for _, x in cols), sum(x for _, x in rows)
    # weights as fractions of each side: no products of two tiny lengths
    return sum(
        (x / wide) * (y / high) * image[j, i].astype(float) for i, x in cols for j, y in rows
    )


coordinate = st.floats(-3 * W, 3 * W, allow_nan=False)
length = st.one_of(st.floats(0.0, 2.5), st.floats(0.0, 2.5 * W), st.just(float(W)))


@settings(max_examples=200)
@given(
    st.integers(0, 2**32 - 1),
    coordinate,
    length,
    st.floats(-2, H + 2),
    st.floats(1e-3, H + 4),
)
def test_box_mean_is_the_brute_force_mean(seed, c0, width, r0, height) -> None:
    rng = np.random.default_rng(seed)
    image = rng.random((H, W, 3)) * rng.choice([1.0, 1e3])
    c1, r1 = c0 + width, r0 + height
    if c1 <= c0 or min(r1, H) - max(r0, 0) <= 0:
        return  # zero area: test_degenerate_rectangles_read_points
    got = SummedArea(image).box_mean(c0, c1, r0, r1)
    np.testing.assert_allclose(got, brute_mean(image, c0, c1, r0, r1), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize(
    ("widths", "heights"),
    [((0, 1), (0, 1)), ((0, 1), (1, H)), ((1, 3 * W), (0, 1)), ((1, 3 * W), (1, H))],
    ids=["small", "thin-columns", "thin-rows", "wide"],
)
def test_box_mean_of_each_kind_of_rectangle(widths, heights) -> None:
    rng = np.random.default_rng(11)
    image = rng.random((H, W, 3))
    n = 300
    c0, r0 = rng.uniform(-2 * W, 2 * W, n), rng.uniform(0, H - 1, n)
    c1, r1 = c0 + rng.uniform(*widths, n), r0 + rng.uniform(*heights, n)
    got = SummedArea(image).box_mean(c0, c1, r0, r1)
    expected = [brute_mean(image, *rect) for rect in zip(c0, c1, r0, r1, strict=True)]
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-12)


def test_box_mean_is_vectorised_and_handles_wrapping_and_whole_rings() -> None:
    rng = np.random.default_rng(7)
    image = rng.random((H, W, 3)).astype(np.float32)
    sat = SummedArea(image)
    rects = np.array([[W - 1.5, W + 2.25, 1.0, 3.5], [-0.5, 0.5, 0, H], [3.0, 3.0 + W, 0, H]])
    got = sat.box_mean(*rects.T)
    assert got.shape == (3, 3)
    for k, rect in enumerate(rects):
        np.testing.assert_allclose(got[k], brute_mean(image, *rect), rtol=1e-9)
    np.testing.assert_allclose(got[2], image.reshape(-1, 3).mean(axis=0, dtype=float), rtol=1e-9)
    wider = sat.box_mean(3.0, 3.0 + 2.7 * W, 0, H)  # more than a ring: the ring
    np.testing.assert_allclose(wider, got[2], rtol=1e-9)


def test_box_mean_of_a_grey_map() -> None:
    sat = SummedArea(np.arange(H * W, dtype=float).reshape(H, W))
    assert sat.box_mean([0.0], [2.0], [0.0], [1.0]).shape == (1,)
    assert float(sat.box_mean(0.0, 2.0, 0.0, 1.0)) == 0.5


def test_degenerate_rectangles_read_points() -> None:
    image = np.random.default_rng(3).random((H, W, 3))
    sat = SummedArea(image)
    np.testing.assert_allclose(sat.box_mean(2.3, 2.3, 1.0, 4.0), sat.point(2.3, 2.5))
    np.testing.assert_allclose(sat.box_mean(2.0, 5.0, 6.5, 6.5), sat.point(3.5, 6.5))


def test_box_mean_refuses_reversed_corners() -> None:
    sat = SummedArea(np.ones((H, W)))
    with pytest.raises(GshadeError) as exc:
        sat.box_mean(2.0, 1.0, 0.0, 1.0)
    one_line(exc, "c0 <= c1")


def test_points_at_texel_centres_are_the_texels() -> None:
    image = np.random.default_rng(5).random((H, W, 3))
    j, i = np.mgrid[0:H, 0:W]
    np.testing.assert_allclose(SummedArea(image).point(i + 0.5, j + 0.5), image, atol=1e-12)
    np.testing.assert_allclose(SummedArea(image).point(i + 0.5 + W, j + 0.5), image, atol=1e-12)


def test_points_between_texels_interpolate_and_wrap() -> None:
    image = np.zeros((H, W))
    image[:, 0] = 1.0
    sat = SummedArea(image)
    assert sat.point(0.0, 3.5) == pytest.approx(0.5)  # halfway between columns W - 1 and 0
    assert sat.point(W + 1.0, 3.5) == pytest.approx(0.5)
    assert sat.point(0.5, -4.0) == pytest.approx(1.0)  # rows clamp


# ------------------------------------------------------------------ built-in maps


def test_lightbox_shape_and_range() -> None:
    m = lightbox(width=256)
    assert m.shape == (128, 256, 3) and m.dtype == np.float32
    assert m.min() == pytest.approx(0.02) and m.max() == pytest.approx(1.0)
    assert np.array_equal(m[..., 0], m[..., 2])


def test_lightbox_strips_where_they_should_be() -> None:
    w = 720  # texel centres at 0.25, 0.75, ... degrees of theta; 0.25 degrees in azimuth
    m = lightbox(strips=3, strip_width=8.0, width=w)[..., 0]
    theta = (np.arange(w // 2) + 0.5) * 0.5
    plus_y = m[:, w // 4]  # the arc from the zenith towards +y: the middle strip
    assert np.all(plus_y[theta < 59] == 1.0) and np.all(plus_y[(theta > 61) & (theta < 89)] == 0.02)
    plus_x = m[:, 0]  # in the x-z plane (phi = 0.25 degrees): strips at 0 and 60 degrees
    assert np.all(plus_x[(theta < 3.4) | ((theta > 56.6) & (theta < 63.4))] > 0.99)
    assert np.all(
        plus_x[((theta > 4.6) & (theta < 55.4)) | ((theta > 64.6) & (theta < 89))] == 0.02
    )
    floor = m[theta > 90.6, 100]
    assert np.all(np.diff(floor) < 0) and floor[0] == pytest.approx(0.25, abs=0.01)
    assert floor[-1] == pytest.approx(0.08, abs=0.01)


def test_lightbox_even_strip_count_leaves_the_zenith_dark() -> None:
    m = lightbox(strips=2, strip_width=8.0, width=360)[..., 0]
    assert np.all(m[0] == 0.02)


def test_lightbox_edges_are_soft() -> None:
    m = lightbox(strips=1, strip_width=8.0, width=4096)[..., 0]
    column = m[: 2048 // 4, 0]  # theta up to 45 degrees along +x: the strip's edge at 4 degrees
    values = np.unique(column.round(6))
    assert len(values) > 5  # intermediate values across the edge, not a step


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"strips": 0}, "strips"),
        ({"strips": 65}, "strips"),
        ({"strips": 2.0}, "strips"),
        ({"strips": True}, "strips"),
        ({"strip_width": 0.0}, "strip_width"),
        ({"strip_width": 90}, "strip_width"),
        ({"strip_width": float("nan")}, "strip_width"),
        ({"strip_width": "8"}, "strip_width"),
        ({"width": 62}, "width"),
        ({"width": 65}, "width"),
        ({"width": 8194}, "width"),
        ({"width": 256.0}, "width"),
    ],
)
def test_lightbox_argument_errors(kwargs, name) -> None:
    with pytest.raises(GshadeError) as exc:
        lightbox(**kwargs)
    one_line(exc, f"{name}: expected")


def test_stripe_map() -> None:
    from gshade.display.colour import DARK, LIGHT

    m = stripe_map(8, 64)
    assert m.shape == (32, 64, 3) and m.dtype == np.float32
    expected = np.where((np.arange(64) // 8 % 2 == 1)[:, None], LIGHT, DARK)
    np.testing.assert_allclose(m, np.broadcast_to(expected, m.shape), atol=1e-7)
    with pytest.raises(GshadeError) as exc:
        stripe_map(0, 64)
    one_line(exc, "count: expected")


# ------------------------------------------------------------------ map files


def rgb_map(h: int = 8, seed: int = 1) -> np.ndarray:
    return (np.random.default_rng(seed).random((h, 2 * h, 3)) * 4).astype(np.float32)


def test_exr_reads_back_equal(tmp_path) -> None:
    image = rgb_map()
    path = write_exr(tmp_path / "map.exr", {c: image[..., k] for k, c in enumerate("RGB")})
    got = read_environment_map(path)
    assert got.dtype == np.float32 and np.array_equal(got, image)


def test_hdr_reads_back_within_rgbe_precision(tmp_path) -> None:
    import mitsuba as mi

    image = rgb_map()
    mi.Bitmap(image).write(str(tmp_path / "map.hdr"))
    got = read_environment_map(tmp_path / "map.hdr")
    assert got.shape == image.shape and got.dtype == np.float32
    # RGBE: 8-bit mantissas sharing the largest channel's exponent
    assert np.all(np.abs(got - image) <= image.max(axis=-1, keepdims=True) / 128)


def test_wide_maps_are_box_filtered_down(tmp_path, monkeypatch) -> None:
    monkeypatch.setattr(em, "MAX_MAP_WIDTH", 8)
    image = rgb_map(8)  # 16 wide: 2 x 2 blocks
    path = write_exr(tmp_path / "map.exr", {c: image[..., k] for k, c in enumerate("RGB")})
    got = read_environment_map(path)
    expected = image.reshape(4, 2, 8, 2, 3).mean(axis=(1, 3))
    np.testing.assert_allclose(got, expected, rtol=1e-6)


def test_box_filtering_down_by_a_fraction_keeps_the_mean() -> None:
    image = rgb_map(12).astype(np.float64)  # 24 wide down to 10: 2.4 texels per texel
    got = em._shrink(image, 10)
    assert got.shape == (5, 10, 3)
    np.testing.assert_allclose(got.mean(axis=(0, 1)), image.mean(axis=(0, 1)), rtol=1e-6)
    expected = SummedArea(image).box_mean(0.0, 2.4, 0.0, 2.4)
    np.testing.assert_allclose(got[0, 0], expected, rtol=1e-6)


HEADER = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 8\n"
FLAT = b"\x80\x80\x80\x81" * 32  # 4 x 8 uncompressed pixels of 0.5 x 2


@pytest.mark.parametrize(
    ("content", "words"),
    [
        (b"", ["an empty file"]),
        (b"P6\n8 4\n255\n" + b"\0" * 96, ["expected an OpenEXR or Radiance HDR file"]),
        (b"#?PFM\n" + HEADER[11:] + FLAT, ["#?RADIANCE"]),
        (HEADER.replace(b"-Y 4 +X 8", b"-Y 99999999 +X 199999998") + FLAT, ["texels wide"]),
        (HEADER.replace(b"-Y 4 +X 8", b"-Y 0 +X 0") + FLAT, ["texels wide"]),
        (HEADER.replace(b"-Y 4 +X 8", b"+Y 4 +X 8") + FLAT, ["resolution line"]),
        (HEADER.replace(b"-Y 4 +X 8", b"-Y  4 +X 8") + FLAT, ["resolution line"]),
        # Mitsuba would read the first (its own tokenizer), a check of the second only
        (HEADER.replace(b"\n-Y", b"\n-Y  20 +X 40\n-Y") + FLAT, ["line '-Y H +X W', got"]),
        (HEADER.replace(b"-Y 4 +X 8", b"-Y 4 +X 8 junk") + FLAT, ["resolution line"]),
        (HEADER.replace(b"-Y 4 +X 8", b"-Y 99999999999 +X 8") + FLAT, ["resolution line"]),
        (HEADER.replace(b"-Y 4 +X 8", b"-Y 4 +X 4") + FLAT, ["latitude-longitude", "4x4"]),
        (HEADER.replace(b"rgbe", b"xyze") + FLAT, ["FORMAT=32-bit_rle_rgbe"]),
        (HEADER.replace(b"FORMAT=32-bit_rle_rgbe\n", b"") + FLAT, ["FORMAT"]),
        (HEADER[:-1], ["resolution line"]),
        (b"#?RADIANCE\n" + b"#" * 70000, ["resolution line", "65536 bytes"]),
        (b"#?RADIANCE\n" + b"#" * 300 + b"\n" + HEADER[11:] + FLAT, ["header line 2"]),
        (b"#?RADIANCE\nSOFTWARE=\x1b[2J\n" + HEADER[11:] + FLAT, ["printable"]),
        (HEADER + FLAT[:50], ["cannot read the Radiance HDR file"]),
        (HEADER, ["cannot read the Radiance HDR file"]),
    ],
    ids=[
        "empty",
        "wrong-magic",
        "other-program-type",
        "absurd-size",
        "zero-size",
        "other-orientation",
        "odd-spacing",
        "odd-line-first",
        "trailing-junk",
        "too-many-digits",
        "not-lat-long",
        "xyze",
        "no-format",
        "no-size-line",
        "endless-header",
        "long-line",
        "control-characters",
        "truncated",
        "no-pixels",
    ],
)
def test_hostile_hdr_files_are_refused_in_one_line(tmp_path, content, words) -> None:
    path = tmp_path / "hostile.hdr"
    path.write_bytes(content)
    with pytest.raises(GshadeError) as exc:
        read_environment_map(path)
    one_line(exc, str(path), *words)


def test_a_well_formed_flat_hdr_reads(tmp_path) -> None:
    path = tmp_path / "flat.hdr"
    path.write_bytes(HEADER + FLAT)
    np.testing.assert_allclose(read_environment_map(path), 1.0)


@settings(max_examples=60, deadline=None)
@given(st.binary(min_size=0, max_size=400), st.integers(0, 2**32 - 1))
def test_corrupt_hdr_pixels_never_crash(tmp_path_factory, noise, seed) -> None:
    import mitsuba as mi

    path = tmp_path_factory.mktemp("fuzz") / "map.hdr"
    mi.Bitmap(rgb_map(4, seed % 1000)).write(str(path))
    data = bytearray(path.read_bytes())
    start = data.index(b"+X 8\n") + 5
    data[start : start + len(noise)] = noise
    path.write_bytes(bytes(data))
    try:
        got = read_environment_map(path)
    except GshadeError as exc:
        assert "\n" not in str(exc) and str(path) in str(exc)
    else:
        assert got.shape == (4, 8, 3) and np.all(np.isfinite(got)) and np.all(got >= 0)


def test_missing_and_directory(tmp_path) -> None:
    for path, words in [(tmp_path / "none.hdr", ["no such file"]), (tmp_path, ["directory"])]:
        with pytest.raises(GshadeError) as exc:
            read_environment_map(path)
        one_line(exc, str(path), *words)


@pytest.mark.parametrize(
    ("bad", "words"),
    [(np.nan, ["nan", "row 2, column 3"]), (np.inf, ["inf"]), (-1.0, ["-1.0", ">= 0"])],
)
def test_exr_with_bad_values_is_refused(tmp_path, bad, words) -> None:
    image = rgb_map()
    image[2, 3, 1] = bad
    path = write_exr(tmp_path / "bad.exr", {c: image[..., k] for k, c in enumerate("RGB")})
    with pytest.raises(GshadeError) as exc:
        read_environment_map(path)
    one_line(exc, str(path), "finite values", *words)


def test_exr_without_rgb_or_lat_long_size_is_refused(tmp_path) -> None:
    image = rgb_map()
    path = write_exr(tmp_path / "y.exr", {"Y": image[..., 0]})
    with pytest.raises(GshadeError) as exc:
        read_environment_map(path)
    one_line(exc, str(path), "R, G and B", "Y")
    square = {c: np.ones((8, 8), np.float32) for c in "RGB"}
    path = write_exr(tmp_path / "square.exr", square)
    with pytest.raises(GshadeError) as exc:
        read_environment_map(path)
    one_line(exc, str(path), "latitude-longitude", "8x8")


def test_truncated_exr_is_refused(tmp_path) -> None:
    image = rgb_map(32)
    path = write_exr(tmp_path / "map.exr", {c: image[..., k] for k, c in enumerate("RGB")})
    path.write_bytes(path.read_bytes()[:400])
    with pytest.raises(GshadeError) as exc:
        read_environment_map(path)
    one_line(exc, str(path))
