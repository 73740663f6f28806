"""`gshade batch`: scenes and sweeps into a folder, workers, up-to-date skipping, failures."""

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from gshade import GshadeError
from gshade.app.batch import (
    expand_scenes,
    job_status,
    parse_sweeps,
    plan_jobs,
    run_batch,
    validate_batch_options,
)
from gshade.io.image import read_exr
from gshade.io.outputs import HOST

from ..support.paths import TEAPOT

SMALL = '[render]\nwidth = 48\nheight = 36\nspp = 1\nlighting = "flat"\n'


@pytest.fixture
def scenes(tmp_path):
    folder = tmp_path / "scenes"
    folder.mkdir()
    shutil.copy(TEAPOT, folder / "teapot.txt")
    (folder / "teapot.toml").write_text(
        '[[surface]]\ntype = "newell"\nfile = "teapot.txt"\n[shape]\nfunction = "isophotes"\n'
        + SMALL
    )
    (folder / "sphere.toml").write_text('[[surface]]\ntype = "sphere"\n' + SMALL)
    return folder


def start_batch(folder, out):
    """``gshade batch FOLDER -o OUT`` in the background, its output piped."""
    return subprocess.Popen(
        [sys.executable, "-m", "gshade", "batch", str(folder), "-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "gshade", "batch", *map(str, args)],
        capture_output=True,
        text=True,
    )


def test_folder_with_workers_equals_one_process(scenes, tmp_path):
    jobs = plan_jobs(expand_scenes([str(scenes)]), [])
    assert [j.name for j in jobs] == ["sphere", "teapot"]
    one = run_batch(jobs, tmp_path / "one", workers=1)
    two = run_batch(jobs, tmp_path / "two", workers=2)
    assert [r.status for r in one] == [r.status for r in two] == ["rendered", "rendered"]
    for job in jobs:
        a, _ = read_exr(tmp_path / "one" / f"{job.name}.exr")
        b, header = read_exr(tmp_path / "two" / f"{job.name}.exr")
        assert all(np.array_equal(a[c], b[c]) for c in a)
        assert header["batch_hash"] == one[0 if job.name == "sphere" else 1].hash
        assert (tmp_path / "two" / f"{job.name}.png").exists()
    manifest = json.loads((tmp_path / "two" / "manifest.json").read_text())
    assert [j["status"] for j in manifest["jobs"]] == ["rendered", "rendered"]


def test_up_to_date_outputs_are_skipped_until_something_changes(scenes, tmp_path):
    out = tmp_path / "out"
    assert cli(scenes, "-o", out).returncode == 0
    mtime = (out / "teapot.exr").stat().st_mtime_ns
    result = cli(scenes, "-o", out)
    assert result.returncode == 0 and "0 rendered, 2 up to date" in result.stdout
    assert (out / "teapot.exr").stat().st_mtime_ns == mtime
    # a change in a data file makes its scene out of date, and --force renders everything
    data = scenes / "teapot.txt"
    data.write_text(data.read_text().replace("1.4,0.0,2.4", "1.41,0.0,2.4", 1))
    assert "1 rendered, 1 up to date" in cli(scenes, "-o", out).stdout
    assert "2 rendered" in cli(scenes, "-o", out, "--force").stdout


def test_sweeps_name_their_outputs(scenes, tmp_path):
    sweeps = parse_sweeps(["shape.function=isophotes,mean", "shape.light=[0,0,1],[1,0,1]"])
    assert sweeps[1] == ("shape.light", [[0, 0, 1], [1, 0, 1]])
    jobs = plan_jobs(expand_scenes([str(scenes / "teapot.toml")]), sweeps[:1])
    assert [j.name for j in jobs] == ["teapot--function=isophotes", "teapot--function=mean"]
    results = run_batch(jobs, tmp_path / "out")
    assert all(r.status == "rendered" for r in results)
    _, header = read_exr(tmp_path / "out" / "teapot--function=mean.exr")
    assert header["legend"].startswith("mean (order 2)")


def test_a_failing_scene_is_isolated(scenes, tmp_path):
    (scenes / "broken.toml").write_text('[[surface]]\ntype = "newell"\nfile = "gone.txt"\n')
    result = cli(scenes / "*.toml", "-o", tmp_path / "out", "-j", 2)
    assert result.returncode == 2
    assert "failed: broken" in result.stderr and "gone.txt" in result.stderr
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    status = {j["name"]: j["status"] for j in manifest["jobs"]}
    assert status == {"broken": "failed", "sphere": "rendered", "teapot": "rendered"}
    log = next(j["log"] for j in manifest["jobs"] if j["name"] == "broken")
    assert "gone.txt" in open(log).read()


def test_bad_batch_input(scenes, tmp_path):
    with pytest.raises(GshadeError, match="no such scene file"):
        expand_scenes([str(tmp_path / "nothing.toml")])
    with pytest.raises(GshadeError, match="matches no scene file"):
        expand_scenes([str(tmp_path / "*.nope")])
    (tmp_path / "empty").mkdir()
    with pytest.raises(GshadeError, match="empty: the folder has no scene files"):
        expand_scenes([str(scenes), str(tmp_path / "empty")])
    # files, folders and patterns, in order, each file once
    both = expand_scenes([str(scenes / "teapot.toml"), str(scenes), str(scenes / "*.toml")])
    assert both == [scenes / "teapot.toml", scenes / "sphere.toml"]
    with pytest.raises(GshadeError, match="expected key=value1,value2"):
        parse_sweeps(["shape.function"])
    # a sweep over a key the scenes lack fails their jobs (one line each), not the batch
    result = cli(scenes, "-o", tmp_path / "o", "--sweep", "shape.nothing=1,2")
    assert result.returncode == 2 and "0 rendered, 0 up to date, 4 failed" in result.stdout
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 4 and all('unknown key "nothing"' in line for line in lines)
    blocker = tmp_path / "file"
    blocker.write_text("")
    result = cli(scenes, "-o", blocker / "sub")
    assert result.returncode == 2 and "cannot write to the output folder" in result.stderr


def test_sweep_table_in_the_scene_file(scenes, tmp_path):
    path = scenes / "swept.toml"
    path.write_text(
        'name = "swept"\n[[surface]]\ntype = "sphere"\n'
        + SMALL
        + '[sweep]\n"shape.form" = ["cos", "angle"]\n'
        + "shape.light = [[0, 0, 1], [0, 1, 0]]\n"
    )
    jobs = plan_jobs([path], [])
    assert len(jobs) == 4
    assert jobs[0].name == "swept--form=cos--light=[0,0,1]"
    # the command line adds sweeps and wins over the file's for the same key
    jobs = plan_jobs([path], parse_sweeps(["shape.form=angle"]))
    assert [dict(j.overrides)["shape.form"] for j in jobs] == ["angle", "angle"]
    path.write_text('[[surface]]\ntype = "sphere"\n[sweep]\nfunction = ["mean"]\n')
    from gshade.scene import load_scene

    with pytest.raises(GshadeError, match="expected a dotted scene key"):
        load_scene(path)


def test_dask_cluster_gives_the_same_outputs_as_a_local_run(scenes, tmp_path):
    distributed = pytest.importorskip("distributed")
    import dask

    from gshade.app.worker_pool import DaskPool

    jobs = plan_jobs(expand_scenes([str(scenes)]), [])
    local = run_batch(jobs, tmp_path / "local", workers=1)
    with (
        dask.config.set({"distributed.scheduler.allowed-failures": 0}),
        distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
        ) as cluster,
    ):
        remote = run_batch(jobs, tmp_path / "dask", scheduler=cluster.scheduler_address)
        # a task whose worker dies (KilledWorker) fails alone
        with DaskPool(
            lambda code: os._exit(code) if code else "ok", cluster.scheduler_address
        ) as pool:
            outcomes = sorted((o for o in pool.run([(3,), (0,)]) if o), key=lambda o: o.index)
        assert "the Dask task failed (KilledWorker" in outcomes[0].error
        assert outcomes[1].value == "ok" and not outcomes[1].error
    assert [r.status for r in remote] == [r.status for r in local] == ["rendered"] * 2
    for job in jobs:
        a, _ = read_exr(tmp_path / "local" / f"{job.name}.exr")
        b, _ = read_exr(tmp_path / "dask" / f"{job.name}.exr")
        assert all(np.array_equal(a[c], b[c]) for c in a)


@pytest.mark.slow
def test_unreachable_scheduler_is_one_line(scenes, tmp_path):
    pytest.importorskip("distributed")
    result = cli(scenes, "-o", tmp_path / "o", "--scheduler", "tcp://127.0.0.1:9")
    assert result.returncode == 2
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


#: ``gshade batch`` whose job named "block" never ends by itself: it says it started (the
#: file $BLOCK_STARTED) and waits, so the batch cannot finish before the test's signal on any
#: machine, however fast or busy (the workers are spawned: they import this script as
#: ``__mp_main__`` and take its ``render_job``).
BLOCKING_BATCH = """
import os, sys, time
import gshade.app.batch as batch

_render_job = batch.render_job


def render_job(job, folder):
    if job.name == "block":
        open(os.environ["BLOCK_STARTED"], "w").close()
        while True:
            time.sleep(0.1)
    return _render_job(job, folder)


batch.render_job = render_job

if __name__ == "__main__":
    from gshade.app.cli import console

    sys.argv = ["gshade", "batch", *sys.argv[1:]]
    console()
"""
#: A hang guard only: how long a test waits for what must happen (never met unless stuck).
HANG = 300


def outputs(folder):
    """The finished EXRs in a folder (not the temporaries, whose names start with a dot)."""
    if not folder.exists():
        return []
    return [p for p in folder.glob("*.exr") if not p.name.startswith(".")]


def test_an_interrupted_batch_leaves_no_partial_files(scenes, tmp_path):
    """Ctrl-C while one worker renders and the other holds a job that cannot end: the
    batch stops without a traceback, leaves no temporary, and what it wrote is whole."""
    for k in range(6):
        (scenes / f"more{k}.toml").write_text(
            f'name = "more{k}"\n[[surface]]\ntype = "torus"\n'
            + SMALL.replace("width = 48", "width = 400").replace("height = 36", "height = 300")
        )
    (scenes / "block.toml").write_text('[[surface]]\ntype = "sphere"\n' + SMALL)
    script, started, out = tmp_path / "blocking_batch.py", tmp_path / "started", tmp_path / "out"
    script.write_text(BLOCKING_BATCH)
    process = subprocess.Popen(  # block.toml first: one worker holds it, the other renders
        [sys.executable, str(script), str(scenes), "-o", str(out), "-j", "2"],
        env={**os.environ, "BLOCK_STARTED": str(started)},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + HANG
    while time.monotonic() < deadline and not (started.exists() and outputs(out)):
        time.sleep(0.05)
    assert process.poll() is None, process.communicate()  # it cannot have ended
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=HANG)
    assert process.returncode != 0
    assert "Traceback" not in err
    assert not [p.name for p in out.iterdir() if p.name.startswith(".")]  # no temporaries
    assert outputs(out) and not (out / "block.exr").exists()
    for exr in outputs(out):
        read_exr(exr)  # every output there is whole
    assert manifest_status(out)["block"] == "not run"


# ----------------------------------------------------------------- faults (hostile input)

TINY = '[render]\nwidth = 16\nheight = 12\nspp = 1\nlighting = "flat"\n'
# several seconds at least, on any machine: killed long before it ends
SLOW = '[[surface]]\ntype = "torus"\n[render]\nwidth = 1000\nheight = 1000\nspp = 256\n'


def tiny(folder, name, text='[[surface]]\ntype = "sphere"\n'):
    path = folder / f"{name}.toml"
    path.write_text(text + TINY)
    return path


def temporaries(folder):
    return [p.name for p in folder.iterdir() if ".gshade-tmp" in p.name]


def writer_pid(folder, prefix, timeout=HANG):
    """The id of the process writing a temporary whose name starts with ``prefix``."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        names = temporaries(folder) if folder.exists() else []
        for name in names:
            if name.startswith(prefix):
                return int(re.search(r"\.(\d+)-\w{8}\.gshade-tmp", name).group(1))
        time.sleep(0.005)
    raise AssertionError(f"no temporary {prefix}* in {folder}")


def alive(pid):
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        return state != "Z"
    except OSError:
        return False


def manifest_status(out):
    return {j["name"]: j["status"] for j in json.loads((out / "manifest.json").read_text())["jobs"]}


def test_a_worker_that_dies_fails_only_its_job(tmp_path):
    folder = tmp_path / "s"
    folder.mkdir()
    (folder / "b.toml").write_text(SLOW)
    paths = [tiny(folder, "a"), folder / "b.toml", tiny(folder, "c")]
    out = tmp_path / "out"
    killed = []

    def kill_the_worker_of_b():  # as the OOM killer would, while it writes
        pid = writer_pid(out, ".b.")
        os.kill(pid, signal.SIGKILL)
        killed.append(pid)

    thread = threading.Thread(target=kill_the_worker_of_b, daemon=True)
    thread.start()
    results = run_batch(plan_jobs(paths, []), out, workers=1)  # -j 1 runs a worker too
    thread.join()
    assert killed and [r.status for r in results] == ["rendered", "failed", "rendered"]
    assert "the worker process died (killed by signal 9, SIGKILL" in results[1].message
    assert "signal 9" in Path(results[1].log).read_text()
    assert results[1].log == str(out / "logs" / "b.log")
    assert not temporaries(out) and not (out / "b.exr").exists()
    assert manifest_status(out) == {"a": "rendered", "b": "failed", "c": "rendered"}


def test_a_job_over_the_time_limit_fails_alone(tmp_path):
    folder = tmp_path / "s"
    folder.mkdir()
    (folder / "b.toml").write_text(SLOW)
    jobs = plan_jobs([folder / "b.toml", tiny(folder, "a")], [])
    start = time.monotonic()
    results = run_batch(jobs, tmp_path / "out", timeout=2)
    assert time.monotonic() - start < HANG  # SLOW was stopped (its result says so), not run
    assert [r.status for r in results] == ["failed", "rendered"]
    assert results[0].message == "exceeded the time limit of 2 s"
    assert "time limit" in Path(results[0].log).read_text()
    assert not temporaries(tmp_path / "out")
    # bad options are refused before the output folder is made
    for options in ({"timeout": 0}, {"timeout": float("nan")}, {"workers": 0}):
        with pytest.raises(GshadeError, match="expected"):
            run_batch(jobs, tmp_path / "never", **options)
    assert not (tmp_path / "never").exists()
    result = cli(tmp_path / "s", "-o", tmp_path / "never", "-j", 0)
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert "-j: expected at least 1 worker, got 0" in result.stderr
    assert not (tmp_path / "never").exists()


def test_scenes_that_break_python_fail_alone(tmp_path):
    folder = tmp_path / "s"
    (folder / "other").mkdir(parents=True)
    good = tiny(
        folder, "good", '[sweep]\n"surface.1.radius" = [1, 2]\n[[surface]]\ntype = "sphere"\n'
    )
    torus = tiny(
        folder, "torus", '[sweep]\n"surface.1.radius" = [1]\n[[surface]]\ntype = "torus"\n'
    )
    bigint = folder / "bigint.toml"
    bigint.write_text('[[surface]]\ntype = "sphere"\nradius = 1' + "0" * 400 + "\n")
    digits = folder / "digits.toml"
    digits.write_text('[[surface]]\ntype = "sphere"\n[check]\nwidth = 1' + "0" * 5000 + "\n")
    deep = folder / "deep.toml"
    deep.write_text('[[surface]]\ntype = "sphere"\n[check]\nchannels = ' + "[" * 3000 + "]" * 3000)
    longname = tiny(folder, "long", f'name = "{"n" * 190}"\n[[surface]]\ntype = "sphere"\n')
    dup = tiny(folder, "dup")
    dup2 = tiny(folder / "other", "dup")
    scenes = [good, torus, bigint, digits, deep, longname, dup, dup2]
    jobs = plan_jobs(scenes, parse_sweeps(["shape.function=isophotes"]))  # never raises
    errors = {j.name: j.error for j in jobs}
    assert [j.name for j in jobs][:2] == [
        "good--radius=1--function=isophotes",
        "good--radius=2--function=isophotes",
    ]
    assert not any(errors[j.name] for j in jobs[:2])
    assert 'unknown key "radius"' in errors["torus--radius=1--function=isophotes"]
    for path in (bigint, digits, deep):
        assert errors[path.stem].startswith(str(path))
    assert "at most 200 bytes" in errors["n" * 190 + "--function=isophotes"]
    assert jobs[-1].error.startswith(str(dup2)) and "dup--function=isophotes" in jobs[-1].error
    results = run_batch(jobs, tmp_path / "out", workers=2)
    status = [r.status for r in results]
    assert status == ["rendered"] * 2 + ["failed"] * 5 + ["rendered", "failed"]
    logs = [r.log for r in results if r.status == "failed"]
    assert len(set(logs)) == 6 and all(Path(log).is_file() for log in logs)
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert [j["status"] for j in manifest["jobs"]] == status


def test_any_exception_of_the_scene_reader_fails_that_scene_alone(tmp_path, monkeypatch):
    import gshade.scene

    read = gshade.scene.load_scene

    def load_scene(path, overrides=None):  # as a reader's bug would, on one file
        if Path(path).stem == "a":
            raise RecursionError("maximum recursion depth exceeded")
        return read(path, overrides)

    monkeypatch.setattr(gshade.scene, "load_scene", load_scene)
    a, b = tiny(tmp_path, "a"), tiny(tmp_path, "b")
    jobs = plan_jobs([a, b], [])
    assert jobs[0].error == f"{a}: RecursionError: maximum recursion depth exceeded"
    assert not jobs[1].error
    result = job_status(jobs[0], str(tmp_path / "out"), force=False)
    assert result.status == "failed" and result.message == jobs[0].error
    assert "Traceback" in Path(result.log).read_text()
    assert job_status(jobs[1], str(tmp_path / "out"), force=False).status == "todo"


def test_sigterm_stops_the_workers_and_the_manifest_shows_progress(scenes, tmp_path):
    folder = tmp_path / "s"
    folder.mkdir()
    tiny(folder, "a")
    (folder / "z.toml").write_text(SLOW)
    out = tmp_path / "out"
    process = start_batch(folder, out)
    worker = writer_pid(out, ".z.")
    deadline = time.monotonic() + HANG  # the manifest says "a" is done while "z" renders
    while time.monotonic() < deadline and manifest_status(out).get("a") != "rendered":
        time.sleep(0.01)
    assert manifest_status(out) == {"a": "rendered", "z": "not run"}
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=HANG)
    assert process.returncode == 143 and "Traceback" not in err
    assert not alive(worker) and not temporaries(out)
    assert manifest_status(out) == {"a": "rendered", "z": "not run"}


def test_an_interrupted_batch_records_the_outputs_it_finds_complete(scenes, tmp_path, monkeypatch):
    import gshade.app.batch

    jobs = plan_jobs(expand_scenes([str(scenes)]), [])

    def render_one_then_interrupt(state, todo, pool):  # Ctrl-C before its result is seen
        result = gshade.app.batch.render_job(state.jobs[todo[0]], str(state.out))
        assert result.status == "rendered", result.message
        raise KeyboardInterrupt

    monkeypatch.setattr(gshade.app.batch, "_collect", render_one_then_interrupt)
    with pytest.raises(KeyboardInterrupt):
        run_batch(jobs, tmp_path / "out")
    assert manifest_status(tmp_path / "out") == {"sphere": "rendered", "teapot": "not run"}


def test_a_corrupted_png_is_rendered_again(tmp_path):
    import hashlib

    from gshade.io.image import read_exr_header

    jobs = plan_jobs([tiny(tmp_path, "a")], [])
    out = tmp_path / "out"
    assert run_batch(jobs, out)[0].status == "rendered"
    png = (out / "a.png").read_bytes()
    assert read_exr_header(out / "a.exr")["batch_png"] == hashlib.sha256(png).hexdigest()
    assert run_batch(jobs, out)[0].status == "up to date"
    (out / "a.png").write_bytes(png[:-10] + b"garbage")
    assert run_batch(jobs, out)[0].status == "rendered"
    assert (out / "a.png").read_bytes() == png


def test_a_rerun_removes_what_a_killed_run_left(tmp_path):
    dead = int(subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                              capture_output=True, text=True).stdout)  # fmt: skip
    out = tmp_path / "out"
    out.mkdir()
    stale = out / f".a.exr.{HOST}.{dead}-abcd1234.gshade-tmp.exr"
    stale.write_bytes(b"half")
    run_batch([], out)
    assert not stale.exists()


def test_workers_die_with_their_parent_and_remove_their_temporaries(tmp_path):
    script = tmp_path / "parent.py"
    script.write_text(
        "import sys, time\n"
        "from gshade.io.outputs import staged\n"
        "from gshade.app.worker_pool import WorkerPool\n"
        "def hold(path):\n"
        "    with staged([path]):\n"
        "        time.sleep(60)\n"
        "if __name__ == '__main__':\n"
        "    pool = WorkerPool(hold, 1)\n"
        "    for _ in pool.run([(sys.argv[1],)], tick=0.1):\n"
        "        if pool._workers[0].task is not None:  # sent: print the pid, then wait\n"
        "            print(pool._workers[0].process.pid, flush=True)\n"
        "            time.sleep(60)\n"
    )
    target = tmp_path / "x.exr"
    parent = subprocess.Popen(
        [sys.executable, str(script), str(target)], stdout=subprocess.PIPE, text=True
    )
    worker = int(parent.stdout.readline())
    writer_pid(tmp_path, ".x.exr")
    parent.kill()  # SIGKILL: no cleanup in the parent
    parent.wait()
    deadline = time.monotonic() + HANG
    while time.monotonic() < deadline and alive(worker):
        time.sleep(0.01)
    assert not alive(worker) and not temporaries(tmp_path)


def test_scheduler_addresses_are_checked(scenes, tmp_path):
    for address, message in (
        ("", "got an empty one"),
        ("  ", "got an empty one"),
        ("ucx://host:1", "expected a tcp:// or tls:// address"),
        ("tcp://", "expected a tcp:// or tls:// address"),
    ):
        with pytest.raises(GshadeError, match=message):
            validate_batch_options(1, 60, address)
    result = cli(scenes, "-o", tmp_path / "o", "--scheduler", "")
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert not (tmp_path / "o").exists()
    pytest.importorskip("distributed")
    from gshade.app.worker_pool import dask_client

    with pytest.raises(GshadeError, match=r"Dask's configuration for TLS.*tls\.ca-file"):
        dask_client("tls://127.0.0.1:9")
