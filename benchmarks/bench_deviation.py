"""``gshade deviation`` against the mesh-based distance a user would reach for (issue 30):
the same points of A (every covered pixel's exact point) measured to B exactly by gshade
and to B's triangle mesh by VTK's ``vtkImplicitPolyDataDistance`` (through PyVista), side
by side in one run: the times (and a plain render of A for the 2x target) and the mesh
method's error against the exact distances.

    python benchmarks/bench_deviation.py [--size 1024x768] [--rounds 3] [--cad A.step ...]

The sphere pair (radii 2 and 2.003) is built in; each ``--cad`` file is measured against
itself (exact distance 0: the mesh's error is its own deflection).  B's mesh is the one
gshade renders B with (``gshade.rendering.deviation_measure.sample_mesh``: the
kernel's within 2e-3 of the diagonal for a CAD model).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

SPHERE = """name = "{name}"
[[surface]]
type = "sphere"
radius = {radius}
[camera]
type = "perspective"
origin = [2, -4, 2.5]
target = [0, 0, 0]
up = [0, 0, 1]
"""


def _mesh_of(scene):
    """B's mesh as a PyVista PolyData: the one the closest-point search starts from."""
    import pyvista as pv

    from gshade.rendering.deviation_measure import sample_mesh

    mesh = sample_mesh(scene)
    faces = np.hstack([np.full((len(mesh.faces), 1), 3), mesh.faces]).ravel()
    return pv.PolyData(mesh.positions, faces)


def _vtk_distances(mesh, points: np.ndarray) -> np.ndarray:
    """VTK's signed distances of the points to the mesh (vtkImplicitPolyDataDistance over
    all points at once, PyVista's ``compute_implicit_distance``)."""
    import pyvista as pv

    cloud = pv.PolyData(points).compute_implicit_distance(mesh)
    return np.asarray(cloud.point_data["implicit_distance"], dtype=np.float64)


def _scaled_copy(path: Path, folder: Path) -> Path:
    """The CAD file's shape scaled by 1.001 about its bounding box's centre, as a BREP file
    in ``folder`` (Open CASCADE: read, BRepBuilderAPI_Transform, written)."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
    from OCP.BRepTools import BRepTools
    from OCP.gp import gp_Pnt, gp_Trsf
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader

    reader = STEPControl_Reader()
    assert reader.ReadFile(str(path)) == IFSelect_RetDone, path
    reader.TransferRoots()
    shape = reader.OneShape()
    box = Bnd_Box()
    BRepBndLib.Add_s(shape, box)
    lo, hi = box.CornerMin(), box.CornerMax()
    scale = gp_Trsf()
    centre = gp_Pnt((lo.X() + hi.X()) / 2, (lo.Y() + hi.Y()) / 2, (lo.Z() + hi.Z()) / 2)
    scale.SetScale(centre, 1.001)
    out = folder / (path.stem + "-scaled.brep")
    BRepTools.Write_s(BRepBuilderAPI_Transform(shape, scale, True).Shape(), str(out))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="1024x768", help="picture size (default 1024x768)")
    parser.add_argument("--rounds", type=int, default=3, help="timed rounds (default 3)")
    parser.add_argument("--cad", action="append", default=[], help="a CAD file, against itself")
    parser.add_argument(
        "--scaled",
        action="append",
        default=[],
        help="a CAD file, against its copy scaled by 1.001 about its box's centre (every "
        "face moved: a real deviation; the copy made by the kernel in a temporary folder)",
    )
    args = parser.parse_args()
    width, height = (int(x) for x in args.size.split("x"))

    import gshade
    from gshade.rendering.deviation_image import deviation_image
    from gshade.rendering.deviation_references import SurfaceReference
    from gshade.runtime import setup
    from gshade.scene import load_scene

    setup()
    folder = Path(tempfile.mkdtemp())
    (folder / "a.toml").write_text(SPHERE.format(name="a", radius=2.0))
    (folder / "b.toml").write_text(SPHERE.format(name="b", radius=2.003))
    pairs = [("sphere 2 vs 2.003", folder / "a.toml", folder / "b.toml", 0.003)]
    pairs += [(Path(f).name + " vs itself", Path(f), Path(f), 0.0) for f in args.cad]
    pairs += [
        (Path(f).name + " vs scaled 1.001", Path(f), _scaled_copy(Path(f), folder), 1e-6)
        for f in args.scaled
    ]
    size = {"render.width": width, "render.height": height, "render.spp": 4}
    print(
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"{time.strftime('%Y-%m-%d %H:%M')}, {width}x{height}, {args.rounds} rounds"
    )
    for label, a_path, b_path, exact in pairs:
        a, b = load_scene(a_path, size), load_scene(b_path)
        render_s, deviation_s, vtk_s = [], [], []
        mesh = _mesh_of(b)
        for round_ in range(args.rounds + 1):
            start = time.perf_counter()
            gshade.render(a)
            rendered = time.perf_counter() - start
            start = time.perf_counter()
            image, summary = deviation_image(a, SurfaceReference(b), max(exact, 1e-9))
            deviated = time.perf_counter() - start
            on = image["patch"] >= 0
            P = np.stack([image[f"P.{c}"][on] for c in "XYZ"], -1).astype(np.float64)
            start = time.perf_counter()
            mesh_d = _vtk_distances(mesh, P)
            meshed = time.perf_counter() - start
            if round_:
                render_s.append(rendered)
                deviation_s.append(deviated)
                vtk_s.append(meshed)
        exact_d = np.abs(image["f"][on].astype(np.float64))
        error = np.abs(np.abs(mesh_d) - exact_d)
        r, d, v = (statistics.median(x) for x in (render_s, deviation_s, vtk_s))
        print(
            f"{label:32} {on.sum():7d} points  render {r:6.2f} s  deviation {d:6.2f} s "
            f"[{min(deviation_s):.2f}-{max(deviation_s):.2f}] ({d / r:4.1f}x render)  "
            f"VTK {v:6.2f} s  |  gshade max |d| {summary['max_abs']:.3e} (exact {exact}), "
            f"VTK error max {error.max():.3e} mean {error.mean():.3e}"
        )


if __name__ == "__main__":
    main()
