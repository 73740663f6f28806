"""Exact ray–surface hits: where the ray through each pixel centre meets the exact patch.

The render's centre pass gives, per pixel, the patch and its parameters from one float32
Newton step on the Hermite-interpolated surface (about 1e-6 relative).  One more Newton step
on p(u, v) - o - t d = 0 in float64, on the exact patch, reaches round-off:
[p_u p_v -d] (du, dv, dt) = o + t d - p, solved by Cramer's rule
(:func:`gshade.rendering.newton.newton_step`).  Points whose step does not settle (a
silhouette pixel whose centre ray misses the patch) keep their start values.

The same step runs two ways: polynomial Bézier patches of one degree all at once in one
Dr.Jit float64 kernel (their control points gathered per point, the Bernstein bases in closed
form), every other patch by numpy: B-spline patches of one degree all at once
(:func:`gshade.geometry.spline_batches.batch_derivatives`), the rest through their own
``derivatives``.  They agree to round-off
(tested); the kernel saves the per-patch work (benchmarks/bench_render.py measures it).
"""

from __future__ import annotations

from math import comb
from typing import cast

import numpy as np
from numpy.typing import NDArray

from ..geometry import BezierPatch, Patch
from ..geometry.patch_groups import bezier_groups, domain_spans
from ..geometry.spline_batches import batch_derivatives
from ..runtime.backend import NUMPY, drjit_ops
from ..runtime.drjit_arrays import drjit_array
from ..shape.kernels import backend
from .newton import newton_step, ray_residual

__all__ = ["surface_hits"]

#: A Newton step has settled when |p - o - t d| <= SETTLED * |p - o|.
SETTLED = 1e-7
#: Rays this close to the tangent plane (|det [p_u p_v -d]| at most this) take no step.
TINY = 1e-300


def _newton_numpy(derivatives, lo, hi, u, v, origin, direction, steps: int = 1):
    """``steps`` float64 Newton steps on points of patches evaluated by ``derivatives(u, v)``
    (derivatives of order <= 1, (2, 2, N, 3)), each point's parameters kept within
    [lo, hi] (N, 2); returns (u, v, derivatives (2, 2, N, 3), settled)."""
    start = d = derivatives(u, v)
    scale = np.linalg.norm(d[0, 0] - origin, axis=1)
    uu, vv = u, v
    for step in range(steps):
        if step:
            d = derivatives(uu, vv)
        t, r = ray_residual(d[0, 0], origin, direction, NUMPY)
        du, dv, dt, _ = newton_step(d[1, 0], d[0, 1], direction, r, NUMPY, TINY)
        uu = np.clip(uu + du, lo[:, 0], hi[:, 0])
        vv = np.clip(vv + dv, lo[:, 1], hi[:, 1])
        t = t + dt
    d = derivatives(uu, vv)
    residual = np.linalg.norm(d[0, 0] - origin - t[:, None] * direction, axis=1)
    settled = residual <= SETTLED * np.maximum(scale, 1e-300)
    if not settled.all():  # those keep their start values and derivatives
        d[:, :, ~settled] = start[:, :, ~settled]
    return np.where(settled, uu, u), np.where(settled, vv, v), d, settled


def _bernstein(degree: int, s):
    """Values and first derivatives of the Bernstein basis at s (Dr.Jit arrays)."""
    one = 1.0 - s
    powers_s, powers_1 = [1.0], [1.0]
    for _ in range(degree):
        powers_s.append(powers_s[-1] * s)
        powers_1.append(powers_1[-1] * one)

    def basis(n, i):
        return comb(n, i) * powers_s[i] * powers_1[n - i] if 0 <= i <= n else 0.0

    values = [basis(degree, i) for i in range(degree + 1)]
    slopes = [degree * (basis(degree - 1, i - 1) - basis(degree - 1, i)) for i in range(degree + 1)]
    return values, slopes


def _newton_bezier_drjit(patches: list[BezierPatch], local, u, v, origin, direction):
    """One float64 Newton step on many polynomial Bézier patches of one degree at once.

    ``local`` (N,) indexes ``patches``; returns what :func:`_newton_numpy` does."""
    import drjit as dr
    from drjit.llvm import Array3f64, Float64, UInt32

    ops = drjit_ops(fused=False)  # products written out, as the numpy path's
    m, n = patches[0].degree
    stride = (m + 1) * (n + 1) * 3
    nets = drjit_array(Float64, np.concatenate([p.points.ravel() for p in patches]))
    lo = np.array([[p.domain[0][0], p.domain[1][0]] for p in patches])
    span = domain_spans(patches)
    base = drjit_array(UInt32, local * stride, np.uint32)
    su, sv = drjit_array(Float64, span[local, 0]), drjit_array(Float64, span[local, 1])
    ou, ov = drjit_array(Float64, lo[local, 0]), drjit_array(Float64, lo[local, 1])
    o = Array3f64(*(drjit_array(Float64, origin[:, c]) for c in range(3)))
    w = Array3f64(*(drjit_array(Float64, direction[:, c]) for c in range(3)))
    u0, v0 = drjit_array(Float64, u), drjit_array(Float64, v)

    def evaluate(uu, vv):
        """p, p_u, p_v at (uu, vv)."""
        bu, du = _bernstein(m, (uu - ou) / su)
        bv, dv = _bernstein(n, (vv - ov) / sv)
        p, pu, pv = [0.0] * 3, [0.0] * 3, [0.0] * 3
        for i in range(m + 1):
            for j in range(n + 1):
                for c in range(3):
                    x = dr.gather(Float64, nets, base + 3 * (i * (n + 1) + j) + c)
                    p[c] = p[c] + (bu[i] * bv[j]) * x
                    pu[c] = pu[c] + (du[i] * bv[j]) * x
                    pv[c] = pv[c] + (bu[i] * dv[j]) * x
        return Array3f64(*p), Array3f64(*(x / su for x in pu)), Array3f64(*(x / sv for x in pv))

    p, pu, pv = evaluate(u0, v0)
    t, r = ray_residual(p, o, w, ops)
    scale = dr.sqrt(ops.dot(p - o, p - o))
    du, dv, dt, _ = newton_step(pu, pv, w, r, ops, TINY)

    def clamp(x, a, b):
        return dr.select(x < a, a, dr.select(x > b, b, x))

    u1 = clamp(u0 + du, ou, ou + su)
    v1 = clamp(v0 + dv, ov, ov + sv)
    t = t + dt
    p1, pu1, pv1 = evaluate(u1, v1)
    res = p1 - o - t * w
    settled = dr.sqrt(ops.dot(res, res)) <= SETTLED * scale
    # unsettled points keep their start values
    out = [
        dr.select(settled, a, b)
        for a, b in zip([u1, v1, *p1, *pu1, *pv1], [u0, v0, *p, *pu, *pv], strict=True)
    ]
    dr.eval(*out, settled)
    out = [np.array(x) for x in out]
    d = np.zeros((2, 2, u.size, 3))
    d[0, 0] = np.stack(out[2:5], -1)
    d[1, 0] = np.stack(out[5:8], -1)
    d[0, 1] = np.stack(out[8:11], -1)
    return out[0], out[1], d, np.array(settled, dtype=bool)


def surface_hits(
    patches: list[Patch] | tuple[Patch, ...],
    index: NDArray,
    u: NDArray,
    v: NDArray,
    origin: NDArray,
    direction: NDArray,
    backend_name: str = "auto",
    steps: int = 1,
) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """One exact Newton step for each ray (origin, direction) from (u, v) on patch index
    (``steps`` of them, through numpy, for starts farther away).

    Returns the parameters (u, v) (N,), the derivatives of order <= 1 there (2, 2, N, 3) and
    whether the step settled (N,); unsettled points keep their start parameters.
    ``backend_name``: "auto" (Dr.Jit for polynomial Bézier patches where it works), "drjit"
    or "numpy" (every patch through its ``derivatives``).
    """
    index = np.asarray(index, dtype=np.int64)
    N = index.size
    u_out, v_out = np.asarray(u, dtype=np.float64).copy(), np.asarray(v, dtype=np.float64).copy()
    d = np.zeros((2, 2, N, 3))
    settled = np.zeros(N, dtype=bool)
    origin = np.broadcast_to(origin, (N, 3))
    direction = np.broadcast_to(direction, (N, 3))
    groups, others = bezier_groups(patches)
    if backend(backend_name) != "drjit" or steps != 1:
        groups, others = {}, list(range(len(patches)))
    for members in groups.values():
        lookup = np.full(len(patches), -1, dtype=np.int64)
        lookup[members] = np.arange(len(members))
        sel = np.flatnonzero(lookup[index] >= 0)
        if sel.size:
            result = _newton_bezier_drjit(
                [cast(BezierPatch, patches[k]) for k in members],  # bezier_groups' members
                lookup[index[sel]],
                u_out[sel],
                v_out[sel],
                origin[sel],
                direction[sel],
            )
            u_out[sel], v_out[sel], d[:, :, sel], settled[sel] = result
    if others:  # every other patch's points at once (B-splines batched by degree)
        sel = np.flatnonzero(np.isin(index, others))
        if sel.size:
            on = index[sel]
            domains = np.array([p.domain for p in patches], dtype=np.float64)[on]
            lo, hi = domains[:, :, 0], domains[:, :, 1]

            def derivatives(uu, vv):
                return batch_derivatives(patches, on, uu, vv, 1)

            result = _newton_numpy(
                derivatives, lo, hi, u_out[sel], v_out[sel], origin[sel], direction[sel], steps
            )
            u_out[sel], v_out[sel], d[:, :, sel], settled[sel] = result
    return u_out, v_out, d, settled
