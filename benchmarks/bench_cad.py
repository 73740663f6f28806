"""Benchmark gshade on real CAD files, side by side with the peer (the kernel's mesh in PyVista).

For each shared model (``../shared/data/cad`` or the folder given; missing files are
skipped), whole processes, interleaved within each round (the order of gshade and the peer
alternating from round to round), a first round untimed (kernel caches: Dr.Jit's LLVM
kernels in ``~/.drjit``; the file cache), then ``--rounds`` timed rounds:

- gshade: ``gshade render FILE -o OUT.exr --width 1024 --height 768 --spp 16``, the default
  shape (lit isophote stripes), and the same with ``--set shape.function=mean`` (a colour
  map of the exact mean curvature);
- the peer (``benchmarks/cad_peer.py``): what a user would do otherwise: read the file with
  Open CASCADE (OCP), mesh it with ``BRepMesh_IncrementalMesh`` at gshade's deflection (its
  chord tolerance: 1e-3 of the bounding-box diagonal, at most half a pixel at the nearest
  point; the same angle, 0.5 rad), merge the nodes into one ``pyvista.PolyData``, take VTK's
  discrete mean curvature and plot it off-screen at 1024 x 768 through gshade's camera, to a
  PNG.  ``.3dm`` files: Rhino's stored render meshes (rhino3dm), or no peer.

Per process: wall time (start to exit), CPU time (user + system, ``RUSAGE_CHILDREN``
around the wait) and peak RSS (``ru_maxrss`` of ``os.wait4``).  Reported: medians and
min-max spreads, the median of the per-round ratios gshade / peer.  For the link rod, the
stages of gshade's render (a stage run per round: ``bench_render``'s in-process copy of the
command, ``RenderedImage.timings``) and of the peer.

Error of the peer's curvature (untimed, after the rounds): at the pixels of gshade's
mean-curvature EXR that are fully covered and whose 3 x 3 neighbourhood lies on one face,
the mesh's mean curvature interpolated linearly on the closest triangle at gshade's exact
point ``P``, against gshade's ``f`` there (the exact H, the mean over the pixel's samples).
Signs: gshade's H is signed w.r.t. the outward normal (positive where the surface bends away
from it, e.g. H = -1/r on a sphere); VTK's has the opposite convention on an outward
oriented mesh: the peer's sign is flipped once, for the whole model, by the sign of the
correlation (reported).  Error = |H_peer - H_exact| / s, with s the 99th percentile of
|H_exact| over those pixels (a robust maximum): median and 95th percentile.

A second render of a file in one batch (untimed by the rounds, after them, ``--rounds``
times): ``gshade batch FILE --sweep shape.stripes=20,21 -j 1`` at the rounds' size, two
jobs of equal work in one worker, with a cache folder of its own that is empty (cold: the
first job reads and converts the file; target: the second <= 0.5 x the first) and again
with it full (warm, ``--force``); each job's seconds from ``manifest.json``.

Targets (the link rod, 2-core machine): whole command <= 5 s with warm kernel caches,
<= 1.5 x the peer, peak memory <= 2 GB.

Usage, from the repository root::

    .venv/bin/python benchmarks/bench_cad.py [FOLDER] [--rounds 5] [--write] [--keep DIR]

``--keep DIR`` keeps the last mean-curvature EXR of each model, gshade's PNGs of an extra
untimed render of each shape and the peer's PNG.  Off-screen VTK needs EGL (Mesa):
``apt-get install -y libegl1 libegl-mesa0 libgl1 libgl1-mesa-dri`` (see RESULTS.md).
"""

from __future__ import annotations

import argparse
import compileall
import json
import os
import resource
import shutil
import sys
import tempfile
import textwrap
from dataclasses import dataclass, field
from importlib.metadata import version
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from bench_render import (
    GSHADE,
    PYTHON,
    STAGES,
    Run,
    SanityError,
    checked,
    cli_command,
    fresh,
    median,
    met,
    mib,
    run_process,
    secs,
    spread,
    stage_command,
)
from report import (
    load_average,
    machine_info,
    markdown_section,
    publish,
)

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_FOLDER = ROOT.parent / "shared" / "data" / "cad"
MODELS = (
    "linkrods.step",
    "featuretype.STEP",
    "hammer.iges",
    "sunglasses_lens.igs",
    "v3_Speeder.3dm",
    "v4_DinerMug.3dm",
    "v5_teapot.3dm",
)
LINK_ROD = "linkrods.step"
PEER = Path(__file__).with_name("cad_peer.py")
WIDTH, HEIGHT, SPP = 1024, 768, 16
SIZE = ("--width", str(WIDTH), "--height", str(HEIGHT), "--spp", str(SPP))
SIZE_SETS = (f"render.width={WIDTH}", f"render.height={HEIGHT}", f"render.spp={SPP}")
SHAPES = {"isophotes": (), "mean": ("shape.function=mean",)}
NO_PEER_STATUS = 3  # cad_peer.py: a .3dm file without render meshes
TIMEOUT_S = 600
#: The second render of a file in one batch, against its first (a cold cache).
TARGET_BATCH = 0.5

TARGET_S, TARGET_RATIO, TARGET_GB = 5.0, 1.5, 2.0
SECTION = "bench_cad"
#: RESULTS.md's section of a run with ``--all`` (outside parts, never committed).
OUTSIDE = "bench_cad_outside"
CAD_SUFFIXES = (".step", ".stp", ".iges", ".igs", ".brep", ".3dm")

#: The report's fixed notes: how the peer is set up, what the error means.
METHOD_NOTES = (
    'Setup: `.venv/bin/pip install -e ".[bench,cad]"` (pyvista, vtk; OCP without VTK: '
    "importing both in one process works, `tests/cad/test_cad_occt.py` passes).  Off-screen VTK "
    "without X: the vtk wheel renders through EGL with Mesa's software rasteriser "
    "(llvmpipe); Debian: `apt-get install -y libegl1 libegl-mesa0 libgl1 libgl1-mesa-dri` "
    "(no OSMesa, no Xvfb).  `cad_peer.py` sets `VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow`"
    ", else VTK tries X first and warns `bad X server connection`.",
    "Peer curvature error: at the pixels of gshade's mean-curvature EXR fully covered and "
    "with a 3 x 3 neighbourhood on one face, |s H_mesh(P) - f| / (99th percentile of |f|), "
    "H_mesh VTK's discrete mean curvature interpolated linearly on the closest triangle at "
    "gshade's exact point P, f gshade's exact H (sample mean in the pixel); s = -1 or +1 for "
    "the whole model by the sign of the correlation, in brackets (-1: VTK's H is positive "
    "where gshade's, w.r.t. the outward normal, is negative).",
    "Ratios: median of the per-round ratios gshade wall / peer wall; the peer draws the "
    "mesh's curvature without anti-aliasing (one sample per pixel), gshade 16 spp.",
)

#: gshade's deflection and camera for a file, as its render resolves them (untimed).
PROBE_CHILD = textwrap.dedent(
    """
    import json, sys
    from gshade.rendering.sizing import chord_tolerance, frame
    from gshade.scene import load_scene, parse_overrides
    scene = load_scene(sys.argv[1], parse_overrides(sys.argv[2:]))
    framing = frame(scene, scene.render, sys.argv[1])
    v = framing.view
    camera = {"origin": v.origin.tolist(), "target": v.target.tolist(), "up": v.up.tolist(),
              "fov": v.fov}
    print("BENCH_JSON " + json.dumps({
        "deflection": chord_tolerance(scene, scene.render, framing), "camera": camera,
        "diagonal": framing.diag, "faces": len(scene.patches)}))
    """
)


@dataclass
class Process:
    """One whole process: wall and CPU time (s), peak RSS (KiB)."""

    wall: float
    cpu: float
    maxrss_kb: int


@dataclass
class Model:
    """A model's runs: gshade per shape, the peer, the link rod's stages, the error."""

    path: Path
    probe: dict | None = None
    gshade: dict[str, list[Process]] = field(default_factory=lambda: {s: [] for s in SHAPES})
    peer: list[Process] = field(default_factory=list)
    refused: str | None = None  # gshade's one line when it does not render the file
    no_peer: str | None = None
    stages: dict[str, list[dict]] = field(default_factory=lambda: {s: [] for s in SHAPES})
    peer_stages: list[dict] = field(default_factory=list)
    error: dict | None = None
    error_failed: str | None = None  # why the peer's error could not be measured
    batches: dict[str, list[tuple[float, float]]] = field(
        default_factory=lambda: {"cold": [], "warm": []}
    )  # (first job's seconds, second's) per round


def timed(cmd: list[str]) -> tuple[Run, float]:
    """Run a command (``bench_render.run_process``); also its CPU time, user + system."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    run = run_process(cmd, TIMEOUT_S)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return run, cpu


def json_line(run: Run, tag: str) -> dict:
    """The ``{tag} {...}`` line a child printed."""
    for line in run.stdout.splitlines():
        if line.startswith(tag + " "):
            return json.loads(line[len(tag) + 1 :])
    raise SanityError(f"no {tag} line; stderr: {run.stderr[-2000:]}")


def one_line(run: Run) -> str:
    """The last line of a refusal on stderr."""
    lines = [x for x in run.stderr.strip().splitlines() if x.strip()]
    return lines[-1] if lines else f"exit status {run.returncode}"


def peer_command(model: Model, png: Path, sample: tuple[Path, Path] | None = None) -> list:
    cmd = [PYTHON, str(PEER), str(model.path), str(png)]
    cmd += ["--width", str(WIDTH), "--height", str(HEIGHT)]
    if model.probe is not None:
        cmd += ["--deflection", repr(model.probe["deflection"])]
        cmd += ["--camera", json.dumps(model.probe["camera"])]
    if sample is not None:
        cmd += ["--sample", str(sample[0]), str(sample[1])]
    return cmd


def probe(model: Model) -> None:
    """gshade's deflection and camera for the model, if gshade renders it."""
    run = run_process([PYTHON, "-c", PROBE_CHILD, str(model.path), *SIZE_SETS], TIMEOUT_S)
    if run.returncode == 0:  # else the command says why, in the rounds
        model.probe = json_line(run, "BENCH_JSON")


# --------------------------------------------------------------------------- one round


def run_gshade(model: Model, shape: str, exr: Path, keep: bool) -> None:
    sets = [x for s in SHAPES[shape] for x in ("--set", s)]
    run, cpu = timed(cli_command(model.path, fresh(exr), (*SIZE, *sets)))
    if run.returncode == 2 and run.stderr.strip().count("\n") == 0:
        model.refused = one_line(run)  # gshade refuses the file (e.g. .3dm): not rendered
        return
    checked(run, f"gshade render {model.path.name} ({shape})", exr)
    if keep:
        model.gshade[shape].append(Process(run.wall, cpu, run.maxrss_kb))


def run_peer(model: Model, png: Path, keep: bool) -> None:
    run, cpu = timed(peer_command(model, fresh(png)))
    if run.returncode == NO_PEER_STATUS:
        model.no_peer = one_line(run)
        return
    checked(run, f"peer {model.path.name}", png)
    if keep:
        model.peer.append(Process(run.wall, cpu, run.maxrss_kb))
        model.peer_stages.append(json_line(run, "PEER_JSON")["stages"])


def run_stages(model: Model, tmp: Path) -> None:
    """The link rod's stage runs (one per shape), in process (``bench_render``'s child)."""
    for shape, sets in SHAPES.items():
        exr = fresh(tmp / f"stage-{shape}.exr")
        run = run_process(stage_command(model.path, exr, 0, (*SIZE_SETS, *sets)), TIMEOUT_S)
        model.stages[shape].append(checked(run, f"stage run {shape}", exr).result())


def one_round(models: list[Model], tmp: Path, index: int, rounds: int) -> None:
    """Round ``index`` (0: the untimed warm-up): every model, gshade and the peer in turn."""
    keep = index > 0
    for k, model in enumerate(models):
        stem = f"{k}-{model.path.stem}"
        gshade_first = index % 2 == 0

        def gshade(model=model, stem=stem) -> None:
            for shape in SHAPES:
                if model.refused is None:
                    run_gshade(model, shape, tmp / f"{stem}-{shape}.exr", keep)

        def peer(model=model, stem=stem) -> None:
            if model.no_peer is None:
                run_peer(model, tmp / f"{stem}-peer.png", keep)

        for step in (gshade, peer) if gshade_first else (peer, gshade):
            step()
        if keep and model.path.name == LINK_ROD and model.refused is None:
            run_stages(model, tmp)
        print(f"round {index}/{rounds}: {model.path.name} done", file=sys.stderr)


# --------------------------------------------------------------------------- the batch

#: The batch of two renders of one file: equal work (one more stripe), at the rounds' size.
BATCH_SWEEPS = (
    "shape.stripes=20,21",
    f"render.width={WIDTH}",
    f"render.height={HEIGHT}",
    f"render.spp={SPP}",
)


def batch_round(model: Model, tmp: Path) -> None:
    """``gshade batch FILE --sweep shape.stripes=20,21 -j 1``: with a cache folder of its
    own, empty (cold: the first job reads and converts the file), then again with it
    (warm, ``--force``); each job's seconds from the manifest."""
    cache, out = tmp / "batch-cache", tmp / "batch-out"
    for folder in (cache, out):
        shutil.rmtree(folder, ignore_errors=True)
    sweeps = [x for sweep in BATCH_SWEEPS for x in ("--sweep", sweep)]
    for label in ("cold", "warm"):
        cmd = ["env", f"GSHADE_CACHE_DIR={cache}", GSHADE, "batch", str(model.path), *sweeps]
        run = run_process([*cmd, "-j", "1", "-o", str(out), "--force"], TIMEOUT_S)
        checked(run, f"gshade batch {model.path.name} ({label})")
        manifest = json.loads((out / "manifest.json").read_text())
        jobs = manifest["jobs"] if isinstance(manifest, dict) else manifest
        seconds = [float(job["seconds"]) for job in jobs]
        if len(seconds) != 2 or any(job["status"] != "rendered" for job in jobs):
            raise SanityError(f"gshade batch {model.path.name}: {jobs}")
        model.batches[label].append((seconds[0], seconds[1]))


BATCH_COLUMNS = [
    "Model",
    "cold: first s",
    "second s",
    "second / first [min-max]",
    "warm: first s",
    "second s",
    "second / first [min-max]",
    "target (cold)",
    "Met",
]


def batch_rows(models: list[Model]) -> list[list[str]]:
    rows = []
    for m in models:
        if not m.batches["cold"]:
            continue
        row, found = [m.path.name], {}
        for label in ("cold", "warm"):
            pairs = np.array(m.batches[label])
            ratios = list(pairs[:, 1] / pairs[:, 0])
            found[label] = median(ratios)
            row += [secs(list(pairs[:, 0])), secs(list(pairs[:, 1]))]
            row.append(f"{found[label]:.2f} [{spread(ratios)}]")
        row += [f"<= {TARGET_BATCH}", met(found["cold"] <= TARGET_BATCH)]
        rows.append(row)
    return rows


# --------------------------------------------------------------------------- the error


def curvature_error(model: Model, tmp: Path, keep_dir: Path | None) -> None:
    """The peer's mean curvature against gshade's exact one at gshade's pixels (untimed)."""
    from gshade.io.image import read_exr

    stem = model.path.stem
    exr = tmp / f"error-{stem}.exr"
    png = (keep_dir or tmp) / f"{stem}-gshade-mean.png"
    sets = [x for s in SHAPES["mean"] for x in ("--set", s)]
    run = run_process(cli_command(model.path, exr, (*SIZE, *sets, "--png", str(png))), TIMEOUT_S)
    checked(run, f"gshade render {model.path.name} (mean, for the error)", exr)
    channels, _ = read_exr(exr)
    patch = channels["patch"]
    inner = (channels["A"] >= 0.999) & (patch >= 0)
    padded = np.pad(patch, 1, constant_values=-1)
    H, W = patch.shape
    for dy in (0, 1, 2):
        for dx in (0, 1, 2):
            inner &= padded[dy : dy + H, dx : dx + W] == patch
    points = np.stack([channels[f"P.{a}"][inner] for a in "XYZ"], -1).astype(np.float64)
    exact = channels["f"][inner].astype(np.float64)
    np.save(tmp / "P.npy", points)
    peer_png = (keep_dir or tmp) / f"{stem}-peer.png"
    run = run_process(peer_command(model, peer_png, (tmp / "P.npy", tmp / "H.npy")), TIMEOUT_S)
    checked(run, f"peer {model.path.name} (sampling)", peer_png)
    mesh = np.load(tmp / "H.npy")
    sign = -1.0 if float(np.dot(mesh, exact)) < 0 else 1.0
    scale = float(np.percentile(np.abs(exact), 99)) or 1.0
    relative = np.abs(sign * mesh - exact) / scale
    model.error = {
        "pixels": int(inner.sum()),
        "sign": sign,
        "scale": scale,
        "median": float(np.median(relative)),
        "p95": float(np.percentile(relative, 95)),
    }
    if keep_dir is not None:
        shutil.copy(exr, keep_dir / f"{stem}-mean.exr")
        iso = keep_dir / f"{stem}-gshade-isophotes.png"
        run = run_process(cli_command(model.path, tmp / "iso.exr", (*SIZE, "--png", str(iso))))
        checked(run, f"gshade render {model.path.name} (isophotes PNG)", iso)


# --------------------------------------------------------------------------- tables


def walls(xs: list[Process]) -> list[float]:
    return [x.wall for x in xs]


def ratio(model: Model, shape: str) -> list[float]:
    return [
        g.wall / p.wall for g, p in zip(model.gshade[shape], model.peer, strict=False) if p.wall
    ]


def wall_cell(xs: list[Process]) -> str:
    return f"{secs(walls(xs))} [{spread(walls(xs))}]" if xs else "-"


MAIN_COLUMNS = [
    "Model",
    "faces",
    "gshade isophotes wall s [min-max]",
    "gshade mean wall s [min-max]",
    "peer wall s [min-max]",
    "ratio isophotes / peer",
    "ratio mean / peer",
    "CPU s isophotes / mean / peer",
    "peak RSS MiB isophotes / mean / peer",
    "peer curvature error median / p95 (sign)",
]


def main_rows(models: list[Model]) -> list[list[str]]:
    rows = []
    for m in models:
        iso, mean = m.gshade["isophotes"], m.gshade["mean"]
        rendered = m.refused is None
        cpu = [f"{median([x.cpu for x in xs]):.2f}" if xs else "-" for xs in (iso, mean, m.peer)]
        rss = [mib(max(x.maxrss_kb for x in xs)) if xs else "-" for xs in (iso, mean, m.peer)]
        r = [f"{median(ratio(m, s)):.2f}" if ratio(m, s) else "-" for s in SHAPES]
        err = "-"
        if m.error is not None:
            e = m.error
            err = f"{100 * e['median']:.1f} % / {100 * e['p95']:.0f} % ({e['sign']:+.0f})"
        rows.append(
            [
                m.path.name,
                str(m.probe["faces"]) if m.probe else "-",
                wall_cell(iso) if rendered else "not rendered",
                wall_cell(mean) if rendered else "not rendered",
                wall_cell(m.peer) if m.no_peer is None else "no peer",
                *r,
                " / ".join(cpu),
                " / ".join(rss),
                err,
            ]
        )
    return rows


STAGE_COLUMNS = ["Stage (link rod, s)", "isophotes", "mean"]
PROCESS_PARTS = ("startup", "imports", "load_scene")


def stage_rows(model: Model) -> list[list[str]]:
    """Medians of the link rod's stage runs: start-up, imports, reading, the render's
    stages, the EXR and the teardown, their sum against the command's wall time."""
    runs = model.stages

    def cell(shape: str, get) -> str:
        return f"{median([get(s) for s in runs[shape]]):.2f}"

    labels = {
        "startup": "start-up (interpreter, site)",
        "imports": "import gshade.scene, gshade.rendering",
        "load_scene": "load_scene (read the file, NURBS faces)",
        "setup": "setup (Mitsuba import, variant)",
        "tessellate": "tessellate (framing, kernel mesh)",
        "write_exr": "write EXR",
        "teardown": "teardown (exit)",
    }
    rows = []
    for key in (*PROCESS_PARTS, *STAGES, "write_exr", "teardown"):

        def get(r: dict, k: str = key) -> float:
            return r["stages"][k] if k in STAGES else r[k]

        rows.append([labels.get(key, key), *(cell(s, get) for s in runs)])
    rows.append(["sum = stage run's wall", *(cell(s, lambda r: r["wall"]) for s in runs)])
    rows.append(["CLI wall (median, table above)", *(secs(walls(model.gshade[s])) for s in runs)])
    return rows


PEER_STAGE_COLUMNS = ["Peer stage (link rod, s)", "median"]


def peer_stage_rows(model: Model) -> list[list[str]]:
    keys = model.peer_stages[0].keys() if model.peer_stages else ()
    rows = [[k, f"{median([s[k] for s in model.peer_stages]):.2f}"] for k in keys]
    total = median([sum(s.values()) for s in model.peer_stages]) if keys else 0.0
    rows.append(["sum (in process)", f"{total:.2f}"])
    rows.append(["whole process wall", secs(walls(model.peer))])
    return rows


def targets(model: Model) -> list[str]:
    """The link rod's targets, met or not, with the margin."""
    lines = []
    for shape in SHAPES:
        xs = model.gshade[shape]
        if not xs:
            lines.append(f"{shape}: not rendered")
            continue
        wall = median(walls(xs))
        r = median(ratio(model, shape)) if model.peer else float("nan")
        gb = max(x.maxrss_kb for x in xs) / 2**20
        lines.append(
            f"{shape}: wall {wall:.2f} s <= {TARGET_S:g} s {met(wall <= TARGET_S)}"
            f" ({wall - TARGET_S:+.2f} s); gshade / peer {r:.2f} <= {TARGET_RATIO:g} "
            f"{met(r <= TARGET_RATIO)} ({wall - TARGET_RATIO * median(walls(model.peer)):+.2f} s"
            f" against 1.5 x peer); peak RSS {gb:.2f} GiB <= {TARGET_GB:g} {met(gb <= TARGET_GB)}"
        )
    return lines


# --------------------------------------------------------------------------- main


def section(info, tables, notes, args) -> str:
    what = f"FOLDER --all --rounds {args.rounds}" if args.all else f"--rounds {args.rounds}"
    run = (
        f"Run: `.venv/bin/python benchmarks/bench_cad.py {what} --write`; "
        f"whole processes, {WIDTH} x {HEIGHT}, {SPP} spp, one untimed warm-up round, then "
        f"{args.rounds} rounds, gshade and the peer interleaved (the order alternating)."
    )
    heading = "CAD files, gshade and the peer (`benchmarks/bench_cad.py`)"
    if args.all:
        heading = "Outside CAD parts, gshade and the peer (`benchmarks/bench_cad.py --all`)"
    return markdown_section(heading, run, info, tables, notes)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder", nargs="?", type=Path, default=DEFAULT_FOLDER)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--write", action="store_true", help="update benchmarks/RESULTS.md")
    parser.add_argument("--keep", type=Path, help="keep the pictures and EXRs here")
    parser.add_argument(
        "--all",
        action="store_true",
        help="every CAD file in the folder (not only the shared models'), written to "
        "RESULTS.md's section of outside parts",
    )
    args = parser.parse_args(argv)
    # resolved: gshade reads a data file only within its scene's folder, links resolved
    names = (
        sorted(p.name for p in args.folder.iterdir() if p.suffix.lower() in CAD_SUFFIXES)
        if args.all
        else MODELS
    )
    models = [Model((args.folder / n).resolve()) for n in names if (args.folder / n).is_file()]
    if not models:
        raise SanityError(f"no model found in {args.folder}")
    if args.keep:
        args.keep.mkdir(parents=True, exist_ok=True)
    load_start = load_average()
    compileall.compile_dir(str(ROOT / "src" / "gshade"), quiet=1)
    with tempfile.TemporaryDirectory(prefix="gshade-bench-cad-") as name:
        tmp = Path(name)
        for model in models:
            probe(model)
        for index in range(args.rounds + 1):
            one_round(models, tmp, index, args.rounds)
        for _ in range(args.rounds):
            for model in models:
                if model.refused is None:
                    batch_round(model, tmp)
        for model in models:
            if model.refused is None and model.no_peer is None:
                try:
                    curvature_error(model, tmp, args.keep)
                except SanityError as exc:  # the timings stand; say what failed
                    model.error_failed = str(exc).splitlines()[0]

    info = machine_info(
        [
            f"mitsuba {version('mitsuba')}",
            f"OCP {version('cadquery-ocp-novtk')}",
            f"pyvista {version('pyvista')}",
            f"vtk {version('vtk')}",
            f"rhino3dm {version('rhino3dm')}",
        ],
        ["Dr.Jit: its default thread pool; VTK: EGL (Mesa llvmpipe)"],
    )
    tables = [("Whole commands (medians over the rounds)", MAIN_COLUMNS, main_rows(models))]
    tables.append(
        (
            "A second render of a file in one batch (`gshade batch FILE --sweep "
            "shape.stripes=20,21 -j 1`, each job's seconds from the manifest; medians)",
            BATCH_COLUMNS,
            batch_rows(models),
        )
    )
    notes = list(METHOD_NOTES)
    link = next((m for m in models if m.path.name == LINK_ROD), None)
    if link is not None and link.stages["isophotes"]:
        tables.append(
            (
                "Link rod: where gshade's time goes (stage runs, medians)",
                STAGE_COLUMNS,
                stage_rows(link),
            )
        )
    if link is not None and link.peer_stages:
        tables.append(("Link rod: the peer's stages", PEER_STAGE_COLUMNS, peer_stage_rows(link)))
    if link is not None:
        notes += [f"Link rod targets, {t}." for t in targets(link)]
    for m in models:
        if m.probe:
            notes.append(
                f"{m.path.name}: deflection {m.probe['deflection']:.3g} "
                f"({m.probe['deflection'] / m.probe['diagonal']:.2g} of the diagonal)"
                + (
                    f"; error over {m.error['pixels']:,} pixels, s = {m.error['scale']:.3g}"
                    if m.error
                    else ""
                )
            )
        if m.refused:
            notes.append(f"{m.path.name}: not rendered: `{m.refused}`")
        if m.error_failed:
            notes.append(f"{m.path.name}: the peer's error not measured: `{m.error_failed}`")
        if m.no_peer:
            notes.append(f"{m.path.name}: no peer: `{m.no_peer}`")
    notes.append(
        f"Load average (1, 5, 15 min): {load_start} at the start, {load_average()} at the end."
    )
    text = (
        (OUTSIDE if args.all else SECTION, section(info, tables, notes, args))
        if args.write
        else None
    )
    publish(info, tables, notes, text)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except SanityError as exc:
        sys.exit(f"FAILED sanity check, timings not reported.\n{exc}")
