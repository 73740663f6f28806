"""The ``gshade`` subcommands, one function each: render, info, continuity, shapes, keys,
compare, check, batch, figure and view.

Each takes the parsed arguments (:func:`gshade.app.cli.build_parser`) and returns the exit
status.  Bad input raises a GshadeError, which :func:`gshade.app.cli.main` reports in one
line in the command line's words (:mod:`gshade.app.flags`).  Everything a command needs is
imported when it runs, so that ``gshade --help`` starts at once.  Every line printed goes
through :func:`gshade.app.terminal.say` (names and messages with their control characters
escaped).  No output may replace an input or another output
(:func:`gshade.io.outputs.distinct_files`): that is refused before anything is written.
"""

from __future__ import annotations

import argparse
import sys
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

from .. import __version__
from ..errors import GshadeError, show
from .flags import in_flags, parameter
from .terminal import printable, say

if TYPE_CHECKING:
    from ..analysis.continuity import Junction
    from ..regression.check import CheckResult
    from ..scene.model import Scene

__all__ = [
    "batch",
    "check",
    "compare",
    "continuity",
    "figure",
    "info",
    "keys",
    "render",
    "shapes",
    "view",
]


def _scene_overrides(args: argparse.Namespace) -> dict:
    """The overrides of ``--set`` and of the render flags (``--width`` ...)."""
    from ..scene import parse_overrides

    overrides = parse_overrides(args.set)
    for key in ("width", "height", "spp", "variant", "junctions", "parabolic", "combs"):
        value = getattr(args, key, None)
        if value is not None:
            overrides[f"render.{key}"] = value
    aovs = getattr(args, "aovs", None)
    if aovs is not None:
        overrides["render.aovs"] = [n.strip() for n in aovs.split(",") if n.strip()]
    return overrides


# --------------------------------------------------------------------------- scenes


def render(args: argparse.Namespace) -> int:
    """``gshade render``: the EXR (and PNG), written together once both are complete."""
    from ..io.outputs import distinct_files, output_file, staged, write_all
    from ..rendering import render as render_scene
    from ..scene import load_scene

    if args.legend and not args.png:
        raise GshadeError("--legend: draws the legend under the PNG; expected --png too")
    scene = load_scene(args.scene, _scene_overrides(args), strict=args.strict)
    output = Path(args.output) if args.output else output_file(".", scene.name, ".exr")
    html = args.html
    targets = [output] + ([Path(args.png)] if args.png else []) + ([Path(html)] if html else [])
    distinct_files(
        [("the scene file", args.scene)] + [("the data file", f) for f in scene.data_files],
        [("-o" if args.output else "the EXR", output), ("--png", args.png), ("--html", html)],
    )
    # the outputs' temporaries are made first: an unwritable target fails before rendering,
    # and the targets change only once every file is written
    with staged(targets) as names:
        image = render_scene(scene)
        writers = [partial(image.exr_writer, output)]
        if args.png:
            writers.append(partial(image.png_writer, args.png, legend=args.legend))
        if html:  # the page of the EXR's channels and header, as `gshade view` makes it
            from ..display.html_view import view_writer

            page = [(image.channels, image.metadata)]
            writers.append(partial(view_writer, page, html, labels=[output.name]))
        write_all(list(zip(names, writers, targets, strict=True)))
    _tell(image.notes, image.warnings)
    if args.json:
        import json

        listed = {
            "output": str(output),
            "png": args.png,
            "html": html,
            "width": image.shape[1],
            "height": image.shape[0],
            "variant": image.metadata["variant"],
            "legend": image.metadata["legend"],
            **json.loads(image.metadata["statistics"]),
        }
        if "combs" in image.metadata:
            listed["combs"] = json.loads(image.metadata["combs"])
        print(json.dumps(listed, indent=2, allow_nan=False))
        return 0
    say(
        f"{output}: {image.shape[1]}x{image.shape[0]}, {image.metadata['variant']}, "
        f"{image.metadata['legend']}"
    )
    return 0


def _tell(notes: list[str], warnings: list[str]) -> None:
    """The notes (what the kernel's healing changed) and warnings (CAD faces left out), a
    line each on stderr."""
    for line in notes:
        say(f"gshade: note: {line}", file=sys.stderr)
    for line in warnings:
        say(f"gshade: warning: {line}", file=sys.stderr)


def _cad_notes(scene: Scene) -> tuple[list[str], list[str]]:
    """The notes and warnings of a scene's CAD models once read (:func:`_tell`)."""
    from ..rendering.pipeline import cad_notes, left_out_faces

    notes = [f"{path}: {line}" for path, line in cad_notes(scene)]
    return notes, [f"{path}: {face.line()}" for path, face in left_out_faces(scene)]


def info(args: argparse.Namespace) -> int:
    """``gshade info``: the surfaces, patch count, bounding box and irregular points."""

    from ..geometry import irregular_mask
    from ..geometry.core.patch import EXTENT_GRID
    from ..rendering.sizing import extent_points
    from ..scene import load_scene

    scene = load_scene(args.scene, _scene_overrides(args), strict=args.strict)
    _tell(*_cad_notes(scene))
    say(f"scene {scene.name} ({scene.path})")
    for k, surface in enumerate(scene.surfaces):
        kinds: dict[str, int] = {}
        for patch in surface.patches:
            degree = getattr(patch, "degree", None)
            label = type(patch).__name__ + (f" degree {tuple(degree)}" if degree else "")
            label += " rational" if getattr(patch, "rational", False) else ""
            kinds[label] = kinds.get(label, 0) + 1
        summary = ", ".join(f"{n} x {label}" for label, n in kinds.items())
        say(f"  surface {k} ({surface.kind}, {surface.source}): {summary}")
        for line in surface.body.info_lines():
            say(f"    {line}")
    irregular = []
    index = 0
    for surface in scene.surfaces:
        numbers = surface.body.patch_numbers(index, len(surface.patches))
        for patch, number in zip(surface.patches, numbers, strict=True):
            u, v = patch.parameter_grid(EXTENT_GRID, EXTENT_GRID)
            mask = irregular_mask(patch.derivatives(u, v, 1))
            if mask.any():
                sides = (("u0", mask[0]), ("u1", mask[-1]), ("v0", mask[:, 0]), ("v1", mask[:, -1]))
                edges = [name for name, sel in sides if sel.all()]
                where = ", ".join(f"collapsed edge {e}" for e in edges)
                label = surface.body.patch_label
                irregular.append(
                    f"{label} {number}: " + (where or f"{int(mask.sum())} sample points")
                )
            index += 1
    # the extent the camera frames (a CAD face's trimmed region, not its patch's box)
    pts = extent_points(scene)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    say(f"  patches: {index}")
    say(
        f"  bounding box: [{', '.join(f'{x:.6g}' for x in lo)}] .. "
        f"[{', '.join(f'{x:.6g}' for x in hi)}]"
    )
    say("  irregular points:" + ("" if irregular else " none"))
    for line in irregular:
        say(f"    {line}")
    if args.stats:
        _say_statistics(scene)
    return 0


def _say_statistics(scene: Scene) -> None:
    """``gshade info --stats``: the shape function's numbers over the whole surface."""
    from ..rendering.pipeline import shape_statistics

    numbers = shape_statistics(scene)
    label, surface = numbers["patch_label"], numbers["surface"]
    say(f"  {numbers['function']} over the whole surface:" + ("" if surface else " no value"))
    if surface is None:
        return
    for name in ("min", "max"):
        e = surface[name]
        point = ", ".join(f"{x:.6g}" for x in e["point"])
        where = f"{label} {e['patch']}, u {e['u']:.6g}, v {e['v']:.6g}"
        say(f"    {name} {e['value']:.6g} at [{point}] ({where})")
    say(f"    mean {surface['mean']:.6g} (by area)")
    percentiles = ", ".join(f"{k}% {v:.6g}" for k, v in surface["percentiles"].items())
    say(f"    percentiles: {percentiles}")
    radius = numbers.get("min_radius")
    if radius is not None:
        value = "none (flat)" if radius["value"] is None else f"{radius['value']:.6g}"
        say(f"    smallest radius {value} ({radius['side']}, {label} {radius['patch']})")


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


def continuity(args: argparse.Namespace) -> int:
    """``gshade continuity``: every junction's measurements and class, as a table or JSON."""
    import json

    from ..analysis.continuity import Tolerances, continuity_report, validate_samples
    from ..analysis.scene_junctions import scene_continuity, scene_diagonal, unmeasured_edges
    from ..scene import load_scene

    validate_samples(args.samples)  # before the scene (and a CAD file) is read
    scene = load_scene(args.scene, _scene_overrides(args), strict=args.strict)
    _tell(*_cad_notes(scene))
    patches = list(scene.patches)
    unmeasured: list[dict] = []
    tol = Tolerances.for_size(
        scene_diagonal(scene), g0=args.tol_g0, g1=args.tol_g1, g2=args.tol_g2, g3=args.tol_g3
    )
    pairs = [_parse_pair(text) for text in args.pair] if args.pair else None
    if pairs and any(s.body.patch_label != "patch" for s in scene.surfaces):
        raise GshadeError("--pair: names patch sides; a CAD scene's junctions are B-rep edges")
    try:
        if pairs:
            report = continuity_report(patches, samples=args.samples, tolerances=tol, pairs=pairs)
        else:
            report, _ = scene_continuity(scene, samples=args.samples, tolerances=tol)
            unmeasured = unmeasured_edges(scene)
    except GshadeError as exc:  # about a parameter (a flag), or about the scene's surfaces
        if parameter(str(exc)) is not None:
            raise
        raise GshadeError(f"{args.scene}: {exc}") from None
    if args.json:
        listed: dict = {"junctions": [j.as_dict() for j in report], "tolerances": tol.__dict__}
        if unmeasured:
            listed["not_measured"] = unmeasured
        print(json.dumps(listed, indent=2))
        return 0
    print(
        f"{'patches':>10}  {'sides':>7}  class  {'gap':>9}  {'angle(deg)':>10}  "
        f"{'curv.jump':>9}  {'grad.jump':>9}  where (t; x y z of the deciding measure's largest)"
    )
    for j in report:
        if j.knot is not None:  # a B-spline's interior knot line, e.g. u=0.5
            where = j.knot.label()
        else:
            where = f"{j.sides[0]}-{j.sides[1]}" if j.sides else f"e{j.edge:<6}"
        say(
            f"{j.patches[0]:>4} {j.patches[1]:>4}  {where}  {j.cls:>5}  "
            f"{j.gap:9.2e}  {j.normal_angle_deg:10.3e}  {j.curvature_jump:9.2e}  "
            f"{j.curvature_gradient_jump:9.2e}{_largest_at(j)}"
        )
    for edge in unmeasured:  # beside a face left out
        i, j = edge["faces"]
        say(f"{i:>4} {j:>4}  e{edge['edge']:<6}  not measured ({edge['why']})")
    counts = {c: sum(j.cls == c for j in report) for c in ("G3", "G2", "G1", "G0", "none")}
    summary = ", ".join(f"{n} {c}" for c, n in counts.items() if n)
    lost = f"; {len(unmeasured)} edges not measured" if unmeasured else ""
    say(f"{len(report)} junctions" + (f": {summary}" if summary else "") + lost)
    return 0


def _largest_at(j: Junction) -> str:
    """The table's last column: where the measure deciding the class is largest."""
    from ..analysis.junction_lines import deciding_place

    at = deciding_place(j)
    if not at:
        return ""
    return f"  t={at['at_t']:.4f}; {at['at_x']:.6g} {at['at_y']:.6g} {at['at_z']:.6g}"


# --------------------------------------------------------------------------- references


def shapes(args: argparse.Namespace) -> int:
    """``gshade shapes``: the shape functions, their order and parameters."""
    from ..shape import SHAPE_FUNCTIONS

    for fn in SHAPE_FUNCTIONS.values():
        flags = ", eye-dependent" if fn.eye_dependent else ""
        print(f"{fn.name}  (order {fn.order}{flags})")
        print(f"    {fn.summary}")
        for name, p in fn.parameters.items():
            default = p.default if p.kind != "choice" else f"{p.default} ({'|'.join(p.choices)})"
            print(f"    {name} = {default}: {p.help}")
    return 0


def keys(args: argparse.Namespace) -> int:
    """``gshade keys``: the scene files' keys."""
    from ..scene.keys import scene_keys

    print(scene_keys())
    return 0


# --------------------------------------------------------------------------- comparisons


def compare(args: argparse.Namespace) -> int:
    """``gshade compare``: 0 pass, 1 warning, 2 failure (the images differ), 3 size or
    channel mismatch, 4 unreadable file (idiff's statuses).  A usage error (bad thresholds
    or channels, a difference image that cannot be written: found before comparing) is
    raised, for :func:`gshade.app.cli.main` to report with status 5."""
    import json

    from ..io.outputs import distinct_files
    from ..regression.comparison import EXIT_STATUS, ChannelMismatch, Thresholds, UnreadableImage
    from ..regression.diff_images import compare_and_write_diffs

    thresholds = Thresholds(args.fail, args.failpercent, args.hardfail, args.warn, args.warnpercent)
    channels = [c.strip() for c in args.channels.split(",") if c.strip()]
    if not channels:
        raise GshadeError(
            f"--channels: expected channel names such as R,G,B, got {args.channels!r}"
        )
    # a difference image may not replace an image compared, nor the other one (usage
    # errors: status 5)
    diffs = [("--diff", args.diff), ("--diff-png", args.diff_png)]
    distinct_files(
        [("TEST.exr", args.test), ("REF.exr", args.reference)], diffs, among_outputs=False
    )
    try:
        distinct_files([], diffs)
    except GshadeError:
        raise GshadeError(
            f"--diff and --diff-png: expected two different files, got {args.diff} and "
            f"{args.diff_png}"
        ) from None
    try:
        result = compare_and_write_diffs(
            args.test,
            args.reference,
            channels=channels,
            thresholds=thresholds,
            diff=args.diff,
            diff_png=args.diff_png,
            only_if_not_pass=args.diff_on_fail,
            ssim=args.ssim,
        )
    except UnreadableImage as exc:
        say(f"gshade: error: {exc}", file=sys.stderr)
        return EXIT_STATUS["UNREADABLE"]
    except ChannelMismatch as exc:
        say(f"gshade: error: {exc}", file=sys.stderr)
        return EXIT_STATUS["MISMATCH"]
    if args.json:
        # non-finite metrics are null (as_dict): the output is always strict JSON
        print(json.dumps(result.as_dict(), indent=2, allow_nan=False))
    else:
        for name, m in {**result.per_channel, **result.per_group}.items():
            at = f" at ({m.max_at[0]}, {m.max_at[1]})" if m.max_at else ""
            say(
                f"  {name:>6}: max {m.max_error:.6g}{at}, mean {m.mean_error:.6g}, "
                f"RMSE {m.rmse:.6g}, PSNR {m.psnr:.4g} dB (range {m.data_range:.4g})"
            )
        v = result.all_values
        if v is not None:
            say(
                f"  values: mean {v.mean_error:.6g}, RMSE {v.rmse:.6g}, PSNR {v.psnr:.4g} dB "
                f"(peak {v.peak:.4g}; over all {v.values} pixel values, as idiff)"
            )
        say(result.summary())
    return result.exit_status


def check(args: argparse.Namespace) -> int:
    """``gshade check``: one line per scene as it is checked, then the counts (and the report
    and JUnit XML files, if asked); 2 if any scene failed.

    Everything that can be refused is refused before anything is made: scenes not found, a
    missing reference folder without ``--update``, a ``--junit`` or ``--report`` that cannot
    be written or would replace an input (a scene file, a reference) or each other, a
    ``--report`` folder whose ``views`` is a symbolic link.  The folders made for them are
    removed again if the command fails."""
    from dataclasses import replace

    from ..io.output_folders import created_folders, missing_folders, output_folder
    from ..io.outputs import check_target, confined, distinct_files, staged, write_to
    from ..regression.check import check as check_scenes
    from ..regression.check import find_scenes, missing_references
    from ..regression.junit import junit_writer
    from ..regression.report import write_report

    scenes = find_scenes(args.scenes)
    references = Path(args.references)
    missing_references(references, update=args.update or args.update_all)
    junit = Path(args.junit) if args.junit else None
    report = Path(args.report) if args.report else None
    folders: list[Path] = []
    if junit is not None:  # its folder is made if need be, as --report's
        folders += missing_folders(
            junit.parent, f"--junit {args.junit}: cannot create the folder {junit.parent}"
        )
        check_target(junit)
    pages = []
    if report is not None:
        folders += missing_folders(report, f"--report {args.report}: cannot create the folder")
        output_folder(report, "views", create=False)  # not a link (nothing is made yet)
        pages = [report / "report.html", report / "summary.json"]
        for page in pages:
            check_target(page)
    inputs = [("the scene file", scene) for scene in scenes]
    if references.is_dir():  # the references compared (--junit refs/ball.exr)
        inputs += [("the reference", ref) for ref in sorted(references.glob("*.exr"))]
    distinct_files(
        inputs,
        [("--junit", junit)] + [("--report", page) for page in pages],
    )
    report_error: GshadeError | None = None
    with created_folders(folders):
        # the JUnit file's temporary is made first: an unwritable --junit fails before
        # anything is rendered; the file is written whatever the scenes' verdicts (and even
        # if the report cannot be)
        with staged([junit] if junit else []) as names:

            def progress(result: CheckResult) -> None:
                result.message = in_flags(result.message)  # for the report too
                say(result.line(), flush=True)

            results = check_scenes(
                scenes,
                references,
                update=args.update,
                update_all=args.update_all,
                statistical=args.statistical,
                progress=progress,
            )
            written: Path | None = None
            if report is not None:
                # the report shows the scene files' paths as printable text (a name that
                # is not UTF-8 cannot be written into an HTML page)
                shown = [replace(r, scene=Path(printable(r.scene))) for r in results]
                try:
                    with confined(report):  # nothing through a link inside the folder
                        written = write_report(shown, report)
                except GshadeError as exc:
                    report_error = exc
                else:
                    say(f"report: {written}")
            for target, name in zip([junit] if junit else [], names, strict=True):
                write_to(name, junit_writer(results, report=written), target)
                say(f"JUnit XML: {target}")
        if report_error is not None:  # the folders made for it go, unless they hold files
            raise report_error
    failed = [r for r in results if not r.ok]
    updated = sum(bool(r.written) for r in results)
    say(
        f"{len(results) - len(failed)} passed, {len(failed)} failed"
        + (f" ({updated} references written)" if updated else "")
    )
    return 0 if not failed else 2


# --------------------------------------------------------------------------- many scenes


def batch(args: argparse.Namespace) -> int:
    """``gshade batch``: every job's outputs, the failures on stderr, then the counts; 2 if
    any job failed."""
    from .batch import expand_scenes, parse_sweeps, plan_jobs, run_batch, validate_batch_options

    validate_batch_options(
        args.jobs, args.timeout, args.scheduler
    )  # before anything is read or made
    from ..cad.process import kernel_time_limit

    with kernel_time_limit(args.timeout):  # a CAD file read to plan takes no longer than a job
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
    for r in results:
        for line in r.warnings:
            say(f"warning: {r.name}: {line}", file=sys.stderr)
    for r in failed:
        name = r.name if len(r.name) <= 80 else r.name[:79] + "…"
        say(f"failed: {name} ({r.scene}): {r.message} [log: {r.log}]", file=sys.stderr)
    counts = {s: sum(r.status == s for r in results) for s in ("rendered", "up to date")}
    say(
        f"{counts['rendered']} rendered, {counts['up to date']} up to date, "
        f"{len(failed)} failed; manifest: {Path(args.output) / 'manifest.json'}"
    )
    return 0 if not failed else 2


def view(args: argparse.Namespace) -> int:
    """``gshade view``: one self-contained HTML page of 1 to 3 EXRs; the images are read and
    checked before anything is written."""
    from ..display.html_view import view_writer
    from ..io.outputs import distinct_files, output_name, staged, write_to

    first = Path(args.images[0])
    output = Path(args.output) if args.output else Path(output_name(first.stem, "IMAGE") + ".html")
    distinct_files(
        [("IMAGE.exr", image) for image in args.images],
        [("-o" if args.output else "the page", output)],
    )
    try:
        writer = view_writer(args.images, output, title=args.title)
    except GshadeError as exc:  # the library's parameter is the command's IMAGE arguments
        raise GshadeError(str(exc).replace("images: ", "IMAGE.exr: ", 1)) from None
    with staged([output]) as (name,):
        write_to(name, writer, output)
    for note in writer.notes:  # a header attribute left out of the page
        say(f"gshade: warning: {note}", file=sys.stderr)
    say(
        f"{output}: {len(args.images)} image{'s' if len(args.images) > 1 else ''}, "
        f"{output.stat().st_size} bytes"
    )
    return 0


def lightbox(args: argparse.Namespace) -> int:
    """``gshade lightbox``: write the built-in studio map as an OpenEXR file."""
    from ..io.image import write_exr
    from ..io.outputs import check_target
    from ..rendering.environment_maps import lightbox as make_lightbox

    target = check_target(args.output)
    if target.suffix.lower() != ".exr":
        raise GshadeError(f"-o: expected a file name ending in .exr, got {show(str(target))}")
    try:
        rgb = make_lightbox(args.strips, args.strip_width, args.width)
    except GshadeError as exc:  # the library names its parameters; here they are flags
        text = str(exc)
        for name in ("strip_width", "strips", "width"):
            if text.startswith(f"{name}:"):
                raise GshadeError(f"--{name.replace('_', '-')}{text[len(name) :]}") from None
        raise
    header = {
        "gshade_version": __version__,
        "environment": f"lightbox: {args.strips} strips, {args.strip_width:g} deg wide",
        "convention": "column = atan2(y, x) / 2 pi W from +x towards +y; row = acos(z) / pi H",
    }
    path = write_exr(target, {c: rgb[..., k] for k, c in enumerate("RGB")}, header)
    say(f"{path}: {rgb.shape[1]}x{rgb.shape[0]} lat-long map, {header['environment']}")
    return 0


def figure(args: argparse.Namespace) -> int:
    """``gshade figure``: render the spec's panels and write the figure (which may not
    replace the spec or a row's scene file)."""
    from ..io.outputs import distinct_files
    from .figure import load_figure_spec, make_figure

    spec = load_figure_spec(args.spec)
    distinct_files(
        [("SPEC", args.spec)] + [("the row's scene file", row) for row in spec.rows],
        [("-o", args.output)],
    )
    path = make_figure(spec, args.output)
    say(f"{path}")
    return 0
