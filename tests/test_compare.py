"""`gshade compare`: metrics, idiff's thresholds and verdicts, exit statuses, diff images."""

import json
import subprocess
import sys

import numpy as np
import pytest

from gshade.io.image import write_exr
from gshade.regression.comparison import Thresholds, compare


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
    from gshade.regression.comparison import z_test

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
