"""Images: OpenEXR (any named float channels, with header attributes) and 8-bit sRGB PNG.

Both writers are atomic: the image goes to a temporary file in the target's directory that
then replaces the target (:func:`os.replace`), so a reader never sees a half-written file and
a failed write leaves an existing target untouched (and no temporary file behind).

EXR channels are 2-D arrays (height, width) named freely ("R", "P.X", "patch"); they are
stored as 32-bit FLOAT, or 16-bit HALF where asked, and read back as float32
(:func:`read_exr_planes`: HALF channels as float16).  Header attributes are strings,
integers (EXR ``int``, 32 bits) and floats (EXR ``double``).
"""

from __future__ import annotations

import os
import stat
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np
import OpenEXR
from numpy.typing import ArrayLike, NDArray

from ..errors import GshadeError
from ..limits import MAX_IMAGE_FILE_BYTES
from ..runtime.native import NativeOutput, captured_output
from .files import read_bytes
from .outputs import atomic_write

__all__ = [
    "ExrWindow",
    "atomic_write",
    "exr_writer",
    "linear_to_srgb",
    "png_writer",
    "read_exr",
    "read_exr_header",
    "read_exr_planes",
    "read_exr_windows",
    "srgb8",
    "straight_rgb",
    "write_exr",
    "write_png",
]

#: The first four bytes of every OpenEXR file.
_EXR_MAGIC = b"\x76\x2f\x31\x01"

#: Attributes the EXR writer sets itself: not accepted in ``header``, not returned by
#: :func:`read_exr`.
_STRUCTURAL = frozenset(
    {
        "channels",
        "compression",
        "dataWindow",
        "displayWindow",
        "lineOrder",
        "pixelAspectRatio",
        "screenWindowCenter",
        "screenWindowWidth",
        "type",
    }
)
#: Further attributes with a meaning to EXR readers (tiled, multi-part, multi-view files).
_RESERVED = _STRUCTURAL | {"tiles", "name", "version", "chunkCount", "view", "multiView"}

_INT32 = (-(2**31), 2**31 - 1)


# --------------------------------------------------------------------------- EXR


def _validate_channels(
    path: Path, channels: Mapping[str, ArrayLike], half: set[str] | None
) -> dict[str, NDArray]:
    if not isinstance(channels, Mapping) or not channels:
        raise GshadeError(
            f"{path}: channels: expected a non-empty dict name -> array, got {channels!r}"
        )
    half = set() if half is None else set(half)
    unknown = sorted(half - set(channels))
    if unknown:
        raise GshadeError(
            f"{path}: half: expected names of channels ({', '.join(channels)}), got {unknown[0]!r}"
        )
    out: dict[str, NDArray] = {}
    shape = None
    for name, data in channels.items():
        if not isinstance(name, str) or not name:
            raise GshadeError(f"{path}: channels: expected non-empty string names, got {name!r}")
        a = np.asarray(data)
        if a.dtype.kind not in "biuf":
            raise GshadeError(
                f"{path}: channel {name!r}: expected an array of real numbers, got dtype {a.dtype}"
            )
        if a.ndim != 2 or 0 in a.shape:
            raise GshadeError(
                f"{path}: channel {name!r}: expected a 2-D array (height, width), got shape "
                f"{a.shape}"
            )
        if shape is None:
            shape = a.shape
        elif a.shape != shape:
            first = next(iter(channels))
            raise GshadeError(
                f"{path}: channel {name!r}: expected the shape {shape} of channel {first!r}, "
                f"got {a.shape}"
            )
        with np.errstate(over="ignore"):
            out[name] = np.ascontiguousarray(a, dtype=np.float16 if name in half else np.float32)
    return out


def _validate_header(path: Path, header: Mapping[str, object] | None) -> dict[str, object]:
    out: dict[str, object] = {}
    for key, value in (header or {}).items():
        if not isinstance(key, str) or not key:
            raise GshadeError(f"{path}: header: expected non-empty string keys, got {key!r}")
        if key in _RESERVED:
            raise GshadeError(
                f"{path}: header {key}: expected a name that is not a standard EXR attribute "
                f"(e.g. 'gshade:{key}'), got {key!r}"
            )
        if isinstance(value, str):
            out[key] = value
        elif isinstance(value, (bool, np.bool_)):
            raise GshadeError(
                f"{path}: header {key}: expected a string, an integer or a float, got {value!r}"
            )
        elif isinstance(value, (int, np.integer)):
            if not _INT32[0] <= int(value) <= _INT32[1]:
                raise GshadeError(
                    f"{path}: header {key}: expected an integer in [-2**31, 2**31) (EXR int), "
                    f"got {int(value)}"
                )
            out[key] = int(value)
        elif isinstance(value, (float, np.floating)):
            out[key] = np.array([float(value)], dtype=np.float64)  # written as EXR 'double'
        else:
            raise GshadeError(
                f"{path}: header {key}: expected a string, an integer or a float, got "
                f"{type(value).__name__} {value!r}"
            )
    return out


def exr_writer(
    path: str | os.PathLike,
    channels: Mapping[str, ArrayLike],
    header: Mapping[str, str | float | int] | None = None,
    half: set[str] | None = None,
) -> Callable[[str], None]:
    """The channels and header checked now (errors name ``path``), as a function that
    writes them to a file name given later (a temporary: see :mod:`gshade.io.outputs`).

    See :func:`write_exr` for the parameters."""
    target = Path(path)
    data = _validate_channels(target, channels, half)
    attributes = _validate_header(target, header)
    # lossless ZIP per scanline: read everywhere, and faster to write than 16-line ZIP
    attributes["compression"] = OpenEXR.ZIPS_COMPRESSION
    attributes["type"] = OpenEXR.scanlineimage

    def write(name: str) -> None:
        _use_all_cores()
        # OpenEXR.File replaces the values of the dict it is given: hand it a fresh one.
        OpenEXR.File(dict(attributes), dict(data)).write(name)

    return write


def write_exr(
    path: str | os.PathLike,
    channels: Mapping[str, ArrayLike],
    header: Mapping[str, str | float | int] | None = None,
    half: set[str] | None = None,
) -> Path:
    """Write a single-part scanline OpenEXR file (ZIP compressed), atomically.

    Parameters
    ----------
    path : path-like
        The target; an existing file is replaced only once the new one is complete.
    channels : dict of str to array_like
        Channel name -> 2-D array (height, width) of real numbers, all of the same shape.
        Names are free ("R", "P.X", "patch"); EXR stores them sorted.
    header : dict, optional
        Extra attributes: str (EXR ``string``), int (``int``, 32 bits) or float
        (``double``).  Standard EXR attribute names (``channels``, ``compression``, ...)
        are refused; a prefix such as ``gshade:`` avoids clashes.
    half : set of str, optional
        Channels to store as 16-bit HALF; the others are stored as 32-bit FLOAT.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    GshadeError
        For bad channels or header values, or if the file cannot be written.
    """
    return atomic_write(path, ".exr", exr_writer(path, channels, header, half))


def _use_all_cores() -> None:
    """Let OpenEXR compress (and decompress) scanline blocks on every usable core: its
    global pool has no threads by default.  Raised, never lowered (a program's larger pool
    stays), before each read and write: reading the pool's size costs nothing."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    if OpenEXR.global_thread_count() < cores:
        OpenEXR.set_global_thread_count(cores)


def _plain(value: object) -> object:
    """A header value as a plain Python value where it has one (double -> float, ...)."""
    if isinstance(value, np.ndarray) and value.shape == (1,) and value.dtype == np.float64:
        return float(value[0])
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    return value


@dataclass(frozen=True)
class ExrWindow:
    """An EXR data or display window: the pixels (x_min, y_min) to (x_max, y_max), both
    included, in the image's pixel coordinates."""

    x_min: int
    y_min: int
    x_max: int
    y_max: int

    @property
    def width(self) -> int:
        return self.x_max - self.x_min + 1

    @property
    def height(self) -> int:
        return self.y_max - self.y_min + 1

    @classmethod
    def of_shape(cls, shape: tuple[int, ...]) -> ExrWindow:
        """The window at the origin of an array of shape (height, width)."""
        return cls(0, 0, int(shape[1]) - 1, int(shape[0]) - 1)

    def __str__(self) -> str:
        return (
            f"({self.x_min}, {self.y_min})-({self.x_max}, {self.y_max}) "
            f"({self.width}x{self.height})"
        )


def read_exr(path: str | os.PathLike) -> tuple[dict[str, NDArray[np.float32]], dict[str, object]]:
    """Read an OpenEXR file (its first part).

    Parameters
    ----------
    path : path-like

    Returns
    -------
    channels : dict of str to ndarray
        Channel name -> float32 array (height, width), in the file's (sorted) order.
    header : dict
        The attributes other than the structural ones (channels, compression, data and
        display windows, line order, pixel aspect ratio, screen window, type): what
        :func:`write_exr` was given as ``header``; doubles and ints as Python numbers.

    Raises
    ------
    GshadeError
        If the file is missing, unreadable, not an OpenEXR file, truncated or corrupt.
    """
    channels, header, _, _ = read_exr_windows(path)
    return channels, header


def read_exr_windows(
    path: str | os.PathLike,
) -> tuple[dict[str, NDArray[np.float32]], dict[str, object], ExrWindow, ExrWindow]:
    """:func:`read_exr`, and the file's data window (where the channels' pixels lie: row 0,
    column 0 of each array is its (x_min, y_min)) and display window."""
    planes, header, data, display = read_exr_planes(path)
    channels = {name: np.asarray(plane, dtype=np.float32) for name, plane in planes.items()}
    return channels, header, data, display


def read_exr_planes(
    path: str | os.PathLike,
) -> tuple[
    dict[str, NDArray[np.float16] | NDArray[np.float32]], dict[str, object], ExrWindow, ExrWindow
]:
    """:func:`read_exr_windows`, with HALF channels as float16 arrays (the same values in
    half the memory of float32); the other channels are float32 as there."""
    path = Path(path)
    _check_size(path)  # before anything of it is read
    magic = read_bytes(path, "an OpenEXR file", size=4)  # refuses FIFOs, devices
    if magic != _EXR_MAGIC:
        raise GshadeError(
            f"{path}: expected an OpenEXR file (starting with bytes 76 2f 31 01), "
            f"got {magic.hex(' ') or 'an empty file'}"
        )
    _use_all_cores()
    try:
        # libOpenEXR prints its own diagnostics of a corrupt file: gshade shows one line
        with captured_output() as native:
            exr = OpenEXR.File(str(path), separate_channels=True)
            raw_header = exr.header()
            raw_channels = exr.channels()
    except (RuntimeError, ValueError, OSError, TypeError) as exc:
        said = _library_said(native, path) or str(exc)
        raise GshadeError(
            f"{path}: cannot read the OpenEXR file (truncated or corrupt?): {said}"
        ) from None
    channels: dict[str, NDArray[np.float16] | NDArray[np.float32]] = {}
    for name, channel in raw_channels.items():
        pixels = getattr(channel, "pixels", None)
        if not isinstance(pixels, np.ndarray) or pixels.ndim != 2 or pixels.dtype.kind not in "uif":
            raise GshadeError(
                f"{path}: channel {name!r}: expected flat (not deep) 2-D pixel data, got "
                f"{type(pixels).__name__}"
            )
        kept = np.float16 if pixels.dtype == np.float16 else np.float32
        channels[name] = np.ascontiguousarray(pixels, dtype=kept)
    header = {k: _plain(v) for k, v in raw_header.items() if k not in _STRUCTURAL}
    shape = next(iter(channels.values())).shape if channels else (0, 0)
    data = _window(raw_header.get("dataWindow")) or ExrWindow.of_shape(shape)
    display = _window(raw_header.get("displayWindow")) or data
    if channels and (data.height, data.width) != shape:
        raise GshadeError(
            f"{path}: expected pixels filling the data window {data}, got {shape[1]}x{shape[0]}"
        )
    return channels, header, data, display


def _check_size(path: Path) -> None:
    """Refuse a regular file larger than :data:`gshade.limits.MAX_IMAGE_FILE_BYTES` before
    anything of it is read (a missing file, a FIFO ... are :func:`read_bytes`'s to refuse)."""
    try:
        info = os.stat(path)
    except (OSError, ValueError):
        return
    size = info.st_size
    if stat.S_ISREG(info.st_mode) and size > MAX_IMAGE_FILE_BYTES:
        raise GshadeError(
            f"{path}: expected an image file of at most {MAX_IMAGE_FILE_BYTES} bytes "
            f"({MAX_IMAGE_FILE_BYTES / 2**30:g} GB), got {size} bytes ({size / 2**30:.2f} GB)"
        )


def _window(value: object) -> ExrWindow | None:
    """An EXR box attribute ((x_min, y_min), (x_max, y_max)) as a window; None if it is not
    one."""
    try:
        box = np.asarray(value, dtype=np.int64)
    except (TypeError, ValueError):
        return None
    if box.shape != (2, 2):
        return None
    return ExrWindow(int(box[0, 0]), int(box[0, 1]), int(box[1, 0]), int(box[1, 1]))


def read_exr_header(path: str | os.PathLike) -> dict[str, object]:
    """The header attributes of an OpenEXR file (as :func:`read_exr` returns them), without
    reading the pixels."""
    path = Path(path)
    _check_size(path)  # before anything of it is read
    magic = read_bytes(path, "an OpenEXR file", size=4)  # refuses FIFOs, devices
    if magic != _EXR_MAGIC:
        raise GshadeError(f"{path}: expected an OpenEXR file")
    try:
        with captured_output() as native:
            raw = OpenEXR.File(str(path), header_only=True).header()
    except (RuntimeError, ValueError, OSError, TypeError) as exc:
        said = _library_said(native, path) or str(exc)
        raise GshadeError(f"{path}: cannot read the OpenEXR header: {said}") from None
    return {k: _plain(v) for k, v in raw.items() if k not in _STRUCTURAL}


def _library_said(native: NativeOutput, path: Path) -> str:
    """libOpenEXR's own first error line ("(EXR_ERR_...) ..."), without the path it starts
    with; "" if it printed nothing."""
    line = native.line(marker="EXR_ERR")
    return line.removeprefix(f"{path}: ").removeprefix(f"{path}:")


# --------------------------------------------------------------------------- PNG


def linear_to_srgb(linear: ArrayLike) -> NDArray[np.float64]:
    """The sRGB transfer function (IEC 61966-2-1) of linear values, clipped to [0, 1].

    ``12.92 x`` for ``x <= 0.0031308``, else ``1.055 x^(1/2.4) - 0.055``; NaN becomes 0.
    """
    x = np.nan_to_num(np.asarray(linear, dtype=np.float64), nan=0.0, posinf=1.0, neginf=0.0)
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


def _to_uint8(x: NDArray) -> NDArray[np.uint8]:
    return np.round(np.clip(x, 0.0, 1.0) * 255.0).astype(np.uint8)


def straight_rgb(channels: Mapping[str, NDArray]) -> NDArray[np.float64]:
    """R, G, B divided by A where A > 0 (EXR colour is premultiplied by the coverage),
    shape (height, width, 3)."""
    rgb = np.stack([channels[c] for c in "RGB"], -1).astype(np.float64)
    a = channels.get("A")
    if a is None:
        return rgb
    return rgb / np.where(a > 0, a, 1.0)[..., None]


@cache
def _srgb8_steps() -> NDArray[np.float64]:
    """The linear values t_k (k = 1 ... 255) from which the 8-bit sRGB code is k: the inverse
    transfer function at (k - 1/2) / 255, ``s / 12.92`` up to 0.04045, else
    ``((s + 0.055) / 1.055)^2.4``."""
    s = (np.arange(1, 256) - 0.5) / 255.0
    return np.where(s <= 0.04045, s / 12.92, ((s + 0.055) / 1.055) ** 2.4)


def srgb8(rgb: ArrayLike, alpha: ArrayLike | None = None) -> NDArray[np.uint8]:
    """A PNG's pixels: linear RGB (not premultiplied) sRGB-encoded and rounded to 8 bits,
    shape (height, width, 3), or (height, width, 4) with the alpha stored linearly
    (NaN -> 0, clipped to [0, 1]).

    The code round(255 srgb(x)) is the number of steps t_k <= x (:func:`_srgb8_steps`): one
    search among 255 values instead of a power per value (the same codes, but at a float's
    exact tie).

    Examples
    --------
    >>> srgb8([[[0.0, 0.18, 1.0]]]).tolist()
    [[[0, 118, 255]]]
    """
    x = np.asarray(rgb, dtype=np.float64)
    image = np.searchsorted(_srgb8_steps(), x, side="right").astype(np.uint8)
    image[np.isnan(x)] = 0  # NaN sorts after every step
    if alpha is None:
        return image
    a = np.nan_to_num(np.asarray(alpha, dtype=np.float64), nan=0.0, posinf=1.0, neginf=0.0)
    return np.concatenate([image, _to_uint8(a)[..., None]], axis=2)


def png_writer(
    path: str | os.PathLike, rgb: ArrayLike, alpha: ArrayLike | None = None
) -> Callable[[str], None]:
    """The picture checked and encoded now (errors name ``path``), as a function that writes
    it to a file name given later.  See :func:`write_png` for the parameters."""
    import PIL.Image

    target = Path(path)
    rgb = np.asarray(rgb)
    if rgb.dtype.kind not in "biuf" or rgb.ndim != 3 or rgb.shape[2] != 3 or 0 in rgb.shape:
        raise GshadeError(
            f"{target}: rgb: expected an array of real numbers of shape (height, width, 3), got "
            f"shape {rgb.shape} and dtype {rgb.dtype}"
        )
    if alpha is not None:
        a = np.asarray(alpha)
        if a.dtype.kind not in "biuf" or a.shape != rgb.shape[:2]:
            raise GshadeError(
                f"{target}: alpha: expected an array of real numbers of shape {rgb.shape[:2]}, "
                f"got shape {a.shape} and dtype {a.dtype}"
            )
    image = srgb8(rgb, alpha)

    def write(name: str) -> None:
        # zlib's fastest level: a few per cent larger than its default, in half the time
        PIL.Image.fromarray(image).save(name, format="PNG", compress_level=1)

    return write


def write_png(path: str | os.PathLike, rgb: ArrayLike, alpha: ArrayLike | None = None) -> Path:
    """Write linear RGB (and straight alpha) as an 8-bit sRGB PNG, atomically.

    Parameters
    ----------
    path : path-like
    rgb : array_like, shape (height, width, 3)
        Linear colour, not premultiplied by alpha; clipped to [0, 1] (NaN -> 0), then
        sRGB-encoded and rounded to 8 bits.
    alpha : array_like, shape (height, width), optional
        Coverage in [0, 1], stored linearly (an RGBA PNG); without it the PNG is RGB.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    GshadeError
        For arrays of the wrong shape or type, or if the file cannot be written.
    """
    return atomic_write(path, ".png", png_writer(path, rgb, alpha))
