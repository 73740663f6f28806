"""Rhino trims recovered at poles and seams: faces that the kernel's mesher must cover.

Each construction is built with rhino3dm at test time, written to a ``.3dm`` file, read back
with :func:`gshade.cad.read_cad` and meshed with :func:`gshade.cad.mesh.mesh_faces`;
the mesh must lie on the exact surface and cover it (its area that of the surface, in closed
form).  The centres and sizes are ones where the point inversion puts a pole's parameter
away from the seam (spheres, cones) or a torus's corner on the other seam: the cases that
once left both uses of a seam edge on one side of the domain, a face without area.
"""

from __future__ import annotations

import numpy as np
import pytest

from gshade.cad import read_cad
from gshade.cad.mesh import mesh_faces

r3 = pytest.importorskip("rhino3dm")
from gshade.cad import rhino, rhino_inversion, rhino_seams  # noqa: E402

#: Mesher deflection, relative to the part's size.
DEFLECTION = 1e-3
#: The mesh's area may fall short of the surface's by the chords (relative).
AREA_TOLERANCE = 5e-3


def _point(xyz) -> object:
    return r3.Point3d(*map(float, xyz))


def _revolved(profile, centre, angle: float = 2 * np.pi) -> object:
    """The Brep of ``profile`` revolved by ``angle`` about the vertical axis through
    ``centre``."""
    c = np.asarray(centre, dtype=float)
    axis = r3.Line(_point(c), _point(np.add(c, (0.0, 0.0, 1.0))))
    return r3.Brep.CreateFromRevSurface(
        r3.RevSurface.Create(profile, axis, 0.0, angle), False, False
    )


def _torus(centre, major: float, minor: float) -> object:
    c = np.asarray(centre, dtype=float)
    plane = r3.Plane(
        _point(np.add(c, (major, 0.0, 0.0))), r3.Vector3d(1, 0, 0), r3.Vector3d(0, 0, 1)
    )
    circle = r3.Circle(minor)
    circle.Plane = plane
    return _revolved(circle.ToNurbsCurve(), c)


def _cone(centre, height: float, radius: float) -> object:
    c = np.asarray(centre, dtype=float)
    return _revolved(
        r3.LineCurve(_point(np.add(c, (0, 0, height))), _point(np.add(c, (radius, 0, 0)))), c
    )


def _mesh(tmp_path, brep, size: float):
    """The Brep written to a file, read back and meshed: (model, mesh, area per face)."""
    f = r3.File3dm()
    f.Objects.AddBrep(brep)
    path = tmp_path / "part.3dm"
    assert f.Write(str(path), 7)
    model = read_cad(path)
    mesh = mesh_faces(model, DEFLECTION * size)
    P, T = mesh.positions, mesh.triangles
    area = 0.5 * np.linalg.norm(np.cross(P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]), axis=1)
    per_face = np.bincount(mesh.face[T[:, 0]], weights=area, minlength=len(model.faces))
    return model, mesh, per_face


@pytest.mark.parametrize(("centre", "radius"), [((10, -5, 2), 7.0), ((0.3, 0.1, 0), 0.37)])
def test_sphere_pole_off_the_seam(tmp_path, centre, radius):
    """A sphere whose poles pull back off its seam: the face covers the whole sphere."""
    model, mesh, area = _mesh(tmp_path, r3.Sphere(_point(centre), radius).ToBrep(), radius)
    assert len(model.faces) == 1 and area[0] > 0
    distance = np.linalg.norm(mesh.positions - centre, axis=1)
    assert np.abs(distance - radius).max() <= DEFLECTION * radius
    exact = 4 * np.pi * radius**2
    assert exact * (1 - AREA_TOLERANCE) <= area.sum() <= exact
    lo, hi = mesh.positions.min(axis=0), mesh.positions.max(axis=0)
    assert np.allclose(lo, np.subtract(centre, radius), atol=2 * DEFLECTION * radius)
    assert np.allclose(hi, np.add(centre, radius), atol=2 * DEFLECTION * radius)


@pytest.mark.parametrize(
    ("centre", "height", "radius"), [((10, -5, 2), 7.0, 2.0), ((0.3, 0.1, 0), 0.37, 0.5)]
)
def test_cone_apex(tmp_path, centre, height, radius):
    """A cone with its apex a singular trim (a pole off the seam): the whole lateral face."""
    size = max(height, radius)
    model, mesh, area = _mesh(tmp_path, _cone(centre, height, radius), size)
    assert len(model.faces) == 1 and area[0] > 0
    d = mesh.positions - centre
    rho = np.hypot(d[:, 0], d[:, 1])
    # on the cone: distance from the axis falls linearly from the base to the apex
    slant = np.hypot(height, radius)
    off = np.abs(rho - radius * (1 - d[:, 2] / height)) * height / slant
    assert off.max() <= DEFLECTION * size
    assert d[:, 2].min() == pytest.approx(0, abs=1e-9 * size)
    assert d[:, 2].max() == pytest.approx(height, abs=DEFLECTION * size)
    exact = np.pi * radius * slant
    assert exact * (1 - AREA_TOLERANCE) <= area.sum() <= exact


def test_torus_corner_on_both_seams(tmp_path):
    """A torus (closed both ways, its seam edges meeting at the corner of the domain): the
    trims along the u seam take opposite ends, the face covers the whole torus."""
    centre, major, minor = np.array([1.0, 2.0, 3.0]), 3.0, 1.0
    model, mesh, area = _mesh(tmp_path, _torus(centre, major, minor), major + minor)
    assert len(model.faces) == 1 and area[0] > 0
    d = mesh.positions - centre
    off = np.abs(np.hypot(np.hypot(d[:, 0], d[:, 1]) - major, d[:, 2]) - minor)
    assert off.max() <= DEFLECTION * (major + minor)
    exact = 4 * np.pi**2 * major * minor
    assert exact * (1 - AREA_TOLERANCE) <= area.sum() <= exact


def test_solids_in_one_file(tmp_path):
    """A box, a sphere, a cone and a torus in one file: every face meshes, and each body's
    area is its closed form."""
    f = r3.File3dm()
    box = r3.Brep.CreateFromBoundingBox(r3.BoundingBox(_point((0, 0, 0)), _point((2, 3, 4))))
    bodies = [
        (box, 2 * (2 * 3 + 3 * 4 + 2 * 4)),
        (r3.Sphere(_point((10, -5, 2)), 7.0).ToBrep(), 4 * np.pi * 49),
        (_cone((0.3, 0.1, 0), 0.37, 0.5), np.pi * 0.5 * np.hypot(0.37, 0.5)),
        (_torus((20, 0, 0), 3.0, 1.0), 4 * np.pi**2 * 3),
    ]
    owner = []
    for k, (brep, _) in enumerate(bodies):
        f.Objects.AddBrep(brep)
        owner += [k] * len(brep.Faces)
    path = tmp_path / "solids.3dm"
    assert f.Write(str(path), 7)
    model = read_cad(path)
    mesh = mesh_faces(model, 1e-3)
    P, T = mesh.positions, mesh.triangles
    area = 0.5 * np.linalg.norm(np.cross(P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]), axis=1)
    per_face = np.bincount(mesh.face[T[:, 0]], weights=area, minlength=len(model.faces))
    assert len(model.faces) == len(owner) and (per_face > 0).all()
    per_body = np.bincount(owner, weights=per_face)
    exact = np.array([a for _, a in bodies])
    assert np.all(per_body <= exact * (1 + 1e-9))
    assert np.all(per_body >= exact * (1 - AREA_TOLERANCE))


def test_nearly_closed_tube_edges_take_their_ends():
    """A tube closed around u to within a small gap (as a file's tolerance allows, not
    exactly): it counts as closed there, and a trim running up the high end of u whose
    points pulled back a hair inside the low end (within the gap, beyond 1e-4 of the span)
    moves to the high end, as the loop's counterclockwise sense asks."""
    eps, r, h = 5e-3, 1.0, 2.0
    brep = _revolved(r3.LineCurve(_point((r, 0, 0)), _point((r, 0, h))), (0, 0, 0), 2 * np.pi - eps)
    nurbs = brep.Faces[0].ToNurbsSurface()
    patch = rhino.nurbs_patch(nurbs)
    (u0, u1), (v0, v1) = patch.domain
    assert np.linalg.norm(patch(u0, v0) - patch(u1, v0)) == pytest.approx(r * eps, rel=1e-3)
    assert not nurbs.IsClosed(0)
    closed = rhino_seams.closed_directions(nurbs, patch)
    assert closed == (True, False)
    grid = rhino_inversion.Grid(patch, patch.domain, closed)
    s = np.linspace(0.0, 1.0, 9)
    inside = u0 + 4e-4 * (u1 - u0)
    uv = np.concatenate(
        [
            np.stack([u0 + (u1 - u0) * s, np.full(9, v0)], -1),  # along v = v0
            np.stack([np.full(9, inside), v0 + (v1 - v0) * s], -1),  # up the high end of u
            np.stack([u1 - (u1 - u0) * s, np.full(9, v1)], -1),  # back along v = v1
            np.stack([np.full(9, u0), v1 - (v1 - v0) * s], -1),  # down the low end
        ]
    )
    rhino_seams.fix_ambiguous(grid, uv, np.full(len(uv), -1), True, [9, 9, 9, 9])
    assert np.all(uv[9:18, 0] == u1) and np.all(uv[27:, 0] == u0)
    assert np.all(uv[1:8, 0] > u0) and np.all(uv[1:8, 0] < u1)  # the others stay
