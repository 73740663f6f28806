"""Benchmark continuity along B-rep edges (``edge_report``) on CAD parts of hundreds of faces.

What is measured (wall-clock, median and min-max over repeats after a warm-up, the garbage
collector off while timing): ``edge_report(model)`` — finding every edge shared by two
faces in the kernel's shape, sampling both faces' pcurves at 32 edge parameters, the faces'
exact derivatives there, the four measures and the classes.  Reading the file is not timed.

Parts, built with the kernel (Open CASCADE) when the benchmark runs: a plate 10 x 10 x 1
drilled with an n x n grid of holes, each hole's rim filleted (n = 6, 12, 18: 6 + 3 n^2
faces, a cylinder and two fillets per hole), written as BREP; and, when the folder exists,
the real models in ``../shared/data/cad`` (never copied into the project).  Target: hundreds
of faces in well under a second.

Usage, from the repository root::

    .venv/bin/python benchmarks/bench_edges.py            # print the table
    .venv/bin/python benchmarks/bench_edges.py --write    # and update RESULTS.md
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from collections import Counter
from importlib.metadata import version
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from report import (
    load_average,
    machine_info,
    markdown_table,
    text_table,
    time_interleaved,
    write_section,
)

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from gshade.analysis.edge_continuity import edge_report  # noqa: E402
from gshade.cad import read_cad  # noqa: E402

SHARED = ROOT.parent / "shared" / "data" / "cad"


def drilled_plate(n: int):
    """A 10 x 10 x 1 plate with n x n through holes, their top rims filleted."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
    from OCP.BRepFilletAPI import BRepFilletAPI_MakeFillet
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder
    from OCP.collections import List_TopoDS_Shape as TopTools_ListOfShape
    from OCP.GeomAbs import GeomAbs_Circle
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    plate = BRepPrimAPI_MakeBox(10.0, 10.0, 1.0).Shape()
    step = 10.0 / n
    tools = TopTools_ListOfShape()
    for i in range(n):
        for j in range(n):
            axis = gp_Ax2(gp_Pnt((i + 0.5) * step, (j + 0.5) * step, -1.0), gp_Dir(0, 0, 1))
            tools.Append(BRepPrimAPI_MakeCylinder(axis, 0.25 * step, 3.0).Shape())
    args = TopTools_ListOfShape()
    args.Append(plate)
    cut = BRepAlgoAPI_Cut()
    cut.SetArguments(args)
    cut.SetTools(tools)
    cut.Build()
    shape = cut.Shape()
    fillet = BRepFilletAPI_MakeFillet(shape)
    explorer = TopExp_Explorer(shape, TopAbs_EDGE)
    while explorer.More():  # the holes' rims: circles, at z = 0 or z = 1
        edge = TopoDS.Edge(explorer.Current())
        if BRepAdaptor_Curve(edge).GetType() == GeomAbs_Circle:
            fillet.Add(0.05 * step, edge)
        explorer.Next()
    return fillet.Shape()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="update benchmarks/RESULTS.md")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    from OCP.BRepTools import BRepTools

    models = []
    with tempfile.TemporaryDirectory() as folder:
        for n in (6, 12, 18):
            path = Path(folder) / f"plate{n}.brep"
            BRepTools.Write_s(drilled_plate(n), str(path))
            models.append((f"plate, {n}x{n} filleted holes", read_cad(path)))
    if SHARED.is_dir():
        for path in sorted(SHARED.iterdir()):
            if path.suffix.lower() in (".step", ".stp", ".iges", ".igs", ".3dm"):
                try:
                    models.append((path.name, read_cad(path)))
                except Exception as exc:  # a benchmark reports what it could not read
                    print(f"{path.name}: not read ({exc})", file=sys.stderr)
    rows = []
    for name, model in models:
        report, _ = edge_report(model)
        timing = time_interleaved({name: lambda m=model: edge_report(m)}, args.repeats)[name]
        classes = Counter(j.cls for j in report)
        summary = ", ".join(
            f"{classes[c]} {c}" for c in ("G3", "G2", "G1", "G0", "none") if classes[c]
        )
        rows.append(
            [
                name,
                str(len(model.faces)),
                str(len(report)),
                f"{timing.median_ms:.0f}",
                timing.spread_ms,
                summary,
            ]
        )
    columns = ["Part", "Faces", "Edges", "edge_report median (ms)", "Spread (ms)", "Classes"]
    print(text_table(columns, rows))
    if args.write:
        info = machine_info(versions=[f"cadquery-ocp-novtk {version('cadquery-ocp-novtk')}"])
        lines = [
            "## Continuity along B-rep edges (`benchmarks/bench_edges.py`)",
            "",
            f"Run: `.venv/bin/python benchmarks/bench_edges.py --write`; medians of "
            f"{args.repeats} edge_report calls after a warm-up (reading not timed); load "
            f"{load_average()}.",
            "",
            *(f"- {label}: {text}" for label, text in info.items()),
            "Target: hundreds of faces in well under a second.",
            "",
            markdown_table(columns, rows),
        ]
        write_section("bench_edges", "\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
