"""Shared helpers of the benchmark scripts: timing, machine description and RESULTS.md.

Nothing here is measured by itself.  The scripts import it as ``from report import ...``;
they are run as ``python benchmarks/<script>.py``, which puts ``benchmarks/`` on
``sys.path``.

* :func:`time_interleaved` runs a few functions once each to warm up and then in rounds of
  one call each (garbage collector off), so that all of them see the same machine state;
  :class:`Timing` holds the samples (median and min-max spread in ms).
* :func:`machine_info` describes the machine, the library versions and the thread settings
  for the report; the versions of the libraries a script compares with are passed in.
* :func:`markdown_table` / :func:`text_table` format a table of string cells.
* :func:`write_section` replaces one script's section of ``benchmarks/RESULTS.md``, between
  the markers ``<!-- {name}:start -->`` and ``<!-- {name}:end -->``, leaving the rest alone.

Thread policy: importing this module sets ``OPENBLAS_NUM_THREADS=1`` unless the
environment already sets it (measured on a 2-core machine: with two BLAS threads the
medians of small products jumped between 9 and 279 ms from run to run).  OpenBLAS reads it
once, when numpy loads, so it must be set before anything imports numpy: the scripts set it
themselves before their imports (import sorting puts ``numpy`` before ``report``), and this
module sets it for any other user.  The report records the value and the runtime thread
count.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import ctypes
import gc
import platform
import statistics
import subprocess
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from datetime import datetime, timezone
from importlib.metadata import version
from pathlib import Path

import numpy as np

__all__ = [
    "RESULTS",
    "Timing",
    "cpu_model",
    "git_revision",
    "machine_info",
    "markdown_table",
    "markers",
    "openblas_threads",
    "text_table",
    "time_interleaved",
    "write_section",
]

RESULTS = Path(__file__).resolve().parent / "RESULTS.md"
HEADER = "# gshade benchmark results\n"


# --------------------------------------------------------------------------- timing


@dataclass
class Timing:
    samples: list[float] = field(default_factory=list)  # seconds

    @property
    def median_ms(self) -> float:
        return 1e3 * statistics.median(self.samples)

    @property
    def spread_ms(self) -> str:
        return f"{1e3 * min(self.samples):.1f}-{1e3 * max(self.samples):.1f}"


def time_interleaved(fns: dict[str, Callable[[], object]], repeats: int) -> dict[str, Timing]:
    """Run each function once to warm up, then ``repeats`` rounds of one call each."""
    out = {name: Timing() for name in fns}
    for fn in fns.values():
        fn()
    gc_was_enabled = gc.isenabled()
    gc.disable()
    try:
        for _ in range(repeats):
            for name, fn in fns.items():
                t0 = time.perf_counter()
                fn()
                out[name].samples.append(time.perf_counter() - t0)
    finally:
        if gc_was_enabled:
            gc.enable()
    return out


# --------------------------------------------------------------------------- machine info


def load_average() -> str:
    """The 1, 5 and 15 minute load averages, for the report's notes."""
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "unknown"


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def openblas_threads() -> str:
    """Threads of the OpenBLAS that numpy loaded, asked through its C API (Linux only)."""
    try:
        maps = Path("/proc/self/maps").read_text()
    except OSError:
        return "unknown"
    libs = {line.split()[-1] for line in maps.splitlines() if "openblas" in line.lower()}
    symbols = (
        "openblas_get_num_threads",
        "openblas_get_num_threads64_",
        "scipy_openblas_get_num_threads64_",
        "scipy_openblas_get_num_threads",
    )
    for lib in sorted(libs):
        try:
            handle = ctypes.CDLL(lib)
        except OSError:
            continue
        for sym in symbols:
            fn = getattr(handle, sym, None)
            if fn is not None:
                fn.restype = ctypes.c_int
                return str(fn())
    return "unknown"


def git_revision() -> str:
    try:
        root = Path(__file__).resolve().parent.parent
        rev = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--", "src"], cwd=root, capture_output=True, text=True
        ).stdout.strip()
    except OSError:
        return "unknown"
    return f"{rev or 'unknown'}{' + uncommitted changes in src/' if dirty else ''}"


def machine_info(versions: Iterable[str] = (), threads: Iterable[str] = ()) -> dict[str, str]:
    """Machine, date, versions and thread settings, as report lines (label -> text).

    ``versions``: extra version strings such as ``"splipy 1.10.1"``, listed between
    numpy's and gshade's; ``threads``: extra thread settings, appended to that line.
    """
    try:
        affinity = len(os.sched_getaffinity(0))
    except AttributeError:
        affinity = os.cpu_count()
    try:
        thp = Path("/sys/kernel/mm/transparent_hugepage/enabled").read_text().strip()
    except OSError:
        thp = "unknown"
    env = ", ".join(
        f"{k}={os.environ.get(k, 'unset')}"
        for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
    )
    libs = ", ".join([f"Python {platform.python_version()}", f"numpy {np.__version__}", *versions])
    return {
        "Machine": f"{cpu_model()}, {os.cpu_count()} logical CPUs ({affinity} usable), "
        f"{platform.system()} {platform.release()}",
        "Date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "Versions": f"{libs}, gshade {version('gshade')} (git {git_revision()})",
        "Threads": "; ".join(
            [f"{env}", f"OpenBLAS runtime threads: {openblas_threads()}", *threads]
        ),
        "Transparent huge pages": thp,
    }


# --------------------------------------------------------------------------- tables


def markdown_table(columns: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    lines = ["| " + " | ".join(columns) + " |", "|" + "|".join("---" for _ in columns) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def text_table(columns: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    table = [list(columns), *(list(r) for r in rows)]
    widths = [max(len(r[k]) for r in table) for k in range(len(columns))]
    fmt = "  ".join(f"{{:<{w}}}" for w in widths)
    lines = [fmt.format(*r) for r in table]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


# --------------------------------------------------------------------------- RESULTS.md


def markdown_section(
    heading: str,
    run: str,
    info: dict[str, str],
    tables: Sequence[tuple[str, Sequence[str], Sequence[Sequence[str]]]],
    notes: Sequence[str],
) -> str:
    """A benchmark's RESULTS.md section: its heading, how it was run, the machine lines, its
    titled tables and its notes."""
    lines = [f"## {heading}", "", run, ""]
    lines += [f"- {k}: {v}" for k, v in info.items()]
    for title, columns, rows in tables:
        lines += ["", f"**{title}**", "", markdown_table(columns, rows)]
    lines += [""] + [f"- {n}" for n in notes]
    return "\n".join(lines)


def publish(
    info: dict[str, str],
    tables: Sequence[tuple[str | None, Sequence[str], Sequence[Sequence[str]]]],
    notes: Sequence[str],
    section: tuple[str, str] | None = None,
) -> None:
    """Print a benchmark's machine lines, its tables ((title or None, columns, rows)) and
    notes; with ``section`` (name, markdown text), also replace its section of RESULTS.md."""
    print("\n".join(f"{k}: {v}" for k, v in info.items()))
    for title, columns, rows in tables:
        print(f"\n{title}\n" if title else "")
        print(text_table(columns, rows))
    print()
    print("\n".join(f"* {n}" for n in notes))
    if section is not None:
        write_section(*section)
        print(f"\nwrote {RESULTS}")


def markers(name: str) -> tuple[str, str]:
    """The start and end markers of section ``name`` in RESULTS.md."""
    return f"<!-- {name}:start -->", f"<!-- {name}:end -->"


def write_section(name: str, text: str, path: Path = RESULTS) -> None:
    """Put ``text`` between section ``name``'s markers, replacing what was there, or append
    the section (markers included) if the file does not have it yet."""
    start_marker, end_marker = markers(name)
    block = f"{start_marker}\n{text.strip(chr(10))}\n{end_marker}"
    old = path.read_text() if path.exists() else HEADER
    start, end = old.find(start_marker), old.find(end_marker)
    if start >= 0 and end > start:
        new = old[:start] + block + old[end + len(end_marker) :]
    else:
        new = old.rstrip("\n") + "\n\n" + block + "\n"
    path.write_text(new)
