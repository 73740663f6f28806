"""The CAD kernel in a process of its own (gshade.cad.process): a file that crashes the
kernel, makes it loop or exhausts its memory is one line naming the file, and this process
goes on; results come back through an allow-list; SIGTERM is honoured while the kernel loops.

The damaged files are made here from kernel-built parts (tests/support/cad_parts.py) by the edits
that the hostile-input run found (Open CASCADE 8.0): a BREP file cut in half (the reader
loops), a STEP entity misspelt (the reader crashes).  Where a newer kernel would cope with
such a file, the promise tested still holds: one clean line or a model, never a signal.
"""

from __future__ import annotations

import os
import pickle
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

pytest.importorskip("OCP")

from gshade import GshadeError, limits
from gshade.app.cli import main
from gshade.cad import process as cad_process
from gshade.cad import read_cad
from gshade.cad import zygote as cad_zygote
from gshade.cad.edges import shared_edges
from gshade.cad.mesh import mesh_faces

from ..support.cad_parts import bspline_sheet, filleted_box, write_shape


@pytest.fixture(scope="module")
def parts(tmp_path_factory) -> dict[str, Path]:
    """The filleted box as BREP and STEP, and two damaged copies."""
    folder = tmp_path_factory.mktemp("kernel")
    box = filleted_box()
    out = {
        "box.brep": write_shape(box, folder / "box.brep"),
        "box.step": write_shape(box, folder / "box.step"),
        "sheet.step": write_shape(bspline_sheet(), folder / "sheet.step"),
    }
    data = out["box.brep"].read_bytes()
    (folder / "half.brep").write_bytes(data[: len(data) // 2])  # the reader loops
    out["half.brep"] = folder / "half.brep"
    step = out["box.step"].read_bytes()
    assert step.count(b"CARTESIAN_POINT(") > 10
    (folder / "typo.step").write_bytes(step.replace(b"CARTESIAN_POINT(", b"CARTESIAN_POJNT(", 3))
    out["typo.step"] = folder / "typo.step"
    return out


def _descendants(pid: int) -> list[int]:
    """The processes below ``pid`` (its children, theirs, ...)."""
    parents: dict[int, int] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    parents[int(entry)] = int(f.read().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
    out, todo = [], [pid]
    while todo:
        below = [p for p, parent in parents.items() if parent == todo[-1]]
        todo.pop()
        out += below
        todo += below
    return out


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def test_the_model_comes_back_and_its_operations_run_in_the_child(parts):
    """Read isolated: the faces are the in-process reader's, bit for bit; meshing and the
    edges run in the child and give what they give in-process."""
    isolated = read_cad(parts["box.brep"])
    here = read_cad(parts["box.brep"], isolated=False)
    assert isinstance(isolated.brep, cad_process.KernelProcess)
    assert not isinstance(here.brep, cad_process.KernelProcess)
    assert len(isolated.faces) == len(here.faces) == 26
    for a, b in zip(isolated.faces, here.faces, strict=True):
        assert a.kind == b.kind and a.box == b.box and a.reversed == b.reversed
        assert (a.patch.points == b.patch.points).all()
        assert all((x == y).all() for x, y in zip(a.loops, b.loops, strict=True))
    m1, m2 = mesh_faces(isolated, 0.5), mesh_faces(here, 0.5)
    assert (m1.positions == m2.positions).all() and (m1.triangles == m2.triangles).all()
    e1, e2 = shared_edges(isolated, 8), shared_edges(here, 8)
    assert [e.faces for e in e1] == [e.faces for e in e2]
    assert all((a.uv[0] == b.uv[0]).all() for a, b in zip(e1, e2, strict=True))
    child = isolated.brep._child.pid
    assert _alive(child)
    isolated.brep.close()  # the model's child ends with it
    assert not _alive(child)


def test_a_dropped_model_ends_its_child(parts):
    model = read_cad(parts["sheet.step"])
    child = model.brep._child.pid
    del model
    import gc

    gc.collect()
    assert not _alive(child)


def test_a_crash_in_the_kernel_is_one_line(parts):
    """The misspelt entity crashes Open CASCADE 8's STEP reader; either way (a newer kernel
    may read or refuse it) the caller gets a model or one line naming the file."""
    try:
        read_cad(parts["typo.step"])
    except GshadeError as exc:
        message = str(exc)
        assert message.startswith(str(parts["typo.step"])) and "\n" not in message
        assert "crashed (SIGSEGV) reading it" in message or "kernel" in message


def test_a_child_killed_by_a_signal_is_said_to_have_crashed(parts, monkeypatch):
    """A signal that ends the child while it reads (here sent on purpose, as a crash would)
    is named in one line; this process goes on."""
    monkeypatch.setenv("GSHADE_CAD_TIMEOUT", "300")
    started = threading.Event()
    real = cad_process._send

    def send_then_crash(child, message):
        real(child, message)
        started.set()
        threading.Timer(1.0, os.kill, (child.pid, signal.SIGSEGV)).start()

    monkeypatch.setattr(cad_process, "_send", send_then_crash)
    with pytest.raises(GshadeError) as info:
        read_cad(parts["half.brep"])  # loops: still reading when the signal comes
    assert started.is_set()
    assert str(info.value) == (
        f"{parts['half.brep']}: the CAD kernel crashed (SIGSEGV) reading it; "
        "the file is probably damaged"
    )


def test_a_looping_reader_is_stopped_at_the_time_limit(parts, monkeypatch):
    monkeypatch.setenv("GSHADE_CAD_TIMEOUT", "1.5")
    children: list[int] = []
    real = cad_process._send

    def record(child, message):
        children.append(child.pid)
        real(child, message)

    monkeypatch.setattr(cad_process, "_send", record)
    with pytest.raises(GshadeError) as info:
        read_cad(parts["half.brep"])
    assert str(info.value) == (
        f"{parts['half.brep']}: the CAD kernel took longer than 1.5 s reading it "
        "(GSHADE_CAD_TIMEOUT sets the limit)"
    )
    assert children and not _alive(children[0])


def test_the_time_limit_is_the_smaller_of_the_setting_and_the_block(monkeypatch):
    monkeypatch.setenv("GSHADE_CAD_TIMEOUT", "30")
    assert cad_process.kernel_seconds() == 30
    with cad_process.kernel_time_limit(5):
        assert cad_process.kernel_seconds() == 5
        with cad_process.kernel_time_limit(60):
            assert cad_process.kernel_seconds() == 5
    with cad_process.kernel_time_limit(None):
        assert cad_process.kernel_seconds() == 30
    monkeypatch.delenv("GSHADE_CAD_TIMEOUT")
    assert cad_process.kernel_seconds() == limits.CAD_SECONDS
    for bad in ("0", "-3", "soon", "nan", "inf"):
        monkeypatch.setenv("GSHADE_CAD_TIMEOUT", bad)
        with pytest.raises(GshadeError, match="GSHADE_CAD_TIMEOUT: expected a positive"):
            cad_process.kernel_seconds()


def test_a_runaway_allocation_is_refused(parts, monkeypatch):
    """Reading within a tiny address-space budget: the kernel's allocation fails, and the
    caller hears of the memory (or of a crash at the limit), in one line."""
    monkeypatch.setattr(limits, "CAD_READ_MEMORY_BASE", 2**20)
    monkeypatch.setattr(limits, "CAD_READ_MEMORY_PER_BYTE", 0)
    with pytest.raises(GshadeError) as info:
        read_cad(parts["box.step"])
    message = str(info.value)
    assert message.startswith(str(parts["box.step"])) and "\n" not in message
    assert "needed more than" in message or "crashed (" in message


def test_answers_are_unpickled_through_an_allow_list():
    """A child whose memory a hostile file corrupted cannot make this process run code."""
    evil = pickle.dumps(("ok", os.system))
    with pytest.raises(pickle.UnpicklingError, match=r"posix\.system is not a CAD result"):
        cad_process._Results.answer(evil)

    class Sneaky:
        def __reduce__(self):
            return (eval, ("1 + 1",))

    with pytest.raises(pickle.UnpicklingError, match=r"builtins\.eval"):
        cad_process._Results.answer(pickle.dumps(("ok", Sneaky())))
    with pytest.raises(ValueError, match="kind"):
        cad_process._Results.answer(pickle.dumps(("surprise", None)))


def test_an_answer_that_is_refused_is_one_line(parts, monkeypatch):
    monkeypatch.setattr(cad_process._Results, "ALLOWED", frozenset())
    with pytest.raises(GshadeError) as info:
        read_cad(parts["sheet.step"])
    assert "gave an answer gshade does not accept reading it" in str(info.value)


def test_cli_and_batch_go_on_after_a_crash(parts, tmp_path, capsys, monkeypatch):
    """One damaged file costs its scene: the others of a batch render, the manifest and the
    failed scene's log are written."""
    monkeypatch.chdir(tmp_path)
    good = tmp_path / "good.toml"
    good.write_text(
        '[[surface]]\ntype = "sphere"\n[render]\nwidth = 16\nheight = 12\nspp = 1\n'
        'lighting = "flat"\n'
    )
    crash = tmp_path / "crash.step"
    crash.write_bytes(parts["typo.step"].read_bytes())
    hang = tmp_path / "hang.brep"
    hang.write_bytes(parts["half.brep"].read_bytes())
    monkeypatch.setenv("GSHADE_CAD_TIMEOUT", "3")
    status = main(["batch", str(good), str(crash), str(hang), "-o", "out", "-j", "1"])
    out, err = capsys.readouterr()
    assert status == 2
    assert (tmp_path / "out" / "good.exr").is_file()
    assert (tmp_path / "out" / "manifest.json").is_file()
    assert "Traceback" not in out + err
    assert "hang.brep: the CAD kernel took longer than 3 s reading it" in err


def test_sigterm_is_honoured_while_the_kernel_loops(parts, tmp_path):
    """`gshade info` on a file the reader loops on: SIGTERM ends gshade (status 143) and its
    kernel process, long before the kernel's time limit (the kernel ignores SIGTERM while it
    loops; gshade waits for it in Python)."""
    hang = tmp_path / "hang.brep"
    hang.write_bytes(parts["half.brep"].read_bytes())
    env = {**os.environ, "GSHADE_CAD_TIMEOUT": "600"}
    gshade = subprocess.Popen(
        [sys.executable, "-m", "gshade", "info", str(hang)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
    )
    try:
        kernel: list[int] = []
        while len(kernel) < 2 and gshade.poll() is None:  # the zygote and the model's child
            time.sleep(0.1)
            kernel = _descendants(gshade.pid)
        time.sleep(1.0)  # well into the reader's loop
        gshade.send_signal(signal.SIGTERM)
        _, err = gshade.communicate(timeout=300)  # a hang guard only: far below 600 s
    finally:
        gshade.kill()
    assert gshade.returncode == 128 + signal.SIGTERM
    assert b"terminated by signal 15" in err and b"Traceback" not in err
    for _ in range(100):  # the kernel's process is killed with its parent
        if not any(_alive(k) for k in kernel):
            break
        time.sleep(0.1)
    assert kernel and not any(_alive(k) for k in kernel)


def _parent(pid: int) -> int:
    with open(f"/proc/{pid}/stat") as f:
        return int(f.read().rsplit(")", 1)[1].split()[1])


def test_models_are_forked_from_one_zygote(parts):
    """The kernel's libraries are loaded once, by the zygote; each model's process is
    forked from it."""
    a, b = read_cad(parts["sheet.step"]), read_cad(parts["box.brep"])
    first, second = a.brep._child, b.brep._child
    assert isinstance(first, cad_zygote.Forked) and isinstance(second, cad_zygote.Forked)
    assert first.zygote is second.zygote and first.pid != second.pid
    assert _parent(first.pid) == _parent(second.pid) == first.zygote.process.pid
    assert _parent(first.zygote.process.pid) == os.getpid()


def test_without_the_zygote_a_model_gets_a_process_of_its_own(parts, monkeypatch):
    monkeypatch.setenv("GSHADE_CAD_ZYGOTE", "off")
    monkeypatch.setattr(cad_zygote, "_zygotes", {})
    model = read_cad(parts["sheet.step"])
    assert isinstance(model.brep._child, subprocess.Popen)
    assert _parent(model.brep._child.pid) == os.getpid()
    here = read_cad(parts["sheet.step"], isolated=False)
    assert (model.faces[0].patch.points == here.faces[0].patch.points).all()


def test_a_dead_zygote_costs_its_models_only(parts, monkeypatch):
    """The zygote killed: its models' processes die with it (one line when used), and the
    next model is read all the same (a process of its own, then a new zygote)."""
    monkeypatch.setattr(cad_zygote, "_zygotes", {})  # a zygote of this test's own
    model = read_cad(parts["sheet.step"])
    child = model.brep._child
    child.zygote.process.kill()
    child.zygote.process.wait()
    for _ in range(100):
        if not _alive(child.pid):
            break
        time.sleep(0.05)
    assert not _alive(child.pid)
    with pytest.raises(GshadeError, match="the CAD kernel"):
        mesh_faces(model, 1.0)
    for _ in range(2):
        again = read_cad(parts["sheet.step"])
        assert len(again.faces) == 1 and len(mesh_faces(again, 1.0).triangles) > 0
