"""Benchmark gshade's shape functions on a 1000 x 1000 grid, surface gradient included.

What is measured (wall-clock, ``time.perf_counter``, median over repeats after a warm-up):

S   Every registered shape function (``gshade.shape.SHAPE_FUNCTIONS``) evaluated at the
    1,000,000 points of a 1000 x 1000 parameter grid of a bicubic Bézier patch: one
    ``evaluate(name, d)`` call, which returns f, the surface gradient grad_S f (computed by
    default) and the validity mask.  Only ``evaluate`` is timed: the derivatives ``d`` are
    computed once beforehand, to order 3 (a curvature's gradient needs third derivatives),
    and every function reads the ones it needs from that same array.  Parameters are the
    defaults, except the eye point of ``reflection_lines``, [1.5, -6, 4]; besides each
    function's default form, the variants isophotes ``form='angle'``, reflection_lines
    ``form='infinity'`` and highlight_lines ``form='distance'`` are timed too.
D   Informational: the derivatives themselves, ``patch.derivatives(u, v, 3)`` on the same
    grid, once with a fresh result per call and once overwriting an earlier result
    (``out=buffer``).

The patch is a gently curved height field: control points (i, j, z_ij), i, j = 0..3, with
z_ij uniform in [0, 0.5) (fixed seed).  The shape functions run as Dr.Jit LLVM kernels
cached on disk (the default backend wherever a libLLVM >= 17 is found); one untimed call per
function loads (or compiles) them before the timing, and the first call's time is reported.
The same formulas on the numpy backend (the fallback without a usable LLVM) are timed beside
them, with fewer repeats, for comparison.  All functions are timed interleaved (one call of each per
repeat), so that they see the same machine state; the derivative rows are timed apart.
Before timing, the results are checked: f, the gradient and the derivatives must be
finite everywhere (no NaN), and the ``out=`` derivatives must equal the fresh ones.

Targets (2-core machine): each order-1 function at most 60 ms, each curvature (order 2) at
most 80 ms, both including the gradient; order 0 and the derivatives have none.

Usage, from the repository root::

    .venv/bin/python benchmarks/bench_shape.py            # print the table
    .venv/bin/python benchmarks/bench_shape.py --write    # and update RESULTS.md
    .venv/bin/python benchmarks/bench_shape.py --quick    # fewer repeats

``--write`` replaces this benchmark's section of ``benchmarks/RESULTS.md`` (between the
``bench_shape`` markers) and leaves the rest of the file alone.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import dataclass

# One BLAS thread, as in bench_geometry (``report`` sets it too); set before numpy loads.
# An explicit OPENBLAS_NUM_THREADS in the environment wins, and the report records it.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from report import (
    Timing,
    load_average,
    machine_info,
    markdown_table,
    publish,
    time_interleaved,
)

from gshade.geometry import BezierPatch
from gshade.shape import SHAPE_FUNCTIONS, evaluate
from gshade.shape.kernels import backend

GRID = 1000  # parameter values per direction
ORDER = 3  # derivative order computed: curvature (2) + 1 for its gradient
REPEATS, QUICK_REPEATS = 15, 3
SEED = 20240612
EYE_POINT = (1.5, -6.0, 4.0)
#: Non-default forms timed besides each function's default.
VARIANTS = (
    ("isophotes", "angle"),
    ("reflection_lines", "infinity"),
    ("highlight_lines", "distance"),
)
#: Median target (ms) by shape-function order, gradient included; None: no target.
TARGET_MS = {0: None, 1: 60.0, 2: 80.0}

SECTION = "bench_shape"  # its markers in RESULTS.md


class SanityError(RuntimeError):
    pass


# --------------------------------------------------------------------------- workload


def make_patch(rng: np.random.Generator) -> BezierPatch:
    """A bicubic Bézier height field: control points (i, j, z_ij), z_ij in [0, 0.5)."""
    points = np.empty((4, 4, 3))
    points[..., 0] = np.arange(4.0)[:, None]
    points[..., 1] = np.arange(4.0)[None, :]
    points[..., 2] = 0.5 * rng.random((4, 4))
    return BezierPatch(points)


@dataclass(frozen=True)
class Case:
    """One timed shape-function evaluation: the function and its non-default parameters."""

    name: str
    params: dict

    @property
    def order(self) -> int:
        return SHAPE_FUNCTIONS[self.name].order

    @property
    def form(self) -> str:
        spec = SHAPE_FUNCTIONS[self.name].parameters.get("form")
        return "-" if spec is None else self.params.get("form", spec.default)

    @property
    def label(self) -> str:
        return self.name if self.form == "-" else f"{self.name} ({self.form})"


def make_cases() -> list[Case]:
    """Every registered function with its default form, each variant right after it."""
    cases = []
    for name, fn in SHAPE_FUNCTIONS.items():
        base = {"eye_point": EYE_POINT} if fn.eye_dependent else {}
        cases.append(Case(name, base))
        cases += [Case(name, {**base, "form": form}) for n, form in VARIANTS if n == name]
    missing = {n for n, _ in VARIANTS} - set(SHAPE_FUNCTIONS)
    if missing:
        raise SanityError(f"variants of unregistered shape functions: {sorted(missing)}")
    return cases


# --------------------------------------------------------------------------- checks


def check_values(case: Case, res) -> float:
    """Raise unless f and the gradient are finite everywhere; the fraction of valid points."""
    shape = (GRID, GRID)
    if res.gradient is None or res.f.shape != shape or res.gradient.shape != (*shape, 3):
        raise SanityError(
            f"{case.label}: unexpected result shapes f {res.f.shape}, gradient "
            f"{None if res.gradient is None else res.gradient.shape}"
        )
    for what, a in (("f", res.f), ("gradient", res.gradient)):
        bad = ~np.isfinite(a)
        if bad.any():
            raise SanityError(
                f"{case.label}: {what} is not finite at {int(bad.sum())} points "
                f"({int(np.isnan(a).sum())} NaN)"
            )
    return float(res.valid.mean())


def check_derivatives(d: np.ndarray, again: np.ndarray) -> None:
    if not np.isfinite(d).all():
        raise SanityError(f"derivatives: {int((~np.isfinite(d)).sum())} non-finite entries")
    if not np.array_equal(d, again):
        raise SanityError("derivatives: the out= result differs from the fresh one")


# --------------------------------------------------------------------------- report


@dataclass
class Row:
    function: str
    form: str
    order: str
    timing: Timing
    target_ms: float | None = None
    informational: bool = False
    numpy: Timing | None = None

    def cells(self) -> list[str]:
        if self.informational:
            target, met = "- (informational)", "-"
        elif self.target_ms is None:
            target, met = "none", "-"
        else:
            target = f"<= {self.target_ms:g} ms"
            met = "yes" if self.timing.median_ms <= self.target_ms else "NO"
        return [
            self.function,
            self.form,
            self.order,
            f"{self.timing.median_ms:.1f}",
            self.timing.spread_ms,
            "-" if self.numpy is None else f"{self.numpy.median_ms:.0f}",
            target,
            met,
        ]


COLUMNS = [
    "Function",
    "Form",
    "Order",
    "Median (ms)",
    "Spread (min-max ms)",
    "numpy backend (ms)",
    "Target",
    "Met",
]


def section(info: dict[str, str], rows: list[Row], notes: list[str], args) -> str:
    command = ".venv/bin/python benchmarks/bench_shape.py --write" + (
        " --quick" if args.quick else ""
    )
    lines = [
        "## Shape functions (`benchmarks/bench_shape.py`)",
        "",
        f"Run: `{command}`; {args.repeats} repeats after a warm-up (medians); "
        f"{GRID} x {GRID} grid = {GRID * GRID:,} points, surface gradient included.",
        "",
    ]
    lines += [f"- {k}: {v}" for k, v in info.items()]
    lines += ["", markdown_table(COLUMNS, [r.cells() for r in rows]), ""]
    lines += [f"- {n}" for n in notes]
    return "\n".join(lines)


# --------------------------------------------------------------------------- main


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--write", action="store_true", help="update benchmarks/RESULTS.md")
    parser.add_argument("--quick", action="store_true", help="fewer repeats")
    args = parser.parse_args(argv)
    args.repeats = QUICK_REPEATS if args.quick else REPEATS
    load_start = load_average()

    patch = make_patch(np.random.default_rng(SEED))
    u, v = patch.parameter_grid(GRID, GRID)
    d = patch.derivatives(u, v, ORDER)  # computed once; not part of the shape timings
    check_derivatives(d, patch.derivatives(u, v, ORDER, out=np.empty_like(d)))

    # Warm-up: load each kernel (Dr.Jit's on-disk cache, or compile) and check its result.
    cases = make_cases()
    first_ms, valid = {}, {}
    for case in cases:
        t0 = time.perf_counter()
        res = evaluate(case.name, d, **case.params)
        first_ms[case.label] = 1e3 * (time.perf_counter() - t0)
        valid[case.label] = check_values(case, res)
    del res

    timings = time_interleaved(
        {c.label: (lambda c=c: evaluate(c.name, d, **c.params)) for c in cases}, args.repeats
    )
    on_numpy = time_interleaved(
        {c.label: (lambda c=c: evaluate(c.name, d, backend="numpy", **c.params)) for c in cases},
        QUICK_REPEATS,
    )
    rows = [
        Row(
            c.name,
            c.form,
            str(c.order),
            timings[c.label],
            TARGET_MS[c.order],
            numpy=on_numpy[c.label],
        )
        for c in cases
    ]

    buffer = patch.derivatives(u, v, ORDER)
    t_d = time_interleaved(
        {
            "fresh": lambda: patch.derivatives(u, v, ORDER),
            "out": lambda: patch.derivatives(u, v, ORDER, out=buffer),
        },
        args.repeats,
    )
    call = f"patch.derivatives(u, v, {ORDER})"
    rows += [
        Row(call, "fresh result", "-", t_d["fresh"], informational=True),
        Row(call, "out=buffer", "-", t_d["out"], informational=True),
    ]

    import gshade.runtime

    gshade.runtime.setup()  # Dr.Jit pointed at a usable libLLVM first
    import drjit as dr

    info = machine_info(
        [f"drjit {dr.__version__} (libLLVM {'.'.join(map(str, dr.detail.llvm_version()))})"],
        [f"shape backend: {backend()}; Dr.Jit: {dr.thread_count()} threads"],
    )
    missed = [r.cells()[0] + f" ({r.form})" for r in rows if r.cells()[-1] == "NO"]
    first = max(first_ms, key=first_ms.get)
    notes = [
        f"Patch: bicubic Bézier height field (i, j, z_ij), z_ij uniform in [0, 0.5) (seed "
        f"{SEED}); u, v = `patch.parameter_grid({GRID}, {GRID})`; `d = "
        f"patch.derivatives(u, v, {ORDER})` computed once (shape {d.shape}, "
        f"{d.nbytes / 2**20:.0f} MiB), not timed in the shape rows.",
        f"Each shape row times one `evaluate(name, d, **params)` call (f, gradient and validity "
        f"mask; new output arrays each call); reflection_lines with eye_point "
        f"{list(EYE_POINT)}, all other parameters default.",
        "Checked before timing: f, gradient and derivatives finite everywhere (no NaN); "
        "`out=` derivatives equal the fresh ones.  Valid points: "
        + ", ".join(f"{k} {100 * x:.1f}%" for k, x in valid.items() if x < 1.0)
        + (" (all others 100%)." if any(x < 1.0 for x in valid.values()) else "all 100%."),
        f"First (untimed) call, which loads the kernels from Dr.Jit's cache or compiles them: "
        f"{first} {first_ms[first]:.0f} ms; the others "
        f"{min(first_ms.values()):.0f}-"
        f"{max(x for k, x in first_ms.items() if k != first):.0f} ms.",
        f"Load average (1, 5, 15 min): {load_start} at the start, {load_average()} at the end.",
        "Targets missed: " + (", ".join(missed) if missed else "none") + ".",
    ]

    tables = [(None, COLUMNS, [r.cells() for r in rows])]
    publish(
        info, tables, notes, (SECTION, section(info, rows, notes, args)) if args.write else None
    )
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except SanityError as exc:
        sys.exit(f"FAILED sanity check, timings not reported.\n{exc}")
