"""`compare` block by block (issue 15, point 3): the same figures, to the last bit, as the
whole-image computation it replaced (tests/support/compare_oracle.py), on images of many blocks."""

import dataclasses
import itertools
import json
import subprocess
import sys
import tracemalloc

import numpy as np
import pytest

from gshade.io.image import write_exr
from gshade.regression import blockwise
from gshade.regression.blockwise import ExactSum, spans
from gshade.regression.comparison import Thresholds, compare

from ..support.compare_oracle import direct_compare
from ..support.exr_files import write_windowed

CHANNELS = ["R", "G", "B", "A", "f", "P.X", "P.Y", "P.Z"]


def identical(new, old):
    """Every field equal, bit for bit (repr tells -0.0, inf and nan apart), and the arrays."""
    for f in dataclasses.fields(old):
        a, b = getattr(new, f.name), getattr(old, f.name)
        if f.name in ("difference", "pixel_difference"):
            assert a.shape == b.shape and a.dtype == b.dtype, f.name
            assert np.array_equal(a, b, equal_nan=True), f.name
        else:
            assert repr(a) == repr(b), f.name


def smooth(shape, seed, half=()):
    h, w = shape
    y, x = np.mgrid[0:h, 0:w] / max(h, w)
    rng = np.random.default_rng(seed)
    out = {}
    for k, c in enumerate(CHANNELS):
        v = 0.5 + 0.4 * np.sin(3 * x + k) * np.cos(2 * y - k) + 1e-3 * rng.random(shape)
        if c.startswith("P."):
            v = 80 * v - 60  # positions: from -60 to 20
        out[c] = v.astype(np.float16 if c in half else np.float32)
    return out


def perturbed(image, seed, share=0.2, amount=1e-2):
    rng = np.random.default_rng(seed)
    out = {}
    for c, v in image.items():
        bump = amount * rng.random(v.shape) * (rng.random(v.shape) < share)
        out[c] = (v + bump).astype(v.dtype)
    return out


@pytest.fixture
def small_blocks(monkeypatch):
    """Blocks of 64 pixels: every image here spans many of them."""
    monkeypatch.setattr(blockwise, "BLOCK", 64)
    return 64


# --------------------------------------------------------------------------- exact sums


@pytest.mark.parametrize("n", [0, 1, 7, 128, 129, 1000, 4099, 70001])
@pytest.mark.parametrize("piece", [1, 5, 64, 1000, 1 << 16])
def test_exact_sum_is_numpys_sum_bit_for_bit(n, piece):
    rng = np.random.default_rng(n)
    x = rng.standard_normal(n) * 10.0 ** rng.integers(-9, 9, n)  # rounding everywhere
    total = ExactSum(n)
    for start in range(0, n, piece):
        total.add(x[start : start + piece])
    assert total.result() == float(np.add.reduce(x))
    assert n < 1000 or total.result() != float(np.add.reduce(np.sort(x)))  # order matters
    with pytest.raises(ValueError, match="values"):
        ExactSum(n + 1).result()


@pytest.mark.parametrize(("n", "block"), [(1, 64), (1000, 64), (4099, 300), (70001, 1 << 12)])
def test_blocks_cover_the_pixels_in_order_as_subtrees_of_the_pairwise_sum(n, block):
    got = list(spans(n, block))
    assert got[0][0] == 0 and got[-1][1] == n
    assert all(stop == start for (_, stop), (start, _) in itertools.pairwise(got))
    assert all(0 < stop - start <= block for start, stop in got)
    x = np.random.default_rng(2).standard_normal(n) * 1e6
    total = ExactSum(n)
    for start, stop in got:
        total.add(x[start:stop])
        # blocks of 128 pixels or more: one numpy sum each, nothing waits for the next block
        assert block < 128 or total._tail.size == 0
    assert total.result() == float(np.add.reduce(x))


# --------------------------------------------------------------------------- compare


@pytest.mark.parametrize("channels", [CHANNELS, ["R", "G", "B"], ["P.Z", "R", "f", "B", "G"]])
def test_many_blocks_give_the_whole_image_figures(small_blocks, channels):
    ref = smooth((37, 53), 0, half={"R", "G", "B", "A"})
    test = perturbed(ref, 1)
    ref["P.Z"][20, 30] = -200.0  # idiff's PSNR peak: the reference's largest magnitude
    for thresholds in (Thresholds(), Thresholds(fail=5e-3, failpercent=5, warn=1e-3)):
        new = compare(test, ref, channels=channels, thresholds=thresholds)
        identical(new, direct_compare(test, ref, channels=channels, thresholds=thresholds))
        assert new.overall.mean_error > 0 and new.verdict != "PASS"


def test_a_tie_across_a_block_boundary_reports_the_first(small_blocks):
    ref = smooth((20, 50), 3)
    boundary = [start for start, _ in spans(20 * 50, small_blocks)][5]
    test = {c: v.copy() for c, v in ref.items()}
    moves = [("G", boundary - 1), ("R", boundary), ("P.Y", boundary + 200), ("P.X", boundary + 200)]
    for c, pixel in moves:  # errors of exactly 0.5: G's, at the last pixel of a block, first
        ref[c].reshape(-1)[pixel], test[c].reshape(-1)[pixel] = 0.25, 0.75
    for channels in (CHANNELS, ["R", "G", "B"], ["R", "P.X", "P.Y", "G"]):
        new = compare(test, ref, channels=channels)
        identical(new, direct_compare(test, ref, channels=channels))
    new = compare(test, ref, channels=CHANNELS)
    y, x = divmod(boundary - 1, 50)
    assert new.overall.max_at == (x, y) and new.overall.max_channel == "G"
    assert new.per_group["P"].max_at == ((boundary + 200) % 50, (boundary + 200) // 50)
    assert new.per_group["P"].max_channel == "P.X"


@pytest.mark.parametrize("seed", range(6))
def test_nan_and_infinity_in_some_blocks(small_blocks, seed):
    rng = np.random.default_rng(seed)
    ref = smooth((31, 29), seed, half={"R", "A"})
    test = perturbed(ref, seed + 10, share=0.5)
    for image in (test, ref):
        for _ in range(3):
            c = CHANNELS[rng.integers(len(CHANNELS))]
            image[c][rng.integers(31), rng.integers(29)] = rng.choice([np.nan, np.inf, -np.inf])
    if seed == 0:  # everywhere non-finite in one channel of the reference
        ref["B"][:] = np.nan
    for channels in (CHANNELS, ["R", "G", "B"], ["A", "f"]):
        with np.errstate(invalid="ignore"):
            old = direct_compare(test, ref, channels=channels)
        identical(compare(test, ref, channels=channels), old)


def test_an_overflowing_difference_of_float64_values(small_blocks):
    ref = {c: np.full((9, 13), 1e308) for c in "RGB"}
    test = {c: np.full((9, 13), 0.5) for c in "RGB"}
    test["G"][4, 6] = -1e308  # 2e308: infinite, but both values are finite
    with np.errstate(over="ignore", divide="ignore"):
        old = direct_compare(test, ref)
    new = compare(test, ref)
    identical(new, old)
    assert new.per_channel["G"].nonfinite == 1 and new.per_channel["G"].nonfinite_test == 0


def test_data_windows_over_many_blocks(tmp_path, small_blocks):
    a = smooth((23, 17), 4)
    b = perturbed(a, 5)
    b["G"][3, 2] = np.nan
    display = (0, 0, 39, 29)
    ref = write_windowed(tmp_path / "ref.exr", a, origin=(5, 2), display=display)
    test = write_windowed(tmp_path / "test.exr", b, origin=(11, 4), display=display)
    for channels in (CHANNELS, ["B", "G", "R"]):
        with np.errstate(invalid="ignore"):
            old = direct_compare(test, ref, channels=channels)
        new = compare(test, ref, channels=channels)
        identical(new, old)
        assert new.window is not None and (new.window.x_min, new.window.y_min) == (5, 2)


def test_half_and_float_channels_of_exr_files(tmp_path, small_blocks):
    half = {"R", "G", "B", "A"}
    a = smooth((41, 33), 6)
    write_exr(tmp_path / "ref.exr", a, half=half)
    write_exr(tmp_path / "test.exr", perturbed(a, 7), half=half)
    test, ref = tmp_path / "test.exr", tmp_path / "ref.exr"
    new = compare(test, ref, channels=CHANNELS)
    identical(new, direct_compare(test, ref, channels=CHANNELS))


def test_without_differences_or_ssim_the_figures_are_the_same():
    ref = smooth((40, 60), 8)
    test = perturbed(ref, 9)
    full = compare(test, ref, channels=CHANNELS)
    lean = compare(test, ref, channels=CHANNELS, ssim=False, differences=False)
    assert full.ssim is not None and lean.ssim is None
    assert lean.difference is None and lean.pixel_difference is None
    assert json.dumps({**full.as_dict(), "ssim": None}) == json.dumps(lean.as_dict())
    assert compare(test, ref, channels=["f"], ssim=True).ssim is None  # no R, G, B


def test_compare_needs_no_whole_image_float64_copies():
    ref = smooth((1024, 1024), 10, half=set(CHANNELS))
    test = perturbed(ref, 11, share=0.01)
    plane = 1024 * 1024 * 8  # one channel in float64
    tracemalloc.start()
    try:
        compare(test, ref, channels=CHANNELS, ssim=False, differences=False)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < plane  # it was over 30 such planes


def test_cli_computes_ssim_only_when_asked(tmp_path):
    a = smooth((16, 20), 12)
    write_exr(tmp_path / "ref.exr", a)
    write_exr(tmp_path / "test.exr", perturbed(a, 13))

    def run(*args):
        pair = [tmp_path / "test.exr", tmp_path / "ref.exr"]
        out = subprocess.run(
            [sys.executable, "-m", "gshade", "compare", *pair, "--json", *args],
            capture_output=True,
            text=True,
        )
        return out.returncode, json.loads(out.stdout)

    (code, plain), (code_ssim, with_ssim) = run(), run("--ssim")
    assert code == code_ssim == 2
    assert plain["ssim"] is None and 0 < with_ssim["ssim"] < 1
    assert with_ssim["ssim"] == compare(tmp_path / "test.exr", tmp_path / "ref.exr").ssim
    assert {**with_ssim, "ssim": None} == plain


def test_an_empty_image(small_blocks):
    empty = {c: np.zeros((0, 5), np.float32) for c in "RGB"}
    identical(compare(empty, dict(empty)), direct_compare(empty, dict(empty)))
