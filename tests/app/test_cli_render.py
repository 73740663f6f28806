"""`gshade render` and `gshade info` from the command line: outputs, overrides, bad input."""

import subprocess
import sys

import numpy as np
import pytest

from gshade.io import read_exr

from ..support.paths import ROOT

SCENES = ROOT / "scenes"


def gshade(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "gshade", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
    )


def test_render_writes_exr_and_png_with_overrides(tmp_path):
    exr, png = tmp_path / "teapot.exr", tmp_path / "teapot.png"
    result = gshade(
        "render",
        SCENES / "teapot-isophotes.toml",
        "-o",
        exr,
        "--png",
        png,
        "--width",
        96,
        "--height",
        72,
        "--spp",
        2,
        "--set",
        "shape.period=0.05",
        "--set",
        "render.lighting=flat",
    )
    assert result.returncode == 0, result.stderr
    channels, header = read_exr(exr)
    assert channels["R"].shape == (72, 96)
    assert '"period": 0.05' in header["settings"] and '"lighting": "flat"' in header["settings"]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the teapot fills the automatic frame: coverage touches both sides' margins
    covered = channels["A"] > 0
    assert covered.any(axis=0).sum() > 70
    assert set(np.unique(channels["patch"])) <= set(range(-1, 32))


def test_info_describes_the_teapot():
    result = gshade("info", SCENES / "teapot-isophotes.toml")
    assert result.returncode == 0, result.stderr
    assert "32 x BezierPatch degree (3, 3)" in result.stdout
    assert "collapsed edge u0" in result.stdout


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("name = \n", "scene.toml"),
        ('[[surface]]\ntype = "sphere"\n[shape]\nfunction = "curvy"\n', "function"),
        ('[[surface]]\ntype = "newell"\nfile = "missing.txt"\n', "missing.txt"),
        ('[[surface]]\ntype = "sphere"\n[render]\nwidht = 10\n', "widht"),
        ('[[surface]]\ntype = "sphere"\n[render]\nvariant = "gpu"\n', "variant"),
        ('[[surface]]\ntype = "sphere"\n[render]\nspp = "many"\n', "spp"),
        (
            '[[surface]]\ntype = "bspline"\ndegree = [3, 3]\nknots_u = [0, 1]\nknots_v = [0, 1]\n'
            "points = [[[0, 0, 0]]]\n",
            "surface",
        ),
    ],
)
def test_bad_scenes_exit_2_with_one_line_and_no_output(tmp_path, text, message):
    scene = tmp_path / "scene.toml"
    scene.write_text(text)
    out = tmp_path / "out.exr"
    result = gshade("render", scene, "-o", out)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "Traceback" not in result.stderr
    assert message in lines[0] and "scene.toml" in lines[0]
    assert not out.exists()


def test_missing_scene_and_bad_output_folder(tmp_path):
    result = gshade("render", tmp_path / "nothing.toml")
    assert result.returncode == 2 and "nothing.toml" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    result = gshade("render", SCENES / "sphere-isophotes.toml", "-o", tmp_path / "no" / "x.exr")
    assert result.returncode == 2 and "does not exist" in result.stderr


def test_an_existing_output_is_not_touched_by_a_failing_render(tmp_path):
    out = tmp_path / "keep.exr"
    out.write_bytes(b"precious")
    scene = tmp_path / "scene.toml"
    scene.write_text('[[surface]]\ntype = "sphere"\n[shape]\nfunction = "nope"\n')
    assert gshade("render", scene, "-o", out).returncode == 2
    assert out.read_bytes() == b"precious"
