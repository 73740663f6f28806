"""Triangle meshes and point clouds as files (gshade.io.meshes): each format read, and each
hostile file refused with one line that names it."""

from __future__ import annotations

import os
import struct
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gshade.errors import SurfaceDataError
from gshade.io.meshes import MESH_SUFFIXES, MeshData, fan_triangles, is_mesh_file, read_mesh

#: A unit square in z = 0 as two triangles, and as one quad.
SQUARE = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
TRIANGLES = np.array([[0, 1, 2], [0, 2, 3]])

STL_RECORD = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])


def binary_stl(triangles: np.ndarray, header: bytes = b"binary test") -> bytes:
    records = np.zeros(len(triangles), dtype=STL_RECORD)
    records["corners"] = triangles
    records["normal"] = [0.0, 0.0, 1.0]
    return header.ljust(80, b"\0") + struct.pack("<I", len(triangles)) + records.tobytes()


def ascii_stl(triangles: np.ndarray, name: str = "square") -> str:
    facets = "".join(
        "facet normal 0 0 1\n outer loop\n"
        + "".join(f"  vertex {float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in tri)
        + " endloop\nendfacet\n"
        for tri in triangles
    )
    return f"solid {name}\n{facets}endsolid {name}\n"


PLY_HEAD = (
    "ply\nformat {format} 1.0\ncomment made by a test\nelement vertex {nv}\n"
    "property float x\nproperty float y\nproperty float z\n"
)
PLY_FACES = "element face {nf}\nproperty list uchar int vertex_indices\n"


def ply_ascii(vertices, faces=None, nv=None, nf=None) -> str:
    head = PLY_HEAD.format(format="ascii", nv=len(vertices) if nv is None else nv)
    if faces is not None:
        head += PLY_FACES.format(nf=len(faces) if nf is None else nf)
    rows = [" ".join(repr(float(c)) for c in v) for v in vertices]
    rows += [" ".join(str(i) for i in (len(f), *f)) for f in faces or []]
    return head + "end_header\n" + "\n".join(rows) + "\n"


def ply_binary(vertices, faces) -> bytes:
    head = PLY_HEAD.format(format="binary_little_endian", nv=len(vertices))
    head += PLY_FACES.format(nf=len(faces)) + "end_header\n"
    body = np.asarray(vertices, "<f4").tobytes()
    body += b"".join(struct.pack(f"<B{len(f)}i", len(f), *f) for f in faces)
    return head.encode() + body


def write(folder: Path, name: str, content: str | bytes) -> Path:
    path = folder / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    return path


def assert_square(mesh: MeshData) -> None:
    """The mesh is the unit square (vertices shared or not): two triangles covering it."""
    assert mesh.vertices.dtype == np.float64 and mesh.faces.dtype == np.int64
    assert mesh.faces.shape == (2, 3) and not mesh.is_cloud
    corners = mesh.vertices[mesh.faces]  # (2, 3, 3)
    area = 0.5 * np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )
    np.testing.assert_allclose(area, [0.5, 0.5])
    np.testing.assert_allclose(np.unique(corners.reshape(-1, 3), axis=0), SQUARE[[0, 3, 1, 2]])


# --- each format ---------------------------------------------------------------------------


def test_binary_stl(tmp_path):
    mesh = read_mesh(write(tmp_path, "square.stl", binary_stl(SQUARE[TRIANGLES])))
    assert mesh.format == "binary STL" and mesh.name == "square"
    assert_square(mesh)


def test_binary_stl_whose_header_starts_solid(tmp_path):
    # some exporters write 'solid' into a binary file's header: its length decides
    data = binary_stl(SQUARE[TRIANGLES], header=b"solid exported by a CAD system")
    assert read_mesh(write(tmp_path, "square.STL", data)).format == "binary STL"


def test_ascii_stl_with_two_solids(tmp_path):
    text = ascii_stl(SQUARE[TRIANGLES[:1]], "a") + ascii_stl(SQUARE[TRIANGLES[1:]], "b")
    mesh = read_mesh(write(tmp_path, "square.stl", text))
    assert mesh.format == "ASCII STL"
    assert_square(mesh)


def test_obj_with_a_quad_and_relative_indices(tmp_path):
    text = "# a comment\no part\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\n"
    text += "f -4//1 -3//1 -2//1 -1//1\n"
    mesh = read_mesh(write(tmp_path, "square.obj", text))
    assert mesh.format == "OBJ" and mesh.faces.tolist() == [[0, 1, 2], [0, 2, 3]]
    assert_square(mesh)


@pytest.mark.parametrize("faces", [TRIANGLES.tolist(), [[0, 1, 2, 3]]], ids=["triangles", "quad"])
def test_ascii_ply_mesh(tmp_path, faces):
    mesh = read_mesh(write(tmp_path, "square.ply", ply_ascii(SQUARE, faces)))
    assert mesh.format == "ASCII PLY"
    assert_square(mesh)


def test_binary_ply_mesh(tmp_path):
    mesh = read_mesh(write(tmp_path, "square.ply", ply_binary(SQUARE, TRIANGLES.tolist())))
    assert mesh.format == "binary PLY"
    assert_square(mesh)


def test_ply_without_faces_is_a_cloud(tmp_path):
    cloud = read_mesh(write(tmp_path, "scan.ply", ply_ascii(SQUARE)))
    assert cloud.is_cloud and cloud.faces.shape == (0, 3)
    assert cloud.format == "ASCII PLY point cloud"
    np.testing.assert_array_equal(cloud.vertices, SQUARE)


@pytest.mark.parametrize("separator", [" ", ",", "\t"])
def test_xyz_cloud(tmp_path, separator):
    rows = [separator.join(repr(float(c)) for c in (*v, 255, 0, 0)) for v in SQUARE]  # and colours
    cloud = read_mesh(write(tmp_path, "scan.xyz", "\n".join(rows) + "\n"))
    assert cloud.is_cloud and cloud.format == "XYZ point cloud"
    np.testing.assert_array_equal(cloud.vertices, SQUARE)


def test_off_mesh(tmp_path):
    text = "OFF\n# a square\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n"
    mesh = read_mesh(write(tmp_path, "square.off", text))
    assert mesh.format == "OFF"
    assert_square(mesh)


def test_the_suffixes():
    assert MESH_SUFFIXES == (".stl", ".obj", ".ply", ".off", ".xyz")
    assert is_mesh_file("a/b/scan.Xyz") and not is_mesh_file("part.step")


def test_fans_cut_polygons_in_order():
    assert fan_triangles(np.array([[0, 1, 2, 3, 4]])).tolist() == [[0, 1, 2], [0, 2, 3], [0, 3, 4]]
    assert fan_triangles([(5, 6, 7), (0, 1, 2, 3)]).tolist() == [[5, 6, 7], [0, 1, 2], [0, 2, 3]]


# --- hostile files: one line naming the file -------------------------------------------------

NAN_STL = binary_stl(np.array([[[0, 0, 0], [1, 0, 0], [np.nan, 1, 0]]]))
HUGE_STL = b"\0" * 80 + struct.pack("<I", 2**32 - 1) + b"\0" * 50
HOSTILE = {
    "empty.stl": ("", "found an empty file"),
    "blank.xyz": ("\n \n", "found an empty file"),
    "truncated.stl": (binary_stl(SQUARE[TRIANGLES])[:-7], "a truncated file?"),
    "huge-count.stl": (HUGE_STL, "of the 4294967295 triangles its header declares"),
    "zero.stl": (binary_stl(np.zeros((0, 3, 3))), "with a triangle, found 0"),
    "nan.stl": (NAN_STL, "expected finite coordinates"),
    "no-facets.stl": ("solid nothing\nendsolid nothing\n", "found none"),
    "text.stl": ("hello, this is not a mesh\n", "neither"),
    "inf.obj": ("v 0 0 0\nv 1 0 0\nv 0 inf 0\nf 1 2 3\n", "expected finite coordinates"),
    "range.obj": ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "expected vertex indices from 1 to 3"),
    "nofaces.obj": ("v 0 0 0\nv 1 0 0\n", "expected at least one face"),
    "range.ply": (ply_ascii(SQUARE, [[0, 1, 7]]), "expected face vertex indices from 0 to 3"),
    "short-face.ply": (ply_ascii(SQUARE, [[0, 1, 2], [0, 2]], nf=2), "found 1 that could be read"),
    "negative.ply": (ply_ascii(SQUARE, [[0, 1, -1]]), "expected face vertex indices from 0 to 3"),
    "nan.ply": (ply_ascii([[0, 0, 0], [1, np.nan, 0], [0, 1, 0]], [[0, 1, 2]]), "finite"),
    "big.ply": (ply_ascii([[0, 0, 0], [1, 1e300, 0], [0, 1, 0]]), "within ±1e+15"),
    "huge-count.ply": (ply_ascii(SQUARE, nv=10**15), "expected 1000000000000000 lines"),
    "huge-binary.ply": (
        ply_binary(SQUARE, TRIANGLES.tolist()).replace(b"vertex 4", b"vertex 99999999999"),
        "a truncated file?",
    ),
    "truncated-binary.ply": (ply_binary(SQUARE, TRIANGLES.tolist())[:-5], "binary PLY data"),
    "no-vertex.ply": ("ply\nformat ascii 1.0\nelement face 0\nend_header\n", "element vertex"),
    "no-end.ply": ("ply\nformat ascii 1.0\nelement vertex 3\n", "'end_header'"),
    "bad-type.ply": (
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty quux x\nend_header\n1\n",
        "header line 4: expected 'property TYPE NAME'",
    ),
    "not-a-ply.ply": ("solid x\nendsolid x\n", "expected a PLY file"),
    "binary-junk.ply": (b"ply\n\xff\xfe\x00 format\nend_header\n\x00\x01", "ASCII text"),
    "short.xyz": ("0 0 0\n1 0\n0 1 0\n", "as many on every line"),
    "ragged.xyz": ("0 0 0\n1 2\n3 4 5 6\n", "as many on every line"),
    "nan.xyz": ("0 0 0\n1 nan 0\n", "expected finite coordinates"),
    "one.xyz": ("1 2 3\n", "at least 2 points"),
    "words.xyz": ("x y z\n1 2 3\n4 5 6\n", "found otherwise (not shown)"),
    "huge-count.off": ("OFF\n999999999 1 0\n0 0 0\n3 0 0 0\n", "a truncated file?"),
    "range.off": ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n", "indices from 0 to 2"),
    "no-faces.off": ("OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n", "with a face, found none"),
    "not-off.off": ("ply\n", "expected an OFF file"),
    "part.step": ("ISO-10303-21;\n", 'got the suffix ".step"'),
    "noext": ("0 0 0\n", "got no suffix"),
}


@pytest.mark.parametrize("name", sorted(HOSTILE))
def test_hostile_files_give_one_line_naming_the_file(tmp_path, name):
    content, expected = HOSTILE[name]
    path = write(tmp_path, name, content)
    with pytest.raises(SurfaceDataError) as caught:
        read_mesh(path)
    message = str(caught.value)
    assert message.startswith(str(path)), message
    assert "\n" not in message and expected in message, message


def test_no_file_and_a_directory(tmp_path):
    with pytest.raises(SurfaceDataError, match="no such file"):
        read_mesh(tmp_path / "missing.stl")
    folder = tmp_path / "scan.ply"
    folder.mkdir()
    with pytest.raises(SurfaceDataError, match=r"scan\.ply: expected .* got a directory"):
        read_mesh(folder)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "pipe.stl"
    os.mkfifo(fifo)
    with pytest.raises(SurfaceDataError, match="FIFO"):
        read_mesh(fifo)


def test_the_size_limit(tmp_path, monkeypatch):
    import gshade.io.meshes as meshes

    monkeypatch.setattr(meshes, "MAX_DATA_FILE_BYTES", 100)
    path = write(tmp_path, "big.stl", binary_stl(SQUARE[TRIANGLES]))
    with pytest.raises(SurfaceDataError, match=r"big\.stl: expected .* of at most"):
        read_mesh(path)


def test_names_inside_files_are_never_read_out(tmp_path):
    text = ascii_stl(SQUARE[TRIANGLES], name="\x1b[31mred\x1b[0m")
    mesh = read_mesh(write(tmp_path, "plain.stl", text))
    assert mesh.name == "plain"
    bad = write(tmp_path, "secret.xyz", "password hunter2\n1 2 3\n")
    with pytest.raises(SurfaceDataError) as caught:
        read_mesh(bad)
    assert "hunter2" not in str(caught.value)


def test_trimesh_warnings_stay_off_stderr(tmp_path, capfd):
    # an ASCII STL whose normals do not parse: trimesh logs a warning with a traceback
    text = ascii_stl(SQUARE[TRIANGLES]).replace("normal 0 0 1", "normal 0 zero 1", 1)
    read_mesh(write(tmp_path, "normals.stl", text))
    assert capfd.readouterr().err == ""


VALID = {
    ".stl": binary_stl(SQUARE[TRIANGLES]),
    ".obj": b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n",
    ".ply": ply_binary(SQUARE, TRIANGLES.tolist()),
    ".off": b"OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n",
    ".xyz": b"0 0 0\n1 0 0\n1 1 0\n",
}


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    suffix=st.sampled_from(sorted(VALID)),
    edits=st.lists(st.tuples(st.integers(0, 400), st.binary(max_size=6)), max_size=4),
    cut=st.integers(0, 400),
)
def test_damaged_files_read_or_give_one_line(tmp_path, suffix, edits, cut):
    data = bytearray(VALID[suffix])
    for at, new in edits:  # overwrite bytes here and there, then maybe cut the end off
        at = min(at, len(data))
        data[at : at + len(new)] = new
    path = write(tmp_path, f"damaged{suffix}", bytes(data[: max(cut, len(data) // 2)]))
    try:
        mesh = read_mesh(path)
    except SurfaceDataError as exc:
        assert str(exc).startswith(str(path)) and "\n" not in str(exc)
    else:
        assert np.all(np.abs(mesh.vertices) <= 1e15)
        assert mesh.faces.size == 0 or 0 <= mesh.faces.min() <= mesh.faces.max() < len(
            mesh.vertices
        )


@pytest.mark.parametrize("chunk", [1, 7, 20, 10**6])
def test_xyz_read_in_chunks(tmp_path, monkeypatch, chunk):
    """An XYZ file goes to trimesh a piece at a time (its memory): every point comes back,
    in order, whatever the pieces' size; a line of other columns in a later piece is
    refused as in the first."""
    import gshade.io.meshes as meshes

    monkeypatch.setattr(meshes, "XYZ_CHUNK", chunk)
    points = np.arange(7 * 3, dtype=float).reshape(7, 3) / 4
    text = "\n".join(" ".join(repr(float(c)) for c in p) for p in points)
    np.testing.assert_array_equal(read_mesh(write(tmp_path, "c.xyz", text)).vertices, points)
    with pytest.raises(SurfaceDataError, match="as many on every line"):
        read_mesh(write(tmp_path, "d.xyz", text + "\n1 2 3 4\n5 6 7 8\n"))
