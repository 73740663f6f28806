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
import json
import math
import zlib
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from .colour import auto_range

__all__ = [
    "ENCODING",
    "GEOMETRY_CHANNELS",
    "PICTURE_CHANNELS",
    "colour_table",
    "junction_list",
    "junction_seams",
    "pack_planes",
    "picture_rgba8",
    "plain_header",
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


def _finite(value: object) -> object:
    """A value for strict JSON: non-finite floats as text ("inf", "nan")."""
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, dict):
        return {str(k): _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def plain_header(header: Mapping[str, object]) -> dict[str, object]:
    """The header's attributes as strict-JSON values: strings, numbers (non-finite ones as
    text), anything else as its text."""
    out: dict[str, object] = {}
    for key, value in header.items():
        if isinstance(value, (np.integer, np.floating)):
            value = value.item()
        if isinstance(value, bool) or not isinstance(value, (str, int, float)):
            value = str(value)
        out[str(key)] = _finite(value)
    return out


def parsed(header: Mapping[str, object], key: str) -> dict:
    """A header attribute holding JSON (``settings``, ``junctions``) as a dict; {} where it
    is missing or not a JSON object."""
    text = header.get(key)
    if not isinstance(text, str):
        return {}
    try:
        value = json.loads(text)
    except ValueError:
        return {}
    return _finite(value) if isinstance(value, dict) else {}  # type: ignore[return-value]


def junction_list(header: Mapping[str, object]) -> tuple[list[dict], dict[str, str]]:
    """The junctions the header lists (each a dict: ``class``, ``patches``, ``sides`` or
    ``edge``, and the measures where recorded) and the classes' colours (#rrggbb, sRGB)."""
    from ..io.image import linear_to_srgb

    meta = parsed(header, "junctions")
    rows = [j for j in meta.get("junctions", []) if isinstance(j, dict)]
    rows = [j for j in rows if _pair(j) is not None]
    colours = {}
    for cls, rgb in (meta.get("colours") or {}).items():
        try:
            s = np.round(linear_to_srgb(np.asarray(rgb, float)[:3]) * 255).astype(int)
        except (TypeError, ValueError):
            continue
        if s.shape == (3,):
            colours[str(cls)] = "#" + "".join(f"{int(c):02x}" for c in s)
    return rows, colours


def _pair(junction: dict) -> tuple[int, int] | None:
    try:
        a, b = (int(p) for p in junction.get("patches", ()))
    except (TypeError, ValueError):
        return None
    return (a, b) if a != b and min(a, b) >= 0 else None


def junction_seams(patch: NDArray, junctions: list[dict]) -> NDArray[np.uint32]:
    """The pixel edges between two patches that form a listed junction: planes (3, 1, m) of
    (2 x, 2 y, junction index), (x, y) the edge's midpoint in pixel units (pixel (i, j)
    covers [i, i + 1] x [j, j + 1]), so that x is whole on a vertical edge, y on a
    horizontal one.  Of several junctions between one pair (a CAD model's faces meeting at
    two edges) the first is given.  Row-major order: horizontal neighbours first."""
    ids = np.rint(np.nan_to_num(np.asarray(patch, np.float64), nan=-1.0))
    index: dict[tuple[int, int], int] = {}
    for j, row in enumerate(junctions):
        pair = _pair(row)
        if pair is not None:
            index.setdefault((min(pair), max(pair)), j)
    if not index or ids.size == 0:
        return np.zeros((3, 1, 0), np.uint32)
    top = int(max(max(k) for k in index)) + 1
    lookup = np.full(top * top, -1, np.int64)
    for (first, second), number in index.items():
        lookup[first * top + second] = number
    found = []
    for axis in (1, 0):  # neighbours along x (a vertical edge), then along y
        lo = [slice(None)] * 2
        hi = [slice(None)] * 2
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        left, right = ids[tuple(lo)], ids[tuple(hi)]
        small, large = np.minimum(left, right), np.maximum(left, right)
        ok = (small >= 0) & (large < top) & (small != large)
        key = np.where(ok, small * top + large, 0).astype(np.int64)
        junction = np.where(ok, lookup[key], -1)
        y, x = np.nonzero(junction >= 0)
        x2, y2 = (2 * x + 2, 2 * y + 1) if axis == 1 else (2 * x + 1, 2 * y + 2)
        found.append(np.stack([x2, y2, junction[y, x]]))
    seams = np.concatenate(found, axis=1).astype(np.uint32)
    return seams[:, None, :]


def colour_table(name: str) -> str:
    """A matplotlib colour map as 256 sRGB colours, hex ``rrggbb`` each, concatenated."""
    import matplotlib

    table = matplotlib.colormaps[name](np.linspace(0.0, 1.0, 256))[:, :3]
    return bytes(np.round(table * 255).astype(np.uint8).ravel()).hex()


def scalar_scales(
    images: list[Mapping[str, NDArray]], header: Mapping[str, object]
) -> dict[str, dict]:
    """The false-colour scale of each shape-function channel (``f``, ``f.mean``, ``f2``,
    the AOVs) and of ``u`` and ``v``, common to all images: ``range`` [lo, hi],
    ``colormap``, ``signed`` and ``auto`` (whether the range is gshade's robust automatic
    one: the 1st to 99th percentile of the values on the surface, symmetric about 0 for a
    signed function).  The scene's own ``range`` and ``colormap`` where it gives them for
    the channel it colour-maps."""
    from ..shape import SHAPE_FUNCTIONS

    shape = parsed(header, "settings").get("shape", {})
    functions = {"f": shape.get("function"), "f.mean": shape.get("function")}
    functions["f2"] = shape.get("colour_function")
    mapped = {"colormap": "f", "both": "f2"}.get(str(shape.get("display")))
    names: list[str] = []
    for channels in images:
        names += [n for n in channels if n not in names]
    scales = {}
    for name in names:
        if name in PICTURE_CHANNELS or name in GEOMETRY_CHANNELS or name.endswith(".var"):
            continue
        function = SHAPE_FUNCTIONS.get(str(functions.get(name, name)))
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
        parameter = name in ("u", "v")
        lo, hi = auto_range(x, ok, signed=signed, percentiles=(0, 100) if parameter else (1, 99))
        colormap = "coolwarm" if signed else "viridis"
        auto = not parameter
        if name == mapped:
            colormap = str(shape.get("colormap") or colormap)
            given = shape.get("range")
            if isinstance(given, list) and len(given) == 2:
                lo, hi, auto = float(given[0]), float(given[1]), False
        scales[name] = {"range": [lo, hi], "colormap": colormap, "signed": signed, "auto": auto}
    return scales
