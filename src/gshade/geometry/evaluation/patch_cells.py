"""Bézier and B-spline patches of one degree as Bézier cells, their points and first
derivatives at many points in one Dr.Jit kernel.

A CAD model's faces are B-spline patches (rational or not) of a few degrees; an image's
pixels fall on all of them.  Evaluated by numpy, each point gathers its (m + 1) x (n + 1)
control points into memory before the products
(:mod:`gshade.geometry.evaluation.spline_batches`), and that traffic is the cost.  Here each
patch is cut once into the Bézier patches of its knot intervals (Bézier extraction,
:func:`gshade.geometry.evaluation.bezier_cells.tensor_cells`; a Bézier patch is one cell),
the homogeneous nets of all cells laid end to end and each point's cell found as
:class:`gshade.geometry.evaluation.bezier_cells.CellTable` lays them out and finds them, and
one kernel per call evaluates, per point, the Bernstein basis of its cell in closed form and
sums its control points gathered inside the kernel (no temporaries):

    h(s, t) = sum_ij B_i^m(s) B_j^n(t) H_ij,   p = h_xyz / h_w,
    p_s = (h_xyz,s - p h_w,s) / h_w,  ...

with s, t the point's parameters normalised to its cell, and the higher derivatives alike
(Leibniz's rule for rational patches,
:func:`gshade.geometry.core.rational.project_patch_derivatives`).  The result equals each patch's
own ``derivatives`` up to round-off (tested).

Examples
--------
>>> import numpy as np
>>> from gshade.geometry import BSplinePatch
>>> rng = np.random.default_rng(3)
>>> knots = ([0, 0, 0, 0.4, 1, 1, 1], [0, 0, 1, 1])
>>> patch = BSplinePatch(rng.normal(size=(4, 2, 3)), (2, 1), knots, rng.uniform(1, 2, (4, 2)))
>>> cells = PatchCells([patch])
>>> u, v = np.array([0.1, 0.7]), np.array([0.3, 0.9])
>>> d = cells.derivatives(np.zeros(2, dtype=np.int64), u, v)
>>> bool(np.allclose(d, patch.derivatives(u, v, 1)))
True
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from math import comb, perm
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...runtime.drjit_arrays import drjit_array
from ...runtime.llvm import import_drjit
from ..core.patch import homogeneous, validate_order
from ..core.rational import project_patch_derivatives
from ..patches.bezier import BezierPatch
from ..patches.bspline import BSplinePatch
from .bezier_cells import CellTable, few_cells, tensor_cells
from .spline_batches import batch_derivatives

__all__ = ["ManyPatches", "PatchCells", "cell_groups"]


def cell_groups(patches: Sequence[Any]) -> tuple[dict[tuple, list[int]], list[int]]:
    """The indices of the Bézier and B-spline patches (of at most
    :data:`gshade.geometry.evaluation.bezier_cells.MAX_CELLS` knot intervals) by (degree, rational),
    and of all other patches."""
    groups: dict[tuple, list[int]] = {}
    others = []
    for k, patch in enumerate(patches):
        if type(patch) is BezierPatch or (type(patch) is BSplinePatch and few_cells(patch)):
            groups.setdefault((patch.degree, patch.rational), []).append(k)
        else:
            others.append(k)
    return groups, others


#: each patch's cells, kept while the patch lives (see :func:`_cells`)
_CELLS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _cells(patch: BezierPatch | BSplinePatch) -> tuple[NDArray, NDArray, NDArray]:
    """The patch's cell breaks along u and v and its cells' homogeneous nets
    (cells, m + 1, n + 1, c), as :func:`gshade.geometry.evaluation.bezier_cells.tensor_cells` gives
    them (a Bézier patch: one cell over its domain)."""
    kept = _CELLS.get(patch)
    if kept is not None:
        return kept
    net = homogeneous(patch.points, patch.weights)  # (w P, w) if rational
    if isinstance(patch, BezierPatch):
        (a, b), (c, d) = patch.domain
        kept = (np.array([a, b]), np.array([c, d]), net[None])
    else:
        kept = tensor_cells(patch.knots, patch.degree, net)
    _CELLS[patch] = kept
    return kept


class PatchCells:
    """Bézier or B-spline patches of one degree and kind as Bézier cells, for
    :meth:`derivatives`."""

    def __init__(self, patches: Sequence[BezierPatch | BSplinePatch]) -> None:
        first = patches[0]
        self.degree: tuple[int, int] = first.degree
        self.rational: bool = first.rational
        if any(p.degree != self.degree or p.rational != self.rational for p in patches):
            raise ValueError("PatchCells: patches of one degree and kind only")
        self.table = CellTable([_cells(p) for p in patches])
        self.nets = self.table.nets.reshape(-1)  # flat, for the kernel's gathers

    def derivatives(
        self, member: NDArray, u: NDArray, v: NDArray, order: int = 1
    ) -> NDArray[np.float64]:
        """Derivatives up to total order ``order`` of patch ``member[i]`` at (u[i], v[i]):
        shape (order + 1, order + 1, N, 3), as ``Patch.derivatives(u, v, order)`` (zero for
        i + j > order)."""
        dr = import_drjit()
        from drjit.llvm import Float64, UInt32

        order = validate_order(order)
        member = np.asarray(member, dtype=np.int64)
        u = np.asarray(u, dtype=np.float64)
        v = np.asarray(v, dtype=np.float64)
        cell, (s, t), (side_u, side_v) = self.table.locate(member, u, v)
        m, n = self.degree
        c = 4 if self.rational else 3
        nets = drjit_array(Float64, self.nets)
        base = drjit_array(UInt32, cell * ((m + 1) * (n + 1) * c), np.uint32)
        bu = _bernstein(m, drjit_array(Float64, s), order)
        bv = _bernstein(n, drjit_array(Float64, t), order)
        wanted = [(a, b) for a in range(order + 1) for b in range(order + 1 - a)]
        h: dict[tuple[int, int], list[Any]] = {ab: [0.0] * c for ab in wanted}
        # the sum over j first (each row's v-derivatives), then over i: fewer products
        for i in range(m + 1):
            row: list[list[Any]] = [[0.0] * c for _ in range(order + 1)]
            for j in range(n + 1):
                for k in range(c):
                    x = dr.gather(Float64, nets, base + ((i * (n + 1) + j) * c + k))
                    for b in range(order + 1):
                        row[b][k] = row[b][k] + bv[b][j] * x
            for a, b in wanted:
                for k in range(c):
                    h[a, b][k] = h[a, b][k] + bu[a][i] * row[b][k]
        arrays = [h[ab][k] for ab in wanted for k in range(c)]
        dr.eval(*arrays)
        buf = np.zeros((order + 1, order + 1, c, u.size))
        for at, (a, b) in enumerate(wanted):
            # d/du = d/ds / side_u: the cell's parameters normalised
            scale = 1.0 / (side_u**a * side_v**b) if a or b else 1.0
            for k in range(c):
                np.multiply(np.asarray(arrays[at * c + k]), scale, out=buf[a, b, k])
        if self.rational:
            buf = project_patch_derivatives(buf[:, :, :3], buf[:, :, 3], order)
        return np.moveaxis(buf, 2, -1)


class ManyPatches:
    """Any patches, for the derivatives of points on many of them at once: the Bézier and
    B-spline patches of one degree and kind by one Dr.Jit kernel over their cells
    (:class:`PatchCells`, with ``drjit``), every other patch (all without ``drjit``) by
    :func:`gshade.geometry.evaluation.spline_batches.batch_derivatives`."""

    def __init__(self, patches: Sequence[Any], drjit: bool) -> None:
        self.patches = patches
        groups = cell_groups(patches)[0] if drjit else {}
        self.groups = [
            (np.asarray(members), PatchCells([patches[k] for k in members]))
            for members in groups.values()
        ]
        self.place = np.full(len(patches), -1, dtype=np.int64)  # a patch's place in its group
        self.group = np.full(len(patches), -1, dtype=np.int64)  # its group (-1: by numpy)
        for g, (members, _) in enumerate(self.groups):
            self.place[members] = np.arange(members.size)
            self.group[members] = g

    def derivatives(
        self, index: NDArray, u: NDArray, v: NDArray, order: int
    ) -> NDArray[np.float64]:
        """Derivatives up to total order ``order`` of patch ``index[i]`` at (u[i], v[i]):
        shape (order + 1, order + 1, N, 3), as each patch's ``derivatives``."""
        index = np.asarray(index, dtype=np.int64)
        u = np.asarray(u, dtype=np.float64)
        v = np.asarray(v, dtype=np.float64)
        group = self.group[index]
        if len(self.groups) == 1 and index.size and (group == 0).all():  # no copy
            return self.groups[0][1].derivatives(self.place[index], u, v, order)
        out = np.empty((order + 1, order + 1, index.size, 3))
        for g, (_, cells) in enumerate(self.groups):
            at = np.flatnonzero(group == g)
            if at.size:
                out[:, :, at] = cells.derivatives(self.place[index[at]], u[at], v[at], order)
        rest = np.flatnonzero(group < 0)
        if rest.size:
            out[:, :, rest] = batch_derivatives(self.patches, index[rest], u[rest], v[rest], order)
        return out


def _bernstein(degree: int, s: Any, order: int) -> list[list[Any]]:
    """The Bernstein basis of ``degree`` at s (Dr.Jit arrays) and its derivatives up to
    ``order``: ``out[r][i]`` = d^r/ds^r B_i^n = n!/(n - r)! sum_k (-1)^(r-k) C(r, k)
    B_{i-k}^{n-r} (Farin, *Curves and Surfaces for CAGD*, §5.3)."""
    one = 1.0 - s
    powers_s, powers_1 = [1.0], [1.0]
    for _ in range(degree):
        powers_s.append(powers_s[-1] * s)
        powers_1.append(powers_1[-1] * one)

    def basis(n: int, i: int) -> Any:
        return comb(n, i) * powers_s[i] * powers_1[n - i] if 0 <= i <= n else 0.0

    out = []
    for r in range(order + 1):
        if r > degree:
            out.append([0.0] * (degree + 1))
            continue
        factor = perm(degree, r)
        row = []
        for i in range(degree + 1):
            total: Any = 0.0
            for k in range(r + 1):
                term = basis(degree - r, i - k)
                if isinstance(term, float) and term == 0.0:
                    continue
                total = total + ((-1) ** (r - k) * comb(r, k) * factor) * term
            row.append(total)
        out.append(row)
    return out
