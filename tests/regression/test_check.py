"""`gshade check`: references, verdicts, updates, broken scenes, reports, regression power."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gshade import GshadeError
from gshade.geometry import sphere
from gshade.regression.check import check, find_scenes

from ..support.paths import ROOT, TEAPOT

CHECK = "\n[check]\nwidth = 64\nheight = 48\nspp = 2\n"
#: The teapot's view: its body's first patch (vertex 1 on the rim) in sight, whatever the
#: automatic framing does, at a size where a change of 1 % of a control point covers many
#: pixels, not one or two
TEAPOT_VIEW = (
    "[camera]\norigin = [7, -5, 5]\ntarget = [0, 0, 1.2]\nup = [0, 0, 1]\n"
    "\n[check]\nwidth = 128\nheight = 96\nspp = 2\n"
)


def teapot_scene(folder: Path, name="teapot", light="[0.3, -0.5, 0.8]", data="teapot.txt"):
    text = (
        f'name = "{name}"\n[[surface]]\ntype = "newell"\nfile = "{data}"\n[shape]\n'
        f'function = "isophotes"\nlight = {light}\nperiod = 0.1\n'
        '[render]\nlighting = "flat"\n' + TEAPOT_VIEW
    )
    path = folder / f"{name}.toml"
    path.write_text(text)
    return path


def nurbs_sphere_scene(folder: Path, weight_scale=1.0):
    s = sphere(1.0)
    w = s.weights.copy()
    w[2, 7] *= weight_scale  # at the equator, facing the camera

    def fmt(a):
        return json.dumps(np.asarray(a).tolist())

    text = (
        f'name = "nurbs-sphere"\n[[surface]]\ntype = "bspline"\ndegree = [2, 2]\n'
        f"knots_u = {fmt(s.knots[0])}\nknots_v = {fmt(s.knots[1])}\n"
        f"points = {fmt(s.points)}\nweights = {fmt(w)}\n"
        '[shape]\nfunction = "isophotes"\nlight = [0, -1, 0]\nperiod = 0.1\n'
        '[camera]\ntype = "orthographic"\norigin = [0, -5, 0]\ntarget = [0, 0, 0]\n'
        'up = [0, 0, 1]\nwidth = 2.4\n[render]\nlighting = "flat"\n' + CHECK
    )
    path = folder / "nurbs-sphere.toml"
    path.write_text(text)
    return path


@pytest.fixture
def workspace(tmp_path):
    shutil.copy(TEAPOT, tmp_path / "teapot.txt")
    refs = tmp_path / "references"
    scenes = [teapot_scene(tmp_path), nurbs_sphere_scene(tmp_path)]
    results = check(scenes, refs, update=True)
    assert [r.status for r in results] == ["NEW", "NEW"]
    return tmp_path, refs, scenes


def statuses(results):
    return {r.name: r.status for r in results}


def test_rerenders_pass_and_nothing_is_rewritten(workspace):
    _, refs, scenes = workspace
    before = {p.name: p.stat().st_mtime_ns for p in refs.iterdir()}
    results = check(scenes, refs)
    assert statuses(results) == {"teapot": "PASS", "nurbs-sphere": "PASS"}
    assert {p.name: p.stat().st_mtime_ns for p in refs.iterdir()} == before


def test_a_control_point_moved_by_one_percent_fails(workspace):
    folder, refs, _ = workspace
    lines = (folder / "teapot.txt").read_text().splitlines()
    # vertex 1 belongs to the body's first patch (size about 3): move it by 0.03 in x
    x, y, z = (float(t) for t in lines[34].split(","))
    lines[34] = f"{x + 0.03},{y},{z}"
    (folder / "moved.txt").write_text("\n".join(lines) + "\n")
    scene = teapot_scene(folder, data="moved.txt")
    assert statuses(check([scene], refs)) == {"teapot": "FAILURE"}


def test_a_changed_weight_and_a_light_turned_by_two_degrees_fail(workspace):
    folder, refs, _ = workspace
    scene = nurbs_sphere_scene(folder, weight_scale=1.02)
    assert statuses(check([scene], refs)) == {"nurbs-sphere": "FAILURE"}
    a = np.radians(2.0)
    light = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    turned = np.array(
        [
            light[0] * np.cos(a) - light[1] * np.sin(a),
            light[0] * np.sin(a) + light[1] * np.cos(a),
            light[2],
        ]
    )
    scene = teapot_scene(folder, light=json.dumps([float(x) for x in turned]))
    assert statuses(check([scene], refs)) == {"teapot": "FAILURE"}


def test_update_rewrites_only_new_and_failing_references(workspace):
    folder, refs, scenes = workspace
    sphere_ref = refs / "nurbs-sphere.exr"
    teapot_ref = refs / "teapot.exr"
    t0 = teapot_ref.stat().st_mtime_ns
    s0 = sphere_ref.stat().st_mtime_ns
    changed = nurbs_sphere_scene(folder, weight_scale=1.05)
    results = check([scenes[0], changed], refs, update=True)
    assert [(r.status, r.written) for r in results] == [("PASS", ""), ("FAILURE", "updated")]
    assert teapot_ref.stat().st_mtime_ns == t0 and sphere_ref.stat().st_mtime_ns != s0
    assert statuses(check([changed], refs)) == {"nurbs-sphere": "PASS"}
    results = check(scenes[:1], refs, update_all=True)
    assert results[0].written == "updated"


def test_missing_reference_broken_scene_and_report(workspace):
    folder, refs, scenes = workspace
    new = teapot_scene(folder, name="<new> & co")
    broken = folder / "broken.toml"
    broken.write_text('[[surface]]\ntype = "newell"\nfile = "nothing.txt"\n')
    results = check([broken, new, scenes[0]], refs)
    st = {r.name: (r.status, r.message) for r in results}
    assert st["broken"][0] == "ERROR" and "nothing.txt" in st["broken"][1]
    # the library names its parameter; the command line (below) says --update
    assert st["<new> & co"][0] == "FAILURE" and "with update=True" in st["<new> & co"][1]
    assert st["teapot"][0] == "PASS"  # the others went on
    assert not (refs / "<new> & co.exr").exists()
    from gshade.regression.report import write_report

    report = write_report(results, folder / "report")
    page = report.read_text()
    assert "&lt;new&gt; &amp; co" in page and "<new>" not in page
    assert page.index("broken") < page.index("teapot")  # failures first
    assert page.count("data:image/png;base64,") >= 3
    summary = json.loads((folder / "report" / "summary.json").read_text())
    assert summary["counts"]["ERROR"] == 1 and summary["counts"]["PASS"] == 1


def test_the_report_has_an_inspectable_view_of_every_rendered_scene(workspace):
    """Each rendered scene gets views/NAME.html (new and reference: the values under the
    cursor, flip, difference); a failure's view is framed in the report itself."""
    from gshade.regression.report import write_report

    folder, refs, scenes = workspace
    changed = nurbs_sphere_scene(folder, weight_scale=1.05)
    results = check([scenes[0], changed], refs)
    assert statuses(results) == {"teapot": "PASS", "nurbs-sphere": "FAILURE"}
    report = write_report(results, folder / "report")
    page = report.read_text()
    summary = json.loads((folder / "report" / "summary.json").read_text())
    views = {s["name"]: s["view"] for s in summary["scenes"]}
    assert views == {"nurbs-sphere": "views/nurbs-sphere.html", "teapot": "views/teapot.html"}
    for view in views.values():
        html_text = (folder / "report" / view).read_text()
        assert f'href="{view}"' in page
        # both images are in the page, labelled, and nothing is loaded from elsewhere
        assert '"new"' in html_text and '"reference"' in html_text
        assert "http://" not in html_text and "https://" not in html_text
    assert page.count("<iframe") == 1 and 'iframe src="views/nurbs-sphere.html"' in page


def test_find_scenes_takes_files_and_folders_as_named(tmp_path):
    """Folders give their *.toml by name; an empty one is fine unless nothing is found at
    all; no glob patterns (gshade batch has them); a file named twice is checked twice."""
    folder, empty = tmp_path / "scenes", tmp_path / "empty"
    folder.mkdir()
    empty.mkdir()
    for name in ("b.toml", "a.toml", "notes.txt"):
        (folder / name).write_text("")
    found = find_scenes([str(folder), str(empty), str(folder / "b.toml")])
    assert found == [folder / "a.toml", folder / "b.toml", folder / "b.toml"]
    with pytest.raises(GshadeError, match="empty: no scene files"):
        find_scenes([str(empty)])
    with pytest.raises(GshadeError, match=r"\*.toml: no such scene file or folder"):
        find_scenes([str(folder / "*.toml")])


def test_cli_exit_status_and_missing_reference_folder(tmp_path):
    shutil.copy(TEAPOT, tmp_path / "teapot.txt")
    scene = teapot_scene(tmp_path)

    def run(*args):
        return subprocess.run(
            [sys.executable, "-m", "gshade", "check", *map(str, args)],
            capture_output=True,
            text=True,
        )

    result = run(scene, "--references", tmp_path / "nope")
    assert result.returncode == 2 and "reference folder does not exist" in result.stderr
    assert "(use --update to create it" in result.stderr
    (tmp_path / "empty").mkdir()
    result = run(scene, "--references", tmp_path / "empty")
    assert result.returncode == 2 and "; run with --update to create it" in result.stdout
    assert run(scene, "--references", tmp_path / "refs", "--update").returncode == 0
    result = run(scene, "--references", tmp_path / "refs")
    assert result.returncode == 0 and "1 passed, 0 failed" in result.stdout


@pytest.mark.slow
def test_the_project_scenes_match_their_references():
    results = check(find_scenes([str(ROOT / "scenes")]), ROOT / "references")
    bad = [r.line() for r in results if r.status not in ("PASS", "WARNING")]
    assert not bad, "\n".join(bad)
    total = sum(p.stat().st_size for p in (ROOT / "references").glob("*.exr"))
    assert total <= 20 * 2**20


def test_statistical_check_separates_sampling_noise_from_a_change(tmp_path):
    """Lit renders with other random numbers differ by noise that thresholds flag; the
    z-test against the reference's variances passes them and still fails a 2° light turn."""
    shutil.copy(TEAPOT, tmp_path / "teapot.txt")

    def scene(seed, light="[0.3, -0.5, 0.8]"):
        path = tmp_path / "lit.toml"
        path.write_text(
            f'name = "lit"\n[[surface]]\ntype = "newell"\nfile = "teapot.txt"\n[shape]\n'
            f'function = "isophotes"\nlight = {light}\nperiod = 0.1\n[render]\n'
            f'lighting = "soft"\nseed = {seed}\n[check]\nwidth = 64\nheight = 48\nspp = 4\n'
            "runs = 6\n"
        )
        return path

    refs = tmp_path / "refs"
    assert check([scene(0)], refs, update=True, statistical=True)[0].status == "NEW"
    other_seeds = scene(1000)
    assert statuses(check([other_seeds], refs, statistical=True)) == {"lit": "PASS"}
    assert statuses(check([other_seeds], refs)) == {"lit": "FAILURE"}  # thresholds: noise
    turned = scene(1000, light="[0.3283, -0.4817, 0.8]")  # 1.95 degrees
    assert statuses(check([turned], refs, statistical=True)) == {"lit": "FAILURE"}
