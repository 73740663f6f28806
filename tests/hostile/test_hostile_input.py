"""Hostile input: names that would escape the chosen folder, unusable names, inputs that are
not regular files, numbers and sizes beyond the stated limits, degenerate surfaces, data
files outside the scene's folder, outputs of a failing command, SIGTERM.

Each case is one line on stderr, exit status 2, and no file written or overwritten."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from gshade import GshadeError
from gshade.app.cli import main
from gshade.io.outputs import (
    HOST,
    MAX_NAME_BYTES,
    output_name,
    remove_stale_temporaries,
    staged,
)
from gshade.rendering import render
from gshade.scene import load_scene

from ..support.paths import TEAPOT

SMALL = '[render]\nwidth = 16\nheight = 12\nspp = 1\nlighting = "flat"\n'
SPHERE = '[[surface]]\ntype = "sphere"\n'


def listing(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def run(capsys, *argv):
    status = main([str(a) for a in argv])
    err = capsys.readouterr().err
    return status, err


def one_line_error(err, *fragments):
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gshade: error: "), err
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])


# --------------------------------------------------------------------------- output names


@pytest.mark.parametrize(
    ("name", "why"),
    [
        ("../../escaped", "path separator"),
        ("/tmp/absolute", "path separator"),
        ("a\\b", "path separator"),
        ("..", "'..'"),
        ("a..b", "'..'"),
        (".hidden", "not starting with '.'"),
        ("a\x00b", "control character"),
        ("a\nb", "control character"),
        ("evil\u202etxt.exe", "control character"),
        ("n" * 300, f"at most {MAX_NAME_BYTES} bytes"),
        ("é" * 101, f"at most {MAX_NAME_BYTES} bytes"),
        ("", "non-empty"),
    ],
)
def test_output_names_that_cannot_name_a_file_are_refused(name, why):
    with pytest.raises(GshadeError, match=r"scene\.toml: name") as info:
        output_name(name, "scene.toml: name")
    assert why in str(info.value) and "\n" not in str(info.value)


def test_good_names_pass():
    for name in ("teapot", "teapot--function=gaussian", "a.b", "ünïcode-✓", "n" * 200):
        assert output_name(name) == name


@pytest.mark.parametrize("name", ["../../escaped", "ABSOLUTE", "a\\u0000b", "x" * 300])
def test_render_batch_and_check_never_write_outside_the_chosen_folder(tmp_path, capsys, name):
    work = tmp_path / "work"
    (work / "out").mkdir(parents=True)
    (work / "refs").mkdir()
    scene = work / "evil.toml"
    name = name.replace("ABSOLUTE", str(tmp_path / "absolute"))
    scene.write_text(f'name = "{name}"\n' + SPHERE + SMALL)
    good = work / "z-good.toml"
    good.write_text('[[surface]]\ntype = "torus"\n' + SMALL)
    before = listing(tmp_path)
    cwd = os.getcwd()
    os.chdir(work / "out")
    try:
        status, err = run(capsys, "render", scene)
    finally:
        os.chdir(cwd)
    assert status == 2
    one_line_error(err, f"{scene}: name: expected a name")
    assert listing(tmp_path) == before
    # check --update: the bad scene is an ERROR, the good one gets its reference
    status, err = run(capsys, "check", scene, good, "--references", work / "refs", "--update")
    assert status == 2
    assert sorted(os.listdir(work / "refs")) == ["z-good.exr"]
    assert listing(tmp_path) == sorted([*before, "work/refs/z-good.exr"])


def test_symlinked_output_is_replaced_not_followed(tmp_path, capsys):
    outside = tmp_path / "outside.exr"
    outside.write_text("precious")
    (tmp_path / "out").mkdir()
    link = tmp_path / "out" / "x.exr"
    link.symlink_to(outside)
    scene = tmp_path / "s.toml"
    scene.write_text(SPHERE + SMALL)
    status, _ = run(capsys, "render", scene, "-o", link)
    assert status == 0
    assert outside.read_text() == "precious"
    assert not link.is_symlink() and link.read_bytes()[:4] == b"\x76\x2f\x31\x01"


# --------------------------------------------------------------------------- failing commands


def test_render_writes_nothing_when_the_png_cannot_be_written(tmp_path, capsys):
    scene = tmp_path / "a.toml"
    scene.write_text(SPHERE + SMALL)
    (tmp_path / "pngdir").mkdir()
    old = tmp_path / "out.exr"
    old.write_text("OLD")
    status, err = run(capsys, "render", scene, "-o", old, "--png", tmp_path / "pngdir")
    assert status == 2
    one_line_error(err, "pngdir: cannot write the file: it is a directory")
    assert old.read_text() == "OLD"
    status, err = run(capsys, "render", scene, "-o", tmp_path / "new.exr", "--png", "/proc/x.png")
    assert status == 2 and not (tmp_path / "new.exr").exists()
    assert not [p for p in os.listdir(tmp_path) if p.startswith(".")]


def test_staged_outputs_are_all_or_nothing(tmp_path):
    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    a.write_text("old a")
    with pytest.raises(RuntimeError), staged([a, b]) as (ta, tb):
        open(ta, "w").write("new a")
        raise RuntimeError("the second file fails")
    assert a.read_text() == "old a" and not b.exists()
    assert os.listdir(tmp_path) == ["a.txt"]
    with staged([a, b]) as (ta, tb):
        open(ta, "w").write("new a")
        open(tb, "w").write("new b")
    assert (a.read_text(), b.read_text()) == ("new a", "new b")


def test_stale_temporaries_of_dead_processes_are_removed(tmp_path):
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"], text=True, capture_output=True
    ).stdout.strip()
    stale = tmp_path / f".x.exr.{HOST}.{dead}-abcd1234.gshade-tmp.exr"
    mine = tmp_path / f".y.exr.{HOST}.{os.getpid()}-abcd1234.gshade-tmp.exr"
    other = tmp_path / ".not-ours.exr"
    for p in (stale, mine, other):
        p.write_text("")
    elsewhere = tmp_path / f".z.exr.another_machine.{dead}-abcd1234.gshade-tmp.exr"
    elsewhere.write_text("")  # a shared folder: that process id means nothing here
    assert remove_stale_temporaries(tmp_path) == [stale]
    assert sorted(os.listdir(tmp_path)) == sorted([mine.name, other.name, elsewhere.name])


@pytest.mark.parametrize(
    "delay", [0.3, pytest.param(2.5, marks=pytest.mark.slow)]
)  # during the imports; during Mitsuba's render
def test_sigterm_during_a_render_leaves_no_temporary(tmp_path, delay):
    scene = tmp_path / "big.toml"
    scene.write_text(
        '[[surface]]\ntype = "torus"\n[render]\nwidth = 1600\nheight = 1200\nspp = 64\n'
        'sampling = "uniform"\n'  # 64 samples in every pixel: seconds of Mitsuba's render
    )
    out = tmp_path / "out"
    out.mkdir()
    p = subprocess.Popen(
        [sys.executable, "-m", "gshade", "render", str(scene), "-o", str(out / "x.exr")],
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 60
    while not os.listdir(out) and time.monotonic() < deadline and p.poll() is None:
        time.sleep(0.01)
    assert os.listdir(out), "the temporary is made before rendering"
    time.sleep(delay)
    assert p.poll() is None
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 128 + signal.SIGTERM, err
    assert os.listdir(out) == []
    assert "Traceback" not in err


# --------------------------------------------------------------------------- inputs


def test_inputs_must_be_regular_files(tmp_path, capsys):
    fifo = tmp_path / "scene.toml"
    os.mkfifo(fifo)
    start = time.monotonic()
    status, err = run(capsys, "info", fifo)
    assert status == 2 and time.monotonic() - start < 5
    one_line_error(err, "expected a scene file (TOML) (a regular file), got a FIFO")
    status, err = run(capsys, "info", "/dev/zero")
    assert status == 2
    one_line_error(err, "/dev/zero: expected a scene file (TOML) (a regular file), got a character")
    big = tmp_path / "big.toml"
    with open(big, "wb") as f:
        f.truncate(17 * 2**20)
    status, err = run(capsys, "info", big)
    assert status == 2
    one_line_error(err, "of at most 16 MB, got 17.0 MB")


def test_data_files_must_lie_within_the_scene_folder(tmp_path, monkeypatch):
    secret = tmp_path / "secret.txt"
    secret.write_text("root:$6$verysecrethash:19000:0:99999:7:::\n")
    folder = tmp_path / "scenes"
    folder.mkdir()
    (folder / "link.txt").symlink_to(secret)
    for name in ("../secret.txt", str(secret), "link.txt"):
        scene = folder / "s.toml"
        scene.write_text(f'[[surface]]\ntype = "newell"\nfile = "{name}"\n')
        with pytest.raises(GshadeError, match="expected a file within the scene's folder") as info:
            load_scene(scene)
        assert "verysecret" not in str(info.value)
    # allowed explicitly: the file is read, and its parse error does not echo its content
    monkeypatch.setenv("GSHADE_DATA_PATH", str(tmp_path))
    with pytest.raises(GshadeError, match=r"line 1: expected the number of patches") as info:
        load_scene(folder / "s.toml")
    assert "verysecret" not in str(info.value) and "$6$" not in str(info.value)


# --------------------------------------------------------------------------- limits


HOSTILE = {
    "integer beyond float": (SPHERE + "radius = 1" + "0" * 400 + "\n", "radius: expected a finite"),
    "5000 digits": (SPHERE + "[check]\nwidth = 1" + "0" * 5000 + "\n", "invalid TOML: Exceeds"),
    "deep nesting": (
        SPHERE + "[check]\nchannels = " + "[" * 3000 + "]" * 3000 + "\n",
        "nested too deeply",
    ),
    "nesting within the parser's reach": (
        SPHERE + "[check]\nchannels = " + "[" * 200 + "]" * 200 + "\n",
        "nested at most 8 deep",
    ),
    "all points equal": (
        '[[surface]]\ntype = "bezier"\npoints = [[[1, 1, 1], [1, 1, 1]], [[1, 1, 1], [1, 1, 1]]]\n',
        "(bezier): degenerate: it has no regular point",
    ),
    "all points equal, away from the origin": (  # derivatives are round-off, not zero
        '[[surface]]\ntype = "bezier"\npoints = ['
        + ", ".join("[" + ", ".join(["[1.0, 2.0, 3.0]"] * 4) + "]" for _ in range(4))
        + "]\n",
        "(bezier): degenerate: it has no regular point",
    ),
    "collinear points": (
        '[[surface]]\ntype = "bezier"\npoints = [[[0, 0, 0], [1, 1, 1]], [[2, 2, 2], [3, 3, 3]]]\n',
        "degenerate",
    ),
    "tiny sphere": (SPHERE + "radius = 1e-300\n", "degenerate"),
    "huge coordinates": (
        '[[surface]]\ntype = "bezier"\n'
        "points = [[[0, 0, 0], [1e300, 0, 0]], [[0, 1, 0], [1, 1, 1]]]\n",
        "points[0][1][0]: expected a finite number within ±1e+15, got 1e+300",
    ),
    "knots near 1e308": (
        '[[surface]]\ntype = "bspline"\ndegree = [1, 1]\nknots_u = [0, 0, 1e308, 1e308]\n'
        "knots_v = [0, 0, 1, 1]\npoints = [[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 1]]]\n",
        "knots_u[2]: expected a finite number",
    ),
    "knots 5e-324 apart": (
        '[[surface]]\ntype = "bspline"\ndegree = [1, 1]\nknots_u = [0, 0, 5e-324, 5e-324]\n'
        "knots_v = [0, 0, 1, 1]\npoints = [[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 1]]]\n",
        "degenerate",
    ),
    "light 1e-320": (SPHERE + "[shape]\nlight = [1e-320, 0, 0]\n", "of length at least 1e-12"),
    "fov 5e-324": (SPHERE + "[camera]\nfov = 5e-324\n", "fov: expected a number in (0.001, 180)"),
    "width 2^31": (SPHERE + "[render]\nwidth = 2147483648\n", "width: expected an integer from 1"),
    "spp 2^30": (SPHERE + "[render]\nspp = 1073741824\n", "spp: expected an integer from 1 to"),
    "seed 2^32": (SPHERE + "[render]\nseed = 4294967296\n", "seed: expected an integer from 0"),
    "tessellation 3000": (SPHERE + "[render]\ntessellation = 3000\n", "from 2 to 1024"),
    "chord tolerance 5e-324": (SPHERE + "[render]\nchord_tolerance = 5e-324\n", "[1e-09, 1]"),
    "degree 60": (
        '[[surface]]\ntype = "bezier"\npoints = ['
        + ", ".join(
            "[" + ", ".join(f"[{i}, {j}, {(i * j) % 3}]" for j in range(61)) + "]" for i in range(2)
        )
        + "]\n",
        "expected at most 21 points per row and column (degree 20), got degree 60",
    ),
    "5000-character file name": (
        '[[surface]]\ntype = "newell"\nfile = "' + "a" * 5000 + '"\n',
        "file: expected a string of at most 4096 characters",
    ),
    "key with a newline": (SPHERE + '"a\\nb" = 1\n', "expected keys of at most 64 printable"),
}


@pytest.mark.parametrize("case", list(HOSTILE))
def test_hostile_scenes_are_one_line_errors(tmp_path, capsys, case):
    text, fragment = HOSTILE[case]
    scene = tmp_path / "scene.toml"
    scene.write_text(text)
    before = listing(tmp_path)
    for command in ("info", "render"):
        status, err = run(
            capsys, command, scene, *(["-o", tmp_path / "o.exr"] * (command == "render"))
        )
        assert status == 2, (command, err)
        one_line_error(err, str(scene), fragment)
    assert listing(tmp_path) == before


def test_render_limits_in_python_and_memory(tmp_path, monkeypatch):
    scene = load_scene(_write(tmp_path, SPHERE + SMALL))
    with pytest.raises(GshadeError, match=r"render\(\): \[render\] width: expected an integer"):
        render(scene, width=100_000)
    with pytest.raises(GshadeError, match=r"width x height x spp: expected at most"):
        render(scene, width=16384, height=16384, spp=16)
    monkeypatch.setenv("GSHADE_MEMORY_LIMIT", "300M")
    with pytest.raises(GshadeError, match=r"the render would need about .* the limit is 0.3 GB"):
        render(scene, width=2048, height=2048)
    monkeypatch.setenv("GSHADE_MEMORY_LIMIT", "lots")
    with pytest.raises(GshadeError, match="GSHADE_MEMORY_LIMIT: expected a size"):
        render(scene)


@pytest.mark.parametrize("channel", ["f.mean", "f", "P.X"])  # the samples'; the exact hits'
def test_a_render_with_non_finite_values_is_refused(tmp_path, monkeypatch, channel):
    from gshade.rendering import pipeline

    real = pipeline.exact_channels

    def poisoned(*args):
        channels = real(*args)
        channels[channel][0, 0] = np.nan
        return channels

    monkeypatch.setattr(pipeline, "exact_channels", poisoned)
    with pytest.raises(GshadeError, match=rf"non-finite values \(1 pixels of {channel}\)"):
        render(load_scene(_write(tmp_path, SPHERE + SMALL)))


def test_tessellation_leaving_no_triangle(tmp_path):
    scene = load_scene(_write(tmp_path, SPHERE + SMALL + "tessellation = 2\n"))
    with pytest.raises(GshadeError, match="tessellation: 2 vertices per patch side leave no"):
        render(scene)


def _write(tmp_path, text):
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


def test_a_fifo_or_device_among_the_scenes_fails_alone(tmp_path, capsys):
    """A FIFO named *.toml (and a symbolic link to /dev/zero) in a folder given to batch or
    check: that scene fails at once with one line, the others render."""
    folder = tmp_path / "s"
    folder.mkdir()
    (folder / "a-good.toml").write_text(SPHERE + SMALL)
    os.mkfifo(folder / "b-fifo.toml")
    (folder / "c-zero.toml").symlink_to("/dev/zero")
    start = time.monotonic()
    status, err = run(capsys, "batch", folder, "-o", tmp_path / "out")
    assert status == 2 and time.monotonic() - start < 60
    assert "b-fifo.toml: expected a scene file (TOML) (a regular file), got a FIFO" in err
    assert "c-zero.toml: expected a scene file (TOML) (a regular file), got a character" in err
    assert (tmp_path / "out" / "a-good.exr").exists()
    status, _ = run(capsys, "check", folder, "--references", tmp_path / "refs", "--update")
    assert status == 2 and os.listdir(tmp_path / "refs") == ["a-good.exr"]


def test_the_memory_limit_follows_ulimit_v():
    """Under ``ulimit -v`` (or a container's limit) the default limit is what is left, not
    3/4 of the machine: a render estimated beyond it is refused instead of crashing."""
    code = (
        "import resource; resource.setrlimit(resource.RLIMIT_AS, (3 * 2**30, 3 * 2**30)); "
        "from gshade.limits import memory_limit; print(memory_limit())"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert int(out.stdout) == 3 * 2**30 - 512 * 2**20


def test_a_camera_inside_the_surfaces_keeps_a_small_image_small(tmp_path):
    """A camera inside the teapot saw the nearest surface at depth ~0 and asked for the
    finest mesh and atlas: gigabytes and tens of seconds for a small image."""
    shutil.copy(TEAPOT, tmp_path / "teapot.txt")
    text = '[[surface]]\ntype = "newell"\nfile = "teapot.txt"\n[camera]\norigin = [0.3, 0, 1]\n'
    image = render(load_scene(_write(tmp_path, text + SMALL)), width=160, height=120)
    settings = json.loads(image.metadata["settings"])
    assert 32 * settings["tessellation"] ** 2 <= 16 * 160 * 120
    assert settings["texture_texels"] <= 16 * 160 * 120


def test_an_override_on_a_surface_whose_type_is_not_a_name(tmp_path):
    """``--set surface.1.radius=2`` where ``type = [1]``: was a TypeError (unhashable list)."""
    path = _write(tmp_path, "[[surface]]\ntype = [1]\n")
    with pytest.raises(GshadeError, match=r"\[\[surface\]\] 1: type: expected one of"):
        load_scene(path, {"surface.1.radius": 2})
