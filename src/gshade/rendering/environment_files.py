"""Environment map files: a user's latitude-longitude map read from OpenEXR or Radiance HDR,
checked before any native code sees it, and filtered down to at most
:data:`gshade.rendering.environment_maps.MAX_MAP_WIDTH` columns (the convention:
:mod:`gshade.rendering.environment_maps`)."""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError, show
from ..io.files import read_bytes
from ..io.image import read_exr
from ..limits import MAX_IMAGE_FILE_BYTES, MAX_IMAGE_SIDE
from ..runtime.native import captured_output
from ..runtime.variant import mitsuba
from .environment_maps import MAX_MAP_WIDTH

__all__ = ["MAX_FILE_WIDTH", "MIN_FILE_WIDTH", "read_environment_map"]

#: Widest map file accepted (before filtering down), and the narrowest.
MAX_FILE_WIDTH = MAX_IMAGE_SIDE
MIN_FILE_WIDTH = 4
#: The most bytes of a Radiance file's header (its text before the pixels) read.
_HDR_HEADER_BYTES = 65536
_HDR_LINE = 256
_HDR_SIZE = re.compile(rb"-Y ([0-9]{1,9}) \+X ([0-9]{1,9})")
_AXES = {b"-Y", b"+Y", b"-X", b"+X"}


def read_environment_map(path: str | os.PathLike) -> NDArray[np.float32]:
    """A user's latitude-longitude map, (H, W = 2H, 3) float32 linear RGB.

    OpenEXR (its R, G, B channels; others ignored) or Radiance HDR (``#?RADIANCE`` /
    ``#?RGBE``, ``FORMAT=32-bit_rle_rgbe``, resolution line ``-Y H +X W``), told apart by
    their first bytes.  A Radiance header is checked before Mitsuba reads the pixels.  W must
    lie in [4, 16384]; maps wider than :data:`MAX_MAP_WIDTH` (4096) are box-filtered down to
    4096 x 2048 (each new texel the exact mean of the area it covers).

    Raises
    ------
    GshadeError
        One line naming the file: missing, not a map file, a bad header, truncated or
        corrupt, not a lat-long size (W != 2H), or values that are NaN, infinite or negative.
    """
    path = Path(path)
    head = read_bytes(
        path, "an environment map", size=_HDR_HEADER_BYTES, limit=MAX_IMAGE_FILE_BYTES
    )
    if head.startswith(b"\x76\x2f\x31\x01"):
        channels, _ = read_exr(path)
        missing = [c for c in "RGB" if c not in channels]
        if missing:
            raise GshadeError(f"{path}: expected R, G and B channels, got {show(sorted(channels))}")
        h, w = channels["R"].shape
        _check_size(path, w, h)
        rgb = np.stack([channels[c] for c in "RGB"], axis=-1)
    elif head.startswith(b"#?"):
        h, w = _radiance_size(path, head)
        rgb = _read_radiance(path, w, h)
    else:
        raise GshadeError(
            f"{path}: expected an OpenEXR or Radiance HDR file (starting with bytes "
            f"76 2f 31 01 or '#?RADIANCE'), got {head[:8].hex(' ') or 'an empty file'}"
        )
    bad = ~np.isfinite(rgb) | (rgb < 0)
    if bad.any():
        j, i, c = (int(x) for x in np.argwhere(bad)[0])
        raise GshadeError(
            f"{path}: expected finite values >= 0, got {show(float(rgb[j, i, c]))} in "
            f"{'RGB'[c]} at row {j}, column {i} ({int(bad.sum())} such values)"
        )
    return _shrink(rgb) if w > MAX_MAP_WIDTH else np.ascontiguousarray(rgb, np.float32)


def _check_size(path: Path, w: int, h: int) -> None:
    if not MIN_FILE_WIDTH <= w <= MAX_FILE_WIDTH:
        raise GshadeError(
            f"{path}: expected a map {MIN_FILE_WIDTH} to {MAX_FILE_WIDTH} texels wide, got {w}x{h}"
        )
    if w != 2 * h:
        raise GshadeError(
            f"{path}: expected a latitude-longitude map (width = 2 x height), got {w}x{h}"
        )


def _radiance_size(path: Path, head: bytes) -> tuple[int, int]:
    """(H, W) from a Radiance header, refusing anything Mitsuba might read otherwise."""
    lines = head.split(b"\n")
    if lines[0] not in (b"#?RADIANCE", b"#?RGBE"):
        raise GshadeError(
            f"{path}: expected a Radiance HDR file starting with '#?RADIANCE' or '#?RGBE', "
            f"got {show(lines[0][:20].decode('latin-1'))}"
        )
    rgbe = False
    for number, line in enumerate(lines[1:-1], start=2):  # the last may be cut off
        if len(line) > _HDR_LINE or not all(32 <= b < 127 or b == 9 for b in line):
            raise GshadeError(
                f"{path}: header line {number}: expected printable text of at most "
                f"{_HDR_LINE} bytes, got {len(line)} bytes"
            )
        if line.startswith(b"FORMAT="):
            if line != b"FORMAT=32-bit_rle_rgbe":
                raise GshadeError(
                    f"{path}: expected FORMAT=32-bit_rle_rgbe, got {show(line.decode())}"
                )
            rgbe = True
            continue
        size = _HDR_SIZE.fullmatch(line)
        if size is None and _AXES & set(re.split(rb"[\s,]+", line)):
            raise GshadeError(
                f"{path}: expected the resolution line '-Y H +X W', got {show(line.decode())}"
            )
        if size is not None:
            if not rgbe:
                raise GshadeError(f"{path}: expected FORMAT=32-bit_rle_rgbe before the size")
            h, w = int(size.group(1)), int(size.group(2))
            _check_size(path, w, h)
            return h, w
    raise GshadeError(
        f"{path}: expected a resolution line '-Y H +X W' in the first "
        f"{_HDR_HEADER_BYTES} bytes, got none"
    )


def _read_radiance(path: Path, w: int, h: int) -> NDArray[np.float32]:
    mi = mitsuba()
    try:
        with captured_output() as native:
            bitmap = mi.Bitmap(str(path), mi.Bitmap.FileFormat.RGBE)
            rgb = np.array(bitmap, dtype=np.float32)
    except (RuntimeError, ValueError, OSError, TypeError, MemoryError) as exc:
        said = native.line() or (str(exc).splitlines() or [type(exc).__name__])[0]
        raise GshadeError(
            f"{path}: cannot read the Radiance HDR file (truncated or corrupt?): {said}"
        ) from None
    if rgb.shape != (h, w, 3):
        raise GshadeError(f"{path}: expected {w}x{h} RGB pixels, got an array {rgb.shape}")
    return rgb


def _shrink(rgb: NDArray, width: int = 0) -> NDArray[np.float32]:
    """Box-filter (H, W, 3) down to (width / 2, width, 3) (default :data:`MAX_MAP_WIDTH`):
    each new texel the exact mean of the old texels' area it covers."""
    width = width or MAX_MAP_WIDTH
    across = _shrink_rows(rgb.transpose(1, 0, 2), width).transpose(1, 0, 2)
    return _shrink_rows(across, width // 2)


def _shrink_rows(a: NDArray, m: int) -> NDArray[np.float32]:
    """Axis 0 of (n, k, 3) box-filtered to m: prefix sums interpolated at k n / m, in
    chunks along axis 1."""
    n = a.shape[0]
    edges = np.arange(m + 1) * (n / m)
    whole = np.minimum(np.floor(edges).astype(np.intp), n - 1)
    part = (edges - whole)[:, None, None]
    out = np.empty((m, *a.shape[1:]), np.float32)
    for s in range(0, a.shape[1], 256):
        chunk = a[:, s : s + 256]
        prefix = np.zeros((n + 1, *chunk.shape[1:]), np.float64)
        np.cumsum(chunk, axis=0, dtype=np.float64, out=prefix[1:])
        at = prefix[whole] + part * chunk[whole]
        out[:, s : s + 256] = (at[1:] - at[:-1]) / (n / m)
    return out
