"""gshade's pytest plugin (the gshade_check fixture, --gshade-update, --gshade-report), run
with pytester on the documentation's example (docs/how_to/ci.rst, "The pytest plugin"), and
`gshade check --junit` read back by junitparser."""

from __future__ import annotations

import importlib.metadata
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from gshade.app.cli import main

from ..support.docs_pages import code_block
from ..support.paths import ROOT

pytestmark = pytest.mark.slow  # whole pytest sessions (pytester)

pytest_plugins = ["pytester"]

#: The page that shows the example, and the markers (reST comments there) around it.
DOCS_PAGE = ROOT / "docs" / "how_to" / "ci.rst"
MARKERS = ("<!-- pytest-example -->", "<!-- /pytest-example -->")
DIRECTIVE = ".. code-block:: python\n"
#: A scene that does not load.
BROKEN = "[[surface]]\ntype = 'sphere'\nradius = -1\n"


def docs_example() -> str:
    """The example as the docs page shows it: the ``.. code-block:: python`` between the
    markers, unindented."""
    text = DOCS_PAGE.read_text(encoding="utf-8")
    page = DOCS_PAGE.relative_to(ROOT)
    assert MARKERS[0] in text and MARKERS[1] in text, f"{page}: the pytest example is gone"
    block = text.split(MARKERS[0], 1)[1].split(MARKERS[1], 1)[0]
    assert DIRECTIVE in block, f"{page}: the pytest example's markers hold no python block"
    code = code_block(block, DIRECTIVE, str(page))
    assert "def test_" in code, f"{page}: the pytest example holds no test"
    return code


def sphere_scene(period: float = 0.1, check: str = "", name: str = "sphere") -> str:
    """A small scene: an exact sphere's isophotes at a check size of 32 x 24, one sample."""
    return (
        f'name = "{name}"\n[[surface]]\ntype = "sphere"\nradius = 1\n[shape]\n'
        f'function = "isophotes"\nlight = [0, -1, 0]\nperiod = {period}\n'
        '[render]\nlighting = "flat"\n[check]\nwidth = 32\nheight = 24\nspp = 1\n' + check
    )


@pytest.fixture
def project(pytester):
    """A project with the documentation's example test and its scene, no references yet."""
    (pytester.path / "scenes").mkdir()
    (pytester.path / "scenes" / "sphere.toml").write_text(sphere_scene())
    pytester.makepyfile(test_shape=docs_example())
    return pytester


def test_the_plugin_is_installed_and_cheap_to_import():
    plugins = importlib.metadata.entry_points(group="pytest11")
    assert any(e.name == "gshade" and e.value == "gshade.app.pytest_plugin" for e in plugins)
    code = (
        "import sys, gshade.app.pytest_plugin; "
        "print(sorted(m for m in ('numpy', 'mitsuba', 'drjit') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_tests_without_the_fixture_see_nothing_of_it(pytester):
    pytester.makepyfile("def test_plain():\n    assert True\n")
    result = pytester.runpytest_subprocess()
    result.assert_outcomes(passed=1)
    assert "= gshade =" not in result.stdout.str()
    assert not (pytester.path / "references").exists()


def test_a_missing_reference_fails_and_says_how_to_create_it(project):
    result = project.runpytest_subprocess()
    result.assert_outcomes(failed=2)
    result.stdout.fnmatch_lines(
        [
            "gshade check sphere: no reference */references/sphere.exr; "
            "run pytest with --gshade-update to create it",
            "gshade check sphere-mean: no reference */references/sphere-mean.exr; *",
        ]
    )
    assert "Traceback" not in result.stdout.str()
    assert not (project.path / "references").exists()


def test_gshade_update_writes_the_references_and_the_tests_pass(project):
    result = project.runpytest_subprocess("--gshade-update")
    result.assert_outcomes(passed=2)
    result.stdout.fnmatch_lines(
        [
            "*= gshade =*",
            "created reference */references/sphere.exr (scenes/sphere.toml)",
            "created reference */references/sphere-mean.exr (scenes/sphere.toml)",
        ]
    )
    refs = project.path / "references"
    before = {p.name: p.stat().st_mtime_ns for p in refs.iterdir()}
    assert set(before) == {"sphere.exr", "sphere-mean.exr"}
    result = project.runpytest_subprocess()  # the references match; nothing is rewritten
    result.assert_outcomes(passed=2)
    assert "= gshade =" not in result.stdout.str()
    assert {p.name: p.stat().st_mtime_ns for p in refs.iterdir()} == before


def test_a_changed_scene_fails_with_its_verdict_metrics_and_pictures(project):
    project.runpytest_subprocess("--gshade-update").assert_outcomes(passed=2)
    (project.path / "scenes" / "sphere.toml").write_text(sphere_scene(period=0.13))
    result = project.runpytest_subprocess("-p", "no:cacheprovider")
    result.assert_outcomes(failed=1, passed=1)
    result.stdout.fnmatch_lines(
        [
            "gshade check sphere: FAILURE: *% of 768 pixels over 0.02 (warn *% over 0.001); "
            "max error * at (*, *) in *, mean *, RMSE *, PSNR * dB *",
            "scene: scenes/sphere.toml",
            "reference: */references/sphere.exr",
            "new render: */sphere.exr",
            "difference: */sphere.diff.png",
            "to accept the new render as the reference: pytest --gshade-update",
        ]
    )
    saved = re.search(r"^difference: (.*)$", result.stdout.str(), re.M)
    assert saved and Path(saved.group(1)).stat().st_size > 0
    # Blender's rule: the failing reference is rewritten, the passing one is not
    refs = project.path / "references"
    mean = refs / "sphere-mean.exr"
    kept = mean.stat().st_mtime_ns
    result = project.runpytest_subprocess("--gshade-update")
    result.assert_outcomes(passed=2)
    result.stdout.fnmatch_lines(["updated reference */references/sphere.exr (scenes/sphere.toml)"])
    assert mean.stat().st_mtime_ns == kept
    project.runpytest_subprocess().assert_outcomes(passed=2)


def test_the_scenes_own_thresholds_apply(project):
    project.runpytest_subprocess("--gshade-update").assert_outcomes(passed=2)
    lenient = sphere_scene(period=0.13, check="fail = 1.0\n")  # its differences are < 0.9
    (project.path / "scenes" / "sphere.toml").write_text(lenient)
    result = project.runpytest_subprocess()
    result.assert_outcomes(passed=2)  # a WARNING passes, as in gshade check


def test_gshade_report_writes_the_report_of_every_scene(project):
    project.runpytest_subprocess("--gshade-update").assert_outcomes(passed=2)
    (project.path / "scenes" / "sphere.toml").write_text(sphere_scene(period=0.13))
    result = project.runpytest_subprocess("--gshade-report", "out/report")
    result.assert_outcomes(failed=1, passed=1)
    result.stdout.fnmatch_lines(
        [
            "report: out/report/report.html (written at the end of the session)",
            "report of 2 scenes: out/report/report.html",
        ]
    )
    page = (project.path / "out" / "report" / "report.html").read_text()
    assert "FAILURE: sphere" in page and "PASS: sphere-mean" in page
    assert page.index("FAILURE: sphere") < page.index("PASS: sphere-mean")


def test_an_unusable_report_folder_is_a_usage_error(project):
    (project.path / "taken").write_text("")
    result = project.runpytest_subprocess("--gshade-report", "taken/report")
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    result.stderr.fnmatch_lines(["*--gshade-report taken/report: cannot create the folder (*)"])
    assert not (project.path / "references").exists()


def test_the_ini_reference_folder_and_a_broken_scene(project):
    project.makeini("[pytest]\ngshade_references = tests/refs\n")
    project.runpytest_subprocess("--gshade-update").assert_outcomes(passed=2)
    assert (project.path / "tests" / "refs" / "sphere.exr").is_file()
    (project.path / "scenes" / "sphere.toml").write_text(BROKEN)
    result = project.runpytest_subprocess("-k", "isophotes")
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(["gshade check sphere: does not render: *radius*"])


def test_assert_matches_reference_outside_pytest_fixtures(tmp_path):
    from gshade.app.pytest_plugin import assert_matches_reference

    scene = tmp_path / "sphere.toml"
    scene.write_text(sphere_scene())
    refs = tmp_path / "refs"
    with pytest.raises(AssertionError, match=r"no reference .*--gshade-update to create it"):
        assert_matches_reference(scene, refs)
    assert assert_matches_reference(scene, refs, update=True).written == "created"
    result = assert_matches_reference(scene, refs)
    assert result.status == "PASS" and result.comparison is not None
    scene.write_text(sphere_scene(period=0.13))
    with pytest.raises(AssertionError, match=r"(?s)FAILURE: .*reference: .*sphere\.exr"):
        assert_matches_reference(scene, refs)


# --------------------------------------------------------------------------- gshade check --junit

#: The attributes of the common JUnit schema (Jenkins' junit-10.xsd, as pytest's xunit2),
#: required ones first, and the children each element may have.
SCHEMA = {
    "testsuites": ((), {"name", "time", "tests", "failures", "errors", "disabled"}),
    "testsuite": (
        ("name", "tests", "failures", "errors"),
        {"group", "time", "skipped", "timestamp", "hostname", "id", "package", "file", "log"}
        | {"url", "version"},
    ),
    "properties": ((), set()),
    "property": (("name", "value"), set()),
    "testcase": (("name",), {"time", "classname", "group"}),
    "failure": ((), {"type", "message"}),
    "error": ((), {"type", "message"}),
    "skipped": ((), {"type", "message"}),
    "system-out": ((), set()),
    "system-err": ((), set()),
}
CHILDREN = {
    "testsuites": {"testsuite"},
    "testsuite": {"testsuite", "properties", "testcase", "system-out", "system-err"},
    "properties": {"property"},
    "testcase": {"skipped", "error", "failure", "system-out", "system-err"},
}


def assert_schema_shape(element: ET.Element) -> None:
    required, optional = SCHEMA[element.tag]
    assert set(required) <= set(element.attrib), (element.tag, element.attrib)
    assert set(element.attrib) <= set(required) | optional, (element.tag, element.attrib)
    if "time" in element.attrib:  # SUREFIRE_TIME: at most three decimals
        assert re.fullmatch(r"\d+(\.\d{1,3})?", element.attrib["time"]), element.attrib
    for child in element:
        assert child.tag in CHILDREN.get(element.tag, set()), (element.tag, child.tag)
        assert_schema_shape(child)


@pytest.fixture
def two_scenes(tmp_path, monkeypatch):
    """A passing and a failing scene, and one that does not load, with references."""
    monkeypatch.chdir(tmp_path)
    Path("good.toml").write_text(sphere_scene(name="good"))
    Path("bad.toml").write_text(sphere_scene(name="bad"))
    assert main(["check", "good.toml", "bad.toml", "--references", "refs", "--update"]) == 0
    Path("bad.toml").write_text(sphere_scene(period=0.13, name="bad"))
    Path("broken.toml").write_text(BROKEN)
    return tmp_path


def test_junit_file_of_a_passing_a_failing_and_a_broken_scene(two_scenes, capsys):
    from junitparser import Error, Failure, JUnitXml

    args = ["check", "good.toml", "bad.toml", "broken.toml", "--references", "refs"]
    status = main([*args, "--junit", "out/check.xml", "--report", "rep"])
    assert status == 2  # as without --junit
    printed = capsys.readouterr().out
    assert "JUnit XML: out/check.xml" in printed
    root = ET.parse("out/check.xml").getroot()
    assert_schema_shape(root)
    assert root.tag == "testsuites" and len(root) == 1
    xml = JUnitXml.fromfile("out/check.xml")
    (suite,) = list(xml)
    assert suite.name == "gshade check"
    assert (suite.tests, suite.failures, suite.errors, suite.skipped) == (3, 1, 1, 0)
    cases = {case.name: case for case in suite}
    assert list(cases) == ["good", "bad", "broken"]
    assert {case.classname for case in suite} == {"gshade.check"}
    assert cases["good"].is_passed and "PASS: 0% of 768 pixels" in cases["good"].system_out
    (failure,) = cases["bad"].result
    assert isinstance(failure, Failure) and failure.type == "FAILURE"
    assert re.fullmatch(
        r"FAILURE: [\d.]+% of 768 pixels over 0\.02 .*PSNR .* dB.*", failure.message
    )
    # the text is the line gshade check printed, then the files
    line = next(li for li in printed.splitlines() if li.startswith("FAILURE") and " bad: " in li)
    assert failure.text.splitlines()[:4] == [
        line,
        "scene: bad.toml",
        "reference: refs/bad.exr",
        "report: rep/report.html",
    ]
    (error,) = cases["broken"].result
    assert isinstance(error, Error) and error.type == "ERROR"
    assert error.message.startswith("ERROR: does not render: ") and "radius" in error.message
    assert float(suite.time) == pytest.approx(sum(float(c.time) for c in suite), abs=0.01)


def test_junit_file_of_scenes_that_pass_or_are_new(two_scenes):
    from junitparser import JUnitXml

    Path("new.toml").write_text(sphere_scene(name="new"))
    args = ["check", "good.toml", "bad.toml", "new.toml", "--references", "refs", "--update"]
    assert main([*args, "--junit", "check.xml"]) == 0
    (suite,) = list(JUnitXml.fromfile("check.xml"))
    assert (suite.tests, suite.failures, suite.errors) == (3, 0, 0)
    outs = {case.name: case.system_out for case in suite if case.is_passed}
    assert outs["bad"].startswith("FAILURE (updated reference)")
    assert outs["new"].startswith("NEW (created reference)")


def test_an_unwritable_junit_file_is_one_line_and_nothing_is_written(two_scenes, capsys):
    refs = {p: p.stat().st_mtime_ns for p in Path("refs").iterdir()}
    for target, problem in (
        ("good.toml/check.xml", "--junit good.toml/check.xml: cannot create the folder good.toml"),
        ("refs", "refs: cannot write the file: it is a directory"),
    ):
        args = ["check", "bad.toml", "--references", "refs", "--update", "--report", "rep"]
        assert main([*args, "--junit", target]) == 2
        out, err = capsys.readouterr()
        assert err.count("\n") == 1 and err.startswith(f"gshade: error: {problem}")
        assert out == ""  # nothing rendered
    assert {p: p.stat().st_mtime_ns for p in Path("refs").iterdir()} == refs
    assert not Path("rep").exists()
    assert not [p for p in two_scenes.iterdir() if "gshade-tmp" in p.name]


def test_junit_text_holds_only_characters_xml_allows(tmp_path):
    from junitparser import JUnitXml

    from gshade.regression.check import CheckResult
    from gshade.regression.junit import write_junit

    odd = CheckResult("odd", Path("odd.toml"), "ERROR", "does not render: \x1b[31mred\x00")
    odd.log = "Traceback\x0c\n"
    path = write_junit([odd], tmp_path / "odd.xml")
    (suite,) = list(JUnitXml.fromfile(str(path)))
    (case,) = list(suite)
    assert case.result[0].message == "ERROR: does not render: \\x1b[31mred\\x00"
    assert "Traceback\\x0c" in case.result[0].text
