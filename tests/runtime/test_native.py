"""Native libraries' own output captured (gshade.runtime.native), and EXR reading without
their noise."""

import os
import subprocess
import sys

import numpy as np
import pytest

from gshade import GshadeError
from gshade.io.image import read_exr, read_exr_header, write_exr
from gshade.runtime.native import MAX_CAPTURED, captured_output


def test_captured_output_takes_what_is_written_to_the_descriptors(capfd):
    print("before", flush=True)
    with captured_output() as native:
        os.write(2, b"native noise on stderr\n")
        os.write(1, b"native noise on stdout\n")
        print("python, inside", file=sys.stderr)
    print("after", flush=True)
    assert native.text.splitlines() == [
        "native noise on stderr",
        "native noise on stdout",
        "python, inside",
    ]
    assert native.line(marker="stdout") == "native noise on stdout"
    out, err = capfd.readouterr()
    assert (out, err) == ("before\nafter\n", "")


def test_captured_output_restores_the_descriptors_after_an_error_and_is_bounded(capfd):
    with pytest.raises(RuntimeError, match="boom"):
        with captured_output() as native:
            os.write(2, b"x" * (MAX_CAPTURED + 1000))
            with captured_output() as inner:  # nested in the same thread
                os.write(2, b"inner\n")
            raise RuntimeError("boom")
    assert inner.text == "inner\n" and len(native.text) == MAX_CAPTURED
    os.write(2, b"shown\n")
    assert capfd.readouterr().err == "shown\n"
    assert native.line(limit=10) == "x" * 9 + "…"


@pytest.fixture
def corrupt_exr(tmp_path):
    """A truncated EXR (libOpenEXR prints a warning on stdout and errors on stderr)."""
    good = tmp_path / "good.exr"
    rng = np.random.default_rng(0)
    write_exr(good, {c: rng.random((120, 160)).astype(np.float32) for c in "RGB"})
    cut = tmp_path / "cut.exr"
    cut.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    return cut, good


def test_corrupt_exr_error_carries_the_library_message_and_prints_nothing(corrupt_exr, capfd):
    cut, _ = corrupt_exr
    with pytest.raises(GshadeError) as info:
        read_exr(cut)
    assert capfd.readouterr() == ("", "")
    message = str(info.value)
    assert message.startswith(f"{cut}: cannot read the OpenEXR file (truncated or corrupt?): ")
    assert "(EXR_ERR_" in message and "\n" not in message


def test_compare_of_a_corrupt_exr_prints_one_line(corrupt_exr):
    cut, good = corrupt_exr
    result = subprocess.run(
        [sys.executable, "-m", "gshade", "compare", str(cut), str(good), "--json"],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 4 and result.stdout == ""
    assert result.stderr.count("\n") == 1 and "cannot read the OpenEXR file" in result.stderr


def test_fifos_are_refused_at_once(tmp_path):
    fifo = tmp_path / "f.exr"
    os.mkfifo(fifo)
    for read in (read_exr, read_exr_header):
        with pytest.raises(GshadeError, match=r"f.exr: expected an OpenEXR file .*FIFO"):
            read(fifo)
    result = subprocess.run(
        [sys.executable, "-m", "gshade", "compare", str(fifo), str(fifo)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 4 and result.stdout == ""
    assert result.stderr.count("\n") == 1 and "FIFO" in result.stderr
