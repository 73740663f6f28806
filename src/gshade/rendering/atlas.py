"""The texture atlas: a tile of texels per patch, its addressing and its lookups.

Written once, for numpy arrays (the textures, the exact channels) and Dr.Jit arrays (the
integrator), through :class:`gshade.runtime.backend.ArrayOps`.

Layout.  Patch k's tile is S_k columns by T_k rows of texels, its first texel at column
c0_k and row r0_k of an atlas of W x H texels.  Texel (row r, column c) has its centre at
atlas coordinates ((c + 0.5) / W, (r + 0.5) / H), and the texel centres of a tile sit on the
grid s_i = i / (S_k - 1), t_j = j / (T_k - 1) of the patch's normalised parameters: s maps
to the continuous texel column X = c0_k + s (S_k - 1), t to the row Y = r0_k + t (T_k - 1).
Tiles start on multiples of a block of B texels and each covers whole blocks, so that a
*block map* (one patch number per B x B block) tells the tile a point lies in: the block of
texel coordinate X is floor((X + 0.5) / B).  All tiles square and of one size
(``Atlas.for_patches``: B = T, the tiles in rows of ceil(sqrt(n))) or each its own
(``Atlas.for_tiles``: sides in multiples of B, packed into shelves, tallest first), so that
a small face costs few texels, and a long thin one few across.

Lookups.  A point's cell is the square of four texel centres around it inside its own tile
(never reading a neighbouring patch's texels); within it, a value with its s, t and st
derivatives is interpolated bicubically (Hermite: exact for bicubic polynomials, error
O(h^4), spacings 1 / (S_k - 1) and 1 / (T_k - 1)), a slope bilinearly.

Packed textures.  The integrator fetches all a texel's channels at once: :data:`GEOMETRY`
and :data:`SHAPE` name the channels of its two kinds of packed texture.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from dataclasses import field as dataclass_field
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..runtime.backend import NUMPY, ArrayOps

__all__ = [
    "BLOCK",
    "GEOMETRY",
    "SHAPE",
    "Atlas",
    "Cell",
    "Packing",
    "Tiles",
    "atlas_coordinate",
    "bilinear",
    "cell_centre",
    "hermite",
    "locate_cell",
    "texel_coordinate",
    "tile_bounds",
    "tile_of",
]


def atlas_coordinate(start: Any, s: Any, tile: int, size: int) -> Any:
    """Atlas coordinate of normalised parameter ``s`` in [0, 1] of a tile whose first texel
    is ``start``: (start + 0.5 + s (T - 1)) / size."""
    return (start + 0.5 + s * (tile - 1)) / size


def texel_coordinate(x: Any, size: int) -> Any:
    """Continuous texel coordinate of atlas coordinate x: X = x size - 0.5 (texel centres at
    whole numbers)."""
    return x * size - 0.5


def tile_bounds(start: Any, tile: Any, size: int) -> tuple[Any, Any]:
    """Atlas coordinates of a tile's first and last texel centres (s = 0 and s = 1)."""
    return atlas_coordinate(start, 0.0, tile, size), atlas_coordinate(start, 1.0, tile, size)


def cell_centre(i: Any, size: int) -> Any:
    """Atlas coordinate halfway between texels i and i + 1: a bilinear lookup there reads
    exactly those two texels (along each axis)."""
    return (i + 1.0) / size


class Tiles(NamedTuple):
    """Where the tiles are, as arrays of one library (numpy, or Dr.Jit for the
    integrator): the block size ``block`` (B), the blocks per atlas row ``blocks_wide`` and
    column ``blocks_high``, the patch of each block (row-major, ``patch_of_block``) and per
    patch its tile's first column ``c0``, first row ``r0``, columns ``columns`` (S) and rows
    ``rows`` (T)."""

    block: int
    blocks_wide: int
    blocks_high: int
    patch_of_block: Any
    c0: Any
    r0: Any
    columns: Any
    rows: Any


class Cell(NamedTuple):
    """The cell around a point: its first texel (column i, row j), the point's position
    (a, b) in [0, 1]^2 within it, the first texel (c0, r0) of its tile and the tile's
    columns and rows (S, T)."""

    i: Any
    j: Any
    a: Any
    b: Any
    c0: Any
    r0: Any
    columns: Any
    rows: Any

    @property
    def spacing(self) -> tuple[Any, Any]:
        """The texel spacings in s and t: 1 / (S - 1), 1 / (T - 1)."""
        return 1.0 / (self.columns - 1.0), 1.0 / (self.rows - 1.0)


def tile_of(X: Any, Y: Any, tiles: Tiles, ops: ArrayOps) -> Any:
    """The patch whose tile holds texel coordinates (X, Y): the patch of the block
    (floor((X + 0.5) / B), floor((Y + 0.5) / B)), clipped into the atlas."""
    B = tiles.block
    bx = ops.clip(ops.floor((X + 0.5) / B), 0.0, tiles.blocks_wide - 1.0)
    by = ops.clip(ops.floor((Y + 0.5) / B), 0.0, tiles.blocks_high - 1.0)
    return ops.gather(tiles.patch_of_block, by * tiles.blocks_wide + bx)


def locate_cell(x: Any, y: Any, width: int, height: int, tiles: Tiles, ops: ArrayOps) -> Cell:
    """The cell of atlas coordinates (x, y) in an atlas of ``width`` x ``height`` texels:
    i = clip(floor(X), c0, c0 + S - 2), a = clip(X - i, 0, 1) with X the texel coordinate
    and c0, S its tile's first column and columns (rows likewise)."""
    X = texel_coordinate(x, width)
    Y = texel_coordinate(y, height)
    k = tile_of(X, Y, tiles, ops)
    c0, r0, S, T = (ops.gather(a, k) for a in (tiles.c0, tiles.r0, tiles.columns, tiles.rows))
    i = ops.clip(ops.floor(X), c0, c0 + S - 2)
    j = ops.clip(ops.floor(Y), r0, r0 + T - 2)
    a = ops.clip(X - i, 0.0, 1.0)
    b = ops.clip(Y - j, 0.0, 1.0)
    return Cell(i, j, a, b, c0, r0, S, T)


#: the corners of a cell, in the order its texels are fetched: (i, j), (i+1, j), (i, j+1),
#: (i+1, j+1)
CORNERS = ((0, 0), (1, 0), (0, 1), (1, 1))


def hermite(corners: Sequence, a: Any, b: Any, spacing: tuple, channels: Sequence[int]) -> Any:
    """Bicubic Hermite interpolation at (a, b) of a cell from the value, d/ds, d/dt and
    d2/dsdt at its corners (``channels`` of each corner texel, in that order), with
    ``spacing`` = (1 / (S - 1), 1 / (T - 1)) the texel spacings in the normalised parameters
    (numbers, or one per point):
    sum over the corners of H0 H0' value + H1 H0' d/ds + H0 H1' d/dt + H1 H1' d2/dsdt, with
    the cubic Hermite bases H0(a) = 1 - a^2 (3 - 2a) (or a^2 (3 - 2a)) and H1(a) =
    a (1 - a)^2 h (or -a^2 (1 - a) h)."""
    hs, ht = spacing
    va = (1 - a * a * (3 - 2 * a), a * a * (3 - 2 * a))
    da = (a * (1 - a) * (1 - a) * hs, -a * a * (1 - a) * hs)
    vb = (1 - b * b * (3 - 2 * b), b * b * (3 - 2 * b))
    db = (b * (1 - b) * (1 - b) * ht, -b * b * (1 - b) * ht)
    total = 0.0
    for texel, (di, dj) in zip(corners, CORNERS, strict=True):
        weights = (va[di] * vb[dj], da[di] * vb[dj], va[di] * db[dj], da[di] * db[dj])
        for w, channel in zip(weights, channels, strict=True):
            total = total + w * texel[channel]
    return total


def bilinear(corners: Sequence, a: Any, b: Any, channel: int) -> Any:
    """Bilinear interpolation at (a, b) of one channel of a cell's corner texels."""
    c = [texel[channel] for texel in corners]
    return (c[0] * (1 - a) + c[1] * a) * (1 - b) + (c[2] * (1 - a) + c[3] * a) * b


@dataclass(frozen=True)
class Packing:
    """Named quantities side by side in the channels of one packed texture: ``fields`` are
    (name, number of channels).  A quantity q with derivatives has them as q_s, q_t, q_st."""

    fields: tuple[tuple[str, int], ...]

    @property
    def size(self) -> int:
        """Channels per texel."""
        return sum(n for _, n in self.fields)

    def channel(self, name: str, component: int = 0) -> int:
        """The channel of one component of a quantity."""
        at = 0
        for field, n in self.fields:
            if field == name:
                if not 0 <= component < n:
                    raise IndexError(f"Packing: {name} has {n} components, not {component + 1}")
                return at + component
            at += n
        raise KeyError(f"Packing: no quantity {name!r}")

    def hermite_channels(self, name: str, component: int = 0) -> tuple[int, int, int, int]:
        """The channels of q, q_s, q_t and q_st for :func:`hermite`."""
        names = (name, f"{name}_s", f"{name}_t", f"{name}_st")
        a, b, c, d = (self.channel(q, component) for q in names)
        return a, b, c, d

    def pack(self, arrays: Mapping[str, NDArray]) -> NDArray[np.float32]:
        """One (H, W, channels) float32 image of the quantities' (H, W) or (H, W, n) images:
        no copy when they are already its channels, in order (views of one packed image)."""
        parts = []
        for name, n in self.fields:
            array = arrays[name]
            array = array[..., None] if array.ndim == 2 else array
            if array.shape[-1] != n:
                raise ValueError(f"Packing: {name} has {array.shape[-1]} channels, expected {n}")
            parts.append(array)
        whole = _packed_base(parts, self.size)
        if whole is not None:
            return whole
        return np.ascontiguousarray(np.concatenate(parts, -1), dtype=np.float32)


def _packed_base(parts: list[NDArray], size: int) -> NDArray[np.float32] | None:
    """The packed float32 (H, W, size) image whose consecutive channels the parts are, in
    order, or None."""
    base = parts[0].base
    if not (
        isinstance(base, np.ndarray)
        and base.dtype == np.float32
        and base.ndim == 3
        and base.shape[-1] == size
        and base.flags.c_contiguous
        and all(p.base is base and p.shape[:2] == base.shape[:2] for p in parts)
    ):
        return None
    start = base.__array_interface__["data"][0]
    at = 0
    for p in parts:
        if p.__array_interface__["data"][0] != start + at * base.itemsize:
            return None
        at += p.shape[-1]
    return base if at == size else None


#: the surface: p, p_s, p_t, p_st (3 coordinates each; s, t the normalised parameters)
GEOMETRY = Packing((("p", 3), ("p_s", 3), ("p_t", 3), ("p_st", 3)))
#: a shape function: f, f_s, f_t, f_st and its validity (1 where f is defined, else 0)
SHAPE = Packing((("f", 1), ("f_s", 1), ("f_t", 1), ("f_st", 1), ("valid", 1)))


#: Texels per block of an atlas of tiles of several sizes (``Atlas.for_tiles``): the sizes
#: are multiples of it, and so are the tiles' first rows and columns.
BLOCK = 8


@dataclass(frozen=True, eq=False)
class Atlas:
    """Where each patch's tile lies: ``sizes[k]`` = (S_k, T_k) texels (columns along s,
    rows along t), its first texel at row ``row0[k]`` and column ``col0[k]`` of a ``width``
    x ``height`` atlas, all multiples of ``block`` (B), which the sides are too, or B = T
    for square tiles of one size T."""

    sizes: NDArray[np.int64]
    row0: NDArray[np.int64]
    col0: NDArray[np.int64]
    width: int
    height: int
    block: int
    patch_of_block: NDArray[np.int64] = dataclass_field(init=False, repr=False)

    def __post_init__(self) -> None:
        bw, bh = self.width // self.block, self.height // self.block
        blocks = np.zeros((bh, bw), dtype=np.int64)  # a gap's blocks: patch 0 (never read)
        B = self.block
        for k, (r0, c0, (S, T)) in enumerate(zip(self.row0, self.col0, self.sizes, strict=True)):
            ns, nt = -(-int(S) // B), -(-int(T) // B)  # the blocks the tile covers
            blocks[r0 // B : r0 // B + nt, c0 // B : c0 // B + ns] = k
        object.__setattr__(self, "patch_of_block", blocks.ravel())

    @classmethod
    def for_patches(cls, n_patches: int, tile: int) -> Atlas:
        """Tiles of ``tile`` x ``tile`` texels, in rows of ceil(sqrt(n)): patch k's at
        column (k mod cols) T and row (k div cols) T."""
        T = int(tile)
        cols = int(np.ceil(np.sqrt(n_patches)))
        k = np.arange(n_patches)
        rows = int(np.ceil(n_patches / cols))
        sizes = np.full((n_patches, 2), T)
        return cls(sizes, (k // cols) * T, (k % cols) * T, cols * T, rows * T, T)

    @classmethod
    def for_tiles(cls, sizes: Sequence | NDArray) -> Atlas:
        """Tiles of the given sizes ((S_k, T_k) each, or T_k for square ones), packed into
        shelves: the tallest first, left to right in rows about sqrt(sum S_k T_k) texels
        wide, each shelf as high as its first tile.  Square tiles all alike (any side >= 2)
        give :meth:`for_patches`' layout; else each side is a multiple of :data:`BLOCK`."""
        T = np.asarray(sizes, dtype=np.int64)
        if T.ndim == 1:
            T = np.stack([T, T], -1)
        if T.size and (T == T[0, 0]).all() and T[0, 0] >= 2:  # one size: the square layout
            return cls.for_patches(len(T), int(T[0, 0]))
        if T.size == 0 or (T % BLOCK).any() or (T < BLOCK).any():
            raise ValueError(f"Atlas.for_tiles: sides must be multiples of {BLOCK}, got {T}")
        area = float((T[:, 0] * T[:, 1]).sum())
        width = max(int(T[:, 0].max()), BLOCK * int(np.ceil(np.sqrt(area) / BLOCK)))
        row0, col0 = np.zeros(len(T), np.int64), np.zeros(len(T), np.int64)
        x = y = shelf = 0
        for k in np.lexsort((-T[:, 0], -T[:, 1])):  # tallest first, then widest
            if x + T[k, 0] > width:  # the next shelf
                x, y, shelf = 0, y + shelf, 0
            row0[k], col0[k] = y, x
            x += int(T[k, 0])
            shelf = max(shelf, int(T[k, 1]))
        return cls(T, row0, col0, width, y + shelf, BLOCK)

    @property
    def tile(self) -> int:
        """The largest tile's longer side."""
        return int(self.sizes.max())

    @property
    def texels(self) -> int:
        """The texels the tiles hold (the atlas's gaps aside)."""
        return int((self.sizes[:, 0] * self.sizes[:, 1]).sum())

    def spacing(self, patch: NDArray | int) -> tuple[Any, Any]:
        """The texel spacings in the normalised parameters of the tiles of ``patch``:
        1 / (S - 1) in s, 1 / (T - 1) in t."""
        n = self.sizes[patch] - 1.0
        return 1.0 / n[..., 0], 1.0 / n[..., 1]

    def tiles(self, ops: ArrayOps = NUMPY, array: Any = None) -> Tiles:
        """The layout as :class:`Tiles` of arrays made by ``array`` (default numpy's)."""
        make = np.asarray if array is None else array
        columns, rows = self.sizes[:, 0], self.sizes[:, 1]
        return Tiles(
            self.block,
            self.width // self.block,
            self.height // self.block,
            make(self.patch_of_block.astype(np.float64)),
            *(make(a.astype(np.float64)) for a in (self.col0, self.row0, columns, rows)),
        )

    def tile_start(self, patch: NDArray | int) -> tuple[Any, Any]:
        """First texel row r0 and column c0 of the tiles of patches ``patch``."""
        return self.row0[patch], self.col0[patch]

    def tile_slices(self, patch: int) -> tuple[slice, slice]:
        """The rows and columns of patch ``patch``'s tile in an atlas image."""
        r0, c0 = int(self.row0[patch]), int(self.col0[patch])
        S, T = (int(x) for x in self.sizes[patch])
        return slice(r0, r0 + T), slice(c0, c0 + S)

    def all_tile_slices(self) -> list[tuple[slice, slice]]:
        """:meth:`tile_slices` of every patch, in order."""
        return [self.tile_slices(k) for k in range(len(self.sizes))]

    def texel_positions(self, patch: NDArray, st: NDArray) -> tuple[NDArray, NDArray]:
        """Continuous texel column X and row Y of normalised parameters ``st`` (N, 2) on
        patches ``patch`` (N,): X = c0 + s (S - 1), Y = r0 + t (T - 1)."""
        S, T = self.sizes[patch, 0], self.sizes[patch, 1]
        return self.col0[patch] + st[:, 0] * (S - 1), self.row0[patch] + st[:, 1] * (T - 1)

    def texcoords(self, patch: NDArray, st: NDArray) -> NDArray[np.float64]:
        """Atlas coordinates of normalised parameters ``st`` (N, 2) on patches ``patch`` (N,)."""
        X, Y = self.texel_positions(patch, st)
        return np.stack([(X + 0.5) / self.width, (Y + 0.5) / self.height], -1)

    def locate(self, xy: NDArray) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """Patch index and normalised parameters of atlas coordinates ``xy`` (..., 2)."""
        X = texel_coordinate(xy[..., 0], self.width)
        Y = texel_coordinate(xy[..., 1], self.height)
        k = tile_of(X, Y, self.tiles(), NUMPY).astype(np.int64)
        s = np.clip((X - self.col0[k]) / (self.sizes[k, 0] - 1), 0.0, 1.0)
        t = np.clip((Y - self.row0[k]) / (self.sizes[k, 1] - 1), 0.0, 1.0)
        return k, np.stack([s, t], -1)

    def cell(self, xy: NDArray) -> Cell:
        """The cells of atlas coordinates ``xy`` (N, 2) (numpy)."""
        return locate_cell(xy[:, 0], xy[:, 1], self.width, self.height, self.tiles(), NUMPY)

    def corners(self, image: NDArray, cell: Cell) -> list[NDArray]:
        """The four corner texels of the cells (in :data:`CORNERS` order) of an
        (H, W, channels) image, each as an array (channels, N)."""
        i, j = cell.i.astype(np.int64), cell.j.astype(np.int64)
        return [np.moveaxis(image[j + dj, i + di], -1, 0) for di, dj in CORNERS]

    def interpolate(
        self, image: NDArray, packing: Packing, name: str, xy: NDArray, component: int = 0
    ) -> NDArray[np.float64]:
        """One quantity of a packed image at atlas coordinates ``xy`` (N, 2), bicubically
        (:func:`hermite`) where the packing holds its derivatives, else bilinearly (numpy,
        float64: the integrator's lookup in double precision)."""
        cell = self.cell(xy)
        corners = self.corners(np.asarray(image, dtype=np.float64), cell)
        try:
            channels = packing.hermite_channels(name, component)
        except KeyError:
            return bilinear(corners, cell.a, cell.b, packing.channel(name, component))
        return hermite(corners, cell.a, cell.b, cell.spacing, channels)
