"""Hostile EXR headers and oversized images (issue 24, points 4, 5 and 14): every header
attribute the view reads is validated, a bad one is left out with a one-line note (in the
page, in `gshade view`'s writer, in the check report's section), never a traceback; image
files over `limits.MAX_IMAGE_FILE_BYTES` are refused in one line before they are read, by
every command that reads images."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from gshade import GshadeError
from gshade.app.cli import main
from gshade.display.html_view import view_data, view_page, view_writer
from gshade.display.view_data import junction_seams
from gshade.io.image import read_exr, read_exr_header, write_exr
from gshade.limits import MAX_IMAGE_FILE_BYTES

from ..support.hostile_headers import BAD_JUNCTIONS, HOSTILE, shape_settings
from ..support.view_pages import page_data

pytest_plugins = ["pytester"]

BALL = (
    '[[surface]]\ntype = "sphere"\nradius = 1.0\n[shape]\nfunction = "isophotes"\n'
    '[render]\nlighting = "flat"\n[check]\nwidth = 32\nheight = 24\nspp = 1\n'
)


def channels8(patch: float = 0.0) -> dict[str, np.ndarray]:
    base = {c: np.full((8, 8), 0.5, np.float32) for c in "RGBA"}
    base["f"] = np.linspace(0, 1, 64, dtype=np.float32).reshape(8, 8)
    base["patch"] = np.full((8, 8), patch, np.float32)
    return base


@pytest.mark.parametrize("case", sorted(HOSTILE))
def test_a_malformed_attribute_is_left_out_with_a_note(case):
    attribute, value = HOSTILE[case]
    header = {"scene_name": "s", attribute: value}
    data = view_data([(channels8(), header)], labels=["a.exr"])
    assert len(data["notes"]) == 1, data["notes"]
    note = data["notes"][0]
    assert note.startswith(f"a.exr: header {attribute}: expected ") and "\n" not in note
    assert len(note) < 300
    image = data["images"][0]
    if attribute == "settings":
        assert image["settings"] == {}
    elif attribute == "junctions":
        assert image["junctions"] is None and image["junction_colours"] == {}
    else:
        assert attribute not in image["header"]
    view_page([(channels8(), header)])  # the page is made (strict JSON)


def test_the_command_writes_the_page_and_names_the_attribute(tmp_path, capsys):
    """Reproducer 01: `gshade view` of a malformed junctions attribute: exit 0, the page
    written, its note naming the file and the attribute (no traceback)."""
    exr = write_exr(tmp_path / "a.exr", channels8(), {"junctions": BAD_JUNCTIONS})
    out = tmp_path / "a.html"
    assert main(["view", str(exr), "-o", str(out)]) == 0
    notes = page_data(out.read_text(encoding="utf-8"))["notes"]
    assert notes == [
        f"{exr}: header junctions: expected colours: an object class -> [r, g, b], got "
        "[1, 2, 3]; shown without it"
    ]
    assert list(view_writer([exr], out).notes) == notes
    assert "Traceback" not in capsys.readouterr().err


def test_valid_attributes_are_kept_and_the_scene_range_is_used():
    junctions = {
        "colours": {"G1": [1.0, 0.42, 0.0]},
        "junctions": [
            {"class": "G1", "patches": [0, 1], "sides": ["u1", "u0"], "gap": "inf", "x": 1},
            {"class": "G0", "patches": [2, 2], "edge": 4},  # one face: no seam, not listed
        ],
    }
    header = {
        "junctions": json.dumps(junctions),
        "settings": shape_settings(value_range=[-3, 3], colormap="magma"),
        "legend": "<b>legend</b>",
    }
    data = view_data([(channels8(), header)])
    assert data["notes"] == []
    image = data["images"][0]
    assert image["junctions"] == junctions["junctions"][:1]
    assert image["junction_colours"] == {"G1": "#ffad00"}
    assert image["header"]["legend"] == "<b>legend</b>"
    assert data["scales"]["f"] == {
        "range": [-3.0, 3.0],
        "colormap": "magma",
        "signed": True,
        "auto": False,
    }


def test_seams_do_not_allocate_by_the_largest_patch_id():
    """Reproducer 01's 74.5 GiB: patch ids up to 2**31 - 1 cost nothing."""
    top = 2**31 - 1
    patch = np.array([[0, top], [100000, top]], np.float64)
    junctions = [
        {"class": "G1", "patches": [top, 0]},
        {"class": "G2", "patches": [100000, top]},
        {"class": "G0", "patches": [0, 100000]},
    ]
    seams = junction_seams(patch, junctions)[:, 0, :].T.tolist()
    assert seams == [[2, 1, 0], [2, 3, 1], [1, 2, 2]]
    # and through the page, with ids beyond float32's exact integers
    data = view_data([(channels8(100000.0), {"junctions": json.dumps({"junctions": junctions})})])
    assert data["notes"] == [] and data["images"][0]["seams"] is None


@pytest.mark.parametrize(
    "names, views",
    [
        (["A"], ["A"]),
        (["R"], ["R"]),
        (["P.X"], ["P.X"]),
        (["N.X", "N.Y"], ["N.X", "N.Y"]),
        (["R", "G", "B", "u", "P.Z", "R.var"], ["u", "P.Z", "R.var"]),
        (["__proto__", "length", "A"], ["__proto__", "length", "A"]),
    ],
)
def test_every_channel_has_a_view(names, views):
    """Reproducer 05: a channel that neither the picture, N nor the patch view shows gets a
    false-colour view (a page without R, G and B shows its data channels)."""
    channels = {n: np.linspace(0, 1, 6, dtype=np.float32).reshape(2, 3) for n in names}
    assert list(view_data([(channels, {})])["scales"]) == views


def test_channel_counts_and_names_are_bounded():
    one = np.zeros((2, 2), np.float32)
    with pytest.raises(GshadeError, match="image A: expected at most 256 channels, got 257"):
        view_data([({f"c{k}": one for k in range(257)}, {})])
    with pytest.raises(GshadeError, match="expected channel names of 1 to 1024 characters"):
        view_data([({"x" * 1025: one}, {})])


# --------------------------------------------------------------------------- sizes


def oversized(path: Path, like: Path) -> Path:
    """A valid EXR padded (sparsely) to one byte over the limit."""
    shutil.copy(like, path)
    os.truncate(path, MAX_IMAGE_FILE_BYTES + 1)
    return path


def size_message(path: Path) -> str:
    return (
        f"{path}: expected an image file of at most {MAX_IMAGE_FILE_BYTES} bytes (4 GB), got "
        f"{MAX_IMAGE_FILE_BYTES + 1} bytes (4.00 GB)"
    )


@pytest.fixture
def small(tmp_path):
    return write_exr(tmp_path / "small.exr", channels8())


def test_view_and_compare_refuse_an_image_over_the_limit(tmp_path, small, capsys):
    """Reproducer 14: one line naming the file, the limit and the size; nothing written."""
    big = oversized(tmp_path / "big.exr", small)
    out = tmp_path / "big.html"
    assert main(["view", str(big), "-o", str(out)]) == 2
    assert capsys.readouterr().err == f"gshade: error: {size_message(big)}\n"
    assert not out.exists()
    assert main(["compare", str(big), str(small)]) == 4
    assert capsys.readouterr().err == f"gshade: error: {size_message(big)}\n"
    for read in (read_exr, read_exr_header):
        with pytest.raises(GshadeError) as error:
            read(big)
        assert str(error.value) == size_message(big)


@pytest.fixture(scope="module")
def project(tmp_path_factory):
    """scenes/ball.toml (32 x 24, one sample) and its reference in refs/."""
    folder = tmp_path_factory.mktemp("project")
    (folder / "scenes").mkdir()
    (folder / "scenes" / "ball.toml").write_text(BALL)
    (folder / "refs").mkdir()
    refs = str(folder / "refs")
    assert main(["check", str(folder / "scenes"), "--references", refs, "--update"]) == 0
    return folder


def copy_project(project: Path, to: Path, junctions: str | None = None, big: bool = False):
    shutil.copytree(project, to, dirs_exist_ok=True)
    reference = to / "refs" / "ball.exr"
    if junctions is not None:
        channels, header = read_exr(reference)
        write_exr(reference, channels, {**header, "junctions": junctions})
    if big:
        os.truncate(reference, MAX_IMAGE_FILE_BYTES + 1)
    return to


def run_check(folder: Path, capsys) -> tuple[int, str]:
    status = main(
        [
            "check",
            str(folder / "scenes"),
            "--references",
            str(folder / "refs"),
            "--report",
            str(folder / "rep"),
            "--junit",
            str(folder / "j.xml"),
        ]
    )
    return status, capsys.readouterr().out


def test_check_report_with_a_hostile_reference(project, tmp_path, capsys):
    """Reproducer 02: the report, its view and the JUnit file are written; the scene's
    section says which attribute of which file was left out of the view."""
    folder = copy_project(project, tmp_path / "p", junctions=BAD_JUNCTIONS)
    status, out = run_check(folder, capsys)
    assert status == 0 and "report: " in out
    assert (folder / "j.xml").exists() and (folder / "rep" / "views" / "ball.html").exists()
    page = (folder / "rep" / "report.html").read_text(encoding="utf-8")
    reference = folder / "refs" / "ball.exr"
    note = f"{reference}: header junctions: expected colours: an object class -&gt; [r, g, b]"
    assert f'<p class="note">{note}' in page
    summary = json.loads((folder / "rep" / "summary.json").read_text())
    assert summary["scenes"][0]["view_notes"][0].startswith(f"{reference}: header junctions")


def test_check_refuses_a_reference_over_the_limit(project, tmp_path, capsys):
    """Check's references and the report: the scene fails naming the limit, the report and
    the JUnit file are written, the view shows the new image alone."""
    folder = copy_project(project, tmp_path / "p", big=True)
    status, out = run_check(folder, capsys)
    reference = folder / "refs" / "ball.exr"
    assert status == 2 and f"cannot compare: {size_message(reference)}" in out
    assert (folder / "j.xml").exists()
    view = page_data((folder / "rep" / "views" / "ball.html").read_text(encoding="utf-8"))
    assert [image["label"] for image in view["images"]] == ["new"]


def test_a_report_survives_a_view_that_fails(project, tmp_path, capsys, monkeypatch):
    """The last resort: whatever goes wrong in one scene's view costs that view alone."""
    import gshade.display.html_view as html_view

    def broken(*args, **kwargs):
        raise KeyError("bug")

    monkeypatch.setattr(html_view, "view_writer", broken)
    folder = copy_project(project, tmp_path / "p")
    status, _ = run_check(folder, capsys)
    assert status == 0
    page = (folder / "rep" / "report.html").read_text(encoding="utf-8")
    assert "no view: KeyError: &#x27;bug&#x27; (a bug: please report it)" in page
    assert not (folder / "rep" / "views").exists()


@pytest.mark.parametrize("big", [False, True], ids=["hostile-header", "over-the-limit"])
def test_the_pytest_plugin_report_with_a_bad_reference(project, pytester, big):
    """Reproducer 09 (and 14 through the plugin): the session ends normally with its
    report; a reference over the limit fails its test naming the limit."""
    folder = copy_project(project, pytester.path, junctions=BAD_JUNCTIONS, big=big)
    (folder / "test_ball.py").write_text(
        'def test_ball(gshade_check):\n    gshade_check("scenes/ball.toml")\n'
    )
    (folder / "pytest.ini").write_text("[pytest]\ngshade_references = refs\n")
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "--gshade-report", "rep")
    text = result.stdout.str()
    assert "Traceback" not in text and "no report" not in text
    page = (folder / "rep" / "report.html").read_text(encoding="utf-8")
    if big:
        result.assert_outcomes(failed=1)
        assert f"expected an image file of at most {MAX_IMAGE_FILE_BYTES} bytes" in text
    else:
        result.assert_outcomes(passed=1)
        assert 'class="note">' in page and "header junctions" in page


# --------------------------------------------------------------------------- properties

_json = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner),
    max_leaves=20,
)
_keys = ["junctions", "settings", "shape", "render", "colours", "patches", "class", "sides"]
_keys += ["edge", "gap", "range", "value_range", "function", "display", "colormap", "period"]
_shaped = st.recursive(
    _json | st.sampled_from(["G0", "G1", "none", "u0", "v1", "inf", "nan", "mean"]),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.sampled_from(_keys), inner),
    max_leaves=30,
)


def _text(value: object) -> str:
    return json.dumps(value)  # NaN and Infinity as JSON's extensions


_attribute = (
    st.builds(_text, _shaped)
    | st.text(max_size=40)
    | st.integers(-(2**31), 2**31 - 1)
    | st.floats()
    | st.builds(lambda v, cut: _text(v)[:cut], _shaped, st.integers(0, 60))
)
_header = st.dictionaries(
    st.sampled_from(["junctions", "settings", "scene_name", "legend", "cad", "variant", "x"]),
    _attribute,
    max_size=4,
)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(header=_header, patch=st.sampled_from([0.0, 1.0, -1.0, 2.0**31, float("nan")]))
@example(header={"junctions": '[{"\\n": null}]'}, patch=0.0)  # a key with a line break
def test_any_header_makes_a_page_or_one_clean_error(header, patch):
    channels = {"f": np.zeros((3, 2), np.float32), "patch": np.full((3, 2), patch, np.float32)}
    channels["patch"][0, 0] = 0.0
    try:
        page = view_page([(channels, header), (channels, header)])
    except GshadeError as exc:
        assert "\n" not in str(exc)
        return
    data = page_data(page)
    assert all("\n" not in note and "header " in note for note in data["notes"])


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(header=_header)
def test_any_reference_header_leaves_a_report(tmp_path_factory, header):
    """The report of a scene whose reference carries any attributes is written."""
    from gshade.regression.check import CheckResult
    from gshade.regression.report import write_report

    folder = tmp_path_factory.mktemp("report")
    reference = write_exr(folder / "ref.exr", channels8(), header)

    image = SimpleNamespace(channels=channels8(), metadata={"scene_name": "s"})
    result = CheckResult("s", folder / "s.toml", "FAILURE", "m", reference, image=image)
    write_report([result], folder / "rep")
    summary = json.loads((folder / "rep" / "summary.json").read_text())
    assert summary["scenes"][0]["view"] == "views/s.html"
