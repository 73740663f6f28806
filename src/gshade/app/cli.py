"""The ``gshade`` command line.

Exit statuses: 0 success, 2 bad input (one line on stderr naming the file, the key or line,
what was expected and what was found; never a traceback), 130 after Ctrl-C, 128 + the signal
after SIGTERM or SIGHUP.  ``compare`` keeps idiff's statuses (0 pass, 1 warning, 2 failure,
3 size or channel mismatch, 4 unreadable file) and gives usage errors 5.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any, NoReturn

from .. import __version__
from ..errors import GshadeError

__all__ = ["console", "main"]


class _SubcommandParser(argparse.ArgumentParser):
    """A subcommand's parser; with ``usage_status``, its argument errors (``--fail abc``, a
    missing or an unrecognised argument) are one line ``PROG: error: ...`` and that exit
    status (``gshade compare``: 5, apart from idiff's 0-4) instead of usage and status 2."""

    def __init__(self, *args: Any, usage_status: int | None = None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.usage_status = usage_status

    def error(self, message: str) -> NoReturn:
        if self.usage_status is None:
            super().error(message)
        print(f"{self.prog}: error: {message}", file=sys.stderr)
        sys.exit(self.usage_status)

    def parse_known_args(
        self, args: Iterable[str] | None = None, namespace: Any = None
    ) -> tuple[Any, list[str]]:
        given = None if args is None else list(args)  # as argparse itself takes them
        namespace, extras = super().parse_known_args(given, namespace)
        if extras and self.usage_status is not None:  # they would reach the main parser: 2
            self.error(f"unrecognized arguments: {' '.join(extras)}")
        return namespace, extras


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gshade",
        description="Render the shape quality of parametric surfaces (Kiciak's shape functions).",
    )
    parser.add_argument("--version", action="version", version=f"gshade {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_SubcommandParser)
    shapes = sub.add_parser("shapes", help="list the shape functions, their order and parameters")
    shapes.set_defaults(run=_shapes)
    keys = sub.add_parser(
        "keys", help="list the scene files' keys: types, ranges, defaults, meanings"
    )
    keys.set_defaults(run=_keys)

    render = sub.add_parser("render", help="render a scene file to EXR (and PNG)")
    render.add_argument("scene", help="scene file (TOML)")
    render.add_argument("-o", "--output", help="EXR file (default: <scene name>.exr here)")
    render.add_argument("--png", help="also write this PNG (sRGB)")
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
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override any scene key, e.g. --set shape.period=0.05 (repeatable)",
    )
    render.set_defaults(run=_render)

    cmp = sub.add_parser(
        "compare",
        help="compare an EXR with a reference (exit 0 pass, 1 warning, 2 failure, "
        "3 size or channel mismatch, 4 unreadable file, 5 usage error)",
        description="Compare an EXR with a reference, as OpenImageIO's idiff does. Exit "
        "status: 0 pass, 1 warning, 2 failure (the images differ), 3 size or channel "
        "mismatch, 4 unreadable file (idiff's), 5 usage error (a bad argument, a "
        "difference image that cannot be written).",
        usage_status=5,
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
    cmp.add_argument("--json", action="store_true", help="print the metrics as JSON")
    cmp.set_defaults(run=_compare)

    chk = sub.add_parser(
        "check", help="render scenes at their check settings and diff them with references"
    )
    chk.add_argument("scenes", nargs="*", help="scene files or folders (default: scenes/)")
    chk.add_argument("--references", default="references", help="reference folder")
    chk.add_argument("--report", help="write report.html and summary.json into this folder")
    chk.add_argument(
        "--update", action="store_true", help="write references for new and failing scenes"
    )
    chk.add_argument("--update-all", action="store_true", help="write every reference")
    chk.add_argument(
        "--statistical",
        action="store_true",
        help="render each scene several times and compare by a z-test against the "
        "reference's variances (for noisy lit renders)",
    )
    chk.set_defaults(run=_check)

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
    bat.set_defaults(run=_batch)

    fig = sub.add_parser("figure", help="a multi-panel figure from a figure spec")
    fig.add_argument("spec", help="figure spec (TOML)")
    fig.add_argument("-o", "--output", required=True, help="OUT.png, OUT.pdf or OUT.svg")
    fig.set_defaults(run=_figure)

    cont = sub.add_parser("continuity", help="measure and classify the patch junctions")
    cont.add_argument("scene", help="scene file (TOML)")
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
    cont.set_defaults(run=_continuity)

    info = sub.add_parser("info", help="describe a scene's surfaces")
    info.add_argument("scene", help="scene file (TOML)")
    info.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    info.set_defaults(run=_info)
    return parser


def _scene_overrides(args: argparse.Namespace) -> dict:
    from ..scene import parse_overrides

    overrides = parse_overrides(args.set)
    for key in ("width", "height", "spp", "variant", "junctions"):
        value = getattr(args, key, None)
        if value is not None:
            overrides[f"render.{key}"] = value
    return overrides


def _render(args: argparse.Namespace) -> int:
    from ..io.outputs import output_file, staged, write_to
    from ..rendering import render
    from ..scene import load_scene

    scene = load_scene(args.scene, _scene_overrides(args))
    output = Path(args.output) if args.output else output_file(".", scene.name, ".exr")
    targets = [output] + ([Path(args.png)] if args.png else [])
    # the outputs' temporaries are made first: an unwritable target fails before rendering,
    # and the targets change only once every file is written
    with staged(targets) as names:
        image = render(scene)
        writers = [image.exr_writer(output)] + ([image.png_writer(args.png)] if args.png else [])
        for target, writer, name in zip(targets, writers, names, strict=True):
            write_to(name, writer, target)
    print(
        f"{output}: {image.shape[1]}x{image.shape[0]}, {image.metadata['variant']}, "
        f"{image.metadata['legend']}"
    )
    return 0


def _compare(args: argparse.Namespace) -> int:
    """``gshade compare``: 0 pass, 1 warning, 2 failure (the images differ), 3 size or
    channel mismatch, 4 unreadable file (idiff's statuses), 5 usage error (bad thresholds or
    channels, a difference image that cannot be written: found before comparing)."""
    import json

    from ..regression.comparison import EXIT_STATUS, ChannelMismatch, Thresholds, UnreadableImage
    from ..regression.diff_images import compare_and_write_diffs

    try:
        try:
            thresholds = Thresholds(
                args.fail, args.failpercent, args.hardfail, args.warn, args.warnpercent
            )
        except GshadeError as exc:  # "fail: expected ..." names the option
            raise GshadeError(f"--{exc}") from None
        channels = [c.strip() for c in args.channels.split(",") if c.strip()]
        if not channels:
            raise GshadeError(
                f"--channels: expected channel names such as R,G,B, got {args.channels!r}"
            )
        result = compare_and_write_diffs(
            args.test,
            args.reference,
            channels=channels,
            thresholds=thresholds,
            diff=args.diff,
            diff_png=args.diff_png,
            only_if_not_pass=args.diff_on_fail,
        )
    except UnreadableImage as exc:
        print(f"gshade: error: {exc}", file=sys.stderr)
        return EXIT_STATUS["UNREADABLE"]
    except ChannelMismatch as exc:
        print(f"gshade: error: {exc}", file=sys.stderr)
        return EXIT_STATUS["MISMATCH"]
    except GshadeError as exc:  # a bad argument, an output that cannot be written
        print(f"gshade: error: {_in_flags(str(exc))}", file=sys.stderr)
        return EXIT_STATUS["USAGE"]
    if args.json:
        print(json.dumps(result.as_dict(), indent=2))
    else:
        for name, m in {**result.per_channel, **result.per_group}.items():
            at = f" at ({m.max_at[0]}, {m.max_at[1]})" if m.max_at else ""
            print(
                f"  {name:>6}: max {m.max_error:.6g}{at}, mean {m.mean_error:.6g}, "
                f"RMSE {m.rmse:.6g}, PSNR {m.psnr:.4g} dB (range {m.data_range:.4g})"
            )
        print(result.summary())
    return result.exit_status


def _check(args: argparse.Namespace) -> int:
    from ..regression.check import check, find_scenes, write_report

    scenes = find_scenes(args.scenes)
    if args.report:  # an unusable report folder fails before any scene renders
        try:
            Path(args.report).mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise GshadeError(
                f"--report {args.report}: cannot create the folder ({exc.strerror})"
            ) from None
    results = check(
        scenes,
        Path(args.references),
        update=args.update,
        update_all=args.update_all,
        statistical=args.statistical,
        progress=lambda r: print(r.line(), flush=True),
    )
    if args.report:
        report = write_report(results, Path(args.report))
        print(f"report: {report}")
    failed = [r for r in results if not r.ok]
    written = sum(bool(r.written) for r in results)
    print(
        f"{len(results) - len(failed)} passed, {len(failed)} failed"
        + (f" ({written} references written)" if written else "")
    )
    return 0 if not failed else 2


def _batch(args: argparse.Namespace) -> int:
    from .batch import check_options, expand_scenes, parse_sweeps, plan_jobs, run_batch

    check_options(args.jobs, args.timeout, args.scheduler)  # before anything is read or made
    jobs = plan_jobs(expand_scenes(args.scenes), parse_sweeps(args.sweep))
    results = run_batch(
        jobs,
        args.output,
        workers=args.jobs,
        force=args.force,
        scheduler=args.scheduler,
        timeout=args.timeout,
    )
    failed = [r for r in results if r.status == "failed"]
    for r in failed:
        name = r.name if len(r.name) <= 80 else r.name[:79] + "…"
        print(f"failed: {name} ({r.scene}): {r.message} [log: {r.log}]", file=sys.stderr)
    counts = {s: sum(r.status == s for r in results) for s in ("rendered", "up to date")}
    print(
        f"{counts['rendered']} rendered, {counts['up to date']} up to date, "
        f"{len(failed)} failed; manifest: {Path(args.output) / 'manifest.json'}"
    )
    return 0 if not failed else 2


def _figure(args: argparse.Namespace) -> int:
    from .figure import load_figure_spec, make_figure

    path = make_figure(load_figure_spec(args.spec), args.output)
    print(f"{path}")
    return 0


def _parse_pair(text: str) -> tuple[int, str, int, str]:
    """'0:u1,1:u0' -> (0, 'u1', 1, 'u0')."""
    try:
        (i, si), (j, sj) = (part.split(":") for part in text.split(","))
        return int(i), si.strip(), int(j), sj.strip()
    except ValueError:
        raise GshadeError(
            f"--pair: expected I:SIDE,J:SIDE such as 0:u1,1:u0 (SIDE one of u0 u1 v0 v1), "
            f"got {text!r}"
        ) from None


def _continuity(args: argparse.Namespace) -> int:
    import json

    import numpy as np

    from ..analysis.continuity import Tolerances, continuity_report
    from ..scene import load_scene

    scene = load_scene(args.scene, _scene_overrides(args))
    patches = list(scene.patches)
    pts = np.concatenate([p(*p.parameter_grid(9, 9)).reshape(-1, 3) for p in patches])
    tol = Tolerances.for_size(
        float(np.linalg.norm(np.ptp(pts, axis=0))),
        g0=args.tol_g0,
        g1=args.tol_g1,
        g2=args.tol_g2,
        g3=args.tol_g3,
    )
    pairs = [_parse_pair(text) for text in args.pair] if args.pair else None
    try:
        report = continuity_report(patches, samples=args.samples, tolerances=tol, pairs=pairs)
    except GshadeError as exc:  # about the scene's surfaces, or about a flag
        message = _in_flags(str(exc))
        where = "" if message.startswith("-") else f"{args.scene}: "
        raise GshadeError(where + message) from None
    if args.json:
        print(
            json.dumps(
                {"junctions": [j.as_dict() for j in report], "tolerances": tol.__dict__}, indent=2
            )
        )
        return 0
    print(
        f"{'patches':>10}  {'sides':>7}  class  {'gap':>9}  {'angle(deg)':>10}  "
        f"{'curv.jump':>9}  {'grad.jump':>9}"
    )
    for j in report:
        print(
            f"{j.patches[0]:>4} {j.patches[1]:>4}  {j.sides[0]}-{j.sides[1]}  {j.cls:>5}  "
            f"{j.gap:9.2e}  {j.normal_angle_deg:10.3e}  {j.curvature_jump:9.2e}  "
            f"{j.curvature_gradient_jump:9.2e}"
        )
    counts = {c: sum(j.cls == c for j in report) for c in ("G3", "G2", "G1", "G0", "none")}
    summary = ", ".join(f"{n} {c}" for c, n in counts.items() if n)
    print(f"{len(report)} junctions" + (f": {summary}" if summary else ""))
    return 0


def _info(args: argparse.Namespace) -> int:
    import numpy as np

    from ..geometry import irregular_mask
    from ..scene import load_scene

    scene = load_scene(args.scene, _scene_overrides(args))
    print(f"scene {scene.name} ({scene.path})")
    points = []
    for k, surface in enumerate(scene.surfaces):
        kinds: dict[str, int] = {}
        for patch in surface.patches:
            degree = getattr(patch, "degree", None)
            label = type(patch).__name__ + (f" degree {tuple(degree)}" if degree else "")
            label += " rational" if getattr(patch, "rational", False) else ""
            kinds[label] = kinds.get(label, 0) + 1
        summary = ", ".join(f"{n} x {label}" for label, n in kinds.items())
        print(f"  surface {k} ({surface.kind}, {surface.source}): {summary}")
    index = 0
    irregular = []
    for patch in scene.patches:
        u, v = patch.parameter_grid(17, 17)
        d = patch.derivatives(u, v, 1)
        points.append(d[0, 0].reshape(-1, 3))
        mask = irregular_mask(d)
        if mask.any():
            edges = [
                name
                for name, sel in (
                    ("u0", mask[0]),
                    ("u1", mask[-1]),
                    ("v0", mask[:, 0]),
                    ("v1", mask[:, -1]),
                )
                if sel.all()
            ]
            irregular.append(
                f"patch {index}: "
                + (
                    ", ".join(f"collapsed edge {e}" for e in edges)
                    or f"{int(mask.sum())} sample points"
                )
            )
        index += 1
    pts = np.concatenate(points)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    print(f"  patches: {index}")
    print(
        f"  bounding box: [{', '.join(f'{x:.6g}' for x in lo)}] .. "
        f"[{', '.join(f'{x:.6g}' for x in hi)}]"
    )
    print("  irregular points:" + ("" if irregular else " none"))
    for line in irregular:
        print(f"    {line}")
    return 0


def _keys(args: argparse.Namespace) -> int:
    from ..scene.keys import scene_keys

    print(scene_keys())
    return 0


def _shapes(args: argparse.Namespace) -> int:
    from ..shape import SHAPE_FUNCTIONS

    for fn in SHAPE_FUNCTIONS.values():
        flags = ", eye-dependent" if fn.eye_dependent else ""
        print(f"{fn.name}  (order {fn.order}{flags})")
        print(f"    {fn.summary}")
        for name, p in fn.parameters.items():
            default = p.default if p.kind != "choice" else f"{p.default} ({'|'.join(p.choices)})"
            print(f"    {name} = {default}: {p.help}")
    return 0


#: Library parameters as the command line spells them: library errors name parameters, the
#: command line speaks of its flags.
_FLAGS = {
    "samples": "--samples",
    "pairs": "--pair",
    **{f"tolerance {order}": f"--tol-{order}" for order in ("g0", "g1", "g2", "g3")},
    "workers": "-j",
    "timeout": "--timeout",
    "scheduler": "--scheduler",
    "diff and diff_png": "--diff and --diff-png",
}


def _in_flags(message: str) -> str:
    """A library error that begins with a parameter's name, with the flag's name instead."""
    for name, flag in _FLAGS.items():
        if message.startswith((f"{name}:", f"{name} ")):
            return flag + message[len(name) :]
    return message


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
    import signal

    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 0
    _command[0] = args.command
    for sig in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, _terminated)
    import numpy as np

    # floating-point trouble is found by explicit checks (finite inputs, finite images) and
    # reported in one line: numpy's own warnings would only add lines before it
    np.seterr(all="ignore")
    try:
        return args.run(args)
    except GshadeError as exc:
        message = _in_flags(str(exc)).replace("\r", "\\r").replace("\n", "\\n")  # one line
        print(f"gshade: error: {message}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # outputs are written atomically: nothing partial is left
        print("gshade: interrupted", file=sys.stderr)
        return 130
    except BaseException:
        if _signalled:  # the signal's SystemExit, perhaps changed by the native call it hit
            print(f"gshade: terminated by signal {_signalled[0]}", file=sys.stderr)
            return 128 + _signalled[0]
        raise


def console() -> None:
    """The ``gshade`` command: run, flush, and leave without the interpreter's finalisation.

    Everything is written and closed by then; tearing down Mitsuba's JIT, its threads and the
    modules would add about 0.4 s to every command (measured), for nothing.
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
