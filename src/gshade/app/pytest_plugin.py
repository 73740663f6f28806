"""gshade's pytest plugin: a scene's shape quality checked against its reference as a test.

Installed with gshade (entry point ``pytest11``: ``gshade``; ``-p no:gshade`` turns it off),
it gives tests the fixture :func:`gshade_check`: ``gshade_check(scene)`` renders a scene file
(or a scene loaded with :func:`gshade.load_scene`) at its check settings and compares it
with ``references/<name>.exr`` under the same thresholds as ``gshade check`` (it runs
:func:`gshade.regression.check.check_scene`, the command's own per-scene check).  A test
fails with the verdict, the metrics, and where the new render and the difference heat map
were written; a WARNING passes, as in ``gshade check``.

Options:

- ``--gshade-update``: write the references of new and failing scenes (Blender's rule, as
  ``gshade check --update``); those tests pass, and the terminal summary lists every
  reference written.  Without it a missing reference fails, saying to run with it.
- ``--gshade-report DIR``: at the end of the session, ``DIR/report.html`` and
  ``DIR/summary.json`` of every scene checked (``gshade check --report``'s report).
- ini ``gshade_references``: the reference folder, relative to the rootdir (default
  ``references``).

Importing this module is cheap (no numpy, Mitsuba or Dr.Jit: they load when a test first
checks a scene), and it changes nothing for tests that do not use the fixture.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from ..errors import GshadeError

if TYPE_CHECKING:
    from ..regression.check import CheckResult
    from ..scene.model import Scene

__all__ = [
    "assert_matches_reference",
    "failure_message",
    "gshade_check",
    "pytest_addoption",
    "pytest_configure",
    "pytest_sessionfinish",
    "pytest_terminal_summary",
]

#: What the library's messages say of updating, in this plugin's words.
_UPDATE_HINT = ("run with update=True", "run pytest with --gshade-update")


@dataclass
class _Session:
    """The options of this pytest session, and what its checks gave."""

    references: Path
    update: bool
    report: Path | None
    results: list[CheckResult] = field(default_factory=list)  # kept for the report only
    written: list[CheckResult] = field(default_factory=list)
    report_error: str = ""


_SESSION = pytest.StashKey[_Session]()


def pytest_addoption(parser: pytest.Parser) -> None:
    """``--gshade-update``, ``--gshade-report DIR`` and the ini key ``gshade_references``."""
    group = parser.getgroup("gshade", "gshade reference checks (the gshade_check fixture)")
    group.addoption(
        "--gshade-update",
        action="store_true",
        default=False,
        help="write the references of new and failing scenes (as gshade check --update); "
        "those tests pass and are listed in the summary",
    )
    group.addoption(
        "--gshade-report",
        metavar="DIR",
        default=None,
        help="write report.html and summary.json of every scene checked into DIR at the "
        "end of the session (as gshade check --report)",
    )
    parser.addini(
        "gshade_references",
        "gshade_check's reference folder, relative to the rootdir (default: references)",
        default="references",
    )


def pytest_configure(config: pytest.Config) -> None:
    """The session's options; an unusable ``--gshade-report`` folder is a usage error at
    once, before any test runs."""
    report = config.getoption("gshade_report")
    if report is not None:
        report = Path(report)
        try:
            report.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise pytest.UsageError(
                f"--gshade-report {report}: cannot create the folder ({exc.strerror})"
            ) from None
    references = config.rootpath / str(config.getini("gshade_references"))
    config.stash[_SESSION] = _Session(references, bool(config.getoption("gshade_update")), report)


def failure_message(
    result: CheckResult, *, saved: list[str] | None = None, report: Path | None = None
) -> str | None:
    """Why a check failed, for a test's failure (None if it passed).

    Parameters
    ----------
    result : CheckResult
        As :func:`gshade.regression.check.check_scene` returns it.
    saved : list of str, optional
        Lines naming the files written for inspection (the new render, the difference).
    report : Path, optional
        The HTML report that will show this scene.

    Returns
    -------
    str or None
        The scene and its reference, the verdict with the metrics (the line ``gshade check``
        prints), what was saved and how to accept the new render.
    """
    if result.ok:
        return None
    message = result.message.replace(*_UPDATE_HINT)
    lines = [f"gshade check {result.name}: {message}", f"scene: {result.scene}"]
    if result.reference is not None and result.reference.exists():
        lines.append(f"reference: {result.reference}")
    lines += saved or []
    if report is not None:
        lines.append(f"report: {report / 'report.html'} (written at the end of the session)")
    if result.status == "FAILURE" and result.reference is not None and result.reference.exists():
        lines.append("to accept the new render as the reference: pytest --gshade-update")
    if result.log:
        lines.append(result.log.rstrip())
    return "\n".join(lines)


def assert_matches_reference(
    scene: str | os.PathLike | Scene,
    references: str | os.PathLike = "references",
    *,
    update: bool = False,
    statistical: bool = False,
) -> CheckResult:
    """Check ``scene`` against ``references/<name>.exr`` as ``gshade check`` does; an
    AssertionError (:func:`failure_message`) unless it passes.

    For tests outside pytest's fixtures (unittest, scripts); in pytest, the
    :func:`gshade_check` fixture adds ``--gshade-update``, the report and the saved images.

    Parameters
    ----------
    scene : path-like or Scene
        A scene file, or a scene loaded with :func:`gshade.load_scene`.
    references : path-like
        The reference folder (relative to the working directory).
    update : bool
        Write the reference if it is missing or the check fails (Blender's rule); the check
        then passes.
    statistical : bool
        Compare by the z-test (``gshade check --statistical``).

    Returns
    -------
    CheckResult
        The verdict, message, metrics (``comparison``) and rendered image.
    """
    __tracebackhide__ = True
    result = _check(scene, Path(references), update=update, statistical=statistical)
    message = failure_message(result)
    if message is not None:
        raise AssertionError(message)
    return result


def _check(
    scene: str | os.PathLike | Scene, references: Path, *, update: bool, statistical: bool
) -> CheckResult:
    from ..regression.check import check_scene

    if update:
        try:
            references.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise GshadeError(
                f"references: cannot create the folder {references} ({exc.strerror})"
            ) from None
    return check_scene(scene, references, update=update, statistical=statistical)


def _save_for_inspection(result: CheckResult, folder: Callable[[], Path]) -> list[str]:
    """Write a failed check's new render (EXR) and difference heat map (PNG) for a look;
    the lines naming them."""
    from ..io.outputs import output_file
    from ..regression.diff_images import write_diff_png

    if result.image is None:
        return []
    lines = []
    try:
        where = folder()
        render = output_file(where, result.name, ".exr")
        result.image.write_exr(render)
        lines.append(f"new render: {render}")
        if result.comparison is not None:
            diff = write_diff_png(result.comparison, output_file(where, result.name, ".diff.png"))
            lines.append(f"difference: {diff}")
    except GshadeError as exc:
        lines.append(f"(the new render could not be saved: {exc})")
    return lines


@pytest.fixture
def gshade_check(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Callable[..., CheckResult]:
    """A function ``check(scene, *, references=None, statistical=False)`` that checks a
    scene against its reference as ``gshade check`` does and fails the test unless it
    passes.

    ``scene`` is a scene file or a scene loaded with :func:`gshade.load_scene` (e.g. with
    overrides, and a ``name`` of its own: the reference is ``<name>.exr``).  ``references``
    (default: the ini key ``gshade_references``, ``references``) is relative to the rootdir.
    On failure the test's message gives the verdict and metrics, the reference, the new
    render and the difference heat map (saved under pytest's temporary folder) and the
    report.  With ``--gshade-update`` a missing or failing reference is written and the test
    passes.  Returns the :class:`gshade.regression.check.CheckResult`.
    """
    session = request.config.stash[_SESSION]

    def check(
        scene: str | os.PathLike | Scene,
        *,
        references: str | os.PathLike | None = None,
        statistical: bool = False,
    ) -> CheckResult:
        __tracebackhide__ = True
        folder = session.references
        if references is not None:
            folder = request.config.rootpath / references
        try:
            result = _check(scene, folder, update=session.update, statistical=statistical)
        except GshadeError as exc:
            pytest.fail(f"gshade: {exc}", pytrace=False)
        if session.report is not None:
            session.results.append(result)
        if result.written:
            session.written.append(result)
        if not result.ok:
            saved = _save_for_inspection(
                result, lambda: tmp_path_factory.mktemp(f"gshade-{result.name}"[:40])
            )
            message = failure_message(result, saved=saved, report=session.report)
            pytest.fail(message or result.message, pytrace=False)
        return result

    return check


def pytest_sessionfinish(session: pytest.Session) -> None:
    """Write the report of every scene checked (``--gshade-report``)."""
    state = session.config.stash.get(_SESSION, None)
    if state is None or state.report is None or not state.results:
        return
    from ..io.outputs import confined
    from ..regression.report import write_report

    try:
        with confined(state.report):  # nothing written through a link inside it
            write_report(state.results, state.report)
    except GshadeError as exc:  # said in the summary: the tests' outcomes stand
        state.report_error = str(exc)


def pytest_terminal_summary(
    terminalreporter: pytest.TerminalReporter, config: pytest.Config
) -> None:
    """The references written, and where the report is."""
    state = config.stash.get(_SESSION, None)
    if state is None or not (state.written or state.results):
        return
    terminalreporter.section("gshade")
    from ..io.printable import printable

    for r in state.written:
        terminalreporter.write_line(printable(f"{r.written} reference {r.reference} ({r.scene})"))
    if state.report_error:
        terminalreporter.write_line(printable(f"no report: {state.report_error}"), red=True)
    elif state.report is not None and state.results:
        terminalreporter.write_line(
            f"report of {len(state.results)} scenes: {state.report / 'report.html'}"
        )
