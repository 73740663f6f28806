"""A surface's body (:mod:`gshade.scene.bodies`): what its patches stand for, asked instead of
branching on kinds."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

import gshade
from gshade.geometry import BezierPatch
from gshade.scene.bodies import PATCHES


def _patch() -> BezierPatch:
    rng = np.random.default_rng(5)
    return BezierPatch(rng.normal(size=(4, 3, 3)))


def test_patches_stand_for_their_whole_domain():
    patch = _patch()
    grid = np.linspace(0.0, 1.0, 17)
    u, v = np.meshgrid(grid, grid, indexing="ij")
    expected = np.asarray(patch(u, v)).reshape(-1, 3)
    points = PATCHES.extent_points([patch])
    assert points.shape == expected.shape
    assert np.allclose(np.sort(points, axis=0), np.sort(expected, axis=0), atol=1e-12)
    (tile,) = list(PATCHES.tile_extents([patch]))
    assert np.array_equal(tile, patch.points)  # the control net holds the patch
    assert PATCHES.length_unit is None and PATCHES.patch_label == "patch"
    assert not PATCHES.trimmed and PATCHES.info_lines() == [] and PATCHES.notes() == []


def test_a_cad_model_stands_for_its_trimmed_faces(tmp_path):
    pytest.importorskip("OCP")
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    from gshade.scene import load_scene

    writer = STEPControl_Writer()
    writer.Transfer(BRepPrimAPI_MakeBox(10.0, 20.0, 30.0).Shape(), STEPControl_AsIs)
    writer.Write(str(tmp_path / "box.step"))
    (surface,) = load_scene(tmp_path / "box.step").surfaces
    body = surface.body
    assert body is surface.cad and body.patch_label == "face" and body.trimmed
    assert body.length_unit == "mm"
    points = body.extent_points(surface.patches)
    assert np.allclose(points.min(axis=0), 0.0, atol=1e-9)
    assert np.allclose(points.max(axis=0), (10.0, 20.0, 30.0), atol=1e-9)
    size = body.size_points(surface.patches)
    assert np.allclose(np.ptp(size, axis=0), (10.0, 20.0, 30.0), atol=1e-6)
    lines = body.info_lines()
    assert lines[0].startswith("model: 6 faces, unit mm") and len(lines) == 2 + 6
    assert all(" plane " in line for line in lines[2:])


@pytest.mark.parametrize(
    "module",
    [
        "rendering/sizing.py",
        "rendering/pipeline.py",
        "rendering/surface_meshes.py",
        "app/commands.py",
    ],
)
def test_the_pipeline_asks_the_body(module):
    """Sizing, the pipeline, the meshing and the commands have no branch on a surface's
    kind: they ask its body (or a registry by body)."""
    source = Path(gshade.__file__).parent / module
    tree = ast.parse(source.read_text(encoding="utf-8"))
    kinds = [n.lineno for n in ast.walk(tree) if isinstance(n, ast.Attribute) and n.attr == "cad"]
    assert not kinds, f"{module} reads a surface's cad at lines {kinds}"
