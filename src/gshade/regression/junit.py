"""A reference check's results as JUnit XML, the test report format CI systems show natively
(GitLab, Jenkins, GitHub actions that read test reports, Azure Pipelines).

One ``<testsuites>`` holding one ``<testsuite name="gshade check">`` with the counts
(``tests``, ``failures``, ``errors``, ``skipped``: always 0) and the time; one ``<testcase
classname="gshade.check" name=SCENE time=SECONDS>`` per checked scene.  A scene that fails
its comparison (or has no reference) has a ``<failure>``, one that does not load or render
an ``<error>``; the element's ``message`` is the verdict with its one-line summary, its
``type`` the verdict, and its text the line ``gshade check`` prints (with the metrics), the
scene file, the reference and the HTML report when there is one.  Every test case's
``<system-out>`` holds that line and those paths, passing ones too (a WARNING is a pass, as
in ``gshade check``; so is a reference just written).  A scene checked against a geometric
reference (``[check] reference_model``) also has its deviation numbers as the test case's
``<properties>`` (``deviation.max_abs``, ``deviation.point``, ... , ``geometry`` the
verdict), and in the line (so in a failure's message); the reference model is named with the
paths.  Only the elements and attributes of the common JUnit schema are used (those of
Jenkins' ``junit-10.xsd``, which pytest's ``xunit2`` files follow, and ``<error>``), but for
those test-case properties (as pytest's ``xunit1`` files write them, and Jenkins' JUnit
plugin reads them), which only scenes with a reference model have; names, paths and
messages are written as
:func:`gshade.io.printable.printable` shows them: control characters (those XML cannot
hold, terminal escapes), format characters and bytes of a file name that are not UTF-8 as
``\\xNN`` / ``\\uNNNN``, so that the file is always written and always valid UTF-8 XML.
"""

from __future__ import annotations

import os
import socket
import xml.etree.ElementTree as ET
from collections.abc import Callable, Sequence
from datetime import datetime, timezone
from pathlib import Path

from .. import __version__
from ..io.outputs import atomic_write
from ..io.printable import printable
from .check import CheckResult

__all__ = ["SUITE", "junit_writer", "junit_xml", "write_junit"]

#: The test suite's name, and (with ``.check``) the test cases' class name.
SUITE = "gshade check"
CLASSNAME = "gshade.check"


def _text(value: object) -> str:
    """``value`` as text XML can hold (and a CI page can show): its control characters,
    surrogates and noncharacters written as escapes; lines kept."""
    return printable(value, keep_lines=True)


def _headline(result: CheckResult) -> str:
    """The verdict and the first line of the message: a failure's ``message``."""
    first = result.message.splitlines()[0] if result.message else ""
    if first.startswith(f"{result.status}:"):
        return first
    return f"{result.status}: {first}" if first else result.status


def _details(result: CheckResult, report: Path | None) -> str:
    """The line ``gshade check`` prints, then the scene file, reference and report."""
    lines = [result.line(), f"scene: {result.scene}"]
    if result.reference is not None:
        lines.append(f"reference: {result.reference}")
    if result.reference_model is not None:
        lines.append(f"reference model: {result.reference_model}")
    if report is not None:
        lines.append(f"report: {report}")
    return "\n".join(lines)


#: The deviation summary's numbers a test case's properties give, in order.
_DEVIATION_NUMBERS = (
    "tolerance",
    "count",
    "max_abs",
    "point",
    "pixel",
    "patch_a",
    "patch_b",
    "min",
    "max",
    "mean",
    "rms",
    "p95",
    "within",
)


def _deviation_properties(result: CheckResult) -> dict[str, str]:
    """A scene's deviation numbers as test-case properties (none without a reference
    model): the verdict, the tolerance and count, max |d| with its point, pixel and faces,
    the signed min and max, mean, RMS, 95th percentile of |d| and fraction within, full
    precision."""
    if result.reference_model is None:
        return {}
    facts = {"geometry": result.geometry, "reference_model": str(result.reference_model)}
    d = result.deviation or {}
    for key in _DEVIATION_NUMBERS:
        if d.get(key) is not None:
            facts[f"deviation.{key}"] = _number(d[key])
    return facts


def _number(value: object) -> str:
    """A number (repr: every digit) or a list of them (``x y z``)."""
    if isinstance(value, (list, tuple)):
        return " ".join(repr(v) for v in value)
    return repr(value)


def junit_xml(
    results: Sequence[CheckResult],
    *,
    report: str | os.PathLike | None = None,
    timestamp: datetime | None = None,
) -> ET.Element:
    """The JUnit XML of a check's results.

    Parameters
    ----------
    results : sequence of CheckResult
        As :func:`gshade.regression.check.check` returns them, in order.
    report : path-like, optional
        The HTML report of these results (``report.html``), named in each test case.
    timestamp : datetime, optional
        When the check began (default: now); written in ISO 8601.

    Returns
    -------
    xml.etree.ElementTree.Element
        The ``<testsuites>`` element.
    """
    report_path = Path(report) if report is not None else None
    failures = sum(not r.ok and r.status != "ERROR" for r in results)
    errors = sum(r.status == "ERROR" for r in results)
    seconds = sum(r.seconds for r in results)
    counts = {
        "tests": str(len(results)),
        "failures": str(failures),
        "errors": str(errors),
        "time": f"{seconds:.3f}",
    }
    root = ET.Element("testsuites", {"name": SUITE, **counts})
    when = (timestamp or datetime.now(timezone.utc)).isoformat(timespec="seconds")
    suite = ET.SubElement(
        root,
        "testsuite",
        {
            "name": SUITE,
            **counts,
            "skipped": "0",  # a suite's attribute only
            "timestamp": when,
            "hostname": _text(socket.gethostname()),
        },
    )
    properties = ET.SubElement(suite, "properties")
    facts = {"gshade_version": __version__}
    if report_path is not None:
        facts["report"] = str(report_path)
    for key, value in facts.items():
        ET.SubElement(properties, "property", {"name": key, "value": _text(value)})
    for r in results:
        case = ET.SubElement(
            suite,
            "testcase",
            {"classname": CLASSNAME, "name": _text(r.name), "time": f"{r.seconds:.3f}"},
        )
        details = _details(r, report_path)
        deviation = _deviation_properties(r)
        if deviation:
            numbers = ET.SubElement(case, "properties")
            for key, value in deviation.items():
                ET.SubElement(numbers, "property", {"name": key, "value": _text(value)})
        if not r.ok:
            kind = "error" if r.status == "ERROR" else "failure"
            problem = ET.SubElement(
                case, kind, {"message": _text(_headline(r)), "type": _text(r.status)}
            )
            problem.text = _text(details + (f"\n\n{r.log}" if r.log else ""))
        ET.SubElement(case, "system-out").text = _text(details)
    return root


def junit_writer(
    results: Sequence[CheckResult],
    *,
    report: str | os.PathLike | None = None,
    timestamp: datetime | None = None,
) -> Callable[[str], None]:
    """:func:`junit_xml` as a function writing it (UTF-8, with an XML declaration) to a
    file name: for :func:`gshade.io.outputs.staged` temporaries."""
    root = junit_xml(results, report=report, timestamp=timestamp)
    ET.indent(root)

    def write(name: str) -> None:
        ET.ElementTree(root).write(name, encoding="utf-8", xml_declaration=True)

    return write


def write_junit(
    results: Sequence[CheckResult],
    path: str | os.PathLike,
    *,
    report: str | os.PathLike | None = None,
) -> Path:
    """Write :func:`junit_xml` to ``path`` (atomically); return the path."""
    return atomic_write(path, ".xml", junit_writer(results, report=report))
