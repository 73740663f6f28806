"""Irregular points of a patch: limit normals and curvatures at collapsed edges.

Where p_u x p_v = 0 (a collapsed edge, e.g. the teapot's lid top) the normal and the
curvatures are limits taken from inside the patch.  The normal's limit comes from the
Taylor expansion of p_u x p_v (:func:`~gshade.geometry.core.differential.unit_normal`); for
the derivatives used by curvatures and shape functions, the point is moved a tiny step
(``offset`` times the domain's size) toward the domain's centre and re-evaluated.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.differential import IRREGULAR_TOL, Normal, irregular_mask, unit_normal
from ..core.patch import Patch

__all__ = [
    "RegularisedDerivatives",
    "degenerate_patch",
    "degenerate_patches",
    "patch_normals",
    "regularised_derivatives",
    "toward_interior",
]


def toward_interior(patch: Patch, u: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
    """Unit parameter directions (du, dv) from (u, v) toward the centre of the domain."""
    (u0, u1), (v0, v1) = patch.domain
    u, v = np.broadcast_arrays(np.asarray(u, dtype=float), np.asarray(v, dtype=float))
    du = (0.5 * (u0 + u1) - u) / (u1 - u0)
    dv = (0.5 * (v0 + v1) - v) / (v1 - v0)
    length = np.hypot(du, dv)
    centre = length == 0
    length[centre] = 1.0
    du[centre] = 1.0
    return np.stack([du / length * (u1 - u0), dv / length * (v1 - v0)], axis=-1)


def patch_normals(patch: Patch, u: ArrayLike, v: ArrayLike) -> Normal:
    """Unit normals of a patch with exact limits at irregular points.

    Returns :class:`~gshade.geometry.core.differential.Normal` (``n``, ``regular``).
    """
    d = patch.derivatives(u, v, 3)
    return unit_normal(d, toward=toward_interior(patch, u, v))


class RegularisedDerivatives(NamedTuple):
    """Derivatives with irregular points replaced by limits, and the regularity mask."""

    d: NDArray[np.float64]
    regular: NDArray[np.bool_]


def regularised_derivatives(
    patch: Patch, u: ArrayLike, v: ArrayLike, order: int = 2, offset: float = 1e-5
) -> RegularisedDerivatives:
    """``patch.derivatives(u, v, order)`` with usable values at irregular points.

    At irregular points the derivatives of order >= 1 are taken at a parameter moved by
    ``offset`` (relative to the domain size) toward the domain's centre, so that normals,
    curvatures and shape functions computed from them are their limits up to O(offset).
    Positions stay exact.
    """
    d = patch.derivatives(u, v, order)
    if order < 1:
        return RegularisedDerivatives(d, np.ones(d.shape[2:-1], dtype=bool))
    regular = ~irregular_mask(d)
    if regular.all():
        return RegularisedDerivatives(d, regular)
    ub, vb = np.broadcast_arrays(np.asarray(u, dtype=float), np.asarray(v, dtype=float))
    irr = ~regular
    step = toward_interior(patch, ub[irr], vb[irr]) * offset
    moved = patch.derivatives(ub[irr] + step[:, 0], vb[irr] + step[:, 1], order)
    position = d[0, 0][irr]
    d[:, :, irr] = moved
    d[0, 0][irr] = position
    return RegularisedDerivatives(d, regular)


def degenerate_patch(
    patches: list[Patch] | tuple[Patch, ...], samples: int = 3
) -> tuple[int, str] | None:
    """The first patch that is no surface, and why; None if every patch is one
    (:func:`degenerate_patches`)."""
    return next(iter(degenerate_patches(patches, samples)), None)


def degenerate_patches(
    patches: list[Patch] | tuple[Patch, ...], samples: int = 3
) -> list[tuple[int, str]]:
    """The patches that are no surface, and why: (index, reason) each, in order.

    A patch is degenerate when its derivatives are not finite anywhere on an interior
    sample grid (its data overflow), or when it is irregular (|p_u x p_v| ≈ 0, see
    :func:`~gshade.geometry.core.differential.irregular_mask`) at every sample: all control
    points equal, collinear points, a sphere too small for double precision.  Collapsed
    edges (the teapot's lid) are irregular only at the boundary and pass.
    """
    from .patch_groups import grid_derivatives

    s = (np.arange(samples) + 0.5) / samples
    chunk = 512  # patches per evaluation: bounded memory for large scenes
    out = []
    for start in range(0, len(patches), chunk):
        group = list(patches[start : start + chunk])
        with np.errstate(all="ignore"):
            d = grid_derivatives(group, s, 1)  # (patches, 2, 2, n, n, 3)
        flat = d.reshape(len(group), -1)
        # beyond 1e100 the curvatures' products of derivatives overflow
        overflow = ~np.asarray((np.abs(flat) <= 1e100).all(axis=1))
        with np.errstate(all="ignore"):
            pu, pv = d[:, 1, 0], d[:, 0, 1]
            cross = np.linalg.norm(np.cross(pu, pv), axis=-1).reshape(len(group), -1)
            # the scale of irregular_mask, per patch: the largest first-derivative component
            scale = np.abs(np.concatenate([pu, pv], axis=1)).reshape(len(group), -1).max(axis=1)
            # derivatives at the round-off of the positions: all control points equal
            size = np.abs(d[:, 0, 0]).reshape(len(group), -1).max(axis=1)
            point = scale <= 1e-12 * size
            scale = np.where(scale > 0, scale, 1.0)
            flat_patch = point | (cross <= IRREGULAR_TOL * scale[:, None] ** 2).all(axis=1)
        for k in np.flatnonzero(overflow | flat_patch):
            if overflow[k]:
                out.append(
                    (start + int(k), "its points or derivatives overflow (numbers too large)")
                )
                continue
            out.append(
                (
                    start + int(k),
                    "it has no regular point (p_u x p_v = 0 everywhere: all control points "
                    "equal or collinear, or a size below double precision)",
                )
            )
    return out


_OVERFLOW = "its points or derivatives overflow (numbers too large)"
_NO_REGULAR_POINT = (
    "it has no regular point (p_u x p_v = 0 everywhere: all control points equal or "
    "collinear, or a size below double precision)"
)
