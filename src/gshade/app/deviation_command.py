"""``gshade deviation A B``: how far surface A lies from surface B, exactly, in a picture
and in numbers (:mod:`gshade.rendering.deviation_image`), with exit statuses for CI like
``compare``'s: 0 within the warning level, 1 between it and the tolerance, 2 beyond the
tolerance, 3 incomparable (no point of A in view), 4 a scene or CAD file that cannot be
read, 5 a usage error.
"""

from __future__ import annotations

import argparse
import json
from functools import partial
from pathlib import Path
from typing import Any

from ..errors import GshadeError
from .terminal import say

__all__ = [
    "BEYOND",
    "INCOMPARABLE",
    "UNREADABLE",
    "USAGE",
    "WARNING",
    "add_deviation",
    "deviation",
]

#: The exit statuses (0: within the warning level).
WARNING, BEYOND, INCOMPARABLE, UNREADABLE, USAGE = 1, 2, 3, 4, 5


def add_deviation(sub: argparse._SubParsersAction) -> None:
    """The ``deviation`` subcommand's arguments."""
    dev = sub.add_parser(
        "deviation",
        help="the exact signed distance of surface A from surface B, pictured and summed up "
        "(exit 0 within, 1 warning, 2 beyond tolerance, 3 incomparable, 4 unreadable, 5 usage)",
        description="Render A from its view and give every covered pixel's exact point on A "
        "its signed distance to B's exact surfaces (positive on the side A's normal points "
        "to). Exit status: 0 max |d| within --warn, 1 within --tolerance, 2 beyond it, "
        "3 incomparable (no point of A in view), 4 a file that cannot be read, 5 usage.",
        usage_status=USAGE,
    )
    dev.add_argument("a", help="surface A: a scene file (TOML) or a CAD file")
    dev.add_argument("b", help="surface B: a scene file (TOML) or a CAD file")
    dev.add_argument("-o", "--output", help="EXR file (default: <A's name>-deviation.exr here)")
    dev.add_argument("--png", help="also write this PNG (sRGB)")
    dev.add_argument("--legend", action="store_true", help="draw the legend under the PNG")
    dev.add_argument(
        "--tolerance",
        type=float,
        help="the tolerance T in model units (default: 1e-6 of A's bounding box diagonal)",
    )
    dev.add_argument(
        "--warn", type=float, help="the warning level (default: the tolerance): exit 1 above it"
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
    from ..rendering.deviation_image import deviation_image
    from ..scene import load_scene, parse_overrides

    if args.legend and not args.png:
        raise GshadeError("--legend: draws the legend under the PNG; expected --png too")
    overrides: dict[str, Any] = parse_overrides(args.set)
    for key in ("width", "height", "spp"):
        if getattr(args, key) is not None:
            overrides[f"render.{key}"] = getattr(args, key)
    args.error_status = UNREADABLE  # a file that cannot be read, a scene that is not one
    a = load_scene(args.a, overrides)
    b = load_scene(args.b)
    args.error_status = USAGE
    tolerance, warn = _levels(args, scene_diagonal(a))
    output = Path(args.output) if args.output else output_file(".", f"{a.name}-deviation", ".exr")
    inputs = [("A", args.a), ("B", args.b)]
    inputs += [("A's data file", f) for f in a.data_files] + [
        ("B's data file", f) for f in b.data_files
    ]
    distinct_files(inputs, [("-o" if args.output else "the EXR", output), ("--png", args.png)])
    targets = [output] + ([Path(args.png)] if args.png else [])
    with staged(targets) as names:
        args.error_status = UNREADABLE
        image, summary = deviation_image(a, b, tolerance)
        args.error_status = USAGE
        writers = [partial(image.exr_writer, output)]
        if args.png:
            writers.append(partial(image.png_writer, args.png, legend=args.legend))
        write_all(list(zip(names, writers, targets, strict=True)))
    status = _status(summary, tolerance, warn)
    if args.json:
        listed = {"output": str(output), "png": args.png, "status": status, **summary}
        listed["warn"] = warn
        print(json.dumps(listed, indent=2, allow_nan=False))
        return status
    if summary["count"] == 0:
        say(f"{output}: incomparable: no point of {a.name} in view")
        return status
    x, y, z = summary["point"]
    say(
        f"{output}: {summary['count']} points of {a.name} against {b.name}: max |d| "
        f"{summary['max_abs']:.6g} at ({x:.6g}, {y:.6g}, {z:.6g}) (pixel {summary['pixel']}), "
        f"mean {summary['mean']:.6g}, RMS {summary['rms']:.6g}, 95 % {summary['p95']:.6g}, "
        f"{100 * summary['within']:.4g} % within ±{tolerance:.6g}: "
        f"{('PASS', 'WARNING', 'BEYOND TOLERANCE', 'INCOMPARABLE')[status]}"
    )
    return status


def _status(summary: dict[str, Any], tolerance: float, warn: float) -> int:
    """0 within ``warn``, :data:`WARNING` within ``tolerance``, :data:`BEYOND` beyond it,
    :data:`INCOMPARABLE` without a point."""
    if not summary["count"]:
        return INCOMPARABLE
    if summary["max_abs"] > tolerance:
        return BEYOND
    return WARNING if summary["max_abs"] > warn else 0
