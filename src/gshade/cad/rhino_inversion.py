"""Points of a Rhino face's trims pulled back into its NURBS form's (u, v), by point
inversion (:mod:`gshade.cad.rhino` recovers the trimming loops with it: the Python bindings
expose no 2D trimming curves).

Starting points come from a grid whose density follows the control net (:class:`Grid`: a
grid uniform in (u, v) misses short knot spans where the surface moves fast, and then Newton
lands on a nearby sheet, the other wall of a mug); a damped Gauss-Newton runs over all the
points of a face at once; points left far from the surface are tried again from their
neighbours' parameters along the loop (:func:`pull_back`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..geometry.patches.bspline import BSplinePatch
from . import rhino_seams as seams

__all__ = ["Grid", "pull_back"]

_GRID, _GRID_MAX, _GRID_PIECES = 48, 200, 8
_NEWTON_STEPS = 40
_RETRIES, _RETRY_RATIO, _RETRY_FLOOR = 400, 100.0, 1e-5


def _grid_parameters(patch: BSplinePatch, d: int, lo: float, hi: float) -> NDArray[np.float64]:
    """Starting parameters over [lo, hi] in direction ``d``: between consecutive Greville
    abscissae, as many as the control polygon's length there asks for (``_GRID`` per size of
    the surface): a uniform grid misses short spans where the surface moves fast, and then
    the nearest grid point may lie on another sheet (the inner wall of a mug)."""
    p = patch.degree[d]
    U = patch.knots[d]
    P = np.moveaxis(patch.points, d, 0)
    n = P.shape[0]
    g = np.array([U[i + 1 : i + p + 1].mean() for i in range(n)]) if p else U[:n]
    chord = np.linalg.norm(np.diff(P, axis=0), axis=-1).max(axis=-1)
    scale = float(np.ptp(P.reshape(-1, 3), axis=0).max()) or 1.0
    pieces = np.clip(np.ceil(chord * _GRID / scale), 1, _GRID_PIECES).astype(np.intp)
    t = np.concatenate(
        [np.linspace(a, b, k + 1) for a, b, k in zip(g[:-1], g[1:], pieces, strict=True)]
        + [[lo, hi]]
    )
    t = np.unique(np.clip(t, lo, hi))
    if len(t) > _GRID_MAX:
        t = t[np.round(np.linspace(0, len(t) - 1, _GRID_MAX)).astype(np.intp)]
    return t


class Grid:
    """A patch sampled over ``box`` (per knot span), for starting points of the inversion;
    its domain, closed directions and seams' widths (:func:`.rhino_seams.seam_widths`)."""

    def __init__(
        self,
        patch: BSplinePatch,
        box: tuple[tuple[float, float], tuple[float, float]],
        closed: tuple[bool, bool],
    ) -> None:
        self.patch = patch
        (u0, u1), (v0, v1) = patch.domain
        self.lo = np.array([u0, v0])
        self.hi = np.array([u1, v1])
        self.span = self.hi - self.lo
        self.closed = closed
        gu = _grid_parameters(patch, 0, *box[0])
        gv = _grid_parameters(patch, 1, *box[1])
        self.uv = np.stack(np.meshgrid(gu, gv, indexing="ij"), -1).reshape(-1, 2)
        self.xyz = patch(self.uv[:, 0], self.uv[:, 1])
        self.scale = float(np.ptp(self.xyz, axis=0).max()) or 1.0
        self.seam = seams.seam_widths(patch, closed)

    def wrap(self, uv: NDArray[np.float64]) -> NDArray[np.float64]:
        """Parameters brought into the domain: across the seam of a closed direction, else
        clipped."""
        out = np.clip(uv, self.lo, self.hi)
        for d in (0, 1):
            if self.closed[d]:
                out[:, d] = self.lo[d] + np.mod(uv[:, d] - self.lo[d], self.span[d])
        return out

    def nearest(self, xyz: NDArray[np.float64]) -> NDArray[np.float64]:
        """The grid parameters nearest each point of ``xyz``."""
        g2 = (self.xyz**2).sum(-1)
        out = np.empty((len(xyz), 2))
        for i in range(0, len(xyz), 256):
            x = xyz[i : i + 256]
            out[i : i + 256] = self.uv[np.argmin(g2[None, :] - 2.0 * x @ self.xyz.T, axis=1)]
        return out


def _newton(
    grid: Grid, xyz: NDArray[np.float64], uv: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Damped Gauss-Newton from ``uv`` towards the surface points nearest ``xyz``, all points
    at once (one surface evaluation per iteration, for the points still moving).

    Returns the parameters and the squared 3D residuals there.
    """
    uv = uv.copy()
    m = len(uv)
    d = grid.patch.derivatives(uv[:, 0], uv[:, 1], 1)
    S, Su, Sv = d[0, 0], d[1, 0], d[0, 1]
    f = ((S - xyz) ** 2).sum(-1)
    alpha = np.ones(m)
    step = np.zeros((m, 2))
    fresh = np.ones(m, dtype=bool)  # a step to compute from the current derivatives
    act = np.arange(m)
    small = 1e-12 * grid.span
    for _ in range(_NEWTON_STEPS):
        new = act[fresh[act]]
        if new.size:
            J = np.stack([Su[new], Sv[new]], -1)  # (k, 3, 2)
            A = np.einsum("mki,mkj->mij", J, J)
            g = np.einsum("mki,mk->mi", J, S[new] - xyz[new])
            A += (1e-12 * np.trace(A, axis1=1, axis2=2) + 1e-300)[:, None, None] * np.eye(2)
            step[new] = -np.linalg.solve(A, g[..., None])[..., 0]
        trial = grid.wrap(uv[act] + alpha[act, None] * step[act])
        dt = grid.patch.derivatives(trial[:, 0], trial[:, 1], 1)
        ft = ((dt[0, 0] - xyz[act]) ** 2).sum(-1)
        ok = ft <= f[act]
        a = act[ok]
        moved = np.all(np.abs(trial - uv[act]) <= small, axis=1)
        stalled = f[act] - ft <= 1e-6 * f[act]
        done = (ok & (moved | stalled)) | (alpha[act] < 1e-8)
        uv[a], f[a] = trial[ok], ft[ok]
        S[a], Su[a], Sv[a] = dt[0, 0][ok], dt[1, 0][ok], dt[0, 1][ok]
        alpha[a] = np.minimum(1.0, 2.0 * alpha[a])
        alpha[act[~ok]] *= 0.25
        fresh[act] = ok
        act = act[~done]
        if not act.size:
            break
    return uv, f


def pull_back(
    grid: Grid, xyz: NDArray[np.float64], near: NDArray[np.intp]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.intp]]:
    """(u, v) of the surface points nearest ``xyz`` (m, 3), points along loops.

    ``near`` (2, m) names each point's neighbours along its loop: points whose inversion from
    the grid lands far from the surface are tried again from their neighbours' parameters.

    Returns the parameters, each point's 3D residual over the smallest parameter speed there
    (the loop tolerance), and at singular points (where the speed vanishes) the direction
    along which the surface does not move (-1 elsewhere).
    """
    uv, f = _newton(grid, xyz, grid.nearest(xyz))
    for _ in range(_RETRIES):
        bad = np.flatnonzero(
            f > np.maximum(_RETRY_RATIO * np.minimum(*f[near]), (_RETRY_FLOOR * grid.scale) ** 2)
        )
        if not bad.size:
            break
        improved = False
        for side in near:
            u2, f2 = _newton(grid, xyz[bad], uv[side[bad]])
            better = f2 < 0.25 * f[bad]
            uv[bad[better]], f[bad[better]] = u2[better], f2[better]
            improved |= bool(better.any())
        if not improved:
            break
    d = grid.patch.derivatives(uv[:, 0], uv[:, 1], 1)
    res = np.linalg.norm(d[0, 0] - xyz, axis=1)
    J = np.stack([d[1, 0], d[0, 1]], -1)
    speed = np.linalg.svd(J, compute_uv=False)[:, -1]
    singular = speed <= 1e-8 * grid.scale
    slow_u = np.linalg.norm(d[1, 0], axis=1) < np.linalg.norm(d[0, 1], axis=1)
    free = np.where(singular, np.where(slow_u, 0, 1), -1)
    return uv, res / np.where(singular, 1.0, speed), free
