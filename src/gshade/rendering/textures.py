"""Shape-function textures: exact values on a fine grid per patch, packed into one atlas.

Each patch gets a T x T tile of texels whose centres sit on the grid s_k = k / (T - 1) of its
normalised parameters, holding (f, f_s, f_t): the shape function's value and its exact
derivatives in the normalised parameters (from the surface gradient: f_s = <grad_S f, p_s>).
The renderer interpolates them (bicubic Hermite) at each sample's (s, t) and applies the stripe or
colour mapping per sample, so stripes stay sharp and anti-aliased whatever the mesh.

The atlas layout (where patch k's tile lies, which texel holds which (s, t)) is
:class:`gshade.rendering.atlas.Atlas`'s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..geometry import Patch, irregular_mask, regularised_derivatives
from ..geometry.core.differential import derivative_scales
from ..geometry.evaluation.patch_groups import domain_spans, grid_derivatives, patch_grid
from ..shape import ShapeFunction, evaluate, function_period
from .atlas import GEOMETRY, SHAPE, Atlas

__all__ = ["Atlas", "ShapeTextures", "shape_textures", "texel_areas"]


@dataclass(frozen=True)
class ShapeTextures:
    """Atlas images, each (H, W, 3) float32 unless noted.

    ``values[k]`` = (f, f_s, f_t), ``twist[k]`` (H, W) = f_st (central differences of f_s
    along t, one-sided at tile borders) and ``valid[k]`` (H, W) in {0, 1} for the k-th
    function: the data of a bicubic Hermite interpolant, accurate to O(h^4);
    ``position`` = p, ``tangent_s`` = p_s, ``tangent_t`` = p_t and ``twist_st`` = p_st, the
    bicubic Hermite data with which the renderer moves each sample from the mesh onto the
    exact surface (one Newton step); ``regular`` where the parametrisation is regular.
    """

    atlas: Atlas
    values: list[NDArray[np.float32]]
    twist: list[NDArray[np.float32]]
    valid: list[NDArray[np.float32]]
    position: NDArray[np.float32]
    tangent_s: NDArray[np.float32]
    tangent_t: NDArray[np.float32]
    twist_st: NDArray[np.float32]
    #: (H, W): whether each texel's parametrisation is regular (False on a collapsed edge,
    #: at an extraordinary vertex: its values are limits taken from inside); None: all
    regular: NDArray[np.bool_] | None = None
    #: per function, the period of its values where they are angles that wrap (the
    #: renderer interpolates them unwrapped: :func:`gshade.shape.function_period`), else None
    periods: tuple[float | None, ...] = ()

    def geometry(self) -> dict[str, NDArray[np.float32]]:
        """The surface's images by quantity (see :data:`gshade.rendering.atlas.GEOMETRY`)."""
        return {
            "p": self.position,
            "p_s": self.tangent_s,
            "p_t": self.tangent_t,
            "p_st": self.twist_st,
        }

    def function(self, k: int) -> dict[str, NDArray[np.float32]]:
        """The k-th function's images by quantity (see :data:`gshade.rendering.atlas.SHAPE`)."""
        values = self.values[k]
        return {
            "f": values[..., 0],
            "f_s": values[..., 1],
            "f_t": values[..., 2],
            "f_st": self.twist[k],
            "valid": self.valid[k],
        }


def texel_areas(tex: ShapeTextures, where: NDArray | None = None) -> NDArray[np.float32]:
    """|p_s x p_t| h_s h_t at each texel (h_s, h_t its tile's spacings): the surface area a
    texel stands for, as an (H, W) image, or at the texels ``where`` (a mask) as a vector.
    Float32, as the textures."""
    atlas = tex.atlas
    spacing = np.zeros((atlas.height, atlas.width), dtype=np.float32)
    for k, tile in enumerate(atlas.all_tile_slices()):
        hs, ht = atlas.spacing(k)
        spacing[tile] = np.float32(hs * ht)
    a, b = tex.tangent_s, tex.tangent_t
    # the cross product's length, as np.linalg.norm(np.cross(a, b)) rounds it, in a fifth of
    # its time: per component, no (..., 3) temporaries
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    c0, c1, c2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
    area = np.sqrt(c0 * c0 + c1 * c1 + c2 * c2) * spacing
    return area if where is None else area[where]


#: Texels per shape-function call: small tiles are evaluated many patches at a time (one
#: kernel launch per chunk), large ones one patch at a time (no copy into a chunk buffer).
CHUNK_TEXELS = 1 << 15


def _chunk_derivatives(
    patches: list[Patch] | tuple[Patch, ...],
    chunk: list[int],
    grid: tuple[NDArray, NDArray],
    order: int,
) -> tuple[NDArray, NDArray, NDArray]:
    """Derivatives of the patches ``chunk`` on the tile grid (s, t):
    (order+1, order+1, n, S, T, 3), regularised at irregular points (see
    :func:`gshade.geometry.regularised_derivatives`), the regularity (n, S, T) and the
    parameter spans (n, 2)."""
    members = [patches[k] for k in chunk]
    spans = domain_spans(members)
    s, t = grid
    if len(members) == 1:  # in place, no copy
        rd = regularised_derivatives(members[0], *patch_grid(members[0], s, t), order)
        return rd.d[:, :, None], rd.regular[None], spans
    d = np.moveaxis(grid_derivatives(members, s, order, t), 0, 2)
    # each patch judged on its own scale (as regularised_derivatives judges it)
    scale = derivative_scales(d, np.arange(len(members))[:, None, None])
    regular = ~irregular_mask(d, scale=scale)
    for c in np.flatnonzero(~regular.all(axis=(1, 2))):
        rd = regularised_derivatives(members[c], *patch_grid(members[c], s, t), order)
        d[:, :, c], regular[c] = rd.d, rd.regular
    return d, regular, spans


def _chunks(atlas: Atlas) -> list[tuple[list[int], tuple[int, int]]]:
    """The patches in chunks of one tile size (S, T), of about :data:`CHUNK_TEXELS`
    texels."""
    out = []
    for S, T in np.unique(atlas.sizes, axis=0):
        same = np.flatnonzero((atlas.sizes == (S, T)).all(axis=1)).tolist()
        per_chunk = max(1, CHUNK_TEXELS // int(S * T))
        size = (int(S), int(T))
        out += [(same[i : i + per_chunk], size) for i in range(0, len(same), per_chunk)]
    return out


def shape_textures(
    patches: list[Patch] | tuple[Patch, ...],
    atlas: Atlas,
    functions: list[tuple[ShapeFunction, dict]],
) -> ShapeTextures:
    """Evaluate shape functions with their slopes, and the surface, on every patch's tile.

    The slopes are exact: f_s = (u1 - u0) f_u and f_t = (v1 - v0) f_v from the kernels'
    jets.  At irregular texels (collapsed edges, extraordinary vertices) they are one-sided
    differences of f instead: the exact ones may be unbounded there (a curvature near an
    extraordinary vertex) and would make the Hermite interpolant overshoot.
    """
    H, W = atlas.height, atlas.width
    # the images are views into the packed textures the integrator reads, written in place
    # (one copy of the atlas fewer: packing them is then no copy, see Packing.pack)
    packed = [np.zeros((H, W, SHAPE.size), dtype=np.float32) for _ in functions]
    f0, f_st = SHAPE.channel("f"), SHAPE.channel("f_st")
    values = [p[..., f0 : f0 + 3] for p in packed]  # f, f_s, f_t side by side
    twist = [p[..., f_st] for p in packed]
    valid = [p[..., SHAPE.channel("valid")] for p in packed]
    surface = np.zeros((H, W, GEOMETRY.size), dtype=np.float32)
    regular_image = np.ones((H, W), dtype=bool)
    geometry = [
        surface[..., GEOMETRY.channel(q) : GEOMETRY.channel(q) + 3]
        for q in ("p", "p_s", "p_t", "p_st")
    ]
    order = max(2, max(fn.order for fn, _ in functions) + 1)
    for chunk, (S, T) in _chunks(atlas):
        grid = np.linspace(0.0, 1.0, S), np.linspace(0.0, 1.0, T)
        hs, ht = 1.0 / (S - 1), 1.0 / (T - 1)
        d, regular, spans = _chunk_derivatives(patches, chunk, grid, order)
        su = spans[:, 0, None, None, None]
        sv = spans[:, 1, None, None, None]
        p_s, p_t, p_st = d[1, 0] * su, d[0, 1] * sv, d[1, 1] * su * sv
        shaped = []
        for fn, params in functions:
            res = evaluate(
                fn, d[: fn.order + 2, : fn.order + 2], gradient=False, partials=True, **params
            )
            assert res.partials is not None  # asked for with partials=True
            f_s = res.partials[..., 0] * spans[:, 0, None, None]
            f_t = res.partials[..., 1] * spans[:, 1, None, None]
            if not regular.all():
                irr = ~regular
                f_s[irr] = np.gradient(res.f, hs, axis=1)[irr]
                f_t[irr] = np.gradient(res.f, ht, axis=2)[irr]
            # f_st: central differences of f_s along t, one-sided at the tile's borders
            shaped.append((res, f_s, f_t, np.gradient(f_s, ht, axis=2)))
        for c, k in enumerate(chunk):
            tile = atlas.tile_slices(k)
            # rows follow t (v), columns follow s (u): a tile is the transpose of the grid
            regular_image[tile] = regular[c].T
            for image, field in zip(geometry, (d[0, 0, c], p_s[c], p_t[c], p_st[c]), strict=True):
                image[tile] = field.transpose(1, 0, 2)
            for j, (res, f_s, f_t, f_st) in enumerate(shaped):
                values[j][tile] = np.stack([res.f[c], f_s[c], f_t[c]], -1).transpose(1, 0, 2)
                twist[j][tile] = f_st[c].T
                valid[j][tile] = res.valid[c].T
    position, tangent_s, tangent_t, twist_st = geometry
    periods = tuple(function_period(fn, params) for fn, params in functions)
    return ShapeTextures(
        atlas,
        values,
        twist,
        valid,
        position,
        tangent_s,
        tangent_t,
        twist_st,
        regular_image,
        periods,
    )
