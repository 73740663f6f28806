"""Curvature combs (``render.combs``, ``--combs``) against closed forms: a kernel cylinder's
circular edges (curvature 1 / R everywhere, normal part -1 / R or 0, geodesic part), a
planar cubic's inflection at its known parameter, spines drawn only where the curve is in
sight, and the numbers in the header and ``--json``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gshade.analysis.curvature_combs import combs, iso_line_family
from gshade.analysis.scene_combs import scene_combs
from gshade.app.cli import main
from gshade.geometry import BezierPatch
from gshade.rendering import render
from gshade.rendering.camera import View, header_view
from gshade.rendering.comb_lines import in_sight
from gshade.scene import load_scene

R, HEIGHT = 3.0, 5.0


def _cubic_sheet() -> BezierPatch:
    """A bicubic sheet whose side v = 0 is the planar cubic c(t) = (3t, 4(2t - 1)^3 ... ):
    control points (0, -1), (1, 3), (2, -3), (3, 1) in the plane z = 0; its inflection, where
    x'y'' - y'x'' = 0, is at t = 1/2 by symmetry (the curve is odd about its middle)."""
    side = np.array([[0.0, -1.0], [1.0, 3.0], [2.0, -3.0], [3.0, 1.0]])
    points = np.zeros((4, 4, 3))
    for j in range(4):
        points[:, j, :2] = side
        points[:, j, 2] = j  # the sheet rises along v
    return BezierPatch(points)


def test_a_cubic_has_one_inflection_where_its_curvature_changes_sign():
    patch = _cubic_sheet()
    family = iso_line_family([patch], [(0, "v", 0.0, 0.0, 1.0, "cubic")])
    for curvature in ("space", "normal"):  # the sheet stands on the curve: k is normal
        (comb,) = combs([family], [patch], samples=40, curvature=curvature)
        assert len(comb.inflections) == 1
        found = comb.inflections[0]
        assert found.t == pytest.approx(0.5, abs=1e-12)
        np.testing.assert_allclose(found.point, patch(0.5, 0.0).ravel(), atol=1e-12)
    # the closed form of the planar curvature: (x'y'' - y'x'') / |c'|^3
    t = (np.arange(40) + 0.5) / 40
    d = patch.derivatives(t, np.zeros(40), 2)
    x1, y1 = d[1, 0][:, 0], d[1, 0][:, 1]
    x2, y2 = d[2, 0][:, 0], d[2, 0][:, 1]
    kappa = np.abs(x1 * y2 - y1 * x2) / np.hypot(x1, y1) ** 3
    (comb,) = combs([family], [patch], samples=40)
    np.testing.assert_allclose(comb.values, kappa, rtol=1e-12)


def test_a_straight_side_has_no_comb_and_no_inflection():
    """The sheet's side u = 0 is a straight line: zero curvature, no spurious sign changes
    from rounding."""
    patch = _cubic_sheet()
    family = iso_line_family([patch], [(0, "u", 0.0, 0.0, 1.0, "line")])
    (comb,) = combs([family], [patch], samples=50)
    assert np.abs(comb.values).max() < 1e-12
    assert comb.inflections == []


@pytest.fixture(scope="module")
def cylinder(tmp_path_factory) -> Path:
    pytest.importorskip("OCP")
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeCylinder
    from OCP.BRepTools import BRepTools
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt

    folder = tmp_path_factory.mktemp("combs")
    shape = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), R, HEIGHT).Shape()
    BRepTools.Write_s(shape, str(folder / "cylinder.brep"))
    scene = folder / "cylinder.toml"
    scene.write_text(
        '[[surface]]\ntype = "cad"\nfile = "cylinder.brep"\n'
        '[shape]\nfunction = "mean"\ndisplay = "colormap"\n'
        "[render]\nwidth = 160\nheight = 120\nspp = 1\n"
        "[camera]\norigin = [14, -18, 12]\ntarget = [0, 0, 2.5]\nup = [0, 0, 1]\n"
    )
    return scene


def test_a_cylinders_circular_edges_have_constant_combs(cylinder):
    """The two circles (the seam, a line, is no comb): space curvature 1/R at every sample,
    the spines all one length; the normal part is the cylinder's -1/R or the cap's 0 (on
    whichever face the edge is taken), the geodesic part the other."""
    scene = load_scene(cylinder)
    found = scene_combs(scene, lines=("edges",), samples=33)
    circles = [c for c in found if np.ptp(c.points[:, 2]) < 1e-9]
    assert len(circles) == 2
    for comb in circles:
        np.testing.assert_allclose(comb.values, 1.0 / R, rtol=1e-12)
        lengths = np.linalg.norm(comb.vectors, axis=-1)
        np.testing.assert_allclose(lengths, lengths[0], rtol=1e-12)
        # the spine points away from the axis: -k is radial, outward
        radial = comb.points[:, :2] / np.linalg.norm(comb.points[:, :2], axis=-1)[:, None]
        np.testing.assert_allclose(-comb.vectors[:, :2] * R, radial, atol=1e-12)
        assert comb.inflections == []
    normal = scene_combs(scene, lines=("edges",), samples=17, curvature="normal")
    geodesic = scene_combs(scene, lines=("edges",), samples=17, curvature="geodesic")
    for n, g in zip(normal, geodesic, strict=True):
        if np.ptp(n.points[:, 2]) < 1e-9:
            parts = np.hypot(n.values, g.values)
            np.testing.assert_allclose(parts, 1.0 / R, rtol=1e-12)
            assert min(np.abs(n.values).max(), np.abs(g.values).max()) < 1e-12


def _view(image) -> View:
    H, W = image["patch"].shape
    return header_view(image.metadata, W, H)


def test_combs_are_drawn_where_the_edges_are_seen(cylinder):
    """Seen from above and in front, the top circle is in sight all round, the bottom
    circle on its near half only (the side hides the rest); spines change the picture, the
    header and the legend give the numbers."""
    plain = render(load_scene(cylinder))
    image = render(load_scene(cylinder), combs=True)
    rgb = np.stack([image[c] for c in "RGB"], -1)
    changed = np.abs(rgb - np.stack([plain[c] for c in "RGB"], -1)).max(-1) > 1e-3
    assert changed.sum() > 200
    view = _view(image)
    angle = np.linspace(0, 2 * np.pi, 72, endpoint=False)
    eye = np.arctan2(view.origin[1], view.origin[0])
    for z in (0.0, HEIGHT):
        circle = np.stack([R * np.cos(angle), R * np.sin(angle), np.full(72, z)], -1)
        seen = in_sight(circle, image.channels, view)
        facing = np.cos(angle - eye)  # > 0: the near half
        if z == HEIGHT:
            assert seen.all()
        else:
            assert seen[facing > 0.3].all() and not seen[facing < -0.3].any()
    summary = json.loads(image.metadata["combs"])
    assert summary["curvature"] == "space"
    assert summary["max"]["value"] == pytest.approx(1.0 / R, rel=1e-12)
    assert "combs: space curvature" in image.metadata["legend"]


def test_combs_json(cylinder, tmp_path, capsys):
    out = tmp_path / "c.exr"
    assert main(["render", str(cylinder), "--combs", "-o", str(out), "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert listed["combs"]["curves"] == 2
    assert listed["combs"]["inflections"] == []


@pytest.mark.parametrize(
    ("key", "value", "expected"),
    [
        ("comb_curvature", '"mean"', "comb_curvature: expected one of"),
        ("comb_lines", '["edges", "seams"]', "comb_lines: expected a list of"),
        ("comb_scale", "-1", "comb_scale: expected a positive number"),
    ],
)
def test_bad_comb_keys_get_one_line(cylinder, key, value, expected, capsys):
    assert main(["render", str(cylinder), "--set", f"render.{key}={value}"]) == 2
    err = capsys.readouterr().err
    assert expected in err and len(err.strip().splitlines()) == 1
