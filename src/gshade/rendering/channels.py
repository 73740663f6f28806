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
