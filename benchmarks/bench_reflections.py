"""Benchmark the studio reflection (issue 32): a mirror render against the isophote render of
the same scene.

What is measured (wall-clock, ``time.perf_counter``): ``gshade render SCENE -o OUT.exr`` as
a subprocess, start to exit (the EXR written), for each scene with its own ``[shape]`` and
with ``--set shape.function=isophotes`` (the same mesh, camera, size and spp; light
[0.3, -0.5, 0.8], 20 stripes), the runs interleaved (mirror, isophotes, mirror, ...) after
one untimed run of each (Dr.Jit's kernel cache warm).  Median of 5 rounds (``--quick``: 2)
and the min-max spread; the ratio of the medians.  Then one in-process render of each
(``RenderedImage.timings``: where the time goes).  Scenes: ``teapot-studio`` (32 bicubic
patches), ``bracket-studio`` (a STEP part of 52 faces) at 1024 x 768, 16 spp; and, for
information, the teapot as a glossy conductor (roughness 0.05) at 320 x 240, sampled until
two seeds agree.

Target: a mirror render <= 1.5 x the isophote render of the same scene.

Usage, from the repository root::

    .venv/bin/python benchmarks/bench_reflections.py [--quick] [--write]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from report import machine_info, markdown_section, publish

ROOT = Path(__file__).resolve().parent.parent
GSHADE = [sys.executable, "-m", "gshade"]
SCENES = ("teapot-studio", "bracket-studio")
ISOPHOTES = (
    "--set",
    "shape.function=isophotes",
    "--set",
    "shape.light=[0.3, -0.5, 0.8]",
    "--set",
    "shape.stripes=20",
)
GLOSSY = ("--set", "shape.roughness=0.05", "--width", "320", "--height", "240")
TARGET = 1.5


def run(scene: str, extra: tuple[str, ...], out: Path) -> float:
    """One ``gshade render`` subprocess: its wall time (it must succeed)."""
    cmd = [*GSHADE, "render", str(ROOT / "scenes" / f"{scene}.toml"), "-o", str(out), *extra]
    t0 = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)}: exit {done.returncode}: {done.stderr.strip()}")
    return wall


def stages(scene: str, sets: dict[str, object]) -> dict[str, float]:
    """The stage timings of one render in a fresh process (kernels cached on disk)."""
    code = (
        "import json, gshade; "
        f"im = gshade.render({str(ROOT / 'scenes' / (scene + '.toml'))!r}, set={sets!r}); "
        "print(json.dumps(im.timings))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    import json

    return json.loads(done.stdout.strip().splitlines()[-1])


def secs(xs: list[float]) -> str:
    return f"{statistics.median(xs):.2f} s [{min(xs):.2f}-{max(xs):.2f}]"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="2 rounds instead of 5")
    parser.add_argument("--write", action="store_true", help="update benchmarks/RESULTS.md")
    args = parser.parse_args()
    rounds = 2 if args.quick else 5
    rows, stage_rows, notes = [], [], []
    iso_sets = {"shape.function": "isophotes", "shape.light": [0.3, -0.5, 0.8], "shape.stripes": 20}
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out.exr"
        for scene in SCENES:
            cases = {"mirror": (), "isophotes": ISOPHOTES}
            for extra in cases.values():  # warm: Dr.Jit compiles each kernel once
                run(scene, extra, out)
            walls: dict[str, list[float]] = {name: [] for name in cases}
            for _ in range(rounds):
                for name, extra in cases.items():
                    walls[name].append(run(scene, extra, out))
            ratio = statistics.median(walls["mirror"]) / statistics.median(walls["isophotes"])
            rows.append(
                [
                    scene,
                    secs(walls["mirror"]),
                    secs(walls["isophotes"]),
                    f"{ratio:.2f}x",
                    "met" if ratio <= TARGET else "missed",
                ]
            )
            for name, sets in (("mirror", {}), ("isophotes", iso_sets)):
                t = stages(scene, sets)
                stage_rows.append([f"{scene} {name}"] + [f"{t.get(k, 0.0):.2f}" for k in STAGES])
        glossy = [run("teapot-studio", GLOSSY, out)]
        notes.append(
            f"teapot-studio as a glossy conductor at 320x240 (roughness 0.05, sampled until "
            f"two seeds agree within 1 % in sRGB): {secs(glossy)} end to end, for information."
        )
    notes += [
        f"Target: mirror <= {TARGET}x isophotes of the same scene (median wall of the command).",
        "Same mesh, atlas size and spp in both; the mirror has three normal textures where "
        "isophotes have one, the summed-area lookups per sample, one occlusion ray per "
        "sample where isophotes trace a shadow ray, and no lighting.",
    ]
    info = machine_info(threads=("OPENBLAS_NUM_THREADS",))
    columns = ["scene (1024x768, 16 spp)", "mirror", "isophotes", "ratio", "<= 1.5x"]
    stage_columns = ["render (in process)", *STAGES]
    tables = [
        ("Command wall time, median [min-max]", columns, rows),
        ("Stage seconds of one render", stage_columns, stage_rows),
    ]
    run_line = f"`.venv/bin/python benchmarks/bench_reflections.py` ({rounds} rounds)"
    section = markdown_section(
        "Studio reflections: mirror vs isophotes", run_line, info, tables, notes
    )
    publish(info, tables, notes, ("bench_reflections", section) if args.write else None)


STAGES = ("setup", "tessellate", "textures", "scene", "render", "supersample", "exact_channels")

if __name__ == "__main__":
    main()
