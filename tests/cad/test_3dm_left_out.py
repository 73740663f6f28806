"""Rhino files: what Rhino does not draw is passed over, and a face the reader or the
kernel cannot use is left out while the rest meshes (issue 25, points 1 and 2).

The files are written with rhino3dm at test time: spheres of known radii, one of them hidden
or on a layer that is off; a face that fails is made to fail by replacing the reader's step
for it (the plumbing of numbers, kernel shape and mesh is what is tested, not the failure).
"""

from __future__ import annotations

import numpy as np
import pytest

from gshade.cad import read_cad
from gshade.cad.mesh import mesh_faces
from gshade.errors import GshadeError

r3 = pytest.importorskip("rhino3dm")
from gshade.cad import rhino, rhino_brep  # noqa: E402

#: Sphere radii and centres, far enough apart; face k is sphere k.
SPHERES = [(1.0, (0, 0, 0)), (2.0, (10, 0, 0)), (3.0, (0, 20, 0))]


def _write(path, hide: int | None = None, layer_off: int | None = None):
    """The spheres in one file; sphere ``hide`` hidden, sphere ``layer_off`` on a layer
    that is off (under a parent layer that is on)."""
    model = r3.File3dm()
    parent = r3.Layer()
    parent.Name = "parts"
    model.Layers.Add(parent)
    off = r3.Layer()
    off.Name = "off"
    off.ParentLayerId = model.Layers[0].Id
    off.Visible = False
    model.Layers.Add(off)
    for k, (radius, centre) in enumerate(SPHERES):
        attributes = r3.ObjectAttributes()
        attributes.LayerIndex = 1 if k == layer_off else 0
        attributes.Visible = k != hide
        brep = r3.Sphere(r3.Point3d(*map(float, centre)), radius).ToBrep()
        model.Objects.AddBrep(brep, attributes)
    model.Write(str(path), 7)
    return path


def _areas(model, mesh) -> dict[int, float]:
    """Mesh area per face number."""
    out = {}
    for f in sorted(set(mesh.face.tolist())):
        mine = mesh.triangles[(mesh.face[mesh.triangles] == f).all(axis=1)]
        p = mesh.positions[mine]
        cross = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        out[f] = 0.5 * float(np.linalg.norm(cross, axis=1).sum())
    return out


@pytest.mark.parametrize("how", ["hidden", "layer off"])
def test_objects_rhino_does_not_draw_are_passed_over_and_said(tmp_path, how):
    """A hidden sphere, or one on a layer that is off, is not read; a note says how many
    objects and faces were passed over; the others mesh with their closed-form areas."""
    kwargs = {"hide": 1} if how == "hidden" else {"layer_off": 1}
    model = read_cad(_write(tmp_path / "spheres.3dm", **kwargs))
    assert len(model.faces) == 2 and model.left_out == []
    assert model.notes == [
        "1 objects (1 faces) that Rhino does not draw (hidden, on layers that are off, in "
        "block definitions or on layout pages) passed over"
    ]
    areas = _areas(model, mesh_faces(model, 1e-3))
    expected = [4 * np.pi * r**2 for r, _ in (SPHERES[0], SPHERES[2])]
    assert sorted(areas.values()) == pytest.approx(expected, rel=5e-3)


def test_every_sphere_is_read_when_all_are_drawn(tmp_path):
    model = read_cad(_write(tmp_path / "spheres.3dm"))
    assert len(model.faces) == 3 and model.notes == []


def test_a_face_the_reader_cannot_use_is_left_out(tmp_path, monkeypatch):
    """Face 1 failing in the reader is left out (its number kept: the others are 0 and 2),
    and the kernel's shape and mesh hold the others, with their own areas."""
    real = rhino._brep_face

    def failing(path, part, face, index):
        if index == 1:
            raise GshadeError(f"{path}: face 1: unusable NURBS surface (made to fail)")
        return real(path, part, face, index)

    monkeypatch.setattr(rhino, "_brep_face", failing)
    model = read_cad(_write(tmp_path / "spheres.3dm"), isolated=False)
    assert [f.index for f in model.faces] == [0, 2]
    assert [f.line() for f in model.left_out] == [
        "face 1 left out: unusable NURBS surface (made to fail) (tried: reading its NURBS "
        "surface and recovering its trims)"
    ]
    assert model.kernel_numbers() == (0, 2)
    areas = _areas(model, mesh_faces(model, 1e-3))
    assert areas[0] == pytest.approx(4 * np.pi, rel=5e-3)
    assert areas[2] == pytest.approx(36 * np.pi, rel=5e-3)


def test_a_face_the_kernel_cannot_build_is_left_out(tmp_path, monkeypatch):
    """Face 2 failing on the kernel (building it from its surface and trims) is left out of
    the model and of the kernel's shape; faces 0 and 1 mesh."""
    real = rhino_brep._face

    def failing(cad, *args):
        if cad.index == 2:
            raise RuntimeError("made to fail")
        return real(cad, *args)

    monkeypatch.setattr(rhino_brep, "_face", failing)
    model = read_cad(_write(tmp_path / "spheres.3dm"), isolated=False)
    assert [f.index for f in model.faces] == [0, 1]
    assert [f.index for f in model.left_out] == [2]
    assert "the kernel failed (RuntimeError: made to fail)" in model.left_out[0].why
    assert model.kernel_numbers() == (0, 1)
    areas = _areas(model, mesh_faces(model, 1e-3))
    assert areas[1] == pytest.approx(16 * np.pi, rel=5e-3)
    assert set(areas) == {0, 1}
