"""Benchmark gshade against what a user would do otherwise: whole commands, side by side.

Whole processes, interleaved within each round (the order of each pair alternating from
round to round), one untimed warm-up round first (Dr.Jit's kernel cache in ``~/.drjit``, the
file cache), then ``--rounds`` timed rounds.  Per process: wall time (start to exit), CPU
time (user + system) and peak RSS (``ru_maxrss`` of ``os.wait4``).

- Teapot (``scenes/teapot-isophotes.toml`` and ``scenes/teapot-mean.toml``: 32 bicubic
  patches, 1024 x 768, 16 spp, lit): ``gshade render SCENE -o OUT.exr`` against
  ``benchmarks/teapot_peer.py``: the same patches evaluated on 64 x 64 vertices each, welded
  in PyVista, VTK's normals (isophotes: two-colour stripes of <n, l>) or VTK's discrete mean
  curvature (with the stripes' edges as lines), plotted off-screen through gshade's resolved
  camera (EGL, Mesa's llvmpipe) to a PNG.  Per round also a stage run of each scene
  (``bench_render``'s in-process copy of the command, ``RenderedImage.timings``) that then
  calls ``render`` a second time in the same process, as ``batch`` and a notebook do.
- CAD part (``scenes/data/bracket.step``): ``gshade render FILE --set shape.function=mean``
  against ``cad_peer.py`` (Open CASCADE's mesh at gshade's deflection, VTK's curvature), as
  ``bench_cad.py`` runs them (its functions).
- ``gshade compare`` against OpenImageIO on a 2048 x 2048 pair of EXRs with 8 float32
  channels (R G B A f P.X P.Y P.Z, written by gshade's EXR writer, made at run time):
  ``gshade compare --channels`` (all 8) against ``idiff`` (all channels), and ``gshade
  compare`` (R, G, B) against ``oiiotool A --ch R,G,B B --ch R,G,B --diff``; the same
  thresholds, and the verdicts, failing pixels and largest error checked to agree.

The error of the peers' values (untimed, after the rounds): at the pixels of gshade's EXR
fully covered and whose 3 x 3 neighbourhood lies on one patch (face), the peer's value
interpolated linearly on the closest triangle at gshade's exact point ``P``, against
gshade's exact value there: as ``bench_cad.py``, |s x_peer - x| / q with q the 99th
percentile of |x| over those pixels and s = +-1 by the sign of the correlation.

Targets (issue 15): teapot, both scenes, gshade / peer <= 1.0 and peak RSS <= the peer's; a
second ``render`` of the lit teapot in one process <= 1.0 s; ``gshade compare`` <= 1.5 x the
OpenImageIO tool's time and <= 2 x its memory, on the same channels.

Usage, from the repository root::

    .venv/bin/python benchmarks/bench_peer.py [--rounds 5] [--quick] [--write] [--keep DIR]
"""

from __future__ import annotations

import argparse
import compileall
import json
import os
import re
import resource
import sys
import tempfile
from dataclasses import dataclass, field
from functools import partial
from importlib.metadata import version
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from bench_cad import PROBE_CHILD, Model, Process, json_line, peer_command, probe, timed
from bench_render import (
    GSHADE,
    PYTHON,
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
from report import load_average, machine_info, markdown_section, publish

ROOT = Path(__file__).resolve().parent.parent
BIN = Path(sys.executable).parent
SCENES = {s: ROOT / "scenes" / f"teapot-{s}.toml" for s in ("isophotes", "mean")}
EXACT = {"isophotes": "f", "mean": "f2"}  # the exact <n, l> and H at the pixel centres
BRACKET = ROOT / "scenes" / "data" / "bracket.step"
TEAPOT_PEER = Path(__file__).with_name("teapot_peer.py")
MEAN_SETS = ("--set", "shape.function=mean")
SIZE_SETS = ("render.width=1024", "render.height=768", "render.spp=16")
PAIR_CHANNELS = ("R", "G", "B", "A", "f", "P.X", "P.Y", "P.Z")
PAIR_SIZE, QUICK_PAIR_SIZE = 2048, 512
THRESHOLDS = {"fail": 0.02, "failpercent": 1.0, "warn": 0.01, "warnpercent": 0.1}
TIMEOUT_S = 600
TARGET_RATIO, TARGET_SECOND_S, TARGET_COMPARE_RATIO, TARGET_COMPARE_RSS = 1.0, 1.0, 1.5, 2.0
#: Against the plainer teapot peer (``teapot_peer.py --plain``: no contour lines), issue 27.
TARGET_PLAIN_RATIO = 0.8
SECTION = "bench_peer"


@dataclass
class Case:
    """One side-by-side comparison: gshade's command and the peer's, per round."""

    label: str  # the case
    tool: str  # gshade's command
    peer_label: str
    ratio_target: float | None = None
    rss_target: float | None = None  # gshade's peak RSS <= this x the peer's
    gshade: list[Process] = field(default_factory=list)
    peer: list[Process] = field(default_factory=list)

    def ratios(self) -> list[float]:
        return [g.wall / p.wall for g, p in zip(self.gshade, self.peer, strict=True)]


@dataclass
class Teapot:
    """A teapot scene: its camera, stage runs, the peer's stages and the error."""

    shape: str
    camera: dict | None = None
    stages: list[dict] = field(default_factory=list)
    peer_stages: list[dict] = field(default_factory=list)
    error: dict | None = None


# --------------------------------------------------------------------------- commands


def teapot_peer_command(
    teapot: Teapot, png: Path, sample: tuple[Path, Path] | None = None, plain: bool = False
):
    cmd = [PYTHON, str(TEAPOT_PEER), teapot.shape, str(png)]
    cmd += ["--camera", json.dumps(teapot.camera)] + (["--plain"] if plain else [])
    return cmd + (["--sample", str(sample[0]), str(sample[1])] if sample else [])


def threshold_flags(prefix: str = "--") -> list[str]:
    return [x for k, v in THRESHOLDS.items() for x in (f"{prefix}{k}", repr(v))]


def compare_commands(test: Path, ref: Path) -> dict[str, list[str]]:
    """gshade's two compare commands and OpenImageIO's counterparts."""
    gshade = [GSHADE, "compare", str(test), str(ref), *threshold_flags()]
    rgb_pair = [str(test), "--ch", "R,G,B", str(ref), "--ch", "R,G,B"]
    return {
        "gshade all": [*gshade, "--channels", ",".join(PAIR_CHANNELS)],
        "idiff": [str(BIN / "idiff"), *threshold_flags("-"), str(test), str(ref)],
        "gshade RGB": gshade,
        "oiiotool RGB": [str(BIN / "oiiotool"), *threshold_flags(), *rgb_pair, "--diff"],
    }


def measured(cmd: list[str], what: str, output: Path | None = None, codes=(0,)) -> tuple:
    """Run a command; raise unless its exit status is one of ``codes`` (and it wrote
    ``output``); the run and its :class:`Process`."""
    run, cpu = timed(cmd)
    if run.returncode not in codes:
        raise SanityError(f"{what}: exit status {run.returncode}; {run.stderr[-2000:]}")
    if output is not None:
        checked(run, what, output)
    return run, Process(run.wall, cpu, run.maxrss_kb)


# --------------------------------------------------------------------------- the pair


def write_pair(folder: str, size: int) -> None:
    """Write ``test.exr`` and ``ref.exr``, like gshade's: an object (a disc, 60 % of the
    image) with smooth channels, zeros around it; the test differs by N(0, 1e-5) noise on the
    object and by 0.05 in R, G, B and f on a spot of 0.3 % of the pixels.  Run in a child
    process: a child's ``ru_maxrss`` starts from its parent's peak (exec after vfork), so the
    benchmark itself must stay small."""
    from gshade.io.image import write_exr

    y, x = (np.mgrid[0:size, 0:size] + 0.5) / size
    inside = (x - 0.5) ** 2 + (y - 0.5) ** 2 < 0.6 / np.pi
    spot = (x - 0.6) ** 2 + (y - 0.4) ** 2 < 0.003 / np.pi
    smooth = {
        "R": 0.5 + 0.4 * np.sin(6 * x) * np.cos(4 * y),
        "G": 0.5 + 0.4 * np.cos(5 * x + y),
        "B": 0.5 + 0.3 * np.sin(3 * y),
        "A": np.ones_like(x),
        "f": np.sin(8 * x) * np.cos(7 * y),
        "P.X": 2 * x - 1,
        "P.Y": 2 * y - 1,
        "P.Z": 0.3 * np.sin(4 * x * y),
    }
    rng = np.random.default_rng(15)
    ref, test = {}, {}
    for name in PAIR_CHANNELS:
        ref[name] = np.where(inside, smooth[name], 0.0).astype(np.float32)
        noisy = ref[name] + np.where(inside, rng.normal(0.0, 1e-5, x.shape), 0.0)
        test[name] = (noisy + (0.05 * spot if name in "RGBf" else 0.0)).astype(np.float32)
    write_exr(Path(folder) / "test.exr", test)
    write_exr(Path(folder) / "ref.exr", ref)


def oiio_report(text: str) -> tuple:
    """Verdict, failing pixels, largest error, its x and y, from idiff's or oiiotool's report."""
    fail = re.search(rf"(\d+) pixels \([^)]*\) over {THRESHOLDS['fail']:g}\b", text)
    peak = re.search(r"Max error\s*=\s*(\S+) @ \((\d+), (\d+)", text)
    verdicts = [x.strip() for x in text.splitlines() if x.strip() in ("PASS", "WARNING", "FAILURE")]
    if not (fail and peak and verdicts):
        raise SanityError(f"could not read OpenImageIO's report:\n{text[-2000:]}")
    return verdicts[-1], int(fail.group(1)), float(peak.group(1)), *map(int, peak.group(2, 3))


def check_agreement(commands: dict[str, list[str]]) -> dict[str, int]:
    """Untimed: both sides' verdict, failing pixels and largest error agree; the exit
    status each timed run must give."""
    codes = {}
    for ours, theirs in (("gshade all", "idiff"), ("gshade RGB", "oiiotool RGB")):
        run = run_process([*commands[ours], "--json"], TIMEOUT_S)
        if run.returncode not in (0, 1, 2):
            raise SanityError(f"{ours}: exit status {run.returncode}; {run.stderr[-2000:]}")
        mine = json.loads(run.stdout)
        other_run = run_process(commands[theirs], TIMEOUT_S)
        verdict, failing, largest, *where = oiio_report(other_run.stdout)
        got = (mine["verdict"], mine["failing_pixels"], *mine["overall"]["max_at"])
        expected = (verdict, failing, *where)
        close = abs(mine["overall"]["max_error"] - largest) <= 1e-6
        if got != expected or not close:
            raise SanityError(f"{ours} and {theirs} disagree: {got} against {expected}")
        codes[ours], codes[theirs] = run.returncode, other_run.returncode
    return codes


# --------------------------------------------------------------------------- rounds


def pair(index: int, gshade, peer) -> None:
    """gshade's and the peer's step, gshade first in even rounds."""
    for step in (gshade, peer) if index % 2 == 0 else (peer, gshade):
        step()


def step(keep: bool, processes: list, cmd: list, what: str, output=None, codes=(0,), stages=None):
    """One side of a pair: run ``cmd`` (``output`` removed first); in the timed rounds,
    append its :class:`Process` to ``processes`` and its ``PEER_JSON`` stages to ``stages``."""

    def run_step() -> None:
        run, process = measured(cmd, what, output and fresh(output), codes)
        if keep:
            processes.append(process)
            if stages is not None:
                stages.append(json_line(run, "PEER_JSON")["stages"])

    return run_step


def one_round(index: int, state: dict, tmp: Path) -> None:
    """Round ``index`` (0: the untimed warm-up) of every case."""
    keep, cases = index > 0, state["cases"]
    for shape, teapot in state["teapots"].items():
        exr, png = tmp / f"{shape}.exr", tmp / f"{shape}-peer.png"
        gshade = cli_command(SCENES[shape], exr)
        peer = teapot_peer_command(teapot, png)
        pair(
            index,
            step(keep, cases[shape].gshade, gshade, f"gshade render teapot-{shape}", exr),
            step(keep, cases[shape].peer, peer, f"peer {shape}", png, stages=teapot.peer_stages),
        )
        plain = teapot_peer_command(teapot, png, plain=True)
        pair(
            index,
            step(keep, cases[f"{shape} plain"].gshade, gshade, f"gshade teapot-{shape}", exr),
            step(keep, cases[f"{shape} plain"].peer, plain, f"plain peer {shape}", png),
        )
        if keep:
            run = run_process(stage_command(SCENES[shape], fresh(exr), 1), TIMEOUT_S)
            teapot.stages.append(checked(run, f"stage run teapot-{shape}", exr).result())
    model, case = state["bracket"], cases["bracket"]
    exr, png = tmp / "bracket.exr", tmp / "bracket-peer.png"
    pair(
        index,
        step(keep, case.gshade, cli_command(model.path, exr, MEAN_SETS), "gshade bracket", exr),
        step(keep, case.peer, peer_command(model, png), "cad_peer", png, stages=model.peer_stages),
    )
    commands, codes = state["commands"], state["codes"]
    for ours, theirs in (("gshade all", "idiff"), ("gshade RGB", "oiiotool RGB")):
        case = cases[ours]
        pair(
            index,
            step(keep, case.gshade, commands[ours], ours, codes=(codes[ours],)),
            step(keep, case.peer, commands[theirs], theirs, codes=(codes[theirs],)),
        )
    print(f"round {index}/{state['rounds']} done", file=sys.stderr)


# --------------------------------------------------------------------------- the error


def peer_error(exr: Path, channel: str, sample_command, tmp: Path) -> dict:
    """The peer's values at gshade's exact points against gshade's ``channel`` there."""
    from gshade.io.image import read_exr

    channels, _ = read_exr(exr)
    patch = channels["patch"]
    inner = (channels["A"] >= 0.999) & (patch >= 0)
    padded = np.pad(patch, 1, constant_values=-1)
    height, width = patch.shape
    for dy in (0, 1, 2):
        for dx in (0, 1, 2):
            inner &= padded[dy : dy + height, dx : dx + width] == patch
    points = np.stack([channels[f"P.{a}"][inner] for a in "XYZ"], -1).astype(np.float64)
    exact = channels[channel][inner].astype(np.float64)
    np.save(tmp / "P.npy", points)
    checked(run_process(sample_command(tmp / "P.npy", tmp / "x.npy"), TIMEOUT_S), "sampling")
    peer = np.load(tmp / "x.npy")
    sign = -1.0 if float(np.dot(peer, exact)) < 0 else 1.0
    scale = float(np.percentile(np.abs(exact), 99)) or 1.0
    relative = np.abs(sign * peer - exact) / scale
    return {
        "pixels": int(inner.sum()),
        "sign": sign,
        "scale": scale,
        "median": float(np.median(relative)),
        "p95": float(np.percentile(relative, 95)),
        "max": float(relative.max()),
    }


def errors(state: dict, tmp: Path, keep: Path | None) -> None:
    """Untimed: gshade's EXR (and PNG) of each case, the peer's values at its points."""
    out = keep or tmp
    for shape, teapot in state["teapots"].items():
        exr = tmp / f"error-{shape}.exr"
        run = run_process(cli_command(SCENES[shape], exr, ("--png", str(out / f"{shape}.png"))))
        checked(run, f"gshade render teapot-{shape}", exr)
        png = out / f"{shape}-peer.png"
        sample = partial(teapot_peer_command, teapot, png)
        teapot.error = peer_error(exr, EXACT[shape], lambda p, x, f=sample: f((p, x)), tmp)
    model = state["bracket"]
    exr, png = tmp / "error-bracket.exr", out / "bracket-peer.png"
    sets = (*MEAN_SETS, "--png", str(out / "bracket.png"))
    checked(run_process(cli_command(model.path, exr, sets)), "gshade render bracket.step", exr)
    model.error = peer_error(exr, "f", lambda p, x: peer_command(model, png, (p, x)), tmp)


# --------------------------------------------------------------------------- tables


def walls(xs: list[Process]) -> list[float]:
    return [x.wall for x in xs]


MAIN_COLUMNS = (
    "Case|gshade|wall s [min-max]|peer|peer wall s [min-max]|gshade / peer [min-max]|"
    "CPU s gshade / peer|peak RSS MiB gshade / peer|target|Met"
).split("|")


def main_rows(cases: dict[str, Case]) -> list[list[str]]:
    rows = []
    for case in cases.values():
        g, p, r = walls(case.gshade), walls(case.peer), case.ratios()
        rss_g, rss_p = max(x.maxrss_kb for x in case.gshade), max(x.maxrss_kb for x in case.peer)
        target, ok = "none", None
        if case.ratio_target is not None:
            target, ok = f"ratio <= {case.ratio_target:g}", median(r) <= case.ratio_target
            if case.rss_target is not None:
                target += f", RSS <= {case.rss_target:g} x peer"
                ok = ok and rss_g <= case.rss_target * rss_p
        cpu = " / ".join(f"{median([x.cpu for x in xs]):.2f}" for xs in (case.gshade, case.peer))
        timings = [f"{secs(g)} [{spread(g)}]", case.peer_label, f"{secs(p)} [{spread(p)}]"]
        ratio = f"{median(r):.2f} [{spread(r)}]"
        memory = f"{mib(rss_g)} / {mib(rss_p)}"
        rows.append([case.label, case.tool, *timings, ratio, cpu, memory, target, met(ok)])
    return rows


ERROR_COLUMNS = ["Peer value", "pixels", "q (p99 of exact)", "s", "median", "p95", "max"]


def error_rows(state: dict) -> list[list[str]]:
    named = [
        ("teapot <n, l> (VTK normals, 64 x 64 per patch)", state["teapots"]["isophotes"].error),
        ("teapot H (VTK, negated; 64 x 64 per patch)", state["teapots"]["mean"].error),
        ("bracket.step H (OCCT mesh, VTK)", state["bracket"].error),
    ]
    return [
        [label, f"{e['pixels']:,}", f"{e['scale']:.3g}", f"{e['sign']:+.0f}"]
        + [f"{100 * e[k]:.3g} %" for k in ("median", "p95", "max")]
        for label, e in named
    ]


SECOND_COLUMNS = ["Scene", "first render() s", "second render() s [min-max]", "target", "Met"]


def second_rows(teapots: dict[str, Teapot]) -> list[list[str]]:
    rows = []
    for shape, teapot in teapots.items():
        first = [s["render_call"] for s in teapot.stages]
        second = [w["render_call"] for s in teapot.stages for w in s["warm"]]
        target = TARGET_SECOND_S if shape == "isophotes" else None  # the lit teapot's target
        ok = None if target is None else median(second) <= target
        cells = [secs(first), f"{secs(second)} [{spread(second)}]"]
        rows.append([f"teapot-{shape}", *cells, f"<= {target:g} s" if target else "none", met(ok)])
    return rows


def stage_rows(teapots: dict[str, Teapot], cases: dict[str, Case]) -> list[list[str]]:
    """gshade's stage medians (fresh process, first render) against the CLI's wall; the
    render's stages as ``RenderedImage.timings`` names them."""
    stages = list(dict.fromkeys(k for t in teapots.values() for k in t.stages[0]["stages"]))

    def get(t: Teapot, key: str) -> str:
        xs = [s["stages"].get(key, 0.0) if key in stages else s[key] for s in t.stages]
        return f"{median(xs):.2f}"

    keys = ("startup", "imports", "load_scene", *stages, "write_exr", "teardown", "wall")
    labels = {"wall": "sum = stage run's wall"} | {k: f"render: {k}" for k in stages}
    rows = [[labels.get(k, k), *(get(t, k) for t in teapots.values())] for k in keys]
    return [*rows, ["CLI wall (median)", *(secs(walls(cases[s].gshade)) for s in teapots)]]


def peer_stage_rows(state: dict) -> list[list[str]]:
    runs = [t.peer_stages for t in state["teapots"].values()] + [state["bracket"].peer_stages]
    keys = list(dict.fromkeys(k for stages in runs for k in stages[0]))
    rows = [
        [k, *(f"{median([s[k] for s in st]):.2f}" if k in st[0] else "-" for st in runs)]
        for k in keys
    ]
    rows.append(
        ["sum (in process)", *(f"{median([sum(s.values()) for s in st]):.2f}" for st in runs)]
    )
    cases = [state["cases"][k] for k in (*SCENES, "bracket")]
    return [*rows, ["whole process wall", *(secs(walls(c.peer)) for c in cases)]]


# --------------------------------------------------------------------------- main


def notes_for(state: dict, args, load_start: str) -> list[str]:
    size = state["pair_size"]
    processes = [x for c in state["cases"].values() for x in (*c.gshade, *c.peer)]
    smallest = min(x.maxrss_kb for x in processes)
    return [
        "Teapot peer (`teapot_peer.py`): Newell's file parsed with numpy, each patch on 64 x 64 "
        "vertices (Bernstein basis), one PolyData welded with `clean()`, `compute_normals`, "
        "isophotes as <n, l> through a 40-entry dark/light lookup table on [-1, 1] (gshade's "
        "20 stripes, duty 1/2; VTK interpolates the scalar before mapping, so the stripes are "
        "sharp but aliased: one sample per pixel); mean: `-curvature('mean')` (VTK's sign is "
        "the opposite of gshade's for the same normals) on coolwarm [-3, 3], and the stripes' "
        "edges (<n, l> = k / 20) as black `contour` lines instead of gshade's darkened bands; "
        "Phong shading with those normals, VTK's light kit, gshade's resolved camera, "
        "off-screen through EGL (Mesa llvmpipe), a 1024 x 768 PNG.  gshade writes a 15- or "
        "16-channel EXR (exact f, P, N, u, v, patch) at 16 spp; the peer only a PNG.",
        "CAD part: `scenes/data/bracket.step` rendered as a file (as `bench_cad.py` does: the "
        "automatic camera, `--set shape.function=mean`, drawn as stripes of H, the default "
        "display, with H exact in the EXR's f; no junction lines, unlike "
        "`scenes/bracket-mean.toml`); the peer `cad_peer.py` at gshade's deflection and camera.",
        f"Compare: a {size} x {size} pair, 8 float32 channels ({', '.join(PAIR_CHANNELS)}; "
        "ZIPS, gshade's EXR writer), an object covering 60 % of the image with smooth "
        "channels, N(0, 1e-5) noise on it in the test image and +0.05 in R, G, B, f on 0.3 % "
        "of the pixels; thresholds "
        + ", ".join(f"{k} {v:g}" for k, v in THRESHOLDS.items())
        + ".  `idiff` compares all channels (by position; the files list them in the same "
        "order); it has no channel option, so the R, G, B comparison's peer is `oiiotool A "
        "--ch R,G,B B --ch R,G,B --diff` with the same thresholds (it reads both files, "
        "keeps R, G, B, and prints idiff's report; its exit status is 0 on WARNING, so its "
        "verdict line is read).  Checked once, untimed, before the rounds: verdicts "
        f"({state['verdicts']}), failing pixels and the largest error and its pixel agree.",
        "Ratios: median of the per-round ratios gshade wall / peer wall, min-max over the "
        "rounds in brackets.  Peak RSS: the largest over the rounds of the child's ru_maxrss "
        "(os.wait4), which starts from the parent's peak (exec after vfork): this script's own "
        f"peak during the rounds was {mib(state['own_rss_kb'])} MiB (the smallest figure "
        f"above: {mib(smallest)} MiB).",
        "Peer error: at the pixels of gshade's EXR fully covered and with a 3 x 3 neighbourhood "
        "on one patch (face), |s x_peer(P) - x| / q, x gshade's exact value at the pixel "
        "centre's hit P (teapot-isophotes: f = <N, l>; teapot-mean: f2 = H; bracket: f = H), "
        "x_peer the peer's per-vertex value interpolated linearly on the triangle closest to "
        "P, q the 99th percentile of |x| over those pixels, s = +-1 by the sign of the "
        "correlation (bracket: -1, VTK's sign convention, as in bench_cad; the teapot peer "
        "negates H itself).  The teapot's largest errors lie at the lid's and the bottom's "
        "poles (a patch edge collapsed into one point) and along the G1 seams, where the "
        "mesh's curvature is smeared over a ring of vertices.",
        "Second render: the stage run calls `gshade.rendering.render(scene)` twice in one "
        "process (kernels in memory, variant set); the second call's time.",
        f"Load average (1, 5, 15 min): {load_start} at the start, {load_average()} at the end.",
    ]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--quick", action="store_true", help="1 round, a 512 x 512 pair")
    parser.add_argument("--write", action="store_true", help="update benchmarks/RESULTS.md")
    parser.add_argument("--keep", type=Path, help="keep the pictures here")
    args = parser.parse_args(argv)
    rounds = 1 if args.quick else args.rounds
    load_start = load_average()
    compileall.compile_dir(str(ROOT / "src" / "gshade"), quiet=1)
    if args.keep:
        args.keep.mkdir(parents=True, exist_ok=True)
    teapots = {s: Teapot(s) for s in SCENES}
    cases = {
        s: Case(f"teapot-{s}", "gshade render", "teapot_peer.py", TARGET_RATIO, TARGET_RATIO)
        for s in SCENES
    }
    for s in SCENES:
        plain = "teapot_peer.py --plain"
        cases[f"{s} plain"] = Case(
            f"teapot-{s}", "gshade render", plain, TARGET_PLAIN_RATIO, TARGET_RATIO
        )
    cases["bracket"] = Case("bracket.step (mean)", "gshade render", "cad_peer.py")
    compare_targets = (TARGET_COMPARE_RATIO, TARGET_COMPARE_RSS)
    size = QUICK_PAIR_SIZE if args.quick else PAIR_SIZE
    for key, channels, peer in (("all", "all 8 channels", "idiff"), ("RGB", "R, G, B", "oiiotool")):
        label = f"{size} x {size} pair, {channels}"
        cases[f"gshade {key}"] = Case(label, "gshade compare", peer, *compare_targets)
    state = {"teapots": teapots, "cases": cases, "rounds": rounds, "bracket": Model(BRACKET)}
    state["pair_size"] = size
    with tempfile.TemporaryDirectory(prefix="gshade-bench-peer-") as name:
        tmp = Path(name)
        for shape, teapot in teapots.items():
            run = run_process([PYTHON, "-c", PROBE_CHILD, str(SCENES[shape]), *SIZE_SETS])
            teapot.camera = json_line(checked(run, "camera probe"), "BENCH_JSON")["camera"]
        probe(state["bracket"])
        here = str(Path(__file__).parent)
        code = f"import sys; sys.path.insert(0, {here!r}); from bench_peer import write_pair; "
        code += f"write_pair({str(tmp)!r}, {size})"
        checked(run_process([PYTHON, "-c", code], TIMEOUT_S), "writing the EXR pair")
        state["commands"] = compare_commands(tmp / "test.exr", tmp / "ref.exr")
        state["codes"] = check_agreement(state["commands"])
        state["verdicts"] = ", ".join(f"{k}: exit {v}" for k, v in state["codes"].items())
        for index in range(rounds + 1):
            one_round(index, state, tmp)
        state["own_rss_kb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        errors(state, tmp, args.keep)

    packages = ("mitsuba", "pyvista", "vtk", "cadquery-ocp-novtk", "OpenImageIO")
    info = machine_info(
        [f"{p} {version(p)}" for p in packages],
        ["Dr.Jit: its default thread pool; VTK: EGL (Mesa llvmpipe); OpenImageIO: its default"],
    )
    peer_columns = ["Peer stage", "teapot isophotes", "teapot mean", "bracket.step"]
    tables = [
        ("Whole commands (medians over the rounds)", MAIN_COLUMNS, main_rows(cases)),
        ("The peers' values at gshade's exact pixels", ERROR_COLUMNS, error_rows(state)),
        ("A second render in the same process (stage runs)", SECOND_COLUMNS, second_rows(teapots)),
        (
            "gshade's stages (stage runs, medians, s)",
            ["Stage", *SCENES],
            stage_rows(teapots, cases),
        ),
        ("The peers' stages (medians, s)", peer_columns, peer_stage_rows(state)),
    ]
    notes = notes_for(state, args, load_start)
    run = (
        f"Run: `.venv/bin/python benchmarks/bench_peer.py --rounds {rounds}"
        f"{' --quick' if args.quick else ''} --write`; whole processes, one untimed warm-up "
        f"round, then {rounds} rounds, each pair interleaved (the order alternating)."
    )
    heading = "gshade and its peers, whole commands (`benchmarks/bench_peer.py`)"
    text = (SECTION, markdown_section(heading, run, info, tables, notes)) if args.write else None
    publish(info, tables, notes, text)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except SanityError as exc:
        sys.exit(f"FAILED sanity check, timings not reported.\n{exc}")
