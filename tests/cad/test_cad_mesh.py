"""The kernel's mesh of trimmed faces: closed, outward, on the exact surfaces, holes kept."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("OCP")

from OCP.BRep import BRep_Tool
from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
from OCP.BRepGProp import BRepGProp
from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder
from OCP.BRepTools import BRepTools
from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt
from OCP.GProp import GProp_GProps

from gshade.cad import CadModel, read_cad
from gshade.cad.kernel import shape_faces
from gshade.cad.mesh import FaceMesh, mesh_faces
from gshade.errors import GshadeError

from ..support.cad_parts import filleted_box

DEFLECTION = 0.01


def _volume(shape) -> float:
    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(shape, props)
    return props.Mass()


@pytest.fixture(scope="module")
def box(tmp_path_factory) -> tuple[CadModel, float]:
    shape = filleted_box()
    path = tmp_path_factory.mktemp("mesh") / "box.brep"
    BRepTools.Write_s(shape, str(path))
    return read_cad(path), _volume(shape)


@pytest.fixture(scope="module")
def box_mesh(box) -> FaceMesh:
    return mesh_faces(box[0], DEFLECTION)


def _edge_uses(mesh: FaceMesh) -> np.ndarray:
    """How often each edge is used, after merging bit-identical positions."""
    _, index = np.unique(mesh.positions, axis=0, return_inverse=True)
    merged = index.ravel()[mesh.triangles]
    edges = np.sort(merged[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    return np.unique(edges, axis=0, return_counts=True)[1]


def _signed_volume(mesh: FaceMesh) -> float:
    p0, p1, p2 = (mesh.positions[mesh.triangles[:, k]] for k in range(3))
    return float(np.einsum("ij,ij->", np.cross(p1 - p0, p2 - p0), p0)) / 6.0


def _exact(model: CadModel, mesh: FaceMesh, k: np.ndarray) -> np.ndarray:
    """The exact patches at the vertices k (each face's vertices evaluated together)."""
    out = np.empty((len(k), 3))
    for index in np.unique(mesh.face[k]):
        here = mesh.face[k] == index
        patch = model.faces[index].patch
        (u0, u1), (v0, v1) = patch.domain
        uv = mesh.uv[k[here]]
        out[here] = patch(np.clip(uv[:, 0], u0, u1), np.clip(uv[:, 1], v0, v1))
    return out


def test_arrays(box, box_mesh):
    mesh = box_mesh
    n = len(mesh.positions)
    assert mesh.positions.shape == (n, 3) and mesh.uv.shape == (n, 2)
    assert mesh.face.dtype == np.int32 and mesh.triangles.dtype == np.int32
    assert set(np.unique(mesh.face)) == set(range(len(box[0].faces)))
    assert mesh.triangles.min() >= 0 and mesh.triangles.max() < n
    # each triangle's vertices belong to one face
    assert (mesh.face[mesh.triangles] == mesh.face[mesh.triangles[:, :1]]).all()


def test_closed(box_mesh):
    # every edge is shared by exactly two triangles: a closed surface, no cracks
    assert (_edge_uses(box_mesh) == 2).all()


def test_outward(box, box_mesh):
    _, volume = box
    assert _signed_volume(box_mesh) == pytest.approx(volume, rel=1e-3)


def test_on_surface(box, box_mesh):
    model, _ = box
    mesh = box_mesh
    assert mesh.node_gap < 1e-9
    inner = np.flatnonzero(~mesh.boundary)
    assert inner.size
    assert (mesh.positions[inner] == _exact(model, mesh, inner)).all()
    edge = np.flatnonzero(mesh.boundary)
    assert np.linalg.norm(mesh.positions[edge] - _exact(model, mesh, edge), axis=1).max() < 1e-9
    # triangle centroids stay within the deflection of the surface: their offset from S at
    # the mean (u, v) along the normal there (the offset along the surface is the (u, v)
    # map's, not a distance from the surface)
    tri = mesh.triangles[::5]
    centroid = mesh.positions[tri].mean(axis=1)
    uv = mesh.uv[tri].mean(axis=1)
    offsets = []
    for t, q in zip(tri, uv, strict=True):
        d = model.faces[mesh.face[t[0]]].patch.derivatives(*q, 1)
        normal = np.cross(d[1, 0], d[0, 1])
        normal /= np.linalg.norm(normal)
        offsets.append(abs(float(np.dot(centroid[len(offsets)] - d[0, 0], normal))))
    assert max(offsets) < 2 * DEFLECTION


def test_subset(box, box_mesh):
    model, _ = box
    part = mesh_faces(model, DEFLECTION, faces=[3, 0])
    assert set(np.unique(part.face)) == {0, 3}
    assert len(part.triangles) == sum(
        (box_mesh.face[box_mesh.triangles[:, 0]] == i).sum() for i in (0, 3)
    )


def test_hole(tmp_path: Path):
    # a thin plate with a cylindrical hole: the top face is a plane trimmed by a circle
    plate = BRepPrimAPI_MakeBox(10.0, 8.0, 0.5).Shape()
    cylinder = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(4.0, 3.0, -1.0), gp_Dir(0, 0, 1)), 1.5, 3.0)
    shape = BRepAlgoAPI_Cut(plate, cylinder.Shape()).Shape()
    path = tmp_path / "plate.brep"
    BRepTools.Write_s(shape, str(path))
    model = read_cad(path)
    mesh = mesh_faces(model, 0.002)
    assert (_edge_uses(mesh) == 2).all()
    assert _signed_volume(mesh) == pytest.approx(_volume(shape), rel=1e-3)
    holed = [f.index for f in model.faces if f.inner_loops == 1]
    assert len(holed) == 2  # top and bottom
    for index in holed:
        face = model.faces[index]
        tri = mesh.triangles[mesh.face[mesh.triangles[:, 0]] == index]
        uv = mesh.uv[tri]
        # the hole in (u, v): the inner loop's centre and radius
        hole = face.loops[1]
        centre = hole[:-1].mean(axis=0)
        radius = np.linalg.norm(hole[:-1] - centre, axis=1).mean()
        assert np.linalg.norm(hole - centre, axis=1).std() < 1e-6 * radius
        chord = np.linalg.norm(np.diff(uv[:, [0, 1, 2, 0]], axis=1), axis=2).max()
        sagitta = chord**2 / (8 * radius)
        inside = np.linalg.norm(uv.mean(axis=1) - centre, axis=1) < radius - sagitta
        assert not inside.any()
        a, b, c = uv[:, 0], uv[:, 1], uv[:, 2]
        ab, ac = b - a, c - a
        area = 0.5 * np.abs(ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0]).sum()
        (u0, u1), (v0, v1) = face.box
        assert area == pytest.approx((u1 - u0) * (v1 - v0) - np.pi * radius**2, rel=1e-3)


def test_errors(box):
    model, _ = box
    with pytest.raises(GshadeError, match="deflection"):
        mesh_faces(model, 0.0)
    with pytest.raises(GshadeError, match="no face 99"):
        mesh_faces(model, DEFLECTION, faces=[99])
    bare = CadModel(model.path, model.faces, model.unit, model.bounds)
    with pytest.raises(GshadeError, match="kernel's shape"):
        mesh_faces(bare, DEFLECTION)


def test_shape_kept(box):
    """The kept shape's faces are the model's faces, in order: each kernel surface at its
    (u, v) is the face's patch at to_patch(u, v) (planes, cylinders and spheres read without
    the kernel's NURBS conversion: the patch's parameters are the arcs' along angles)."""
    model = read_cad(box[0].path, isolated=False)  # the kernel's shape here
    assert model.brep is not None
    surfaces = [BRep_Tool.Surface_s(f) for f in shape_faces(model.brep)]
    assert len(surfaces) == len(model.faces)
    rng = np.random.default_rng(3)
    worst = 0.0
    for face, surface in zip(model.faces, surfaces, strict=True):
        (u0, u1), (v0, v1) = face.box
        uv = np.stack([rng.uniform(u0, u1, 20), rng.uniform(v0, v1, 20)], -1)
        kernel = np.array([[c.X(), c.Y(), c.Z()] for c in (surface.Value(*q) for q in uv)])
        mine = face.patch(*face.to_patch(uv).T)
        worst = max(worst, float(np.abs(mine - kernel).max()))
    assert worst < 1e-12 * 30
    assert {type(s).__name__ for s in surfaces} >= {"Geom_Plane", "Geom_CylindricalSurface"}


def test_remesh_coarser(box):
    # the deflection asked for, not that of an earlier, finer mesh of the same shape
    model, _ = box
    fine = mesh_faces(model, 0.005)
    coarse = mesh_faces(model, 0.05)
    assert len(coarse.triangles) < len(fine.triangles) / 4
