"""Batch rendering against separate processes, and an up-to-date re-run.

20 of the project's scenes at 512 x 512 (their own spp and lighting), rendered
(a) by one ``gshade batch -j 2`` (two worker processes that keep Mitsuba and the kernels
warm between scenes) and (b) by 20 separate ``gshade render`` processes, one after another,
in the same run; then (c) the same batch again, with every output up to date.  Targets: (a)
at least 1.5x faster than (b), and (c) at most 10 % of (a).

Run from the repository root: ``.venv/bin/python benchmarks/bench_batch.py --write``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from report import machine_info, markdown_table, text_table, write_section

ROOT = Path(__file__).resolve().parents[1]
GSHADE = [sys.executable, "-m", "gshade"]
SIZE = ["--sweep", "render.width=512", "--sweep", "render.height=512"]


def run(args: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(args, check=True, capture_output=True, cwd=ROOT)
    return time.perf_counter() - start


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--write", action="store_true", help="update benchmarks/RESULTS.md")
    args = parser.parse_args()
    scenes = sorted((ROOT / "scenes").glob("*.toml"))[:20]
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        run([*GSHADE, "batch", str(scenes[0]), "-o", str(out / "warm"), *SIZE])  # warm caches
        batch = run(
            [*GSHADE, "batch", *map(str, scenes), "-o", str(out / "batch"), "-j", "2", *SIZE]
        )
        again = run(
            [*GSHADE, "batch", *map(str, scenes), "-o", str(out / "batch"), "-j", "2", *SIZE]
        )
        separate = sum(
            run(
                [
                    *GSHADE,
                    "render",
                    str(s),
                    "-o",
                    str(out / f"{s.stem}.exr"),
                    "--png",
                    str(out / f"{s.stem}.png"),
                    "--width",
                    "512",
                    "--height",
                    "512",
                ]
            )
            for s in scenes
        )
    rows = [
        [
            "20 scenes, `gshade batch -j 2`",
            f"{batch:.1f}",
            f"{separate / batch:.2f}x faster",
            ">= 1.5x",
            "yes" if separate / batch >= 1.5 else "NO",
        ],
        ["20 separate `gshade render` processes", f"{separate:.1f}", "-", "-", "-"],
        [
            "the batch again, all up to date",
            f"{again:.2f}",
            f"{100 * again / batch:.1f} % of it",
            "<= 10 %",
            "yes" if again <= 0.1 * batch else "NO",
        ],
    ]
    columns = ["Run", "Wall (s)", "Ratio", "Target", "Met"]
    info = machine_info()
    print(text_table(columns, rows))
    if args.write:
        text = "\n".join(
            ["## Batch (`benchmarks/bench_batch.py`)", ""]
            + [f"- {k}: {v}" for k, v in info.items()]
            + [
                "",
                markdown_table(columns, rows),
                "",
                "- Scenes: the first 20 of `scenes/` (sorted), 512 x 512, their own spp and "
                "lighting; every process starts with warm kernel caches; the batch writes EXR "
                "and PNG, as do the separate renders (`--png`).",
            ]
        )
        write_section("bench_batch", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
