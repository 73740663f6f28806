"""``gshade deviation A B``: how far surface A lies from surface B, exactly, in a picture
and in numbers (:mod:`gshade.rendering.deviation_image`), with exit statuses for CI like
``compare``'s: 0 within the warning level, 1 between it and the tolerance, 2 beyond the
tolerance, 3 incomparable (no point of A in view), 4 a scene or CAD file that cannot be
read, 5 a usage error.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

from ..errors import GshadeError
from .terminal import say

__all__ = [
    "BEYOND",
    "INCOMPARABLE",
    "UNCOVERED",
    "UNREADABLE",
    "USAGE",
    "WARNING",
    "add_deviation",
    "deviation",
]

#: The exit statuses (0: within the warning level).
WARNING, BEYOND, INCOMPARABLE, UNREADABLE, USAGE = 1, 2, 3, 4, 5
#: The fraction of A's points in view beyond B's free boundary above which B does not
#: cover A: the comparison is :data:`INCOMPARABLE`.
UNCOVERED = 0.01
#: The most points of a whole surface (``--samples``).
MOST_SAMPLES = 10_000_000


def add_deviation(sub: argparse._SubParsersAction) -> None:
    """The ``deviation`` subcommand's arguments."""
    dev = sub.add_parser(
        "deviation",
        help="the exact signed distance of surface A from surface B, pictured and summed up "
        "(exit 0 within, 1 warning, 2 beyond tolerance, 3 incomparable, 4 unreadable, 5 usage)",
        description="Render A from its view and give every covered pixel's exact point on A "
        "its signed distance to B's exact surfaces (positive on the side A's normal points "
        "to). Exit status: 0 max |d| within --warn, 1 within --tolerance, 2 beyond it, "
        "3 incomparable (no point of A in view, or more than 1 %% of them beyond B's free "
        "boundary: B does not cover A), 4 a file that cannot be read, 5 usage.",
        usage_status=USAGE,
    )
    dev.add_argument("a", help="surface A: a scene file (TOML) or a CAD file")
    dev.add_argument("b", help="surface B: a scene file (TOML) or a CAD file")
    dev.add_argument("-o", "--output", help="EXR file (default: <A's name>-deviation.exr here)")
    dev.add_argument("--png", help="also write this PNG (sRGB)")
    dev.add_argument("--legend", action="store_true", help="draw the legend under the PNG")
    dev.add_argument("--html", help="also write this HTML page: the picture and the numbers")
    dev.add_argument(
        "--whole",
        action="store_true",
        help="also measure A's whole surface, sampled by area independently of the view "
        "(the exit status heeds both)",
    )
    dev.add_argument(
        "--symmetric",
        action="store_true",
        help="also the Hausdorff distance both ways, A to B and B to A, sampled by area "
        "(exit 2 when it exceeds the tolerance)",
    )
    dev.add_argument(
        "--tolerance",
        type=float,
        help="the tolerance T in model units (default: 1e-6 of A's bounding box diagonal)",
    )
    dev.add_argument(
        "--warn", type=float, help="the warning level (default: the tolerance): exit 1 above it"
    )
    dev.add_argument(
        "--samples",
        type=int,
        default=100_000,
        help="points of a whole surface for --whole and --symmetric (default 100000)",
    )
    dev.add_argument("--width", type=int, help="image width in pixels")
    dev.add_argument("--height", type=int, help="image height in pixels")
    dev.add_argument("--spp", type=int, help="samples per pixel")
    dev.add_argument(
        "--set", action="append", default=[], metavar="KEY=VALUE", help="override A's scene keys"
    )
    dev.add_argument("--json", action="store_true", help="print the numbers as one JSON object")
    dev.set_defaults(run=deviation, error_status=USAGE)


def _levels(args: argparse.Namespace, diagonal: float) -> tuple[float, float]:
    """(tolerance, warning level), checked: finite, >= 0, the warning level at most the
    tolerance (default: :data:`gshade.analysis.deviation.RELATIVE_TOLERANCE` of A's
    diagonal)."""
    import math

    from ..analysis.deviation import RELATIVE_TOLERANCE

    tolerance = RELATIVE_TOLERANCE * diagonal if args.tolerance is None else args.tolerance
    if not (math.isfinite(tolerance) and tolerance >= 0):
        raise GshadeError(f"--tolerance: expected a number >= 0, got {args.tolerance}")
    warn = tolerance if args.warn is None else args.warn
    if not (math.isfinite(warn) and 0 <= warn <= tolerance):
        raise GshadeError(
            f"--warn: expected a number from 0 to the tolerance {tolerance:g}, got {args.warn}"
        )
    return tolerance, warn


def deviation(args: argparse.Namespace) -> int:
    """``gshade deviation``: the EXR (and PNG) of A coloured by its deviation from B, the
    numbers on stdout, the exit status by the largest |d|."""
    from ..analysis.scene_junctions import scene_diagonal
    from ..io.outputs import distinct_files, output_file, staged, write_all
    from ..regression.report import deviation_page
    from ..rendering.deviation_image import deviation_image
    from ..rendering.deviation_references import read_reference, surface_numbers
    from ..scene import load_scene, parse_overrides

    if args.legend and not args.png:
        raise GshadeError("--legend: draws the legend under the PNG; expected --png too")
    overrides: dict[str, Any] = parse_overrides(args.set)
    for key in ("width", "height", "spp"):
        if getattr(args, key) is not None:
            overrides[f"render.{key}"] = getattr(args, key)
    args.error_status = UNREADABLE  # a file that cannot be read, a scene that is not one
    a = load_scene(args.a, overrides)
    b = read_reference(args.b)
    args.error_status = USAGE
    tolerance, warn = _levels(args, scene_diagonal(a))
    if not 1 <= args.samples <= MOST_SAMPLES:
        raise GshadeError(
            f"--samples: expected an integer from 1 to {MOST_SAMPLES}, got {args.samples}"
        )
    output = Path(args.output) if args.output else output_file(".", f"{a.name}-deviation", ".exr")
    inputs = [("A", args.a), ("B", args.b)]
    inputs += [("A's data file", f) for f in a.data_files] + [
        ("B's data file", f) for f in b.data_files
    ]
    distinct_files(
        inputs,
        [("-o" if args.output else "the EXR", output), ("--png", args.png), ("--html", args.html)],
    )
    targets = [output] + [Path(x) for x in (args.png, args.html) if x]
    with staged(targets) as names:
        args.error_status = UNREADABLE
        image, summary = deviation_image(a, b, tolerance)
        summary["a"] = a.name
        summary |= surface_numbers(
            a, b, tolerance, args.samples, whole=args.whole, symmetric=args.symmetric
        )
        args.error_status = USAGE
        writers: list[Callable[[], Callable[[str], object]]] = [partial(image.exr_writer, output)]
        if args.png:
            writers.append(partial(image.png_writer, args.png, legend=args.legend))
        if args.html:
            page = deviation_page(image, summary, f"{a.name} against {b.name}")
            writers.append(partial(partial, _write_text, page))
        write_all(list(zip(names, writers, targets, strict=True)))
    status = _status(summary, tolerance, warn)
    if args.json:
        listed = {"output": str(output), "png": args.png, "status": status, **summary}
        listed["warn"] = warn
        print(json.dumps(listed, indent=2, allow_nan=False))
        return status
    verdict = ("PASS", "WARNING", "BEYOND TOLERANCE", "INCOMPARABLE")[status]
    say(f"{output}: {_line(summary, a.name, b.name, tolerance)}: {verdict}")
    if "whole" in summary:
        say(f"  whole surface: {_line(summary['whole'], a.name, b.name, tolerance)}")
    if "hausdorff" in summary:
        h = summary["hausdorff"]
        say(
            f"  Hausdorff distance: {h['a_to_b']:.6g} ({a.name} to {b.name}), "
            f"{h['b_to_a']:.6g} ({b.name} to {a.name}), {h['samples']} points each by area"
        )
    return status


def _line(summary: dict[str, Any], a: str, b: str, tolerance: float) -> str:
    """The numbers of one summary in a line."""
    beyond = ""
    if summary.get("beyond"):
        share = 100 * summary["beyond_fraction"]
        beyond = f"; {summary['beyond']} points ({share:.3g} %) beyond {b}'s free boundary"
    if not summary["count"]:
        return f"no point of {a} measured{beyond}"
    x, y, z = summary["point"]
    pixel = f" (pixel {summary['pixel']})" if "pixel" in summary else ""
    return (
        f"{summary['count']} points of {a} against {b}: max |d| {summary['max_abs']:.6g} at "
        f"({x:.6g}, {y:.6g}, {z:.6g}){pixel}, mean {summary['mean']:.6g}, RMS "
        f"{summary['rms']:.6g}, 95 % {summary['p95']:.6g}, {100 * summary['within']:.4g} % "
        f"within ±{tolerance:.6g}{beyond}"
    )


def _write_text(text: str, name: str | Path) -> None:
    """``text`` into the file ``name`` (UTF-8)."""
    Path(name).write_text(text, encoding="utf-8")


def _status(summary: dict[str, Any], tolerance: float, warn: float) -> int:
    """0 within ``warn``, :data:`WARNING` within ``tolerance``, :data:`BEYOND` beyond it,
    :data:`INCOMPARABLE` without a point or where B does not cover A (more than
    :data:`UNCOVERED` of A's points beyond B's free boundary): in view, and over the whole
    surface and both ways where measured."""
    parts = [summary] + ([summary["whole"]] if "whole" in summary else [])
    if any(not s["count"] or s.get("beyond_fraction", 0.0) > UNCOVERED for s in parts):
        return INCOMPARABLE
    largest = max(s["max_abs"] for s in parts)
    if "hausdorff" in summary:
        largest = max(largest, summary["hausdorff"]["both"])
    if largest > tolerance:
        return BEYOND
    return WARNING if largest > warn else 0
