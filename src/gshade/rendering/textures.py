"""Shape-function textures: exact values on a fine grid per patch, packed into one atlas.

Each patch gets a T x T tile of texels whose centres sit on the grid s_k = k / (T - 1) of its
normalised parameters, holding (f, f_s, f_t): the shape function's value and its exact
derivatives in the normalised parameters (from the surface gradient: f_s = <grad_S f, p_s>).
The renderer interpolates them bilinearly at each sample's (s, t) and applies the stripe or
colour mapping per sample, so stripes stay sharp and anti-aliased whatever the mesh.

Texel (row r, column c) has its centre at atlas coordinates ((c + 0.5) / W, (r + 0.5) / H);
patch k's tile starts at column (k mod cols) T and row (k div cols) T, and its parameter s
maps to column c0 + s (T - 1), t to row r0 + t (T - 1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..geometry import Patch, irregular_mask, regularised_derivatives
from ..geometry.patch_groups import domain_spans, grid_derivatives, patch_grid
from ..shape import ShapeFunction, evaluate

__all__ = ["Atlas", "ShapeTextures", "shape_textures"]


@dataclass(frozen=True)
class Atlas:
    """Layout of T x T tiles, one per patch, in a grid of ``cols`` x ``rows`` tiles."""

    tile: int
    cols: int
    rows: int

    @classmethod
    def for_patches(cls, n_patches: int, tile: int) -> Atlas:
        cols = int(np.ceil(np.sqrt(n_patches)))
        return cls(int(tile), cols, int(np.ceil(n_patches / cols)))

    @property
    def width(self) -> int:
        return self.cols * self.tile

    @property
    def height(self) -> int:
        return self.rows * self.tile

    @property
    def scale(self) -> tuple[float, float]:
        """d(s, t) / d(atlas x, y): converts atlas-coordinate derivatives to parameter ones."""
        return self.width / (self.tile - 1), self.height / (self.tile - 1)

    def texcoords(self, patch: NDArray, st: NDArray) -> NDArray[np.float64]:
        """Atlas coordinates of normalised parameters ``st`` (N, 2) on patches ``patch`` (N,)."""
        c0 = (patch % self.cols) * self.tile
        r0 = (patch // self.cols) * self.tile
        x = (c0 + 0.5 + st[:, 0] * (self.tile - 1)) / self.width
        y = (r0 + 0.5 + st[:, 1] * (self.tile - 1)) / self.height
        return np.stack([x, y], -1)

    def locate(self, xy: NDArray) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """Patch index and normalised parameters of atlas coordinates ``xy`` (..., 2)."""
        cx = xy[..., 0] * self.width - 0.5
        ry = xy[..., 1] * self.height - 0.5
        col = np.clip(np.floor((cx + 0.5) / self.tile), 0, self.cols - 1).astype(np.int64)
        row = np.clip(np.floor((ry + 0.5) / self.tile), 0, self.rows - 1).astype(np.int64)
        s = np.clip((cx - col * self.tile) / (self.tile - 1), 0.0, 1.0)
        t = np.clip((ry - row * self.tile) / (self.tile - 1), 0.0, 1.0)
        return row * self.cols + col, np.stack([s, t], -1)


@dataclass(frozen=True)
class ShapeTextures:
    """Atlas images, each (H, W, 3) float32 unless noted.

    ``values[k]`` = (f, f_s, f_t), ``twist[k]`` (H, W) = f_st (central differences of f_s
    along t, one-sided at tile borders) and ``valid[k]`` (H, W) in {0, 1} for the k-th
    function: the data of a bicubic Hermite interpolant, accurate to O(h^4);
    ``position`` = p, ``tangent_s`` = p_s, ``tangent_t`` = p_t and ``twist_st`` = p_st, the
    bicubic Hermite data with which the renderer moves each sample from the mesh onto the
    exact surface (one Newton step).
    """

    atlas: Atlas
    values: list[NDArray[np.float32]]
    twist: list[NDArray[np.float32]]
    valid: list[NDArray[np.float32]]
    position: NDArray[np.float32]
    tangent_s: NDArray[np.float32]
    tangent_t: NDArray[np.float32]
    twist_st: NDArray[np.float32]


#: Texels per shape-function call: small tiles are evaluated many patches at a time (one
#: kernel launch per chunk), large ones one patch at a time (no copy into a chunk buffer).
CHUNK_TEXELS = 1 << 15


def _chunk_derivatives(patches, chunk, grid, order):
    """Derivatives of the patches ``chunk`` on the tile grid: (order+1, order+1, n, T, T, 3),
    regularised at irregular points (see :func:`gshade.geometry.regularised_derivatives`),
    the regularity (n, T, T) and the parameter spans (n, 2)."""
    members = [patches[k] for k in chunk]
    spans = domain_spans(members)
    if len(members) == 1:  # in place, no copy
        rd = regularised_derivatives(members[0], *patch_grid(members[0], grid), order)
        return rd.d[:, :, None], rd.regular[None], spans
    d = np.moveaxis(grid_derivatives(members, grid, order), 0, 2)
    regular = ~irregular_mask(d)
    # the chunk-wide test only finds candidates: each patch is judged on its own scale
    for c in np.flatnonzero(~regular.all(axis=(1, 2))):
        rd = regularised_derivatives(members[c], *patch_grid(members[c], grid), order)
        d[:, :, c], regular[c] = rd.d, rd.regular
    return d, regular, spans


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
    T = atlas.tile
    H, W = atlas.height, atlas.width
    values = [np.zeros((H, W, 3), dtype=np.float32) for _ in functions]
    valid = [np.zeros((H, W), dtype=np.float32) for _ in functions]
    twist = [np.zeros((H, W), dtype=np.float32) for _ in functions]
    geometry = [np.zeros((H, W, 3), dtype=np.float32) for _ in range(4)]
    grid = np.linspace(0.0, 1.0, T)
    h = 1.0 / (T - 1)
    order = max(2, max(fn.order for fn, _ in functions) + 1)
    per_chunk = max(1, CHUNK_TEXELS // (T * T))
    for first in range(0, len(patches), per_chunk):
        chunk = range(first, min(first + per_chunk, len(patches)))
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
                f_s[irr] = np.gradient(res.f, h, axis=1)[irr]
                f_t[irr] = np.gradient(res.f, h, axis=2)[irr]
            shaped.append((res, f_s, f_t))
        for c, k in enumerate(chunk):
            r0, c0 = (k // atlas.cols) * T, (k % atlas.cols) * T
            tile = (slice(r0, r0 + T), slice(c0, c0 + T))
            # rows follow t (v), columns follow s (u): a tile is the transpose of the grid
            for image, field in zip(geometry, (d[0, 0, c], p_s[c], p_t[c], p_st[c]), strict=True):
                image[tile] = field.transpose(1, 0, 2)
            for j, (res, f_s, f_t) in enumerate(shaped):
                values[j][tile] = np.stack([res.f[c], f_s[c], f_t[c]], -1).transpose(1, 0, 2)
                twist[j][tile] = np.gradient(f_s[c], h, axis=1).T
                valid[j][tile] = res.valid[c].T
    return ShapeTextures(atlas, values, twist, valid, *geometry)
