"""``gshade deviation`` (issue 30) against closed forms: spheres of radii R and R + delta
(|d| = delta at every pixel, B's closest point radial), a scene against itself (0), the
teapot with one inner control point moved (the deviation inside that patch only), and the
exit statuses a CI reads."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gshade.app.cli import main
from gshade.io.image import read_exr

ROOT = Path(__file__).resolve().parents[2]
SPHERE = """name = "{name}"
[[surface]]
type = "sphere"
radius = {radius}
[camera]
type = "perspective"
origin = [2, -4, 2.5]
target = [0, 0, 0]
up = [0, 0, 1]
[render]
width = 96
height = 72
spp = 1
"""


@pytest.fixture
def spheres(tmp_path):
    a = tmp_path / "a.toml"
    b = tmp_path / "b.toml"
    a.write_text(SPHERE.format(name="a", radius=2.0))
    b.write_text(SPHERE.format(name="b", radius=2.003))
    return a, b


def test_spheres_r_and_r_plus_delta(spheres, tmp_path, capsys):
    """Every covered pixel: |d| = 0.003 to 1e-12 relative, B's closest point radial; beyond
    a tolerance of 0.001: exit 2; within 0.005: exit 0, warning above 0.002: exit 1."""
    a, b = spheres
    out = tmp_path / "d.exr"
    assert main(["deviation", str(a), str(b), "-o", str(out), "--tolerance", "0.001"]) == 2
    channels, header = read_exr(out)
    on = channels["patch"] >= 0
    assert on.sum() > 1000
    np.testing.assert_allclose(np.abs(channels["f"][on]), 0.003, rtol=1e-6)  # float32 EXR
    summary = json.loads(header["deviation"])
    assert summary["max_abs"] == pytest.approx(0.003, rel=1e-12)
    assert summary["rms"] == pytest.approx(0.003, rel=1e-12)
    assert summary["within"] == 0.0 and summary["count"] == int(on.sum())
    P = np.stack([channels[f"P.{c}"][on] for c in "XYZ"], -1)
    foot = np.stack([channels[f"B.{c}"][on] for c in "XYZ"], -1)
    np.testing.assert_allclose(foot, P * 2.003 / 2.0, atol=1e-5)
    assert main(["deviation", str(a), str(b), "-o", str(out), "--tolerance", "0.005"]) == 0
    args = ["deviation", str(a), str(b), "-o", str(out), "--tolerance", "0.005", "--warn", "0.002"]
    capsys.readouterr()
    assert main([*args, "--json"]) == 1
    listed = json.loads(capsys.readouterr().out)
    assert listed["status"] == 1 and listed["max_abs"] == pytest.approx(0.003, rel=1e-12)


def test_a_scene_against_itself_is_zero(spheres, tmp_path, capsys):
    a, _ = spheres
    out = tmp_path / "same.exr"
    assert main(["deviation", str(a), str(a), "-o", str(out), "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert listed["max_abs"] < 1e-12 and listed["within"] == 1.0


def _moved_teapot(folder: Path) -> int:
    """The teapot's data with one inner control point of a patch (used by that patch only)
    raised by 0.05; the patch's number."""
    lines = (ROOT / "scenes" / "data" / "teapot.txt").read_text().splitlines()
    n = int(lines[0])
    patches = [[int(i) for i in line.split(",")] for line in lines[1 : n + 1]]
    uses = np.bincount([i for p in patches for i in p])
    k, vertex = next(
        (k, patch[i])
        for k, patch in enumerate(patches)
        for i in (5, 6, 9, 10)
        if uses[patch[i]] == 1
    )
    row = n + 1 + vertex  # the vertex count's line, then the vertices from 1
    x, y, z = (float(c) for c in lines[row].split(","))
    lines[row] = f"{x},{y},{z + 0.05}"
    (folder / "data").mkdir()
    (folder / "data" / "teapot.txt").write_text("\n".join(lines) + "\n")
    return k


def test_a_teapot_with_one_control_point_moved(tmp_path, capsys):
    """The deviation lies inside the moved patch; every other pixel is on B to 1e-12."""
    moved = tmp_path / "moved"
    moved.mkdir()
    k = _moved_teapot(moved)
    scene = (ROOT / "scenes" / "teapot-mean.toml").read_text()
    (moved / "teapot.toml").write_text(scene)
    out = tmp_path / "teapot.exr"
    args = ["deviation", str(ROOT / "scenes" / "teapot-mean.toml"), str(moved / "teapot.toml")]
    assert main([*args, "-o", str(out), "--width", "160", "--height", "120", "--json"]) == 2
    listed = json.loads(capsys.readouterr().out)
    assert listed["patch_a"] == k and listed["patch_b"] == k and listed["max_abs"] > 1e-3
    channels, _ = read_exr(out)
    on = channels["patch"] >= 0
    elsewhere = on & (channels["patch"] != k)
    assert np.abs(channels["f"][elsewhere]).max() < 1e-12
    assert np.abs(channels["f"][channels["patch"] == k]).max() > 1e-3


def test_exit_statuses_for_files_and_usage(spheres, tmp_path, capsys):
    a, b = spheres
    assert main(["deviation", str(a), str(tmp_path / "none.toml")]) == 4
    bad = tmp_path / "bad.toml"
    bad.write_text("[[surface]]\ntype = 'nothing'\n")
    assert main(["deviation", str(bad), str(b)]) == 4
    assert main(["deviation", str(a), str(b), "--tolerance", "-1"]) == 5
    assert main(["deviation", str(a), str(b), "--tolerance", "1", "--warn", "2"]) == 5
    assert main(["deviation", str(a), str(b), "-o", str(b)]) == 5
    assert not (tmp_path / "a-deviation.exr").exists()
    err = capsys.readouterr().err
    assert err.count("\n") == 5 and "Traceback" not in err


def _from_above(folder, **shapes):
    """Each shape written as a BREP file with a scene seeing it from above, orthographic;
    the scenes' paths."""
    from OCP.BRepTools import BRepTools

    view = (
        '[camera]\ntype = "orthographic"\norigin = [0, 0, 20]\ntarget = [0, 0, 0]\n'
        "up = [0, 1, 0]\nwidth = 12\n[render]\nwidth = 96\nheight = 80\nspp = 1\n"
    )
    scenes = []
    for name, shape in shapes.items():
        BRepTools.Write_s(shape, str(folder / f"{name}.brep"))
        scene = folder / f"{name}.toml"
        scene.write_text(
            f'name = "{name}"\n[[surface]]\ntype = "cad"\nfile = "{name}.brep"\n' + view
        )
        scenes.append(scene)
    return tuple(scenes)


@pytest.fixture(scope="module")
def sheets(tmp_path_factory):
    """A 10 x 8 plane sheet at z = 4 (A) and the same sheet with a hole of radius 2 cut
    around (2, 0) (B: an open face whose hole's circle is a free edge, no wall), seen from
    above."""
    pytest.importorskip("OCP")
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeCylinder
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pln, gp_Pnt

    sheet = BRepBuilderAPI_MakeFace(gp_Pln(gp_Pnt(0, 0, 4), gp_Dir(0, 0, 1)), -5, 5, -4, 4).Face()
    drill = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(2, 0, -1), gp_Dir(0, 0, 1)), 2.0, 6).Shape()
    folder = tmp_path_factory.mktemp("sheets")
    return _from_above(folder, sheet=sheet, holed=BRepAlgoAPI_Cut(sheet, drill).Shape())


def test_a_hole_in_b_is_measured_to_its_edge_and_b_does_not_cover_a_there(sheets, tmp_path):
    """A's points over B's hole: B's closest point is on the hole's circle (a B-rep edge:
    the plane's foot point lies in the trimmed-away disc), |d| = 2 - rho at distance rho
    from the axis; the circle is a free edge (no wall), so those points lie beyond B:
    B does not cover A (exit 3), and the numbers are over the rest (0)."""
    a, b = sheets
    out = tmp_path / "d.exr"
    assert main(["deviation", str(a), str(b), "-o", str(out), "--tolerance", "1e-6"]) == 3
    channels, header = read_exr(out)
    on = channels["patch"] >= 0
    P = np.stack([channels[f"P.{c}"][on] for c in "XYZ"], -1).astype(np.float64)
    rho = np.hypot(P[:, 0] - 2, P[:, 1])
    over = rho < 1.9
    assert over.sum() > 100
    f = np.abs(channels["f"][on].astype(np.float64))
    np.testing.assert_allclose(f[over], 2 - rho[over], atol=2e-6)  # P in float32
    foot = np.stack([channels[f"B.{c}"][on] for c in "XYZ"], -1)[over]
    np.testing.assert_allclose(np.hypot(foot[:, 0] - 2, foot[:, 1]), 2.0, atol=1e-5)
    np.testing.assert_allclose(foot[:, 2], 4.0, atol=1e-5)
    assert f[rho > 2.1].max() < 1e-9
    summary = json.loads(header["deviation"])
    assert over.sum() <= summary["beyond"] <= (rho < 2).sum()
    assert summary["max_abs"] < 1e-9 and summary["count"] == on.sum() - summary["beyond"]


@pytest.fixture(scope="module")
def oblique(tmp_path_factory):
    """A 10 x 8 x 4 block (A) and the same block drilled through by a cylinder of radius 1.5
    about the axis through (1, 0, 4) tilted 30 degrees toward +x (B: its top face and the
    hole's wall both trimmed by the rim, an ellipse of semi-axes 1.5 / cos 30 and 1.5),
    seen from above."""
    pytest.importorskip("OCP")
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt

    block = BRepPrimAPI_MakeBox(gp_Pnt(-5, -4, 0), 10, 8, 4).Shape()
    axis = np.array([np.sin(np.radians(30)), 0.0, np.cos(np.radians(30))])
    start = np.array([1.0, 0.0, 4.0]) - 8 * axis
    drill = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(*start), gp_Dir(*axis)), 1.5, 16).Shape()
    folder = tmp_path_factory.mktemp("oblique")
    return _from_above(folder, block=block, drilled=BRepAlgoAPI_Cut(block, drill).Shape())


def _to_ellipse(x: np.ndarray, y: np.ndarray, a: float, b: float) -> np.ndarray:
    """The distance of points (x, y) to the ellipse x^2/a^2 + y^2/b^2 = 1: the least over
    20,000 parameters, then Newton on t (an oracle independent of gshade's)."""
    t = np.linspace(0, 2 * np.pi, 20_000, endpoint=False)
    d2 = (x[:, None] - a * np.cos(t)) ** 2 + (y[:, None] - b * np.sin(t)) ** 2
    s = t[np.argmin(d2, axis=1)]
    for _ in range(8):
        ex, ey = a * np.cos(s) - x, b * np.sin(s) - y
        g = -ex * a * np.sin(s) + ey * b * np.cos(s)
        h = (a * np.sin(s)) ** 2 + (b * np.cos(s)) ** 2 - ex * a * np.cos(s) - ey * b * np.sin(s)
        s = s - g / h
    return np.hypot(a * np.cos(s) - x, b * np.sin(s) - y)


def _to_oblique_hole(P: np.ndarray) -> np.ndarray:
    """The distance of points P (n, 3) of the plane z = 4 inside the oblique hole to B:
    the nearer of the rim (:func:`_to_ellipse`) and the wall's foot point (the radial
    projection from the axis) where that lies below the top, on the wall."""
    axis = np.array([np.sin(np.radians(30)), 0.0, np.cos(np.radians(30))])
    w = P - [1.0, 0.0, 4.0]
    across = w - np.outer(w @ axis, axis)
    away = np.linalg.norm(across, axis=-1)
    foot = P - across + 1.5 * across / away[:, None]
    wall = np.where(foot[:, 2] <= 4.0, 1.5 - away, np.inf)
    rim = _to_ellipse(P[:, 0] - 1, P[:, 1], 1.5 / np.cos(np.radians(30)), 1.5)
    return np.minimum(rim, wall)


def test_an_oblique_holes_rim_is_a_trimmed_edge_of_both_faces(oblique, tmp_path):
    """A's top over B's oblique hole: on the side the wall leans away the closest point is
    on the rim, an edge both faces are trimmed by (the plane's foot lies in the hole, the
    wall's off its trims), so found only along the edge; where the wall leans under the
    opening, on the wall.  |d| = the nearer (an independent oracle) to 1e-9 at the largest
    (the header's point, in double), 2e-6 at the pixels (P in float32); B covers A there
    (the rim is no free edge): exit 2."""
    a, b = oblique
    out = tmp_path / "d.exr"
    assert main(["deviation", str(a), str(b), "-o", str(out), "--tolerance", "1e-6"]) == 2
    channels, header = read_exr(out)
    on = channels["patch"] >= 0
    P = np.stack([channels[f"P.{c}"][on] for c in "XYZ"], -1).astype(np.float64)
    semi = 1.5 / np.cos(np.radians(30))
    inner = ((P[:, 0] - 1) / semi) ** 2 + (P[:, 1] / 1.5) ** 2 < 0.8
    top = np.abs(P[:, 2] - 4) < 1e-4
    over = inner & top
    assert over.sum() > 80
    f = np.abs(channels["f"][on].astype(np.float64))
    expected = _to_oblique_hole(P[over])
    np.testing.assert_allclose(f[over], expected, atol=2e-6)
    rim = _to_ellipse(P[over, 0] - 1, P[over, 1], semi, 1.5)
    on_rim = np.abs(f[over] - rim) < 2e-6
    assert on_rim.sum() > 40  # on the rim: the edge search
    # beside P in A's tangent plane, the rim is on neither side: one sign, no speckle
    assert (channels["f"][on][over][on_rim] > 0).all()
    summary = json.loads(header["deviation"])
    assert summary["beyond"] == 0
    x, y, z = summary["point"]
    largest = _to_oblique_hole(np.array([[x, y, z]]))[0]
    assert z == pytest.approx(4.0, abs=1e-12)
    assert summary["max_abs"] == pytest.approx(largest, abs=1e-9)


def test_whole_surface_and_hausdorff_distance_both_ways(spheres, tmp_path, capsys):
    """--whole: every sampled point of A's whole sphere (not only the half in view) at
    |d| = 0.003; --symmetric: the Hausdorff distance 0.003 both ways, to 1e-12; --html:
    the page holds the numbers, A's name escaped."""
    a, b = spheres
    a.write_text(a.read_text().replace('name = "a"', 'name = "a<b>&"'))
    page = tmp_path / "d.html"
    out = tmp_path / "d.exr"
    args = [str(a), str(b), "-o", str(out), "--samples", "20000", "--tolerance", "0.01", "--json"]
    assert main(["deviation", *args, "--whole", "--symmetric", "--html", str(page)]) == 0
    listed = json.loads(capsys.readouterr().out)
    whole = listed["whole"]
    assert whole["samples"] > 15_000 and whole["count"] == whole["samples"]
    assert whole["max_abs"] == pytest.approx(0.003, rel=1e-12)
    assert whole["min"] == pytest.approx(whole["max"], rel=1e-9)  # one side everywhere
    P = np.asarray(whole["point"])
    assert np.linalg.norm(P) == pytest.approx(2.0, rel=1e-12)
    h = listed["hausdorff"]
    assert h["a_to_b"] == pytest.approx(0.003, rel=1e-12)
    assert h["b_to_a"] == pytest.approx(0.003, rel=1e-12)
    text = page.read_text()
    assert "a&lt;b&gt;&amp;" in text and "a<b>&" not in text
    assert "Hausdorff" in text and "0.003" in text and "data:image/png;base64," in text
    # the Hausdorff distance beyond the tolerance fails the run even where the view passes
    assert main(["deviation", *args[:-3], "--tolerance", "0.002", "--symmetric"]) == 2


@pytest.fixture(scope="module")
def kernel_sphere(tmp_path_factory):
    """A solid sphere of radius 2 (A, exact) and the kernel's mesh of it within a linear
    deflection of 0.01 (B, an STL file)."""
    pytest.importorskip("OCP")
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeSphere
    from OCP.BRepTools import BRepTools
    from OCP.StlAPI import StlAPI_Writer

    folder = tmp_path_factory.mktemp("kernel_sphere")
    ball = BRepPrimAPI_MakeSphere(2.0).Shape()
    BRepTools.Write_s(ball, str(folder / "ball.brep"))
    BRepMesh_IncrementalMesh(ball, 0.01, False, 0.5, True)
    writer = StlAPI_Writer()
    writer.ASCIIMode = False
    assert writer.Write(ball, str(folder / "ball.stl"))
    return folder / "ball.brep", folder / "ball.stl"


def test_a_sphere_against_its_own_kernel_mesh(kernel_sphere, tmp_path, capsys):
    """The exact sphere against its kernel mesh at a deflection of 0.01: every point of
    the whole sphere within the deflection of the mesh, the largest close to it (the
    chords' sagitta), the mesh inside (d <= 0 on the outward normal), and B's parts its
    triangles."""
    a, b = kernel_sphere
    out = tmp_path / "d.exr"
    args = ["deviation", str(a), str(b), "-o", str(out), "--tolerance", "0.011", "--json"]
    assert main([*args, "--whole", "--samples", "20000"]) == 0  # within 0.011
    listed = json.loads(capsys.readouterr().out)
    for s in (listed, listed["whole"]):
        assert 0.5 * 0.01 < s["max_abs"] <= 0.01 * (1 + 1e-6)
        assert s["max"] <= 1e-12 and s["beyond"] == 0
    channels, _ = read_exr(out)
    on = channels["patch"] >= 0
    assert channels["B.patch"][on].min() >= 0 and len(np.unique(channels["B.patch"][on])) > 50


def test_a_point_cloud_as_b(spheres, tmp_path, capsys):
    """B a cloud of 200,000 points of the sphere of radius 2.003 (an XYZ file): every
    pixel's nearest point at least 0.003 away, within the cloud's spacing of it."""
    a, _ = spheres
    rng = np.random.default_rng(5)
    points = rng.normal(size=(200_000, 3))
    points *= 2.003 / np.linalg.norm(points, axis=1, keepdims=True)
    cloud = tmp_path / "cloud.xyz"
    np.savetxt(cloud, points, fmt="%.17g")
    out = tmp_path / "d.exr"
    assert main(["deviation", str(a), str(cloud), "-o", str(out), "--json"]) == 2
    listed = json.loads(capsys.readouterr().out)
    channels, _ = read_exr(out)
    on = channels["patch"] >= 0
    f = np.abs(channels["f"][on].astype(np.float64))
    assert (f >= 0.003 * (1 - 1e-6)).all() and f.max() < 0.03
    assert min(abs(listed["min"]), abs(listed["max"])) >= 0.003 - 1e-12
    assert listed["count"] == on.sum()
