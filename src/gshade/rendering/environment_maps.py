"""Environment maps: latitude-longitude images of the world around a mirror surface, and their
exact lookups.

The convention, used everywhere in gshade: a map of H rows and W = 2H columns holds the
radiance arriving from world direction d = (x, y, z) at

* column ``c = phi / (2 pi) W``, phi = atan2(y, x) in [0, 2 pi) the azimuth (0 at +x,
  increasing towards +y);
* row ``r = theta / pi H``, theta = acos(z) the polar angle from +z (row 0 = +z, the zenith).

Texels are cells: texel (i, j) covers columns [i, i + 1) and rows [j, j + 1), its centre at
(i + 0.5, j + 0.5).  A map rotated by rho degrees about z turns with the world: direction d
looks up azimuth phi - rho.

:class:`SummedArea` box-filters a map exactly (the mean of the piecewise-constant map over a
rectangle of texel coordinates, columns wrapping round the azimuth);
:func:`lightbox` generates gshade's built-in studio, :func:`stripe_map` a map of azimuthal
stripes, and :func:`gshade.rendering.environment_files.read_environment_map` reads a user's map
(OpenEXR or Radiance HDR).
"""

from __future__ import annotations

from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..display.colour import DARK, LIGHT
from ..errors import GshadeError, show
from ..runtime.backend import NUMPY, ArrayOps

__all__ = [
    "MAX_MAP_WIDTH",
    "SummedArea",
    "direction_to_map",
    "lightbox",
    "map_position",
    "map_to_direction",
    "stripe_map",
    "table_integral",
]

#: Widest map kept: wider maps read from files are box-filtered down to this width.
MAX_MAP_WIDTH = 4096
_TWO_PI = 2.0 * np.pi


# ------------------------------------------------------------------------- the convention


def direction_to_map(
    d: ArrayLike, width: int, height: int, rotation: float = 0.0
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Continuous texel coordinates (column, row) of world directions.

    ``column = ((atan2(y, x) - rho) mod 2 pi) / (2 pi) W`` in [0, W) and
    ``row = acos(z) / pi H`` in [0, H], rho = ``rotation`` in radians; theta is computed as
    atan2(sqrt(x^2 + y^2), z), accurate near the poles where acos is not.

    Parameters
    ----------
    d : array_like, shape (..., 3)
        Directions, of any length (a zero vector reads as the zenith).
    width, height : int
        The map's W and H.
    rotation : float
        Degrees about +z that the map is turned with the world.

    Returns
    -------
    column, row : ndarray, shape (...)

    Examples
    --------
    >>> c, r = direction_to_map([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1]], 8, 4)
    >>> c.tolist(), r.tolist()
    ([0.0, 2.0, 0.0, 0.0], [2.0, 2.0, 0.0, 4.0])
    >>> direction_to_map([[0, 1, 0]], 8, 4, rotation=90.0)[0].tolist()
    [0.0]
    """
    v = np.asarray(d, dtype=np.float64)
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    return map_position(x, y, z, width, height, float(np.radians(rotation)), NUMPY)


def map_position(
    x: Any, y: Any, z: Any, width: int, height: int, rotation: float, ops: ArrayOps
) -> tuple[Any, Any]:
    """:func:`direction_to_map` of the direction (x, y, z), ``rotation`` in radians: written
    once for numpy and for the renderer's Dr.Jit arrays (``ops``)."""
    phi = ops.atan2(y, x) - rotation
    phi = phi - _TWO_PI * ops.floor(phi / _TWO_PI)
    column = phi / _TWO_PI * width
    column = ops.select(column >= width, column - width, column)  # phi rounded up to 2 pi
    column = ops.select(column < 0, column * 0, column)
    return column, ops.atan2(ops.sqrt(x * x + y * y), z) / np.pi * height


def map_to_direction(
    column: ArrayLike, row: ArrayLike, width: int, height: int, rotation: float = 0.0
) -> NDArray[np.float64]:
    """World unit directions at continuous texel coordinates: :func:`direction_to_map`'s
    inverse.

    ``phi = 2 pi column / W + rho``, ``theta = pi row / H``,
    ``d = (sin theta cos phi, sin theta sin phi, cos theta)``; texel (i, j)'s centre is
    (i + 0.5, j + 0.5).

    Returns
    -------
    ndarray, shape (..., 3)

    Examples
    --------
    >>> map_to_direction([2.0, 0.0], [2.0, 0.0], 8, 4).round(12).tolist()
    [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    """
    phi = np.asarray(column, dtype=np.float64) / width * _TWO_PI + np.radians(rotation)
    theta = np.asarray(row, dtype=np.float64) / height * np.pi
    phi, theta = np.broadcast_arrays(phi, theta)
    s = np.sin(theta)
    return np.stack([s * np.cos(phi), s * np.sin(phi), np.cos(theta)], axis=-1)


# ---------------------------------------------------------------------- summed-area table


def _turns(c: NDArray, w: int) -> tuple[NDArray, NDArray]:
    """(k, c - k w) with c - k w in [0, w]: whole turns and the column within the ring
    (c / w may underflow to -0 for tiny negative c: corrected here)."""
    turns = np.floor(c / w)
    rest = c - turns * w
    turns = turns - (rest < 0)
    return turns, np.where(rest < 0, rest + w, rest)


def table_integral(
    tables: list[Any], width: int, height: int, c: Any, r: Any, ops: ArrayOps
) -> list[Any]:
    """F(c, r), the integral of a map over [0, c) x [0, r) in texel coordinates, per channel:
    bilinear interpolation of its summed-area tables (each flat, row-major (H + 1, W + 1),
    see :class:`SummedArea`), columns wrapping (``F(c + k W, r) = F(c, r) + k F(W, r)``),
    r in [0, H].  Written once for numpy and for the renderer's Dr.Jit arrays (``ops``,
    :class:`gshade.runtime.backend.ArrayOps`; c and r of the tables' precision, float64).

    Examples
    --------
    >>> m = np.arange(6.0).reshape(2, 3)
    >>> sat = SummedArea(m)
    >>> [float(x) for x in table_integral([sat.table[..., 0].ravel()], 3, 2, 4.0, 2.0, NUMPY)]
    [18.0]
    """
    turns = ops.floor(c / width)
    c = c - turns * width
    turns = ops.select(c < 0, turns - 1, turns)  # c / w rounded up past a whole turn
    c = ops.select(c < 0, c + width, c)
    i = ops.minimum(ops.floor(c), width - 1.0)
    j = ops.minimum(ops.floor(r), height - 1.0)
    a, b = c - i, r - j
    row = width + 1.0
    k00, k_end = j * row + i, j * row + width
    out = []
    for t in tables:
        top = ops.gather(t, k00) * (1 - a) + ops.gather(t, k00 + 1) * a
        bottom = ops.gather(t, k00 + row) * (1 - a) + ops.gather(t, k00 + row + 1) * a
        whole = ops.gather(t, k_end) * (1 - b) + ops.gather(t, k_end + row) * b
        out.append(top * (1 - b) + bottom * b + turns * whole)
    return out


class SummedArea:
    """Exact box filtering of a piecewise-constant map (H, W) or (H, W, C).

    The table ``S[r, c]`` (float64, shape (H + 1, W + 1, C)) sums the texels above and left
    of the corner (c, r); bilinear interpolation of S is the exact integral
    ``F(c, r)`` of the map over [0, c) x [0, r), so the integral over [c0, c1) x [r0, r1) is
    ``F(c1, r1) - F(c0, r1) - F(c1, r0) + F(c0, r0)``.  Columns wrap,
    ``F(c + k W, r) = F(c, r) + k F(W, r)``; rows clamp to [0, H].  Memory: 8 (H + 1)
    (W + 1) C bytes.

    Examples
    --------
    >>> m = np.arange(24, dtype=np.float32).reshape(4, 6)
    >>> sat = SummedArea(m)
    >>> float(sat.box_mean(1.0, 4.0, 0.0, 2.0)), float(m[0:2, 1:4].mean())
    (5.0, 5.0)
    >>> float(sat.box_mean(5.0, 7.0, 0.0, 1.0)), float(m[0, [5, 0]].mean())  # wraps
    (2.5, 2.5)
    >>> float(sat.point(2.5, 1.5)), float(m[1, 2])
    (8.0, 8.0)
    """

    def __init__(self, image: ArrayLike) -> None:
        m = np.asarray(image)
        if m.ndim not in (2, 3) or m.shape[0] < 1 or m.shape[1] < 1:
            raise GshadeError(f"environment map: expected an array (H, W[, C]), got {m.shape}")
        self._flat = m.ndim == 2
        self.map = m[..., None] if self._flat else m
        self.height, self.width = int(m.shape[0]), int(m.shape[1])
        table = np.zeros((self.height + 1, self.width + 1, self.map.shape[2]), np.float64)
        inner = table[1:, 1:]
        np.cumsum(self.map, axis=0, dtype=np.float64, out=inner)
        np.cumsum(inner, axis=1, out=inner)
        self.table = table

    def channel_tables(self) -> list[NDArray[np.float64]]:
        """The table of each channel, flat (row-major (H + 1, W + 1)): what
        :func:`table_integral` reads."""
        table = self.table
        return [np.ascontiguousarray(table[..., k]).ravel() for k in range(table.shape[2])]

    @cached_property
    def _channels(self) -> list[NDArray[np.float64]]:
        return self.channel_tables()

    def _integral(self, c: NDArray, r: NDArray) -> NDArray:
        """F(c, r) for any column c (wrapping) and r in [0, H]."""
        values = table_integral(self._channels, self.width, self.height, c, r, NUMPY)
        return np.stack(values, axis=-1)

    def box_mean(self, c0: ArrayLike, c1: ArrayLike, r0: ArrayLike, r1: ArrayLike) -> NDArray:
        """Mean of the map over [c0, c1) x [r0, r1) in texel coordinates (broadcast).

        Columns wrap (a rectangle at least W wide covers the whole ring once); rows clamp to
        [0, H].  A rectangle of zero area reads :meth:`point` at its centre.  One at most a
        texel wide or high is summed from the <= 2 columns or rows it touches, so thin
        rectangles lose no precision to differences of large sums.

        Returns
        -------
        ndarray, shape (...) or (..., C), float64
        """
        a0, a1, b0, b1 = np.broadcast_arrays(*(np.asarray(x, np.float64) for x in (c0, c1, r0, r1)))
        if not (np.all(np.isfinite([a0, a1, b0, b1])) and np.all(a0 <= a1) and np.all(b0 <= b1)):
            raise GshadeError("box_mean: expected finite corners with c0 <= c1 and r0 <= r1")
        a1 = np.minimum(a1, a0 + self.width)
        b0, b1 = np.clip(b0, 0, self.height), np.clip(b1, 0, self.height)
        thin_c, thin_r = a1 - a0 <= 1, b1 - b0 <= 1
        empty = (a1 <= a0) | (b1 <= b0)
        out = np.empty((*a0.shape, self.map.shape[2]))
        for where, mean in (
            (~thin_c & ~thin_r, self._wide_mean),
            (thin_c & ~empty, self._narrow_columns),
            (thin_r & ~thin_c & ~empty, self._narrow_rows),
        ):
            if where.any():
                out[where] = mean(a0[where], a1[where], b0[where], b1[where])
        if empty.any():
            out[empty] = self._point((a0[empty] + a1[empty]) / 2, (b0[empty] + b1[empty]) / 2)
        return out[..., 0] if self._flat else out

    def _wide_mean(self, c0: NDArray, c1: NDArray, r0: NDArray, r1: NDArray) -> NDArray:
        """Rectangles over a texel on each side: the table's four corners."""
        total = (
            self._integral(c1, r1)
            - self._integral(c0, r1)
            - self._integral(c1, r0)
            + self._integral(c0, r0)
        )
        return total / ((c1 - c0) * (r1 - r0))[..., None]

    def _narrow_columns(self, c0: NDArray, c1: NDArray, r0: NDArray, r1: NDArray) -> NDArray:
        """Rectangles at most a texel wide: the <= 2 columns touched, weighted by their
        overlaps (no difference of large sums across a thin rectangle)."""
        i = np.floor(c0)
        wa = np.minimum(c1, i + 1) - c0
        wb = np.maximum(c1 - (i + 1), 0.0)
        i0 = np.mod(i, self.width).astype(np.intp)
        i1 = np.mod(i0 + 1, self.width)
        fa = (wa / (wa + wb))[:, None]  # fractions first: no products of two tiny numbers
        return fa * self._column(i0, r0, r1) + (1 - fa) * self._column(i1, r0, r1)

    def _column(self, i: NDArray, r0: NDArray, r1: NDArray) -> NDArray:
        """Mean of column i over [r0, r1): from the <= 2 texels touched if at most a texel
        high, else from the column's prefix sums."""
        h, m, t = self.height, self.map, self.table
        j = np.minimum(np.floor(r0), h - 1)
        ha = np.minimum(r1, j + 1) - r0
        hb = np.maximum(r1 - (j + 1), 0.0)
        j0 = j.astype(np.intp)
        j1 = np.minimum(j0 + 1, h - 1)
        fa = (ha / (ha + hb))[:, None]
        direct = fa * m[j0, i] + (1 - fa) * m[j1, i]

        def prefix(r: NDArray) -> NDArray:
            k = np.minimum(np.floor(r).astype(np.intp), h - 1)
            return t[k, i + 1] - t[k, i] + (r - k)[:, None] * m[k, i]

        prefixed = (prefix(r1) - prefix(r0)) / (r1 - r0)[:, None]
        return np.where((r1 - r0 <= 1)[:, None], direct, prefixed)

    def _narrow_rows(self, c0: NDArray, c1: NDArray, r0: NDArray, r1: NDArray) -> NDArray:
        """Rectangles at most a texel high (and over a texel wide): the <= 2 rows touched,
        each integrated along its own prefix sums."""
        h, w, m, t = self.height, self.width, self.map, self.table
        j = np.minimum(np.floor(r0), h - 1)
        ha = np.minimum(r1, j + 1) - r0
        hb = np.maximum(r1 - (j + 1), 0.0)
        j0 = j.astype(np.intp)
        j1 = np.minimum(j0 + 1, h - 1)

        def prefix(row: NDArray, c: NDArray) -> NDArray:
            turns, c = _turns(c, w)
            i = np.minimum(np.floor(c).astype(np.intp), w - 1)
            whole = t[row + 1, w] - t[row, w]
            return t[row + 1, i] - t[row, i] + (c - i)[:, None] * m[row, i] + turns[:, None] * whole

        fa = (ha / (ha + hb))[:, None]
        total = fa * (prefix(j0, c1) - prefix(j0, c0)) + (1 - fa) * (
            prefix(j1, c1) - prefix(j1, c0)
        )
        return total / (c1 - c0)[:, None]

    def point(self, c: ArrayLike, r: ArrayLike) -> NDArray:
        """Bilinear interpolation of the texel centres at (c, r): columns wrap, rows clamp
        (for footprints smaller than a texel).

        Returns
        -------
        ndarray, shape (...) or (..., C), float64
        """
        cc, rr = np.broadcast_arrays(np.asarray(c, np.float64), np.asarray(r, np.float64))
        value = self._point(cc, rr)
        return value[..., 0] if self._flat else value

    def _point(self, c: NDArray, r: NDArray) -> NDArray:
        w, h = self.width, self.height
        x = c - 0.5
        y = np.clip(np.asarray(r, np.float64) - 0.5, 0.0, h - 1)
        i = np.floor(x)
        j = np.minimum(np.floor(y), max(h - 2, 0))
        a, b = (x - i)[..., None], (y - j)[..., None]
        i0 = np.mod(i, w).astype(np.intp)
        i1 = np.mod(i0 + 1, w)
        j0 = j.astype(np.intp)
        j1 = np.minimum(j0 + 1, h - 1)
        m = self.map
        top = m[j0, i0] * (1 - a) + m[j0, i1] * a
        bottom = m[j1, i0] * (1 - a) + m[j1, i1] * a
        return top * (1 - b) + bottom * b


# --------------------------------------------------------------------------- built-in maps


def _check_width(width: object) -> int:
    if (
        not isinstance(width, (int, np.integer))
        or isinstance(width, bool)
        or not 64 <= width <= 8192
        or width % 2
    ):
        raise GshadeError(f"width: expected an even integer in [64, 8192], got {show(width)}")
    return int(width)


def _smoothstep(x: NDArray) -> NDArray:
    t = np.clip(x, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def lightbox(strips: int = 5, strip_width: float = 8.0, width: int = 2048) -> NDArray[np.float32]:
    """gshade's studio: overhead strip lights over a soft floor, (width / 2, width, 3)
    float32 linear grey.

    Strip k is the set of directions whose angle from the zenith in the x-z plane,
    ``alpha = atan2(x, z)``, lies within ``strip_width / 2`` degrees of
    ``alpha_k`` (``strips`` angles evenly over [-60, 60] degrees; 0 for one strip), and whose
    ``|atan2(y, z)| <= 60`` degrees: strips parallel to world y, radiance 1.0.  Their edges are
    smoothsteps ``min(1, strip_width / 2)`` degrees wide.  Ceiling and walls are 0.02; the
    floor (theta > 90 degrees) falls linearly in theta from 0.25 at the horizon (a
    1-degree smoothstep from the walls) to 0.08 at the nadir.  Each texel holds the value at
    its centre.

    Examples
    --------
    >>> m = lightbox(strips=3, width=64)
    >>> m.shape, m.dtype.name
    ((32, 64, 3), 'float32')
    >>> float(m[0, 0, 0]), float(m[-1, 0, 0]) < 0.1 < float(m[17, 0, 0])
    (1.0, True)
    """
    if (
        not isinstance(strips, (int, np.integer))
        or isinstance(strips, bool)
        or not (1 <= strips <= 64)
    ):
        raise GshadeError(f"strips: expected an integer in [1, 64], got {show(strips)}")
    if (
        not isinstance(strip_width, (int, float, np.integer, np.floating))
        or isinstance(strip_width, bool)
        or not 0 < strip_width < 90
    ):
        raise GshadeError(f"strip_width: expected degrees in (0, 90), got {show(strip_width)}")
    w = _check_width(width)
    h = w // 2
    half = float(strip_width) / 2
    edge = min(0.5, half / 2)  # half the soft edge's width
    centres = np.linspace(-60.0, 60.0, strips) if strips > 1 else np.zeros(1)
    out = np.empty((h, w, 3), np.float32)
    columns = np.arange(w) + 0.5
    for start in range(0, h, 128):  # bounded temporaries
        rows = np.arange(start, min(start + 128, h)) + 0.5
        d = map_to_direction(columns[None, :], rows[:, None], w, h)
        alpha = np.degrees(np.arctan2(d[..., 0], d[..., 2]))
        beta = np.degrees(np.abs(np.arctan2(d[..., 1], d[..., 2])))
        lit = np.zeros(alpha.shape)
        for centre in centres:
            off = np.abs(alpha - centre)
            lit = np.maximum(lit, _smoothstep((half + edge - off) / (2 * edge)))
        lit *= _smoothstep((60.0 + 0.5 - beta) / 1.0)
        theta = np.degrees(np.arccos(np.clip(d[..., 2], -1, 1)))
        floor = 0.25 + (0.08 - 0.25) * np.clip((theta - 90.0) / 90.0, 0, 1)
        below = _smoothstep((theta - 89.5) / 1.0)
        background = 0.02 + (floor - 0.02) * below
        out[start : start + len(rows)] = (background + (1.0 - background) * lit)[..., None]
    return out


def stripe_map(count: int, width: int = 2048) -> NDArray[np.float32]:
    """``count`` stripes in azimuth, (width / 2, width, 3) float32: texel column i is
    ``DARK`` where ``floor(phi / (2 pi / count))`` is even at its centre phi, else ``LIGHT``
    (:mod:`gshade.display.colour`'s stripe colours).

    Examples
    --------
    >>> m = stripe_map(4, 64)
    >>> m.shape, bool(m[5, 0, 0] < m[5, 16, 0]), bool((m[:, 0] == m[0, 0]).all())
    ((32, 64, 3), True, True)
    """
    w = _check_width(width)
    if (
        not isinstance(count, (int, np.integer))
        or isinstance(count, bool)
        or not (1 <= count <= w // 2)
    ):
        raise GshadeError(f"count: expected an integer in [1, {w // 2}], got {show(count)}")
    phi = (np.arange(w) + 0.5) / w * _TWO_PI
    light = (np.floor(phi / (_TWO_PI / count)).astype(np.int64) % 2 == 1)[:, None]
    row = np.where(light, np.asarray(LIGHT), np.asarray(DARK)).astype(np.float32)
    return np.ascontiguousarray(np.broadcast_to(row, (w // 2, w, 3)))
