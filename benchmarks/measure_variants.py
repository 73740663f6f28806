"""How far do renders differ between Mitsuba's variants, and between re-renders?

The numbers behind ``gshade check``'s default thresholds.  Every scene in ``scenes/`` is
rendered at its check settings (gshade.regression.check.CHECK_DEFAULTS and its ``[check]``
table) with
``llvm_ad_rgb`` twice and with ``scalar_rgb`` once, and the images are compared with
``gshade.compare`` over the check channels: the largest per-pixel difference, the share of
pixels over 0.02 and over 1e-3, and SSIM on the picture.  Re-renders in one variant are
expected to be bit-identical (fixed seed, box filter).  ``flat`` and ``lit`` pictures use no
random numbers (samples at the strata centres; ``lit`` shades with a head light, a constant
ambient term and a key light with one deterministic shadow ray), so the variants differ
only by float rounding; ``soft`` lighting samples the sky, and the two variants draw
different random numbers for it (measure it with ``--set render.lighting=soft``).

Run from the repository root: ``.venv/bin/python benchmarks/measure_variants.py --write``
(several minutes: the scalar variant runs gshade's integrator in Python, per sample).
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from report import machine_info, markdown_table, text_table, write_section

import gshade
from gshade.regression.check import CHECK_DEFAULTS, find_scenes
from gshade.regression.comparison import Thresholds, compare
from gshade.scene import load_scene, parse_overrides

COLUMNS = [
    "Scene",
    "Lighting",
    "llvm re-render: max |diff|",
    "scalar vs llvm: max |diff|",
    "% pixels > 0.02",
    "% pixels > 1e-3",
    "SSIM",
]


def measure(path, overrides=None):
    scene = load_scene(path, overrides or None)
    settings = {**CHECK_DEFAULTS, **scene.check}
    kw = dict(width=settings["width"], height=settings["height"], spp=settings["spp"])
    channels = [c for c in settings["channels"]]
    a = gshade.render(scene, variant="llvm_ad_rgb", **kw)
    b = gshade.render(scene, variant="llvm_ad_rgb", **kw)
    s = gshade.render(scene, variant="scalar_rgb", **kw)
    same = compare(b, a, channels=channels)
    cross = compare(s, a, channels=channels, thresholds=Thresholds(fail=0.02, warn=1e-3))
    return scene, same, cross


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--write", action="store_true", help="update benchmarks/RESULTS.md")
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a scene key in every scene, e.g. render.lighting=soft",
    )
    parser.add_argument("scenes", nargs="*", help="scene files (default: scenes/)")
    args = parser.parse_args()
    rows = []
    worst = {"flat": [0.0, 0.0], "lit": [0.0, 0.0]}
    overrides = parse_overrides(args.set)
    for path in find_scenes(args.scenes or None):
        scene, same, cross = measure(path, overrides)
        lighting = scene.render.lighting
        rows.append(
            [
                scene.name,
                lighting,
                f"{same.overall.max_error:.3g}",
                f"{cross.overall.max_error:.3g}",
                f"{cross.failing_percent:.3f}",
                f"{cross.warning_percent:.3f}",
                "-" if cross.ssim is None else f"{cross.ssim:.4f}",
            ]
        )
        w = worst.setdefault(lighting, [0.0, 0.0])
        w[0] = max(w[0], cross.failing_percent)
        w[1] = max(w[1], cross.warning_percent)
        print(" | ".join(rows[-1]), flush=True)
    info = machine_info(versions=[f"mitsuba {__import__('mitsuba').__version__}"])
    notes = [
        f"Check settings: {CHECK_DEFAULTS['width']}x{CHECK_DEFAULTS['height']} pixels, "
        f"{CHECK_DEFAULTS['spp']} spp, channels {', '.join(CHECK_DEFAULTS['channels'])} "
        "(unless a scene's [check] says otherwise); differences are per pixel, the largest "
        "over the channels (idiff's rule).",
        "Worst share of pixels differing by more than 0.02 between the variants: "
        + ", ".join(f"{k} {w[0]:.3f} %" for k, w in worst.items())
        + "; by more than 1e-3: "
        + ", ".join(f"{k} {w[1]:.3f} %" for k, w in worst.items())
        + ".",
    ]
    print(text_table(COLUMNS, rows))
    print("\n".join(notes))
    if args.write:
        text = "\n".join(
            ["## Variants and re-renders (`benchmarks/measure_variants.py`)", ""]
            + [f"- {k}: {v}" for k, v in info.items()]
            + ["", markdown_table(COLUMNS, rows), ""]
            + [f"- {n}" for n in notes]
        )
        write_section("measure_variants", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
