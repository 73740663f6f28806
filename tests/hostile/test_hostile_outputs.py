"""Hostile input, second round: what gshade prints and where it writes.

File names with terminal escapes are shown escaped; nothing is written through a symbolic
link inside the chosen folder; no output replaces an input or another output; names that
are not UTF-8 do not stop the report or the JUnit file; one batch at a time writes into a
folder; a refused command creates nothing; read-only outputs are not replaced.

Each refusal is one line on stderr, the documented exit status, and nothing written."""

import json
import os
import stat
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from gshade import GshadeError
from gshade.app.cli import main
from gshade.app.terminal import printable
from gshade.io.output_folders import created_folders, folder_lock, missing_folders, output_folder
from gshade.io.outputs import atomic_write, confined, distinct_files, staged, write_all

SMALL = '[render]\nwidth = 16\nheight = 12\nspp = 1\nlighting = "flat"\n'
CHECK = "[check]\nwidth = 16\nheight = 12\nspp = 1\n"
SPHERE = '[[surface]]\ntype = "sphere"\n'
#: A file name that sets the terminal's title, turns the text red and rings the bell.
ESCAPES = "x-\x1b]0;PWNED\x07\x1b[31mred\x1b[0m"
SHOWN = "x-\\x1b]0;PWNED\\x07\\x1b[31mred\\x1b[0m"
CONTROL = [chr(c) for c in (*range(0x20), 0x7F, *range(0x80, 0xA0))]


def listing(folder):
    return sorted(str(p.relative_to(folder)) for p in Path(folder).rglob("*"))


def run(capsys, *argv):
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


def one_line_error(err, *fragments):
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gshade: error: "), err
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])


def no_control_characters(text):
    assert not [c for c in text if c in CONTROL and c != "\n"], repr(text)
    assert not [c for c in text if "\ud800" <= c <= "\udfff"], repr(text)


def scene_file(folder, name="ball", text=SPHERE + SMALL + CHECK):
    path = Path(folder) / f"{name}.toml"
    path.write_text(text)
    return path


# --------------------------------------------------------------------------- terminal escapes


def test_printable_escapes_control_format_and_undecodable_characters():
    assert printable(ESCAPES) == SHOWN
    assert printable("a\nb\r\tc\x00\x9b[2J") == "a\\x0ab\\x0d\\x09c\\x00\\x9b[2J"
    assert printable("evil\u202etxt\u2028") == "evil\\u202etxt\\u2028"
    assert printable(os.fsdecode(b"bad\xff.toml")) == "bad\\xff.toml"
    assert printable("\ud800\ufffe") == "\\ud800\\ufffe"
    assert printable("ünïcode-✓ teapot [1, 2]") == "ünïcode-✓ teapot [1, 2]"
    assert printable("log\n\tline\x1b", keep_lines=True) == "log\n\tline\\x1b"
    assert printable(printable(ESCAPES)) == printable(ESCAPES)
    printable(os.fsdecode(b"\xff\xfe")).encode("utf-8")  # always encodable


def test_check_render_info_batch_show_escaped_file_names(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scenes").mkdir()
    scene = scene_file(tmp_path / "scenes", ESCAPES)
    status, out, err = run(capsys, "check", "scenes", "--references", "refs", "--update")
    assert status == 2
    no_control_characters(out + err)
    assert f"ERROR                        {SHOWN}: does not render: scenes/{SHOWN}.toml" in out
    for command in (["render", scene, "-o", "o.exr"], ["info", scene], ["continuity", scene]):
        status, out, err = run(capsys, *command)
        assert status == 2 and out == ""
        no_control_characters(err)
        one_line_error(err, f"gshade: error: {scene.parent}/{SHOWN}.toml: name")
    status, out, err = run(capsys, "batch", scene, "-o", "out")
    assert status == 2
    no_control_characters(out + err)
    assert err.startswith(f"failed: {SHOWN} ({scene.parent}/{SHOWN}.toml): ")
    with pytest.raises(SystemExit) as exit_info:  # argparse's own errors quote arguments
        main(["render", str(scene), f"--bogus{ESCAPES}"])
    assert exit_info.value.code == 2
    _, err = capsys.readouterr()
    no_control_characters(err)
    assert f"--bogus{SHOWN}" in err
    with pytest.raises(SystemExit) as exit_info:
        main(["compare", "a.exr", "b.exr", f"--bogus{ESCAPES}"])
    assert exit_info.value.code == 5
    _, err = capsys.readouterr()
    assert f"--bogus{SHOWN}" in err
    no_control_characters(err)


def test_messages_of_a_rendered_scene_and_of_view_are_escaped(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    scene = scene_file(tmp_path, "ball")
    status, out, err = run(capsys, "render", scene, "-o", f"{ESCAPES}.exr")
    assert status == 0 and (tmp_path / f"{ESCAPES}.exr").is_file()
    assert out.startswith(f"{SHOWN}.exr: 16x12")
    no_control_characters(out + err)
    status, out, err = run(capsys, "view", f"{ESCAPES}.exr", "-o", f"{ESCAPES}.html")
    assert status == 0 and out.startswith(f"{SHOWN}.html: 1 image")
    no_control_characters(out + err)


# --------------------------------------------------------------------------- links


def test_check_refuses_a_report_whose_views_folder_is_a_link(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    scene = scene_file(tmp_path)
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "rep").mkdir()
    (tmp_path / "rep" / "views").symlink_to(tmp_path / "elsewhere")
    before = listing(tmp_path)
    status, out, err = run(
        capsys, "check", scene, "--references", "refs", "--update", "--report", "rep"
    )
    assert status == 2 and out == ""  # refused before any scene renders
    one_line_error(err, "rep/views: expected a folder, got a symbolic link")
    assert listing(tmp_path) == before


def test_batch_refuses_a_logs_folder_that_is_a_link(tmp_path, capsys):
    broken = scene_file(tmp_path, "broken", '[[surface]]\ntype = "sphere"\nradius = -1\n')
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "logs").symlink_to(tmp_path / "elsewhere")
    before = listing(tmp_path)
    status, _, err = run(capsys, "batch", broken, "-o", tmp_path / "out")
    assert status == 2
    one_line_error(err, "out/logs: expected a folder, got a symbolic link")
    assert listing(tmp_path) == before


def test_a_job_log_is_never_written_through_a_link(tmp_path):
    from gshade.app.batch import job_status
    from gshade.app.jobs import plan_jobs

    broken = scene_file(tmp_path, "broken", '[[surface]]\ntype = "sphere"\nradius = -1\n')
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "logs").symlink_to(tmp_path / "elsewhere")
    (job,) = plan_jobs([broken], [])
    result = job_status(job, str(tmp_path / "out"), force=False)
    assert result.status == "failed" and result.log is None
    assert list((tmp_path / "elsewhere").iterdir()) == []


def test_outputs_refuse_links_below_a_confined_folder(tmp_path):
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "chosen").symlink_to(tmp_path / "root", target_is_directory=True)
    (tmp_path / "root").mkdir()
    (tmp_path / "root" / "views").symlink_to(tmp_path / "elsewhere")
    (tmp_path / "root" / "real").mkdir()
    with confined(tmp_path / "chosen"):
        with pytest.raises(GshadeError, match=r"chosen/views is a symbolic link \(nothing is"):
            atomic_write(tmp_path / "chosen" / "views" / "a.html", ".html", Path.touch)
        with pytest.raises(GshadeError, match="views is a symbolic link"):
            with staged([tmp_path / "chosen" / "views" / "a.html"]):
                pass
        # the chosen folder may itself be a link, its real subfolders are fine
        atomic_write(tmp_path / "chosen" / "a.html", ".html", lambda t: Path(t).write_text("a"))
        atomic_write(tmp_path / "chosen" / "real" / "b.html", ".html", Path.touch)
        atomic_write(tmp_path / "elsewhere" / "c.html", ".html", Path.touch)  # not below it
    assert sorted(os.listdir(tmp_path / "elsewhere")) == ["c.html"]
    atomic_write(tmp_path / "chosen" / "views" / "d.html", ".html", Path.touch)  # unconfined
    assert (tmp_path / "elsewhere" / "d.html").exists()


def test_output_folder_makes_a_subfolder_and_refuses_a_link_or_a_file(tmp_path):
    assert output_folder(tmp_path, "views") == tmp_path / "views"
    assert (tmp_path / "views").is_dir()
    assert output_folder(tmp_path, "views") == tmp_path / "views"  # it exists: fine
    (tmp_path / "logs").symlink_to(tmp_path / "views")
    with pytest.raises(GshadeError, match=r"logs: expected a folder, got a symbolic link"):
        output_folder(tmp_path, "logs")
    (tmp_path / "dangling").symlink_to(tmp_path / "nowhere")
    with pytest.raises(GshadeError, match="got a symbolic link"):
        output_folder(tmp_path, "dangling")
    assert not (tmp_path / "nowhere").exists()
    (tmp_path / "file").write_text("")
    with pytest.raises(GshadeError, match="expected a folder, got a file"):
        output_folder(tmp_path, "file")
    assert output_folder(tmp_path, "later", create=False) == tmp_path / "later"
    assert not (tmp_path / "later").exists()
    with pytest.raises(GshadeError, match="subfolder"):
        output_folder(tmp_path, "../up")


# --------------------------------------------------------------------------- outputs on inputs


def test_render_refuses_outputs_onto_its_inputs_or_each_other(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "quad.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    scene = scene_file(tmp_path, "scene", SPHERE + SMALL).name
    mesh = scene_file(
        tmp_path, "mesh", '[[surface]]\ntype = "subdivision"\nfile = "data/quad.obj"\n' + SMALL
    ).name
    (tmp_path / "same").symlink_to(tmp_path, target_is_directory=True)
    before = {p: p.read_bytes() for p in map(Path, (scene, mesh, "data/quad.obj"))}
    files = listing(tmp_path)
    for args, message in [
        ([scene, "-o", scene], "-o scene.toml: expected an output other than the scene file"),
        ([scene, "-o", "same/scene.toml"], "-o same/scene.toml: expected an output other"),
        ([scene, "-o", "x.exr", "--png", "x.exr"], "--png x.exr: expected a file other than -o"),
        ([scene, "-o", "y.exr", "--html", "./y.exr"], "--html ./y.exr: expected a file other"),
        ([scene, "--png", "scene.exr"], "--png scene.exr: expected a file other than the EXR"),
        ([mesh, "-o", "data/quad.obj"], "-o data/quad.obj: expected an output other than the "),
        ([mesh, "--html", "mesh.toml"], "--html mesh.toml: expected an output other than the"),
    ]:
        status, out, err = run(capsys, "render", *args)
        assert status == 2 and out == "", args
        one_line_error(err, message)
    assert {p: p.read_bytes() for p in before} == before
    assert listing(tmp_path) == files


def test_view_and_compare_refuse_outputs_onto_their_images(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for name in ("a.exr", "b.exr"):  # refused before they are read: any bytes do
        (tmp_path / name).write_bytes(b"image " + name.encode())
    files = listing(tmp_path)
    status, _, err = run(capsys, "view", "a.exr", "b.exr", "-o", "b.exr")
    assert status == 2
    one_line_error(err, "-o b.exr: expected an output other than IMAGE.exr b.exr")
    status, _, err = run(capsys, "compare", "a.exr", "b.exr", "--diff", "a.exr")
    assert status == 5
    one_line_error(err, "--diff a.exr: expected an output other than TEST.exr a.exr")
    status, _, err = run(capsys, "compare", "a.exr", "b.exr", "--diff-png", "./b.exr")
    assert status == 5
    one_line_error(err, "--diff-png ./b.exr: expected an output other than REF.exr b.exr")
    (tmp_path / "here").symlink_to(tmp_path, target_is_directory=True)
    status, _, err = run(capsys, "compare", "a.exr", "b.exr", "--diff", "d", "--diff-png", "here/d")
    assert status == 5
    one_line_error(err, "--diff and --diff-png: expected two different files")
    assert (tmp_path / "a.exr").read_bytes() == b"image a.exr"
    assert (tmp_path / "b.exr").read_bytes() == b"image b.exr"
    assert listing(tmp_path) == sorted([*files, "here"])


def test_check_refuses_junit_or_report_onto_inputs_or_each_other(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    scene = scene_file(tmp_path)
    (tmp_path / "refs").mkdir()
    (tmp_path / "refs" / "ball.exr").write_bytes(b"reference")
    files = listing(tmp_path)
    for args, message in [
        (["--junit", "ball.toml"], "--junit ball.toml: expected an output other than the scene"),
        (["--junit", "refs/ball.exr"], "--junit refs/ball.exr: expected an output other than"),
        (
            ["--junit", "rep/report.html", "--report", "rep"],
            "--report rep/report.html: expected a file other than --junit rep/report.html",
        ),
    ]:
        status, out, err = run(capsys, "check", scene, "--references", "refs", *args)
        assert status == 2 and out == "", args
        one_line_error(err, message)
    assert scene.read_text() == SPHERE + SMALL + CHECK
    assert listing(tmp_path) == files


def test_check_never_writes_a_reference_onto_the_scene_file(tmp_path, capsys):
    (tmp_path / "refs").mkdir()
    scene = tmp_path / "refs" / "ball.exr"  # a scene file whose reference it would be
    scene.write_text(SPHERE + SMALL + CHECK)
    status, out, _ = run(capsys, "check", scene, "--references", tmp_path / "refs", "--update")
    assert status == 2
    assert "ERROR" in out and "cannot write the reference: the reference" in out
    assert scene.read_text() == SPHERE + SMALL + CHECK


def test_batch_and_figure_refuse_outputs_onto_scene_files(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    manifest = scene_file(out, "manifest")
    manifest = manifest.rename(out / "manifest.json")
    status, _, err = run(capsys, "batch", manifest, "-o", out)
    assert status == 2
    one_line_error(err, "the manifest")
    assert listing(out) == ["manifest.json"]
    # a job whose output is its own scene file fails alone, the file kept
    png = out / "ball.png"
    png.write_text('name = "ball"\n' + SPHERE + SMALL)
    status, _, err = run(capsys, "batch", png, "-o", out)
    assert status == 2 and "expected an output other than the scene file" in err
    assert png.read_text() == 'name = "ball"\n' + SPHERE + SMALL
    assert not (out / "ball.exr").exists()
    # figure: the spec (and the rows' scene files) are no output
    scene_file(tmp_path, "row", SPHERE + SMALL)
    spec = tmp_path / "fig.svg"
    spec.write_text('rows = ["row.toml"]\n')
    status, _, err = run(capsys, "figure", spec, "-o", spec)
    assert status == 2
    one_line_error(err, "-o ", "fig.svg: expected an output other than SPEC")
    assert spec.read_text() == 'rows = ["row.toml"]\n'


def test_distinct_files_compares_resolved_paths_and_inodes(tmp_path):
    (tmp_path / "a").write_text("a")
    os.link(tmp_path / "a", tmp_path / "hard")
    (tmp_path / "soft").symlink_to(tmp_path / "a")
    with pytest.raises(GshadeError, match="hard: expected an output other than IN "):
        distinct_files([("IN", tmp_path / "a")], [("OUT", tmp_path / "hard")])
    with pytest.raises(GshadeError, match=r"a: expected an output other than IN .*soft"):
        distinct_files([("IN", tmp_path / "soft")], [("OUT", tmp_path / "a")])
    # an output that is a link is replaced, not followed: the input it points at is safe
    distinct_files([("IN", tmp_path / "a")], [("OUT", tmp_path / "soft")])
    with pytest.raises(GshadeError, match="expected a file other than"):
        distinct_files([], [("A", tmp_path / "x"), ("B", tmp_path / "." / "x")])
    distinct_files([], [("A", tmp_path / "x"), ("B", tmp_path / "x")], among_outputs=False)
    with pytest.raises(GshadeError, match="expected a file other than"):
        with staged([tmp_path / "x", tmp_path / "sub" / ".." / "x"]):
            pass
    assert sorted(os.listdir(tmp_path)) == ["a", "hard", "soft"]


# --------------------------------------------------------------------------- not UTF-8


def test_a_scene_name_that_is_not_utf8_leaves_report_and_junit_whole(tmp_path, capsys):
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    scene_file(scenes, "good")
    scene_file(scenes, os.fsdecode(b"bad\xff"))
    rep, junit = tmp_path / "rep", tmp_path / "j.xml"
    status, out, err = run(
        capsys, "check", scenes, "--references", tmp_path / "refs", "--update",
        "--report", rep, "--junit", junit,
    )  # fmt: skip
    assert status == 2, err  # the bad scene is an ERROR
    assert err == "" and "ERROR                        bad\\xff: does not render" in out
    root = ET.parse(junit).getroot()
    names = [case.get("name") for case in root.iter("testcase")]
    assert sorted(names) == ["bad\\xff", "good"]
    page = (rep / "report.html").read_bytes().decode("utf-8")  # valid UTF-8
    assert "bad\\xff.toml" in page
    summary = json.loads((rep / "summary.json").read_text(encoding="utf-8"))
    assert {s["name"] for s in summary["scenes"]} == {"bad\\xff", "good"}
    assert any(s["scene"].endswith("scenes/bad\\xff.toml") for s in summary["scenes"])
    no_control_characters(json.dumps(summary, ensure_ascii=False))  # no lone surrogates


def test_junit_is_written_even_when_the_report_cannot_be(tmp_path, capsys, monkeypatch):
    import gshade.regression.report

    def broken(results, folder):
        raise GshadeError(f"{folder}/report.html: cannot write the file: disk full")

    monkeypatch.setattr(gshade.regression.report, "write_report", broken)
    scene = scene_file(tmp_path)
    junit = tmp_path / "j.xml"
    args = ["--update", "--report", tmp_path / "rep", "--junit", junit]
    status, _, err = run(capsys, "check", scene, "--references", tmp_path / "refs", *args)
    assert status == 2
    one_line_error(err, "rep/report.html: cannot write the file: disk full")
    assert [c.get("name") for c in ET.parse(junit).getroot().iter("testcase")] == ["ball"]
    assert not (tmp_path / "rep").exists()  # made for the report, empty: removed


def test_junit_text_is_printable_and_keeps_its_lines(tmp_path):
    from gshade.regression.check import CheckResult
    from gshade.regression.junit import write_junit

    odd = CheckResult(
        os.fsdecode(b"n\xff\x1b"), Path(os.fsdecode(b"s\xfe.toml")), "ERROR", "does not render"
    )
    odd.log = "Traceback\n  line\u202e\n"
    path = write_junit([odd], tmp_path / "odd.xml")
    text = path.read_bytes().decode("utf-8")
    assert 'name="n\\xff\\x1b"' in text and "scene: s\\xfe.toml" in text
    assert "Traceback\n  line\\u202e" in text
    ET.parse(path)


# --------------------------------------------------------------------------- one batch at a time


def test_a_second_batch_into_a_locked_folder_is_refused_at_once(tmp_path, capsys):
    scene = scene_file(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    with folder_lock(out, "busy"):  # as a batch running there holds it
        status, stdout, err = run(capsys, "batch", scene, "-o", out)
    assert status == 2 and stdout == ""
    one_line_error(err, f"{out}: another batch is writing here")
    assert listing(out) == []
    status, _, _ = run(capsys, "batch", scene, "-o", out)  # the lock is gone with its holder
    assert status == 0 and listing(out) == ["ball.exr", "ball.png", "manifest.json"]


def test_folder_lock_is_exclusive_and_writes_nothing(tmp_path):
    with folder_lock(tmp_path, "busy here"):
        with pytest.raises(GshadeError, match="busy here"):
            with folder_lock(tmp_path, "busy here"):
                pass
    with folder_lock(tmp_path, "busy here"):
        pass
    assert listing(tmp_path) == []
    with pytest.raises(GshadeError, match="cannot write to the output folder"):
        with folder_lock(tmp_path / "missing", "busy"):
            pass


# --------------------------------------------------------------------------- nothing created


def test_a_refused_check_creates_no_folder(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    scene = scene_file(tmp_path)
    (tmp_path / "refs").mkdir()
    (tmp_path / "afile").write_text("x")
    files = listing(tmp_path)
    cases = [
        (["--junit", "new/deep/j.xml", "--report", "afile"], "--report afile: cannot create"),
        (["--junit", "afile/j.xml"], "--junit afile/j.xml: cannot create the folder afile"),
        (["--report", "new/rep", "--references", "missing"], "missing: the reference folder"),
        (["--report", "new/rep", "--junit", "new"], "new: cannot write the file"),
    ]
    for args, message in cases:
        status, out, err = run(capsys, "check", scene, "--references", "refs", *args)
        assert status == 2 and out == "", args
        one_line_error(err, message)
        assert listing(tmp_path) == files, args


def test_created_folders_are_removed_when_the_block_fails(tmp_path):
    folders = missing_folders(tmp_path / "a" / "b")
    assert folders == [tmp_path / "a", tmp_path / "a" / "b"]
    with pytest.raises(RuntimeError):
        with created_folders(folders):
            assert (tmp_path / "a" / "b").is_dir()
            raise RuntimeError
    assert listing(tmp_path) == []
    with created_folders(folders) as made:
        assert made == folders
    assert (tmp_path / "a" / "b").is_dir()
    (tmp_path / "f").write_text("")
    with pytest.raises(GshadeError, match=r"cannot create the folder \(.*f exists and is not"):
        missing_folders(tmp_path / "f" / "g" / "h")


def test_batch_with_a_scheduler_refuses_before_making_anything(tmp_path, capsys, monkeypatch):
    scene = scene_file(tmp_path)
    monkeypatch.setitem(sys.modules, "distributed", None)  # as if Dask were not installed
    status, _, err = run(capsys, "batch", scene, "-o", tmp_path / "out", "--scheduler", "tcp://h:1")
    assert status == 2
    one_line_error(err, "--scheduler: Dask's distributed package is not installed")
    assert not (tmp_path / "out").exists()
    monkeypatch.undo()
    import gshade.app.worker_pool as worker_pool

    def unreachable(address):
        raise GshadeError(f"scheduler: cannot reach the Dask scheduler at {address} (timed out)")

    monkeypatch.setattr(worker_pool, "dask_client", unreachable)
    monkeypatch.setattr("importlib.util.find_spec", lambda name, *a: object())
    status, _, err = run(capsys, "batch", scene, "-o", tmp_path / "out", "--scheduler", "tcp://h:1")
    assert status == 2
    one_line_error(err, "--scheduler: cannot reach the Dask scheduler at tcp://h:1")
    assert not (tmp_path / "out").exists()


# --------------------------------------------------------------------------- permissions


def test_a_read_only_output_is_not_replaced(tmp_path, capsys):
    scene = scene_file(tmp_path)
    locked = tmp_path / "locked.exr"
    locked.write_text("precious")
    locked.chmod(0o444)
    files = listing(tmp_path)
    status, out, err = run(capsys, "render", scene, "-o", locked)
    assert status == 2 and out == ""
    one_line_error(err, "locked.exr: cannot write the file: it is read-only (mode 0444")
    assert locked.read_text() == "precious" and stat.S_IMODE(locked.stat().st_mode) == 0o444
    status, out, err = run(capsys, "check", scene, "--references", tmp_path, "--junit", locked)
    assert status == 2 and out == ""  # before any scene renders
    one_line_error(err, "it is read-only")
    assert listing(tmp_path) == files


def test_a_replaced_output_keeps_its_permission_bits(tmp_path):
    kept = tmp_path / "kept.txt"
    kept.write_text("old")
    kept.chmod(0o640)
    atomic_write(kept, ".txt", lambda t: Path(t).write_text("new"))
    assert kept.read_text() == "new" and stat.S_IMODE(kept.stat().st_mode) == 0o640
    kept.chmod(0o604)
    with staged([kept]) as (name,):
        Path(name).write_text("newer")
    assert stat.S_IMODE(kept.stat().st_mode) == 0o604


def test_write_all_writes_side_by_side_and_raises_the_first_jobs_error_once_all_ended(tmp_path):
    import threading

    met = threading.Barrier(3, timeout=60)  # a hang guard: each writer waits for the others

    def writer(text):
        def write(name):
            met.wait()  # only returns once all three writers run at the same time
            if text is None:
                raise OSError("no space left")
            Path(name).write_text(text)

        return write

    names = [tmp_path / f"{k}.tmp" for k in "abc"]
    jobs = [
        (str(n), lambda t=t: writer(t), n.with_suffix(".out"))
        for n, t in zip(names, ("one", None, "three"), strict=True)
    ]
    with pytest.raises(GshadeError, match=r"b\.out: cannot write the file: no space left"):
        write_all(jobs)
    assert names[0].read_text() == "one" and names[2].read_text() == "three"  # both ended
