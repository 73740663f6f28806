"""The in-process measurements of ``bench_revisions.py``, run by each revision's interpreter.

Public API only, so that it runs on either side of a reorganisation.  Prints one JSON object:
measure -> seconds.  Usage: ``python revision_worker.py SCENES_FOLDER``.
"""

import json
import statistics
import sys
import time

import numpy as np

import gshade
from gshade.geometry import BezierPatch
from gshade.shape import evaluate

try:
    from gshade.analysis.continuity import continuity_report, find_junctions
except ImportError:  # before the packages of 0.2
    from gshade.continuity import continuity_report, find_junctions  # type: ignore


def median_time(f, n: int) -> float:
    times = []
    for _ in range(n):
        start = time.perf_counter()
        f()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main(scenes: str) -> dict[str, float]:
    out = {}
    teapot = f"{scenes}/teapot-isophotes.toml"
    out["load_scene teapot"] = median_time(lambda: gshade.load_scene(teapot), 5)
    for name in ("teapot-isophotes", "teapot-mean"):
        scene = gshade.load_scene(f"{scenes}/{name}.toml")
        totals, stages = [], []
        for i in range(4):  # the first loads the kernels; the last three are warm
            start = time.perf_counter()
            image = gshade.render(scene)
            took = time.perf_counter() - start
            if i:
                totals.append(took)
                stages.append(image.timings)
        out[f"warm render {name}"] = statistics.median(totals)
        for k in stages[0]:
            out[f"  stage {k} ({name})"] = statistics.median(s[k] for s in stages)

    heights = np.random.default_rng(20240612).uniform(0.0, 0.5, (4, 4))
    net = np.array([[[i, j, heights[i, j]] for j in range(4)] for i in range(4)], float)
    patch = BezierPatch(net)
    u, v = patch.parameter_grid(1000, 1000)
    d = patch.derivatives(u, v, 3)
    for fn in ("isophotes", "gaussian", "mean", "max_principal"):
        evaluate(fn, d)
        out[f"shape {fn}, 10^6 points"] = median_time(lambda fn=fn: evaluate(fn, d), 7)

    cube = gshade.load_scene(f"{scenes}/subdivision-cube-mean.toml", {"surface.1.levels": 3})
    patches = list(cube.patches)
    n = len(patches)
    find_junctions(patches, 1e-7)
    out[f"find_junctions, {n} patches"] = median_time(lambda: find_junctions(patches, 1e-7), 7)
    out[f"continuity_report, {n} patches"] = median_time(lambda: continuity_report(patches), 3)
    return out


if __name__ == "__main__":
    print(json.dumps(main(sys.argv[1])))
