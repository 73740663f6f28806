"""Tessellation: watertight, exact normals, chord error within the tolerance, collapsed edges."""

import numpy as np
import pytest

from gshade import GshadeError
from gshade.geometry import patch_normals, sphere, torus
from gshade.io import read_newell
from gshade.rendering.tessellate import chord_resolution, tessellate

from ..support.paths import TEAPOT


@pytest.fixture(scope="module")
def teapot():
    return read_newell(TEAPOT)


def test_teapot_mesh_is_watertight_and_clean(teapot):
    mesh = tessellate(teapot, 12)
    P, F = mesh.positions, mesh.faces
    assert np.all(np.isfinite(P)) and np.all(np.isfinite(mesh.normals))
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1, atol=1e-12)
    # no degenerate triangles (the collapsed lid and bottom edges drop theirs)
    area = np.linalg.norm(np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]]), axis=1)
    assert area.min() > 1e-10
    # watertight: every edge of the mesh is used by two triangles, except the boundary
    # curves the teapot really has (rim, lid rim, spout and handle ends); count edges by
    # their (bit-identical) end positions
    keys = [
        tuple(map(tuple, sorted([tuple(P[a]), tuple(P[b])])))
        for f in F
        for a, b in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))
    ]
    _, counts = np.unique(np.array(keys).reshape(len(keys), -1), axis=0, return_counts=True)
    open_edges = int(np.sum(counts == 1))
    # 16 free patch edges of 11 segments each, and nothing else
    assert open_edges == 16 * 11
    assert counts.max() <= 2


def test_vertex_normals_and_parameters_are_exact():
    t = torus(2.0, 0.5)
    mesh = tessellate([t], 9)
    (u0, u1), (v0, v1) = t.domain
    u = u0 + (u1 - u0) * mesh.params[:, 0]
    v = v0 + (v1 - v0) * mesh.params[:, 1]
    np.testing.assert_allclose(mesh.positions, t(u, v), atol=1e-12)
    np.testing.assert_allclose(mesh.normals, patch_normals(t, u, v).n, atol=1e-12)
    assert set(np.unique(mesh.patch)) == {0}


def test_chord_error_stays_below_the_tolerance():
    s = sphere(1.0)
    for tol in (1e-2, 1e-3):
        n = chord_resolution(s, tol)
        mesh = tessellate([s], n)
        P, F = mesh.positions, mesh.faces
        # centroids of the flat triangles lie inside the sphere by at most the chord error
        centroid = P[F].mean(axis=1)
        error = 1.0 - np.linalg.norm(centroid, axis=1)
        assert error.max() <= tol
        assert error.max() > tol / 20  # and the resolution is not wastefully fine


def test_poles_keep_the_limit_normal(teapot):
    mesh = tessellate([teapot[20]], 8)  # the lid's top: its u0 edge is collapsed
    at_pole = mesh.params[:, 0] == 0
    n = mesh.normals[at_pole]
    np.testing.assert_allclose(n, np.repeat(n[:1], len(n), 0), atol=1e-9)
    assert abs(abs(n[0, 2]) - 1) < 1e-9  # the lid is horizontal at its top


def test_bad_tessellation_arguments(teapot):
    with pytest.raises(GshadeError, match="at least 2 vertices"):
        tessellate(teapot, 1)
    with pytest.raises(GshadeError, match="at least one patch"):
        tessellate([], 4)
    with pytest.raises(GshadeError, match="chord_tolerance: expected a positive number"):
        chord_resolution(teapot[0], 0.0)


def test_textures_are_the_same_one_patch_or_many_at_a_time(monkeypatch):
    """Tiles evaluated per patch (in place) and in chunks of patches (grouped Bézier
    products, irregular patches redone one by one) hold the same values."""
    from gshade.rendering import textures
    from gshade.shape import get_shape_function

    patches = read_newell(TEAPOT)  # collapsed edges included
    atlas = textures.Atlas.for_patches(len(patches), 12)
    functions = [(get_shape_function("mean"), {})]
    monkeypatch.setattr(textures, "CHUNK_TEXELS", 1)
    single = textures.shape_textures(patches, atlas, functions)
    monkeypatch.setattr(textures, "CHUNK_TEXELS", 1 << 20)
    grouped = textures.shape_textures(patches, atlas, functions)
    for a, b in zip(
        [*single.values, *single.twist, *single.valid, single.position, single.tangent_s],
        [*grouped.values, *grouped.twist, *grouped.valid, grouped.position, grouped.tangent_s],
        strict=True,
    ):
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6 * (1 + np.abs(a).max()))
