"""Umbilic points: where the principal curvatures are equal, k1 = k2, found as points.

In an orthonormal frame (e1, e2) of the tangent plane the shape operator is the symmetric
matrix W = [[w11, w12], [w12, w22]], w_ij = II(e_i, e_j) (do Carmo §3-2; Kiciak ch. 6), and

    ((k1 - k2) / 2)^2 = ((w11 - w22) / 2)^2 + w12^2,

so a point is umbilic exactly where F = (w11 - w22, 2 w12) = 0: two equations in (u, v),
isolated points on a generic surface.  Each patch is searched on a grid for the local minima
of |F|^2 / |W|^2 (the relative anisotropy), and from each Newton's method on F (the exact
second derivatives; its Jacobian by central differences) finds the point to round-off.  A
patch umbilic all over (a plane, a sphere) has no isolated umbilics and is reported apart.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..geometry import Patch, regularised_derivatives

__all__ = ["Umbilic", "scene_umbilics", "umbilic_field", "umbilics"]

#: Grid points a patch side is searched at; a grid minimum below CANDIDATE anisotropy is
#: refined; a patch with more than UMBILIC_SHARE of its grid within ALL_OVER is umbilic all
#: over (its points are not isolated)
GRID, CANDIDATE, UMBILIC_SHARE, ALL_OVER = 33, 0.5, 0.25, 1e-8
#: Umbilics closer than this (relative to the scene's diagonal) are one (on a shared side)
SAME_POINT = 1e-6
#: Newton's iterations, and |F| / |W| at which a point is umbilic
NEWTON_STEPS, CONVERGED = 40, 1e-9


@dataclass(frozen=True)
class Umbilic:
    """An umbilic point: the patch, its (u, v), the 3D point and the curvature k1 = k2."""

    patch: int
    u: float
    v: float
    point: tuple[float, float, float]
    curvature: float

    def as_dict(self) -> dict[str, Any]:
        return {
            "point": list(self.point),
            "face": self.patch,
            "patch": self.patch,
            "u": self.u,
            "v": self.v,
            "curvature": self.curvature,
        }


def umbilic_field(patch: Patch, u: NDArray, v: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """F (n, 2) = (w11 - w22, 2 w12), |W| (n,) and the mean curvature (n,) at (u, v), the
    shape operator in the frame e1 = p_u / |p_u|, e2 = N x e1, N = p_u x p_v / |...|."""
    d = regularised_derivatives(patch, u, v, 2).d
    pu, pv = d[1, 0], d[0, 1]
    cross = np.cross(pu, pv)
    W = np.linalg.norm(cross, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        n = cross / W[:, None]
        E, F = np.sum(pu * pu, -1), np.sum(pu * pv, -1)
        L, M, N = (np.sum(x * n, -1) for x in (d[2, 0], d[1, 1], d[0, 2]))
        root = np.sqrt(E)
        a = 1.0 / root  # e1 = (a, 0) in (du, dv)
        s, t = -F / (root * W), root / W  # e2 = (s, t)
        w11 = L * a * a
        w12 = a * (L * s + M * t)
        w22 = L * s * s + 2 * M * s * t + N * t * t
    field = np.stack([w11 - w22, 2.0 * w12], -1)
    size = np.sqrt(w11**2 + 2 * w12**2 + w22**2)
    return field, size, 0.5 * (w11 + w22)


def _newton(patch: Patch, u: NDArray, v: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """The roots of F near each (u, v) (m,), all refined together: (u, v, found), found
    False where an iteration left the domain or stalled."""
    (u0, u1), (v0, v1) = patch.domain
    hu, hv = 1e-6 * (u1 - u0), 1e-6 * (v1 - v0)
    u, v = np.array(u, dtype=np.float64), np.array(v, dtype=np.float64)
    going = np.ones(len(u), bool)
    found = np.zeros(len(u), bool)
    for _ in range(NEWTON_STEPS):
        at = np.flatnonzero(going)
        if not at.size:
            break
        a, b = u[at], v[at]
        U = np.clip(np.concatenate([a, a + hu, a - hu, a, a]), u0, u1)
        V = np.clip(np.concatenate([b, b, b, b + hv, b - hv]), v0, v1)
        field, size, _ = umbilic_field(patch, U, V)
        f = field.reshape(5, len(at), 2)
        ok = np.isfinite(f).all(axis=(0, 2))
        done = ok & (
            np.linalg.norm(f[0], axis=-1) <= CONVERGED * np.maximum(size[: len(at)], 1e-300)
        )
        steps = [U.reshape(5, -1), V.reshape(5, -1)]
        J = np.stack(
            [
                (f[1] - f[2]) / (steps[0][1] - steps[0][2])[:, None],
                (f[3] - f[4]) / (steps[1][3] - steps[1][4])[:, None],
            ],
            -1,
        )  # (m, 2, 2): columns d/du, d/dv
        det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
        solvable = ok & ~done & (np.abs(det) > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            du = -(J[:, 1, 1] * f[0, :, 0] - J[:, 0, 1] * f[0, :, 1]) / det
            dv = -(-J[:, 1, 0] * f[0, :, 0] + J[:, 0, 0] * f[0, :, 1]) / det
        na, nb = a + du, b + dv
        within = (u0 - hu <= na) & (na <= u1 + hu) & (v0 - hv <= nb) & (nb <= v1 + hv)
        moved = solvable & within
        u[at[moved]] = np.clip(na[moved], u0, u1)
        v[at[moved]] = np.clip(nb[moved], v0, v1)
        found[at[done]] = True
        going[at[~moved]] = False
    return u, v, found


def umbilics(
    patches: Sequence[Patch],
    inside: Callable[[int, NDArray], NDArray] | None = None,
    tolerance: float = 1e-7,
) -> tuple[list[Umbilic], list[int]]:
    """The isolated umbilic points of ``patches`` (each once: points within ``tolerance``
    of one found are the same), and the patches umbilic all over.  ``inside(k, uv)``: which
    of patch k's parameters (n, 2) lie on the surface (a trimmed face's region).

    Examples
    --------
    A sphere is umbilic all over: no isolated points.

    >>> from gshade.geometry.patches.revolution import sphere
    >>> umbilics([sphere(2.0)])
    ([], [0])
    """
    found: list[Umbilic] = []
    everywhere: list[int] = []
    for k, patch in enumerate(patches):
        (u0, u1), (v0, v1) = patch.domain
        uu, vv = np.meshgrid(np.linspace(u0, u1, GRID), np.linspace(v0, v1, GRID), indexing="ij")
        u, v = uu.ravel(), vv.ravel()
        field, size, _ = umbilic_field(patch, u, v)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.linalg.norm(field, axis=-1) / size
        flat = ~(size > 0)
        if np.mean(flat | (ratio < ALL_OVER)) > UMBILIC_SHARE:
            everywhere.append(k)
            continue
        ratio = np.where(np.isfinite(ratio), ratio, np.inf).reshape(GRID, GRID)
        padded = np.pad(ratio, 1, constant_values=np.inf)
        windows = np.lib.stride_tricks.sliding_window_view(padded, (3, 3))
        minima = (ratio <= windows.min(axis=(-1, -2))) & (ratio < CANDIDATE)
        roots_u, roots_v, converged = _newton(patch, uu[minima], vv[minima])
        for ru, rv in zip(roots_u[converged], roots_v[converged], strict=True):
            if inside is not None and not inside(k, np.array([[ru, rv]]))[0]:
                continue
            point = np.ravel(patch(np.array([ru]), np.array([rv])))
            if any(np.linalg.norm(point - np.array(f.point)) <= tolerance for f in found):
                continue
            curvature = float(umbilic_field(patch, np.array([ru]), np.array([rv]))[2][0])
            found.append(
                Umbilic(
                    k,
                    float(ru),
                    float(rv),
                    (float(point[0]), float(point[1]), float(point[2])),
                    curvature,
                )
            )
    return found, everywhere


def scene_umbilics(scene: Any) -> tuple[list[Umbilic], list[int]]:
    """The umbilics of a scene's patches (numbered as the scene numbers them), those of a
    CAD face inside its trimming loops only; points within :data:`SAME_POINT` of the
    scene's diagonal are one."""
    from .trimmed_faces import trim_test

    trims = trim_test(scene)

    def inside(k: int, uv: NDArray) -> NDArray:
        if trims is None:
            return np.ones(len(uv), bool)
        return trims(np.full(len(uv), k, dtype=np.int64), uv)

    from .scene_junctions import scene_diagonal

    return umbilics(scene.patches, inside, SAME_POINT * scene_diagonal(scene))
