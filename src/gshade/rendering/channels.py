"""The EXR channels of a render, assembled exactly per pixel.

From the picture's film (R G B A and the sum of f over the pixel's samples) come the
picture, the coverage and f, the mean over the samples that hit.  From the centre pass (the
atlas coordinates where the ray through each pixel centre meets the interpolated surface)
come the patch and a start for one exact Newton step
(:func:`gshade.rendering.surface_hits.surface_hits`): P, the unit normal
N = p_u x p_v / |p_u x p_v| (its limit at collapsed edges), u and v are the exact patch's at
the point where that ray meets it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from ..geometry import Patch, patch_normals, unit_normal
from ..geometry.core.patch import unit_to_domain
from ..shape import ShapeFunction
from .atlas import Atlas
from .camera import View
from .centre_values import centre_values, highest_order
from .integrator import SHAPE_FILM
from .surface_hits import patch_evaluator, surface_hits

__all__ = ["PICTURE", "CentreHits", "centre_hits", "exact_channels", "refuse_non_finite"]

#: the film's channels that all the pixel's samples make (the rest come from its centre)
PICTURE = ("R", "G", "B", "A", "f")


class CentreHits(NamedTuple):
    """Where the centre pass's rays meet the exact surface (:func:`centre_hits`): the
    pixels (flat indices), their patch, (u, v), the derivatives of order <= 1 there,
    (2, 2, N, 3), and each function's value by channel name."""

    pixels: NDArray[np.int64]
    patch: NDArray[np.int64]
    u: NDArray[np.float64]
    v: NDArray[np.float64]
    d: NDArray[np.float64]
    values: dict[str, NDArray[np.float64]]


def centre_hits(
    film: NDArray,
    hit: NDArray,
    atlas: Atlas,
    patches: list[Patch] | tuple[Patch, ...],
    view: View,
    functions: dict[str, tuple[ShapeFunction, dict]] | None = None,
) -> CentreHits:
    """The exact hits of the rays through the pixel centres that met the surface: one
    Newton step each from the centre pass's atlas coordinates (the film's ``x``, ``y``;
    the picture's channels are not read, so the supersampling pass may write them
    meanwhile), and the functions there (parameters as :func:`exact_channels`'s)."""
    functions = functions or {}
    order = highest_order(functions)
    W = film.shape[1]
    pixels = np.flatnonzero(hit.ravel())
    x, y = (film[..., SHAPE_FILM.index(c)].ravel()[pixels] for c in ("x", "y"))
    patch_index, st = atlas.locate(np.stack([x, y], -1).astype(np.float64))
    domains = np.array([p.domain for p in patches], dtype=np.float64)
    u, v = unit_to_domain(domains, st[:, 0], st[:, 1], index=patch_index)
    d = np.empty((2, 2, pixels.size, 3))
    values = {name: np.empty(pixels.size) for name in functions}
    by_patch = np.argsort(patch_index, kind="stable")  # a patch's hits in few blocks
    block = BLOCK >> (order - 1)  # in blocks: the steps' temporaries stay small
    evaluator = patch_evaluator(patches)
    for first in range(0, pixels.size, block):
        at = by_patch[first : first + block]
        rays = view.pixel_rays(pixels[at] // W, pixels[at] % W)
        u[at], v[at], dk, _ = surface_hits(
            patches, patch_index[at], u[at], v[at], *rays, order=order, evaluator=evaluator
        )
        d[:, :, at] = dk[:2, :2]
        for name, x in centre_values(patches, patch_index[at], u[at], v[at], dk, functions).items():
            values[name][at] = x
    return CentreHits(pixels, patch_index, u, v, d, values)


def exact_channels(
    film: NDArray,
    hit: NDArray,
    atlas: Atlas,
    patches: list[Patch] | tuple[Patch, ...],
    view: View,
    functions: dict[str, tuple[ShapeFunction, dict]] | None = None,
    hits: CentreHits | None = None,
) -> dict[str, NDArray[np.float32]]:
    """The EXR channels: the picture, coverage and f.mean (f's mean over the samples) from
    the samples; P, N, u, v, the patch index and each of ``functions`` where the ray through
    the pixel centre meets the exact surface (:func:`gshade.rendering.centre_values`, from
    the derivatives the Newton step ends with).

    Parameters
    ----------
    film : ndarray, shape (H, W, channels)
        The render's film, channels :data:`gshade.rendering.integrator.SHAPE_FILM`: the
        picture (R G B A and the sum of f, :data:`PICTURE`) from all samples, the atlas
        coordinates x, y from the centre pass.
    hit : ndarray, shape (H, W)
        Where the centre pass's rays met the surface.
    atlas, patches, view
        The atlas the centre pass's coordinates address, its patches, the camera.
    functions : dict, optional
        Channel name (``f``, ``f2``, an AOV's) -> (shape function, its parameters).
    hits : CentreHits, optional
        :func:`centre_hits` of the same arguments, where already found.
    """
    functions = functions or {}
    order = highest_order(functions)
    H, W = film.shape[:2]
    A = film[..., SHAPE_FILM.index("A")]
    f = np.where(A > 0, film[..., SHAPE_FILM.index("f")] / np.where(A > 0, A, 1.0), 0.0)
    if hits is None:
        hits = centre_hits(film, hit, atlas, patches, view, functions)
    hit, patch_index, u, v, d, values = hits
    values = dict(values)
    slipped = _slipped_through(A, hit, H, W)
    if slipped.size:
        found = _hits_from_neighbours(slipped, hit, patch_index, u, v, patches, view, H, W, order)
        hit = np.concatenate([hit, found[0]])
        patch_index = np.concatenate([patch_index, found[1]])
        u, v = np.concatenate([u, found[2]]), np.concatenate([v, found[3]])
        d = np.concatenate([d, found[4][:2, :2]], axis=2)
        more = centre_values(patches, found[1], found[2], found[3], found[4], functions)
        values = {name: np.concatenate([values[name], more[name]]) for name in functions}
    normal = unit_normal(d)
    n = normal.n
    if not normal.regular.all():  # limits at collapsed edges need higher derivatives
        irr = np.flatnonzero(~normal.regular)
        for k in np.unique(patch_index[irr]):
            at = irr[patch_index[irr] == k]
            n[at] = patch_normals(patches[k], u[at], v[at]).n
    out = {c: np.ascontiguousarray(film[..., SHAPE_FILM.index(c)]) for c in "RGB"}
    out["A"] = np.ascontiguousarray(A)
    per_hit: dict[str, NDArray | None] = {
        name: values.pop(name) for name in ("f",) if name in values
    }
    per_hit["f.mean"] = None  # the samples' own, below
    per_hit.update({f"P.{axis}": d[0, 0][:, c] for c, axis in enumerate("XYZ")})
    per_hit.update({f"N.{axis}": n[:, c] for c, axis in enumerate("XYZ")})
    per_hit.update(u=u, v=v, patch=patch_index, **values)
    for name, at_hits in per_hit.items():  # written into float32 images, 0 (patch -1) off
        if at_hits is None:
            out[name] = f.astype(np.float32)
            continue
        channel = np.full(H * W, -1.0 if name == "patch" else 0.0, dtype=np.float32)
        channel[hit] = at_hits
        out[name] = channel.reshape(H, W)
    return out


#: Centre rays per block of exact Newton steps to first-order derivatives (halved for each
#: order more that the functions need: the derivatives' memory stays about the same).
BLOCK = 1 << 16
#: Newton steps from a neighbour's hit for a centre ray that slipped between two surfaces.
SLIPPED_STEPS = 4


def _slipped_through(A: NDArray, hit: NDArray, H: int, W: int) -> NDArray:
    """Fully covered pixels whose centre ray met no surface in the centre pass: it slipped
    through a crack between separately tessellated surfaces (or patches) that no sample of
    the pixel saw, so the surface is there."""
    covered = np.zeros(H * W, bool)
    covered[hit] = True
    return np.flatnonzero((A.ravel() >= 1.0) & ~covered)


def _hits_from_neighbours(
    slipped: NDArray,
    hit: NDArray,
    patch_index: NDArray,
    u: NDArray,
    v: NDArray,
    patches: list[Patch] | tuple[Patch, ...],
    view: View,
    H: int,
    W: int,
    order: int = 1,
) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray]:
    """Exact hits for the slipped centre rays: Newton steps on the patches of the pixel's
    neighbours that were hit, from their (u, v); the first that settles.  Returns the
    pixels found and their patch, u, v and derivatives of order <= ``order``."""
    where = np.full(H * W, -1, dtype=np.int64)  # pixel -> its place among the hits
    where[hit] = np.arange(hit.size)
    index = np.full(slipped.size, -1, dtype=np.int64)  # the patch found, -1: none yet
    su, sv = np.zeros(slipped.size), np.zeros(slipped.size)
    d = np.zeros((order + 1, order + 1, slipped.size, 3))
    rows, cols = slipped // W, slipped % W
    evaluator = patch_evaluator(patches)
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
            patches,
            patch_index[s],
            u[s],
            v[s],
            *rays,
            steps=SLIPPED_STEPS,
            order=order,
            evaluator=evaluator,
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
