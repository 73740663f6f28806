"""The peer of ``bench_cad.py``: what a user would do without gshade, in one process.

Read a CAD file with the kernel (Open CASCADE through OCP: STEP, IGES, BREP), mesh it with
``BRepMesh_IncrementalMesh`` at a given deflection, gather the triangles into one
``pyvista.PolyData`` (coincident nodes merged, triangles oriented along the faces' outward
normals), take VTK's discrete mean curvature (``curvature("mean")``), plot it off-screen
and save a screenshot (PNG).  For ``.3dm`` files the triangles are Rhino's stored render
meshes (rhino3dm); a file without them exits with status 3 and one line.

Usage, from the repository root::

    python benchmarks/cad_peer.py FILE OUT.png [--deflection D] [--camera JSON]
        [--width 1024] [--height 768] [--sample P.npy H.npy]

``--deflection``: model units (default 1e-3 of the bounding-box diagonal, gshade's default
chord tolerance).  ``--camera``: gshade's resolved camera as JSON (``origin``, ``target``,
``up``, ``fov`` horizontal in degrees), default an isometric view of the whole part.
``--sample P.npy H.npy``: also write the mesh's mean curvature at the points ``P`` (n x 3),
interpolated linearly on the closest triangle (untimed use, for the error).  Prints one line
``PEER_JSON {...}``: the stage times (s), the mesh's size and the deflection used.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

# Off-screen without X: VTK's wheels try X first (and warn) unless told to use EGL.
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np

NO_MESH_STATUS = 3


class Laps:
    """Stage times: each call adds the seconds since the previous one under its name."""

    def __init__(self) -> None:
        self.times: dict[str, float] = {}
        self.clock = time.perf_counter()

    def __call__(self, name: str) -> None:
        now = time.perf_counter()
        self.times[name] = now - self.clock
        self.clock = now


def read_occt(path: Path):
    """The kernel's shape of a STEP, IGES or BREP file (IGES faces sewn into shells)."""
    from OCP.BRep import BRep_Builder
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Sewing
    from OCP.BRepTools import BRepTools
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.IGESControl import IGESControl_Reader
    from OCP.STEPControl import STEPControl_Reader
    from OCP.TopoDS import TopoDS_Shape

    suffix = path.suffix.lower()
    if suffix == ".brep":
        shape = TopoDS_Shape()
        BRepTools.Read_s(shape, str(path), BRep_Builder())
        return shape
    reader = STEPControl_Reader() if suffix in (".step", ".stp") else IGESControl_Reader()
    if reader.ReadFile(str(path)) != IFSelect_RetDone:
        raise SystemExit(f"{path}: the kernel could not read the file")
    reader.TransferRoots()
    shape = reader.OneShape()
    if suffix in (".iges", ".igs"):
        sewing = BRepBuilderAPI_Sewing(bounding_diagonal(shape) * 1e-6)
        sewing.Add(shape)
        sewing.Perform()
        shape = sewing.SewedShape()
    return shape


def bounding_diagonal(shape) -> float:
    """The diagonal of the shape's bounding box."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib

    box = Bnd_Box()
    BRepBndLib.Add_s(shape, box)
    lo, hi = box.CornerMin(), box.CornerMax()
    return float(np.linalg.norm([hi.X() - lo.X(), hi.Y() - lo.Y(), hi.Z() - lo.Z()]))


def mesh_occt(shape, deflection: float) -> tuple[np.ndarray, np.ndarray]:
    """Points (n, 3) and triangles (m, 3) of the kernel's mesh, oriented outward."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.TopAbs import TopAbs_FACE, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    BRepMesh_IncrementalMesh(shape, deflection, False, 0.5, True)
    points, triangles, count = [], [], 0
    explorer = TopExp_Explorer(shape, TopAbs_FACE)
    while explorer.More():
        face = TopoDS.Face(explorer.Current())
        explorer.Next()
        location = TopLoc_Location()
        tri = BRep_Tool.Triangulation_s(face, location)
        if tri is None:
            continue
        trsf = location.Transformation()
        nodes = [tri.Node(i).Transformed(trsf) for i in range(1, tri.NbNodes() + 1)]
        points.append(np.array([(p.X(), p.Y(), p.Z()) for p in nodes]))
        corners = np.array([tri.Triangle(i).Get() for i in range(1, tri.NbTriangles() + 1)])
        if face.Orientation() == TopAbs_REVERSED:
            corners = corners[:, ::-1]
        triangles.append(corners - 1 + count)
        count += tri.NbNodes()
    return np.concatenate(points), np.concatenate(triangles)


def mesh_3dm(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Points and triangles of a ``.3dm`` file's stored render meshes (quads split)."""
    import rhino3dm

    model = rhino3dm.File3dm.Read(str(path))
    points, triangles, count = [], [], 0
    for obj in model.Objects:
        geometry = obj.Geometry
        if isinstance(geometry, rhino3dm.Extrusion):
            geometry = geometry.ToBrep(False)
        meshes = []
        if isinstance(geometry, rhino3dm.Brep):
            meshes = [face.GetMesh(rhino3dm.MeshType.Render) for face in geometry.Faces]
        elif isinstance(geometry, rhino3dm.Mesh):
            meshes = [geometry]
        for mesh in meshes:
            if mesh is None or len(mesh.Faces) == 0:
                continue
            vertices = mesh.Vertices
            points.append(np.array([(v.X, v.Y, v.Z) for v in vertices]))
            for k in range(len(mesh.Faces)):
                a, b, c, d = mesh.Faces[k]
                triangles.append((a + count, b + count, c + count))
                if c != d:
                    triangles.append((a + count, c + count, d + count))
            count += len(vertices)
    if not triangles:
        print(f"{path}: no render meshes in the file", file=sys.stderr)
        raise SystemExit(NO_MESH_STATUS)
    return np.concatenate(points), np.array(triangles)


def place_camera(plotter, camera: dict | None) -> None:
    """gshade's camera (horizontal field of view), or an isometric view of everything."""
    if camera is None:
        plotter.view_isometric()
        return
    cam = plotter.camera
    cam.position, cam.focal_point, cam.up = camera["origin"], camera["target"], camera["up"]
    cam.SetUseHorizontalViewAngle(True)
    cam.view_angle = camera["fov"]
    plotter.renderer.ResetCameraClippingRange()


def sample_linear(mesh, scalars: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``scalars`` (one per mesh point) interpolated linearly at the points of the mesh's
    triangles closest to ``points`` (its triangles alone: a merged mesh may also hold lines
    and vertices, whose cells come first)."""
    import pyvista as pv

    mesh = pv.PolyData(mesh.points, faces=mesh.faces)
    cells, closest = mesh.find_closest_cell(points, return_closest_point=True)
    corners = mesh.regular_faces[cells]
    a, b, c = (mesh.points[corners[:, k]] for k in range(3))
    v0, v1, v2 = b - a, c - a, closest - a
    d00, d01, d11 = (v0 * v0).sum(1), (v0 * v1).sum(1), (v1 * v1).sum(1)
    d20, d21 = (v2 * v0).sum(1), (v2 * v1).sum(1)
    det = np.where(d00 * d11 - d01 * d01 > 0, d00 * d11 - d01 * d01, 1.0)
    wb, wc = (d11 * d20 - d01 * d21) / det, (d00 * d21 - d01 * d20) / det
    wa = 1.0 - wb - wc
    return wa * scalars[corners[:, 0]] + wb * scalars[corners[:, 1]] + wc * scalars[corners[:, 2]]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("file", type=Path)
    parser.add_argument("png", type=Path)
    parser.add_argument("--deflection", type=float)
    parser.add_argument("--camera", type=json.loads)
    parser.add_argument("--width", type=int, default=1024)
    parser.add_argument("--height", type=int, default=768)
    parser.add_argument("--sample", nargs=2, type=Path, metavar=("P.npy", "H.npy"))
    args = parser.parse_args(argv)

    lap = Laps()
    import pyvista as pv

    if args.file.suffix.lower() != ".3dm":
        import OCP.BRepMesh  # noqa: F401  (the kernel's import, timed with the others)
    lap("imports")
    deflection = None
    if args.file.suffix.lower() == ".3dm":
        points, triangles = mesh_3dm(args.file)
        lap("read")
    else:
        shape = read_occt(args.file)
        lap("read")
        deflection = args.deflection or 1e-3 * bounding_diagonal(shape)
        points, triangles = mesh_occt(shape, deflection)
    lap("mesh")
    faces = np.column_stack([np.full(len(triangles), 3), triangles]).ravel()
    mesh = pv.PolyData(points, faces).clean()
    lap("polydata")
    curvature = mesh.curvature("mean")
    mesh["mean curvature"] = curvature
    lap("curvature")
    plotter = pv.Plotter(off_screen=True, window_size=(args.width, args.height))
    low, high = np.percentile(curvature, [2, 98])
    bound = max(abs(low), abs(high)) or 1.0
    plotter.add_mesh(mesh, scalars="mean curvature", cmap="coolwarm", clim=(-bound, bound))
    place_camera(plotter, args.camera)
    plotter.screenshot(str(args.png))
    plotter.close()
    lap("plot")
    if args.sample:
        np.save(args.sample[1], sample_linear(mesh, curvature, np.load(args.sample[0])))
    result = {
        "stages": lap.times,
        "points": int(mesh.n_points),
        "triangles": int(mesh.n_cells),
        "deflection": deflection,
    }
    print("PEER_JSON " + json.dumps(result), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
