"""Benchmark reading CAD files with two revisions of gshade side by side.

What is measured, per file, round and revision: ``gshade.io.cad.read_cad(path)`` in a fresh
process, its model built (``model.brep``, the kernel's B-rep: for ``.3dm`` the exact
surfaces, edges and fitted pcurves), with the conversion cache off
(``GSHADE_CACHE_DIR=off``): wall-clock (``time.perf_counter``), from importing gshade to the
model built, as a user waits (the kernel works in a child process, so the caller's CPU time
says little).
The revisions alternate in order round by round.  The other revision is a source tree
given by ``--before`` (e.g. ``git worktree add /tmp/before <rev>``): its ``src`` goes first
on ``PYTHONPATH``; this checkout is "after".

Reported: per file, each revision's median over the rounds and its spread (max - min), and
the ratio of the medians after / before.  Files are given on the command line (outside
files: never copied into the project).

Usage, from the repository root::

    .venv/bin/python benchmarks/bench_reads.py --before /tmp/before FILE... [--rounds 3] [--write]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

from report import machine_info, markdown_section, publish

_ROOT = Path(__file__).resolve().parents[1]

#: One read in a fresh process: wall seconds and the number of faces.
_READ = """
import sys, time
t = time.perf_counter()
from gshade.io.cad import read_cad
model = read_cad(sys.argv[1])
model.brep
print(time.perf_counter() - t, len(model.faces))
"""


def _read(path: Path, src: Path) -> tuple[float, int]:
    env = {**os.environ, "PYTHONPATH": str(src), "GSHADE_CACHE_DIR": "off"}
    out = subprocess.run(
        [sys.executable, "-c", _READ, str(path)], env=env, capture_output=True, text=True
    )
    if out.returncode != 0:
        raise SystemExit(f"{path}: the read failed under {src}: {out.stderr.strip()[-300:]}")
    wall, faces = out.stdout.split()[-2:]
    return float(wall), int(faces)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("files", nargs="+", type=Path)
    parser.add_argument("--before", type=Path, required=True, help="the other source tree")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--write", action="store_true", help="update RESULTS.md")
    args = parser.parse_args(argv)
    trees = {"before": args.before / "src", "after": _ROOT / "src"}
    wall = {(f, r): [] for f in args.files for r in trees}
    faces: dict[Path, int] = {}
    for k in range(args.rounds):
        for f in args.files:
            order = list(trees) if k % 2 == 0 else list(trees)[::-1]
            for r in order:
                w, faces[f] = _read(f, trees[r])
                wall[(f, r)].append(w)

    def cell(values: list[float]) -> str:
        return f"{statistics.median(values):.2f} ± {max(values) - min(values):.2f}"

    rows = []
    for f in args.files:
        ratio = statistics.median(wall[(f, "after")]) / statistics.median(wall[(f, "before")])
        rows.append(
            [
                f.name,
                str(faces[f]),
                cell(wall[(f, "before")]),
                cell(wall[(f, "after")]),
                f"{ratio:.2f}",
            ]
        )
    columns = [
        "file",
        "faces",
        "before wall (s)",
        "after wall (s)",
        "after / before",
    ]
    info = machine_info()
    run = (
        f"Run: `.venv/bin/python benchmarks/bench_reads.py --before <tree> FILE... "
        f"--rounds {args.rounds} --write`; each cell the median over the rounds ± its "
        "spread (max - min), a fresh process per read, the cache off."
    )
    notes = [f"before = {args.before}, after = this checkout"]
    text = markdown_section(
        "Reading CAD files, two revisions (`benchmarks/bench_reads.py`)",
        run,
        info,
        [("Reads", columns, rows)],
        notes,
    )
    publish(info, [(None, columns, rows)], notes, ("bench_reads", text) if args.write else None)


if __name__ == "__main__":
    main()
