"""The points of a set of patches a closest-point search starts from: every patch sampled on
a grid of its domain (cells of equal arc length in each knot span, in the ratio of its
lengths across), and the grid's blocks of cells boxed (:class:`Blocks`) for the search's
last round (:mod:`gshade.analysis.closest_points`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..geometry import Patch

__all__ = ["BLOCK", "GRID", "Blocks", "Samples", "grid_samples"]

#: Samples a side of each patch's grid for the coarse search.
GRID = 17
#: The most samples along a side of a patch.
MOST_SAMPLES = 129
#: Cells a side of a block of samples boxed for the search's last round (:class:`Blocks`).
BLOCK = 8


class _Points:
    """Points of many patches at once: lists of (patch, u, v) arrays evaluated in one batch
    (:class:`~gshade.geometry.evaluation.patch_cells.ManyPatches`), split back by list."""

    def __init__(self, patches: Sequence[Patch]) -> None:
        from ..geometry.evaluation.patch_cells import ManyPatches

        self.many = ManyPatches(patches, drjit=False)

    def __call__(self, asked: list[tuple[int, NDArray, NDArray]]) -> list[NDArray[np.float64]]:
        if not asked:
            return []
        sizes = [u.size for _, u, _ in asked]
        index = np.repeat([k for k, _, _ in asked], sizes)
        u = np.concatenate([u.ravel() for _, u, _ in asked])
        v = np.concatenate([v.ravel() for _, _, v in asked])
        points = self.many.derivatives(index, u, v, 0)[0, 0]
        return np.split(points, np.cumsum(sizes)[:-1])


def _lattice_parameters(patch: Patch) -> tuple[NDArray, NDArray]:
    """5 x 5 parameters over a patch's domain, for :func:`_lattice`."""
    t = np.linspace(0.0, 1.0, 5)
    (u0, u1), (v0, v1) = patch.domain
    u, v = np.meshgrid(u0 + (u1 - u0) * t, v0 + (v1 - v0) * t, indexing="ij")
    return u.ravel(), v.ravel()


def _lattice(points: NDArray, grid: int) -> tuple[int, int]:
    """The samples along u and along v of a patch's ``grid`` x ``grid`` budget, in the
    ratio of its lengths across (a long, thin face gets its samples along its length),
    from its ``points`` (25, 3) at :func:`_lattice_parameters`."""
    p = points.reshape(5, 5, 3)
    along_u = np.linalg.norm(np.diff(p, axis=0), axis=-1).sum(axis=0).max()
    along_v = np.linalg.norm(np.diff(p, axis=1), axis=-1).sum(axis=1).max()
    if not (along_u > 0 and along_v > 0):
        return grid, grid
    nu = int(np.clip(round(grid * np.sqrt(along_u / along_v)), 3, grid * grid // 3))
    return nu, max(3, (grid * grid) // nu)


def _axis_parameters(patch: Patch, axis: int) -> tuple[NDArray, NDArray, NDArray]:
    """The parameters along ``axis`` at which :func:`_axis_samples` measures a patch's
    length (eight a knot span, at most :data:`MOST_SAMPLES` spans), and the (u, v) of
    three lines across through them."""
    lo, hi = patch.domain[axis]
    breaks = np.array([lo, hi])
    knots = getattr(patch, "knots", None)
    if knots is not None:
        breaks = np.unique(np.clip(np.asarray(knots[axis], dtype=np.float64), lo, hi))
    if breaks.size > MOST_SAMPLES:
        breaks = breaks[:: -(-breaks.size // MOST_SAMPLES)]
    eighths = np.linspace(0.0, 1.0, 9)
    fine = np.unique(breaks[:-1, None] + np.diff(breaks)[:, None] * eighths)
    (u0, u1), (v0, v1) = patch.domain
    across = np.array([1 / 6, 1 / 2, 5 / 6])
    other = (v0 + (v1 - v0) * across) if axis == 0 else (u0 + (u1 - u0) * across)
    t, o = np.meshgrid(fine, other, indexing="ij")
    u, v = (t, o) if axis == 0 else (o, t)
    return fine, u.ravel(), v.ravel()


def _axis_samples(
    patch: Patch, axis: int, n: int, spacing: float, fine: NDArray, points: NDArray
) -> NDArray[np.float64]:
    """A patch's sample parameters along ``axis``: the middles of n cells of equal length
    (arc length, the longest of three lines across, measured at ``points`` (3 len(fine),
    3) at the parameters ``fine``: a B-spline's speed in each knot span, so that a
    parametrisation that crowds its shape into a few spans has its samples there), more
    where the length needs them ``spacing`` apart (> 0), at most :data:`MOST_SAMPLES`."""
    lo, hi = patch.domain[axis]
    at = points.reshape(len(fine), 3, 3)
    step = np.linalg.norm(np.diff(at, axis=0), axis=-1).max(axis=1)
    length = np.concatenate([[0.0], np.cumsum(step)])
    if spacing > 0:
        n = max(n, min(MOST_SAMPLES, int(np.ceil(length[-1] / spacing))))
    if not length[-1] > 0:
        return lo + (hi - lo) * (np.arange(n) + 0.5) / n
    return np.interp((np.arange(n) + 0.5) / n * length[-1], length, fine)


def _blocks(at: NDArray, su: NDArray, sv: NDArray, reach: float) -> list[tuple]:
    """The :class:`Blocks` of one patch's lattice of samples ``at`` (nu, nv, 3) at
    parameters ``su`` x ``sv`` whose cells' diagonals are at most ``reach``: (lo, hi,
    (u, v)) each, a block's samples and those of the next row and column (the cells
    between blocks) boxed."""
    out = []
    for i in range(0, max(len(su) - 1, 1), BLOCK):
        for j in range(0, max(len(sv) - 1, 1), BLOCK):
            part = at[i : i + BLOCK + 1, j : j + BLOCK + 1].reshape(-1, 3)
            middle = (su[min(i + BLOCK // 2, len(su) - 1)], sv[min(j + BLOCK // 2, len(sv) - 1)])
            out.append((part.min(axis=0) - 2 * reach, part.max(axis=0) + 2 * reach, middle))
    return out


def _samples(
    patches: Sequence[Patch], grid: int, spacing: float = 0.0
) -> tuple[NDArray, NDArray, NDArray, NDArray, Blocks]:
    """Every patch's samples, ``grid`` x ``grid`` of them spread in the ratio of its
    lengths (:func:`_lattice`), at the middles of its cells (none on a side: the samples
    of a pole or a seam would be many at one point, each a poor start): points (m, 3),
    their patch (m,) and (u, v), each patch's spacing in its domain (k, 2) and the blocks
    (:class:`Blocks`).  Each stage's points of all patches in one batch (:class:`_Points`)."""
    evaluate = _Points(patches)
    ks = range(len(patches))
    lattice = evaluate([(k, *_lattice_parameters(patches[k])) for k in ks])
    sizes = [_lattice(p, grid) for p in lattice]
    axes = [[_axis_parameters(patches[k], axis) for axis in (0, 1)] for k in ks]
    measured = evaluate([(k, u, v) for k in ks for _, u, v in axes[k]])
    su, sv = [], []
    for k, patch in enumerate(patches):
        (fu, _, _), (fv, _, _) = axes[k]
        su.append(_axis_samples(patch, 0, sizes[k][0], spacing, fu, measured[2 * k]))
        sv.append(_axis_samples(patch, 1, sizes[k][1], spacing, fv, measured[2 * k + 1]))
    grids = [np.meshgrid(su[k], sv[k], indexing="ij") for k in ks]
    lattices = evaluate([(k, uu.ravel(), vv.ravel()) for k, (uu, vv) in enumerate(grids)])
    points, owner, uv, cells = [], [], [], []
    boxes: list[tuple] = []
    box_patch: list[int] = []
    for k in ks:
        # two mean spacings: the starts within that of each other on the patch are one
        cells.append(tuple(2 * np.ptp(t) / max(len(t) - 1, 1) for t in (su[k], sv[k])))
        u, v = grids[k][0].ravel(), grids[k][1].ravel()
        at = lattices[k].reshape(len(su[k]), len(sv[k]), 3)
        one = np.linalg.norm(at[1:, 1:] - at[:-1, :-1], axis=-1).max(initial=0.0)
        other = np.linalg.norm(at[1:, :-1] - at[:-1, 1:], axis=-1).max(initial=0.0)
        mine = _blocks(at, su[k], sv[k], max(float(one), float(other)))
        boxes += mine
        box_patch += [k] * len(mine)
        points.append(at.reshape(-1, 3))
        owner.append(np.full(u.size, k))
        uv.append(np.stack([u, v], -1))
    cell = np.array(cells, dtype=np.float64).reshape(-1, 2)
    blocks = Blocks(
        np.array([b[0] for b in boxes]).reshape(-1, 3),
        np.array([b[1] for b in boxes]).reshape(-1, 3),
        np.array(box_patch, dtype=np.int64),
        np.array([b[2] for b in boxes], dtype=np.float64).reshape(-1, 2),
    )
    return np.concatenate(points), np.concatenate(owner), np.concatenate(uv), cell, blocks


@dataclass(frozen=True)
class Blocks:
    """Boxes holding the patches piece by piece: each block of a patch's sample lattice
    (:data:`BLOCK` x :data:`BLOCK` cells) boxed by its samples, widened by two of the
    patch's cell diagonals (how far its surface may bulge between samples): corners ``lo``
    and ``hi`` (b, 3), its ``patch`` (b,) and a start ``uv`` (b, 2) in its middle."""

    lo: NDArray[np.float64]
    hi: NDArray[np.float64]
    patch: NDArray[np.int64]
    uv: NDArray[np.float64]


@dataclass(frozen=True)
class Samples:
    """Points of the surface for the coarse search: ``points`` (m, 3) on patches
    ``patch`` (m,) at parameters ``uv`` (m, 2); ``cell`` (k, 2): each patch's spacing of
    samples in its domain, within which two samples of the patch are one start of
    Newton's method; ``blocks``: the patches' blocks of samples, boxed."""

    points: NDArray[np.float64]
    patch: NDArray[np.int64]
    uv: NDArray[np.float64]
    cell: NDArray[np.float64]
    blocks: Blocks


def grid_samples(patches: Sequence[Patch], grid: int = GRID, spacing: float = 0.0) -> Samples:
    """Every patch's ``grid`` x ``grid`` samples at the middles of its cells, spread in
    the ratio of its lengths across, and more along a length that needs them ``spacing``
    apart (> 0: a big face's samples near every point of it, as a start in the basin of
    its foot point)."""
    return Samples(*_samples(patches, grid, spacing))
