"""gshade's continuity classes against the kernel's own (issue 26): for each CAD file, run
``python -m gshade continuity FILE --json`` (a subprocess of this interpreter) and the
independent oracle of ``tests/support/kernel_oracle.py`` (OCP's BRepLProp_SLProps and
LocalAnalysis_SurfaceContinuity, no gshade code), pair their edge rows, and print the
confusion matrices (rows: the oracle's class, columns: gshade's) and the worst
disagreements.

Pairing: gshade's rows name the edge by its number in the kernel's map of edges and the two
faces by number.  The oracle numbers them the same way on its own reading of the file; a row
pairs "by number" when the same (edge, faces) exists on both sides and the edges' arc-length
midpoints agree (gshade's from its own shape, read with gshade's reader, which may heal or
convert the model), else "by location": the oracle row whose midpoint is nearest, within
max(1e-6 x diagonal, 10 x the edge's gap tolerance).

The oracle's G3 is "its measures all within gshade's default tolerances, the
curvature-gradient jump estimated by finite differences of the kernel's curvatures"; the
kernel's own LocalAnalysis has no G3 (its matrix has G2 for G2-or-better).

Both also say whether the two faces' orientations agree along each edge (``orientation``:
gshade's from the edge's orientations in the faces, the oracle's from its normals and the
faces' directions across the edge); the per-file line counts the inconsistent edges of each
and the pairs where they differ.

Usage::

    python benchmarks/continuity_oracle.py FILE... [--samples 32] [--json] [--only NAME]

With no FILE, the STEP and IGES files of ../shared/data/cad/ (3dm files are skipped: the
kernel cannot read them).
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests import kernel_oracle as oracle  # noqa: E402

ORACLE_ROWS = ("G0", "G1", "G2", "G3", "none")
GSHADE_COLS = ("G0", "G1", "G2", "G3", "none", "missing")
LA_ROWS = ("G0", "G1", "G2", "none", "failed")
RANK = {c: i for i, c in enumerate(oracle.CLASSES)}
KERNEL_FORMATS = (".step", ".stp", ".iges", ".igs", ".brep")


def run_gshade(path: Path, samples: int, timeout: float) -> tuple[dict | None, float, str]:
    """gshade's continuity JSON of the file, the seconds it took, and its stderr."""
    start = time.perf_counter()
    try:
        done = subprocess.run(
            [
                sys.executable,
                "-m",
                "gshade",
                "continuity",
                str(path),
                "--json",
                "--samples",
                str(samples),
            ],
            capture_output=True,
            text=True,
            timeout=timeout,
            cwd=ROOT,
        )
    except subprocess.TimeoutExpired:
        return None, time.perf_counter() - start, f"timed out after {timeout:.0f} s"
    took = time.perf_counter() - start
    if done.returncode != 0:
        return None, took, done.stderr.strip()[-2000:]
    return json.loads(done.stdout), took, done.stderr.strip()


def gshade_midpoints(path: Path) -> dict:
    """(edge, faces) -> arc-length midpoint, on gshade's own reading of the file."""
    try:
        from gshade.cad.occt import read  # in this process: the kernel's shape itself

        model = read(path)
        return {
            (m["edge"], tuple(sorted(m["faces"]))): np.array(m["midpoint"])
            for m in oracle.edge_midpoints(model.brep)
        }
    except Exception as exc:  # gshade could not read it (then neither could continuity)
        print(f"  (gshade's shape not read for midpoints: {exc})", file=sys.stderr)
        return {}


def pair(g_rows: list[dict], o_rows: list[dict], g_mid: dict, diagonal: float) -> list[dict]:
    """Each gshade row with its oracle row (or None): {"g", "o", "how"}."""
    by_key = {(r["edge"], tuple(sorted(r["faces"]))): r for r in o_rows}
    mids = np.array([r["midpoint"] for r in o_rows]) if o_rows else np.zeros((0, 3))
    out, used = [], set()
    for g in g_rows:
        key = (g["edge"], tuple(sorted(g["patches"])))
        o, how = by_key.get(key), "number"
        gm = g_mid.get(key)
        limit = max(1e-6 * diagonal, 10 * (o or {}).get("g0_tolerance", 0.0))
        if o is not None and gm is not None and not np.linalg.norm(gm - o["midpoint"]) <= limit:
            o = None  # the same numbers, another edge
        if o is None and gm is not None and len(mids):
            d = np.linalg.norm(mids - gm, axis=1)
            order = np.argsort(d)
            best = [
                int(i)
                for i in order[:4]
                if d[i] <= max(1e-6 * diagonal, 10 * o_rows[i].get("g0_tolerance", 0.0))
            ]
            same = [i for i in best if tuple(sorted(o_rows[i]["faces"])) == key[1]]
            pick = (same or best or [None])[0]
            o, how = (o_rows[pick], "location") if pick is not None else (None, "unmatched")
        elif o is None:
            how = "unmatched"
        if o is not None:
            used.add(id(o))
        out.append({"g": g, "o": o, "how": how})
    for o in o_rows:
        if id(o) not in used:
            out.append({"g": None, "o": o, "how": "oracle only"})
    return out


def matrices(pairs: list[dict]) -> tuple[dict, dict]:
    own = {r: {c: 0 for c in GSHADE_COLS} for r in (*ORACLE_ROWS, "error")}
    la = {r: {c: 0 for c in GSHADE_COLS} for r in LA_ROWS}
    for p in pairs:
        o, g = p["o"], p["g"]
        if o is None:
            continue
        col = g["class"] if g is not None else "missing"
        own[o.get("class") or "error"][col] += 1
        la[o.get("la_class") or "failed"][col] += 1
    own = {r: v for r, v in own.items() if r != "error" or sum(v.values())}
    return own, la


def show_matrix(title: str, m: dict) -> str:
    cols = [c for c in GSHADE_COLS if c != "missing" or any(m[r][c] for r in m)]
    head = "oracle / gshade"
    lines = [title, f"  {head:<16}" + "".join(f"{c:>8}" for c in cols) + f"{'total':>8}"]
    for r, row in m.items():
        lines.append(
            f"  {r:<16}" + "".join(f"{row[c]:>8}" for c in cols) + f"{sum(row.values()):>8}"
        )
    return "\n".join(lines)


def _severity(p: dict) -> tuple:
    o, g = p["o"], p["g"]
    oc, gc = RANK.get(o.get("class") or "none", 0), RANK.get(g["class"], 0)
    da = abs(o.get("normal_angle_deg", 0.0) - g["normal_angle_deg"])
    return (abs(oc - gc), da)


def disagreements(pairs: list[dict], worst: int) -> list[dict]:
    rows = [
        p
        for p in pairs
        if p["o"] is not None and p["g"] is not None and p["o"].get("class") != p["g"]["class"]
    ]
    rows.sort(key=_severity, reverse=True)
    return rows[:worst]


def orientations(pairs: list[dict]) -> dict:
    """How many paired edges each side calls ``inconsistent``, and on how many they differ."""
    both = [(p["o"], p["g"]) for p in pairs if p["o"] is not None and p["g"] is not None]
    return {
        "oracle": sum(o.get("orientation") == "inconsistent" for o, _ in both),
        "gshade": sum(g.get("orientation") == "inconsistent" for _, g in both),
        "differ": sum(o.get("orientation") != g.get("orientation") for o, g in both),
    }


def _f(x) -> str:
    return "-" if x is None else f"{x:.3g}"


def show_disagreement(p: dict) -> str:
    o, g = p["o"], p["g"]
    mid = ", ".join(f"{c:.4g}" for c in o["midpoint"])
    return (
        f"  edge {g['edge']} faces {g['patches']} ({p['how']}): oracle {o.get('class')} "
        f"(kernel LA {o.get('la_class')}), gshade {g['class']}; "
        f"angle {_f(o.get('normal_angle_deg'))}/{_f(g['normal_angle_deg'])} deg, "
        f"gap {_f(o.get('gap'))}/{_f(g['gap'])} (tol {_f(o.get('g0_tolerance'))}), "
        f"curvature jump {_f(o.get('curvature_jump'))}/{_f(g['curvature_jump'])}, "
        f"gradient jump {_f(o.get('curvature_gradient_jump'))}/{_f(g['curvature_gradient_jump'])}; "
        f"LA G1 angle {_f(o.get('la_g1_angle_deg'))} deg; inward dot {_f(o.get('inward_dot'))}; "
        f"orientation {o.get('orientation')}/{g.get('orientation')}; midpoint ({mid})"
    )


def compare_file(path: Path, samples: int, timeout: float, worst: int) -> dict:
    result: dict = {"file": str(path), "name": path.name}
    if path.suffix.lower() not in KERNEL_FORMATS:
        result["skipped"] = "the kernel cannot read this format"
        return result
    gjson, gtime, gerr = run_gshade(path, samples, timeout)
    result["gshade_seconds"] = gtime
    if gjson is None:
        result["gshade_error"] = gerr
    start = time.perf_counter()
    try:
        o = oracle.analyse_file(path, samples)
    except Exception as exc:
        result["oracle_error"] = f"{type(exc).__name__}: {exc}"
        return result
    result["oracle_seconds"] = time.perf_counter() - start
    result["read"] = o["read"]
    result["diagonal"] = o["diagonal"]
    if gjson is None:
        result["oracle"] = o["edges"]
        return result
    result["gshade_diagonal"] = gjson.get("tolerances", {}).get("g0", math.nan) / 1e-7
    g_rows = [r for r in gjson["junctions"] if "edge" in r and "knot" not in r]
    result["knot_lines"] = sum("knot" in r for r in gjson["junctions"])
    result["not_measured"] = len(gjson.get("not_measured", []))
    pairs = pair(g_rows, o["edges"], gshade_midpoints(path), o["diagonal"])
    how: dict = {}
    for p in pairs:
        how[p["how"]] = how.get(p["how"], 0) + 1
    result["pairing"] = how
    result["matrix"], result["la_matrix"] = matrices(pairs)
    result["orientation"] = orientations(pairs)
    result["worst"] = [
        {
            "edge": p["g"]["edge"],
            "faces": p["g"]["patches"],
            "how": p["how"],
            "oracle": p["o"],
            "gshade": p["g"],
        }
        for p in disagreements(pairs, worst)
    ]
    result["_pairs"] = pairs
    return result


def measure_lines(pairs: list[dict], tol: dict) -> list[str]:
    """How far the paired rows' measures differ: angles (apart, those where the oracle's
    angle is above 90 degrees), gaps, curvature jumps on tangent edges (both classes G1 or
    better, one jump at least above the G2 tolerance ``tol["g2"]``), relative."""
    both = [(p["o"], p["g"]) for p in pairs if p["o"] is not None and p["g"] is not None]
    both = [(o, g) for o, g in both if o.get("class") is not None]
    if not both:
        return []
    acute = [
        abs(o["normal_angle_deg"] - g["normal_angle_deg"])
        for o, g in both
        if o["normal_angle_deg"] <= 90
    ]
    obtuse = [
        abs(o["normal_angle_deg"] - g["normal_angle_deg"])
        for o, g in both
        if o["normal_angle_deg"] > 90
    ]
    gaps = [abs(o["gap"] - g["gap"]) for o, g in both]
    out = [
        f"  measures: angles up to 90 deg differ by more than 1e-6 deg on "
        f"{sum(d > 1e-6 for d in acute)} of {len(acute)} edges "
        f"(at most {max(acute, default=0):.3g}), "
        f"above 90 deg on {sum(d > 1e-6 for d in obtuse)} of {len(obtuse)} (at most "
        f"{max(obtuse, default=0):.3g}); gaps by more than 1e-9 x diagonal on "
        f"{sum(d > 1e-9 * tol['g0'] / 1e-7 for d in gaps)} (at most {max(gaps):.3g})"
    ]
    rel = [
        (
            abs(o["curvature_jump"] - g["curvature_jump"])
            / max(o["curvature_jump"], g["curvature_jump"]),
            o["edge"],
        )
        for o, g in both
        if RANK[o["class"]] >= RANK["G1"]
        and RANK.get(g["class"], 0) >= RANK["G1"]
        and max(o["curvature_jump"], g["curvature_jump"]) > tol["g2"]
    ]
    if rel:
        worst = max(rel)
        out.append(
            f"  curvature jumps on {len(rel)} tangent edges (above the G2 tolerance): relative "
            f"difference above 1e-6 on {sum(r > 1e-6 for r, _ in rel)}, at most "
            f"{worst[0]:.3g} (edge {worst[1]})"
        )
    return out


def show(result: dict, worst: int) -> str:
    lines = [f"== {result['name']}"]
    if "skipped" in result:
        return lines[0] + f": skipped ({result['skipped']})"
    if "oracle_error" in result:
        lines.append(f"  oracle failed: {result['oracle_error']}")
    if "gshade_error" in result:
        lines.append(f"  gshade failed: {result['gshade_error']}")
    if "read" not in result:
        return "\n".join(lines)
    r = result["read"]
    lines.append(
        f"  faces {r['faces']}, sewn {r['sewn']}, healed {r['healed']}, declared uncertainty "
        f"{r['precision']:.3g} mm; diagonal oracle {result['diagonal']:.6g}"
        + (f", gshade {result['gshade_diagonal']:.6g}" if "gshade_diagonal" in result else "")
        + f"; gshade {result['gshade_seconds']:.1f} s, oracle {result['oracle_seconds']:.1f} s"
    )
    if "matrix" not in result:
        return "\n".join(lines)
    lines.append(
        f"  pairing: {result['pairing']}; gshade knot-line rows left aside: "
        f"{result['knot_lines']}; not measured: {result['not_measured']}"
    )
    lines.append(show_matrix("  own thresholds (rows) vs gshade (cols):", result["matrix"]))
    lines.append(
        show_matrix(
            "  kernel LocalAnalysis (rows; G2 = G2 or better) vs gshade:", result["la_matrix"]
        )
    )
    pairs = result["_pairs"]
    agree = sum(
        p["o"] is not None and p["g"] is not None and p["o"].get("class") == p["g"]["class"]
        for p in pairs
    )
    both = sum(p["o"] is not None and p["g"] is not None for p in pairs)
    lines.append(f"  agreement (own vs gshade): {agree}/{both}")
    turned = result["orientation"]
    lines.append(
        f"  orientation inconsistent: oracle {turned['oracle']}, gshade {turned['gshade']}; "
        f"the two differ on {turned['differ']}"
    )
    lines.extend(measure_lines(pairs, oracle.tolerances_for(result["diagonal"])))
    opposite = [
        p["o"] for p in pairs if p["o"] is not None and p["o"].get("normal_angle_deg", 0) > 170
    ]
    if opposite:
        same = sum((o.get("inward_dot") or 0) > 0 for o in opposite)
        lines.append(
            f"  edges with opposite outward normals (> 170 deg): {len(opposite)}; the faces on the "
            f"same side (folds, cusps, faces in contact) {same}, continuing each other "
            f"(orientations that disagree) {len(opposite) - same}"
        )
    if result["worst"]:
        lines.append(f"  worst disagreements (up to {worst}):")
        lines.extend(show_disagreement(p) for p in disagreements(pairs, worst))
    return "\n".join(lines)


def total(results: list[dict]) -> tuple[dict, dict]:
    own = {r: {c: 0 for c in GSHADE_COLS} for r in (*ORACLE_ROWS, "error")}
    la = {r: {c: 0 for c in GSHADE_COLS} for r in LA_ROWS}
    for res in results:
        for mine, theirs in ((own, res.get("matrix")), (la, res.get("la_matrix"))):
            for r, row in (theirs or {}).items():
                for c, n in row.items():
                    mine[r][c] += n
    own = {r: v for r, v in own.items() if r != "error" or sum(v.values())}
    return own, la


def total_orientations(results: list[dict]) -> dict:
    """:func:`orientations` summed over the files."""
    out = {"oracle": 0, "gshade": 0, "differ": 0}
    for res in results:
        for key, n in res.get("orientation", {}).items():
            out[key] += n
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("files", nargs="*", type=Path)
    parser.add_argument("--samples", type=int, default=32)
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.add_argument("--only", action="append", help="only files whose name contains this")
    parser.add_argument("--worst", type=int, default=8, help="disagreements listed per file")
    parser.add_argument("--timeout", type=float, default=3600.0, help="seconds per gshade run")
    args = parser.parse_args(argv)
    files = args.files or sorted(
        p
        for p in (ROOT.parent / "shared" / "data" / "cad").iterdir()
        if p.suffix.lower() in (*KERNEL_FORMATS, ".3dm")
    )
    if args.only:
        files = [f for f in files if any(o in f.name for o in args.only)]
    results = []
    for path in files:
        res = compare_file(path, args.samples, args.timeout, args.worst)
        results.append(res)
        if not args.json:
            print(show(res, args.worst), flush=True)
    own, la = total(results)
    if args.json:
        for res in results:
            res.pop("_pairs", None)
        print(
            json.dumps(
                {
                    "files": results,
                    "total": {
                        "matrix": own,
                        "la_matrix": la,
                        "orientation": total_orientations(results),
                    },
                },
                indent=1,
                default=str,
            )
        )
    else:
        print("== all files")
        print(show_matrix("  own thresholds (rows) vs gshade (cols):", own))
        print(show_matrix("  kernel LocalAnalysis (rows; G2 = G2 or better) vs gshade:", la))
        turned = total_orientations(results)
        print(
            f"  orientation inconsistent: oracle {turned['oracle']}, gshade {turned['gshade']}; "
            f"the two differ on {turned['differ']}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
