"""Many rational B-spline patches and curves as Bézier cells: points and first derivatives
at many points of many splines in a few array operations.

Each spline is converted once to the Bézier coefficients of its knot intervals (from its
values at p + 1 Chebyshev points inside each interval: exact to round-off, Piegl & Tiller
§5.6 by interpolation rather than knot insertion), the cells of all splines of one degree
pair laid end to end.  A point's interval is found in one ``searchsorted`` over the
intervals of every spline at once (each spline's interior knots as keys in (i, i + 1)), so
no call loops over the splines: what :mod:`gshade.cad.rhino_pcurves` needs, thousands of
faces' Newton steps at a time.  The end pieces are continued past the domain (as the kernel
extrapolates).  :mod:`gshade.geometry.evaluation.spline_batches` evaluates patches of one degree by
Cox–de Boor, to any order, with a span search per patch.

The cells themselves are written here once for both their users: a patch's extraction and
the nets' layout (:func:`tensor_cells`), which patches a table holds (:func:`few_cells`) and
the table with its search (:class:`CellTable`); :class:`Splines` evaluates them by numpy,
:class:`gshade.geometry.evaluation.patch_cells.PatchCells` by one Dr.Jit kernel, to any order.

Examples
--------
>>> import numpy as np
>>> from gshade.geometry import BSplinePatch
>>> rng = np.random.default_rng(2)
>>> knots = ([0, 0, 0, 0.5, 1, 1, 1], [0, 0, 0.5, 1, 1])
>>> patch = BSplinePatch(rng.normal(size=(4, 3, 3)), (2, 1), knots)
>>> splines = Splines()
>>> number = splines.add_patch(patch)
>>> splines.freeze()
>>> s, s_u, s_v = splines.evaluate(np.array([number]), np.array([0.3]), np.array([0.7]))
>>> d = patch.derivatives(0.3, 0.7, 1)
>>> bool(np.allclose([s[0], s_u[0], s_v[0]], [d[0, 0], d[1, 0], d[0, 1]]))
True
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.bernstein import bernstein_basis
from ..core.knots import basis_functions, one_clamped_span
from ..patches.bspline import BSplinePatch

__all__ = ["MAX_CELLS", "CellTable", "Splines", "few_cells", "tensor_cells", "to_bezier"]

#: A patch of more knot intervals (u times v) is evaluated on its own, not from a table of
#: Bézier cells.
MAX_CELLS = 20000


class _Intervals:
    """The knot intervals of many splines along one parameter, found for many points of
    many splines in one search: spline i's interior knots as keys i + 1/4 + x/2 in
    (i, i + 1), x the knot's place in the spline's domain (0 to 1)."""

    def __init__(self, breaks: list[NDArray[np.float64]]) -> None:
        self.lo = np.array([b[0] for b in breaks])
        self.span = np.array([b[-1] - b[0] for b in breaks])
        count = np.array([len(b) - 1 for b in breaks])
        self.count = count
        self.first = np.cumsum(count) - count  # each spline's first interval
        self.inner_before = np.cumsum(count - 1) - (count - 1)
        self.keys = np.concatenate(
            [i + 0.25 + 0.5 * (b[1:-1] - b[0]) / (b[-1] - b[0]) for i, b in enumerate(breaks)]
        )
        self.start = np.concatenate([b[:-1] for b in breaks])
        self.width = np.concatenate([np.diff(b) for b in breaks])

    def locate(
        self, which: NDArray[np.intp], t: NDArray[np.float64]
    ) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]:
        """Per point: its interval in its spline (0-based: the last whose start t reaches,
        the end ones past the domain), its place in it (0 to 1 inside, beyond at the ends)
        and the interval's width."""
        x = np.clip((t - self.lo[which]) / self.span[which], -0.4, 1.4)
        keys = which + 0.25 + 0.5 * x
        local = np.searchsorted(self.keys, keys, side="right") - self.inner_before[which]
        local = np.clip(local, 0, self.count[which] - 1)
        at = self.first[which] + local
        # The keys are rounded alike and in order, so every knot up to t is counted, but a
        # knot just past t may share t's key: step back until t reaches the start.
        back = np.flatnonzero((local > 0) & (t < self.start[at]))
        while back.size:
            local[back] -= 1
            at[back] -= 1
            back = back[(local[back] > 0) & (t[back] < self.start[at[back]])]
        width = self.width[at]
        return local, (t - self.start[at]) / width, width


class CellTable:
    """The Bézier cells of many splines of one degree pair, laid end to end (``nets``,
    (cells, p + 1, q + 1, c)), each spline's cells u interval major (as
    :func:`tensor_cells` gives them); a point's cell is found in one search per parameter
    over all the splines (:class:`_Intervals`).

    ``members``: per spline its distinct knots along u and v (ends included) and its cells'
    nets."""

    def __init__(self, members: Sequence[tuple[NDArray, NDArray, NDArray]]) -> None:
        self.u = _Intervals([m[0] for m in members])
        self.v = _Intervals([m[1] for m in members])
        self.nets = np.concatenate([m[2] for m in members])
        sizes = np.array([len(m[2]) for m in members])
        self.first = np.cumsum(sizes) - sizes  # each spline's first cell

    def locate(
        self, which: NDArray, u: NDArray[np.float64], v: NDArray[np.float64] | None = None
    ) -> tuple[NDArray[np.intp], tuple[NDArray, NDArray], tuple[NDArray, NDArray]]:
        """Per point (u[i], v[i]) of spline ``which[i]``: its cell (a row of ``nets``: the
        knot intervals holding it, the end ones past the domain), its place (s, t) in the
        cell (0 to 1 inside) and the cell's sides along u and v.  Without ``v`` (curves: one
        v interval) t is 0 and the side 1."""
        iu, su, wu = self.u.locate(which, u)
        if v is None:
            iv, sv, wv = np.zeros_like(iu), np.zeros(len(u)), np.ones(len(u))
        else:
            iv, sv, wv = self.v.locate(which, v)
        return self.first[which] + iu * self.v.count[which] + iv, (su, sv), (wu, wv)


class _Group:
    """Splines of one degree pair (p, q): their Bézier cells (homogeneous, (n, p + 1, q + 1,
    4)), by spline, u interval and v interval."""

    def __init__(self, degree: tuple[int, int], members: list[tuple]) -> None:
        self.degree = degree
        self.table = CellTable(members)

    def evaluate(
        self, which: NDArray[np.intp], u: NDArray[np.float64], v: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        p, q = self.degree
        cell, (su, sv), (wu, wv) = self.table.locate(which, u, v if q else None)
        bu, du = bernstein_basis(p, su, 1)
        if q:
            bv, dv = bernstein_basis(q, sv, 1)
        else:
            bv, dv = np.ones((len(u), 1)), np.zeros((len(u), 1))
        net = self.table.nets[cell]  # (n, p+1, q+1, 4)
        row = np.einsum("na,nabc->nbc", bu, net)
        row_u = np.einsum("na,nabc->nbc", du, net)
        h = np.einsum("nb,nbc->nc", bv, row)
        hu = np.einsum("nb,nbc->nc", bv, row_u) / wu[:, None]
        hv = np.einsum("nb,nbc->nc", dv, row) / wv[:, None]
        w = h[:, 3:]
        x = h[:, :3] / w
        return x, (hu[:, :3] - x * hu[:, 3:]) / w, (hv[:, :3] - x * hv[:, 3:]) / w


class _Own:
    """A patch with too many knot intervals for a table of cells: its own evaluation."""

    def __init__(self, patch: BSplinePatch) -> None:
        self.patch = patch

    def evaluate(
        self, which: NDArray[np.intp], u: NDArray[np.float64], v: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        d = self.patch.derivatives_beyond(u, v, 1)
        return d[0, 0], d[1, 0], d[0, 1]


def to_bezier(
    knots: NDArray[np.float64], p: int, net: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The Bézier coefficients of a B-spline (control points ``net``, (n, ...)) on each of
    its knot intervals in the domain: the distinct knots (ends included) and (intervals,
    p + 1, ...), from its values at p + 1 Chebyshev points inside each interval (a
    polynomial of degree p there: exact to round-off); one clamped span ([a] * (p + 1) +
    [b] * (p + 1)) is its own Bézier cell, the net itself."""
    U = np.asarray(knots, dtype=np.float64)
    lo, hi = U[p], U[len(U) - p - 1]
    if one_clamped_span(U, p):
        return np.array([lo, hi]), np.asarray(net, dtype=np.float64)[None]
    breaks = np.unique(U[(U >= lo) & (U <= hi)])
    x = _INSIDE[p]
    t = (breaks[:-1, None] + np.diff(breaks)[:, None] * x).ravel()
    spans, values = basis_functions(U, p, t, 0)
    local = net[spans[:, None] - p + np.arange(p + 1)]  # (n points, p + 1, ...)
    at = np.einsum("na,na...->n...", values[0], local).reshape(
        len(breaks) - 1, p + 1, *net.shape[1:]
    )
    return breaks, np.einsum("ij,mj...->mi...", _FROM_INSIDE[p], at)


def tensor_cells(
    knots: tuple[NDArray, NDArray], degree: tuple[int, int], net: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The Bézier cells of a tensor-product B-spline (control net ``net``, (nu, nv, c),
    homogeneous if rational): its distinct knots along u and v (ends included) and its
    cells' nets (cells, p + 1, q + 1, c), u interval major (cell iu * (v intervals) + iv);
    by :func:`to_bezier` along v, then u."""
    (U, V), (p, q) = knots, degree
    vb, by_v = to_bezier(V, q, np.swapaxes(net, 0, 1))  # (v cells, q + 1, nu, c)
    ub, cells = to_bezier(U, p, np.moveaxis(by_v, 2, 0))  # (u cells, p + 1, v cells, ...)
    return ub, vb, np.moveaxis(cells, 2, 1).reshape(-1, p + 1, q + 1, net.shape[-1])


def few_cells(patch: BSplinePatch) -> bool:
    """Whether a B-spline patch has at most :data:`MAX_CELLS` knot intervals (u times v) in
    its domain: a table of cells holds it, a patch of more is evaluated on its own."""
    u, v = (np.unique(np.clip(k, *d)) for k, d in zip(patch.knots, patch.domain, strict=True))
    return (len(u) - 1) * (len(v) - 1) <= MAX_CELLS


#: Per degree p: p + 1 Chebyshev points inside (0, 1), and Bernstein coefficients from the
#: values there.
_INSIDE = [0.5 - 0.5 * np.cos(np.pi * (2 * np.arange(p + 1) + 1) / (2 * p + 2)) for p in range(33)]
_FROM_INSIDE = [np.linalg.inv(bernstein_basis(p, x)[0]) for p, x in enumerate(_INSIDE)]


class Splines:
    """Many rational B-spline patches and curves (a curve: a patch of v-degree 0) as their
    Bézier cells, grouped by degrees: points and first derivatives at many points of many
    of them in a few numpy calls, each end piece continued past its domain (as the kernel
    extrapolates)."""

    def __init__(self) -> None:
        self._pending: list[tuple[tuple, tuple]] = []
        self._groups: dict[tuple, _Group | _Own] = {}

    def _add(self, degree: tuple, member: tuple) -> int:
        self._pending.append((degree, member))
        return len(self._pending) - 1

    def add_patch(self, patch: BSplinePatch) -> int:
        """Add a patch; its number."""
        if not few_cells(patch):  # too many for a table: its own evaluation
            return self._add(("own", len(self._pending)), (patch.knots[0], patch))
        w = np.ones(patch.points.shape[:2]) if patch.weights is None else patch.weights
        net = np.concatenate([patch.points * w[..., None], w[..., None]], axis=-1)
        return self._add(patch.degree, tensor_cells(patch.knots, patch.degree, net))

    def add_curve(self, curve: Any) -> int:
        """Add a kernel ``Geom_BSplineCurve``; its number."""
        n, p = int(curve.NbPoles()), int(curve.Degree())
        flat = curve.KnotSequence()
        knots = np.array([flat.Value(i) for i in range(flat.Lower(), flat.Upper() + 1)])
        poles = np.array([[q.X(), q.Y(), q.Z()] for q in (curve.Pole(i) for i in range(1, n + 1))])
        w = np.array([curve.Weight(i) for i in range(1, n + 1)])
        bu, cells = to_bezier(knots, p, np.hstack([poles * w[:, None], w[:, None]]))
        return self._add((p, 0), (bu, np.array([0.0, 1.0]), cells[:, :, None, :]))

    def breaks(self, number: int) -> NDArray[np.float64]:
        """The distinct knots (u) of a spline, its ends included."""
        return self._pending[number][1][0]

    def freeze(self) -> None:
        """Gather the splines added into their groups (before ``evaluate``)."""
        by_degree: dict[tuple, list[int]] = {}
        for k, (degree, _) in enumerate(self._pending):
            by_degree.setdefault(degree, []).append(k)
        self._group_of = np.empty(len(self._pending), dtype=np.intp)
        self._local = np.empty(len(self._pending), dtype=np.intp)
        self._order = list(by_degree)
        for g, (degree, members) in enumerate(by_degree.items()):
            if degree[0] == "own":
                self._groups[degree] = _Own(self._pending[members[0]][1][1])
            else:
                self._groups[degree] = _Group(degree, [self._pending[k][1] for k in members])
            self._group_of[members] = g
            self._local[members] = np.arange(len(members))

    def evaluate(
        self, which: NDArray[np.intp], u: NDArray[np.float64], v: NDArray[np.float64] | None = None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """S, S_u, S_v (each (n, 3)) of spline ``which[i]`` at (u[i], v[i]) (curves: at
        u[i], S_v zero)."""
        v = np.zeros_like(u) if v is None else v
        out = [np.empty((len(u), 3)) for _ in range(3)]
        group = self._group_of[which]
        for g in np.unique(group):
            rows = np.flatnonzero(group == g)
            parts = self._groups[self._order[g]].evaluate(
                self._local[which[rows]], u[rows], v[rows]
            )
            for o, part in zip(out, parts, strict=True):
                o[rows] = part
        return out[0], out[1], out[2]
