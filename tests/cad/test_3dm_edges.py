"""Rhino edges on the faces that share them: each face's pcurve traces the edge curve C(t)
(S(c(t)) = C(t) to round-off of the model's size), and `gshade continuity` sees the faces
meet there (tests/cad/test_3dm_edges.py; the files are built with rhino3dm at test time)."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

rhino3dm = pytest.importorskip("rhino3dm")
pytest.importorskip("OCP")

from gshade.cad import rhino  # noqa: E402


def _write(tmp_path, breps=(), extrusions=(), name="part.3dm"):
    f = rhino3dm.File3dm()
    for b in breps:
        f.Objects.AddBrep(b)
    for e in extrusions:
        f.Objects.AddExtrusion(e)
    path = tmp_path / name
    assert f.Write(str(path), 7)
    return path


def _cylinder(tmp_path):
    circle = rhino3dm.Circle(rhino3dm.Point3d(0, 0, 0), 2.0)
    return _write(tmp_path, [rhino3dm.Cylinder(circle, 3.0).ToBrep(True, True)])


def _sphere(tmp_path):
    return _write(tmp_path, [rhino3dm.Sphere(rhino3dm.Point3d(1, 2, 3), 1.5).ToBrep()])


def _star(points: int = 12):
    """A closed cubic through a star's corners (radii 1.5 and 3, a kink where it closes)."""
    corners = [
        rhino3dm.Point3d(
            (3.0 if i % 2 else 1.5) * math.cos(2 * math.pi * i / points),
            (3.0 if i % 2 else 1.5) * math.sin(2 * math.pi * i / points),
            0.0,
        )
        for i in range(points)
    ]
    return rhino3dm.NurbsCurve.Create(False, 3, [*corners, corners[0]])


def _star_prism(tmp_path):
    """A capped extrusion of the star: a freeform side (degree 3 x 1, 12 knot spans), two
    planar caps trimmed by the freeform star, meeting the side at 90 degrees."""
    return _write(tmp_path, extrusions=[rhino3dm.Extrusion.Create(_star(), 2.0, True)])


def _corner_prism(tmp_path):
    """A capped extrusion of the star's cubic with a corner at its middle (an interior knot
    of full multiplicity): the caps' trim turns there, the side has a crease."""
    corners = _star().Points
    curve = rhino3dm.NurbsCurve(3, False, 4, len(corners))
    for i in range(len(corners)):
        curve.Points[i] = corners[i]
    for i, k in enumerate([0, 0, 0, 1, 2, 3, 4, 5, 5, 5, 6, 7, 8, 8, 8]):
        curve.Knots[i] = float(k)
    return _write(tmp_path, extrusions=[rhino3dm.Extrusion.Create(curve, 2.5, True)])


def _trimmed_plane(tmp_path):
    """One plane trimmed by the freeform star (no junction: its trim's pcurve alone)."""
    plane = rhino3dm.Plane.WorldXY()
    return _write(tmp_path, [rhino3dm.Brep.CreateTrimmedPlane(plane, _star(16))])


def _size(model) -> float:
    lo, hi = model.bounds
    return float(np.linalg.norm(np.asarray(hi) - np.asarray(lo)))


def _image_error(path) -> tuple[float, int]:
    """max |S(c(t)) - C(t)| over every pcurve of the kernel's shape, over the model's size."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Curve, BRepAdaptor_Curve2d
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    model = rhino.read(path)
    size = _size(model)
    worst, count = 0.0, 0
    faces = TopExp_Explorer(model.brep, TopAbs_FACE)
    while faces.More():
        face = TopoDS.Face(faces.Current())
        surface = BRep_Tool.Surface_s(face)
        edges = TopExp_Explorer(face, TopAbs_EDGE)
        while edges.More():
            edge = TopoDS.Edge(edges.Current())
            edges.Next()
            if BRep_Tool.Degenerated_s(edge):
                continue
            c3, c2 = BRepAdaptor_Curve(edge), BRepAdaptor_Curve2d(edge, face)
            a, b = c3.FirstParameter(), c3.LastParameter()
            for t in np.linspace(a, b, 101):
                p, w = c3.Value(float(t)), c2.Value(float(t))
                q = surface.Value(w.X(), w.Y())
                worst = max(worst, p.Distance(q) / size)
            count += 1
        faces.Next()
    return worst, count


def _continuity(path) -> list[dict]:
    out = subprocess.run(
        [sys.executable, "-m", "gshade", "continuity", str(path), "--json"],
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(out.stdout)["junctions"]


@pytest.mark.parametrize("make", [_sphere, _trimmed_plane, _star_prism, _corner_prism])
def test_pcurves_trace_the_edges(tmp_path, make):
    error, count = _image_error(make(tmp_path))
    assert count >= 1
    # the pcurves trace the faces' points nearest the kernel's edge curve to 1e-12 of the
    # model; the sphere's edge curve is the cubic through the edge's samples (openNURBS's
    # NURBS form has another parametrisation), itself ~1e-9 off the sphere (2.4e-3 with
    # the samples' cubic pcurves); the others' edges lie on their faces (2e-7 to 5e-6)
    assert error < (1e-8 if make is _sphere else 1e-11)


def test_cylinder_rims_are_folds_at_90_degrees(tmp_path):
    junctions = _continuity(_cylinder(tmp_path))
    assert len(junctions) == 2  # the two rims (the seam is no junction between faces)
    for j in junctions:
        assert j["class"] == "G0"
        assert abs(j["normal_angle_deg"] - 90.0) < 1e-6
        assert j["gap"] < 1e-11 * 7.2


@pytest.mark.parametrize("make", [_star_prism, _corner_prism])
def test_freeform_trims_meet_their_side(tmp_path, make):
    """The caps' freeform trims meet the side within round-off (the samples' cubic
    pcurves parted by 3.2e-6 and 4.8e-7, 3e-7 and 4e-8 of the model)."""
    path = make(tmp_path)
    size = _size(rhino.read(path))
    rims = [j for j in _continuity(path) if j["patches"][0] != j["patches"][1]]
    assert len(rims) >= 2  # cap to side, both caps (the corner's side: two faces, a fold)
    for j in rims:
        assert j["class"] == "G0"
        assert j["gap"] < 1e-10 * size
        assert j["normal_angle_deg"] > 45.0


def test_a_face_along_its_side_traces_its_boundary():
    """An edge a tolerance outside a face's boundary: the pcurve runs along that side (its
    parameter there pinned), at the side's point nearest the edge, inside the domain."""
    from OCP.collections import Array1_double, Array1_gp_Pnt, Array1_int
    from OCP.Geom import Geom_BSplineCurve
    from OCP.gp import gp_Pnt

    from gshade.cad import rhino_pcurves as pc
    from gshade.geometry.patches.bspline import BSplinePatch

    u = np.linspace(0.0, 1.0, 4)
    points = np.stack(np.meshgrid(u, u, indexing="ij"), -1)
    points = np.concatenate([points, 0.2 * np.sin(3 * points[..., :1])], -1)
    knots = [0, 0, 0, 0, 1, 1, 1, 1]
    patch = BSplinePatch(points, (3, 3), (knots, knots))
    poles = Array1_gp_Pnt(1, 4)  # the side v = 0 (y = 0), moved off it by up to 1e-6
    for i, (x, y, z) in enumerate(points[:, 0]):
        poles.SetValue(i + 1, gp_Pnt(x, y - (1e-6 if 0 < i < 3 else 0.0), z))
    ends, ends_twice = Array1_double(1, 2), Array1_int(1, 2)
    for i in (1, 2):
        ends.SetValue(i, float(i - 1))
        ends_twice.SetValue(i, 4)
    curve = Geom_BSplineCurve(poles, ends, ends_twice, 3, False)
    t = np.linspace(0.0, 1.0, 9)
    (fit,) = pc.fit_faces([(patch, [(curve, t, np.stack([t, 0 * t], -1))])], 1.0)[0]
    assert fit.error < 1e-12
    assert 5e-7 < fit.apart < 1e-6  # the edge's distance from the side
    along = np.linspace(0.0, 1.0, 33)
    at = np.array([[fit.curve.Value(float(s)).X(), fit.curve.Value(float(s)).Y()] for s in along])
    assert np.all(at[:, 1] == 0.0)
    # at the side's point nearest the edge: the side's tangent normal to the gap
    edge = np.array(
        [
            [curve.Value(float(s)).X(), curve.Value(float(s)).Y(), curve.Value(float(s)).Z()]
            for s in along
        ]
    )
    d = patch.derivatives(at[:, 0], at[:, 1], 1)
    along_side = d[1, 0] / np.linalg.norm(d[1, 0], axis=1)[:, None]
    assert np.abs(np.einsum("ij,ij->i", d[0, 0] - edge, along_side)).max() < 1e-13
