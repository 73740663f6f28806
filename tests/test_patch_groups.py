"""Many patches on one grid: the grouped Bézier products equal each patch's own evaluation."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade.geometry import BezierPatch, BSplinePatch, sphere
from gshade.geometry.patch_groups import grid_derivatives
from gshade.io import read_newell
from gshade.rendering.tessellate import chord_resolution, max_chord_resolution

from .conftest import TEAPOT


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), order=st.integers(0, 3))
def test_grouped_grid_equals_per_patch_evaluation(seed, order):
    rng = np.random.default_rng(seed)
    patches = []
    for _ in range(5):
        m, n = rng.integers(1, 5, 2)
        u0, v0 = rng.uniform(-2, 2, 2)
        du, dv = rng.uniform(0.1, 3.0, 2)
        patches.append(
            BezierPatch(rng.normal(size=(m + 1, n + 1, 3)), domain=((u0, u0 + du), (v0, v0 + dv)))
        )
    patches.append(BezierPatch(rng.normal(size=(3, 4, 3)), rng.uniform(0.5, 2.0, (3, 4))))
    patches.append(sphere(1.3))
    P = rng.normal(size=(5, 4, 3))
    patches.append(
        BSplinePatch(P, (2, 3), ([0, 0, 0, 0.3, 0.6, 1, 1, 1], [0, 0, 0, 0, 1, 1, 1, 1]))
    )
    rng.shuffle(patches)
    s = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0, 1, 5)]))
    grouped = grid_derivatives(patches, s, order)
    for k, patch in enumerate(patches):
        (u0, u1), (v0, v1) = patch.domain
        own = patch.derivatives((u0 + (u1 - u0) * s)[:, None], (v0 + (v1 - v0) * s)[None, :], order)
        scale = 1.0 + np.abs(own).max()
        np.testing.assert_allclose(grouped[k], own, atol=1e-12 * scale)


def test_chord_resolution_of_many_from_each_patch_own_derivatives():
    """The bound h^2 / 8 (|p_ss| + 2 |p_st| + |p_tt|) <= tol, with the second derivatives
    taken from each patch's own evaluation on the 9 x 9 grid."""
    patches = read_newell(TEAPOT)
    tol = 1e-3
    bound = 0.0
    for p in patches:
        d = p.derivatives(*p.parameter_grid(9, 9), 2)
        norm = np.linalg.norm
        bound = max(
            bound,
            (norm(d[2, 0], axis=-1) + 2 * norm(d[1, 1], axis=-1) + norm(d[0, 2], axis=-1)).max(),
        )
    cells = int(np.ceil(np.sqrt(bound / (8 * tol))))
    assert max_chord_resolution(patches, tol) == cells + 1
    assert chord_resolution(patches[0], tol) <= cells + 1
