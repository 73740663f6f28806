"""Wavefront OBJ polygon meshes: the vertices and faces, for subdivision surfaces.

Read statements::

    v x y z [w]          a vertex (w, and colours r g b after x y z, are ignored)
    f a b c ...          a face: vertex references a, a/t, a/t/n or a//n; 1-based, or
                         negative: relative to the vertices read so far (-1 = the last)

Ignored: ``vn``, ``vt``, ``vp``, ``o``, ``g``, ``s``, ``usemtl``, ``mtllib``, ``l``, ``p``
and the other display statements, comments (``#`` to the end of the line) and blank lines.
Free-form geometry (``cstype``, ``curv``, ``surf``, ...) is refused: it would be missing
from the picture.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..errors import SurfaceDataError
from ..limits import MAX_DATA_FILE_BYTES, MAX_MAGNITUDE
from .files import describe_fields, read_bytes

__all__ = ["ObjMesh", "parse_obj", "read_obj", "read_obj_mesh"]

_IGNORED = frozenset(
    {
        "vn",
        "vt",
        "vp",
        "o",
        "g",
        "s",
        "usemtl",
        "mtllib",
        "usemap",
        "maplib",
        "l",
        "p",
        "lod",
        "bevel",
        "c_interp",
        "d_interp",
        "shadow_obj",
        "trace_obj",
    }
)
_FREE_FORM = frozenset(
    {
        "cstype",
        "deg",
        "bmat",
        "step",
        "curv",
        "curv2",
        "surf",
        "parm",
        "trim",
        "hole",
        "scrv",
        "sp",
        "end",
        "con",
    }
)


class ObjMesh(NamedTuple):
    """A polygon mesh read from OBJ: 0-based faces and the line each face was on."""

    vertices: NDArray[np.float64]
    faces: list[tuple[int, ...]]
    face_lines: list[int]


def parse_obj(text: str, source: str = "<string>") -> ObjMesh:
    """Parse OBJ text (see the module docstring for what is read).

    Returns
    -------
    ObjMesh
        ``vertices`` (n, 3), ``faces`` as tuples of 0-based vertex indices, ``face_lines``.

    Raises
    ------
    SurfaceDataError
        One line naming the source, the line number, what was expected and what was found.
    """
    vertices: list[tuple[float, float, float]] = []
    faces: list[tuple[int, ...]] = []
    face_lines: list[int] = []
    pending: list[tuple[int, int]] = []  # (line, 1-based index) to check at the end
    for number, raw in enumerate(text.splitlines(), start=1):
        fields = raw.split("#", 1)[0].split()
        if not fields:
            continue
        word = fields[0]
        where = f"{source}, line {number}"
        if word == "v":
            vertices.append(_vertex(fields, where))
        elif word == "f":
            refs, absolute = _face(fields, len(vertices), where)
            pending += [(number, index) for index in absolute]
            faces.append(refs)
            face_lines.append(number)
        elif word not in _IGNORED:
            raise SurfaceDataError(f"{where}: {_unread(word)}")
    for number, index in pending:
        if index > len(vertices):
            raise SurfaceDataError(
                f"{source}, line {number}: expected vertex indices from 1 to {len(vertices)}, "
                f"found {index}"
            )
    if not faces:
        raise SurfaceDataError(f"{source}: expected at least one face ('f' statement), found none")
    V = np.array(vertices, dtype=np.float64).reshape(-1, 3)
    return ObjMesh(V, faces, face_lines)


def _vertex(fields: list[str], where: str) -> tuple[float, float, float]:
    """A ``v x y z [w | r g b]`` statement's point; SurfaceDataError at ``where``."""
    try:
        if not 3 <= len(fields) - 1 <= 7:
            raise ValueError
        numbers = [float(a) for a in fields[1:]]
        xyz = (numbers[0], numbers[1], numbers[2])
    except ValueError:
        raise SurfaceDataError(
            f"{where}: expected a vertex 'v x y z' (3 numbers, optionally w or r g b), found "
            f"{describe_fields(fields)}"
        ) from None
    if not all(abs(x) <= MAX_MAGNITUDE for x in xyz):
        raise SurfaceDataError(f"{where}: expected finite coordinates within ±{MAX_MAGNITUDE:g}")
    return xyz


def _face(fields: list[str], vertex_count: int, where: str) -> tuple[tuple[int, ...], list[int]]:
    """An ``f a b c ...`` statement's 0-based vertex indices (relative ones resolved against
    the ``vertex_count`` vertices so far), and its positive 1-based indices, which the whole
    file must reach; SurfaceDataError at ``where``."""
    if len(fields) < 4:
        raise SurfaceDataError(
            f"{where}: expected a face 'f a b c ...' (at least 3 vertex references), found "
            f"{describe_fields(fields)}"
        )
    refs, absolute = [], []
    for arg in fields[1:]:
        parts = arg.split("/")
        ok = 1 <= len(parts) <= 3 and all(
            _is_int(p) or (k > 0 and p == "") for k, p in enumerate(parts)
        )
        if not ok:
            raise SurfaceDataError(
                f"{where}: expected vertex references a, a/t, a/t/n or a//n (integers), found "
                "one that is not (not shown)"
            )
        index = int(parts[0])
        if index == 0:
            raise SurfaceDataError(
                f"{where}: expected a vertex index other than 0 (OBJ counts from 1)"
            )
        if index < 0:
            if -index > vertex_count:
                raise SurfaceDataError(
                    f"{where}: expected a relative vertex index from -1 to -{vertex_count} "
                    f"({vertex_count} vertices so far), found {index}"
                )
            refs.append(vertex_count + index)
        else:
            refs.append(index - 1)
            absolute.append(index)
    return tuple(refs), absolute


def _unread(word: str) -> str:
    """Why a statement other than ``v``, ``f`` and those passed over is refused."""
    if word in _FREE_FORM:
        return (
            f"expected a polygon mesh (v and f statements), found free-form geometry "
            f"{word!r}, which gshade does not read"
        )
    shown = repr(word) if word.isalpha() and len(word) <= 12 else "an unknown one (not shown)"
    return f"expected an OBJ statement such as 'v' or 'f', found {shown}"


def _is_int(text: str) -> bool:
    body = text[1:] if text[:1] in "+-" else text
    return body.isdigit() and body.isascii()


def read_obj_mesh(path: str | os.PathLike) -> ObjMesh:
    """Read an OBJ file: :class:`ObjMesh` with the face lines (for messages)."""
    path = Path(path)
    data = read_bytes(path, "an OBJ file", SurfaceDataError, limit=MAX_DATA_FILE_BYTES)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        text = data.decode("latin-1")  # names in comments or groups: never needed
    return parse_obj(text, str(path))


def read_obj(path: str | os.PathLike) -> tuple[NDArray[np.float64], list[tuple[int, ...]]]:
    """Read the vertices and faces of an OBJ file.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    vertices : ndarray, shape (n, 3)
    faces : list of tuple of int
        0-based vertex indices of each face, in the file's order.

    Raises
    ------
    SurfaceDataError
        Naming the file, the line, what was expected and what was found (e.g.
        ``mesh.obj, line 12: expected vertex indices from 1 to 8, found 9``).
    """
    mesh = read_obj_mesh(path)
    return mesh.vertices, mesh.faces
