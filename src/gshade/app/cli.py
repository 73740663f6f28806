"""The ``gshade`` command line: the parser, the dispatch to the subcommands
(:mod:`gshade.app.commands`), the exit statuses and the signals.

Exit statuses: 0 success, 2 bad input (one line on stderr naming the file, the key or line,
what was expected and what was found; never a traceback), 130 after Ctrl-C, 128 + the signal
after SIGTERM or SIGHUP.  ``compare`` keeps idiff's statuses (0 pass, 1 warning, 2 failure,
3 size or channel mismatch, 4 unreadable file) and gives usage errors 5.  Every line printed
shows names and messages through :func:`gshade.app.terminal.printable`: a file name's
control characters (terminal escapes, BEL, line breaks, bytes that are not UTF-8) are
written as escapes, never sent to the terminal.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, NoReturn

from .. import __version__
from ..errors import GshadeError
from ..runtime.cache_folder import CACHE_VARIABLE
from . import commands
from .deviation_command import add_deviation
from .flags import in_flags
from .terminal import printable

__all__ = ["build_parser", "console", "main"]

#: ``gshade compare``'s status for usage errors (idiff's own are 0-4).
COMPARE_USAGE = 5


class _Parser(argparse.ArgumentParser):
    """argparse's parser, its error messages (which quote the arguments) made printable."""

    def error(self, message: str) -> NoReturn:
        super().error(printable(message))


class _SubcommandParser(_Parser):
    """A subcommand's parser; with ``usage_status``, its argument errors (``--fail abc``, a
    missing or an unrecognised argument) are one line ``PROG: error: ...`` and that exit
    status (``gshade compare``: 5, apart from idiff's 0-4) instead of usage and status 2."""

    def __init__(self, *args: Any, usage_status: int | None = None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.usage_status = usage_status

    def error(self, message: str) -> NoReturn:
        if self.usage_status is None:
            super().error(message)
        print(f"{self.prog}: error: {printable(message)}", file=sys.stderr)
        sys.exit(self.usage_status)

    def parse_known_args(
        self, args: Iterable[str] | None = None, namespace: Any = None
    ) -> tuple[Any, list[str]]:
        given = None if args is None else list(args)  # as argparse itself takes them
        namespace, extras = super().parse_known_args(given, namespace)
        if extras and self.usage_status is not None:  # they would reach the main parser: 2
            self.error(f"unrecognized arguments: {' '.join(extras)}")
        return namespace, extras


def _strict_flag(parser: argparse.ArgumentParser) -> None:
    """``--strict``: a CAD face left out is an error (``load_scene(..., strict=True)``)."""
    parser.add_argument(
        "--strict",
        action="store_true",
        help="a CAD face that cannot be rendered is an error (exit 2, nothing written), "
        "not a warning (the cad surfaces' scene key strict)",
    )


def _cache_flag(parser: argparse.ArgumentParser) -> None:
    """``--no-cache``: no cache on disk is read or written (``GSHADE_CACHE_DIR=off`` for the
    command and its workers): CAD files are read and converted once per command."""
    parser.add_argument(
        "--no-cache",
        action="store_true",
        help="neither read nor write gshade's caches on disk (as GSHADE_CACHE_DIR=off): "
        "CAD files are read and converted once per command",
    )


#: what a command's SCENE argument may be
SCENE_HELP = "a scene file (TOML), or a CAD file (STEP, IGES, BREP, Rhino 3dm) as a scene"


def build_parser() -> argparse.ArgumentParser:
    """The parser; each subcommand's arguments carry ``run`` (its function in
    :mod:`gshade.app.commands`) and ``error_status`` (for a GshadeError, default 2)."""
    parser = _Parser(
        prog="gshade",
        description="Render the shape quality of parametric surfaces (Kiciak's shape functions).",
    )
    parser.add_argument("--version", action="version", version=f"gshade {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_SubcommandParser)
    for add in SUBCOMMANDS:
        add(sub)
    return parser


def _add_shapes(sub: argparse._SubParsersAction) -> None:
    """The ``shapes`` subcommand's arguments."""
    shapes = sub.add_parser("shapes", help="list the shape functions, their order and parameters")
    shapes.set_defaults(run=commands.shapes)


def _add_keys(sub: argparse._SubParsersAction) -> None:
    """The ``keys`` subcommand's arguments."""
    keys = sub.add_parser(
        "keys", help="list the scene files' keys: types, ranges, defaults, meanings"
    )
    keys.set_defaults(run=commands.keys)


def _add_render(sub: argparse._SubParsersAction) -> None:
    """The ``render`` subcommand's arguments."""
    render = sub.add_parser("render", help="render a scene file to EXR (and PNG)")
    render.add_argument("scene", help=SCENE_HELP)
    render.add_argument("-o", "--output", help="EXR file (default: <scene name>.exr here)")
    render.add_argument("--png", help="also write this PNG (sRGB)")
    render.add_argument(
        "--legend",
        action="store_true",
        help="draw the legend under the PNG: the colour bar with its unit, the function, the "
        "stripe period or the bands, the notes",
    )
    render.add_argument("--width", type=int, help="image width in pixels")
    render.add_argument("--height", type=int, help="image height in pixels")
    render.add_argument("--spp", type=int, help="samples per pixel")
    render.add_argument("--variant", help="auto | llvm_ad_rgb | scalar_rgb | cuda_ad_rgb")
    render.add_argument(
        "--junctions",
        action="store_true",
        default=None,
        help="draw the patch junctions coloured by continuity class "
        "(G0 red, G1 orange, G2 green, G3 blue)",
    )
    render.add_argument(
        "--parabolic",
        action="store_true",
        default=None,
        help="draw the parabolic lines (K = 0, where the surface turns from elliptic to "
        "hyperbolic) as sharp lines over any display (scene key render.parabolic)",
    )
    render.add_argument(
        "--combs",
        action="store_true",
        default=None,
        help="draw curvature combs along the patch boundaries and B-rep edges (and knot lines, "
        "planar sections), inflections ringed (scene keys render.combs, comb_curvature, "
        "comb_lines, comb_sections, comb_section_direction, comb_scale)",
    )
    render.add_argument(
        "--aovs",
        metavar="NAMES",
        help="extra EXR channels: shape functions' exact values at the pixel centres, "
        "e.g. mean,gaussian (scene key render.aovs)",
    )
    render.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override any scene key, e.g. --set shape.period=0.05 (repeatable)",
    )
    render.add_argument(
        "--html", help="also write this HTML page of the EXR (as gshade view makes it)"
    )
    render.add_argument(
        "--json",
        action="store_true",
        help="print one JSON object on stdout: the files written, the legend and the shape "
        "function's numbers over the visible and the whole surface (min and max with where "
        "they are, mean, percentiles; min_radius: the smallest radius)",
    )
    _strict_flag(render)
    _cache_flag(render)
    render.set_defaults(run=commands.render)


def _add_view(sub: argparse._SubParsersAction) -> None:
    """The ``view`` subcommand's arguments."""
    view = sub.add_parser(
        "view",
        help="one self-contained HTML page to inspect EXRs: zoom, every channel under the "
        "cursor, false colours, junctions; with a second image flip and difference",
    )
    view.add_argument("images", nargs="+", metavar="IMAGE.exr", help="1 to 3 EXR files of one size")
    view.add_argument("-o", "--output", help="the page (default: <first image's stem>.html here)")
    view.add_argument("--title", help="the page's title (default: the file names)")
    view.set_defaults(run=commands.view)


def _add_compare(sub: argparse._SubParsersAction) -> None:
    """The ``compare`` subcommand's arguments."""
    cmp = sub.add_parser(
        "compare",
        help="compare an EXR with a reference (exit 0 pass, 1 warning, 2 failure, "
        "3 size or channel mismatch, 4 unreadable file, 5 usage error)",
        description="Compare an EXR with a reference, as OpenImageIO's idiff does. Exit "
        "status: 0 pass, 1 warning, 2 failure (the images differ), 3 size or channel "
        "mismatch, 4 unreadable file (idiff's), 5 usage error (a bad argument, a "
        "difference image that cannot be written).",
        usage_status=COMPARE_USAGE,
    )
    cmp.add_argument("test", help="the new image (EXR)")
    cmp.add_argument("reference", help="the reference image (EXR)")
    cmp.add_argument("--channels", default="R,G,B", help="channels to compare (default R,G,B)")
    cmp.add_argument("--fail", type=float, default=1e-6, help="per-pixel failure threshold")
    cmp.add_argument(
        "--failpercent", type=float, default=0.0, help="%% of pixels allowed over --fail"
    )
    cmp.add_argument(
        "--hardfail", type=float, default=float("inf"), help="any pixel over this fails"
    )
    cmp.add_argument("--warn", type=float, default=1e-6, help="per-pixel warning threshold")
    cmp.add_argument(
        "--warnpercent", type=float, default=0.0, help="%% of pixels allowed over --warn"
    )
    cmp.add_argument("--diff", help="write the absolute differences to this EXR")
    cmp.add_argument("--diff-png", help="write a heat map of the differences to this PNG")
    cmp.add_argument(
        "--diff-on-fail",
        action="store_true",
        help="write the difference images only if the verdict is not PASS",
    )
    cmp.add_argument(
        "--ssim",
        action="store_true",
        help="also compute SSIM of the tone-mapped R, G, B (slow on large images)",
    )
    cmp.add_argument("--json", action="store_true", help="print the metrics as JSON")
    cmp.set_defaults(run=commands.compare, error_status=COMPARE_USAGE)


def _add_check(sub: argparse._SubParsersAction) -> None:
    """The ``check`` subcommand's arguments."""
    chk = sub.add_parser(
        "check", help="render scenes at their check settings and diff them with references"
    )
    chk.add_argument("scenes", nargs="*", help="scene files or folders (default: scenes/)")
    chk.add_argument("--references", default="references", help="reference folder")
    chk.add_argument("--report", help="write report.html and summary.json into this folder")
    chk.add_argument(
        "--junit",
        metavar="FILE",
        help="also write the results as JUnit XML (one test case per scene) for CI systems",
    )
    chk.add_argument(
        "--update", action="store_true", help="write references for new and failing scenes"
    )
    chk.add_argument("--update-all", action="store_true", help="write every reference")
    chk.add_argument(
        "--statistical",
        action="store_true",
        help="render each scene several times and compare by a z-test against the "
        "reference's variances (for noisy soft-lit renders)",
    )
    _cache_flag(chk)
    chk.set_defaults(run=commands.check)


def _add_batch(sub: argparse._SubParsersAction) -> None:
    """The ``batch`` subcommand's arguments."""
    bat = sub.add_parser("batch", help="render many scenes (and sweeps) into a folder")
    bat.add_argument("scenes", nargs="+", help="scene files, folders or glob patterns")
    bat.add_argument("-o", "--output", required=True, help="output folder")
    bat.add_argument("-j", "--jobs", type=int, default=1, help="worker processes (default 1)")
    bat.add_argument("--force", action="store_true", help="render even up-to-date outputs")
    bat.add_argument(
        "--timeout",
        type=float,
        default=3600.0,
        metavar="SECONDS",
        help="time limit of one job; a job over it is stopped and fails (default 3600)",
    )
    bat.add_argument(
        "--sweep",
        action="append",
        default=[],
        metavar="KEY=V1,V2,…",
        help="render each scene once per value, e.g. "
        "--sweep shape.function=isophotes,reflection_lines,gaussian (repeatable)",
    )
    bat.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help='run on an existing Dask cluster, e.g. tcp://host:8786 (pip install "gshade[dask]")',
    )
    _cache_flag(bat)
    bat.set_defaults(run=commands.batch)


def _add_lightbox(sub: argparse._SubParsersAction) -> None:
    """The ``lightbox`` subcommand's arguments."""
    box = sub.add_parser(
        "lightbox",
        help="write gshade's studio environment (strip lights over a soft floor) as an EXR",
        description='Write the lat-long map that [shape] map = "lightbox" reflects: R, G, B '
        "linear; column = azimuth atan2(y, x) from +x towards +y, row = polar angle from +z.",
    )
    box.add_argument("-o", "--output", required=True, help="OUT.exr")
    box.add_argument("--strips", type=int, default=5, help="strip lights overhead (1 to 64)")
    box.add_argument(
        "--strip-width", type=float, default=8.0, help="each strip's width in degrees (0 to 90)"
    )
    box.add_argument(
        "--width", type=int, default=1024, help="columns (even, 64 to 8192; rows: half)"
    )
    box.set_defaults(run=commands.lightbox)


def _add_figure(sub: argparse._SubParsersAction) -> None:
    """The ``figure`` subcommand's arguments."""
    fig = sub.add_parser("figure", help="a multi-panel figure from a figure spec")
    fig.add_argument("spec", help="figure spec (TOML)")
    fig.add_argument("-o", "--output", required=True, help="OUT.png, OUT.pdf or OUT.svg")
    _cache_flag(fig)
    fig.set_defaults(run=commands.figure)


def _add_continuity(sub: argparse._SubParsersAction) -> None:
    """The ``continuity`` subcommand's arguments."""
    cont = sub.add_parser("continuity", help="measure and classify the patch junctions")
    cont.add_argument("scene", help=SCENE_HELP)
    cont.add_argument("--json", action="store_true", help="print JSON")
    cont.add_argument(
        "--samples", type=int, default=32, help="samples per junction (1 to 4096, default 32)"
    )
    for order, unit in (
        ("g0", "length"),
        ("g1", "degrees"),
        ("g2", "1/length"),
        ("g3", "1/length^2"),
    ):
        cont.add_argument(f"--tol-{order}", type=float, help=f"{order.upper()} tolerance ({unit})")
    cont.add_argument(
        "--pair",
        action="append",
        metavar="I:SIDE,J:SIDE",
        help="measure just this junction, e.g. 0:u1,1:u0 (sides u0 u1 v0 v1; repeatable); "
        "an error if the two boundaries do not coincide; at most 10000 pairs",
    )
    cont.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    _strict_flag(cont)
    _cache_flag(cont)
    cont.set_defaults(run=commands.continuity)


def _add_info(sub: argparse._SubParsersAction) -> None:
    """The ``info`` subcommand's arguments."""
    info = sub.add_parser("info", help="describe a scene's surfaces")
    info.add_argument("scene", help=SCENE_HELP)
    info.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    info.add_argument(
        "--stats",
        action="store_true",
        help="also the shape function's numbers over the whole surface, without rendering: "
        "min and max with where they are, mean, percentiles (min_radius: the smallest radius)",
    )
    _strict_flag(info)
    _cache_flag(info)
    info.set_defaults(run=commands.info)


#: The subcommands' argument builders, in the order ``gshade --help`` lists them.
SUBCOMMANDS = (
    _add_shapes,
    _add_keys,
    _add_render,
    _add_view,
    _add_compare,
    add_deviation,
    _add_check,
    _add_batch,
    _add_figure,
    _add_lightbox,
    _add_continuity,
    _add_info,
)


_signalled: list[int] = []
#: Commands that stop on a signal through their own cleanup (``batch``: stop the workers,
#: write the manifest); the others end at once, their temporaries removed.
_GRACEFUL = ("batch",)


def _terminated(signum: int, frame: object) -> None:
    """SIGTERM and SIGHUP: remove this process's temporaries, then end with status
    128 + the signal number.

    Most commands end right here: an exception raised from a signal handler may land inside
    a native call (Mitsuba, Dr.Jit), where it can crash the process.  ``batch`` waits in
    Python for its workers, so it is given a SystemExit and stops them through its
    ``finally`` clauses; :func:`main` recognises that exit by the recorded signal even if a
    native call changed its type.  Further signals are ignored while the cleanup runs."""
    import signal

    from ..io.outputs import discard_temporaries

    signal.signal(signum, signal.SIG_IGN)
    _signalled.append(signum)
    discard_temporaries()
    if _command[0] not in _GRACEFUL:
        print(f"gshade: terminated by signal {signum}", file=sys.stderr, flush=True)
        os._exit(128 + signum)
    raise SystemExit(128 + signum)


_command = [""]


def main(argv: list[str] | None = None) -> int:
    """Run ``gshade`` with ``argv`` (default: the process's arguments); the exit status."""
    import signal

    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 0
    _command[0] = args.command
    for sig in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, _terminated)
    from ..runtime.own_process import configure_own_process

    configure_own_process()  # this process is gshade's (its heap, Mitsuba's variants)
    import numpy as np

    # floating-point trouble is found by explicit checks (finite inputs, finite images) and
    # reported in one line: numpy's own warnings would only add lines before it
    np.seterr(all="ignore")
    with _caches_off(getattr(args, "no_cache", False)):
        return _run(args)


@contextlib.contextmanager
def _caches_off(off: bool) -> Iterator[None]:
    """With ``off`` (``--no-cache``), ``GSHADE_CACHE_DIR=off`` in the environment while the
    command runs (its workers and the CAD kernel's processes inherit it), as it was after."""
    if not off:
        yield
        return
    before = os.environ.get(CACHE_VARIABLE)
    os.environ[CACHE_VARIABLE] = "off"
    try:
        yield
    finally:
        if before is None:
            os.environ.pop(CACHE_VARIABLE, None)
        else:
            os.environ[CACHE_VARIABLE] = before


def _run(args: argparse.Namespace) -> int:
    """The subcommand, its errors and signals turned into exit statuses (see the module)."""
    _prestart_cad_kernel(args)
    try:
        return args.run(args)
    except GshadeError as exc:
        # the library names its parameters; here they are the flags that set them
        scene = getattr(args, "scene", None)
        message = in_flags(str(exc), str(Path(scene)) if scene else "")
        print(f"gshade: error: {printable(message)}", file=sys.stderr)  # one line, shown
        return getattr(args, "error_status", 2)
    except KeyboardInterrupt:  # outputs are written atomically: nothing partial is left
        print("gshade: interrupted", file=sys.stderr)
        return 130
    except BaseException:
        if _signalled:  # the signal's SystemExit, perhaps changed by the native call it hit
            print(f"gshade: terminated by signal {_signalled[0]}", file=sys.stderr)
            return 128 + _signalled[0]
        raise


def _prestart_cad_kernel(args: argparse.Namespace) -> None:
    """Given a CAD file to read, start the kernel's zygote now: it loads the kernel's
    libraries while this process loads its own (:func:`gshade.cad.zygote.prestart`);
    not for files whose reads are cached (:func:`gshade.cad.cache.cached`: the kernel
    may not be needed at all)."""
    from ..cad import CAD_EXTENSIONS

    given = [getattr(args, "scene", None), *(getattr(args, "scenes", None) or [])]
    cad = [p for p in given if isinstance(p, str) and Path(p).suffix.lower() in CAD_EXTENSIONS]
    if cad:
        from ..cad.cache import cached

        if all(cached(p) for p in cad):
            return
        from ..cad.zygote import prestart

        prestart()


def console() -> None:
    """The ``gshade`` command: run, flush, and leave without the interpreter's finalisation.

    Everything is written and closed by then; tearing down Mitsuba's JIT, its threads and the
    modules would only delay every command.
    """
    try:
        status = main()
        sys.stdout.flush()
    except BrokenPipeError:  # e.g. `gshade continuity … | head`: the reader left early
        status = 0
    except SystemExit as exc:  # a signal (see _terminated), or argparse
        status = exc.code if isinstance(exc.code, int) else 2
    try:
        sys.stderr.flush()
    except BrokenPipeError:
        pass
    os._exit(status)


if __name__ == "__main__":  # pragma: no cover
    console()
