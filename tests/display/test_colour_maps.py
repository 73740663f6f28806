"""Colour-map tables: matplotlib's colours, kept in the cache folder for processes that have
not imported matplotlib (gshade.display.colour_maps)."""

import json
import os
import subprocess
import sys

import matplotlib
import numpy as np
import pytest

from gshade import GshadeError
from gshade.display.colour_maps import SUBFOLDER, colour_map_table, validate_colormap
from gshade.io.image import read_exr

from ..support.paths import ROOT

#: A fresh process: the table of a map, whether matplotlib was imported, the entries kept.
CHILD = """
import json, sys
from gshade.display.colour_maps import colour_map_table
table = colour_map_table(sys.argv[1], int(sys.argv[2]))
print(json.dumps({"table": table.tolist(), "matplotlib": "matplotlib" in sys.modules}))
"""


def run_child(cache, name="coolwarm", size=256):
    env = dict(os.environ, GSHADE_CACHE_DIR=str(cache))
    done = subprocess.run(
        [sys.executable, "-c", CHILD, name, str(size)], env=env, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def entries(cache):
    folder = cache / SUBFOLDER
    return sorted(p for p in folder.iterdir() if p.is_file()) if folder.is_dir() else []


def expected(name, size=256):
    return matplotlib.colormaps[name](np.linspace(0.0, 1.0, size))[:, :3]


@pytest.mark.parametrize("name", ["viridis", "coolwarm", "RdBu_r", "tab10"])
def test_the_table_is_matplotlibs(name):
    assert np.array_equal(colour_map_table(name), expected(name))
    assert np.array_equal(colour_map_table(name, 7), expected(name, 7))


def test_a_second_process_reads_the_table_without_matplotlib(tmp_path):
    first = run_child(tmp_path)
    assert first["matplotlib"] and len(entries(tmp_path)) == 1
    second = run_child(tmp_path)
    assert not second["matplotlib"]
    assert np.array_equal(second["table"], expected("coolwarm"))
    assert first["table"] == second["table"]
    # another size is another entry, from matplotlib
    assert run_child(tmp_path, size=16)["matplotlib"] and len(entries(tmp_path)) == 2


@pytest.mark.parametrize(
    "damage",
    [
        lambda b: b[:-8],  # short
        lambda b: b + b"\0" * 8,  # long
        lambda b: np.full(len(b) // 8, np.nan).tobytes(),  # not finite
        lambda b: np.full(len(b) // 8, 2.0).tobytes(),  # outside [0, 1]
    ],
)
def test_a_damaged_entry_is_no_entry(tmp_path, damage):
    run_child(tmp_path)
    (entry,) = entries(tmp_path)
    entry.write_bytes(damage(entry.read_bytes()))
    again = run_child(tmp_path)
    assert again["matplotlib"]  # asked matplotlib again
    assert np.array_equal(again["table"], expected("coolwarm"))


def test_an_entry_that_is_a_link_is_not_read(tmp_path):
    run_child(tmp_path)
    (entry,) = entries(tmp_path)
    target = tmp_path / "elsewhere.f8"
    target.write_bytes(np.zeros(256 * 3).tobytes())  # a table of black
    entry.unlink()
    entry.symlink_to(target)
    again = run_child(tmp_path)
    assert np.array_equal(again["table"], expected("coolwarm"))
    assert not entry.is_symlink()  # written anew, the link replaced, its target untouched
    assert target.read_bytes() == np.zeros(256 * 3).tobytes()


def test_no_entry_with_the_caches_off(tmp_path):
    env = dict(os.environ, GSHADE_CACHE_DIR="off")
    code = CHILD.replace("sys.argv[1], int(sys.argv[2])", "'viridis', 256")
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert done.returncode == 0 and json.loads(done.stdout)["matplotlib"]


def test_a_process_with_matplotlib_asks_it_and_writes_nothing(tmp_path, monkeypatch):
    # this process has imported matplotlib: its registry may hold a program's own maps
    monkeypatch.setenv("GSHADE_CACHE_DIR", str(tmp_path))
    own = matplotlib.colors.ListedColormap([[0.1, 0.2, 0.3], [0.4, 0.5, 0.6]], name="gshade-own")
    matplotlib.colormaps.register(own)
    try:
        assert validate_colormap("gshade-own") == "gshade-own"
        table = colour_map_table("gshade-own", 4)
        assert np.allclose(table, [[0.1, 0.2, 0.3]] * 2 + [[0.4, 0.5, 0.6]] * 2)
    finally:
        matplotlib.colormaps.unregister("gshade-own")
    assert entries(tmp_path) == []


def test_a_misspelt_name_is_refused_with_the_nearest(tmp_path):
    run_child(tmp_path, name="viridis")
    with pytest.raises(GshadeError, match=r'colormap: .*got "viridus"; did you mean "viridis"'):
        colour_map_table("viridus")
    with pytest.raises(GshadeError, match="colormap: expected the name"):
        validate_colormap(3)


def test_a_command_that_shows_a_colour_map_reads_the_kept_table(tmp_path):
    """The second `gshade render` of a colour-mapped scene imports no matplotlib, and its
    picture is the first one's."""
    scene = ROOT / "scenes" / "coons-mean.toml"
    code = (
        "import sys\nfrom gshade.app.cli import main\n"
        "status = main(sys.argv[1:])\n"
        "print('matplotlib' in sys.modules)\nsys.exit(status)\n"
    )
    env = dict(os.environ, GSHADE_CACHE_DIR=str(tmp_path))
    seen, pictures = [], []
    for k in range(2):
        out = tmp_path / f"{k}.exr"
        args = [scene, "-o", str(out), "--set", "render.width=48", "--set", "render.height=32"]
        done = subprocess.run(
            [sys.executable, "-c", code, "render", *args], env=env, capture_output=True, text=True
        )
        assert done.returncode == 0, done.stderr
        seen.append(done.stdout.strip().splitlines()[-1])
        pictures.append(read_exr(out)[0])
    assert seen == ["True", "False"]
    first, second = pictures
    assert all(np.array_equal(first[c], second[c]) for c in ("R", "G", "B", "f2"))
