"""Closest points on a triangle mesh (``gshade.analysis.mesh_distance``, issue 30: B of a
deviation may be an STL/OBJ/PLY mesh): ~800,000 queries against meshes of ~100,000
triangles, each answer checked against libigl's AABB tree where libigl is installed.

    python benchmarks/bench_mesh_distance.py [--queries 800000] [--rounds 3] [--workers 1]

Meshes: an icosphere made bumpy (81,920 even triangles), a UV sphere (98,560 triangles,
slivers at its poles) and a "CAD export" (a 512-sided cylinder's long slivers and fans
beside an icosphere's fine triangles, 83,968).  Queries: random points of each mesh moved
along its normal by up to ``--offset`` times the median edge (a deviation map's points
lie near B; far ones cost more, see the module).  Times are medians of ``--rounds``.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import numpy as np
import trimesh

from gshade.analysis.mesh_distance import mesh_closest_points, triangle_samples


def meshes() -> dict[str, trimesh.Trimesh]:
    bumpy = trimesh.creation.icosphere(subdivisions=6)
    x = bumpy.vertices
    bumpy = trimesh.Trimesh(
        x * (1 + 0.05 * np.sin(7 * x[:, :1]) * np.cos(5 * x[:, 1:2])), bumpy.faces, process=False
    )
    cylinder = trimesh.creation.cylinder(radius=1.0, height=3.0, sections=512)
    ball = trimesh.creation.icosphere(subdivisions=6, radius=0.8)
    ball.apply_translation([0, 0, 1.5])
    return {
        "bumpy icosphere": bumpy,
        "UV sphere": trimesh.creation.uv_sphere(radius=1.0, count=[112, 224]),
        "CAD export": trimesh.util.concatenate([cylinder, ball]),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--queries", type=int, default=800_000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--offset", type=float, nargs="+", default=[0.1, 1.0])
    args = parser.parse_args()
    try:
        import igl  # libigl's AABB tree: the reference, where installed
    except ImportError:
        igl = None
    print(
        f"# {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
        f"numpy {np.__version__}, trimesh {trimesh.__version__}, workers={args.workers}"
    )
    columns = "mesh, triangles, samples, queries, offset / edge, gshade (s), libigl (s), max diff"
    print("| " + " | ".join(columns.split(", ")) + " |")
    print("|---|---|---|---|---|---|---|---|")
    for name, mesh in meshes().items():
        V, F = np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64)
        edge = float(np.median(mesh.edges_unique_length))
        samples = len(triangle_samples(V[F]).points)
        for offset in args.offset:
            points, face = trimesh.sample.sample_surface(mesh, args.queries, seed=1)
            rng = np.random.default_rng(2)
            Q = (
                points
                + mesh.face_normals[face] * rng.uniform(-1, 1, (args.queries, 1)) * offset * edge
            )
            times = []
            for _ in range(args.rounds):
                start = time.perf_counter()
                found = mesh_closest_points(V, F, Q, workers=args.workers)
                times.append(time.perf_counter() - start)
            ours = statistics.median(times)
            reference, diff = "-", "-"
            if igl is not None:
                start = time.perf_counter()
                squared, _, _ = igl.point_mesh_squared_distance(Q, V, F)
                reference = f"{time.perf_counter() - start:.2f}"
                diff = f"{np.max(np.abs(np.sqrt(squared) - found.distance)):.1e}"
            print(
                f"| {name} | {len(F):,} | {samples:,} | {args.queries:,} | <= {offset:g} | "
                f"{ours:.2f} | {reference} | {diff} |"
            )


if __name__ == "__main__":
    main()
