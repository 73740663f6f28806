"""The EXR channels of a render, assembled exactly per pixel.

From the shape pass (R G B A and the sum of f over the pixel's samples) come the picture,
the coverage and f, the mean over the samples that hit.  From the data pass (the atlas
coordinates where the ray through each pixel centre meets the interpolated surface) come the
patch and a start for one exact Newton step (:func:`gshade.rendering.surface_hits.surface_hits`):
P, the unit normal N = p_u x p_v / |p_u x p_v| (its limit at collapsed edges), u and v are
the exact patch's at the point where that ray meets it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from ..geometry import Patch, patch_normals, unit_normal
from ..geometry.patch import unit_to_domain
from .atlas import Atlas
from .camera import View
from .integrator import DATA_FILM, SHAPE_FILM
from .surface_hits import surface_hits

__all__ = ["exact_channels", "refuse_non_finite"]


def exact_channels(
    image: NDArray,
    data: NDArray,
    atlas: Atlas,
    patches: list[Patch] | tuple[Patch, ...],
    view: View,
) -> dict[str, NDArray[np.float32]]:
    """The EXR channels: the picture, coverage and f from the samples; P, N, u, v and the
    patch index where the ray through the pixel centre meets the exact surface.

    Parameters
    ----------
    image : ndarray, shape (H, W, 5)
        The shape pass's film (:data:`gshade.rendering.integrator.SHAPE_FILM`).
    data : ndarray, shape (H, W, 7)
        The data pass's film (:data:`gshade.rendering.integrator.DATA_FILM`).
    atlas, patches, view
        The atlas the data pass's coordinates address, its patches, the camera.
    """
    H, W = image.shape[:2]
    A = image[..., SHAPE_FILM.index("A")]
    f = np.where(A > 0, image[..., SHAPE_FILM.index("f")] / np.where(A > 0, A, 1.0), 0.0)
    x, y, hit_flag = (DATA_FILM.index(c) for c in ("x", "y", "hit"))
    hit = np.flatnonzero(data[..., hit_flag].ravel() > 0.5)
    xy = np.stack([data[..., x], data[..., y]], -1).reshape(-1, 2)
    patch_index, st = atlas.locate(xy[hit].astype(np.float64))
    domains = np.array([p.domain for p in patches], dtype=np.float64)
    u, v = unit_to_domain(domains, st[:, 0], st[:, 1], index=patch_index)
    u, v, d, _ = surface_hits(patches, patch_index, u, v, *view.pixel_rays(hit // W, hit % W))
    slipped = _slipped_through(A, hit, H, W)
    if slipped.size:
        found = _hits_from_neighbours(slipped, hit, patch_index, u, v, patches, view, H, W)
        hit = np.concatenate([hit, found[0]])
        patch_index = np.concatenate([patch_index, found[1]])
        u, v = np.concatenate([u, found[2]]), np.concatenate([v, found[3]])
        d = np.concatenate([d, found[4]], axis=2)
    normal = unit_normal(d)
    n = normal.n
    if not normal.regular.all():  # limits at collapsed edges need higher derivatives
        irr = np.flatnonzero(~normal.regular)
        for k in np.unique(patch_index[irr]):
            at = irr[patch_index[irr] == k]
            n[at] = patch_normals(patches[k], u[at], v[at]).n
    P = np.zeros((H * W, 3))
    N = np.zeros((H * W, 3))
    U = np.zeros(H * W)
    V = np.zeros(H * W)
    patch_of = np.full(H * W, -1.0)
    P[hit], N[hit], U[hit], V[hit], patch_of[hit] = d[0, 0], n, u, v, patch_index
    P, N = P.reshape(H, W, 3), N.reshape(H, W, 3)
    U, V = U.reshape(H, W), V.reshape(H, W)
    out = {c: image[..., SHAPE_FILM.index(c)] for c in "RGB"}
    out["A"], out["f"] = A, f
    for name, arr in (("P", P), ("N", N)):
        for c, axis in enumerate("XYZ"):
            out[f"{name}.{axis}"] = arr[..., c]
    out["u"], out["v"] = U, V
    out["patch"] = patch_of.reshape(H, W)
    return {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in out.items()}


#: Newton steps from a neighbour's hit for a centre ray that slipped between two surfaces.
SLIPPED_STEPS = 4


def _slipped_through(A: NDArray, hit: NDArray, H: int, W: int) -> NDArray:
    """Fully covered pixels whose centre ray met no surface in the data pass: it slipped
    through a crack between separately tessellated surfaces (or patches) that no sample of
    the pixel saw, so the surface is there."""
    covered = np.zeros(H * W, bool)
    covered[hit] = True
    return np.flatnonzero((A.ravel() >= 1.0) & ~covered)


def _hits_from_neighbours(slipped, hit, patch_index, u, v, patches, view: View, H: int, W: int):
    """Exact hits for the slipped centre rays: Newton steps on the patches of the pixel's
    neighbours that were hit, from their (u, v); the first that settles.  Returns the
    pixels found and their patch, u, v and derivatives."""
    where = np.full(H * W, -1, dtype=np.int64)  # pixel -> its place among the hits
    where[hit] = np.arange(hit.size)
    index = np.full(slipped.size, -1, dtype=np.int64)  # the patch found, -1: none yet
    su, sv = np.zeros(slipped.size), np.zeros(slipped.size)
    d = np.zeros((2, 2, slipped.size, 3))
    rows, cols = slipped // W, slipped % W
    for dr, dc in ((0, -1), (0, 1), (-1, 0), (1, 0), (-1, -1), (-1, 1), (1, -1), (1, 1)):
        r, c = rows + dr, cols + dc
        inside = (r >= 0) & (r < H) & (c >= 0) & (c < W) & (index < 0)
        source = np.where(inside, where[np.where(inside, r * W + c, 0)], -1)
        todo = np.flatnonzero(source >= 0)
        if not todo.size:
            continue
        s = source[todo]
        pixels = slipped[todo]
        rays = view.pixel_rays(pixels // W, pixels % W)
        tu, tv, td, settled = surface_hits(
            patches, patch_index[s], u[s], v[s], *rays, steps=SLIPPED_STEPS
        )
        done = todo[settled]
        index[done], su[done], sv[done] = patch_index[s][settled], tu[settled], tv[settled]
        d[:, :, done] = td[:, :, settled]
    found = index >= 0
    return slipped[found], index[found], su[found], sv[found], d[:, :, found]


def refuse_non_finite(where: str, channels: dict[str, NDArray]) -> None:
    """A truthful picture or none: raise GshadeError if any channel holds NaN or infinity."""
    broken = {c: int((~np.isfinite(a)).sum()) for c, a in channels.items()}
    broken = {c: n for c, n in broken.items() if n}
    if broken:
        raise GshadeError(
            f"{where}: the render gave non-finite values ("
            + ", ".join(f"{n} pixels of {c}" for c, n in broken.items())
            + "): the surface data or shape parameters lie outside what gshade evaluates"
        )
