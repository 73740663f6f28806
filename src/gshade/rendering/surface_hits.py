"""Exact ray–surface hits: where the ray through each pixel centre meets the exact patch.

The render's centre pass gives, per pixel, the patch and its parameters from one float32
Newton step on the Hermite-interpolated surface (about 1e-6 relative).  One more Newton step
on p(u, v) - o - t d = 0 in float64, on the exact patch, reaches round-off:
[p_u p_v -d] (du, dv, dt) = o + t d - p, solved by Cramer's rule
(:func:`gshade.rendering.newton.newton_step`).  Points whose step does not settle (a
silhouette pixel whose centre ray misses the patch) keep their start values.

The step runs on numpy arrays; the patches' points and first derivatives come two ways:
Bézier and B-spline patches of one degree and kind all at once from one Dr.Jit kernel over
their Bézier cells (:class:`gshade.geometry.evaluation.patch_cells.PatchCells`), every other
patch (and every patch with ``backend_name="numpy"``) by numpy
(:func:`gshade.geometry.evaluation.spline_batches.batch_derivatives`).  They agree to round-off
(tested); the kernel saves the gathers' memory traffic (benchmarks/bench_render.py measures
it).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from ..geometry import Patch
from ..geometry.evaluation.patch_cells import ManyPatches
from ..runtime.backend import NUMPY
from ..shape.kernels import backend
from .newton import newton_step, ray_residual

__all__ = ["patch_evaluator", "surface_hits"]

#: A Newton step has settled when |p - o - t d| <= SETTLED * |p - o|.
SETTLED = 1e-7
#: Rays this close to the tangent plane (|det [p_u p_v -d]| at most this) take no step.
TINY = 1e-300


def _newton_numpy(
    derivatives: Callable[[NDArray, NDArray, int, slice | NDArray], NDArray],
    lo: NDArray,
    hi: NDArray,
    u: NDArray,
    v: NDArray,
    origin: NDArray,
    direction: NDArray,
    steps: int = 1,
    order: int = 1,
) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """``steps`` float64 Newton steps on points of patches evaluated by
    ``derivatives(u, v, order, at)`` (derivatives of order <= ``order`` at the points
    ``at``, (order + 1, order + 1, N, 3)), each point's parameters kept within [lo, hi]
    (N, 2); returns (u, v, derivatives of order <= ``order`` there, settled)."""
    every = slice(None)
    start = d = derivatives(u, v, 1, every)
    scale = np.linalg.norm(d[0, 0] - origin, axis=1)
    uu, vv = u, v
    for step in range(steps):
        if step:
            d = derivatives(uu, vv, 1, every)
        t, r = ray_residual(d[0, 0], origin, direction, NUMPY)
        du, dv, dt, _ = newton_step(d[1, 0], d[0, 1], direction, r, NUMPY, TINY)
        uu = np.clip(uu + du, lo[:, 0], hi[:, 0])
        vv = np.clip(vv + dv, lo[:, 1], hi[:, 1])
        t = t + dt
    d = derivatives(uu, vv, order, every)
    residual = np.linalg.norm(d[0, 0] - origin - t[:, None] * direction, axis=1)
    settled = residual <= SETTLED * np.maximum(scale, 1e-300)
    if not settled.all():  # those keep their start values and derivatives
        back = np.flatnonzero(~settled)
        d[:, :, back] = (
            start[:, :, back] if order == 1 else derivatives(u[back], v[back], order, back)
        )
    return np.where(settled, uu, u), np.where(settled, vv, v), d, settled


def patch_evaluator(
    patches: list[Patch] | tuple[Patch, ...], backend_name: str = "auto"
) -> ManyPatches:
    """The patches' derivatives at scattered points as :func:`surface_hits` evaluates them
    (Dr.Jit for Bézier and B-spline patches, ``backend_name`` as there): built once for the
    calls on one set of patches (grouping a CAD model's faces into their cells costs about
    as much as a block of steps)."""
    return ManyPatches(patches, drjit=backend(backend_name) == "drjit")


def surface_hits(
    patches: list[Patch] | tuple[Patch, ...],
    index: NDArray,
    u: NDArray,
    v: NDArray,
    origin: NDArray,
    direction: NDArray,
    backend_name: str = "auto",
    steps: int = 1,
    order: int = 1,
    evaluator: ManyPatches | None = None,
) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """One exact Newton step for each ray (origin, direction) from (u, v) on patch index
    (``steps`` of them, for starts farther away).

    Returns the parameters (u, v) (N,), the derivatives of order <= ``order`` (at least 1)
    there (order + 1, order + 1, N, 3) and whether the step settled (N,); unsettled points
    keep their start parameters.
    ``backend_name``: "auto" (Dr.Jit for Bézier and B-spline patches where it works),
    "drjit" or "numpy" (every patch by numpy); ``evaluator``: :func:`patch_evaluator` of
    the same patches and backend, where the caller keeps one across calls.
    """
    index = np.asarray(index, dtype=np.int64)
    N = index.size
    u_out, v_out = np.asarray(u, dtype=np.float64).copy(), np.asarray(v, dtype=np.float64).copy()
    d = np.zeros((order + 1, order + 1, N, 3))
    settled = np.zeros(N, dtype=bool)
    origin = np.broadcast_to(origin, (N, 3))
    direction = np.broadcast_to(direction, (N, 3))
    if N:
        many = evaluator or patch_evaluator(patches, backend_name)
        domains = np.array([p.domain for p in patches], dtype=np.float64)[index]

        def derivatives(uu: NDArray, vv: NDArray, k: int, at: slice | NDArray) -> NDArray:
            return many.derivatives(index[at], uu, vv, k)

        lo, hi = domains[:, :, 0], domains[:, :, 1]
        u_out, v_out, d, settled = _newton_numpy(
            derivatives, lo, hi, u_out, v_out, origin, direction, steps, max(1, order)
        )
    return u_out, v_out, d, settled
