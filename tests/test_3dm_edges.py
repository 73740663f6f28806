"""Rhino edges on the faces that share them: each face's pcurve traces the edge curve C(t)
(S(c(t)) = C(t) to round-off of the model's size), and `gshade continuity` sees the faces
meet there (tests/test_3dm_edges.py; the files are built with rhino3dm at test time)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

rhino3dm = pytest.importorskip("rhino3dm")
pytest.importorskip("OCP")

from gshade.io import cad_3dm  # noqa: E402


def _write(tmp_path, breps, name="part.3dm"):
    f = rhino3dm.File3dm()
    for b in breps:
        f.Objects.AddBrep(b)
    path = tmp_path / name
    assert f.Write(str(path), 7)
    return path


def _cylinder(tmp_path):
    circle = rhino3dm.Circle(rhino3dm.Point3d(0, 0, 0), 2.0)
    return _write(tmp_path, [rhino3dm.Cylinder(circle, 3.0).ToBrep(True, True)])


def _sphere(tmp_path):
    return _write(tmp_path, [rhino3dm.Sphere(rhino3dm.Point3d(1, 2, 3), 1.5).ToBrep()])


def _image_error(path) -> tuple[float, int]:
    """max |S(c(t)) - C(t)| over every pcurve of the kernel's shape, over the model's size."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Curve, BRepAdaptor_Curve2d
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    model = cad_3dm.read(path)
    lo, hi = model.bounds
    size = float(np.linalg.norm(np.asarray(hi) - np.asarray(lo)))
    worst, count = 0.0, 0
    faces = TopExp_Explorer(model.shape, TopAbs_FACE)
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


@pytest.mark.parametrize("make", [_sphere])
def test_pcurves_trace_the_edges(tmp_path, make):
    error, count = _image_error(make(tmp_path))
    assert count >= 2
    # the pcurves trace the faces' points nearest the kernel's edge curve to 1e-12; this
    # edge curve is the cubic through the edge's samples (openNURBS's NURBS form has
    # another parametrisation), itself ~1e-9 off the sphere (was 2.4e-3 with cubic pcurves)
    assert error < 1e-8


def test_cylinder_rims_are_folds_at_90_degrees(tmp_path):
    junctions = _continuity(_cylinder(tmp_path))
    assert len(junctions) == 2  # the two rims (the seam is no junction between faces)
    for j in junctions:
        assert j["class"] == "G0"
        assert abs(j["normal_angle_deg"] - 90.0) < 1e-6
        assert j["gap"] < 1e-11 * 7.2
