"""Benchmark the continuity finder (``find_junctions``) and the whole ``continuity_report``.

What is measured (wall-clock, ``time.perf_counter``, median and min-max over repeats, the
garbage collector off while timing):

F  ``find_junctions(patches, g0)``: every pair of coinciding patch boundaries, with the G0
   tolerance ``continuity_report`` uses (1e-7 of the bounding-box diagonal).  Probing each
   patch's four sides, a k-d tree of their middle points, verification of the candidates.
R  ``continuity_report(patches)``: the same search, then every junction measured at 32
   samples (gap, normal angle, curvature jump, curvature-gradient jump) and classified.

Surfaces:

* the Catmull–Clark limit surface of the cube (``scenes/data/cube.obj``) after 1, 2 and 3
  refinement levels: 24, 96 and 384 patches (24 Stam patches at the extraordinary corners,
  the rest bicubic Bézier patches), a closed surface: 2 junctions per patch;
* sheets of n x n bicubic Bézier patches, the Bézier extraction of one clamped uniform
  bicubic B-spline surface with the wavy height z = 0.05 sin(6 pi x) cos(4 pi y) of its
  control points over [0, 1]^2: 2 n (n - 1) junctions, all at least G2 (the B-spline is C2);
  n = 10, 32, 100 (100, 1,024 and 10,000 patches).

Before timing, each surface's junctions are checked: their number (every shared edge once),
the same pairs from the report as from the finder, and their classes (at least G1 on the
cube, at least G2 on the sheets).  Targets: the 384-patch cube's search under 1 s, the
10,000-patch sheet's in seconds (<= 10 s).

Usage, from the repository root::

    .venv/bin/python benchmarks/bench_continuity.py            # print the table
    .venv/bin/python benchmarks/bench_continuity.py --write    # and update RESULTS.md
    .venv/bin/python benchmarks/bench_continuity.py --quick    # fewer repeats

``--write`` replaces this benchmark's section of ``benchmarks/RESULTS.md`` (between the
``bench_continuity`` markers) and leaves the rest of the file alone.
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from importlib.metadata import version
from pathlib import Path

# One BLAS thread, as in the other benchmarks (``report`` sets it too); before numpy loads.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from report import (
    Timing,
    load_average,
    machine_info,
    markdown_table,
    publish,
)

from gshade.analysis.continuity import CLASSES, Tolerances, continuity_report, find_junctions
from gshade.analysis.continuity import _probe_sides as probe_sides
from gshade.geometry import BSplinePatch
from gshade.geometry.subdivision.stam import subdivision_patches
from gshade.io.obj import read_obj_mesh

ROOT = Path(__file__).resolve().parents[1]
CUBE = ROOT / "scenes" / "data" / "cube.obj"
SECTION = "bench_continuity"  # its markers in RESULTS.md

CUBE_LEVELS = (1, 2, 3)
SHEETS = (10, 32, 100)  # patches per side
FIND_REPEATS, QUICK_FIND_REPEATS = 15, 3
REPORT_REPEATS, QUICK_REPORT_REPEATS = 5, 1
BIG = 1000  # patches from which the report is timed fewer times (about a minute at 10,000)
BIG_REPORT_REPEATS = 3
PROBES = 5  # find_junctions' default

#: Targets of the search, ms, by workload name.
TARGET_MS = {"cube, 3 levels": 1000.0, "sheet 100 x 100": 10_000.0}


class SanityError(RuntimeError):
    pass


# --------------------------------------------------------------------------- surfaces


@dataclass
class Workload:
    name: str
    patches: list
    junctions: int  # expected: every shared edge once
    lowest: str  # the lowest class expected


def cube(levels: int) -> Workload:
    mesh = read_obj_mesh(CUBE)
    patches = subdivision_patches(mesh.vertices, mesh.faces, levels=levels)
    return Workload(
        f"cube, {levels} level{'s' if levels > 1 else ''}", patches, 2 * len(patches), "G1"
    )


def sheet(n: int, degree: int = 3) -> Workload:
    count = n + degree  # control points per side of a clamped uniform B-spline of n spans
    g = np.linspace(0.0, 1.0, count)
    points = np.zeros((count, count, 3))
    points[..., 0] = g[:, None]
    points[..., 1] = g[None, :]
    points[..., 2] = 0.05 * np.sin(6 * np.pi * g[:, None]) * np.cos(4 * np.pi * g[None, :])
    knots = np.concatenate([np.zeros(degree), np.linspace(0.0, 1.0, n + 1), np.ones(degree)])
    surface = BSplinePatch(points, (degree, degree), (knots, knots))
    patches = [p for row in surface.bezier_patches() for p in row]
    if len(patches) != n * n:
        raise SanityError(f"sheet {n} x {n}: {len(patches)} Bézier patches, expected {n * n}")
    return Workload(f"sheet {n} x {n}", patches, 2 * n * (n - 1), "G2")


def g0_tolerance(patches) -> float:
    """The G0 tolerance continuity_report uses: from the bounding box of 9 x 9 grids."""
    pts = np.concatenate([p(*p.parameter_grid(9, 9)).reshape(-1, 3) for p in patches])
    diag = float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))
    return max(Tolerances.for_size(diag).g0, 1e-12 * diag)


# --------------------------------------------------------------------------- checks


def check(w: Workload, found: list, report: list) -> Counter:
    """The junctions found and reported are the expected ones; their classes."""
    if len(found) != w.junctions:
        raise SanityError(f"{w.name}: {len(found)} junctions found, expected {w.junctions}")
    pairs = {(i, si, j, sj) for i, si, j, sj, _ in found}
    if len(pairs) != len(found):
        raise SanityError(f"{w.name}: a junction found twice")
    sides = Counter((i, si) for i, si, *_ in found) + Counter((j, sj) for _, _, j, sj, _ in found)
    if max(sides.values()) != 1:
        raise SanityError(f"{w.name}: a boundary in more than one junction")
    reported = {(j.patches[0], j.sides[0], j.patches[1], j.sides[1]) for j in report}
    if reported != pairs:
        raise SanityError(f"{w.name}: the report's junctions differ from find_junctions'")
    classes = Counter(j.cls for j in report)
    low = [c for c in classes if CLASSES.index(c) < CLASSES.index(w.lowest)]
    if low:
        raise SanityError(f"{w.name}: junctions below {w.lowest}: {dict(classes)}")
    return classes


# --------------------------------------------------------------------------- timing


def timed(fn: Callable[[], object], repeats: int, warm_up: bool = True) -> Timing:
    """``repeats`` calls (after one untimed call if ``warm_up``), the collector off."""
    if warm_up:
        fn()
    out = Timing()
    enabled = gc.isenabled()
    gc.disable()
    try:
        for _ in range(repeats):
            t0 = time.perf_counter()
            fn()
            out.samples.append(time.perf_counter() - t0)
    finally:
        if enabled:
            gc.enable()
    return out


@dataclass
class Row:
    workload: Workload
    boundaries: int
    find: Timing
    probe: Timing
    report: Timing
    classes: Counter

    @property
    def patches(self) -> int:
        return len(self.workload.patches)

    @property
    def target_ms(self) -> float | None:
        return TARGET_MS.get(self.workload.name)

    @property
    def met(self) -> str:
        if self.target_ms is None:
            return "-"
        return "yes" if self.find.median_ms <= self.target_ms else "NO"

    def find_cells(self, previous: Row | None) -> list[str]:
        per_patch = 1e3 * self.find.median_ms / self.patches
        scale = "-"
        if (
            previous is not None
            and previous.workload.name.split()[0] == self.workload.name.split()[0]
        ):
            scale = (
                f"{self.find.median_ms / previous.find.median_ms:.2f}x "
                f"(n {self.patches / previous.patches:.3g}x)"
            )
        target = "-" if self.target_ms is None else f"<= {self.target_ms / 1e3:g} s"
        return [
            self.workload.name,
            f"{self.patches:,}",
            f"{self.boundaries:,}",
            f"{sum(self.classes.values()):,}",
            f"{self.find.median_ms:.1f}",
            self.find.spread_ms,
            f"{per_patch:.0f}",
            f"{100 * self.probe.median_ms / self.find.median_ms:.0f} %",
            scale,
            target,
            self.met,
        ]

    def report_cells(self) -> list[str]:
        junctions = sum(self.classes.values())
        measuring = self.report.median_ms - self.find.median_ms
        return [
            self.workload.name,
            f"{self.patches:,}",
            f"{junctions:,}",
            f"{self.report.median_ms / 1e3:.2f}",
            f"{min(self.report.samples):.2f}-{max(self.report.samples):.2f}",
            f"{measuring / junctions:.2f}",
            f"{100 * self.find.median_ms / self.report.median_ms:.1f} %",
            ", ".join(f"{c} {n:,}" for c, n in sorted(self.classes.items())),
        ]


FIND_COLUMNS = [
    "Surface",
    "Patches",
    "Boundaries",
    "Junctions",
    "find_junctions median (ms)",
    "Spread (ms)",
    "Per patch (us)",
    "Probing share",
    "Time x previous",
    "Target",
    "Met",
]
REPORT_COLUMNS = [
    "Surface",
    "Patches",
    "Junctions",
    "continuity_report median (s)",
    "Spread (s)",
    "Measuring per junction (ms)",
    "Search share",
    "Classes",
]


def section(info: dict[str, str], rows: list[Row], notes: list[str], args) -> str:
    command = ".venv/bin/python benchmarks/bench_continuity.py --write" + (
        " --quick" if args.quick else ""
    )
    lines = [
        "## Continuity finder (`benchmarks/bench_continuity.py`)",
        "",
        f"Run: `{command}`; medians of {args.find_repeats} find_junctions calls after a "
        f"warm-up, and of {args.report_repeats} continuity_report calls ({args.big_repeats} "
        f"from {BIG:,} patches) after the checking one.",
        "",
    ]
    lines += [f"- {k}: {v}" for k, v in info.items()]
    lines += ["", "**F: the search, `find_junctions`**", ""]
    lines += [markdown_table(FIND_COLUMNS, find_rows(rows)), ""]
    lines += ["**R: the whole `continuity_report` (search, measures at 32 samples, classes)**", ""]
    lines += [markdown_table(REPORT_COLUMNS, [r.report_cells() for r in rows]), ""]
    lines += [f"- {n}" for n in notes]
    return "\n".join(lines)


def find_rows(rows: list[Row]) -> list[list[str]]:
    return [r.find_cells(rows[k - 1] if k else None) for k, r in enumerate(rows)]


# --------------------------------------------------------------------------- main


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--write", action="store_true", help="update benchmarks/RESULTS.md")
    parser.add_argument("--quick", action="store_true", help="fewer repeats")
    args = parser.parse_args(argv)
    args.find_repeats = QUICK_FIND_REPEATS if args.quick else FIND_REPEATS
    args.report_repeats = QUICK_REPORT_REPEATS if args.quick else REPORT_REPEATS
    args.big_repeats = 1 if args.quick else BIG_REPORT_REPEATS
    load_start = load_average()

    t0 = time.perf_counter()
    workloads = [cube(k) for k in CUBE_LEVELS] + [sheet(n) for n in SHEETS]
    built_s = time.perf_counter() - t0
    first = {}
    rows = []
    for w in workloads:
        g0 = g0_tolerance(w.patches)
        t0 = time.perf_counter()
        found = find_junctions(w.patches, g0)  # first call: scipy's import on the first
        first[w.name] = 1e3 * (time.perf_counter() - t0)
        report = continuity_report(w.patches)
        classes = check(w, found, report)
        del report
        boundaries = len(probe_sides(w.patches, g0, PROBES)[0])
        find = timed(lambda w=w, g0=g0: find_junctions(w.patches, g0), args.find_repeats)
        probe = timed(lambda w=w, g0=g0: probe_sides(w.patches, g0, PROBES), args.find_repeats)
        big = len(w.patches) >= BIG
        repeats = args.big_repeats if big else args.report_repeats
        # the check's report was the warm-up
        report_t = timed(lambda w=w: continuity_report(w.patches), repeats, warm_up=False)
        rows.append(Row(w, boundaries, find, probe, report_t, classes))
        print(f"{w.name}: find {find.median_ms:.1f} ms, report {report_t.median_ms / 1e3:.2f} s")

    info = machine_info([f"scipy {version('scipy')}"])
    missed = [r.workload.name for r in rows if r.met == "NO"]
    sheets = [r for r in rows if r.workload.name.startswith("sheet")]
    notes = [
        "Boundaries: the patch sides that are not collapsed (a Stam patch's sides all count), "
        "each probed at 5 points; the search's k-d tree holds their middle points.  Probing "
        "share: the median of `_probe_sides` alone (one evaluation call per patch, in Python) "
        "over find_junctions' median.",
        f"Per patch: find_junctions' median over the patches; near-linear scaling keeps it "
        f"flat: sheets {', '.join(r.find_cells(None)[6] for r in sheets)} us per patch from "
        f"{sheets[0].patches:,} to {sheets[-1].patches:,} patches.",
        "Measuring per junction: (report median - find_junctions median) / junctions, which "
        "includes the report's bounding box (a 9 x 9 grid per patch).",
        "First find_junctions call of each surface (untimed; the first also imports "
        "scipy.spatial): " + ", ".join(f"{k} {v:.0f} ms" for k, v in first.items()) + ".",
        f"Surfaces built in {built_s:.1f} s (not timed): the cube's refinement and patches, "
        "the sheets' Bézier extraction.",
        "Checked before timing: junction counts (2 per patch on the closed cube, 2 n (n - 1) on "
        "an n x n sheet), every boundary in at most one junction, the report's pairs equal "
        "find_junctions', classes at least G1 (cube) and G2 (sheets).",
        f"Load average (1, 5, 15 min): {load_start} at the start, {load_average()} at the end.",
        "Targets missed: " + (", ".join(missed) if missed else "none") + ".",
    ]

    print()
    tables = [
        (None, FIND_COLUMNS, find_rows(rows)),
        (None, REPORT_COLUMNS, [r.report_cells() for r in rows]),
    ]
    publish(
        info, tables, notes, (SECTION, section(info, rows, notes, args)) if args.write else None
    )
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except SanityError as exc:
        sys.exit(f"FAILED sanity check, timings not reported.\n{exc}")
