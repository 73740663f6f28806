"""`gshade check` against a geometric reference (``[check] reference_model``, ``deviation``):
the sphere of radius 2 against the sphere of radius 2.003 (|d| = 0.003 at every pixel),
passing and failing on geometry, in the line, the JUnit XML and the report; a reference model
that is missing or does not load; the keys' bounds at load time."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from gshade import GshadeError
from gshade.app.cli import main
from gshade.regression.check import check
from gshade.scene import load_scene

SPHERE = (
    'name = "{name}"\n[[surface]]\ntype = "sphere"\nradius = {radius}\n'
    '[camera]\ntype = "perspective"\norigin = [2, -4, 2.5]\ntarget = {target}\nup = [0, 0, 1]\n'
    "[check]\nwidth = 48\nheight = 36\nspp = 1\n"
)
#: A number as the line and the report write it.
NUMBER = r"([-+0-9.e]+)"


def sphere(folder: Path, name: str, radius: float, check_keys: str = "", target="[0, 0, 0]"):
    path = folder / f"{name}.toml"
    path.write_text(SPHERE.format(name=name, radius=radius, target=target) + check_keys)
    return path


@pytest.fixture
def spheres(tmp_path, monkeypatch):
    """The folder, with b.toml the sphere of radius 2.003 (the reference model)."""
    monkeypatch.chdir(tmp_path)
    sphere(tmp_path, "b", 2.003)
    return tmp_path


def test_within_the_deviation_the_geometry_passes(spheres):
    a = sphere(spheres, "a", 2.0, 'reference_model = "b.toml"\ndeviation = 0.01\n')
    (new,) = check([a], spheres / "refs", update=True)
    assert new.status == "NEW" and new.ok and new.geometry == "PASS"
    (result,) = check([a], spheres / "refs")
    assert result.status == "PASS" and result.ok and result.geometry == "PASS"
    assert result.reference_model == spheres / "b.toml"
    assert abs(result.deviation["max_abs"] - 0.003) < 1e-9
    assert 0 < result.deviation["count"] <= 48 * 36 and result.deviation["within"] == 1.0
    assert "; geometry PASS: max |d| 0.003 ≤ 0.01" in result.line()


def test_beyond_the_deviation_fails_with_its_numbers_in_the_line_junit_and_report(spheres, capsys):
    from junitparser import Failure, JUnitXml, Properties

    sphere(spheres, "a", 2.0, 'reference_model = "b.toml"\ndeviation = 0.001\n')
    args = ["check", "a.toml", "--references", "refs"]
    # the pixels' reference is written, and the check fails all the same: on geometry
    assert main([*args, "--update"]) == 2
    assert "0 passed, 1 failed (1 references written)" in capsys.readouterr().out
    assert main([*args, "--report", "rep", "--junit", "check.xml"]) == 2
    line = capsys.readouterr().out.splitlines()[0]
    assert line.startswith("FAILURE ") and " a: PASS: " in line  # the pixels pass
    found = re.search(rf"geometry FAILURE: max \|d\| {NUMBER} > 0\.001 at \(", line)
    assert found and abs(float(found[1]) - 0.003) < 1e-9, line

    (suite,) = list(JUnitXml.fromfile("check.xml"))
    assert (suite.tests, suite.failures, suite.errors) == (1, 1, 0)
    (case,) = list(suite)
    (failure,) = case.result
    assert isinstance(failure, Failure)
    found = re.search(rf"max \|d\| {NUMBER} > 0\.001", failure.message)
    assert found and abs(float(found[1]) - 0.003) < 1e-9, failure.message
    numbers = {p.name: p.value for p in case.child(Properties)}
    assert numbers["geometry"] == "FAILURE" and numbers["reference_model"] == "b.toml"
    assert abs(float(numbers["deviation.max_abs"]) - 0.003) < 1e-9
    assert float(numbers["deviation.tolerance"]) == 0.001
    assert float(numbers["deviation.within"]) == 0.0
    assert len(numbers["deviation.point"].split()) == 3

    page = Path("rep/report.html").read_text(encoding="utf-8")
    found = re.search(rf"<th>max \|d\|</th><td>{NUMBER} at \(", page)
    assert found and abs(float(found[1]) - 0.003) < 1e-9
    assert re.search(r'<img src="data:image/png;base64,[^"]+" alt="deviation from b ', page)
    summary = json.loads(Path("rep/summary.json").read_text())
    (entry,) = summary["scenes"]
    assert entry["geometry"] == "FAILURE" and abs(entry["deviation"]["max_abs"] - 0.003) < 1e-9


def test_the_default_deviation_is_a_millionth_of_the_diagonal(spheres):
    """The scene against itself passes within 1e-6 of its diagonal; against b it does not."""
    from gshade.analysis.scene_junctions import scene_diagonal

    itself = sphere(spheres, "a", 2.0, 'reference_model = "a.toml"\n')
    other = sphere(spheres, "c", 2.0, 'reference_model = "b.toml"\n')
    same, off = check([itself, other], spheres / "refs", update=True)
    tolerance = 1e-6 * scene_diagonal(load_scene(itself))
    assert same.deviation["tolerance"] == pytest.approx(tolerance, rel=1e-12)
    assert (same.status, same.geometry, same.ok) == ("NEW", "PASS", True)
    assert same.deviation["max_abs"] < 1e-12
    assert (off.status, off.geometry, off.ok) == ("FAILURE", "FAILURE", False)


def test_nothing_in_view_is_incomparable(spheres):
    away = sphere(spheres, "a", 2.0, 'reference_model = "b.toml"\n', target="[4, -8, 5]")
    (result,) = check([away], spheres / "refs", update=True)
    assert (result.status, result.geometry, result.ok) == ("FAILURE", "FAILURE", False)
    assert result.deviation["count"] == 0
    assert "geometry FAILURE: incomparable: no point of a in view" in result.message


def test_a_missing_reference_model_is_one_line_naming_the_key(spheres, capsys):
    sphere(spheres, "a", 2.0, 'reference_model = "parts/nowhere.step"\ndeviation = 0.01\n')
    with pytest.raises(GshadeError) as raised:
        load_scene("a.toml")
    message = str(raised.value)
    assert "\n" not in message and "[check] reference_model: " in message
    assert "nowhere.step" in message
    assert main(["check", "a.toml", "--references", "refs", "--update"]) == 2
    out, err = capsys.readouterr()
    line = out.splitlines()[0]
    assert line.startswith("ERROR") and "[check] reference_model: " in line
    assert "nowhere.step" in line and "Traceback" not in out + err


def test_an_unreadable_reference_model_is_one_line_naming_the_key_and_file(spheres):
    (spheres / "broken.toml").write_text('[[surface]]\ntype = "sphere"\nradius = -1\n')
    a = sphere(spheres, "a", 2.0, 'reference_model = "broken.toml"\n')
    (result,) = check([a], spheres / "refs", update=True)
    assert (result.status, result.geometry, result.ok) == ("ERROR", "ERROR", False)
    assert "\n" not in result.message and not result.log  # a GshadeError: no traceback
    where = r"geometry ERROR: \[check\] reference_model: \S*broken\.toml: \[\[surface\]\] 1 "
    assert re.search(where, result.message), result.message


@pytest.mark.parametrize(
    ("keys", "error"),
    [
        (
            'deviation = -1\nreference_model = "b.toml"\n',
            r"a\.toml: \[check\] deviation: expected a number >= 0, got -1$",
        ),
        ("deviation = 0.1\n", r"\[check\] deviation: expected together with reference_model"),
        ("reference_model = 3\n", r"\[check\] reference_model: expected a path to a scene file"),
        (
            'reference_model = "../b.toml"\n',
            r"\[check\] reference_model: expected a file within the scene's folder",
        ),
    ],
)
def test_the_keys_are_checked_at_load(spheres, keys, error):
    (spheres / "sub").mkdir()
    sphere(spheres / "sub", "a", 2.0, keys)
    with pytest.raises(GshadeError, match=error):
        load_scene("sub/a.toml")


def test_a_point_cloud_as_the_reference_model(spheres):
    """``reference_model`` may be a point cloud (or a mesh): 100,000 points of the sphere
    of radius 2.003 in an XYZ file; each pixel's nearest point at least 0.003 away."""
    import numpy as np

    points = np.random.default_rng(2).normal(size=(100_000, 3))
    points *= 2.003 / np.linalg.norm(points, axis=1, keepdims=True)
    np.savetxt(spheres / "cloud.xyz", points, fmt="%.17g")
    a = sphere(spheres, "a", 2.0, 'reference_model = "cloud.xyz"\ndeviation = 0.05\n')
    (result,) = check([a], spheres / "refs", update=True)
    assert result.geometry == "PASS" and result.deviation["b"] == "cloud"
    assert 0.003 - 1e-12 <= result.deviation["max_abs"] < 0.05
