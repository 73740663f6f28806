"""Rhino .3dm files read into exact faces (files written at test time with rhino3dm)."""

from __future__ import annotations

import numpy as np
import pytest

from gshade.cad import read_cad
from gshade.errors import GshadeError
from gshade.geometry import gaussian_and_mean_curvature
from gshade.geometry.patches.bspline import BSplinePatch

r3 = pytest.importorskip("rhino3dm")
from gshade.cad import rhino, rhino_trims  # noqa: E402


def _write(tmp_path, name, *geoms, unit=None):
    f = r3.File3dm()
    if unit is not None:
        f.Settings.ModelUnitSystem = unit
    for g in geoms:
        if isinstance(g, r3.Brep):
            f.Objects.AddBrep(g)
        elif isinstance(g, r3.Surface):
            f.Objects.AddSurface(g)
        else:
            f.Objects.Add(g, None)
    path = tmp_path / name
    assert f.Write(str(path), 7)
    return path


def _nurbs(rational: bool) -> object:
    """A bicubic x biquadratic surface, non-uniform knots, uneven weights when rational."""
    s = r3.NurbsSurface.Create(3, rational, 4, 3, 5, 4)
    ku = [0.0, 0.0, 0.0, 0.4, 1.0, 1.0, 1.0]
    kv = [0.0, 0.0, 0.3, 1.0, 1.0]
    for i, k in enumerate(ku):
        s.KnotsU[i] = k
    for i, k in enumerate(kv):
        s.KnotsV[i] = k
    rng = np.random.default_rng(1)
    for i in range(5):
        for j in range(4):
            x, y, z = i + 0.2 * rng.random(), j + 0.2 * rng.random(), rng.random()
            w = 0.5 + rng.random() if rational else 1.0
            s.Points[i, j] = r3.Point4d(x * w, y * w, z * w, w)
    assert s.IsValid
    return s


def _max_error(patch: BSplinePatch, surface, n=50, seed=0, mapped=None) -> float:
    rng = np.random.default_rng(seed)
    du, dv = surface.Domain(0), surface.Domain(1)
    err = 0.0
    for _ in range(n):
        s = du.T0 + (du.T1 - du.T0) * rng.random()
        t = dv.T0 + (dv.T1 - dv.T0) * rng.random()
        a, b = (s, t) if mapped is None else mapped(s, t)
        p = surface.PointAt(s, t)
        err = max(err, float(np.linalg.norm(patch(a, b) - [p.X, p.Y, p.Z])))
        nr = surface.NormalAt(s, t)
        d = patch.derivatives(a, b, 1)
        nn = np.cross(d[1, 0], d[0, 1])
        if np.linalg.norm(nn) > 1e-6:
            nn /= np.linalg.norm(nn)
            err = max(err, float(np.linalg.norm(nn - [nr.X, nr.Y, nr.Z])))
    return err


def test_sphere_exact_and_curvature(tmp_path):
    r = 2.5
    path = _write(tmp_path, "s.3dm", r3.Sphere(r3.Point3d(1, 2, 3), r).ToBrep())
    model = read_cad(path)
    brep = r3.File3dm.Read(str(path)).Objects[0].Geometry
    assert len(model.faces) == len(brep.Faces) == 1
    for cf, face in zip(model.faces, [brep.Faces[0]], strict=True):
        assert cf.exact and cf.patch.rational and cf.kind == "sphere"

        def mapped(s, t, face=face):
            ok, a, b = face.GetNurbsFormParameterFromSurfaceParameter(s, t)
            assert ok
            return a, b

        assert _max_error(cf.patch, face, mapped=mapped) < 1e-9 * r
        (u0, u1), (v0, v1) = cf.box
        u = np.linspace(u0, u1, 7)[:, None]
        v = np.linspace(v0 + 0.2 * (v1 - v0), v1 - 0.2 * (v1 - v0), 5)[None, :]
        K, H = gaussian_and_mean_curvature(cf.patch.derivatives(u, v, 2))
        np.testing.assert_allclose(np.abs(H), 1 / r, rtol=1e-9)
        np.testing.assert_allclose(K, 1 / r**2, rtol=1e-9)
        assert cf.loops and cf.loops[0].shape[1] == 2
        assert cf.loop_tolerance < 1e-6
        # the outer loop is the seam (up on one side, down on the other) and the poles: it
        # bounds the box (but for the pole's last chord), not a loop folded onto one side
        L, ((u0, u1), (v0, v1)) = cf.loops[0], cf.box
        area = 0.5 * np.sum(L[:-1, 0] * L[1:, 1] - L[1:, 0] * L[:-1, 1])
        assert area == pytest.approx((u1 - u0) * (v1 - v0), rel=1e-2)
    lo, hi = model.bounds
    np.testing.assert_allclose(lo, [1 - r, 2 - r, 3 - r], atol=1e-6 * r)
    np.testing.assert_allclose(hi, [1 + r, 2 + r, 3 + r], atol=1e-6 * r)


@pytest.mark.parametrize("rational", [False, True])
def test_nurbs_surface_exact(tmp_path, rational):
    s = _nurbs(rational)
    model = read_cad(_write(tmp_path, "n.3dm", s))
    (face,) = model.faces
    assert face.patch.rational == rational and not face.trimmed
    assert _max_error(face.patch, s) < 1e-12


def test_wrong_padding_or_weights_is_caught(tmp_path):
    s = _nurbs(True)
    good = rhino.nurbs_patch(s)
    assert _max_error(good, s) < 1e-12
    U, V = good.knots
    U2 = U.copy()
    U2[0] -= 0.5  # harmless: outside the domain
    assert _max_error(BSplinePatch(good.points, (3, 2), (U2, V), good.weights), s) < 1e-12
    ku = np.asarray(s.KnotsU.ToList())
    with pytest.raises(GshadeError):  # openNURBS knots taken unpadded
        BSplinePatch(good.points, (3, 2), (ku, V), good.weights)
    inner = U.copy()
    inner[4] = 0.6  # an interior knot wrong: the surface changes
    assert _max_error(BSplinePatch(good.points, (3, 2), (inner, V), good.weights), s) > 1e-3
    assert _max_error(BSplinePatch(good.points, (3, 2), (U, V)), s) > 1e-3  # weights dropped


def test_cylinder_closed_and_brep(tmp_path):
    cyl = r3.Cylinder(r3.Circle(r3.Point3d(0, 0, 0), 1.5), 2.0)
    s = cyl.ToNurbsSurface()
    model = read_cad(_write(tmp_path, "c.3dm", s, cyl.ToBrep(True, True)))
    assert _max_error(model.faces[0].patch, s) < 1e-12
    kinds = sorted(f.kind for f in model.faces[1:])
    assert kinds == ["cylinder", "plane", "plane"]
    for f in model.faces[1:]:
        assert f.loops and f.loop_tolerance < 1e-6
        (u0, u1), (v0, v1) = f.box
        L = f.loops[0]
        assert np.all((L[:, 0] >= u0 - 1e-9) & (L[:, 0] <= u1 + 1e-9))
        assert np.all((L[:, 1] >= v0 - 1e-9) & (L[:, 1] <= v1 + 1e-9))
        np.testing.assert_array_equal(L[0], L[-1])
        # the side's outer loop bounds its whole box (the seam traversed on both sides of the
        # periodic direction, not folded onto one); a cap's is the disk (a plane's (u, v) are
        # lengths here)
        area = abs(0.5 * np.sum(L[:-1, 0] * L[1:, 1] - L[1:, 0] * L[:-1, 1]))
        expected = (u1 - u0) * (v1 - v0) if f.kind == "cylinder" else np.pi * 1.5**2
        assert area == pytest.approx(expected, rel=1e-3), f.kind


def test_units(tmp_path):
    path = _write(tmp_path, "u.3dm", _nurbs(False), unit=r3.UnitSystem.Millimeters)
    assert read_cad(path).unit == "mm"
    path = _write(tmp_path, "i.3dm", _nurbs(False), unit=r3.UnitSystem.Inches)
    assert read_cad(path).unit == "in"


def test_bad_input(tmp_path):
    text = tmp_path / "x.3dm"
    text.write_text("not a rhino file\n")
    good = _write(tmp_path, "g.3dm", r3.Sphere(r3.Point3d(0, 0, 0), 1.0).ToBrep())
    data = good.read_bytes()
    half = tmp_path / "half.3dm"
    half.write_bytes(data[: len(data) // 2])
    empty = _write(tmp_path, "p.3dm", r3.Point(r3.Point3d(1, 2, 3)))
    for path in (text, half, empty, tmp_path / "missing.3dm", tmp_path):
        with pytest.raises(GshadeError) as info:
            read_cad(path if path != tmp_path else tmp_path)
        msg = str(info.value)
        assert "\n" not in msg and str(path) in msg


def _double_wall() -> object:
    """A mug-like surface of revolution: a thin double wall (up the outside, over the rim, down
    the inside, 0.03 apart) crowded into short knot spans of the profile between two long
    spans that hold the floor, so that a grid uniform in (u, v) barely samples the wall."""
    pts = [(0.2, 0, 0), (1, 0, 0), (1, 0, 0.5), (1, 0, 1), (0.985, 0, 1.02)]
    pts += [(0.97, 0, 1), (0.97, 0, 0.5), (0.97, 0, 0.03), (0.2, 0, 0.03)]
    c = r3.NurbsCurve.Create(False, 3, [r3.Point3d(*p) for p in pts])
    for i, k in enumerate([0, 0, 0, 10, 10.1, 10.2, 10.3, 10.4, 20, 20, 20]):
        c.Knots[i] = k
    axis = r3.Line(r3.Point3d(0, 0, 0), r3.Point3d(0, 0, 1))
    s = r3.RevSurface.Create(c, axis, 0.0, 2 * np.pi)
    return r3.Brep.CreateFromRevSurface(s, False, False)


def test_loops_on_the_right_sheet(tmp_path):
    """Every recovered loop point maps back onto its edge, not onto the other wall nearby."""
    brep = _double_wall()
    model = rhino.read(_write(tmp_path, "wall.3dm", brep))
    (face,) = model.faces
    edges = np.concatenate([rhino_trims.edge_points(e)[1] for e in brep.Edges])
    size = float(np.ptp(edges, axis=0).max())
    assert face.loops
    for loop in face.loops:
        P = face.patch(loop[:, 0], loop[:, 1])
        d = np.sqrt(((P[:, None, :] - edges[None, :, :]) ** 2).sum(-1)).min(axis=1)
        assert d.max() < 1e-6 * size
    assert face.loop_tolerance < 1e-6


def _edge_faces(shape) -> list[int]:
    """How many faces use each non-degenerated edge of the kernel's shape."""
    from OCP.BRep import BRep_Tool
    from OCP.collections import (
        IndexedDataMap_TopoDS_Shape_List_TopoDS_Shape_TopTools_ShapeMapHasher as EdgeFaces,
    )
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS

    edges = EdgeFaces()
    TopExp.MapShapesAndAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, edges)
    return [
        edges.FindFromIndex(i).Size()
        for i in range(1, edges.Extent() + 1)
        if not BRep_Tool.Degenerated_s(TopoDS.Edge(edges.FindKey(i)))
    ]


def _render(path, camera, **settings):
    from gshade.rendering import render
    from gshade.scene import load_scene

    over = {"render.width": 96, "render.height": 72, "render.spp": 2, **settings}
    over |= {f"camera.{k}": v for k, v in camera.items()}
    return render(load_scene(path, over))


def _silhouette(A):
    from scipy import ndimage

    label, _ = ndimage.label(A == 0)
    edge = np.unique(np.concatenate([label[0], label[-1], label[:, 0], label[:, -1]]))
    return ~np.isin(label, edge[edge > 0])


def test_closed_box_shape_is_sewn_and_renders_without_holes(tmp_path):
    pytest.importorskip("OCP")
    from OCP.BRepCheck import BRepCheck_Analyzer

    from gshade.cad.kernel import shape_faces

    box = r3.Box(r3.BoundingBox(r3.Point3d(0, 0, 0), r3.Point3d(1, 2, 3)))
    path = _write(tmp_path, "box.3dm", r3.Brep.CreateFromBox(box))
    model = read_cad(path, isolated=False)  # the kernel's shape here
    assert len(model.faces) == 6 and model.brep is not None
    faces = shape_faces(model.brep)
    assert len(faces) == 6 and BRepCheck_Analyzer(model.brep).IsValid()
    assert _edge_faces(model.brep) == [2] * 12  # every edge shared by exactly two faces
    # the shape's faces are the model's, in order: the same surface at the same (u, v)
    from OCP.BRep import BRep_Tool

    for face, cad in zip(faces, model.faces, strict=True):
        (u0, u1), (v0, v1) = cad.box
        u, v = 0.3 * u0 + 0.7 * u1, 0.6 * v0 + 0.4 * v1
        p = BRep_Tool.Surface_s(face).Value(u, v)
        np.testing.assert_allclose([p.X(), p.Y(), p.Z()], cad.patch(u, v).ravel(), atol=1e-12)
    camera = {"origin": [4.0, -5.0, 6.0], "target": [0.5, 1.0, 1.5], "up": [0, 0, 1]}
    image = _render(path, camera)
    A = image["A"]
    inside = _silhouette(A)
    assert (A > 0).sum() > 500 and not ((A == 0) & inside).any()
    assert set(np.unique(image["patch"])) - {-1} <= set(range(6))


def test_sphere_renders_mean_curvature(tmp_path):
    r = 2.0
    path = _write(tmp_path, "ball.3dm", r3.Sphere(r3.Point3d(0, 0, 0), r).ToBrep())
    model = read_cad(path, isolated=False)  # the kernel's shape here
    assert _edge_faces(model.brep) == [2]  # the seam, used twice by the one face
    camera = {"origin": [5.0, -6.0, 4.0], "target": [0, 0, 0], "up": [0, 0, 1]}
    image = _render(path, camera, **{"shape.function": "mean", "render.lighting": "flat"})
    A, f = image["A"], image["f"]
    from scipy import ndimage

    inside = ndimage.binary_erosion(_silhouette(A))
    assert inside.sum() > 500 and not ((A == 0) & _silhouette(A)).any()
    assert np.abs(np.abs(f[inside & (A == 1)]) - 1 / r).max() < 1e-6


def test_trimmed_disc_leaves_its_corners_open(tmp_path):
    """A plane trimmed to a disc: the square's corners stay background.  (rhino3dm offers no
    way to cut an inner loop at test time: CreateTrimmedPlane takes one curve, and there are
    no boolean operations; inner loops are checked on the shared files by hand.)"""
    disc = r3.Circle(r3.Point3d(0, 0, 0), 2.0).ToNurbsCurve()
    brep = r3.Brep.CreateTrimmedPlane(r3.Plane.WorldXY(), disc)
    path = _write(tmp_path, "disc.3dm", brep)
    model = read_cad(path, isolated=False)  # the kernel's shape here
    (face,) = model.faces
    assert face.trimmed and _edge_faces(model.brep) == [1]
    camera = {"type": "orthographic", "origin": [0, 0, 10], "target": [0, 0, 0]}
    camera |= {"up": [0, 1, 0], "width": 6.0}
    image = _render(path, camera, **{"render.width": 90, "render.height": 90})
    A = image["A"]
    rows, cols = np.indices(A.shape)
    x = (cols + 0.5) / 90 * 6 - 3
    y = 3 - (rows + 0.5) / 90 * 6
    d = np.hypot(x, y)
    assert (A[d < 1.9] == 1).all() and not (A[d > 2.1] > 0).any()


def test_meshes_or_curves_only_are_refused(tmp_path, capsys):
    from gshade.app.cli import main

    mesh = r3.Mesh()
    for p in ((0, 0, 0), (1, 0, 0), (0, 1, 0)):
        mesh.Vertices.Add(*p)
    mesh.Faces.AddFace(0, 1, 2)
    line = r3.LineCurve(r3.Point3d(0, 0, 0), r3.Point3d(1, 1, 0))
    for name, geom, words in (("m.3dm", mesh, "mesh"), ("c.3dm", line, "curve")):
        path = _write(tmp_path, name, geom)
        with pytest.raises(GshadeError) as info:
            read_cad(path)
        msg = str(info.value)
        assert "\n" not in msg and str(path) in msg and "only" in msg and words in msg
        out = tmp_path / f"{name}.exr"
        assert main(["render", str(path), "-o", str(out), "--png", str(out) + ".png"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and str(path) in err[0] and words in err[0]
        assert not out.exists() and not (tmp_path / f"{name}.exr.png").exists()
