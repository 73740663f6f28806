"""Benchmark rendering: the ``gshade render`` command end to end, its stages, and scaling.

What is measured (wall-clock, ``time.perf_counter``; every render runs in a fresh process):

C   The command line end to end: ``gshade render scenes/teapot-isophotes.toml -o OUT.exr``
    (32 bicubic patches, 1024 x 768, 16 spp, ``llvm_ad_rgb``, lit) as a subprocess, from its
    start to its exit (the EXR written), and the same with ``--set render.lighting=flat``.
    The kernel caches are warm: one untimed run of each before the timed rounds (Dr.Jit caches
    its kernels, Mitsuba's and gshade's, in ``~/.drjit``).  Median of 5 rounds
    (``--quick``: 2), the runs interleaved (lit, flat, and the stage runs of S, in turn).
    Peak memory: the child's ``ru_maxrss`` (``os.wait4``).
S   Where the time goes.  A fresh Python process does what the command does, in process:
    import ``gshade.scene`` and ``gshade.rendering``, ``load_scene``, ``render``,
    ``write_exr``, and reports the stage times of ``RenderedImage.timings`` (``setup``:
    variant selection and Mitsuba's import, ``tessellate``, ``textures``, ``scene``:
    Mitsuba scene construction and the silhouettes, ``render``: Mitsuba's pass through the
    pixel centres, ``supersample``: finding the pixels where the picture jumps and Mitsuba's
    pass through them, ``exact_channels``), then renders once more in the same process
    ("warm": Mitsuba's kernels in memory, variant set).
I   Import and start-up time of the command's dependencies: ``python -c CODE`` for
    ``pass``, ``import gshade.app.cli``, ``import gshade.scene, gshade.rendering``, ``+
    mitsuba``, and ``+ use_variant("auto")`` (Mitsuba's ``llvm_ad_rgb`` variant set, gshade's
    plugins registered), median of 5 runs each; and ``python -X importtime`` of the last,
    top-level modules by cumulative time.
N   Scale: one wavy C1 height-field sheet z = 0.2 sin(pi x) cos(pi y) over [-1, 1]^2 made of
    n = 1, 100, 1,000 (40 x 25) and 10,000 bicubic Bézier patches (a grid of cells, each the
    bicubic Hermite interpolant of z's exact corner values, slopes and twists, so that
    neighbours share edges bit for bit and join C1), written as a TOML scene with one
    ``[[surface]] type = "bezier"`` per patch (a bezier surface holds exactly one patch),
    isophote stripes, automatic camera, 1024 x 1024, 4 spp, lit.  Per size: one untimed
    warm-up run (Mitsuba's kernels can depend on the sizes), one stage run (as in S, also
    its peak memory), then 3 timed CLI runs (``--quick``: 1), each its own subprocess whose
    peak RSS is read with ``os.wait4``.  A run over 300 s is stopped and reported.

Targets (2-core machine): C lit <= 3 s; 10,000 patches <= 30 s and <= 4 GB, growing roughly
linearly.  (The earlier target for gshade's share of the command, <= 25 %, was withdrawn by
issue 15: ``bench_peer.py`` measures the command against the peer a user would run instead.)

Usage, from the repository root::

    .venv/bin/python benchmarks/bench_render.py            # print the tables
    .venv/bin/python benchmarks/bench_render.py --write    # and update RESULTS.md
    .venv/bin/python benchmarks/bench_render.py --quick    # fewer repeats

``--write`` replaces this benchmark's section of ``benchmarks/RESULTS.md`` (between the
``bench_render`` markers) and leaves the rest of the file alone.
"""

from __future__ import annotations

import argparse
import compileall
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import textwrap
import threading
import time
from dataclasses import dataclass, field
from importlib.metadata import version
from pathlib import Path

# One BLAS thread, as in the other benchmarks (``report`` sets it too); set before numpy
# loads.  The child processes inherit it; the report records it.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from report import (
    load_average,
    machine_info,
    markdown_section,
    publish,
)

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "scenes" / "teapot-isophotes.toml"
PYTHON = sys.executable
GSHADE = str(Path(sys.executable).parent / "gshade")
FLAT = ("--set", "render.lighting=flat")

REPEATS, QUICK_REPEATS = 5, 2
IMPORT_REPEATS = 5
SCALE_REPEATS, QUICK_SCALE_REPEATS = 3, 1
#: Patch grids of the scale runs (cells along x, along y).
SCALE_GRIDS = ((1, 1), (10, 10), (40, 25), (100, 100))
SCALE_SIZE, SCALE_SPP, SCALE_LIGHTING = 1024, 4, "lit"
SCALE_TIMEOUT_S = 300
AMPLITUDE, WAVES = 0.2, 1.0  # z = AMPLITUDE sin(WAVES pi x) cos(WAVES pi y)

TARGET_CLI_S = 3.0
TARGET_SCALE_S, TARGET_SCALE_GB, TARGET_SCALE_PATCHES = 30.0, 4.0, 10_000

STAGES = (
    "setup",
    "tessellate",
    "textures",
    "statistics",
    "scene",
    "render",
    "supersample",
    "exact_channels",
)
MITSUBA_STAGES = ("render", "supersample")

SECTION = "bench_render"  # its markers in RESULTS.md

#: The stage run (S, N): what ``gshade render`` does, in a fresh process, timed by parts.
#: argv: scene, output EXR, number of extra (warm) renders, then ``key=value`` overrides.
STAGE_CHILD = textwrap.dedent(
    """
    import json, resource, sys, time
    begin = time.time()
    t0 = time.perf_counter()
    from gshade.scene import load_scene, parse_overrides
    from gshade.rendering import render
    t1 = time.perf_counter()
    scene = load_scene(sys.argv[1], parse_overrides(sys.argv[4:]))
    t2 = time.perf_counter()
    image = render(scene)
    t3 = time.perf_counter()
    image.write_exr(sys.argv[2])
    t4 = time.perf_counter()
    written = time.time()
    settings = json.loads(image.metadata["settings"])
    out = {
        "imports": t1 - t0, "load_scene": t2 - t1, "render_call": t3 - t2,
        "write_exr": t4 - t3, "stages": image.timings, "patches": len(scene.patches),
        "coverage": float((image.channels["A"] > 0).mean()),
        "variant": image.metadata["variant"], "tessellation": settings["tessellation"],
        "texture_tile": settings["texture_tile"], "warm": [], "written": written,
    }
    for _ in range(int(sys.argv[3])):
        t5 = time.perf_counter()
        again = render(scene)
        out["warm"].append({"render_call": time.perf_counter() - t5, "stages": again.timings})
    out["maxrss_kb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    out["begin"], out["end"] = begin, time.time()
    print("BENCH_JSON " + json.dumps(out), flush=True)
    """
)

#: Import runs (I): label -> ``python -c`` code.
IMPORT_CODES = {
    "python -c pass": "pass",
    "import gshade.app.cli": "import gshade.app.cli",
    "import gshade.scene, gshade.rendering": "import gshade.scene, gshade.rendering",
    "... + mitsuba": "import gshade.scene, gshade.rendering, gshade.runtime\n"
    "gshade.runtime.setup()\nimport mitsuba",
    '... + use_variant("auto")': "import gshade.scene, gshade.rendering, gshade.runtime\n"
    "gshade.runtime.setup()\nimport mitsuba\n"
    "from gshade.rendering.plugins import use_variant\nuse_variant('auto')",
}


class SanityError(RuntimeError):
    pass


# --------------------------------------------------------------------------- processes


@dataclass
class Run:
    """One child process: wall time from start to exit, its peak RSS, status and output."""

    wall: float  # seconds
    maxrss_kb: int
    returncode: int
    stdout: str
    stderr: str
    timed_out: bool = False
    spawned: float = 0.0  # time.time() just before the start, and just after the exit
    reaped: float = 0.0

    def result(self) -> dict:
        """The stage run's JSON line, with ``startup`` (from the start to the first line of
        the child's code: interpreter and site) and ``teardown`` (from its last line to the
        exit: interpreter finalisation, Mitsuba's and Dr.Jit's shutdown) added, and ``wall``:
        the process's wall time without the warm renders (start to the EXR written, plus
        the teardown)."""
        for line in self.stdout.splitlines():
            if line.startswith("BENCH_JSON "):
                out = json.loads(line[len("BENCH_JSON ") :])
                out["startup"] = out["begin"] - self.spawned
                out["teardown"] = self.reaped - out["end"]
                out["wall"] = out["written"] - self.spawned + out["teardown"]
                return out
        raise SanityError(f"stage run printed no result; stderr: {self.stderr[-2000:]}")


def run_process(cmd: list[str], timeout: float | None = None) -> Run:
    """Run ``cmd`` from the repository root; its wall time and peak RSS (``os.wait4``, so
    the RSS is this child's own).  Output goes to temporary files (no pipe to fill)."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        spawned = time.time()
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=out, stderr=err, text=True)
        timer = threading.Timer(timeout, proc.kill) if timeout else None
        if timer:
            timer.start()
        try:
            _, status, usage = os.wait4(proc.pid, 0)
        finally:
            if timer:
                timer.cancel()
        wall = time.perf_counter() - t0
        reaped = time.time()
        proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here, not by Popen
        out.seek(0)
        err.seek(0)
        return Run(
            wall,
            usage.ru_maxrss,
            proc.returncode,
            out.read(),
            err.read(),
            timed_out=bool(timeout) and proc.returncode == -9 and wall >= timeout,
            spawned=spawned,
            reaped=reaped,
        )


def cli_command(scene: Path, output: Path, extra: tuple[str, ...] = ()) -> list[str]:
    return [GSHADE, "render", str(scene), "-o", str(output), *extra]


def stage_command(scene: Path, output: Path, warm: int, sets: tuple[str, ...] = ()) -> list:
    return [PYTHON, "-c", STAGE_CHILD, str(scene), str(output), str(warm), *sets]


def checked(run: Run, what: str, output: Path | None = None) -> Run:
    """Raise unless the run succeeded (and wrote ``output``)."""
    if run.timed_out:
        raise SanityError(f"{what}: stopped after {run.wall:.0f} s")
    if run.returncode != 0:
        raise SanityError(f"{what}: exit status {run.returncode}; stderr: {run.stderr[-2000:]}")
    if output is not None and not (output.is_file() and output.stat().st_size > 0):
        raise SanityError(f"{what}: {output} was not written")
    return run


def fresh(path: Path) -> Path:
    path.unlink(missing_ok=True)
    return path


# --------------------------------------------------------------------------- the sheet


def sheet_net(nx: int, ny: int) -> np.ndarray:
    """Control net, shape (3 nx + 1, 3 ny + 1, 3), of nx x ny bicubic Bézier patches forming
    z = AMPLITUDE sin(WAVES pi x) cos(WAVES pi y) over [-1, 1]^2: patch (i, j) is
    ``net[3i:3i+4, 3j:3j+4]``.  Each cell is the bicubic Hermite interpolant of z's corner
    values, slopes and twists, so neighbours share their edge rows (bit for bit: they are
    the same entries) and the inner rows across an edge are collinear and evenly spaced
    with it (C1)."""
    a = WAVES * np.pi
    x, y = np.linspace(-1.0, 1.0, 3 * nx + 1), np.linspace(-1.0, 1.0, 3 * ny + 1)
    hx, hy = 2.0 / nx, 2.0 / ny
    i, j = np.arange(3 * nx + 1), np.arange(3 * ny + 1)
    ci, cj = 3 * np.rint(i / 3).astype(int), 3 * np.rint(j / 3).astype(int)  # nearest corner
    di, dj = (i - ci)[:, None], (j - cj)[None, :]  # -1, 0, +1: the step from that corner
    xc, yc = x[ci][:, None], y[cj][None, :]
    sx, cx, sy, cy = np.sin(a * xc), np.cos(a * xc), np.sin(a * yc), np.cos(a * yc)
    z = AMPLITUDE * (
        sx * cy
        + di * (hx / 3) * a * cx * cy
        - dj * (hy / 3) * a * sx * sy
        - di * dj * (hx * hy / 9) * a * a * cx * sy
    )
    net = np.empty((3 * nx + 1, 3 * ny + 1, 3))
    net[..., 0], net[..., 1], net[..., 2] = x[:, None], y[None, :], z
    return net


def sheet_scene(nx: int, ny: int) -> str:
    """The TOML scene of the nx x ny sheet."""
    net = sheet_net(nx, ny)
    lines = [
        f'name = "sheet-{nx * ny}"',
        "",
        "[shape]",
        'function = "isophotes"',
        "light = [0.3, -0.5, 0.8]",
        'display = "stripes"',
        "stripes = 20",
        "",
        "[render]",
        f"width = {SCALE_SIZE}",
        f"height = {SCALE_SIZE}",
        f"spp = {SCALE_SPP}",
        f'lighting = "{SCALE_LIGHTING}"',
    ]
    for pi in range(nx):
        for pj in range(ny):
            cell = net[3 * pi : 3 * pi + 4, 3 * pj : 3 * pj + 4]
            rows = ", ".join(
                "[" + ", ".join("[" + ", ".join(repr(float(c)) for c in p) + "]" for p in row) + "]"
                for row in cell
            )
            lines += ["", "[[surface]]", 'type = "bezier"', f"points = [{rows}]"]
    return "\n".join(lines) + "\n"


def check_sheet(nx: int, ny: int) -> None:
    """The patches of a small sheet share edges exactly and match z at their corners."""
    from gshade.geometry import BezierPatch

    net = sheet_net(nx, ny)
    patches = [
        [BezierPatch(net[3 * i : 3 * i + 4, 3 * j : 3 * j + 4]) for j in range(ny)]
        for i in range(nx)
    ]
    t = np.linspace(0.0, 1.0, 7)
    for i in range(nx):
        for j in range(ny):
            p = patches[i][j]
            corner = p(np.array([0.0]), np.array([0.0]))[0]
            z = AMPLITUDE * np.sin(WAVES * np.pi * corner[0]) * np.cos(WAVES * np.pi * corner[1])
            if abs(corner[2] - z) > 1e-12:
                raise SanityError(f"sheet {nx}x{ny}: patch ({i}, {j}) corner off z by {z}")
            if i + 1 < nx:  # shared edge u = 1 | u = 0, same points
                a, b = p(np.ones_like(t), t), patches[i + 1][j](np.zeros_like(t), t)
                if not np.array_equal(a, b):
                    raise SanityError(f"sheet {nx}x{ny}: edge ({i}, {j})-({i + 1}, {j}) differs")
            if j + 1 < ny:
                a, b = p(t, np.ones_like(t)), patches[i][j + 1](t, np.zeros_like(t))
                if not np.array_equal(a, b):
                    raise SanityError(f"sheet {nx}x{ny}: edge ({i}, {j})-({i}, {j + 1}) differs")


# --------------------------------------------------------------------------- formatting


def median(xs: list[float]) -> float:
    return statistics.median(xs)


def secs(xs: list[float], digits: int = 2) -> str:
    return f"{median(xs):.{digits}f}"


def spread(xs: list[float], digits: int = 2) -> str:
    return f"{min(xs):.{digits}f}-{max(xs):.{digits}f}"


def mib(kb: float) -> str:
    return f"{kb / 1024:,.0f}"


def met(ok: bool | None) -> str:
    return "-" if ok is None else ("yes" if ok else "NO")


# --------------------------------------------------------------------------- C and S


@dataclass
class EndToEnd:
    """C and S of one lighting: CLI runs and stage runs."""

    label: str
    extra: tuple[str, ...] = ()  # CLI arguments after the output
    cli: list[Run] = field(default_factory=list)
    stage: list[dict] = field(default_factory=list)

    @property
    def cli_walls(self) -> list[float]:
        return [r.wall for r in self.cli]

    def first(self, key: str) -> list[float]:
        """A stage's first-render times (s), or a part of the stage run (imports, ...)."""
        if key in STAGES:
            return [s["stages"][key] for s in self.stage]
        return [s[key] for s in self.stage]

    def warm(self, key: str) -> list[float]:
        if key in STAGES:
            return [w["stages"][key] for s in self.stage for w in s["warm"]]
        return [w[key] for s in self.stage for w in s["warm"]]


def measure_end_to_end(repeats: int, tmp: Path) -> list[EndToEnd]:
    cases = [EndToEnd("lit (scene default)"), EndToEnd("flat (--set render.lighting=flat)", FLAT)]
    exr = tmp / "teapot.exr"

    def cli(case: EndToEnd) -> Run:
        run = run_process(cli_command(SCENE, fresh(exr), case.extra))
        return checked(run, f"gshade render {case.label}", exr)

    def stage(case: EndToEnd, warm: int) -> dict:
        run = run_process(stage_command(SCENE, fresh(exr), warm, case.extra[1:]))
        return checked(run, f"stage run {case.label}", exr).result()

    for case in cases:  # warm-up: kernel caches (Dr.Jit), file cache; untimed
        cli(case)
        stage(case, 0)
    for _ in range(repeats):
        for case in cases:
            case.cli.append(cli(case))
        for case in cases:
            case.stage.append(stage(case, 1))
    for case in cases:
        variants = {s["variant"] for s in case.stage}
        if variants != {"llvm_ad_rgb"}:
            raise SanityError(f"{case.label}: rendered with {variants}, not llvm_ad_rgb")
    return cases


def measure_imports(repeats: int) -> tuple[dict[str, list[float]], list[tuple[str, float]]]:
    walls: dict[str, list[float]] = {k: [] for k in IMPORT_CODES}
    for code in IMPORT_CODES.values():  # warm-up (file system cache)
        checked(run_process([PYTHON, "-c", code]), f"python -c {code!r}")
    for _ in range(repeats):
        for label, code in IMPORT_CODES.items():
            walls[label].append(checked(run_process([PYTHON, "-c", code]), label).wall)
    run = checked(
        run_process([PYTHON, "-X", "importtime", "-c", list(IMPORT_CODES.values())[-1]]),
        "importtime",
    )
    cumulative: dict[str, float] = {}
    for line in run.stderr.splitlines():
        m = re.match(r"import time:\s+\d+ \|\s+(\d+) \| ( *)(\S+)$", line)
        if m and ("." not in m.group(3) or m.group(3).startswith("gshade")):
            cumulative[m.group(3)] = int(m.group(1)) / 1e6
    ranked = sorted(cumulative.items(), key=lambda kv: -kv[1])
    return walls, ranked


# --------------------------------------------------------------------------- N


@dataclass
class ScaleRun:
    nx: int
    ny: int
    toml_mib: float = 0.0
    cli: list[Run] = field(default_factory=list)
    warmup: Run | None = None
    stage: dict | None = None
    stage_run: Run | None = None
    failure: str = ""

    @property
    def patches(self) -> int:
        return self.nx * self.ny


def measure_scale(repeats: int, tmp: Path, sizes=SCALE_GRIDS) -> list[ScaleRun]:
    check_sheet(3, 2)
    out = []
    for nx, ny in sizes:
        sr = ScaleRun(nx, ny)
        out.append(sr)
        scene = tmp / f"sheet-{nx * ny}.toml"
        scene.write_text(sheet_scene(nx, ny))
        sr.toml_mib = scene.stat().st_size / 2**20
        exr = tmp / f"sheet-{nx * ny}.exr"
        label = f"{nx * ny} patches"
        sr.warmup = run_process(cli_command(scene, fresh(exr)), SCALE_TIMEOUT_S)
        try:
            checked(sr.warmup, f"{label}: warm-up run", exr)
            sr.stage_run = run_process(stage_command(scene, fresh(exr), 0), SCALE_TIMEOUT_S)
            sr.stage = checked(sr.stage_run, f"{label}: stage run", exr).result()
            if sr.stage["patches"] != sr.patches:
                raise SanityError(f"{label}: the scene has {sr.stage['patches']} patches")
            for _ in range(repeats):
                run = run_process(cli_command(scene, fresh(exr)), SCALE_TIMEOUT_S)
                sr.cli.append(checked(run, f"{label}: timed run", exr))
        except SanityError as exc:
            sr.failure = str(exc).splitlines()[0][:300]
            print(f"  {label}: FAILED: {sr.failure}", file=sys.stderr)
            if sr.warmup.timed_out or (sr.stage_run is not None and sr.stage_run.timed_out):
                break  # larger sizes would only take longer
        exr.unlink(missing_ok=True)
        print(f"  {label}: done", file=sys.stderr)
    return out


# --------------------------------------------------------------------------- report


C_COLUMNS = ["Run", "CLI wall median (s)", "Spread (s)", "Peak RSS (MiB)", "Target", "Met"]
S_COLUMNS = [
    "Part",
    "lit: first render (s)",
    "lit: warm (s)",
    "flat: first render (s)",
    "flat: warm (s)",
]
I_COLUMNS = ["python -c", "Median (s)", "Spread (s)", "Added (s)"]
N_COLUMNS = [
    "Patches",
    "Scene TOML (MiB)",
    "CLI wall median (s)",
    "Spread (s)",
    "Per patch (ms)",
    "Marginal per patch (ms)",
    "Time x previous",
    "Peak RSS (MiB)",
    "Marginal RSS per patch (KiB)",
    "RSS x previous",
    "Target",
    "Met",
]
NS_COLUMNS = [
    "Patches",
    "Tess. / tile",
    "imports",
    "load_scene",
    *STAGES,
    "write_exr",
    "Stage run peak RSS (MiB)",
]


def c_rows(cases: list[EndToEnd]) -> list[list[str]]:
    rows = []
    for k, case in enumerate(cases):
        walls = case.cli_walls
        target = TARGET_CLI_S if k == 0 else None
        rows.append(
            [
                f"`gshade render scenes/teapot-isophotes.toml` {case.label}",
                secs(walls),
                spread(walls),
                mib(median([r.maxrss_kb for r in case.cli])),
                f"<= {target:g} s" if target else "none",
                met(None if target is None else median(walls) <= target),
            ]
        )
    return rows


def s_rows(cases: list[EndToEnd]) -> list[list[str]]:
    def cell(case: EndToEnd, key: str, warm: bool) -> str:
        xs = case.warm(key) if warm else case.first(key)
        return secs(xs, 3) if xs else "-"

    def process_row(label: str, key: str) -> list[str]:
        return [label] + [c for case in cases for c in (cell(case, key, False), "-")]

    def render_row(label: str, key: str) -> list[str]:
        return [label] + [cell(case, key, w) for case in cases for w in (False, True)]

    rows = [
        process_row("process start (interpreter, site)", "startup"),
        process_row("imports (gshade.scene, gshade.rendering)", "imports"),
        process_row("load_scene", "load_scene"),
    ]
    for key in STAGES:
        rows.append(
            render_row(f"render: {key}" + (" (Mitsuba)" if key in MITSUBA_STAGES else ""), key)
        )
    rows += [
        render_row("render() call, total", "render_call"),
        process_row("write_exr", "write_exr"),
        process_row("process exit (finalisation)", "teardown"),
        process_row("stage process wall (without the warm render)", "wall"),
        ["CLI wall (C)"] + [c for case in cases for c in (secs(case.cli_walls, 3), "-")],
    ]
    extra = []
    for case in cases:
        extra += [f"{median(case.cli_walls) - median(case.first('wall')):+.3f}", "-"]
    rows.append(["CLI wall - stage process wall (argparse, gshade.app.cli; noise)", *extra])
    return rows


def i_rows(walls: dict[str, list[float]]) -> list[list[str]]:
    rows, previous = [], None
    for label, xs in walls.items():
        added = "-" if previous is None else f"{median(xs) - previous:+.3f}"
        rows.append([label, secs(xs, 3), spread(xs, 3), added])
        previous = median(xs)
    return rows


def n_rows(scale: list[ScaleRun]) -> list[list[str]]:
    """One row per size; "marginal" is the growth over the smallest size per added patch."""
    rows, prev, base = [], None, None
    for sr in scale:
        is_target = sr.patches == TARGET_SCALE_PATCHES
        target = f"<= {TARGET_SCALE_S:g} s, <= {TARGET_SCALE_GB:g} GB" if is_target else "none"
        grid = f"{sr.patches:,} ({sr.nx} x {sr.ny})"
        if not sr.cli:
            why = sr.failure or "not run"
            rows.append([grid, f"{sr.toml_mib:.2f}", why] + ["-"] * (len(N_COLUMNS) - 5))
            rows[-1] += [target, "NO" if is_target else "-"]
            prev = None
            continue
        walls = [r.wall for r in sr.cli]
        rss = median([r.maxrss_kb for r in sr.cli])
        t, per = median(walls), 1e3 * median(walls) / sr.patches
        if base is None:
            base = (t, rss, sr.patches)
        added = sr.patches - base[2]
        ok = None
        if is_target:
            ok = t <= TARGET_SCALE_S and rss * 1024 <= TARGET_SCALE_GB * 1e9
        rows.append(
            [
                grid,
                f"{sr.toml_mib:.2f}",
                f"{t:.2f}",
                spread(walls),
                f"{per:.3g}",
                f"{1e3 * (t - base[0]) / added:.3g}" if added else "-",
                "-" if prev is None else f"{t / prev[0]:.2f}x (n {sr.patches / prev[2]:g}x)",
                mib(rss),
                f"{(rss - base[1]) / added:.3g}" if added else "-",
                "-" if prev is None else f"{rss / prev[1]:.2f}x",
                target,
                met(ok),
            ]
        )
        prev = (t, rss, sr.patches)
    return rows


def ns_rows(scale: list[ScaleRun]) -> list[list[str]]:
    rows = []
    for sr in scale:
        s = sr.stage
        if s is None:
            continue
        rows.append(
            [
                f"{sr.patches:,}",
                f"{s['tessellation']} / {s['texture_tile']}",
                f"{s['imports']:.2f}",
                f"{s['load_scene']:.2f}",
                *(f"{s['stages'][k]:.2f}" for k in STAGES),
                f"{s['write_exr']:.2f}",
                mib(s["maxrss_kb"]),
            ]
        )
    return rows


def biggest(case: EndToEnd, n: int = 4) -> str:
    process = ("startup", "imports", "load_scene", "write_exr", "teardown")
    parts = {k: median(case.first(k)) for k in process}
    parts |= {k: median(case.first(k)) for k in STAGES}
    cli = median(case.cli_walls)
    ranked = sorted(parts.items(), key=lambda kv: -kv[1])[:n]
    return ", ".join(f"{k} {v:.2f} s ({100 * v / cli:.0f} %)" for k, v in ranked)


def section(info, tables, notes, args) -> str:
    command = ".venv/bin/python benchmarks/bench_render.py --write" + (
        " --quick" if args.quick else ""
    )
    run = (
        f"Run: `{command}`; every render a fresh process with warm kernel caches; "
        f"{args.repeats} rounds for the teapot, {args.scale_repeats} timed run(s) per sheet "
        "size (medians)."
    )
    return markdown_section("Rendering (`benchmarks/bench_render.py`)", run, info, tables, notes)


# --------------------------------------------------------------------------- main


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--write", action="store_true", help="update benchmarks/RESULTS.md")
    parser.add_argument("--quick", action="store_true", help="fewer repeats")
    parser.add_argument(
        "--max-patches",
        type=int,
        default=TARGET_SCALE_PATCHES,
        help="largest sheet of the scale runs (for trials; the report needs 10000)",
    )
    args = parser.parse_args(argv)
    args.repeats = QUICK_REPEATS if args.quick else REPEATS
    args.scale_repeats = QUICK_SCALE_REPEATS if args.quick else SCALE_REPEATS
    load_start = load_average()
    if not SCENE.is_file():
        raise SanityError(f"{SCENE} is missing")

    # gshade's bytecode cache, as Python keeps it wherever it may write one (this
    # environment may forbid that: PYTHONDONTWRITEBYTECODE); stale files are never read
    compileall.compile_dir(str(ROOT / "src" / "gshade"), quiet=1)
    with tempfile.TemporaryDirectory(prefix="gshade-bench-render-") as name:
        tmp = Path(name)
        print("end to end and stages ...", file=sys.stderr)
        cases = measure_end_to_end(args.repeats, tmp)
        print("imports ...", file=sys.stderr)
        import_walls, ranked = measure_imports(IMPORT_REPEATS)
        print("scale ...", file=sys.stderr)
        sizes = [g for g in SCALE_GRIDS if g[0] * g[1] <= args.max_patches]
        scale = measure_scale(args.scale_repeats, tmp, sizes)

    info = machine_info(
        [f"mitsuba {version('mitsuba')}", f"drjit {version('drjit')}"],
        ["Dr.Jit: its default thread pool (all cores); children inherit this environment"],
    )
    lit = cases[0]
    tables = [
        (
            "C: the command line end to end (1024 x 768, 16 spp, llvm_ad_rgb)",
            C_COLUMNS,
            c_rows(cases),
        ),
        ("S: where the time goes (stage medians, seconds)", S_COLUMNS, s_rows(cases)),
        ("I: imports and start-up of the command's dependencies", I_COLUMNS, i_rows(import_walls)),
        (
            f"N: scale, a C1 sheet of n bicubic Bézier patches ({SCALE_SIZE} x {SCALE_SIZE}, "
            f"{SCALE_SPP} spp, {SCALE_LIGHTING})",
            N_COLUMNS,
            n_rows(scale),
        ),
        (
            "N: stages of one stage run per size (seconds; first render in a fresh process)",
            NS_COLUMNS,
            ns_rows(scale),
        ),
    ]
    scale_misses = [r[0] for r in n_rows(scale) if r[-1] == "NO"]
    misses = [] if median(lit.cli_walls) <= TARGET_CLI_S else [f"C lit {secs(lit.cli_walls)} s"]
    misses += [f"N {m} patches" for m in scale_misses]
    top_imports = ", ".join(f"{k} {v:.2f} s" for k, v in ranked if v >= 0.02)
    notes = [
        "S's first-render columns are medians of fresh processes (as the command runs them: "
        "Mitsuba loads its kernels from ~/.drjit then), interleaved with the CLI runs.  'Warm' "
        "is a second render() in the same process (kernels in memory, variant set, imports "
        "done).",
        f"Biggest parts of the lit CLI run (of {secs(lit.cli_walls)} s): {biggest(lit)}.",
        f"Imports by cumulative time (`python -X importtime`, one run of "
        f"`{list(IMPORT_CODES)[-1]}`; packages and gshade modules over 20 ms, each with "
        f"what it imports first, so nested ones overlap): {top_imports}.  In the command, "
        "Mitsuba is imported lazily, by the pipeline: its import and setting the variant are "
        "the `setup` stage.  PYTHONDONTWRITEBYTECODE="
        f"{os.environ.get('PYTHONDONTWRITEBYTECODE', 'unset')} in this environment (children "
        "inherit it, and do not write bytecode caches): gshade's modules are compiled once "
        "with compileall before the runs, as Python caches them itself on a usual machine.",
        f"Teapot: {cases[0].stage[0]['patches']} patches, tessellation "
        f"{cases[0].stage[0]['tessellation']} vertices per patch side, texture tile "
        f"{cases[0].stage[0]['texture_tile']}; coverage "
        f"{100 * cases[0].stage[0]['coverage']:.0f} % of the pixels.",
        "Sheet: z = 0.2 sin(pi x) cos(pi y) over [-1, 1]^2, one `[[surface]]` of type bezier "
        "per patch (gshade's bezier surface type holds exactly one patch), control points "
        "written with Python's repr (round trip exact); edges shared bit for bit and the "
        "corner values checked on a 3 x 2 sheet before the runs.  Peak RSS: the CLI child's "
        "ru_maxrss from os.wait4 (its own, not the benchmark's).  Marginal per patch: (value "
        "- value at 1 patch) / (n - 1), the cost of each added patch without the fixed costs.",
        f"Load average (1, 5, 15 min): {load_start} at the start, {load_average()} at the end.",
        "Targets missed: " + (", ".join(misses) if misses else "none") + ".",
    ]
    for sr in scale:
        if sr.failure:
            notes.append(f"Scale {sr.patches} patches: {sr.failure}")

    text = (SECTION, section(info, tables, notes, args)) if args.write else None
    publish(info, tables, notes, text)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except SanityError as exc:
        sys.exit(f"FAILED sanity check, timings not reported.\n{exc}")
