"""Fuzz test of CAD input: damaged copies of kernel-made parts (STEP, IGES, BREP, 3dm),
made here at test time, each given to `gshade info` and, where it reads, to `gshade
render`, in this process.  The promise is the scenes' (tests/hostile/test_fuzz.py): one clean line
(exit status 2) or a model and a finite picture; never a signal (it would end this test
process), a hang (the kernel's time limit ends it) or a traceback.

The mutations are those of the hostile-input run that found the kernel's crashes and loops:
truncations (with a STEP file's trailer put back), flipped bytes, hostile numbers (1e400,
1e308, a negative or huge count), and structure edits (a misspelt entity, deep nesting, an
inflated count).  Each is deterministic (a fixed seed).
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

pytest.importorskip("OCP")

from gshade.app.cli import main
from gshade.io.image import read_exr

from ..support.cad_parts import bspline_sheet, filleted_box, write_shape
from ..support.fuzz_scenes import (
    CASE_TIMEOUT,  # the scenes' hang guard (300 s), not a speed test
    alarm,
)

pytestmark = pytest.mark.slow  # damaged CAD files, each up to the kernel's time limit

SEEDS = ("box.step", "box.igs", "box.brep", "sheet.step", "sheet.igs", "sheet.brep", "ball.3dm")

_NUMBER = re.compile(rb"(?<![A-Za-z0-9_#.])-?\d+\.\d*(?:E[+-]?\d+)?")
_COUNT = re.compile(rb"(?m)^(Curves|Surfaces|Locations|TShapes|Polygon3D) (\d+)")


def _truncated(data: bytes, name: str, fraction: float) -> bytes:
    cut = data[: int(len(data) * fraction)]
    if name.endswith(".step"):  # the trailer put back: the cut is inside
        cut += b"\nENDSEC;\nEND-ISO-10303-21;\n"
    return cut


def _flipped(data: bytes, seed: int, count: int) -> bytes:
    rng = np.random.default_rng(seed)
    out = bytearray(data)
    for at in rng.integers(len(data) // 8, len(data), count):
        out[at] ^= 1 << int(rng.integers(0, 7))
    return bytes(out)


def _number(data: bytes, seed: int, value: bytes, every: bool = False) -> bytes:
    found = list(_NUMBER.finditer(data))
    if not found:
        return data
    if every:
        return _NUMBER.sub(value, data)
    at = found[np.random.default_rng(seed).integers(len(found) // 4, len(found))]
    return data[: at.start()] + value + data[at.end() :]


def _structure(data: bytes, name: str, kind: str) -> bytes:
    if kind == "typo":
        if b"CARTESIAN_POINT(" in data:
            return data.replace(b"CARTESIAN_POINT(", b"CARTESIAN_POJNT(", 2)
        if name.endswith(".igs"):  # the second entity's type in the directory section
            return re.sub(rb"(?m)^.{8}(.{64}D0000003)\r?$", rb"     999\1", data, count=1)
        if name.endswith(".3dm"):  # the file format's version (8 characters after the magic)
            return data[:24] + b"      99" + data[32:]
        return _COUNT.sub(lambda m: m.group(1) + b" -3", data, count=1)
    if kind == "nest":
        if name.endswith(".step"):
            at = data.index(b"DATA;") + 5
            return data[:at] + b"\n#999999=" + b"(" * 100_000 + b")" * 100_000 + b";" + data[at:]
        return data.replace(b",", b"," + b"(" * 5_000, 1)
    # an inflated count
    if _COUNT.search(data):
        return _COUNT.sub(lambda m: m.group(1) + b" 2000000000", data, count=1)
    return _number(data, 7, b"99999999")


MUTATIONS = {
    "truncated-0.3": lambda d, n: _truncated(d, n, 0.3),
    "truncated-0.6": lambda d, n: _truncated(d, n, 0.6),
    "flip-3": lambda d, n: _flipped(d, 3, 3),
    "flip-40": lambda d, n: _flipped(d, 40, 40),
    "number-1e400": lambda d, n: _number(d, 1, b"1.E400"),
    "number-all-1e308": lambda d, n: _number(d, 2, b"1.E308", every=True),
    "number-negative": lambda d, n: _number(d, 3, b"-3."),
    "typo": lambda d, n: _structure(d, n, "typo"),
    "nesting": lambda d, n: _structure(d, n, "nest"),
    "count": lambda d, n: _structure(d, n, "count"),
}


@pytest.fixture(scope="module")
def seeds(tmp_path_factory) -> dict[str, bytes]:
    folder = tmp_path_factory.mktemp("cad-seeds")
    out = {}
    for stem, shape in (("box", filleted_box()), ("sheet", bspline_sheet())):
        for ext in ("step", "igs", "brep"):
            out[f"{stem}.{ext}"] = write_shape(shape, folder / f"{stem}.{ext}").read_bytes()
    r3 = pytest.importorskip("rhino3dm")
    model = r3.File3dm()
    model.Objects.AddBrep(r3.Sphere(r3.Point3d(0, 0, 0), 2.0).ToBrep())
    model.Write(str(folder / "ball.3dm"), 7)
    out["ball.3dm"] = (folder / "ball.3dm").read_bytes()
    return out


def _one_clean_line(status: int, err: str, path) -> None:
    assert status == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gshade: error: "), err
    assert str(path) in lines[0] and "Traceback" not in err


@pytest.mark.parametrize("mutation", sorted(MUTATIONS))
@pytest.mark.parametrize("seed", SEEDS)
def test_damaged_cad_file(seed, mutation, seeds, tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("GSHADE_CAD_TIMEOUT", "5")  # loops end here: still one clean line
    monkeypatch.chdir(tmp_path)
    data = MUTATIONS[mutation](seeds[seed], seed)
    path = tmp_path / f"x{seed[seed.index('.') :]}"
    path.write_bytes(data)
    with alarm(CASE_TIMEOUT):  # a hang of gshade's own (the kernel's ends at 5 s)
        _info_then_render(path, tmp_path, capsys)


def _only_notes(err: str, path) -> None:
    """What a command that succeeded says on stderr: only what the healing changed and the
    faces left out, a line each naming the file."""
    for line in err.splitlines():
        assert line.startswith(("gshade: note: ", "gshade: warning: ")), err
        assert str(path) in line and "Traceback" not in line, err


def _info_then_render(path, tmp_path, capsys) -> None:
    status = main(["info", str(path)])
    out, err = capsys.readouterr()
    if status != 0:
        _one_clean_line(status, err, path)
        return
    assert "faces" in out
    _only_notes(err, path)
    status = main(
        [
            "render",
            str(path),
            "-o",
            str(tmp_path / "o.exr"),
            "--width",
            "24",
            "--height",
            "18",
            "--spp",
            "1",
            "--set",
            "render.lighting=flat",
        ]
    )
    _, err = capsys.readouterr()
    if status != 0:
        _one_clean_line(status, err, path)
        assert not (tmp_path / "o.exr").exists()
        return
    _only_notes(err, path)
    channels, _ = read_exr(tmp_path / "o.exr")
    for name, values in channels.items():
        assert np.isfinite(values).all() or name in ("f", "f.mean"), name
    assert math.isfinite(float(np.nansum(channels["R"])))


def test_the_mutations_change_every_seed(seeds):
    """Each mutation makes a file other than its seed (else it would test nothing)."""
    for seed in SEEDS:
        for name, mutate in MUTATIONS.items():
            assert mutate(seeds[seed], seed) != seeds[seed], (seed, name)
