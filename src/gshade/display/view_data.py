"""The data of an HTML view (:mod:`gshade.display.html_view`): EXR channels packed bit for
bit, the picture as gshade's PNGs show it, the junctions' seams, the false-colour scales.

Packing (``pred2d-shuffle-deflate``): a stack of planes (n, height, width) of unsigned
integers (a float32 channel's bits as uint32, a half channel's as uint16, the picture's
8-bit R, G, B, A) is replaced by its two-dimensional difference modulo 2^bits
(r = u - left - up + up-left, zero outside the image: what PNG's and EXR's predictors do),
the residuals' bytes are split into byte planes (all low bytes, then the next ...), the
whole is compressed by zlib (deflate) and written in base64.  Smooth channels leave small
residuals whose high bytes are mostly 0, so a float32 channel of the teapot packs to about
half its size; the page decodes it with the browser's ``DecompressionStream`` and two
prefix sums.  :func:`unpack_planes` is the exact inverse, for tests.

Junction seams: where two neighbouring pixels lie on two patches (faces) that the EXR
header's ``junctions`` list as a junction, the pixel edge between them is a point of that
junction's visible seam; the page finds the junction nearest the cursor among them.
"""

from __future__ import annotations

import base64
import zlib
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from .colour import auto_range
from .colour_maps import colour_map_table

__all__ = [
    "ENCODING",
    "GEOMETRY_CHANNELS",
    "PICTURE_CHANNELS",
    "colour_table",
    "junction_seams",
    "pack_planes",
    "picture_rgba8",
    "scalar_scales",
    "unpack_planes",
]

#: The name of the packing, as the page's data records it.
ENCODING = "pred2d-shuffle-deflate"
#: The picture's channels (linear, premultiplied) and coverage.
PICTURE_CHANNELS = ("R", "G", "B", "A")
#: Channels that are not values of a shape function.
GEOMETRY_CHANNELS = ("P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z", "patch")
_UINT = {1: np.uint8, 2: np.uint16, 4: np.uint32}
#: Patch ids below this (2**31) form seams: a pair of them is one int64 key.
_IDS = 2**31


def pack_planes(planes: NDArray) -> str:
    """Planes of unsigned integers (n, height, width) or (height, width), packed: the 2-D
    difference modulo 2^bits, byte planes, zlib, base64 (see the module's notes)."""
    a = np.asarray(planes)
    if a.ndim == 2:
        a = a[None]
    if a.ndim != 3 or a.dtype.kind != "u" or a.dtype.itemsize not in _UINT:
        raise GshadeError(
            f"planes: expected an array of uint8, uint16 or uint32 of shape (n, height, "
            f"width), got shape {a.shape} and dtype {a.dtype}"
        )
    a = a.astype(a.dtype.newbyteorder("<"), copy=False)
    # unsigned differences wrap modulo 2^bits, as the page's sums do
    across = a.copy()
    across[:, :, 1:] -= a[:, :, :-1]
    residual = across.copy()
    residual[:, 1:, :] -= across[:, :-1, :]
    n, h, w = a.shape
    size = a.dtype.itemsize
    shuffled = np.ascontiguousarray(
        residual.reshape(n, h * w).view(np.uint8).reshape(n, h * w, size).transpose(0, 2, 1)
    )
    return base64.b64encode(zlib.compress(shuffled.tobytes(), 6)).decode("ascii")


def unpack_planes(text: str, dtype: type, shape: tuple[int, int, int]) -> NDArray:
    """The planes that :func:`pack_planes` packed into ``text`` (of that dtype and shape)."""
    kind = np.dtype(dtype).newbyteorder("<")
    n, h, w = shape
    raw = np.frombuffer(zlib.decompress(base64.b64decode(text)), np.uint8)
    residual = raw.reshape(n, kind.itemsize, h * w).transpose(0, 2, 1).copy().view(kind)
    residual = residual.reshape(n, h, w)
    return np.cumsum(np.cumsum(residual, axis=2, dtype=kind), axis=1, dtype=kind)


def picture_rgba8(channels: Mapping[str, NDArray]) -> NDArray[np.uint8] | None:
    """The picture as gshade's PNGs hold it (:func:`gshade.io.image.srgb8` of R, G, B
    divided by A, A linear), as planes (4, height, width); None without R, G and B."""
    from ..io.image import srgb8, straight_rgb

    if not all(c in channels for c in "RGB"):
        return None
    alpha = channels.get("A")
    if alpha is None:
        alpha = np.ones(np.shape(channels["R"]))
    return np.moveaxis(srgb8(straight_rgb(channels), alpha), -1, 0)


def _pair(junction: Mapping[str, object]) -> tuple[int, int] | None:
    """A junction's two patch ids, if they are two different integers in [0, 2**31)."""
    patches = junction.get("patches")
    if not isinstance(patches, (list, tuple)) or len(patches) != 2:
        return None
    a, b = patches
    ok = all(isinstance(p, (int, np.integer)) and 0 <= p < 2**31 for p in (a, b))
    return (int(a), int(b)) if ok and a != b else None


def junction_seams(patch: NDArray, junctions: list[dict]) -> NDArray[np.uint32]:
    """The pixel edges between two patches that form a listed junction: planes (3, 1, m) of
    (2 x, 2 y, junction index), (x, y) the edge's midpoint in pixel units (pixel (i, j)
    covers [i, i + 1] x [j, j + 1]), so that x is whole on a vertical edge, y on a
    horizontal one.  Of several junctions between one pair (a CAD model's faces meeting at
    two edges) the first is given.  Row-major order: horizontal neighbours first."""
    ids = np.rint(np.nan_to_num(np.asarray(patch, np.float64), nan=-1.0))
    index: dict[int, int] = {}  # (low id) * 2**31 + (high id) -> the first junction's number
    for j, row in enumerate(junctions):
        pair = _pair(row)
        if pair is not None:
            index.setdefault(min(pair) * _IDS + max(pair), j)
    if not index or ids.size == 0:
        return np.zeros((3, 1, 0), np.uint32)
    keys = np.fromiter(index, np.int64, len(index))
    order = np.argsort(keys)
    keys, numbers = keys[order], np.fromiter(index.values(), np.int64, len(index))[order]
    found = []
    for axis in (1, 0):  # neighbours along x (a vertical edge), then along y
        lo = [slice(None)] * 2
        hi = [slice(None)] * 2
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        left, right = ids[tuple(lo)], ids[tuple(hi)]
        small, large = np.minimum(left, right), np.maximum(left, right)
        ok = (small >= 0) & (large < _IDS) & (small != large)
        first = np.where(ok, small, 0).astype(np.int64)
        second = np.where(ok, large, 0).astype(np.int64)
        key = np.where(ok, first * _IDS + second, -1)
        at = np.minimum(np.searchsorted(keys, key), len(keys) - 1)
        junction = np.where(ok & (keys[at] == key), numbers[at], -1)
        y, x = np.nonzero(junction >= 0)
        x2, y2 = (2 * x + 2, 2 * y + 1) if axis == 1 else (2 * x + 1, 2 * y + 2)
        found.append(np.stack([x2, y2, junction[y, x]]))
    seams = np.concatenate(found, axis=1).astype(np.uint32)
    return seams[:, None, :]


def colour_table(name: str) -> str:
    """A matplotlib colour map as 256 sRGB colours, hex ``rrggbb`` each, concatenated."""
    table = colour_map_table(name)
    return bytes(np.round(table * 255).astype(np.uint8).ravel()).hex()


#: Channels whose false colours use their whole range (not a shape function's robust
#: one), in the order of their views.
_DATA_ORDER = (
    *("u", "v", "P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z"),
    *("refl.X", "refl.Y", "refl.Z", "R", "G", "B", "A"),
)
#: Unit vectors the page shows as RGB (no false-colour view of their own).
_VECTORS = (("N.X", "N.Y", "N.Z"), ("refl.X", "refl.Y", "refl.Z"))
_FIRST = ("f", "f.mean", "f2")


def _is_data(name: str) -> bool:
    return name in _DATA_ORDER or name.endswith(".var")


def scalar_scales(
    images: list[Mapping[str, NDArray]], settings: Mapping[str, object]
) -> dict[str, dict]:
    """The false-colour scale of each channel that no other view shows, common to all
    images: ``range`` [lo, hi], ``colormap``, ``signed`` and ``auto`` (whether the range is
    gshade's robust automatic one: the 1st to 99th percentile of the values on the surface,
    symmetric about 0 for a signed function).

    Shape-function channels (``f``, ``f.mean``, ``f2``, the AOVs and any other name) come
    first, with the robust range and the scene's own ``range`` (``value_range``) and
    ``colormap`` for the channel it colour-maps; then ``u``, ``v``, ``P``, and the
    picture's and normal's channels where there is no picture or normal view (an image
    without R, G and B, or without all of N), with the whole range of their values.

    ``settings`` is the first image's validated ``settings`` attribute
    (:func:`gshade.display.view_header.view_header`)."""
    from ..shape import SHAPE_FUNCTIONS

    shape = settings.get("shape")
    if not isinstance(shape, Mapping):
        shape = {}
    functions = {"f": shape.get("function"), "f.mean": shape.get("function")}
    functions["f2"] = shape.get("colour_function")
    mapped = {"colormap": "f", "both": "f2"}.get(str(shape.get("display")))
    seen: dict[str, None] = {}
    for channels in images:
        seen.update(dict.fromkeys(channels))
    picture = any(all(c in channels for c in "RGB") for channels in images)
    shown = {"patch"} | (set(PICTURE_CHANNELS) if picture else set())
    for vector in _VECTORS:
        if any(all(c in channels for c in vector) for channels in images):
            shown |= set(vector)
    first = [n for n in _FIRST if n in seen]
    first += [n for n in seen if n not in first and not _is_data(n) and n not in shown]
    data = [n for n in _DATA_ORDER if n in seen and n not in shown]
    data += [n for n in seen if n.endswith(".var") and n not in data and n not in shown]
    scales = {}
    for name in first + data:
        function = None if _is_data(name) else SHAPE_FUNCTIONS.get(str(functions.get(name, name)))
        signed = bool(function is not None and function.signed)
        values, valid = [], []
        for channels in images:
            if name not in channels:
                continue
            x = np.asarray(channels[name], np.float64)
            values.append(x.ravel())
            on = channels.get("patch")
            valid.append(
                (np.asarray(on) >= 0).ravel() if on is not None else np.isfinite(x).ravel()
            )
        x, ok = np.concatenate(values), np.concatenate(valid)
        whole = _is_data(name)
        lo, hi = auto_range(x, ok, signed=signed, percentiles=(0, 100) if whole else (1, 99))
        colormap = "coolwarm" if signed else "viridis"
        auto = not whole
        if name == mapped:
            colormap = str(shape.get("colormap") or colormap)
            given = shape.get("value_range", shape.get("range"))
            if isinstance(given, list) and len(given) == 2:
                lo, hi, auto = float(given[0]), float(given[1]), False
        scales[name] = {"range": [lo, hi], "colormap": colormap, "signed": signed, "auto": auto}
    return scales
