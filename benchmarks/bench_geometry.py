"""Benchmark gshade's surface evaluation and curvature kernels against splipy and geomdl.

What is measured (wall-clock, ``time.perf_counter``, median over repeats after a warm-up):

W1  A bicubic B-spline patch with 20 x 20 control points and clamped uniform knots on
    [0, 1], evaluated on a 500 x 500 parameter grid with every derivative up to order 2
    (p, p_u, p_v, p_uu, p_uv, p_vv):
      * gshade: one ``BSplinePatch.derivatives(u[:, None], v[None, :], 2)`` call (grid path);
      * splipy: ``surface(u, v)`` plus ``surface.derivative(u, v, d=(i, j))`` for the five
        derivatives, each evaluated on the tensor grid as splipy does it;
      * geomdl: ``BSpline.Surface.derivatives(u, v, order=2)``, one call per point.  It is
        too slow for 250,000 points, so it is timed on a random subsample of the grid
        points and the time is scaled linearly to the full grid (marked "extrapolated").
W2  The same patch as a NURBS with random weights in [0.5, 2] (splipy: ``rational=True``
    with weight-premultiplied control points and the weight as last coordinate; geomdl:
    ``NURBS.Surface`` with weighted control points).
KH  Gaussian and mean curvature at the 250,000 grid points of W1 from the already computed
    derivatives: only ``gaussian_and_mean_curvature(d)`` is timed.
D   W1 and W2 again as users and CI run them: OpenBLAS's default thread pool (one thread per
    core, OPENBLAS_NUM_THREADS unset), gshade returning a fresh result, in a child process
    (``--default-threads-child``) with OPENBLAS_NUM_THREADS set but empty; once on the quiet
    machine and LOADED_RUNS times with a busy process (``while True: pass``, one core's
    worth, not pinned) running beside it; the samples of the loaded runs are pooled.
    gshade limits BLAS to one thread during its own calls (``gshade.geometry.core.blas_threads``);
    splipy runs with the default pool.

gshade and splipy are timed interleaved (one call of each per repeat), so that both see the
same machine state; geomdl is timed afterwards.  Before timing, every library's derivatives
are checked against gshade's (all six, on every point compared); the run fails if any
differs by more than 1e-10 relative to that derivative's largest magnitude.  K and H are
checked against a plain textbook evaluation from splipy's derivatives.

The other rows run with ``OPENBLAS_NUM_THREADS=1`` (set below unless the environment sets it).

Usage, from the repository root::

    .venv/bin/python benchmarks/bench_geometry.py            # print the table
    .venv/bin/python benchmarks/bench_geometry.py --write    # and update RESULTS.md
    .venv/bin/python benchmarks/bench_geometry.py --quick    # fewer repeats

``--write`` replaces this benchmark's section of ``benchmarks/RESULTS.md`` (between the
``bench_geometry`` markers) and leaves the rest of the file alone.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from importlib.metadata import version

# Small BLAS products on a 2-core machine: one BLAS thread for both libraries (measured:
# with two, medians jumped between 9 and 279 ms from run to run).  Set before numpy
# loads (``report`` sets it too, before it imports numpy); an explicit OPENBLAS_NUM_THREADS
# in the environment wins, and the report records it.  The child of rows D gets the
# variable set but empty, which this keeps and OpenBLAS reads as unset (its default pool,
# one thread per core); the child checks that with threadpoolctl.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
import splipy
from geomdl import NURBS, BSpline
from report import (
    Timing,
    load_average,
    machine_info,
    markdown_table,
    publish,
    time_interleaved,
)
from threadpoolctl import threadpool_info

from gshade.geometry import BSplinePatch, gaussian_and_mean_curvature

#: The flag of the child process that times the default thread pool (rows D).
CHILD_FLAG = "--default-threads-child"

N_CTRL = 20  # control points per direction
DEGREE = 3
GRID = 500  # parameter values per direction
GEOMDL_POINTS = 200  # grid points per geomdl repeat
REPEATS, QUICK_REPEATS = 15, 3
LOADED_RUNS, QUICK_LOADED_RUNS = 3, 1  # child processes with a busy process beside them
GEOMDL_REPEATS, QUICK_GEOMDL_REPEATS = 5, 1
REL_TOL = 1e-10
SEED = 20240611

#: The derivatives compared and timed, as (i, j) for d^(i+j) p / du^i dv^j.
MULTI_INDICES = ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2))

SECTION = "bench_geometry"  # its markers in RESULTS.md


# --------------------------------------------------------------------------- test surface


@dataclass(frozen=True)
class Surface:
    points: np.ndarray  # (N_CTRL, N_CTRL, 3)
    weights: np.ndarray | None  # (N_CTRL, N_CTRL) or None
    knots: np.ndarray  # clamped uniform on [0, 1], shared by u and v

    @property
    def homogeneous(self) -> np.ndarray:
        """(w x, w y, w z, w) control points, the convention of splipy and geomdl."""
        if self.weights is None:
            return self.points
        w = self.weights[..., None]
        return np.concatenate([self.points * w, w], axis=-1)


def make_surfaces(rng: np.random.Generator) -> tuple[Surface, Surface]:
    """A random height field over the unit square, polynomial (W1) and rational (W2)."""
    g = np.linspace(0.0, 1.0, N_CTRL)
    points = np.empty((N_CTRL, N_CTRL, 3))
    points[..., 0] = g[:, None]
    points[..., 1] = g[None, :]
    points[..., 2] = rng.uniform(-0.2, 0.2, (N_CTRL, N_CTRL))
    inner = np.linspace(0.0, 1.0, N_CTRL - DEGREE + 1)
    knots = np.concatenate([np.zeros(DEGREE), inner, np.ones(DEGREE)])
    weights = rng.uniform(0.5, 2.0, (N_CTRL, N_CTRL))
    return Surface(points, None, knots), Surface(points, weights, knots)


# --------------------------------------------------------------------------- the libraries


def gshade_patch(s: Surface) -> BSplinePatch:
    return BSplinePatch(s.points, (DEGREE, DEGREE), (s.knots, s.knots), weights=s.weights)


def gshade_eval(
    patch: BSplinePatch, u: np.ndarray, v: np.ndarray, out: np.ndarray | None = None
) -> np.ndarray:
    return patch.derivatives(u[:, None], v[None, :], 2, out=out)


def splipy_surface(s: Surface) -> splipy.Surface:
    basis = splipy.BSplineBasis(DEGREE + 1, s.knots)  # splipy's "order" is degree + 1
    cp = s.homogeneous
    # splipy reads a flat list of control points with the first (u) index varying fastest.
    flat = cp.transpose(1, 0, 2).reshape(-1, cp.shape[-1])
    return splipy.Surface(basis, basis, flat, rational=s.weights is not None)


def splipy_eval(surface: splipy.Surface, u: np.ndarray, v: np.ndarray) -> list[np.ndarray]:
    """The six grid derivatives, each (GRID, GRID, 3), in the order of MULTI_INDICES."""
    # d must be a tuple: splipy's rational second derivatives compare it with tuples.
    return [surface(u, v)] + [surface.derivative(u, v, d=ij) for ij in MULTI_INDICES[1:]]


def geomdl_surface(s: Surface) -> BSpline.Surface:
    surface = BSpline.Surface() if s.weights is None else NURBS.Surface()
    surface.degree_u = surface.degree_v = DEGREE
    cp = s.homogeneous
    # geomdl reads a flat list with the second (v) index varying fastest.
    surface.set_ctrlpts(cp.reshape(-1, cp.shape[-1]).tolist(), N_CTRL, N_CTRL)
    surface.knotvector_u = s.knots.tolist()
    surface.knotvector_v = s.knots.tolist()
    return surface


def geomdl_eval(surface: BSpline.Surface, params: list[tuple[float, float]]) -> list:
    return [surface.derivatives(u, v, order=2) for u, v in params]


# --------------------------------------------------------------------------- checks


class Disagreement(RuntimeError):
    pass


def check_close(name: str, ref: np.ndarray, other: np.ndarray, ij: tuple[int, int]) -> float:
    """Max |other - ref|; raise if it exceeds REL_TOL times the derivative's magnitude."""
    diff = float(np.max(np.abs(other - ref)))
    scale = max(1.0, float(np.max(np.abs(ref))))
    if not diff <= REL_TOL * scale:
        worst = np.unravel_index(np.argmax(np.abs(other - ref)), ref.shape)
        raise Disagreement(
            f"{name}: derivative {ij} differs from gshade by {diff:.3e} "
            f"(tolerance {REL_TOL * scale:.3e}, max |value| {scale:.3e}); worst at index "
            f"{tuple(int(k) for k in worst)}: gshade {float(ref[worst])!r}, "
            f"other {float(other[worst])!r}"
        )
    return diff


def check_splipy(name: str, d: np.ndarray, sp: list[np.ndarray]) -> float:
    return max(check_close(name, d[ij], a, ij) for ij, a in zip(MULTI_INDICES, sp, strict=True))


def check_geomdl(name: str, d: np.ndarray, idx: np.ndarray, skl: list) -> float:
    gd = np.asarray(skl)  # (points, 3, 3, 3): point, k, l, coordinate
    ref = d[:, :, idx[:, 0], idx[:, 1]]  # (3, 3, points, 3)
    return max(check_close(name, ref[ij], gd[:, ij[0], ij[1]], ij) for ij in MULTI_INDICES)


def textbook_curvature(sp: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """K and H from the fundamental forms with a unit normal (do Carmo's formulas)."""
    _, pu, pv, puu, puv, pvv = sp
    n = np.cross(pu, pv)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    E, F, G = (np.sum(a * b, axis=-1) for a, b in ((pu, pu), (pu, pv), (pv, pv)))
    L, M, N = (np.sum(a * n, axis=-1) for a in (puu, puv, pvv))
    det = E * G - F * F
    return (L * N - M * M) / det, (E * N - 2 * F * M + G * L) / (2 * det)


def check_curvature(KH: tuple[np.ndarray, np.ndarray], ref: tuple[np.ndarray, np.ndarray]):
    for name, a, b in zip("KH", KH, ref, strict=True):
        diff = float(np.max(np.abs(a - b)))
        scale = max(1.0, float(np.max(np.abs(b))))
        if not diff <= 1e-8 * scale:
            raise Disagreement(f"{name}: gshade differs from the textbook formula by {diff:.3e}")


# --------------------------------------------------------------------------- report


@dataclass
class Row:
    workload: str
    gshade: Timing
    splipy: Timing | None = None
    geomdl_ms: float | None = None  # extrapolated to the full grid
    splipy_target: float | None = None
    geomdl_target: float | None = None
    max_ms: float | None = None

    @property
    def splipy_ratio(self) -> float | None:
        return None if self.splipy is None else self.splipy.median_ms / self.gshade.median_ms

    @property
    def geomdl_ratio(self) -> float | None:
        return None if self.geomdl_ms is None else self.geomdl_ms / self.gshade.median_ms

    @property
    def target(self) -> str:
        parts = []
        if self.splipy_target is not None:
            parts.append(f">= {self.splipy_target:g}x vs splipy")
        if self.geomdl_target is not None:
            parts.append(f">= {self.geomdl_target:g}x vs geomdl")
        if self.max_ms is not None:
            parts.append(f"<= {self.max_ms:g} ms")
        return ", ".join(parts)

    @property
    def met(self) -> bool:
        ok = True
        if self.splipy_target is not None:
            ok &= self.splipy_ratio >= self.splipy_target
        if self.geomdl_target is not None:
            ok &= self.geomdl_ratio >= self.geomdl_target
        if self.max_ms is not None:
            ok &= self.gshade.median_ms <= self.max_ms
        return ok

    def cells(self) -> list[str]:
        def ms(x):
            return "-" if x is None else f"{x:.1f}" if x < 1e4 else f"{x:,.0f}"

        def ratio(x):
            return "-" if x is None else f"{x:.2f}x" if x < 100 else f"{x:,.0f}x"

        return [
            self.workload,
            ms(self.gshade.median_ms),
            ms(None if self.splipy is None else self.splipy.median_ms),
            ms(self.geomdl_ms),
            ratio(self.splipy_ratio),
            ratio(self.geomdl_ratio),
            self.target,
            "yes" if self.met else "NO",
        ]


COLUMNS = [
    "Workload",
    "gshade median (ms)",
    "splipy median (ms)",
    "geomdl (ms, extrapolated)",
    "splipy / gshade",
    "geomdl / gshade",
    "Target",
    "Met",
]


def section(info: dict[str, str], rows: list[Row], notes: list[str], args) -> str:
    command = ".venv/bin/python benchmarks/bench_geometry.py --write" + (
        " --quick" if args.quick else ""
    )
    lines = [
        "## Geometry evaluation (`benchmarks/bench_geometry.py`)",
        "",
        f"Run: `{command}`; {args.repeats} repeats after a warm-up (medians), geomdl "
        f"{args.geomdl_repeats} repeat(s) of {GEOMDL_POINTS} points.",
        "",
    ]
    lines += [f"- {k}: {v}" for k, v in info.items()]
    lines += ["", markdown_table(COLUMNS, [r.cells() for r in rows]), ""]
    lines += [f"- {n}" for n in notes]
    return "\n".join(lines)


# --------------------------------------------------------------------------- main


@dataclass
class Workload:
    name: str
    surface: Surface
    splipy_target: float
    geomdl_target: float


def check_agreement(w: Workload, u, v, idx) -> str:
    """Compare splipy (whole grid) and geomdl (subsample) with gshade; a note on the result."""
    tag = w.name.split()[0]
    params = [(float(u[i]), float(v[j])) for i, j in idx]
    d = gshade_eval(gshade_patch(w.surface), u, v)
    sp = splipy_eval(splipy_surface(w.surface), u.copy(), v.copy())
    diff_sp = check_splipy(f"{tag} splipy", d, sp)
    diff_gd = check_geomdl(f"{tag} geomdl", d, idx, geomdl_eval(geomdl_surface(w.surface), params))
    return (
        f"{tag}: splipy {diff_sp:.1e} (all {GRID * GRID:,} points), "
        f"geomdl {diff_gd:.1e} ({len(params)} points)"
    )


def bench_evaluation(w: Workload, u, v, idx, args) -> tuple[Row, str]:
    """Time one evaluation workload in the three libraries: the table row and a note."""
    patch, sp_surface, gd_surface = (
        gshade_patch(w.surface),
        splipy_surface(w.surface),
        geomdl_surface(w.surface),
    )
    params = [(float(u[i]), float(v[j])) for i, j in idx]
    # splipy snaps its parameter arrays to nearby knots in place: give it its own.
    u_sp, v_sp = u.copy(), v.copy()
    # gshade reuses its output buffer (``out=``, the documented way to evaluate
    # repeatedly); a fresh 36 MB result per call costs page faults, timed as well.
    out = gshade_eval(patch, u, v)
    t = time_interleaved(
        {
            "gshade": lambda: gshade_eval(patch, u, v, out),
            "gshade fresh": lambda: gshade_eval(patch, u, v),
            "splipy": lambda: splipy_eval(sp_surface, u_sp, v_sp),
        },
        args.repeats,
    )
    t_gd = time_interleaved(
        {"geomdl": lambda: geomdl_eval(gd_surface, params)}, args.geomdl_repeats
    )["geomdl"]
    geomdl_ms = t_gd.median_ms * GRID * GRID / len(params)
    row = Row(w.name, t["gshade"], t["splipy"], geomdl_ms, w.splipy_target, w.geomdl_target)
    fresh = t["gshade fresh"]
    note = (
        f"{w.name.split()[0]} spread (min-max ms): gshade {t['gshade'].spread_ms}, splipy "
        f"{t['splipy'].spread_ms}; geomdl {1e3 * t_gd.median_ms / len(params):.0f} us per "
        f"point. gshade without `out=` (a fresh result each call): median "
        f"{fresh.median_ms:.1f} ms, {t['splipy'].median_ms / fresh.median_ms:.2f}x splipy"
    )
    return row, note


def bench_curvature(s: Surface, u, v, args) -> Row:
    """Check K and H against the textbook formulas, then time them from W1's derivatives."""
    d = gshade_eval(gshade_patch(s), u, v)
    check_curvature(
        gaussian_and_mean_curvature(d),
        textbook_curvature(splipy_eval(splipy_surface(s), u.copy(), v.copy())),
    )
    t = time_interleaved({"KH": lambda: gaussian_and_mean_curvature(d)}, args.repeats)["KH"]
    return Row("KH Gaussian + mean curvature, 250k points", t, max_ms=20.0)


def blas_threads() -> str:
    """The thread count (and kernel) of each BLAS library loaded (threadpoolctl), for the
    notes."""
    libs = [lib for lib in threadpool_info() if lib.get("user_api") == "blas"]
    return ", ".join(
        sorted(
            f"{os.path.basename(lib['filepath'])} {lib['num_threads']} threads"
            + (f" ({lib['architecture']})" if lib.get("architecture") else "")
            for lib in libs
        )
    )


def default_pool_timings(s: Surface, repeats: int) -> dict[str, list[float]]:
    """Rows D's timings of one surface: gshade fresh and ``out=``, splipy, interleaved."""
    u = np.linspace(0.0, 1.0, GRID)
    v = np.linspace(0.0, 1.0, GRID)
    patch, sp_surface = gshade_patch(s), splipy_surface(s)
    u_sp, v_sp = u.copy(), v.copy()
    out = gshade_eval(patch, u, v)
    t = time_interleaved(
        {
            "gshade": lambda: gshade_eval(patch, u, v),
            "gshade out": lambda: gshade_eval(patch, u, v, out),
            "splipy": lambda: splipy_eval(sp_surface, u_sp, v_sp),
        },
        repeats,
    )
    return {name: timing.samples for name, timing in t.items()}


def default_threads_child(repeats: int) -> int:
    """Rows D, in the child: time W1 and W2 and print the samples as JSON on the last line
    of stdout."""
    pools = [lib["num_threads"] for lib in threadpool_info() if lib.get("user_api") == "blas"]
    cores = len(os.sched_getaffinity(0))
    if cores > 1 and not any(n > 1 for n in pools):
        sys.exit(f"{CHILD_FLAG}: expected OpenBLAS's default pool, got {blas_threads()}")
    surfaces = make_surfaces(np.random.default_rng(SEED))
    result: dict[str, object] = {"threads": blas_threads()}
    for tag, s in zip(("W1", "W2"), surfaces, strict=True):
        result[tag] = default_pool_timings(s, repeats)
    print(json.dumps(result))
    return 0


def run_default_threads(repeats: int, loaded: bool) -> dict:
    """One child run of rows D (default BLAS pool), beside a busy process if ``loaded``."""
    env = os.environ | {"OPENBLAS_NUM_THREADS": ""}  # set, empty: OpenBLAS's default
    cmd = [sys.executable, os.path.abspath(__file__), CHILD_FLAG, "--repeats", str(repeats)]
    busy = subprocess.Popen([sys.executable, "-c", "while True: pass"]) if loaded else None
    try:
        if busy is not None:
            time.sleep(0.5)  # let it take its core
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    finally:
        if busy is not None:
            busy.kill()
            busy.wait()
    if proc.returncode != 0:
        raise RuntimeError(f"{CHILD_FLAG} failed ({proc.returncode}):\n{proc.stderr}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


@dataclass
class DefaultThreads:
    """The pooled samples of rows D: case ('quiet' or 'loaded') -> workload -> library."""

    timings: dict[str, dict[str, dict[str, Timing]]]
    threads: str
    runs: int


def bench_default_threads(args) -> DefaultThreads:
    cases = [("quiet", False)] + [("loaded", True)] * args.loaded_runs
    timings: dict[str, dict[str, dict[str, Timing]]] = {}
    threads = set()
    for case, loaded in cases:
        res = run_default_threads(args.repeats, loaded)
        threads.add(res.pop("threads"))
        for tag, libs in res.items():
            for name, samples in libs.items():
                per_lib = timings.setdefault(case, {}).setdefault(tag, {})
                per_lib.setdefault(name, Timing()).samples.extend(samples)
    return DefaultThreads(timings, "; ".join(sorted(threads)), args.loaded_runs)


#: Rows D's targets vs splipy (gshade with a fresh result), without and with the busy
#: process: the quiet rows' ratios, as one BLAS thread for gshade makes the pool irrelevant
#: (W1 >= 2x rather than 2.5x: a fresh result pays its page faults).
DEFAULT_TARGETS = {
    ("quiet", "W1"): 2.0,
    ("quiet", "W2"): 8.0,
    ("loaded", "W1"): 2.0,
    ("loaded", "W2"): 8.0,
}


def default_threads_rows(d: DefaultThreads) -> tuple[list[Row], list[str]]:
    rows, notes = [], []
    names = {"W1": "W1 B-spline", "W2": "W2 NURBS"}
    for case in ("quiet", "loaded"):
        for tag in ("W1", "W2"):
            t = d.timings[case][tag]
            load = "no added load" if case == "quiet" else "1 busy process"
            label = f"{names[tag]}, default BLAS threads, {load}, fresh result"
            rows.append(
                Row(label, t["gshade"], t["splipy"], splipy_target=DEFAULT_TARGETS[case, tag])
            )
            notes.append(
                f"D {tag} {load} spread (min-max ms): gshade {t['gshade'].spread_ms}, splipy "
                f"{t['splipy'].spread_ms}; gshade with `out=`: median "
                f"{t['gshade out'].median_ms:.1f} ms ({t['gshade out'].spread_ms}), "
                f"{t['splipy'].median_ms / t['gshade out'].median_ms:.2f}x splipy"
            )
    return rows, notes


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--write", action="store_true", help="update benchmarks/RESULTS.md")
    parser.add_argument("--quick", action="store_true", help="fewer repeats")
    parser.add_argument(CHILD_FLAG, action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--repeats", type=int, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.default_threads_child:
        return default_threads_child(args.repeats or REPEATS)
    args.repeats = QUICK_REPEATS if args.quick else REPEATS
    args.geomdl_repeats = QUICK_GEOMDL_REPEATS if args.quick else GEOMDL_REPEATS
    args.loaded_runs = QUICK_LOADED_RUNS if args.quick else LOADED_RUNS
    load_start = load_average()

    rng = np.random.default_rng(SEED)
    bspline, nurbs = make_surfaces(rng)
    u = np.linspace(0.0, 1.0, GRID)
    v = np.linspace(0.0, 1.0, GRID)
    idx = rng.integers(0, GRID, size=(GEOMDL_POINTS, 2))

    w1 = Workload("W1 B-spline 20x20, 500x500 grid, order <= 2", bspline, 2.5, 1000.0)
    w2 = Workload("W2 NURBS 20x20, 500x500 grid, order <= 2", nurbs, 8.0, 1000.0)
    # Agreement first, and its arrays freed, so that the timings run in a lean process.
    agree = [check_agreement(w, u, v, idx) for w in (w1, w2)]
    row1, spread1 = bench_evaluation(w1, u, v, idx, args)
    row2, spread2 = bench_evaluation(w2, u, v, idx, args)
    row_kh = bench_curvature(bspline, u, v, args)
    # the children last, with this process's big arrays freed
    del w1, w2, bspline, nurbs
    default = bench_default_threads(args)
    rows_d, notes_d = default_threads_rows(default)
    rows = [row1, row2, row_kh, *rows_d]

    notes = [
        f"geomdl is timed on {GEOMDL_POINTS} random grid points, one "
        "`derivatives(u, v, order=2)` call per point, and scaled linearly "
        f"(x{GRID * GRID / GEOMDL_POINTS:g}) to the {GRID * GRID:,} grid points.",
        "splipy: `surface(u, v)` + five `surface.derivative(u, v, d=(i, j))` tensor-grid calls; "
        "gshade: one `derivatives(u[:, None], v[None, :], 2, out=buffer)` call; KH times only "
        "`gaussian_and_mean_curvature(d)` on W1's derivatives (K, H checked against the "
        "textbook formulas).",
        "Agreement with gshade, max |difference| over all six derivatives: "
        + "; ".join(agree)
        + ".",
        spread1,
        spread2,
        f"KH spread (min-max ms): {row_kh.gshade.spread_ms}",
        "D (default BLAS threads) rows: each a child process with OPENBLAS_NUM_THREADS "
        f"empty, i.e. OpenBLAS's default (BLAS there: {default.threads}); gshade returns a "
        "fresh result and limits BLAS to one thread during its calls, splipy uses the pool; "
        f"{args.repeats} interleaved repeats per run, one run without added load and "
        f"{default.runs} loaded run(s) (samples pooled), each beside a busy "
        "`python -c 'while True: pass'` process (not pinned) started 0.5 s before it.",
        *notes_d,
        f"Load average (1, 5, 15 min): {load_start} at the start, {load_average()} at the end.",
    ]

    info = machine_info([f"splipy {version('splipy')}", f"geomdl {version('geomdl')}"])
    tables = [(None, COLUMNS, [r.cells() for r in rows])]
    publish(
        info, tables, notes, (SECTION, section(info, rows, notes, args)) if args.write else None
    )
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except Disagreement as exc:
        sys.exit(
            f"FAILED: the libraries disagree, so the timings would not compare like with "
            f"like.\n{exc}"
        )
