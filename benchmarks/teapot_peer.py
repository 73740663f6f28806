"""The teapot peer of ``bench_peer.py``: what a user would do without gshade, in one process.

Read Newell's teapot (``scenes/data/teapot.txt``: 32 bicubic Bézier patches as 16 indices
into a vertex list each), evaluate every patch on a grid of ``--vertices`` x ``--vertices``
points with numpy (Bernstein basis), gather the two triangles of each grid cell into one
``pyvista.PolyData``, weld the patches' shared edges with ``clean()`` (coincident points
merged; the triangles collapsed at the lid's and the bottom's poles become lines), take
VTK's point normals (``compute_normals`` without its reordering pass: the triangles are
oriented along p_u x p_v, as gshade's ``N``) and then, by ``SHAPE``:

- ``isophotes``: the two-colour stripes of <n, l>: the scalars <n, l> through a lookup
  table of ``2 --stripes`` alternating dark and light colours on [-1, 1] (dark where
  fract(<n, l> / T) < 1/2, T = 2 / stripes: gshade's stripes with duty 1/2, phase 0);
- ``mean``: VTK's discrete mean curvature (``curvature("mean")``), negated to gshade's sign
  convention, as a coolwarm colour map on ``--range``, with the isophote stripes' edges
  (<n, l> a multiple of T / 2) drawn over it as black lines (``contour``): gshade's
  ``display = "both"`` as VTK draws it;

or, with ``--plain``, the plainer peer of issue 27: the mean curvature's colour map alone
(no contour lines; the isophotes are the same either way);

then plot off-screen through gshade's camera (``--camera``, horizontal field of view),
shaded with those normals (Phong interpolation; VTK's default light kit), and save a
screenshot (PNG).  Off-screen rendering without X: EGL (Mesa's llvmpipe).

Usage, from the repository root::

    python benchmarks/teapot_peer.py {isophotes,mean} OUT.png [--camera JSON]
        [--vertices 64] [--width 1024] [--height 768] [--plain] [--sample P.npy OUT.npy]

``--sample P.npy OUT.npy``: also write, at the points ``P`` (n x 3), the mesh's mean
curvature (``mean``) or <n, l> (``isophotes``), interpolated linearly on the closest
triangle (untimed use, for the error).  Prints one line ``PEER_JSON {...}``: the stage
times (s) and the mesh's size.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

# Off-screen without X: VTK's wheels try X first (and warn) unless told to use EGL.
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np
from cad_peer import Laps, place_camera, sample_linear

ROOT = Path(__file__).resolve().parent.parent
TEAPOT = ROOT / "scenes" / "data" / "teapot.txt"
LIGHT = (0.3, -0.5, 0.8)  # the teapot scenes' light, normalised below
STRIPES = 20  # stripe periods over <n, l> in [-1, 1]
DARK, LIGHT_COLOUR = (0.04, 0.04, 0.05), (0.92, 0.92, 0.90)  # gshade's stripe colours


def read_newell(path: Path) -> np.ndarray:
    """The control nets, shape (patches, 4, 4, 3), of a file in Newell's format."""
    rows = [line.replace(",", " ").split() for line in path.read_text().splitlines()]
    rows = [r for r in rows if r]
    n_patches = int(rows[0][0])
    indices = np.array(rows[1 : 1 + n_patches], dtype=np.int64) - 1
    n_vertices = int(rows[1 + n_patches][0])
    vertices = np.array(rows[2 + n_patches : 2 + n_patches + n_vertices], dtype=np.float64)
    return vertices[indices].reshape(n_patches, 4, 4, 3)


def grid_mesh(nets: np.ndarray, vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Points (patches x vertices², 3) of each patch on a uniform (u, v) grid, and the
    triangles (two per grid cell, oriented along p_u x p_v, u the nets' first index)."""
    t = np.linspace(0.0, 1.0, vertices)
    s = 1.0 - t
    bernstein = np.stack([s**3, 3 * t * s**2, 3 * t**2 * s, t**3], axis=1)  # (vertices, 4)
    points = np.einsum("ui,pijc,vj->puvc", bernstein, nets, bernstein).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(vertices - 1), np.arange(vertices - 1), indexing="ij")
    a = (i * vertices + j).ravel()
    b, c, d = a + vertices, a + vertices + 1, a + 1  # (u+1, v), (u+1, v+1), (u, v+1)
    cell = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    offsets = np.arange(len(nets))[:, None, None] * vertices**2
    return points, (cell[None] + offsets).reshape(-1, 3)


def stripe_colours(stripes: int):
    """The isophotes' lookup table: dark and light alternating, 2 ``stripes`` entries."""
    from matplotlib.colors import ListedColormap

    return ListedColormap([DARK, LIGHT_COLOUR] * stripes)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("shape", choices=("isophotes", "mean"))
    parser.add_argument("png", type=Path)
    parser.add_argument("--data", type=Path, default=TEAPOT)
    parser.add_argument("--camera", type=json.loads)
    parser.add_argument("--vertices", type=int, default=64, help="per patch side")
    parser.add_argument("--range", type=float, nargs=2, default=(-3.0, 3.0), metavar=("LO", "HI"))
    parser.add_argument("--width", type=int, default=1024)
    parser.add_argument("--height", type=int, default=768)
    parser.add_argument("--sample", nargs=2, type=Path, metavar=("P.npy", "OUT.npy"))
    parser.add_argument("--plain", action="store_true", help="no contour lines over the map")
    args = parser.parse_args(argv)

    lap = Laps()
    import pyvista as pv

    lap("imports")
    nets = read_newell(args.data)
    lap("read")
    points, triangles = grid_mesh(nets, args.vertices)
    faces = np.column_stack([np.full(len(triangles), 3), triangles]).ravel()
    mesh = pv.PolyData(points, faces).clean()
    lap("mesh")
    # the patches are oriented alike (p_u x p_v); VTK's reordering pass for consistency
    # would flip some of the lid's patches at the poles' non-manifold fans: off
    mesh = mesh.compute_normals(cell_normals=False, split_vertices=False, consistent_normals=False)
    light = np.asarray(LIGHT) / np.linalg.norm(LIGHT)
    mesh["n.l"] = mesh.point_data["Normals"] @ light
    if args.shape == "mean":
        # VTK's sign is the opposite of gshade's for the same normals (a sphere with outward
        # normals: VTK +1/r, gshade -1/r): negated, so that the colours mean the same
        mesh["mean curvature"] = -mesh.curvature("mean")
    lap("normals_curvature")
    plotter = pv.Plotter(off_screen=True, window_size=(args.width, args.height))
    common = {"interpolation": "phong", "show_scalar_bar": False}
    if args.shape == "isophotes":
        cmap = stripe_colours(STRIPES)
        plotter.add_mesh(mesh, scalars="n.l", cmap=cmap, clim=(-1.0, 1.0), **common)
    else:
        plotter.add_mesh(mesh, scalars="mean curvature", cmap="coolwarm", clim=args.range, **common)
        edges = np.arange(-1.0, 1.0, 1.0 / STRIPES)[1:]  # every half period T / 2
        lines = None if args.plain else mesh.contour(isosurfaces=edges, scalars="n.l")
        if lines is not None and lines.n_points:
            plotter.add_mesh(lines, color="black", line_width=1)
    place_camera(plotter, args.camera)
    plotter.screenshot(str(args.png))
    plotter.close()
    lap("plot")
    if args.sample:
        triangles_only = pv.PolyData(mesh.points, faces=mesh.faces)  # without the pole lines
        name = "mean curvature" if args.shape == "mean" else "n.l"
        values = np.asarray(mesh.point_data[name], dtype=np.float64)
        np.save(args.sample[1], sample_linear(triangles_only, values, np.load(args.sample[0])))
    result = {
        "stages": lap.times,
        "points": int(mesh.n_points),
        "triangles": int(mesh.n_faces),
        "vertices_per_side": args.vertices,
    }
    print("PEER_JSON " + json.dumps(result), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
