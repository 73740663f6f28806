"""Many patches on one grid at once: Bézier cells of one degree share a basis.

A surface of thousands of bicubic patches (a CAD sheet, a subdivision surface's regular faces, a
CAD model's planes and one-span faces) is one array of control nets. :func:`grid_derivatives`
evaluates every patch on the same grid of normalised parameters with two matrix products per
derivative and group of patches that are one Bézier cell over their domain
(:func:`bezier_groups`: Bézier patches, and B-spline patches of one clamped knot span each way,
whose B-spline basis is the Bernstein basis there) of equal degree and kind — the Bernstein
bases on the grid times all their (homogeneous) nets, rational ones then projected by the
quotient rule (:func:`gshade.geometry.core.rational.project_patch_derivatives`) — instead of one
call per patch; every other patch is evaluated by its own ``derivatives``.  Both give the same
numbers up to round-off (tested).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np
from numpy.typing import NDArray

from ..core.bernstein import bernstein_basis
from ..core.blas_threads import single_threaded_blas
from ..core.knots import one_clamped_span
from ..core.patch import Patch, TensorProductPatch, homogeneous, unit_to_domain, validate_order
from ..core.rational import project_patch_derivatives
from ..patches.bezier import BezierPatch
from ..patches.bspline import BSplinePatch
from .spline_batches import ALONE_FROM, batch_derivatives

__all__ = ["bezier_groups", "domain_spans", "grid_derivatives", "patch_grid"]

#: Patches per matrix product (bounds the temporary arrays).
_CHUNK = 4096


def domain_spans(patches: Sequence[Patch]) -> NDArray[np.float64]:
    """(u1 - u0, v1 - v0) of each patch's domain: shape (len(patches), 2)."""
    domains = np.array([p.domain for p in patches], dtype=np.float64).reshape(-1, 2, 2)
    return domains[:, :, 1] - domains[:, :, 0]


def patch_grid(patch: Patch, s: NDArray, t: NDArray | None = None) -> tuple[NDArray, NDArray]:
    """The grid u = u0 + (u1 - u0) s, v = v0 + (v1 - v0) t (t = s unless given), shaped for
    the grid algorithm."""
    u, v = unit_to_domain(patch.domain, s, s if t is None else t)
    return u[:, None], v[None, :]


def bezier_groups(
    patches: Sequence[Patch],
) -> tuple[dict[tuple[int, int, bool], list[int]], list[int]]:
    """The indices of the patches that are one Bézier cell over their domain, by degree and
    whether they are rational ((m, n, rational)), and of all other patches."""
    groups: dict[tuple[int, int, bool], list[int]] = {}
    others = []
    for k, patch in enumerate(patches):
        if type(patch) is BezierPatch or (type(patch) is BSplinePatch and _one_cell(patch)):
            groups.setdefault((*patch.degree, patch.rational), []).append(k)
        else:
            others.append(k)
    return groups, others


def _one_cell(patch: BSplinePatch) -> bool:
    """Whether a B-spline patch is one Bézier cell: one clamped knot span each way."""
    return all(one_clamped_span(k, p) for k, p in zip(patch.knots, patch.degree, strict=True))


@single_threaded_blas
def grid_derivatives(
    patches: list[Patch] | tuple[Patch, ...], s: NDArray, order: int = 0, t: NDArray | None = None
) -> NDArray[np.float64]:
    """Derivatives of every patch on the grid s x t (t = s unless given) of its normalised
    parameters.

    Parameters
    ----------
    patches : sequence of Patch
    s : ndarray, shape (n,)
        Normalised parameters in [0, 1]: patch k is evaluated at
        u = u0 + (u1 - u0) s_a, v = v0 + (v1 - v0) s_b.
    order : int
        Highest total derivative order (derivatives in u and v, not in s).
    t : ndarray, shape (m,), optional
        The normalised parameters along v (default: ``s``).

    Returns
    -------
    ndarray, shape (len(patches), order + 1, order + 1, n, m, 3)
        Entry ``[k, i, j, a, b]`` is d^(i+j)p_k / du^i dv^j at (s_a, t_b); zero for
        i + j > order.  A view of an array stored derivative- and component-major,
        (order + 1, order + 1, 3, len(patches), n, m): in ``np.moveaxis(result, 0, 2)``
        each component of each derivative is one contiguous block, the layout the shape
        functions read (as a patch's own ``derivatives`` on a grid gives it).
    """
    order = validate_order(order)
    s = np.asarray(s, dtype=np.float64).ravel()
    t = s if t is None else np.asarray(t, dtype=np.float64).ravel()
    store = np.zeros((order + 1, order + 1, 3, len(patches), s.size, t.size))
    out = np.moveaxis(store, 2, -1)  # (order + 1, order + 1, patches, n, m, 3)
    groups, others = bezier_groups(patches)
    if s.size * t.size < ALONE_FROM:  # small grids: the B-splines' points at once
        owner = np.repeat(np.asarray(others, dtype=np.int64), s.size * t.size)
        st = np.stack(np.meshgrid(s, t, indexing="ij"), -1).reshape(-1, 2)
        lo = np.array([[p.domain[0][0], p.domain[1][0]] for p in patches]).reshape(-1, 2)
        hi = np.array([[p.domain[0][1], p.domain[1][1]] for p in patches]).reshape(-1, 2)
        uv = lo[owner] + (hi[owner] - lo[owner]) * np.tile(st, (len(others), 1))
        d = batch_derivatives(patches, owner, uv[:, 0], uv[:, 1], order)
        out[:, :, others] = d.reshape(order + 1, order + 1, len(others), s.size, t.size, 3)
        others = []
    for k in others:
        out[:, :, k] = patches[k].derivatives(*patch_grid(patches[k], s, t), order)
    for (m, mv, rational), members in groups.items():
        Bu = bernstein_basis(m, s, order)  # (o+1, n, m+1), derivatives in s
        BvT = np.ascontiguousarray(bernstein_basis(mv, t, order).transpose(0, 2, 1))
        for start in range(0, len(members), _CHUNK):
            chunk = members[start : start + _CHUNK]
            cells = [cast(TensorProductPatch, patches[k]) for k in chunk]  # one cell each
            nets = np.stack([homogeneous(p.points, p.weights) for p in cells])  # (G, m+1, n+1, c)
            G, c = len(chunk), nets.shape[-1]
            nets = np.ascontiguousarray(nets.transpose(0, 3, 1, 2))  # (G, c, m+1, n+1)
            span = domain_spans(cells)
            # rational: (w p, w) and their derivatives first, component-major
            h = np.zeros((order + 1, order + 1, c, G, s.size, t.size)) if rational else None
            for i in range(order + 1):
                rows = np.matmul(Bu[i], nets)  # (G, c, s.size, mv + 1)
                for j in range(order + 1 - i):
                    # one product for all cells: (G c s.size, mv + 1) x (mv + 1, t.size)
                    value = (rows.reshape(-1, mv + 1) @ BvT[j]).reshape(G, c, s.size, t.size)
                    # d/du = d/ds / (u1 - u0): the chain rule per patch
                    value *= (span[:, 0] ** -float(i) * span[:, 1] ** -float(j))[
                        :, None, None, None
                    ]
                    if h is None:
                        store[i, j][:, chunk] = value.transpose(1, 0, 2, 3)
                    else:
                        h[i, j] = value.transpose(1, 0, 2, 3)
            if h is not None:
                project_patch_derivatives(h[:, :, :3], h[:, :, 3], order)
                store[:, :, :, chunk] = h[:, :, :3]
    return np.moveaxis(out, 2, 0)
