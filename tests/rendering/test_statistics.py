"""The numbers with every render: over the visible and the whole surface, each extreme with
where it is, in the EXR header and on ``gshade render --json``; the smallest radius of an
ellipsoid made by the kernel where the closed form puts it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import gshade
from gshade.scene import load_scene

pytest.importorskip("OCP")

from OCP.BRepBuilderAPI import BRepBuilderAPI_GTransform
from OCP.BRepPrimAPI import BRepPrimAPI_MakeSphere
from OCP.gp import gp_GTrsf, gp_Mat

from ..support.cad_parts import write_shape

AXES = (6.0, 4.0, 2.0)  # the ellipsoid's semi-axes a > b > c


@pytest.fixture(scope="module")
def ellipsoid(tmp_path_factory) -> Path:
    """x^2/a^2 + y^2/b^2 + z^2/c^2 = 1, the unit sphere stretched by the kernel (a NURBS)."""
    stretch = gp_GTrsf()
    stretch.SetVectorialPart(gp_Mat(AXES[0], 0, 0, 0, AXES[1], 0, 0, 0, AXES[2]))
    shape = BRepBuilderAPI_GTransform(BRepPrimAPI_MakeSphere(1.0).Shape(), stretch, True)
    folder = tmp_path_factory.mktemp("statistics")
    write_shape(shape.Shape(), folder / "ellipsoid.step")
    (folder / "radius.toml").write_text(
        '[[surface]]\ntype = "cad"\nfile = "ellipsoid.step"\n'
        '[shape]\nfunction = "min_radius"\nlimit = 1.0\ndisplay = "bands"\n'
        "[camera]\norigin = [0, -30, 12]\ntarget = [0, 0, 0]\nup = [0, 0, 1]\n"
        "[render]\nwidth = 96\nheight = 72\nspp = 1\n"
    )
    return folder


def test_the_smallest_radius_of_an_ellipsoid_is_found_on_the_whole_surface(ellipsoid):
    """The largest curvature a / c^2 (radius c^2 / a) lies at (+-a, 0, 0), out of this view
    (it looks along +y at the side): the whole-surface summary finds it, polished to 1e-9,
    and its point; the smallest |k_max|, c / b^2, at the poles (0, 0, +-c).  The visible
    summary holds the pixels' exact values: its extremes are the channels' own."""
    a, b, c = AXES
    image = gshade.render(load_scene(ellipsoid / "radius.toml"))
    numbers = json.loads(image.metadata["statistics"])
    radius = numbers["min_radius"]
    assert radius["value"] == pytest.approx(c * c / a, rel=1e-9)
    assert radius["side"] == "convex"  # the kernel's outward normal: curving away from it
    np.testing.assert_allclose(np.abs(radius["point"]), [a, 0, 0], atol=1e-6)
    surface = numbers["surface"]
    assert surface["min"]["value"] == pytest.approx(-a / c**2, rel=1e-9)
    assert surface["max"]["value"] == pytest.approx(-c / b**2, rel=1e-6)
    np.testing.assert_allclose(np.abs(surface["max"]["point"]), [0, 0, c], atol=1e-3)
    visible = numbers["visible"]
    on = image["patch"] >= 0
    assert visible["count"] == on.sum()
    assert visible["min"]["value"] == pytest.approx(float(image["f"][on].min()))
    assert visible["min"]["value"] > surface["min"]["value"] + 0.1  # the tips are not seen
    k = np.argmax(np.where(on, image["f"], -np.inf))
    P = [float(image[f"P.{c}"].flat[k]) for c in "XYZ"]
    np.testing.assert_allclose(visible["max"]["point"], P)
    assert set(visible["percentiles"]) == {"1", "5", "25", "50", "75", "95", "99"}


def test_render_json_prints_one_object(ellipsoid, tmp_path):
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "gshade",
            "render",
            str(ellipsoid / "radius.toml"),
            "-o",
            str(tmp_path / "e.exr"),
            "--json",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    listed = json.loads(out.stdout)
    assert listed["output"] == str(tmp_path / "e.exr")
    assert listed["function"] == "min_radius" and listed["patch_label"] == "face"
    assert {"visible", "surface", "min_radius", "legend"} <= set(listed)
    assert listed["min_radius"]["value"] == pytest.approx(AXES[2] ** 2 / AXES[0], rel=1e-9)
