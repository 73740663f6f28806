"""Quad meshes for the subdivision and hole tests: the scene meshes, grids, a wavy fan."""

from __future__ import annotations

import numpy as np

from gshade.geometry.subdivision.catmull_clark import catmull_clark

from .paths import ROOT


def wavy_fan(n, rings):
    """A fan of n sectors around one vertex of valence n, lifted into a wave."""
    V, F = fan_mesh(n, rings=rings, seed=n)
    V[:, 2] += 0.3 * np.sin(1.3 * V[:, 0]) * np.cos(0.9 * V[:, 1])
    return V, F


CUBE = ROOT / "scenes" / "data" / "cube.obj"


DRUM = ROOT / "scenes" / "data" / "pentadrum.obj"


def grid_mesh(m, n, height, closed_u=False, closed_v=False):
    """A quad grid of (m+1) x (n+1) vertices (or periodic), vertices from height(i, j)."""
    mu, nv = (m if closed_u else m + 1), (n if closed_v else n + 1)
    V = np.array([height(i, j) for i in range(mu) for j in range(nv)], dtype=float)

    def vid(i, j):
        return (i % mu) * nv + (j % nv)

    F = [
        (vid(i, j), vid(i + 1, j), vid(i + 1, j + 1), vid(i, j + 1))
        for i in range(m)
        for j in range(n)
    ]
    return V, F


def obj_of(vertices, faces):
    lines = [f"v {x} {y} {z}" for x, y, z in vertices]
    lines += ["f " + " ".join(str(i + 1) for i in f) for f in faces]
    return "\n".join(lines) + "\n"


def fan_mesh(sectors, rings=3, keep=None, seed=0):
    """A disk of ``sectors`` quad sectors (rings x rings each) around a vertex of valence
    ``sectors``; with ``keep`` < sectors, an open fan whose centre is on the boundary."""
    rng = np.random.default_rng(seed)
    keep = sectors if keep is None else keep
    verts, index = [(0.0, 0.0, 0.3)], {}

    def vid(s, i, j):
        if i == 0 and j == 0:
            return 0
        if j == 0:
            s, i, j = (s - 1) % sectors, 0, i
        if (s, i, j) not in index:
            a = 2 * np.pi * (s + j / (i + j)) / sectors
            r = max(i, j)
            index[(s, i, j)] = len(verts)
            verts.append((r * np.cos(a), r * np.sin(a), 0.2 * rng.normal()))
        return index[(s, i, j)]

    F = [
        (vid(s, i, j), vid(s, i + 1, j), vid(s, i + 1, j + 1), vid(s, i, j + 1))
        for s in range(keep)
        for i in range(rings)
        for j in range(rings)
    ]
    used = sorted({v for f in F for v in f})
    remap = {v: k for k, v in enumerate(used)}
    return np.array(verts)[used], [tuple(remap[v] for v in f) for f in F]


def limit_positions(V, F):
    """Catmull–Clark limit points of the vertices (Halstead et al. 1993): inner vertex of
    valence n: (n^2 v + 4 sum e_i + sum f_i) / (n (n + 5)) with e_i the edge neighbours and
    f_i the face-opposite vertices; boundary vertex (b1 + 4 v + b2) / 6; corner: v."""
    V, F = np.asarray(V, float), np.asarray(F)
    n = np.bincount(F.ravel(), minlength=len(V)).astype(float)
    e, f = np.zeros_like(V), np.zeros_like(V)
    for k in range(4):
        np.add.at(e, F[:, k], V[F[:, (k + 1) % 4]])
        np.add.at(f, F[:, k], V[F[:, (k + 2) % 4]])
    L = (n[:, None] ** 2 * V + 4 * e + f) / np.maximum(n * (n + 5), 1)[:, None]
    # boundary edges: directed edges without their reverse
    a, b = F.ravel(), np.roll(F, -1, axis=1).ravel()
    pairs = set(zip(a.tolist(), b.tolist(), strict=True))
    bsum, bcount = np.zeros_like(V), np.zeros(len(V))
    for x, y in zip(a.tolist(), b.tolist(), strict=True):
        if (y, x) not in pairs:
            bsum[x] += V[y]
            bsum[y] += V[x]
            bcount[x] += 1
            bcount[y] += 1
    on = bcount > 0
    L[on] = (bsum[on] + 4 * V[on]) / 6
    corner = on & (n == 1)
    L[corner] = V[corner]
    return L


def nearest_distances(points, targets, chunk=256):
    """For each point, the distance to the nearest target (brute force in chunks)."""
    out = np.empty(len(points))
    for s in range(0, len(points), chunk):
        d = points[s : s + chunk, None, :] - targets[None, :, :]
        out[s : s + chunk] = np.sqrt(np.einsum("ijk,ijk->ij", d, d).min(axis=1))
    return out


def refine_times(V, F, k):
    for _ in range(k):
        V, F = catmull_clark(V, F)
    return V, F
