"""Benchmark two revisions of gshade side by side: is a change (a refactor) slower?

Both revisions run in the same interpreter and virtual environment, interleaved round by
round (the order alternating), each measurement in a fresh process with warm kernel caches
and compiled bytecode (``compileall`` first: this environment may forbid writing bytecode
caches, which Python otherwise keeps, and would charge the compile time to the imports).
The other revision is a source tree given by ``--before`` (e.g. a ``git worktree`` of the
older commit): its ``src`` goes first on ``PYTHONPATH``; this checkout is "after".

What is measured, per round and revision (wall-clock, ``time.perf_counter``):

- ``gshade render`` of the teapot scenes (isophotes, mean curvature) at their settings,
  1024 x 768, 16 spp, lit, and of ``bracket-mean`` (a STEP part of 17 faces: the CAD
  kernel's reading and meshing): the whole command;
- ``gshade --version`` and importing the command line, the scene package and the render
  pipeline;
- in one process: ``load_scene`` of the teapot; a warm ``render`` (the last three of four in
  the same process, median) with its stage timings; four shape functions with their
  gradients on a 1000 x 1000 grid of a bicubic patch (median of 7); ``find_junctions``
  (median of 7) and ``continuity_report`` (median of 3) on the Catmull-Clark cube refined
  three times (384 patches).

Reported: the medians of each revision, the median of the per-round ratios after / before
and both spreads.  Usage, from the repository root::

    git worktree add /tmp/before <rev>
    .venv/bin/python benchmarks/bench_revisions.py --before /tmp/before [--rounds 5] [--write]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from report import machine_info, markdown_table, text_table, write_section

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"

WORKER = Path(__file__).with_name("revision_worker.py")


def command(src: Path | None) -> tuple[list[str], dict[str, str]]:
    """The interpreter's ``gshade`` command and environment for a revision's source tree."""
    env = dict(os.environ)
    if src is None:
        return [sys.executable, "-m", "gshade"], env
    env["PYTHONPATH"] = str(src)
    module = "gshade" if (src / "gshade" / "__main__.py").exists() else "gshade.cli"
    return [sys.executable, "-m", module], env


def timed(args: list[str], env: dict[str, str], cwd: str) -> float:
    start = time.perf_counter()
    subprocess.run(args, env=env, cwd=cwd, check=True, capture_output=True)
    return time.perf_counter() - start


def one_round(src: Path | None, folder: str) -> dict[str, float]:
    gshade, env = command(src)
    row = {"gshade --version": timed([*gshade, "--version"], env, folder)}
    tree = (src or ROOT / "src") / "gshade"
    cli = "gshade.cli" if gshade[-1] == "gshade.cli" else "gshade.app.cli"
    scene = "gshade.scene" if (tree / "scene").is_dir() else "gshade.io.scene"
    row["import cli, scene, pipeline"] = timed(
        [sys.executable, "-c", f"import {cli}, {scene}, gshade.rendering.pipeline"],
        env,
        folder,
    )
    for name in ("teapot-isophotes", "teapot-mean", "bracket-mean"):  # the last a CAD part
        row[f"gshade render {name}"] = timed(
            [*gshade, "render", str(SCENES / f"{name}.toml"), "-o", f"{folder}/{name}.exr"],
            env,
            folder,
        )
    worker = subprocess.run(
        [sys.executable, str(WORKER), str(SCENES)],
        env=env,
        cwd=folder,
        check=True,
        capture_output=True,
        text=True,
    )
    row.update(json.loads(worker.stdout.strip().splitlines()[-1]))
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", required=True, type=Path, help="the other revision's tree")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--write", action="store_true", help="update benchmarks/RESULTS.md")
    args = parser.parse_args()
    before_src = args.before.resolve() / "src"
    revision = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], cwd=args.before, capture_output=True, text=True
    ).stdout.strip()
    for tree in (before_src, ROOT / "src"):
        subprocess.run([sys.executable, "-m", "compileall", "-q", str(tree)], check=True)
    rows: dict[str, list[dict[str, float]]] = {"before": [], "after": []}
    with tempfile.TemporaryDirectory() as folder:
        for r in range(args.rounds):
            order = ("before", "after") if r % 2 == 0 else ("after", "before")
            for side in order:
                rows[side].append(one_round(before_src if side == "before" else None, folder))
                print(f"round {r + 1}/{args.rounds}: {side} done", file=sys.stderr)
    columns = ["Measure", "before (s)", "after (s)", "after / before"]
    columns += ["spread before", "spread after"]
    table = []
    for key in rows["after"][0]:
        b = [x[key] for x in rows["before"] if key in x]
        a = [x[key] for x in rows["after"]]
        if not b:
            continue
        ratio = statistics.median(y / x for x, y in zip(b, a, strict=True))
        table.append([
            key.replace("|", "/"),
            f"{statistics.median(b):.4f}",
            f"{statistics.median(a):.4f}",
            f"{ratio:.3f}",
            f"{min(b):.4f}-{max(b):.4f}",
            f"{min(a):.4f}-{max(a):.4f}",
        ])  # fmt: skip
    print(text_table(columns, table))
    if args.write:
        info = machine_info()
        text = "\n".join(
            [
                "## Two revisions side by side (`benchmarks/bench_revisions.py`)",
                "",
                f"Run: `.venv/bin/python benchmarks/bench_revisions.py --before <tree of "
                f"{revision}> --rounds {args.rounds} --write`; before = git {revision}, after = "
                "this checkout; rounds interleaved, each measure a median within its process, "
                "then the median over the rounds; the ratio is the median of the per-round "
                "ratios.",
                "",
                *[f"- {k}: {v}" for k, v in info.items()],
                "",
                markdown_table(columns, table),
            ]
        )
        write_section("bench_revisions", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
