"""Hostile input, second round (issue 24): limits checked once for every path, and messages
that say what a path is.

- ``samples`` of the continuity report: refused (one line, naming the parameter) for CAD
  edges as for patch junctions, before any edge is sampled by the kernel;
- the render's memory limit: ``GSHADE_MEMORY_LIMIT`` never above what ``ulimit -v`` leaves
  (an 8192 x 8192 render was a SIGSEGV that left its temporary);
- scene and data paths: a symbolic-link loop, a folder or a FIFO named like a CAD file is
  said to be one (not a traceback, not "no such file"); a camera error names the scene.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from gshade import GshadeError
from gshade.analysis import edge_continuity, scene_junctions
from gshade.analysis.continuity import MAX_SAMPLES, continuity_report, validate_samples
from gshade.app.cli import main
from gshade.geometry import sphere
from gshade.limits import MAX_CONTINUITY_SAMPLES, memory_budget
from gshade.scene import load_scene

BALL = '[[surface]]\ntype = "sphere"\nradius = 1.0\n'
BAD_SAMPLES = (0, -5, 100_000, MAX_CONTINUITY_SAMPLES + 1)


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


# --------------------------------------------------------------------------- samples


def test_the_samples_limit_is_stated_once():
    assert MAX_SAMPLES == MAX_CONTINUITY_SAMPLES == 4096
    assert validate_samples(1) == 1 and validate_samples(4096) == 4096
    for bad in BAD_SAMPLES:
        with pytest.raises(GshadeError, match=rf"^samples: expected 1 to 4096, got {bad}$"):
            validate_samples(bad)
    for bad in (True, 2.5, "32", None):
        with pytest.raises(GshadeError, match=r"^samples: expected an integer from 1 to 4096"):
            validate_samples(bad)


@pytest.mark.parametrize("samples", BAD_SAMPLES)
def test_cad_edges_refuse_bad_samples_before_the_kernel(samples, monkeypatch):
    """--samples 0 / -5 on a CAD part was a Dr.Jit traceback, 100000 a MemoryError: the
    edges' samples are now checked before the kernel is asked for any edge."""
    import gshade.cad.edges

    def never(*args, **kwargs):
        raise AssertionError("the kernel was asked for edges")

    monkeypatch.setattr(gshade.cad.edges, "shared_edges", never)
    model = SimpleNamespace(bounds=None, faces=[], precision=0.0)  # never looked at
    with pytest.raises(GshadeError, match=rf"^samples: expected 1 to 4096, got {samples}$"):
        edge_continuity.edge_report(model, samples=samples)
    cad = SimpleNamespace(cad=SimpleNamespace(model=model, faces=[0]), patches=[], source="x")
    scene = SimpleNamespace(surfaces=[cad], patches=[])
    with pytest.raises(GshadeError, match=rf"^samples: expected 1 to 4096, got {samples}$"):
        scene_junctions.scene_continuity(scene, samples=samples, tolerances=object())
    with pytest.raises(GshadeError, match=rf"^samples: expected 1 to 4096, got {samples}$"):
        continuity_report([sphere(1.0)], samples=samples)


def test_the_edges_are_measured_in_bounded_chunks(monkeypatch):
    """4096 samples on many edges: the derivative arrays are made a chunk of edges at a
    time (~25 MB), not all at once (768 bytes per edge and sample)."""
    seen = []
    real = edge_continuity._measure_edges

    def spy(model, edges, samples, directions):
        seen.append(len(edges) * samples)
        return real(model, edges, samples, directions)

    monkeypatch.setattr(edge_continuity, "_measure_edges", spy)
    pytest.importorskip("OCP")
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.BRepTools import BRepTools

    from gshade.cad import read_cad

    folder = Path(os.environ.get("TMPDIR", "/tmp"))
    path = folder / f"gshade-chunks-{os.getpid()}.brep"
    BRepTools.Write_s(BRepPrimAPI_MakeBox(1.0, 2.0, 3.0).Shape(), str(path))
    try:
        model = read_cad(path)
    finally:
        path.unlink()
    report, _ = edge_continuity.edge_report(model, samples=4096)
    assert len(report) == 12 and {j.cls for j in report} == {"G0"}
    assert len(seen) == 2 and max(seen) <= edge_continuity._CHUNK_POINTS


def test_the_continuity_command_refuses_bad_samples_on_a_cad_file(tmp_path, capsys):
    pytest.importorskip("OCP")
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    writer = STEPControl_Writer()
    writer.Transfer(BRepPrimAPI_MakeBox(10.0, 20.0, 30.0).Shape(), STEPControl_AsIs)
    writer.Write(str(tmp_path / "box.step"))
    (tmp_path / "ball.toml").write_text(BALL)
    for name in ("box.step", "ball.toml"):
        for samples in ("0", "-5", "100000"):
            status = main(["continuity", str(tmp_path / name), "--samples", samples])
            err = capsys.readouterr().err
            assert status == 2
            assert _one_line(err).endswith(f"--samples: expected 1 to 4096, got {samples}")


# --------------------------------------------------------------------------- memory


def _under_address_limit(code: str, limit: int, **env: str) -> subprocess.CompletedProcess:
    """``python -c code`` with RLIMIT_AS = ``limit`` bytes (``ulimit -v``)."""

    def cap() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    return subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env={**os.environ, **env},
        preexec_fn=cap,
    )


def test_gshade_memory_limit_cannot_exceed_ulimit_v():
    """GSHADE_MEMORY_LIMIT above ``ulimit -v``: the smaller wins, and the source says so."""
    code = "from gshade.limits import memory_budget; print(*memory_budget(), sep='|')"
    limit = 3 * 2**30
    out = _under_address_limit(code, limit, GSHADE_MEMORY_LIMIT="100G")
    assert out.returncode == 0, out.stderr
    value, source = out.stdout.strip().split("|")
    assert int(value) == limit - 512 * 2**20
    assert "ulimit -v" in source and "GSHADE_MEMORY_LIMIT=100G" in source
    out = _under_address_limit(code, limit, GSHADE_MEMORY_LIMIT="1G")  # below: it wins
    assert out.stdout.strip() == f"{2**30}|GSHADE_MEMORY_LIMIT", out.stderr


def test_memory_budget_names_its_source(monkeypatch):
    monkeypatch.setenv("GSHADE_MEMORY_LIMIT", "2G")
    if resource.getrlimit(resource.RLIMIT_AS)[0] == resource.RLIM_INFINITY:
        assert memory_budget() == (2 * 2**30, "GSHADE_MEMORY_LIMIT")
    monkeypatch.setenv("GSHADE_MEMORY_LIMIT", "lots")
    with pytest.raises(GshadeError, match=r"^GSHADE_MEMORY_LIMIT: expected a size"):
        memory_budget()


def test_a_large_render_under_ulimit_v_is_refused_not_crashed(tmp_path):
    """The reproducer: 8192 x 8192 with GSHADE_MEMORY_LIMIT=100G under a 4 GB address
    space died by SIGSEGV inside the renderer and left its temporary."""
    (tmp_path / "ball.toml").write_text(BALL)
    code = (
        "import sys; from gshade.app.cli import console; sys.argv = ['gshade', 'render', "
        f"{str(tmp_path / 'ball.toml')!r}, '-o', {str(tmp_path / 'o.exr')!r}, '--width', "
        "'8192', '--height', '8192', '--spp', '1']; console()"
    )
    out = _under_address_limit(code, 4_000_000_000, GSHADE_MEMORY_LIMIT="100G")
    assert out.returncode == 2, (out.returncode, out.stderr[-2000:])
    line = _one_line(out.stderr)
    assert "ball.toml: the render would need about" in line
    assert "ulimit -v" in line and "GSHADE_MEMORY_LIMIT=100G" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ball.toml"]


# --------------------------------------------------------------------------- paths


def test_a_cad_scene_that_is_a_symlink_loop_is_one_line(tmp_path, capsys):
    loop = tmp_path / "x.step"
    loop.symlink_to(loop)
    with pytest.raises(GshadeError) as caught:
        load_scene(loop)
    assert str(caught.value) == f"{loop}: cannot read the file (Too many levels of symbolic links)"
    for command in ("render", "info", "continuity"):
        args = [command, str(loop)] + (
            ["-o", str(tmp_path / "o.exr")] if command == "render" else []
        )
        assert main(args) == 2
        assert _one_line(capsys.readouterr().err).endswith("Too many levels of symbolic links)")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.step"]


def test_a_folder_or_fifo_named_like_a_cad_file_is_said_to_be_one(tmp_path):
    (tmp_path / "dir.step").mkdir()
    os.mkfifo(tmp_path / "fifo.step")
    with pytest.raises(GshadeError, match=r"dir\.step: expected a CAD file .*got a directory$"):
        load_scene(tmp_path / "dir.step")
    with pytest.raises(GshadeError, match=r"fifo\.step: expected a CAD file .*got a FIFO"):
        load_scene(tmp_path / "fifo.step")
    with pytest.raises(GshadeError, match=r"none\.step: no such file$"):
        load_scene(tmp_path / "none.step")


@pytest.mark.parametrize("kind", ["folder", "fifo"])
def test_a_data_file_that_is_not_a_regular_file_is_said_to_be_one(tmp_path, kind):
    target = tmp_path / "mesh.obj"
    target.mkdir() if kind == "folder" else os.mkfifo(target)
    scene = tmp_path / "s.toml"
    scene.write_text('[[surface]]\ntype = "subdivision"\nfile = "mesh.obj"\n')
    what = "a directory" if kind == "folder" else "a FIFO"
    with pytest.raises(GshadeError) as caught:
        load_scene(scene)
    message = str(caught.value)
    assert message.startswith(f"{scene}: [[surface]] 1 (subdivision): file: ")
    assert f'got "mesh.obj", which is {what}' in message and "no such file" not in message


def test_a_camera_error_names_the_scene(tmp_path):
    from gshade.rendering import render

    path = tmp_path / "ball.toml"
    path.write_text(BALL)
    scene = load_scene(path, {"camera.origin": [0, 0, 0]})
    with pytest.raises(GshadeError) as caught:
        render(scene, width=8, height=8, spp=1)
    assert str(caught.value).startswith(f"{path}: [camera] (target automatic")
