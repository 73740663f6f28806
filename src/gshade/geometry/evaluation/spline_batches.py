"""Many B-spline patches evaluated at once: points on different patches of one degree in one
set of array operations.

A CAD model is hundreds of NURBS faces, and an image's pixels fall on all of them.  Evaluating
face by face costs a few dozen small numpy operations per face and call, whatever the number
of points; here the points of all faces of one degree (p, q) and kind (polynomial or
rational) share them: the knot vectors and control nets are laid end to end, each point's
knot spans are found in its own face's knots (Piegl & Tiller, A2.1) and offset into the joint
vector, the basis functions and their derivatives come from one Cox–de Boor recursion (A2.3,
:func:`gshade.geometry.core.knots.basis_functions_in_spans`), and each point's (p + 1) x (q + 1)
control points are gathered from the joint net.  The result equals each patch's own
``derivatives`` up to round-off (tested).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np
from numpy.typing import NDArray

from ..core.knots import basis_functions_in_spans, find_spans
from ..core.patch import Patch, validate_order
from ..core.rational import project_patch_derivatives
from ..patches.bspline import BSplinePatch

__all__ = ["ALONE_FROM", "SplineBatch", "batch_derivatives"]


class SplineBatch:
    """B-spline patches of one degree and kind, laid end to end for :meth:`derivatives`."""

    def __init__(self, patches: Sequence[BSplinePatch]) -> None:
        first = patches[0]
        self.degree = first.degree
        self.rational = first.rational
        if any(p.degree != self.degree or p.rational != self.rational for p in patches):
            raise ValueError("SplineBatch: patches of one degree and kind only")
        self.patches = list(patches)
        U = [np.asarray(p.knots[0], dtype=np.float64) for p in patches]
        V = [np.asarray(p.knots[1], dtype=np.float64) for p in patches]
        nets = [p._net for p in patches]  # homogeneous (nu, nv, c)
        self.knots_u, self.knots_v = np.concatenate(U), np.concatenate(V)
        self.start_u = np.cumsum([0] + [len(k) for k in U[:-1]])
        self.start_v = np.cumsum([0] + [len(k) for k in V[:-1]])
        self.net = np.concatenate([n.reshape(-1, n.shape[-1]) for n in nets])
        self.start_net = np.cumsum([0] + [n.shape[0] * n.shape[1] for n in nets[:-1]])
        self.columns = np.array([n.shape[1] for n in nets])
        self.lo = np.array([[p.domain[0][0], p.domain[1][0]] for p in patches])
        self.hi = np.array([[p.domain[0][1], p.domain[1][1]] for p in patches])

    def derivatives(
        self, member: NDArray, u: NDArray, v: NDArray, order: int, beyond: bool = False
    ) -> NDArray:
        """Derivatives up to total order ``order`` of patch ``member[i]`` (its place in the
        batch) at (u[i], v[i]), clipped into its domain (with ``beyond``, not clipped: past
        the domain the end pieces continued, as
        :meth:`gshade.geometry.BSplinePatch.derivatives_beyond`): shape
        (order + 1, order + 1, N, 3), zero for i + j > order."""
        order = validate_order(order)
        member = np.asarray(member, dtype=np.int64)
        u = np.asarray(u, dtype=np.float64)
        v = np.asarray(v, dtype=np.float64)
        if not beyond:
            u = np.clip(u, self.lo[member, 0], self.hi[member, 0])
            v = np.clip(v, self.lo[member, 1], self.hi[member, 1])
        p, q = self.degree
        su = np.empty(u.size, dtype=np.int64)
        sv = np.empty(v.size, dtype=np.int64)
        by_member = np.argsort(member, kind="stable")
        bounds = np.flatnonzero(np.diff(member[by_member])) + 1
        for mine in np.split(by_member, bounds):  # each point's spans in its own knots
            if not mine.size:
                continue
            k = int(member[mine[0]])
            patch = self.patches[k]
            su[mine] = find_spans(patch.knots[0], p, u[mine]) + self.start_u[k]
            sv[mine] = find_spans(patch.knots[1], q, v[mine]) + self.start_v[k]
        out = np.empty((order + 1, order + 1, u.size, 3))
        for start in range(0, u.size, _CHUNK):  # bounded temporaries
            sl = slice(start, start + _CHUNK)
            out[:, :, sl] = self._chunk(member[sl], u[sl], v[sl], su[sl], sv[sl], order)
        return out

    def _chunk(
        self, member: NDArray, u: NDArray, v: NDArray, su: NDArray, sv: NDArray, order: int
    ) -> NDArray:
        p, q = self.degree
        Bu = basis_functions_in_spans(self.knots_u, p, u, su, order)  # (o+1, N, p+1)
        Bv = basis_functions_in_spans(self.knots_v, q, v, sv, order)
        rows = su - self.start_u[member] - p  # the first control point's row and column
        cols = sv - self.start_v[member] - q
        first = self.start_net[member] + rows * self.columns[member] + cols
        at = (
            first[:, None, None]
            + np.arange(p + 1)[None, :, None] * self.columns[member, None, None]
            + np.arange(q + 1)[None, None, :]
        )
        local = self.net[at]  # (N, p+1, q+1, c)
        c = local.shape[-1]
        buf = np.zeros((order + 1, order + 1, c, u.size))
        BvT = Bv.transpose(0, 2, 1)  # (o+1, q+1, N)
        for i in range(order + 1):
            # rows[b] = sum_a Bu[i][:, a] P[a, b]: (q+1, c, N), the point axis last
            rows = np.einsum("na,nabc->bcn", Bu[i], local)
            for j in range(order + 1 - i):
                total = buf[i, j]
                for b in range(q + 1):  # a few fused sweeps (as BSplinePatch evaluates)
                    total += rows[b] * BvT[j, b]
        if self.rational:
            buf = project_patch_derivatives(buf[:, :, :3], buf[:, :, 3], order)
        return np.moveaxis(buf, 2, -1)


def batch_derivatives(
    patches: Sequence[Patch],
    index: NDArray,
    u: NDArray,
    v: NDArray,
    order: int = 0,
    beyond: bool = False,
) -> NDArray[np.float64]:
    """Derivatives of patch ``index[i]`` at (u[i], v[i]) for points on many patches: the
    B-spline patches with fewer than :data:`ALONE_FROM` points by batches of one degree and
    kind (:class:`SplineBatch`), any other patch through its own ``derivatives``.  Shape
    (order + 1, order + 1, N, 3).  With ``beyond``, B-spline patches are evaluated past their
    domains too, their end pieces continued (``derivatives_beyond``).

    Examples
    --------
    >>> import numpy as np
    >>> from gshade.geometry import BSplinePatch
    >>> rng = np.random.default_rng(1)
    >>> knots = ([0, 0, 0, 0.4, 1, 1, 1], [0, 0, 1, 1])
    >>> a = BSplinePatch(rng.normal(size=(4, 2, 3)), (2, 1), knots)
    >>> b = BSplinePatch(rng.normal(size=(4, 2, 3)), (2, 1), knots)
    >>> index, u, v = np.array([0, 1, 1]), np.array([0.1, 0.5, 0.9]), np.array([0.3, 0.2, 1.0])
    >>> d = batch_derivatives([a, b], index, u, v, 1)
    >>> bool(np.allclose(d[1, 0, 1], b.derivatives(0.5, 0.2, 1)[1, 0]))
    True
    """
    index = np.asarray(index, dtype=np.int64)
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    order = validate_order(order)
    out = np.zeros((order + 1, order + 1, index.size, 3))
    groups: dict[tuple, list[int]] = {}
    by_patch = np.argsort(index, kind="stable")
    for at in np.split(by_patch, np.flatnonzero(np.diff(index[by_patch])) + 1):
        if not at.size:
            continue
        k = int(index[at[0]])
        patch = patches[k]
        if type(patch) is BSplinePatch and at.size < ALONE_FROM:
            groups.setdefault((patch.degree, patch.rational), []).append(k)
        elif beyond and isinstance(patch, BSplinePatch):
            out[:, :, at] = patch.derivatives_beyond(u[at], v[at], order)
        else:
            out[:, :, at] = patch.derivatives(u[at], v[at], order)
    for members in groups.values():
        batch = SplineBatch([cast(BSplinePatch, patches[k]) for k in members])  # grouped by type
        place = np.full(len(patches), -1, dtype=np.int64)
        place[members] = np.arange(len(members))
        at = np.flatnonzero(place[index] >= 0)
        out[:, :, at] = batch.derivatives(place[index[at]], u[at], v[at], order, beyond)
    return out


#: Points per batched evaluation.
_CHUNK = 1 << 15
#: A patch with this many points or more is evaluated on its own: then its own evaluation
#: (no gather for a one-span patch, the call's overhead spread over its points) is the
#: faster (benchmarks/RESULTS.md, "Measurements behind code choices").
ALONE_FROM = 100
