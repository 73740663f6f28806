"""`gshade compare` agrees with OpenImageIO's `idiff` (the `test` extra installs it).

Each case writes a pair of small EXRs, runs both tools with the same thresholds and asserts
the same verdict (exit status), largest error, its pixel (and channel), failing-pixel count,
and idiff's mean and RMS error (gshade's ``all_values``).  Left out, as
docs/reference/comparison.rst says: NaN and infinity (idiff lets NaN match NaN), channels
that differ by name (idiff matches them by position), warnings with no pixel over ``--fail``
(idiff ignores ``--warn`` then), display windows that differ (idiff pads), ties at one pixel
(idiff names the channel first in the file, gshade the first compared), and values within
float32 rounding of a threshold.
"""

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gshade.io.image import write_exr

from ..support.exr_files import write_windowed

pytest.importorskip("OpenImageIO", reason="OpenImageIO (idiff) is in the `test` extra")

_BIN = Path(sys.executable).parent
IDIFF = str(_BIN / "idiff") if os.access(_BIN / "idiff", os.X_OK) else shutil.which("idiff")
pytestmark = pytest.mark.skipif(IDIFF is None, reason="no idiff executable")


def rgb(seed, shape=(12, 16), scale=1.0, offset=0.0):
    rng = np.random.default_rng(seed)
    return {c: (offset + scale * rng.random(shape)).astype(np.float32) for c in "RGB"}


def moved(image, amount, seed, where=1.0):
    """`image` plus uniform noise in [0, amount) on a random share `where` of the values."""
    rng = np.random.default_rng(seed)
    out = {}
    for c, v in image.items():
        noise = rng.random(v.shape) * amount * (rng.random(v.shape) < where)
        out[c] = (v + noise).astype(np.float32)
    return out


def run_idiff(test, ref, options):
    result = subprocess.run(
        [IDIFF, "-v", *options, str(test), str(ref)], capture_output=True, text=True, timeout=30
    )
    out = result.stdout
    found = re.search(r"Max error\s+=\s+(\S+)(?: @ \((\d+), (\d+), ([^)]+)\))?", out)
    assert found, out + result.stderr
    counts = [int(n) for n in re.findall(r"^\s+(\d+) pixels \(.*\) over", out, re.M)]
    mean = float(re.search(r"Mean error = (\S+)", out).group(1))
    rms = float(re.search(r"RMS error = (\S+)", out).group(1))
    at = (int(found.group(2)), int(found.group(3))) if found.group(2) else None
    return {
        "status": result.returncode,
        "max_error": float(found.group(1)),
        "max_at": at,
        "channel": found.group(4),
        "warning": counts[0],
        "failing": counts[1],
        "mean": mean,
        "rms": rms,
    }


def run_gshade(test, ref, options, channels):
    result = subprocess.run(
        [sys.executable, "-m", "gshade", "compare", str(test), str(ref), "--json"]
        + [f"-{o}" if o.startswith("-") else o for o in options]
        + ["--channels", ",".join(channels)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.stderr == ""
    data = json.loads(result.stdout)
    return result.returncode, data


def pair(tmp_path, test, ref, windows=None, half=False):
    t, r = tmp_path / "test.exr", tmp_path / "ref.exr"
    if windows:
        write_windowed(t, test, *windows[0])
        write_windowed(r, ref, *windows[1])
    else:
        write_exr(t, test, half=set(test) if half else None)
        write_exr(r, ref, half=set(ref) if half else None)
    return t, r


def cases():
    base = rgb(1)
    sparse = {k: v.copy() for k, v in base.items()}
    sparse["G"][3, 5] += np.float32(0.75)  # one pixel far over --fail
    sparse["B"][7, 2] += np.float32(0.375)
    tie_ref = {c: np.full((8, 8), 0.25, np.float32) for c in "RGB"}
    tie = {k: v.copy() for k, v in tie_ref.items()}
    tie["R"][5, 5] = tie["G"][1, 6] = np.float32(0.75)  # equal errors at two pixels
    crop = {c: np.zeros((12, 16), np.float32) for c in "RGB"}
    small = rgb(4, shape=(6, 5))
    for c in "RGB":
        crop[c][3:9, 7:12] = small[c]
    one = {k: v.copy() for k, v in small.items()}
    one["R"][4, 1] += np.float32(0.5)
    hdr = rgb(5, scale=8.0, offset=-2.0)
    shape_f = {"f": np.random.default_rng(6).normal(size=(10, 14)).astype(np.float32)}
    # name: (test, reference, idiff options, windows, half)
    return {
        "identical": (base, base, [], None, False),
        "failure: every value moved": (moved(base, 0.1, 2), base, ["-fail", "0.0625"], None, False),
        "pass: under failpercent and warnpercent": (
            moved(base, 0.5, 3, where=0.01),
            base,
            ["-fail", "0.25", "-failpercent", "10", "-warn", "0.125", "-warnpercent", "10"],
            None,
            False,
        ),
        "warning: few fail, many warn": (
            moved(moved(base, 0.01, 7), 1.0, 8, where=0.01),
            base,
            ["-fail", "0.5", "-failpercent", "5", "-warn", "0.0009765625", "-warnpercent", "20"],
            None,
            False,
        ),
        "failure: hardfail": (
            sparse,
            base,
            ["-fail", "0.25", "-failpercent", "100", "-hardfail", "0.5", "-warn", "1"],
            None,
            False,
        ),
        "pass: hardfail above the largest error": (
            sparse,
            base,
            [
                "-fail",
                "0.25",
                "-failpercent",
                "100",
                "-hardfail",
                "1",
                "-warn",
                "0.25",
                "-warnpercent",
                "100",
            ],
            None,
            False,
        ),
        "tie at two pixels": (tie, tie_ref, [], None, False),
        "half floats": (moved(base, 0.01, 9), base, ["-fail", "0.0078125"], None, True),
        "HDR values (peak above 1)": (moved(hdr, 0.5, 10), hdr, ["-fail", "0.25"], None, False),
        "raw shape-function channel": (
            {"f": shape_f["f"] + np.float32(0.001)},
            shape_f,
            ["-fail", "0.0078125", "-warn", "0.0078125"],
            None,
            False,
        ),
        "offset data window (shifted by 2)": (
            base,
            base,
            [],
            (((2, 0), (0, 0, 15, 11)), ((0, 0), None)),
            False,
        ),
        "same offset data window, one pixel changed": (
            one,
            small,
            ["-fail", "0.25", "-warn", "0.25"],
            (((7, 3), (0, 0, 15, 11)), ((7, 3), (0, 0, 15, 11))),
            False,
        ),
        "crop in a smaller data window": (
            small,
            crop,
            [],
            (((7, 3), (0, 0, 15, 11)), ((0, 0), (0, 0, 15, 11))),
            False,
        ),
    }


CASES = cases()


@pytest.mark.parametrize("name", list(CASES))
def test_gshade_compare_agrees_with_idiff(tmp_path, name):
    test, ref, options, windows, half = CASES[name]
    t, r = pair(tmp_path, test, ref, windows, half)
    channels = sorted(test)  # idiff compares every channel, in the file's (sorted) order
    theirs = run_idiff(t, r, options)
    status, ours = run_gshade(t, r, options, channels)
    assert status == theirs["status"] == {"PASS": 0, "WARNING": 1, "FAILURE": 2}[ours["verdict"]]
    assert ours["failing_pixels"] == theirs["failing"]
    assert ours["warning_pixels"] == theirs["warning"]
    o = ours["overall"]
    assert o["max_error"] == pytest.approx(theirs["max_error"], rel=1e-5, abs=1e-12)
    if theirs["max_error"] == 0:
        assert o["max_at"] is None
    else:
        assert tuple(o["max_at"]) == theirs["max_at"] and o["max_channel"] == theirs["channel"]
    v = ours["all_values"]
    assert v["mean_error"] == pytest.approx(theirs["mean"], rel=1e-5, abs=1e-12)
    assert v["rmse"] == pytest.approx(theirs["rms"], rel=1e-5, abs=1e-12)
