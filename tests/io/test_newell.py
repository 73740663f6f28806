"""Newell's teapot format: the teapot, other files of the format, and bad files."""

import numpy as np
import pytest

from gshade.errors import SurfaceDataError
from gshade.geometry import BezierPatch
from gshade.io import parse_newell, read_newell

from ..support.paths import TEAPOT

SIDES = {
    "u0": lambda t: (0 * t, t),
    "u1": lambda t: (0 * t + 1, t),
    "v0": lambda t: (t, 0 * t),
    "v1": lambda t: (t, 0 * t + 1),
}


def shared_edges(patches, samples=101):
    """Pairs of patch boundaries that coincide (either orientation), with their max gap."""
    t = np.linspace(0, 1, samples)
    edges = []
    for k, patch in enumerate(patches):
        for side, params in SIDES.items():
            pts = patch(*params(t))
            if np.ptp(pts, axis=0).max() > 1e-9:  # skip collapsed edges
                edges.append((k, side, pts))
    pairs = []
    for a in range(len(edges)):
        for b in range(a + 1, len(edges)):
            A, B = edges[a][2], edges[b][2]
            gap = min(np.abs(A - B).max(), np.abs(A - B[::-1]).max())
            if gap < 1e-3:
                pairs.append((edges[a][:2], edges[b][:2], gap))
    return edges, pairs


def test_teapot_has_32_bicubic_patches():
    patches = read_newell(TEAPOT)
    assert len(patches) == 32
    assert all(isinstance(p, BezierPatch) and p.degree == (3, 3) for p in patches)
    box = np.concatenate([p.points.reshape(-1, 3) for p in patches])
    # z up: the teapot stands on z = 0 and is 3.15 units tall
    np.testing.assert_allclose([box[:, 2].min(), box[:, 2].max()], [0.0, 3.15])


def test_teapot_patches_meet_without_gaps():
    edges, pairs = shared_edges(read_newell(TEAPOT))
    # 52 shared edges; the 16 free ones are the body's rim, the lid's rim, and the ends of
    # the spout and the handle where they pass into the body
    assert len(pairs) == 52
    assert len(edges) - 2 * len(pairs) == 16
    assert max(gap for *_, gap in pairs) < 1e-12


def test_y_up_data_is_rotated_to_z_up(tmp_path):
    vertices, nets = parse_newell(TEAPOT.read_text())
    y_up = vertices[:, [0, 2, 1]] * [1, 1, -1]  # (x, y, z) z-up -> y-up (x, z, -y)
    lines = [str(len(nets))] + [", ".join(str(i + 1) for i in net.ravel()) for net in nets]
    lines += [str(len(y_up))] + ["{:.17g},{:.17g},{:.17g}".format(*v) for v in y_up]
    path = tmp_path / "teapot_y_up.txt"
    path.write_text("\n".join(lines) + "\n")
    a, b = read_newell(TEAPOT), read_newell(path, up="y")
    for pa, pb in zip(a, b, strict=True):
        np.testing.assert_allclose(pb.points, pa.points, atol=1e-15)


def test_another_object_in_the_format(tmp_path):
    # a single flat patch with blank-separated numbers and blank lines
    pts = [f"{i % 4} {i // 4} 0" for i in range(16)]
    path = tmp_path / "plane.txt"
    path.write_text("1\n" + " ".join(str(i) for i in range(1, 17)) + "\n\n16\n" + "\n".join(pts))
    (patch,) = read_newell(path)
    np.testing.assert_allclose(patch(0.5, 0.5), [1.5, 1.5, 0])


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "expected the number of patches, found the end of the file"),
        ("x\n", "line 1: expected the number of patches"),
        ("1\n1,2,3\n", "line 2: expected 16 vertex indices"),
        ("1\n" + ",".join(["1"] * 16) + "\n", "expected the number of vertices"),
        (
            "1\n" + ",".join(["2"] * 16) + "\n1\n0,0,0\n",
            "line 2: expected vertex indices from 1 to 1, found 2",
        ),
        ("1\n" + ",".join(["1"] * 16) + "\n2\n0,0,0\n", "expected 2 vertex lines, found 1"),
        ("1\n" + ",".join(["1"] * 16) + "\n1\n0,zero,0\n", "line 4: expected a vertex 'x, y, z'"),
        ("1\n" + ",".join(["1"] * 16) + "\n1\n0,0,0\n7\n", "line 5: expected the end of the file"),
    ],
)
def test_bad_files_name_the_line(tmp_path, text, message):
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(SurfaceDataError, match=message) as info:
        read_newell(path)
    assert str(path) in str(info.value)


def test_missing_file_and_bad_up_axis(tmp_path):
    with pytest.raises(SurfaceDataError, match="no such file"):
        read_newell(tmp_path / "nothing.txt")
    with pytest.raises(SurfaceDataError, match="up: expected one of"):
        read_newell(TEAPOT, up="w")
