"""The analyses against the render they stand beside: each new display (draft_angle and
min_radius in bands, gaussian bands, the parabolic overlay, the combs) against the mean curvature's
colour map of the same scene, and the share of a render the numbers take (issue 29: each
new function no dearer than mean; the whole surface's numbers at most a tenth of a render).

In one process, interleaved per round, the first round untimed (Dr.Jit's kernels, the
caches): the median and range of the whole ``gshade.render`` call, and of
``timings["statistics"]`` over the stages' sum.

Run from the repository root: ``python benchmarks/bench_analyses.py [--rounds N]``.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
from pathlib import Path

SCENES = Path(__file__).resolve().parent.parent / "scenes"

#: (scene, overrides): the baseline (mean, colour map) first for each scene
CASES = [
    ("teapot-mean.toml", {"shape.function": "mean", "shape.display": "colormap"}),
    ("teapot-mean.toml", {"shape.function": "draft_angle", "shape.display": "bands"}),
    ("teapot-mean.toml", {"shape.function": "min_radius", "shape.display": "bands"}),
    ("teapot-mean.toml", {"shape.function": "gaussian", "shape.display": "bands"}),
    (
        "teapot-mean.toml",
        {"shape.function": "mean", "shape.display": "colormap", "render.parabolic": True},
    ),
    (
        "teapot-mean.toml",
        {"shape.function": "mean", "shape.display": "colormap", "render.combs": True},
    ),
    ("bracket-mean.toml", {"shape.function": "mean", "shape.display": "colormap"}),
    (
        "bracket-mean.toml",
        {"shape.function": "mean", "shape.display": "colormap", "render.combs": True},
    ),
    (
        "bracket-mean.toml",
        {
            "shape.function": "mean",
            "shape.display": "colormap",
            "render.combs": True,
            "render.comb_lines": ["edges", "sections"],
        },
    ),
    ("bracket-mean.toml", {"shape.function": "draft_angle", "shape.display": "bands"}),
    ("bracket-mean.toml", {"shape.function": "min_radius", "shape.display": "bands"}),
]
#: The cases of a CAD file given with --cad (not committed: a real part from elsewhere)
CAD_CASES = [
    {"shape.function": "mean", "shape.display": "colormap"},
    {"shape.function": "mean", "shape.display": "colormap", "render.combs": True},
    {
        "shape.function": "mean",
        "shape.display": "colormap",
        "render.combs": True,
        "render.comb_lines": ["edges", "sections"],
    },
    {"shape.function": "draft_angle", "shape.display": "bands"},
    {"shape.function": "min_radius", "shape.display": "bands"},
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3, help="timed rounds (default 3)")
    parser.add_argument(
        "--cad", action="append", default=[], help="also a CAD file (a scene of its own)"
    )
    args = parser.parse_args()

    import gshade
    from gshade.runtime import setup
    from gshade.scene import load_scene

    setup()
    cases = [(SCENES / name, o) for name, o in CASES]
    cases += [(Path(f).resolve(), o) for f in args.cad for o in CAD_CASES]
    seconds: list[list[float]] = [[] for _ in cases]
    shares: list[list[float]] = [[] for _ in cases]
    for round_ in range(args.rounds + 1):
        for k, (path, overrides) in enumerate(cases):
            scene = load_scene(path, overrides)
            start = time.perf_counter()
            image = gshade.render(scene)
            elapsed = time.perf_counter() - start
            if round_:
                seconds[k].append(elapsed)
                shares[k].append(image.timings["statistics"] / sum(image.timings.values()))
    print(
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"{time.strftime('%Y-%m-%d')}, {args.rounds} rounds"
    )
    base = None
    for k, (path, overrides) in enumerate(cases):
        name = path.name
        median = statistics.median(seconds[k])
        overlays = [o.removeprefix("render.") for o in overrides if o.startswith("render.")]
        if overrides["shape.function"] == "mean" and not overlays:
            base = median
        what = overrides["shape.function"] + "".join(f" +{o}" for o in overlays)
        ratio = median / base if base else float("nan")
        print(
            f"{name:18} {what:20} {median:5.2f} s [{min(seconds[k]):.2f}-{max(seconds[k]):.2f}]"
            f"  {ratio:4.2f}x mean  statistics {statistics.median(shares[k]):5.1%}"
        )


if __name__ == "__main__":
    main()
