"""Write the control meshes of the Catmull–Clark scenes (OBJ files in scenes/data/).

- ``cube.obj``: the cube [-1, 1]^3, 8 vertices of valence 3, 6 quads.
- ``pentadrum.obj``: a pentagonal prism (circumradius 1, height 1.4) with its faces split
  at their centres into quads (each polygon's centre joined to its edge midpoints, as one
  Catmull–Clark step would split it, but without moving anything); the cap centres are
  lifted by 0.45 (domes) and the side midpoints pushed out by 12 % (a bulge).  The 10
  prism corners have valence 3, the 2 cap centres valence 5, the other 20 vertices
  (15 edge midpoints, 5 side centres) valence 4: 32 vertices, 30 quads.
- ``hexadrum.obj``: the same with a hexagonal prism: 12 corners of valence 3, 2 cap
  centres of valence 6; 38 vertices, 36 quads.

Faces run counter-clockwise seen from outside.  Run from the repository root:
``python scenes/make_subdivision_meshes.py``.
"""

from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DOME = np.array([0.0, 0.0, 0.45])  # cap centres lifted
BULGE = np.array([1.12, 1.12, 1.0])  # side midpoints pushed out


def cube():
    v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)

    def i(x, y, z):
        return 4 * x + 2 * y + z

    faces = [
        (i(0, 0, 0), i(0, 1, 0), i(1, 1, 0), i(1, 0, 0)),  # z = -1
        (i(0, 0, 1), i(1, 0, 1), i(1, 1, 1), i(0, 1, 1)),  # z = +1
        (i(0, 0, 0), i(1, 0, 0), i(1, 0, 1), i(0, 0, 1)),  # y = -1
        (i(0, 1, 0), i(0, 1, 1), i(1, 1, 1), i(1, 1, 0)),  # y = +1
        (i(0, 0, 0), i(0, 0, 1), i(0, 1, 1), i(0, 1, 0)),  # x = -1
        (i(1, 0, 0), i(1, 1, 0), i(1, 1, 1), i(1, 0, 1)),  # x = +1
    ]
    return v, faces


def split_polygons(vertices, polygons, centre_lift=None, edge_push=None):
    """Quads from polygons: corner k, midpoint of edge k, centre, midpoint of edge k - 1.

    ``centre_lift(poly_index, centre)`` and ``edge_push(a, b, midpoint)`` may move the new
    points.
    """
    points = [tuple(p) for p in vertices]
    mids = {}

    def midpoint(a, b):
        key = (min(a, b), max(a, b))
        if key not in mids:
            m = 0.5 * (np.asarray(vertices[a]) + np.asarray(vertices[b]))
            if edge_push is not None:
                m = edge_push(a, b, m)
            mids[key] = len(points)
            points.append(tuple(m))
        return mids[key]

    quads = []
    for k, poly in enumerate(polygons):
        c = np.mean([vertices[i] for i in poly], axis=0)
        if centre_lift is not None:
            c = centre_lift(k, c)
        ci = len(points)
        points.append(tuple(c))
        m = len(poly)
        for j in range(m):
            quads.append(
                (
                    poly[j],
                    midpoint(poly[j], poly[(j + 1) % m]),
                    ci,
                    midpoint(poly[(j - 1) % m], poly[j]),
                )
            )
    return np.array(points), quads


def drum(k):
    """A k-gonal prism split into quads (``pentadrum`` for k = 5)."""
    angles = np.pi / 2 + 2 * np.pi * np.arange(k) / k
    height = 1.4
    ring = np.stack([np.cos(angles), np.sin(angles), np.zeros(k)], -1)
    vertices = np.concatenate([ring, ring + np.array([0.0, 0.0, height])])  # bottom, top
    bottom = list(range(k - 1, -1, -1))  # seen from below: counter-clockwise
    top = list(range(k, 2 * k))
    sides = [(i, (i + 1) % k, k + (i + 1) % k, k + i) for i in range(k)]
    polygons = [bottom, top, *sides]

    def lift(j, c):
        if j == 0:
            return c - DOME
        if j == 1:
            return c + DOME
        return c * BULGE

    def push(a, b, m):
        if (a < k) != (b < k):  # a vertical edge
            return m * BULGE
        return m

    return split_polygons(vertices, polygons, lift, push)


def pentadrum():
    return drum(5)


def check_outward(vertices, faces):
    centre = vertices.mean(axis=0)
    for f in faces:
        p = vertices[list(f)]
        n = np.cross(p[2] - p[0], p[3] - p[1])
        assert np.dot(n, p.mean(axis=0) - centre) > 0, f


def write_obj(path, vertices, faces, comment):
    lines = [f"# {line}" if line else "#" for line in comment.splitlines()]
    clean = np.where(np.abs(vertices) < 1e-12, 0.0, vertices)
    lines += [f"v {x:.15g} {y:.15g} {z:.15g}" for x, y, z in clean]
    lines += ["f " + " ".join(str(i + 1) for i in f) for f in faces]
    path.write_text("\n".join(lines) + "\n")


def main():
    v, f = cube()
    check_outward(v, f)
    write_obj(
        HERE / "data" / "cube.obj",
        v,
        f,
        "The cube [-1, 1]^3: 8 vertices of valence 3 (scenes/make_subdivision_meshes.py).",
    )
    v, f = pentadrum()
    check_outward(v, f)
    write_obj(
        HERE / "data" / "pentadrum.obj",
        v,
        f,
        "A pentagonal prism split into quads at its face centres, domed caps, bulging sides:\n"
        "10 vertices of valence 3, 2 of valence 5, 20 of valence 4\n"
        "(scenes/make_subdivision_meshes.py).",
    )
    v, f = drum(6)
    check_outward(v, f)
    write_obj(
        HERE / "data" / "hexadrum.obj",
        v,
        f,
        "A hexagonal prism split into quads at its face centres, domed caps, bulging sides:\n"
        "12 vertices of valence 3, 2 of valence 6, 24 of valence 4\n"
        "(scenes/make_subdivision_meshes.py).",
    )


if __name__ == "__main__":
    main()
