"""The Newton step that puts a point of a ray onto the surface, written once.

On the ray o + t d, the point of the surface p(u, v) satisfies p(u, v) - o - t d = 0.  From
(u, v), one Newton step solves the linear system

    [p_u  p_v  -d] (du, dv, dt) = r,   r = (a point of the ray) - p(u, v),

by Cramer's rule.  Three places take it, each with its own array library and precision
(:class:`gshade.runtime.backend.ArrayOps`): the integrator (float32 Dr.Jit, from the mesh hit,
with p and its derivatives interpolated from the atlas), and the exact surface hits
(float64: numpy through a patch's own derivatives, Dr.Jit for polynomial Bézier patches).
The operations and their order are the same in all of them; the dot and cross products are
those of each caller's ``ops``.
"""

from __future__ import annotations

from typing import Any

from ..runtime.backend import ArrayOps

__all__ = ["newton_step", "ray_residual"]


def ray_residual(p: Any, origin: Any, direction: Any, ops: ArrayOps) -> tuple[Any, Any]:
    """The ray parameter t = <p - o, d> of p's projection onto the ray (d a unit vector) and
    the residual r = o + t d - p."""
    t = ops.dot(p - origin, direction)
    return t, origin + ops.scale(t, direction) - p


def newton_step(
    pu: Any, pv: Any, direction: Any, r: Any, ops: ArrayOps, tiny: float, with_t: bool = True
) -> tuple[Any, Any, Any, Any]:
    """One Newton step onto the ray: (du, dv, dt) solving [p_u p_v -d] (du, dv, dt) = r.

    Cramer's rule with c = -d: det = <p_u, p_v x c>, du = <r, p_v x c> / det,
    dv = <p_u, r x c> / det, dt = <p_u, p_v x r> / det.  Returns (du, dv, dt, solvable):
    where |det| <= ``tiny`` (the ray grazes the surface) the steps are 0 and ``solvable`` is
    false; dt is None unless ``with_t``.
    """
    c = -direction
    pv_c = ops.cross(pv, c)
    det = ops.dot(pu, pv_c)
    solvable = ops.abs(det) > tiny
    inv = ops.select(solvable, 1.0 / ops.select(solvable, det, 1.0), 0.0)
    du = ops.dot(r, pv_c) * inv
    dv = ops.dot(pu, ops.cross(r, c)) * inv
    dt = ops.dot(pu, ops.cross(pv, r)) * inv if with_t else None
    return du, dv, dt, solvable
