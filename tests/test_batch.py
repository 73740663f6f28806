"""`gshade batch`: scenes and sweeps into a folder, workers, up-to-date skipping, failures."""

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

from gshade import GshadeError
from gshade.batch import expand_scenes, parse_sweeps, plan_jobs, run_batch
from gshade.io.image import read_exr

from .conftest import TEAPOT

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


def cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "gshade.cli", "batch", *map(str, args)],
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
    with pytest.raises(GshadeError, match="expected key=value1,value2"):
        parse_sweeps(["shape.function"])
    result = cli(scenes, "-o", tmp_path / "o", "--sweep", "shape.nothing=1,2")
    assert result.returncode == 2 and 'unknown key "nothing"' in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
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
    from gshade.io import load_scene

    with pytest.raises(GshadeError, match="expected a dotted scene key"):
        load_scene(path)


def test_dask_cluster_gives_the_same_outputs_as_a_local_run(scenes, tmp_path):
    distributed = pytest.importorskip("distributed")
    jobs = plan_jobs(expand_scenes([str(scenes)]), [])
    local = run_batch(jobs, tmp_path / "local", workers=1)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
    ) as cluster:
        remote = run_batch(jobs, tmp_path / "dask", scheduler=cluster.scheduler_address)
    assert [r.status for r in remote] == [r.status for r in local] == ["rendered"] * 2
    for job in jobs:
        a, _ = read_exr(tmp_path / "local" / f"{job.name}.exr")
        b, _ = read_exr(tmp_path / "dask" / f"{job.name}.exr")
        assert all(np.array_equal(a[c], b[c]) for c in a)


def test_unreachable_scheduler_is_one_line(scenes, tmp_path):
    pytest.importorskip("distributed")
    result = cli(scenes, "-o", tmp_path / "o", "--scheduler", "tcp://127.0.0.1:9")
    assert result.returncode == 2
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_an_interrupted_batch_leaves_no_partial_files(scenes, tmp_path):
    import signal
    import time

    for k in range(6):
        (scenes / f"more{k}.toml").write_text(
            f'name = "more{k}"\n[[surface]]\ntype = "torus"\n'
            + SMALL.replace("width = 48", "width = 400").replace("height = 36", "height = 300")
        )
    out = tmp_path / "out"
    process = subprocess.Popen(
        [sys.executable, "-m", "gshade.cli", "batch", str(scenes), "-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.time() + 60
    while time.time() < deadline and not list(out.glob("*.exr")):
        time.sleep(0.05)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode != 0
    assert "Traceback" not in err
    assert not [p.name for p in out.iterdir() if p.name.startswith(".")]  # no temporaries
    for exr in out.glob("*.exr"):
        read_exr(exr)  # every output there is whole
