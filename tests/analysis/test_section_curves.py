"""Combs along planar sections (``render.comb_lines = ["sections"]``) against closed forms:
a sphere's latitude circles (curvature 1 / r, normal part 1 / R, the parts adding up), a
saddle's parabolas z = c² - y² (2 / (1 + 4y²)^(3/2)), the inflection of the cubic z = y³
at y = 0, and a kernel block with a drilled hole: the hole's circles, no cut inside the
hole."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gshade.analysis.curvature_combs import combs
from gshade.analysis.scene_combs import scene_combs
from gshade.analysis.section_curves import SectionPlanes, SectionRegion, section_family
from gshade.geometry import BezierPatch, sphere
from gshade.scene import load_scene

X, Y, Z = np.eye(3)


def _graph(along_x: list[float], along_y: list[float]) -> BezierPatch:
    """The graph z = a(x) + b(y) over [-1, 1]², x and y linear in u and v, ``along_x`` and
    ``along_y`` the Bernstein coefficients of a and b (x² = (1, -1, 1), y³ = (-1, 1, -1, 1))."""
    m, n = len(along_x), len(along_y)
    x, y = np.meshgrid(np.linspace(-1, 1, m), np.linspace(-1, 1, n), indexing="ij")
    z = np.add.outer(along_x, along_y)
    return BezierPatch(np.stack([x, y, z], -1))


def _family(patch, direction, levels):
    region = SectionRegion(0, patch.domain, None, "patch 0")
    return section_family([patch], [region], SectionPlanes(direction, np.asarray(levels)))


def test_a_spheres_sections_are_circles_of_known_curvature():
    R = 2.0
    ball = sphere(R)
    family = _family(ball, Z, [-1.0, 0.5, 1.5])
    space = combs([family], [ball], samples=41)
    normal = combs([family], [ball], samples=41, curvature="normal")
    geodesic = combs([family], [ball], samples=41, curvature="geodesic")
    assert len(space) == 3
    for s, n, g, level in zip(space, normal, geodesic, [-1.0, 0.5, 1.5], strict=True):
        np.testing.assert_allclose(s.points[:, 2], level, atol=1e-13)
        np.testing.assert_allclose(s.values, 1 / np.sqrt(R * R - level * level), rtol=1e-12)
        np.testing.assert_allclose(np.abs(n.values), 1 / R, rtol=1e-12)
        np.testing.assert_allclose(np.hypot(n.values, g.values), s.values, rtol=1e-12)
        # the spines point away from the circle's centre on the axis
        outward = s.points[:, :2] / np.linalg.norm(s.points[:, :2], axis=-1)[:, None]
        np.testing.assert_allclose(
            -s.vectors[:, :2] / np.linalg.norm(s.vectors[:, :2], axis=-1)[:, None],
            outward,
            atol=1e-12,
        )
        assert s.inflections == []


def test_a_saddles_sections_are_parabolas():
    """z = x² - y² cut by x = c: z = c² - y², curvature 2 / (1 + 4y²)^(3/2), in the plane."""
    saddle = _graph([1.0, -1.0, 1.0], [-1.0, 1.0, -1.0])
    family = _family(saddle, X, [-0.6, 0.2])
    found = combs([family], [saddle], samples=37)
    assert len(found) == 2
    for comb, c in zip(found, [-0.6, 0.2], strict=True):
        x, y, z = comb.points.T
        np.testing.assert_allclose(x, c, atol=1e-13)
        np.testing.assert_allclose(z, c * c - y * y, atol=1e-13)
        np.testing.assert_allclose(comb.values, 2 / (1 + 4 * y * y) ** 1.5, rtol=1e-11)
        np.testing.assert_allclose(comb.vectors[:, 0], 0, atol=1e-12)


def test_a_cubic_section_has_its_inflection():
    """z = y³ cut by x = c: an inflection at y = 0, found at the point (c, 0, 0)."""
    cubic = _graph([0.0, 0.0], [-1.0, 1.0, -1.0, 1.0])
    family = _family(cubic, X, [0.3])
    (comb,) = combs([family], [cubic], samples=40)
    np.testing.assert_allclose(comb.points[:, 2], comb.points[:, 1] ** 3, atol=1e-13)
    assert len(comb.inflections) == 1
    np.testing.assert_allclose(comb.inflections[0].point, [0.3, 0.0, 0.0], atol=1e-12)


@pytest.fixture(scope="module")
def drilled(tmp_path_factory) -> Path:
    """A 10 x 8 x 4 block with a hole of radius 2 drilled down through (2, 0)."""
    pytest.importorskip("OCP")
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder
    from OCP.BRepTools import BRepTools
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt

    block = BRepPrimAPI_MakeBox(gp_Pnt(-5, -4, 0), 10, 8, 4).Shape()
    drill = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(2, 0, -1), gp_Dir(0, 0, 1)), 2.0, 6).Shape()
    folder = tmp_path_factory.mktemp("sections")
    BRepTools.Write_s(BRepAlgoAPI_Cut(block, drill).Shape(), str(folder / "block.brep"))
    scene = folder / "block.toml"
    scene.write_text(
        '[[surface]]\ntype = "cad"\nfile = "block.brep"\n'
        '[shape]\nfunction = "planar_sections"\ndirection = [1, 0, 0]\n'
        "[render]\nwidth = 160\nheight = 120\nspp = 1\ncombs = true\n"
        'comb_lines = ["sections"]\ncomb_sections = 5\n'
    )
    return scene


def test_sections_of_a_drilled_block_stay_inside_the_trims(drilled):
    """Cut by planes z = c: the hole's circles (curvature 1/2), the block's walls straight;
    cut by x = c (the shape function's direction, the default): nothing inside the hole on
    the top and bottom faces."""
    scene = load_scene(drilled)
    across = scene_combs(scene, lines=("sections",), samples=33, section_direction=(0, 0, 1))
    levels = (np.arange(8) + 0.5) / 8 * 4
    holes = [c for c in across if np.linalg.norm(c.points[:, :2] - [2, 0], axis=-1).max() < 2.01]
    assert len(holes) == 8  # one circle a plane
    for comb in holes:
        assert np.min(np.abs(comb.points[0, 2] - levels)) < 1e-12
        radius = np.linalg.norm(comb.points[:, :2] - [2, 0], axis=-1)
        np.testing.assert_allclose(radius, 2, rtol=1e-12)
        np.testing.assert_allclose(comb.values, 0.5, rtol=1e-10)
    for comb in across:
        if comb not in holes:
            assert np.nanmax(comb.values) < 1e-9  # the walls: straight cuts
    down = scene_combs(scene, lines=("sections",), samples=33, sections=5)
    assert down and all(np.ptp(c.points[:, 0]) < 1e-12 for c in down)
    flat = [c for c in down if np.ptp(c.points[:, 2]) < 1e-12]
    assert flat
    for comb in flat:
        assert (np.linalg.norm(comb.points[:, :2] - [2, 0], axis=-1) > 2 - 0.01).all()
