"""EXR and PNG writing and reading: round trips, atomic writes, bad files."""

import os

import imageio.v3 as iio
import numpy as np
import pytest

from gshade import GshadeError
from gshade.io import image, linear_to_srgb, read_exr, write_exr, write_png

NAMES = ["R", "G", "B", "A", "f", "P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z", "u", "v", "patch"]


def channels(shape=(5, 7), seed=0):
    rng = np.random.default_rng(seed)
    out = {name: rng.normal(size=shape).astype(np.float32) for name in NAMES}
    out["patch"] = rng.integers(0, 2**20, size=shape).astype(np.float32)  # ids, exact
    out["f"][0, 0] = np.inf  # non-finite values survive too
    out["f"][0, 1] = np.nan
    return out


def leftovers(directory):
    """Files in the directory other than the test's own (temporary files left behind)."""
    return sorted(p.name for p in directory.iterdir() if p.name.startswith("."))


# --------------------------------------------------------------------------- EXR


def test_exr_round_trip_float32_exact(tmp_path):
    data = channels()
    path = write_exr(tmp_path / "a.exr", data)
    assert path == tmp_path / "a.exr"
    back, header = read_exr(path)
    assert sorted(back) == sorted(NAMES)
    for name in NAMES:
        assert back[name].dtype == np.float32 and back[name].shape == (5, 7)
        np.testing.assert_array_equal(back[name], data[name])
    assert header == {}
    assert leftovers(tmp_path) == []


def test_exr_half_channels(tmp_path):
    data = channels()
    write_exr(tmp_path / "h.exr", data, half={"R", "G", "B", "A"})
    back, _ = read_exr(tmp_path / "h.exr")
    for name in NAMES:
        expected = data[name].astype(np.float16) if name in "RGBA" else data[name]
        np.testing.assert_array_equal(back[name], expected.astype(np.float32))
    assert not np.array_equal(back["R"], data["R"])  # really stored as half


def test_exr_half_is_smaller_and_accepts_other_dtypes(tmp_path):
    big = {"R": np.random.default_rng(1).random((64, 64))}  # float64 in: stored as float32
    write_exr(tmp_path / "f.exr", big)
    write_exr(tmp_path / "h.exr", big, half={"R"})
    assert (tmp_path / "h.exr").stat().st_size < (tmp_path / "f.exr").stat().st_size
    np.testing.assert_array_equal(read_exr(tmp_path / "f.exr")[0]["R"], big["R"].astype(np.float32))
    write_exr(tmp_path / "i.exr", {"patch": np.arange(12, dtype=np.int64).reshape(3, 4)})
    np.testing.assert_array_equal(
        read_exr(tmp_path / "i.exr")[0]["patch"], np.arange(12).reshape(3, 4)
    )


def test_exr_header_round_trip(tmp_path):
    header = {
        "gshade:scene": "teapot-isophotes",
        "gshade:hash": "ab" * 32,
        "gshade:spp": 16,
        "gshade:seed": -3,
        "gshade:period": 0.1,  # a double: exact
        "gshade:fov": np.float32(30.5),
        "comments": "ünïcode ✓",
    }
    write_exr(tmp_path / "a.exr", {"R": np.zeros((2, 3))}, header)
    _, back = read_exr(tmp_path / "a.exr")
    assert back == {**header, "gshade:fov": 30.5}
    assert type(back["gshade:spp"]) is int and type(back["gshade:period"]) is float


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"channels": {}}, "channels: expected a non-empty dict"),
        (
            {"channels": {"R": np.zeros((2, 3, 3))}},
            r"channel 'R': expected a 2-D array .* \(2, 3, 3\)",
        ),
        ({"channels": {"R": np.zeros((0, 3))}}, r"channel 'R': expected a 2-D array"),
        (
            {"channels": {"R": np.zeros((2, 3)), "G": np.zeros((3, 2))}},
            r"channel 'G': expected the shape \(2, 3\) of channel 'R', got \(3, 2\)",
        ),
        ({"channels": {"R": np.zeros((2, 3), dtype=object)}}, "expected an array of real numbers"),
        ({"channels": {"R": np.zeros((2, 3), dtype=complex)}}, "expected an array of real numbers"),
        ({"channels": {"": np.zeros((2, 3))}}, "expected non-empty string names"),
        ({"half": {"Z"}}, r"half: expected names of channels \(R\), got 'Z'"),
        ({"header": {"compression": "none"}}, "header compression: expected a name that is not"),
        ({"header": {"channels": "x"}}, "header channels: expected a name that is not"),
        ({"header": {"gshade:x": [1, 2]}}, "header gshade:x: expected a string, an integer or a"),
        ({"header": {"gshade:x": True}}, "header gshade:x: expected a string, an integer or a"),
        ({"header": {"gshade:x": 2**40}}, r"header gshade:x: expected an integer in \[-2\*\*31"),
        ({"header": {3: "x"}}, "header: expected non-empty string keys"),
    ],
)
def test_exr_write_errors_leave_the_target_untouched(tmp_path, kwargs, message):
    target = tmp_path / "out.exr"
    write_exr(target, {"R": np.ones((2, 3))}, {"gshade:v": "old"})
    before = target.read_bytes()
    args = {"channels": {"R": np.zeros((2, 3))}, **kwargs}
    with pytest.raises(GshadeError, match=message) as info:
        write_exr(target, args.pop("channels"), **args)
    assert str(info.value).startswith(f"{target}: ")
    assert target.read_bytes() == before
    assert leftovers(tmp_path) == []


def test_exr_failure_after_the_temporary_file_is_written(tmp_path, monkeypatch):
    """A failure at the last step (the rename) removes the temporary file, keeps the target."""
    target = tmp_path / "out.exr"
    write_exr(target, {"R": np.ones((2, 3))})
    before = target.read_bytes()

    def refuse(src, dst):
        assert os.path.exists(src) and os.path.dirname(src) == str(tmp_path)
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(image.os, "replace", refuse)
    with pytest.raises(GshadeError, match=r"out.exr: cannot write the file: .*No space left"):
        write_exr(target, {"R": np.zeros((2, 3))})
    assert target.read_bytes() == before
    assert leftovers(tmp_path) == []


def test_exr_failure_inside_the_library_removes_the_temporary_file(tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(image.OpenEXR, "File", broken)
    with pytest.raises(GshadeError, match=r"new.exr: cannot write the file: disk on fire"):
        write_exr(tmp_path / "new.exr", {"R": np.zeros((2, 3))})
    assert list(tmp_path.iterdir()) == []


def test_exr_write_to_a_missing_directory_or_a_directory(tmp_path):
    with pytest.raises(GshadeError, match=r"nowhere/a.exr: cannot write the file: .*not exist"):
        write_exr(tmp_path / "nowhere" / "a.exr", {"R": np.zeros((2, 3))})
    with pytest.raises(GshadeError, match=r": cannot write the file: it is a directory"):
        write_exr(tmp_path, {"R": np.zeros((2, 3))})


def test_written_files_have_ordinary_permissions(tmp_path):
    write_exr(tmp_path / "a.exr", {"R": np.zeros((2, 3))})
    write_png(tmp_path / "a.png", np.zeros((2, 3, 3)))
    mask = os.umask(0)
    os.umask(mask)
    for name in ("a.exr", "a.png"):
        assert (tmp_path / name).stat().st_mode & 0o777 == 0o666 & ~mask


def test_read_exr_errors(tmp_path):
    with pytest.raises(GshadeError, match=r"missing.exr: no such file"):
        read_exr(tmp_path / "missing.exr")
    with pytest.raises(GshadeError, match=r"an OpenEXR file \(a regular file\), got a dir"):
        read_exr(tmp_path)
    text = tmp_path / "text.exr"
    text.write_text("hello, world\n")
    with pytest.raises(GshadeError, match=r"text.exr: expected an OpenEXR file .*got 68 65 6c 6c"):
        read_exr(text)
    empty = tmp_path / "empty.exr"
    empty.write_bytes(b"")
    with pytest.raises(GshadeError, match=r"empty.exr: expected an OpenEXR file .*an empty file"):
        read_exr(empty)
    good = tmp_path / "good.exr"
    write_exr(good, {"R": np.random.default_rng(0).random((64, 64))})
    data = good.read_bytes()
    for n in (8, 100, len(data) // 2, len(data) - 5):
        cut = tmp_path / f"cut{n}.exr"
        cut.write_bytes(data[:n])
        with pytest.raises(GshadeError, match=rf"cut{n}.exr: cannot read the OpenEXR file"):
            read_exr(cut)


# --------------------------------------------------------------------------- PNG


def srgb(x):
    return 12.92 * x if x <= 0.0031308 else 1.055 * x ** (1 / 2.4) - 0.055


def test_srgb_curve():
    x = np.array([0.0, 0.0031308, 0.001, 0.18, 0.5, 1.0])
    np.testing.assert_allclose(linear_to_srgb(x), [srgb(v) for v in x], rtol=1e-15)
    # the two pieces meet: continuous at the threshold
    t = 0.0031308
    assert 12.92 * t == pytest.approx(1.055 * t ** (1 / 2.4) - 0.055, abs=1e-7)
    np.testing.assert_allclose(
        linear_to_srgb([-1.0, 2.0, np.nan, np.inf]), [0, 1, 0, 1], atol=1e-15
    )


def test_png_srgb_encoding_of_known_values(tmp_path):
    linear = np.array([[0.0, 1.0, 0.0031308, 0.5, 0.18, -0.5, 7.0, np.nan]])
    rgb = np.repeat(linear[..., None], 3, axis=2)
    write_png(tmp_path / "a.png", rgb)
    png = iio.imread(tmp_path / "a.png")
    assert png.dtype == np.uint8 and png.shape == (1, 8, 3)
    expected = [0, 255, round(255 * 12.92 * 0.0031308), 188, round(255 * srgb(0.18)), 0, 255, 0]
    assert expected[2] == 10 and expected[4] == 118
    np.testing.assert_array_equal(png[0, :, 0], expected)
    np.testing.assert_array_equal(png[..., 0], png[..., 2])


def test_png_alpha_is_linear(tmp_path):
    rgb = np.zeros((2, 2, 3))
    rgb[0, 0] = [1.0, 0.5, 0.0]
    alpha = np.array([[1.0, 0.5], [0.0, 2.0]])
    write_png(tmp_path / "a.png", rgb, alpha)
    png = iio.imread(tmp_path / "a.png")
    assert png.shape == (2, 2, 4)
    np.testing.assert_array_equal(png[0, 0], [255, 188, 0, 255])
    np.testing.assert_array_equal(png[..., 3], [[255, 128], [0, 255]])


@pytest.mark.parametrize(
    ("rgb", "alpha", "message"),
    [
        (
            np.zeros((2, 3)),
            None,
            r"rgb: expected an array of real numbers of shape \(height, width, 3\)",
        ),
        (np.zeros((2, 3, 4)), None, r"rgb: expected .* got shape \(2, 3, 4\)"),
        (np.zeros((2, 3, 3), dtype=object), None, r"rgb: expected .* dtype object"),
        (
            np.zeros((2, 3, 3)),
            np.zeros((3, 2)),
            r"alpha: expected .* shape \(2, 3\), got shape \(3, 2\)",
        ),
    ],
)
def test_png_errors_leave_the_target_untouched(tmp_path, rgb, alpha, message):
    target = tmp_path / "a.png"
    write_png(target, np.ones((2, 3, 3)))
    before = target.read_bytes()
    with pytest.raises(GshadeError, match=message):
        write_png(target, rgb, alpha)
    assert target.read_bytes() == before
    assert leftovers(tmp_path) == []


def test_png_replaces_an_existing_file(tmp_path):
    target = tmp_path / "a.png"
    write_png(target, np.zeros((2, 3, 3)))
    write_png(target, np.ones((4, 5, 3)))
    assert iio.imread(target).shape == (4, 5, 3)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png"]


def test_the_8_bit_srgb_codes_by_steps_are_the_rounded_transfer_function():
    """Two algorithms for one quantity: round(255 srgb(x)) by a power per value, and the
    count of steps t_k <= x that srgb8 takes (also just beside every step; right at one,
    255 srgb(x) is a half in floats, and which way it rounds is a matter of taste)."""
    rng = np.random.default_rng(5)
    steps = image._srgb8_steps()
    beside = np.concatenate([steps * (1 - 1e-9), steps * (1 + 1e-9)])
    x = np.concatenate([rng.uniform(-0.2, 1.2, 200_000), rng.uniform(0, 0.01, 10_000), beside])
    powered = np.round(255.0 * linear_to_srgb(x)).astype(np.uint8)
    assert np.array_equal(image.srgb8(x[None, :, None].repeat(3, axis=2))[0, :, 0], powered)
