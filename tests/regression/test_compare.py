"""`gshade compare`: metrics, idiff's thresholds and verdicts, exit statuses, diff images."""

import json
import subprocess
import sys

import numpy as np
import pytest

from gshade.io.image import write_exr
from gshade.regression.comparison import Thresholds, compare

from ..support.exr_files import write_windowed


def image(seed=0, shape=(32, 48)):
    rng = np.random.default_rng(seed)
    return {c: rng.random(shape).astype(np.float32) for c in ("R", "G", "B", "A", "f")}


def cli(*args):
    result = subprocess.run(
        [sys.executable, "-m", "gshade", "compare", *map(str, args)],
        capture_output=True,
        text=True,
    )
    return result.returncode, result.stdout, result.stderr


def test_identical_images_pass_with_zero_errors():
    a = image()
    result = compare(a, dict(a))
    assert result.verdict == "PASS" and result.exit_status == 0
    assert result.overall.max_error == 0 and result.overall.rmse == 0
    assert result.overall.psnr == float("inf") and result.ssim == pytest.approx(1.0)


def test_metrics_and_where_the_largest_error_is():
    a, b = image(), image()
    b["G"] = b["G"].copy()
    b["G"][5, 7] += 0.25
    b["R"] = b["R"] + np.float32(0.01)
    result = compare(b, a)
    g = result.per_channel["G"]
    assert g.max_at == (7, 5) and g.max_error == pytest.approx(0.25, rel=1e-5)
    assert result.overall.max_at == (7, 5)
    r = result.per_channel["R"]
    assert r.mean_error == pytest.approx(0.01, rel=1e-3)
    assert r.rmse == pytest.approx(0.01, rel=1e-3)
    assert r.psnr == pytest.approx(20 * np.log10(r.data_range / r.rmse))
    assert result.failing == a["R"].size  # every pixel moved by 0.01 > 1e-6


@pytest.mark.parametrize(
    ("thresholds", "verdict"),
    [
        (Thresholds(fail=0.1, warn=0.1), "PASS"),
        (Thresholds(fail=0.1, warn=0.005), "WARNING"),
        (Thresholds(fail=0.005, failpercent=100, warn=0.005, warnpercent=100), "PASS"),
        (Thresholds(fail=0.005, failpercent=1, warn=1), "FAILURE"),
        (Thresholds(fail=1, failpercent=100, hardfail=0.009, warn=1), "FAILURE"),
    ],
)
def test_idiff_verdicts(thresholds, verdict):
    a = image()
    b = {k: v + np.float32(0.01) for k, v in a.items()}
    assert compare(b, a, thresholds=thresholds).verdict == verdict


def test_nan_and_inf_never_match():
    a = image()
    b = {k: v.copy() for k, v in a.items()}
    b["R"][3, 3] = np.nan
    loose = Thresholds(fail=10, warn=10)
    result = compare(b, a, thresholds=loose)
    assert result.verdict == "FAILURE" and result.failing == 1
    assert result.per_channel["R"].nonfinite == 1
    both = {k: v.copy() for k, v in a.items()}
    both["R"][3, 3] = np.inf
    ref = {k: v.copy() for k, v in a.items()}
    ref["R"][3, 3] = np.inf
    assert compare(both, ref, thresholds=loose).verdict == "FAILURE"


def test_raw_shape_function_channel_and_bad_thresholds():
    a, b = image(), image()
    b["f"] = a["f"] + np.float32(1e-3)
    assert (
        compare(b, a, channels=["f"], thresholds=Thresholds(fail=2e-3, warn=2e-3)).verdict == "PASS"
    )
    assert compare(b, a, channels=["f"]).ssim is None
    with pytest.raises(ValueError, match="fail: expected a finite number >= 0"):
        Thresholds(fail=-1)
    for bad in ({"warn": float("nan")}, {"fail": float("inf")}, {"failpercent": 101}):
        with pytest.raises(ValueError, match=f"{next(iter(bad))}: expected"):
            Thresholds(**bad)
    assert Thresholds(hardfail=float("inf"), fail=0).hardfail == float("inf")


def test_cli_exit_statuses_and_outputs(tmp_path):
    a = image()
    b = {k: v + np.float32(0.01) for k, v in a.items()}
    ref, same, moved = tmp_path / "ref.exr", tmp_path / "same.exr", tmp_path / "moved.exr"
    write_exr(ref, a)
    write_exr(same, a)
    write_exr(moved, b)
    assert cli(same, ref)[0] == 0
    assert cli(moved, ref, "--fail", 0.1, "--warn", 0.001)[0] == 1
    code, out, _ = cli(moved, ref, "--json")
    assert code == 2
    data = json.loads(out)
    assert data["verdict"] == "FAILURE" and data["failing_percent"] == 100.0
    assert data["per_channel"]["R"]["max_error"] == pytest.approx(0.01, rel=1e-3)
    # difference images only on request, or only on failure with --diff-on-fail
    d_exr, d_png = tmp_path / "d.exr", tmp_path / "d.png"
    assert cli(same, ref, "--diff", d_exr, "--diff-png", d_png, "--diff-on-fail")[0] == 0
    assert not d_exr.exists() and not d_png.exists()
    assert cli(moved, ref, "--diff", d_exr, "--diff-png", d_png, "--diff-on-fail")[0] == 2
    assert d_png.read_bytes()[:4] == b"\x89PNG"
    from gshade.io.image import read_exr

    diff, _ = read_exr(d_exr)
    np.testing.assert_allclose(diff["G"], 0.01, atol=1e-6)


def test_cli_mismatch_and_unreadable(tmp_path):
    ref, small, text = tmp_path / "ref.exr", tmp_path / "small.exr", tmp_path / "text.exr"
    write_exr(ref, image())
    write_exr(small, image(shape=(16, 16)))
    text.write_text("not an image")
    code, _, err = cli(small, ref)
    assert code == 3 and "size" in err and len(err.strip().splitlines()) == 1
    code, _, err = cli(ref, ref, "--channels", "R,Z")
    assert code == 3 and "Z" in err
    code, _, err = cli(text, ref)
    assert code == 4 and "text.exr" in err
    code, _, err = cli(tmp_path / "missing.exr", ref)
    assert code == 4 and "missing.exr" in err
    truncated = tmp_path / "cut.exr"
    truncated.write_bytes(ref.read_bytes()[:200])
    assert cli(truncated, ref)[0] == 4


def test_cli_json_with_nonfinite_pixels_is_valid_json(tmp_path):
    a = image()
    b = {k: v.copy() for k, v in a.items()}
    b["R"][3, 4] = np.nan
    ref, test = tmp_path / "ref.exr", tmp_path / "test.exr"
    write_exr(ref, a)
    write_exr(test, b)
    code, out, err = cli(test, ref, "--json")
    assert code == 2 and err == ""
    data = json.loads(out)
    assert data["verdict"] == "FAILURE" and data["failing_pixels"] == 1
    assert data["per_channel"]["R"]["psnr"] is None  # -inf: not a JSON number
    assert data["per_channel"]["R"]["max_at"] == [4, 3] and data["overall"]["rmse"] is None
    assert data["per_channel"]["G"]["psnr"] is None  # +inf: G is equal
    assert data["thresholds"]["hardfail"] is None


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--fail", "-1"], "gshade: error: --fail: expected a finite number >= 0, got -1.0"),
        (["--warn", "nan"], "gshade: error: --warn: expected a finite number >= 0, got nan"),
        (["--failpercent", "inf"], "gshade: error: --failpercent: expected a finite number"),
        (["--warnpercent", "101"], "gshade: error: --warnpercent: expected a percentage"),
        (["--hardfail", "-0.5"], "gshade: error: --hardfail: expected a number >= 0 or inf"),
        (["--channels", ","], "gshade: error: --channels: expected channel names"),
        (["--fail", "abc"], "gshade compare: error: argument --fail: invalid float value"),
        (["--bogus"], "gshade compare: error: unrecognized arguments: --bogus"),
        (["--diff", "{tmp}/no/d.exr"], "gshade: error: {tmp}/no/d.exr: cannot write the file"),
        (["--diff-png", "{tmp}"], "gshade: error: {tmp}: cannot write the file: it is a dir"),
        (["--diff", "{tmp}/d", "--diff-png", "{tmp}/d"], "gshade: error: --diff and --diff-png"),
    ],
)
def test_cli_usage_errors_exit_5_with_one_line(tmp_path, args, message):
    ref = tmp_path / "ref.exr"
    write_exr(ref, image())
    tmp = str(tmp_path)
    code, out, err = cli(ref, ref, *[a.format(tmp=tmp) for a in args])
    assert (code, out) == (5, "")
    assert err.startswith(message.format(tmp=tmp)) and err.count("\n") == 1
    # found before the images are read: a missing image does not change the status
    code, _, _ = cli(tmp_path / "missing.exr", ref, *[a.format(tmp=tmp) for a in args])
    assert code == 5
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ref.exr"]  # nothing written


def test_cli_missing_argument_exits_5_and_hardfail_may_be_inf(tmp_path):
    ref = tmp_path / "ref.exr"
    write_exr(ref, image())
    code, _, err = cli(ref)
    assert code == 5 and err.startswith("gshade compare: error: the following arguments")
    assert cli(ref, ref, "--hardfail", "inf", "--fail", "0")[0] == 0


def test_cli_writes_both_difference_images_or_neither(tmp_path):
    a = image()
    ref, moved = tmp_path / "ref.exr", tmp_path / "moved.exr"
    write_exr(ref, a)
    write_exr(moved, {k: v + np.float32(0.01) for k, v in a.items()})
    d_exr = tmp_path / "d.exr"
    code, _, err = cli(moved, ref, "--diff", d_exr, "--diff-png", tmp_path / "no" / "d.png")
    assert code == 5 and "no/d.png: cannot write the file" in err
    assert not d_exr.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["moved.exr", "ref.exr"]
    code, _, _ = cli(moved, ref, "--diff", d_exr, "--diff-png", tmp_path / "d.png")
    assert code == 2 and d_exr.exists() and (tmp_path / "d.png").exists()


def noisy(rng, mean, sd, runs=8):
    """Channels R, G, B: the mean of `runs` noisy samples and the variance of that mean."""
    out = {}
    for c in "RGB":
        samples = mean + rng.normal(0.0, sd, size=(runs, *mean.shape))
        out[c] = samples.mean(0).astype(np.float32)
        out[f"{c}.var"] = (samples.var(0, ddof=1) / runs).astype(np.float32)
    return out


def test_z_test_passes_noise_and_fails_a_change():
    from gshade.regression.statistical import z_test

    rng = np.random.default_rng(1)
    truth = rng.random((40, 50))
    reference = noisy(rng, truth, 0.05)
    assert z_test(noisy(rng, truth, 0.05), reference).verdict == "PASS"
    # thresholds cannot tell that noise from a change: it exceeds 0.02 almost everywhere
    assert (
        compare(noisy(rng, truth, 0.05), reference, thresholds=Thresholds(fail=0.02)).verdict
        == "FAILURE"
    )
    shifted = truth.copy()
    shifted[:, :10] += 0.1  # a real change in a fifth of the picture
    result = z_test(noisy(rng, shifted, 0.05), reference)
    assert result.verdict == "FAILURE" and "pixel-channels" in result.summary()
    broken = noisy(rng, truth, 0.05)
    broken["R"][0, 0] = np.nan
    assert z_test(broken, reference).failing >= 1
    from gshade.regression.comparison import ChannelMismatch

    with pytest.raises(ChannelMismatch, match=r"R\.var"):
        z_test({c: truth for c in "RGB"}, reference)


def test_channel_groups():
    from gshade.regression.comparison import channel_groups

    groups = channel_groups(["R", "G", "B", "A", "f", "P.X", "P.Y", "P.Z", "u", "v", "patch"])
    assert groups == {
        "RGB": ["R", "G", "B"],
        "A": ["A"],
        "f": ["f"],
        "P": ["P.X", "P.Y", "P.Z"],
        "uv": ["u", "v"],
        "patch": ["patch"],
    }
    a = {c: np.zeros((4, 5), np.float32) for c in ("P.X", "P.Y", "P.Z", "f")}
    b = {c: v.copy() for c, v in a.items()}
    b["P.Y"][1, 2] = 0.5
    result = compare(b, a, channels=["P.X", "P.Y", "P.Z", "f"])
    assert set(result.per_group) == {"P"}
    assert result.per_group["P"].max_error == 0.5 and result.per_group["P"].max_at == (2, 1)


def test_top_level_compare_is_the_function_even_after_the_module_is_imported():
    import gshade
    import gshade.regression.check  # imports the gshade.regression.comparison module

    a = image()
    assert gshade.compare(a, dict(a)).verdict == "PASS"


# --------------------------------------------------------------------------- issue 14, point 5


def strict_json(text):
    def refuse(constant):
        raise AssertionError(f"not strict JSON: {constant}")

    return json.loads(text, parse_constant=refuse)


def test_offset_data_window_compares_by_position(tmp_path):
    a = image(shape=(8, 8))
    ref = write_windowed(tmp_path / "ref.exr", a)
    shifted = write_windowed(tmp_path / "shifted.exr", a, origin=(2, 0), display=(0, 0, 7, 7))
    code, out, err = cli(shifted, ref, "--json")
    assert (code, err) == (2, "")  # it used to pass: the data window was ignored
    data = strict_json(out)
    assert data["window"] == [0, 0, 9, 7] and data["display_window"] == [0, 0, 7, 7]
    assert data["pixels"] == 80 and data["size"] == [10, 8]
    result = compare(shifted, ref)
    # pixels outside a data window read 0 (as idiff): x = 0, 1 is the reference alone
    r = result.per_channel["R"]
    assert r.max_error == pytest.approx(
        np.abs(np.pad(a["R"], ((0, 0), (0, 2))) - np.pad(a["R"], ((0, 0), (2, 0)))).max()
    )


def test_windows_place_pixels_in_image_coordinates(tmp_path):
    a = image(shape=(6, 5))
    b = {k: v.copy() for k, v in a.items()}
    b["G"][4, 1] += 0.5
    display = (0, 0, 15, 11)
    ref = write_windowed(tmp_path / "ref.exr", a, origin=(7, 3), display=display)
    test = write_windowed(tmp_path / "test.exr", b, origin=(7, 3), display=display)
    result = compare(test, ref, thresholds=Thresholds(fail=0.1, warn=0.1))
    assert result.verdict == "FAILURE" and result.failing == 1 and result.pixels == 30
    assert result.overall.max_at == (8, 7) and result.per_channel["G"].max_at == (8, 7)
    # a crop of the reference in its own, smaller data window matches it pixel for pixel
    full = {c: np.zeros((12, 16), np.float32) for c in "RGB"}
    for c in "RGB":
        full[c][3:9, 7:12] = a[c]
    whole = write_windowed(tmp_path / "whole.exr", full, display=display)
    assert compare(ref, whole).verdict == "PASS"
    assert compare(whole, ref).verdict == "PASS"


@pytest.mark.parametrize(
    ("origin", "display", "message"),
    [
        ((0, 0), (0, 0, 9, 7), "expected the reference's size 8x8, got 10x8"),
        ((2, 1), (2, 1, 9, 8), "expected the reference's display window (0, 0)-(7, 7)"),
    ],
)
def test_different_display_windows_are_a_size_mismatch(tmp_path, origin, display, message):
    a = image(shape=(8, 8))
    ref = write_windowed(tmp_path / "ref.exr", a)
    test = write_windowed(tmp_path / "test.exr", a, origin=origin, display=display)
    d = tmp_path / "d.exr"
    code, out, err = cli(test, ref, "--json", "--diff", d)
    assert (code, out) == (3, "") and message in err and err.count("\n") == 1
    assert not d.exists()


def test_data_windows_far_apart_are_a_size_mismatch_not_a_giant_array(tmp_path):
    a = image(shape=(4, 4))
    ref = write_windowed(tmp_path / "ref.exr", a, display=(0, 0, 7, 7))
    far = write_windowed(tmp_path / "far.exr", a, origin=(10**9, 10**9), display=(0, 0, 7, 7))
    code, out, err = cli(far, ref)
    assert (code, out) == (3, "") and "expected data windows near" in err
    assert err.count("\n") == 1


@pytest.mark.parametrize(
    ("where", "value", "counts"),
    [
        ("test", np.nan, (1, 0)),
        ("reference", np.inf, (0, 1)),
        ("test", -np.inf, (1, 0)),
        ("both", np.inf, (1, 1)),
        ("both", np.nan, (1, 1)),
    ],
)
def test_json_is_strict_with_counts_of_nonfinite_pixels(tmp_path, where, value, counts):
    a = image()
    b = {k: v.copy() for k, v in a.items()}
    if where in ("test", "both"):
        b["G"][2, 9] = value
    if where in ("reference", "both"):
        a["G"][2, 9] = value
    write_exr(tmp_path / "ref.exr", a)
    write_exr(tmp_path / "test.exr", b)
    code, out, err = cli(tmp_path / "test.exr", tmp_path / "ref.exr", "--json")
    assert (code, err) == (2, "")  # NaN or infinity never matches: FAILURE
    data = strict_json(out)
    for block in (data["per_channel"]["G"], data["overall"], data["per_group"]["RGB"]):
        assert block["nonfinite"] == 1
        assert (block["nonfinite_test"], block["nonfinite_reference"]) == counts
        assert block["max_at"] == [9, 2] and block["max_channel"] == "G"
        assert block["max_error"] is None and block["psnr"] is None and block["rmse"] is None
    assert data["per_channel"]["R"]["nonfinite"] == 0
    assert data["nonfinite_pixels"] == {"either": 1, "test": counts[0], "reference": counts[1]}
    assert data["all_values"]["mean_error"] is None
    text = compare(tmp_path / "test.exr", tmp_path / "ref.exr").summary()
    assert f"1 pixel NaN or infinite (test {counts[0]}, reference {counts[1]})" in text


def test_every_metrics_dictionary_is_strict_json(tmp_path):
    from gshade.regression.check import CheckResult
    from gshade.regression.report import write_report
    from gshade.regression.statistical import z_test

    a = {c: np.zeros((8, 8), np.float32) for c in ("R", "G", "B", "R.var", "G.var", "B.var")}
    b = {k: v.copy() for k, v in a.items()}
    b["R"][0, 0], b["G"][1, 1], b["B.var"][2, 2] = np.nan, -np.inf, np.inf
    results = [compare(a, dict(a)), compare(b, a), compare(a, b), z_test(b, a), z_test(a, a)]
    for r in results:
        json.dumps(r.as_dict(), allow_nan=False)
    checks = [
        CheckResult(f"s{k}", tmp_path / f"s{k}.toml", r.verdict, r.summary(), comparison=r)
        for k, r in enumerate(results)
    ]
    write_report(checks, tmp_path / "report")
    summary = strict_json((tmp_path / "report" / "summary.json").read_text())
    nonfinite = {s["name"]: s["metrics"]["nonfinite_pixels"]["either"] for s in summary["scenes"]}
    assert nonfinite == {"s0": 0, "s1": 2, "s2": 2, "s3": 2, "s4": 0}


def test_a_tie_names_the_channel_at_the_reported_pixel():
    ref = {c: np.full((8, 8), 0.25, np.float32) for c in "RGB"}
    test = {k: v.copy() for k, v in ref.items()}
    test["R"][5, 5] = 0.75  # R: 0.5 at (5, 5)
    test["G"][1, 6] = 0.75  # G: 0.5 at (6, 1), first in row-major order
    result = compare(test, ref)
    assert result.per_channel["R"].max_error == result.per_channel["G"].max_error == 0.5
    assert result.overall.max_at == (6, 1) and result.overall.max_channel == "G"
    assert "max error 0.5 at (6, 1) in G" in result.summary()  # it said "in R"
    assert result.as_dict()["max_channel"] == "G"
    # a tie at one pixel: the first channel in the compared order
    test["B"][1, 6] = 0.75
    assert compare(test, ref, channels=["B", "G", "R"]).overall.max_channel == "B"
    assert compare(test, ref, channels=["R", "G", "B"]).overall.max_channel == "G"


def test_json_says_what_overall_mean_rmse_and_psnr_mean(tmp_path):
    a = image(shape=(8, 8))
    b = {k: v.copy() for k, v in a.items()}
    b["R"][1, 2] += 0.5
    b["B"][3, 4] += 0.25
    write_exr(tmp_path / "ref.exr", a)
    write_exr(tmp_path / "test.exr", b)
    data = strict_json(cli(tmp_path / "test.exr", tmp_path / "ref.exr", "--json")[1])
    definitions = data["definitions"]
    for key in ("overall", "mean_error", "rmse", "psnr", "all_values", "nonfinite", "null"):
        assert isinstance(definitions[key], str) and definitions[key]
    assert "worst channel" in definitions["overall"]
    values = np.stack([b[c].astype(float) - a[c] for c in "RGB"])
    # overall: over pixels, each pixel's worst channel; all_values: over every value (idiff)
    worst = np.abs(values).max(axis=0)
    assert data["overall"]["mean_error"] == pytest.approx(worst.mean())
    assert data["overall"]["rmse"] == pytest.approx(np.sqrt((worst**2).mean()))
    v = data["all_values"]
    assert v["values"] == 3 * 64 and v["mean_error"] == pytest.approx(np.abs(values).mean())
    assert v["rmse"] == pytest.approx(np.sqrt((values**2).mean()))
    peak = max(1.0, *(float(np.abs(x[c]).max()) for x in (a, b) for c in "RGB"))
    assert v["peak"] == pytest.approx(peak)
    assert v["psnr"] == pytest.approx(20 * np.log10(peak / v["rmse"]))
