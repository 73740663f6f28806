"""Umbilic points as points: an ellipsoid's four, at their closed-form places, from a
NURBS patch and from a kernel-made CAD face; a sphere umbilic all over; a torus none."""

from __future__ import annotations

import json

import numpy as np
import pytest

from gshade.analysis.umbilics import umbilic_field, umbilics
from gshade.app.cli import main
from gshade.geometry import BSplinePatch
from gshade.geometry.core.differential import gaussian_curvature, mean_curvature
from gshade.geometry.patches.revolution import sphere, torus

A, B, C = 3.0, 2.0, 1.0


def _expected() -> np.ndarray:
    """The ellipsoid's umbilics (a > b > c): x = ±a sqrt((a²-b²)/(a²-c²)), y = 0,
    z = ±c sqrt((b²-c²)/(a²-c²))."""
    x = A * np.sqrt((A * A - B * B) / (A * A - C * C))
    z = C * np.sqrt((B * B - C * C) / (A * A - C * C))
    return np.array([[sx * x, 0.0, sz * z] for sx in (1, -1) for sz in (1, -1)])


def _sorted(points) -> np.ndarray:
    p = np.asarray(points, dtype=float)
    q = np.round(p, 6)
    return p[np.lexsort((q[:, 2], q[:, 0]))]


def test_an_ellipsoid_has_four_umbilics_where_the_closed_form_puts_them():
    s = sphere(1.0)
    ellipsoid = BSplinePatch(s.points * np.array([A, B, C]), s.degree, s.knots, s.weights)
    found, everywhere = umbilics([ellipsoid], tolerance=1e-9)
    assert everywhere == []
    assert len(found) == 4
    np.testing.assert_allclose(_sorted([f.point for f in found]), _sorted(_expected()), atol=1e-9)
    for f in found:  # k1 = k2 there: H² = K, by the library's own curvature formulas
        d = ellipsoid.derivatives(np.array([f.u]), np.array([f.v]), 2)
        H, K = mean_curvature(d)[0], gaussian_curvature(d)[0]
        assert H * H == pytest.approx(K, rel=1e-9)
        assert abs(f.curvature) == pytest.approx(abs(H), rel=1e-9)


def test_a_sphere_is_umbilic_all_over_and_a_torus_nowhere():
    assert umbilics([sphere(2.0)]) == ([], [0])
    assert umbilics([torus(2.0, 0.5)]) == ([], [])


def test_the_field_vanishes_only_at_umbilics():
    """|F| / 2 = (k1 - k2) / 2: checked against the principal curvatures' gap."""
    t = torus(2.0, 0.5)
    u, v = np.array([0.1, 0.3, 0.7]), np.array([0.2, 0.5, 0.9])
    field, _, mean = umbilic_field(t, u, v)
    d = t.derivatives(u, v, 2)
    H, K = mean_curvature(d), gaussian_curvature(d)
    np.testing.assert_allclose(np.linalg.norm(field, axis=-1) / 2, np.sqrt(H * H - K), rtol=1e-9)
    np.testing.assert_allclose(np.abs(mean), np.abs(H), rtol=1e-12)


def test_a_cad_ellipsoids_umbilics_in_the_json(tmp_path, capsys):
    pytest.importorskip("OCP")
    from OCP.BRepBuilderAPI import BRepBuilderAPI_GTransform
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeSphere
    from OCP.BRepTools import BRepTools
    from OCP.gp import gp_GTrsf, gp_Mat

    g = gp_GTrsf()
    g.SetVectorialPart(gp_Mat(A, 0, 0, 0, B, 0, 0, 0, C))
    shape = BRepBuilderAPI_GTransform(BRepPrimAPI_MakeSphere(1.0).Shape(), g, True).Shape()
    BRepTools.Write_s(shape, str(tmp_path / "ellipsoid.brep"))
    scene = tmp_path / "ellipsoid.toml"
    scene.write_text(
        '[[surface]]\ntype = "cad"\nfile = "ellipsoid.brep"\n'
        '[shape]\nfunction = "gaussian"\ndisplay = "colormap"\n'
        "[render]\nwidth = 80\nheight = 60\n"
        "[camera]\norigin = [0, -12, 3]\ntarget = [0, 0, 0]\nup = [0, 0, 1]\n"
    )
    code = main(["render", str(scene), "-o", str(tmp_path / "e.exr"), "--json", "--parabolic"])
    assert code == 0
    listed = json.loads(capsys.readouterr().out)
    points = [u["point"] for u in listed["umbilics"]]
    np.testing.assert_allclose(_sorted(points), _sorted(_expected()), atol=1e-9)
    assert {u["face"] for u in listed["umbilics"]} == {0}
