"""Triangle meshes and point clouds read from files: the reference B of a geometric
deviation may be a scan or an export instead of exact surfaces (issue 30).

One reader per format, chosen by the file's suffix (:data:`READERS`, any case):

``.stl``
    Binary or ASCII STL (trimesh's reader); binary where the file is exactly as long as
    its header's triangle count says, ASCII where it starts ``solid`` and holds no NUL
    byte.  Several ASCII solids are joined.
``.obj``
    Wavefront OBJ polygon meshes (:mod:`gshade.io.obj`, gshade's own reader: trimesh's
    resolves relative indices against the whole file, takes index 0 and 2-number
    vertices without a word, which would move faces silently).
``.ply``
    ASCII or binary PLY (trimesh's reader), a mesh, or a point cloud where it has no
    faces; the header is checked first: its counts must fit in the file.
``.off``
    OFF meshes (trimesh's reader).
``.xyz``
    Point clouds, a point per line: ``x y z`` and optional further columns (colours),
    separated by blanks or commas (trimesh's reader).

Polygons are cut into triangles as fans from their first corner.  E57 is not read: no
library gshade keeps reads it.  Every file is read through
:func:`gshade.io.files.read_bytes` (a regular file of at most ``MAX_DATA_FILE_BYTES``);
its numbers and indices are checked before they reach compiled code, and any failure is
one :class:`~gshade.errors.SurfaceDataError` line naming the file.  Names inside a file
(STL solids, PLY comments, OBJ groups) are never read out: :attr:`MeshData.name` is the
file's own.

trimesh is imported on the first read (it takes a second to import).
"""

from __future__ import annotations

import io
import logging
import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from itertools import chain
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import SurfaceDataError, show
from ..limits import MAX_DATA_FILE_BYTES, MAX_MAGNITUDE
from .files import read_bytes, require_regular_file
from .obj import parse_obj

__all__ = [
    "MESH_SUFFIXES",
    "READERS",
    "MeshData",
    "fan_triangles",
    "is_mesh_file",
    "read_mesh",
]

#: Bytes of a PLY header at most (its lines up to ``end_header``).
MAX_PLY_HEADER = 64 * 2**10
#: Characters of an XYZ file handed to trimesh at once (it holds every number as a string).
XYZ_CHUNK = 4 * 2**20

_PLY_TYPES = {
    "char": 1,
    "uchar": 1,
    "int8": 1,
    "uint8": 1,
    "short": 2,
    "ushort": 2,
    "int16": 2,
    "uint16": 2,
    "int": 4,
    "uint": 4,
    "int32": 4,
    "uint32": 4,
    "float": 4,
    "float32": 4,
    "double": 8,
    "float64": 8,
}


@dataclass(frozen=True)
class MeshData:
    """A triangle mesh or a point cloud read from a file.

    Attributes
    ----------
    vertices : ndarray, shape (n, 3)
        Finite coordinates within ±MAX_MAGNITUDE; n >= 1.
    faces : ndarray of int64, shape (m, 3)
        0-based vertex indices of each triangle, all below n; shape (0, 3) for a cloud.
    name : str
        The file's name without its suffix (never a name read from inside the file).
    path : Path
    format : str
        What was read: ``"binary STL"``, ``"ASCII PLY"``, ...
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    name: str
    path: Path
    format: str

    @property
    def is_cloud(self) -> bool:
        """True for a point cloud (no faces)."""
        return len(self.faces) == 0


#: A reader: the file's bytes and its name for messages, to vertices (n, 3), faces (m, k)
#: or a list of polygons (None for a cloud) and the format read.
Reader = Callable[[bytes, str], tuple[Any, Any, str]]


def read_mesh(path: str | os.PathLike) -> MeshData:
    """Read a triangle mesh or point cloud file (the formats of the module's table).

    Parameters
    ----------
    path : path-like
        A file whose suffix is one of :data:`MESH_SUFFIXES` (any case).

    Returns
    -------
    MeshData

    Raises
    ------
    SurfaceDataError
        One line naming the file and what was expected: another suffix, no such file,
        a directory or another non-regular file, a file larger than
        ``MAX_DATA_FILE_BYTES``, an empty one, one that is not of its format (a
        truncated binary STL, a PLY whose header declares more than the file holds),
        no vertices, coordinates that are not finite or beyond ±MAX_MAGNITUDE, face
        indices outside the vertices, a mesh format without a face.

    Examples
    --------
    A square of one quad (cut in two triangles), and a cloud of two points:

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     square, cloud = Path(folder, "square.obj"), Path(folder, "points.xyz")
    ...     _ = square.write_text("v 0 0 0\\nv 1 0 0\\nv 1 1 0\\nv 0 1 0\\nf 1 2 3 4\\n")
    ...     _ = cloud.write_text("0 0 0\\n1 2 3\\n")
    ...     mesh, points = read_mesh(square), read_mesh(cloud)
    >>> mesh.name, mesh.format, mesh.faces.tolist()
    ('square', 'OBJ', [[0, 1, 2], [0, 2, 3]])
    >>> points.is_cloud, points.vertices.tolist()
    (True, [[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]])
    """
    path = Path(path)
    where = str(path)
    require_regular_file(path, "a triangle mesh or point cloud file", SurfaceDataError)
    suffix = path.suffix.lower()
    if suffix not in READERS:
        got = f"the suffix {show(path.suffix)}" if path.suffix else "no suffix"
        raise SurfaceDataError(
            f"{where}: expected a triangle mesh or point cloud file ending "
            f"{', '.join(MESH_SUFFIXES)}, got {got}"
        )
    expected, reader = READERS[suffix]
    data = read_bytes(path, expected, SurfaceDataError, limit=MAX_DATA_FILE_BYTES)
    if not data.strip():
        raise SurfaceDataError(f"{where}: expected {expected}, found an empty file")
    try:
        with np.errstate(all="ignore"):  # an overflowing cast: an infinity, refused below
            vertices, faces, kind = reader(data, where)
            V = _vertices(vertices, where)
            F = np.zeros((0, 3), dtype=np.int64)
            if faces is not None:
                F = _indices(fan_triangles(faces, where), len(V), where)
                if len(F) == 0:
                    raise SurfaceDataError(f"{where}: expected {expected} with a face, found none")
    except SurfaceDataError:
        raise
    except MemoryError:
        raise SurfaceDataError(
            f"{where}: expected {expected}, found one too large to read"
        ) from None
    except Exception as exc:  # the library's own failure: its message may quote the file
        raise SurfaceDataError(
            f"{where}: expected {expected}, found data that could not be read as one "
            f"({type(exc).__name__})"
        ) from None
    return MeshData(V, F, path.stem, path, kind)


def is_mesh_file(path: str | os.PathLike) -> bool:
    """Whether ``path``'s suffix is one :func:`read_mesh` reads (any case).

    Examples
    --------
    >>> is_mesh_file("scan.PLY"), is_mesh_file("part.step")
    (True, False)
    """
    return Path(path).suffix.lower() in READERS


def fan_triangles(faces: Any, where: str = "<faces>") -> NDArray[np.int64]:
    """Polygons (an (m, k) array, k >= 3, or a sequence of index sequences) cut into
    triangles (p0, p_i, p_i+1) from each one's first corner, in order.

    Raises
    ------
    SurfaceDataError
        A polygon of fewer than 3 corners, or indices that are not integers.

    Examples
    --------
    >>> fan_triangles([(0, 1, 2, 3), (4, 5, 6)]).tolist()
    [[0, 1, 2], [0, 2, 3], [4, 5, 6]]
    """
    if isinstance(faces, np.ndarray) and faces.size == 0:
        return np.zeros((0, 3), dtype=np.int64)
    if isinstance(faces, np.ndarray) and faces.ndim == 2:
        array = _integers(faces, where)
        if array.shape[1] < 3 and len(array):
            raise SurfaceDataError(
                f"{where}: expected faces of at least 3 corners, found faces of {array.shape[1]}"
            )
        if array.shape[1] == 3 or len(array) == 0:
            return array.reshape(-1, 3)
        pieces = [array[:, [0, i, i + 1]] for i in range(1, array.shape[1] - 1)]
        return np.stack(pieces, axis=1).reshape(-1, 3)
    polygons: Sequence[Any] = list(faces)
    if not polygons:
        return np.zeros((0, 3), dtype=np.int64)
    lengths = np.fromiter(map(len, polygons), dtype=np.int64, count=len(polygons))
    if lengths.min() < 3:
        raise SurfaceDataError(
            f"{where}: expected faces of at least 3 corners, found one of {int(lengths.min())}"
        )
    flat = _integers(np.array(list(chain.from_iterable(polygons))), where)
    first = np.cumsum(lengths) - lengths
    count = lengths - 2  # triangles of each polygon
    polygon = np.repeat(np.arange(len(polygons)), count)
    step = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count) + 1
    start = first[polygon]
    return np.stack([flat[start], flat[start + step], flat[start + step + 1]], axis=1)


def _integers(array: NDArray[Any], where: str) -> NDArray[np.int64]:
    """Face indices as int64 (floats only where they are whole numbers, as ASCII PLY
    gives them; unsigned ones above int64's range refused by their size)."""
    if array.size == 0:
        return np.zeros(array.shape, dtype=np.int64)
    if array.dtype.kind == "f":
        with np.errstate(invalid="ignore"):
            whole = np.all(np.isfinite(array)) and np.all(array == np.round(array))
        if not whole or np.max(np.abs(array)) > 2**62:
            raise SurfaceDataError(f"{where}: expected whole-number vertex indices in the faces")
        return array.astype(np.int64)
    if array.dtype.kind == "u" and int(array.max()) > 2**62:
        raise SurfaceDataError(
            f"{where}: expected vertex indices below 2^62 in the faces, found {int(array.max())}"
        )
    if array.dtype.kind not in "iu":
        raise SurfaceDataError(f"{where}: expected integer vertex indices in the faces")
    return array.astype(np.int64)


def _vertices(vertices: Any, where: str) -> NDArray[np.float64]:
    """The vertices as a checked (n, 3) float64 array."""
    V = np.asarray(vertices, dtype=np.float64) if vertices is not None else np.zeros((0, 3))
    if V.ndim != 2 or V.shape[1] != 3:
        raise SurfaceDataError(f"{where}: expected vertices of 3 coordinates x y z")
    if len(V) == 0:
        raise SurfaceDataError(f"{where}: expected at least one vertex, found none")
    bad = ~(np.abs(V) <= MAX_MAGNITUDE)  # NaN too
    if bad.any():
        rows = np.flatnonzero(bad.any(axis=1))
        raise SurfaceDataError(
            f"{where}: expected finite coordinates within ±{MAX_MAGNITUDE:g}, found "
            f"{rows.size} vert{'ices that are' if rows.size != 1 else 'ex that is'} not (the "
            f"first: vertex {int(rows[0])}, counting from 0)"
        )
    return np.ascontiguousarray(V)


def _indices(faces: NDArray[np.int64], count: int, where: str) -> NDArray[np.int64]:
    """Triangles whose indices are checked to lie in [0, count)."""
    if len(faces) and (faces.min() < 0 or faces.max() >= count):
        bad = int(faces.min()) if faces.min() < 0 else int(faces.max())
        raise SurfaceDataError(
            f"{where}: expected face vertex indices from 0 to {count - 1} (counting from 0), "
            f"found {bad}"
        )
    return np.ascontiguousarray(faces, dtype=np.int64)


def _trimesh() -> Any:
    """trimesh's exchange modules, its logger given a handler that drops its records
    (unconfigured, Python would print its warnings, tracebacks included, to stderr)."""
    import trimesh.exchange.off
    import trimesh.exchange.ply
    import trimesh.exchange.stl
    import trimesh.exchange.xyz

    log = logging.getLogger("trimesh")
    if not any(isinstance(h, logging.NullHandler) for h in log.handlers):
        log.addHandler(logging.NullHandler())
    return trimesh.exchange


def _arrays(kwargs: dict[str, Any]) -> tuple[Any, Any]:
    """Vertices and faces (None where absent) of a trimesh loader's keyword arguments,
    the parts of a scene (``{"geometry": {...}}``) joined."""
    if "geometry" not in kwargs:
        return kwargs.get("vertices"), kwargs.get("faces")
    parts = list(kwargs["geometry"].values())
    if not parts:
        return None, None
    vertices, faces, offset = [], [], 0
    for part in parts:
        v = np.asarray(part["vertices"], dtype=np.float64).reshape(-1, 3)
        f = part.get("faces")
        vertices.append(v)
        if f is not None:
            faces.append(_integers(np.asarray(f).reshape(len(f), -1), "") + offset)
        offset += len(v)
    return np.concatenate(vertices), (np.concatenate(faces) if faces else None)


def _text(data: bytes) -> str:
    """The file as text: UTF-8, else Latin-1 (names and comments are never needed)."""
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def _read_stl(data: bytes, where: str) -> tuple[Any, Any, str]:
    stl = _trimesh().stl
    declared = int.from_bytes(data[80:84], "little") if len(data) >= 84 else None
    if declared is not None and len(data) == 84 + 50 * declared:
        vertices, faces = _arrays(stl.load_stl_binary(io.BytesIO(data)))
        if vertices is None:
            raise SurfaceDataError(f"{where}: expected a binary STL with a triangle, found 0")
        return vertices, faces, "binary STL"
    if data.lstrip()[:5].lower() == b"solid" and b"\0" not in data:
        vertices, faces = _arrays(stl.load_stl_ascii(io.StringIO(_text(data))))
        if vertices is None or faces is None or len(faces) == 0:
            raise SurfaceDataError(
                f"{where}: expected an ASCII STL with facets ('facet normal ... outer loop', 3 "
                "'vertex x y z' lines, 'endloop', 'endfacet', before 'endsolid'), found none"
            )
        return vertices, faces, "ASCII STL"
    if declared is not None:
        raise SurfaceDataError(
            f"{where}: expected a binary STL of the {declared} triangles its header declares "
            f"({84 + 50 * declared} bytes) or an ASCII STL starting 'solid', found "
            f"{len(data)} bytes that are neither (a truncated file?)"
        )
    raise SurfaceDataError(
        f"{where}: expected a binary STL (at least 84 bytes) or an ASCII STL starting "
        f"'solid', found {len(data)} bytes that are neither"
    )


def _read_obj(data: bytes, where: str) -> tuple[Any, Any, str]:
    mesh = parse_obj(_text(data), where)
    return mesh.vertices, mesh.faces, "OBJ"


def _read_ply(data: bytes, where: str) -> tuple[Any, Any, str]:
    binary, counts = _ply_header(data, where)
    ply = _trimesh().ply
    try:
        loaded = ply.load_ply(io.BytesIO(data), fix_texture=False, skip_materials=True)
    except ValueError:
        if not binary:
            raise
        raise SurfaceDataError(
            f"{where}: expected binary PLY data as long as its header declares, found "
            "otherwise (a truncated file, or faces of different sizes, which trimesh does not "
            "read in binary PLY)"
        ) from None
    vertices, faces = _arrays(loaded)
    if vertices is None or len(vertices) != counts.get("vertex", 0):
        raise SurfaceDataError(
            f"{where}: expected the {counts.get('vertex', 0)} vertices the PLY header declares, "
            f"found {0 if vertices is None else len(vertices)}"
        )
    kind = "binary PLY" if binary else "ASCII PLY"
    if counts.get("face", 0) == 0:
        return vertices, None, f"{kind} point cloud"
    # each face gives a triangle at least: fewer means faces trimesh passed over (a list
    # shorter than its count)
    triangles = fan_triangles(faces if faces is not None else [], where)
    if len(triangles) < counts["face"]:
        raise SurfaceDataError(
            f"{where}: expected the {counts['face']} faces the PLY header declares, found "
            f"{len(triangles)} that could be read"
        )
    return vertices, triangles, kind


def _ply_header(data: bytes, where: str) -> tuple[bool, dict[str, int]]:
    """Check a PLY header: whether the data is binary, and each element's count.

    The counts must fit in the data after the header (every row takes a byte at least,
    in ASCII a line), so that no count asks for more than the file holds.
    """
    end = data.find(b"end_header", 0, MAX_PLY_HEADER)
    newline = data.find(b"\n", end)
    if not data.startswith(b"ply") or end < 0 or newline < 0:
        raise SurfaceDataError(
            f"{where}: expected a PLY file: 'ply', its header and 'end_header' within the "
            f"first {MAX_PLY_HEADER // 1024} KB"
        )
    try:
        lines = data[:end].decode("ascii").splitlines()
    except UnicodeDecodeError:
        raise SurfaceDataError(f"{where}: expected a PLY header of ASCII text") from None
    body = data[newline + 1 :]
    formats = {"ascii": False, "binary_little_endian": True, "binary_big_endian": True}
    binary: bool | None = None
    counts: dict[str, int] = {}
    rows = 0  # the least bytes (binary) or lines (ASCII) the elements need
    element = None
    least = 0  # the least bytes of a row of the element being read
    for number, line in enumerate(lines[1:], start=2):
        fields = line.split()
        place = f"{where}, header line {number}"
        if not fields or fields[0] in ("comment", "obj_info"):
            continue
        if fields[0] == "format" and len(fields) == 3 and fields[1] in formats:
            binary = formats[fields[1]]
        elif fields[0] == "element" and len(fields) == 3 and fields[2].isdigit():
            rows += counts[element] * least if element is not None else 0
            element, least = fields[1], 0
            counts[element] = int(fields[2])
        elif fields[0] == "property" and element is not None and len(fields) >= 3:
            types = fields[2:-1] if fields[1] == "list" else fields[1:-1]
            if len(types) != (2 if fields[1] == "list" else 1) or any(
                t not in _PLY_TYPES for t in types
            ):
                raise SurfaceDataError(
                    f"{place}: expected 'property TYPE NAME' or 'property list TYPE TYPE NAME' "
                    f"with types from {', '.join(_PLY_TYPES)}"
                )
            least += _PLY_TYPES[types[0]]
        else:
            raise SurfaceDataError(
                f"{place}: expected a PLY header line 'format ascii|binary_little_endian|"
                "binary_big_endian 1.0', 'element NAME COUNT', 'property ...' or 'comment ...'"
            )
    rows += counts[element] * least if element is not None else 0
    if binary is None:
        raise SurfaceDataError(f"{where}: expected a 'format' line in the PLY header, found none")
    if "vertex" not in counts:
        raise SurfaceDataError(f"{where}: expected a PLY 'element vertex COUNT', found none")
    declared = "elements " + ", ".join(f"{name} {n}" for name, n in counts.items())
    if binary and rows > len(body):
        raise SurfaceDataError(
            f"{where}: expected at least {rows} bytes of data after the PLY header for its "
            f"{declared}, found {len(body)} (a truncated file?)"
        )
    if not binary:
        # trimesh reads a row from every line, a blank one too
        lines_found = body.count(b"\n") + (1 if body and not body.endswith(b"\n") else 0)
        if lines_found < sum(counts.values()):
            raise SurfaceDataError(
                f"{where}: expected {sum(counts.values())} lines of data after the PLY header "
                f"for its {declared}, found {lines_found} (a truncated file?)"
            )
    return binary, counts


def _read_off(data: bytes, where: str) -> tuple[Any, Any, str]:
    text = _text(data)
    fields = [line.split("#", 1)[0].split() for line in text.splitlines()]
    fields = [f for f in fields if f]
    if not fields or not fields[0][0].upper().endswith("OFF"):
        raise SurfaceDataError(f"{where}: expected an OFF file starting 'OFF'")
    header = fields[0][1:] if len(fields[0]) > 1 else (fields[1] if len(fields) > 1 else [])
    if len(header) < 2 or not (header[0].isdigit() and header[1].isdigit()):
        raise SurfaceDataError(
            f"{where}: expected the OFF counts 'VERTICES FACES EDGES' after 'OFF'"
        )
    nv, nf = int(header[0]), int(header[1])
    first = 1 if len(fields[0]) > 1 else 2  # the first vertex line
    lines = len(fields) - first
    if nv + nf > lines:
        raise SurfaceDataError(
            f"{where}: expected the {nv} vertex and {nf} face lines the OFF header declares, "
            f"found {lines} lines (a truncated file?)"
        )
    for number, face in enumerate(fields[first + nv : first + nv + nf]):
        corners = face[1 : 1 + int(face[0])] if face[0].isdigit() else []
        if len(corners) < 3 or not all(c.isdigit() and int(c) < nv for c in corners):
            raise SurfaceDataError(
                f"{where}: expected OFF face {number} (counting from 0) to be 'N i1 ... iN' with "
                f"N >= 3 vertex indices from 0 to {nv - 1}, found otherwise (not shown)"
            )
    vertices, faces = _arrays(_trimesh().off.load_off(io.StringIO(text)))
    return vertices, (faces if faces is not None else []), "OFF"


def _read_xyz(data: bytes, where: str) -> tuple[Any, Any, str]:
    # commas as blanks: trimesh counts the columns before it replaces them
    text = _text(data).replace(",", " ").strip()
    if "\n" not in text:
        raise SurfaceDataError(
            f"{where}: expected an XYZ point cloud of at least 2 points (lines 'x y z')"
        )
    xyz = _trimesh().xyz
    parts, columns = [], None
    for chunk in _chunks(text, XYZ_CHUNK):  # trimesh splits all at once: ~15 bytes a byte
        # trimesh reshapes all the numbers by the first line's count: a short line and a
        # long one would pass, misread; every line is counted first
        counts = set(map(len, map(str.split, chunk.splitlines()))) - {0}
        if columns is None:
            columns = min(counts)
        try:
            if counts != {columns}:
                raise ValueError
            vertices, _ = _arrays(xyz.load_xyz(io.StringIO(chunk)))
        except ValueError:
            raise SurfaceDataError(
                f"{where}: expected lines of 3 or more numbers, as many on every line (x y z, "
                "then colours), found otherwise (not shown)"
            ) from None
        parts.append(vertices)
    return np.concatenate(parts), None, "XYZ point cloud"


def _chunks(text: str, size: int) -> Iterator[str]:
    """``text`` in pieces of about ``size`` characters, cut at line ends, each of at least
    2 lines (trimesh's XYZ reader misreads a single line) where ``text`` has 2."""
    start = 0
    while start < len(text):
        end = text.find("\n", start + size)
        if end >= 0 and text.find("\n", start, end) < 0:  # one line so far: take another
            end = text.find("\n", end + 1)
        if end < 0 or text.find("\n", end + 1) < 0:  # one line would be left: take it too
            end = len(text)
        yield text[start:end]
        start = end + 1


#: The readers by suffix: what the file should be (for messages) and its reader.
READERS: dict[str, tuple[str, Reader]] = {
    ".stl": ("a binary or ASCII STL mesh", _read_stl),
    ".obj": ("a Wavefront OBJ mesh", _read_obj),
    ".ply": ("a PLY mesh or point cloud", _read_ply),
    ".off": ("an OFF mesh", _read_off),
    ".xyz": ("an XYZ point cloud", _read_xyz),
}
#: The suffixes :func:`read_mesh` reads.
MESH_SUFFIXES = tuple(READERS)
