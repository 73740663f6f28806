"""Newell's teapot format: bicubic Bézier patches given by indices into a vertex list.

Format (the original teaset files: teapot, teacup, teaspoon, ...)::

    N                       number of patches
    i1, i2, ..., i16        N lines: a 4x4 control net, row-major, 1-based vertex indices
    M                       number of vertices
    x, y, z                 M lines

Numbers may be separated by commas and/or blanks; blank lines are skipped.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..errors import SurfaceDataError
from ..geometry import BezierPatch
from ..limits import MAX_DATA_FILE_BYTES, MAX_MAGNITUDE
from .files import describe_fields, read_bytes

if TYPE_CHECKING:
    from collections.abc import Iterator

__all__ = ["parse_newell", "read_newell"]

#: Rotations taking data with the given up axis to gshade's z-up frame (right-handed).
_TO_Z_UP = {
    "z": np.eye(3),
    "y": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),  # (x, y, z) -> (x, -z, y)
    "x": np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]),  # (x, y, z) -> (y, z, x)
}


def _lines(text: str) -> Iterator[tuple[int, list[str]]]:
    for number, line in enumerate(text.splitlines(), start=1):
        fields = line.replace(",", " ").split()
        if fields:
            yield number, fields


def parse_newell(text: str, source: str = "<string>") -> tuple[NDArray, NDArray]:
    """Parse Newell's format.

    Returns
    -------
    vertices : ndarray, shape (M, 3)
    nets : ndarray of int, shape (N, 4, 4)
        0-based vertex indices of each patch's control net.

    Raises
    ------
    SurfaceDataError
        Naming the source, the line, what was expected and what was found.
    """
    lines = _lines(text)

    def fail(line: int | None, msg: str) -> SurfaceDataError:
        where = f"{source}, line {line}" if line is not None else source
        return SurfaceDataError(f"{where}: {msg}")

    def count(what: str) -> tuple[int, int]:
        try:
            number, fields = next(lines)
        except StopIteration:
            raise fail(None, f"expected the number of {what}, found the end of the file") from None
        if len(fields) != 1 or not fields[0].isdigit():
            raise fail(
                number,
                f"expected the number of {what} (one integer), found {describe_fields(fields)}",
            )
        if int(fields[0]) > len(text):  # each needs a line: more than the file could hold
            raise fail(
                number, f"expected the number of {what}, found a count above the file's size"
            )
        return number, int(fields[0])

    _, n_patches = count("patches")
    nets = np.empty((n_patches, 16), dtype=np.int64)
    net_lines = []
    for k in range(n_patches):
        try:
            number, fields = next(lines)
        except StopIteration:
            raise fail(None, f"expected {n_patches} patch lines, found {k}") from None
        if len(fields) != 16 or not all(f.isdigit() for f in fields):
            raise fail(
                number,
                f"expected 16 vertex indices (positive integers) for patch {k + 1}, "
                f"found {describe_fields(fields)}",
            )
        nets[k] = [int(f) for f in fields]
        net_lines.append(number)
    _, n_vertices = count("vertices")
    vertices = np.empty((n_vertices, 3))
    for k in range(n_vertices):
        try:
            number, fields = next(lines)
        except StopIteration:
            raise fail(None, f"expected {n_vertices} vertex lines, found {k}") from None
        try:
            if len(fields) != 3:
                raise ValueError
            vertices[k] = [float(f) for f in fields]
        except ValueError:
            raise fail(
                number, f"expected a vertex 'x, y, z' (3 numbers), found {describe_fields(fields)}"
            ) from None
        if not np.all(np.abs(vertices[k]) <= MAX_MAGNITUDE):
            raise fail(number, f"expected finite coordinates within ±{MAX_MAGNITUDE:g}")
    extra = next(lines, None)
    if extra is not None:
        raise fail(
            extra[0],
            f"expected the end of the file after {n_vertices} vertices, "
            f"found {describe_fields(extra[1])}",
        )
    bad = np.nonzero((nets < 1) | (nets > n_vertices))
    if bad[0].size:
        k, j = int(bad[0][0]), int(bad[1][0])
        raise fail(
            net_lines[k],
            f"expected vertex indices from 1 to {n_vertices}, "
            f"found {int(nets[k, j])} in patch {k + 1}",
        )
    return vertices, (nets - 1).reshape(n_patches, 4, 4)


def read_newell(path: str | os.PathLike, up: str = "z") -> list[BezierPatch]:
    """Read a file in Newell's format as bicubic Bézier patches in gshade's z-up frame.

    Parameters
    ----------
    path : path-like
    up : {'z', 'y', 'x'}
        The data's up axis; y-up data (x, y, z) become (x, -z, y).

    Returns
    -------
    list of BezierPatch
        ``points[i, j]`` of each patch is entry (i, j) of its row-major 4x4 net.
    """
    if up not in _TO_Z_UP:
        raise SurfaceDataError(f"up: expected one of 'x', 'y', 'z', got {up!r}")
    path = Path(path)
    data = read_bytes(
        path, "a file in Newell's format", SurfaceDataError, limit=MAX_DATA_FILE_BYTES
    )
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SurfaceDataError(f"{path}: cannot read the file ({exc})") from None
    vertices, nets = parse_newell(text, str(path))
    vertices = vertices @ _TO_Z_UP[up].T
    return [BezierPatch(vertices[net]) for net in nets]
