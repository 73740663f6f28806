"""Many B-spline patches at once (``gshade.geometry.evaluation.spline_batches``) against each
patch's own ``derivatives``: the same numbers up to round-off, for any degrees, knots (clamped or
not), weights and points on any of the patches."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade.geometry import BezierPatch
from gshade.geometry.evaluation.spline_batches import batch_derivatives

from ...support.random_patches import random_patch


@settings(max_examples=60, deadline=None)
@given(
    data=st.data(),
    seed=st.integers(0, 2**32 - 1),
    count=st.integers(1, 5),
    order=st.integers(0, 3),
)
def test_a_batch_is_each_patch_evaluated_alone(data, seed, count, order):
    rng = np.random.default_rng(seed)
    patches = []
    for _ in range(count):
        p, q = data.draw(st.integers(1, 4)), data.draw(st.integers(1, 3))
        patches.append(random_patch(data, rng, p, q, data.draw(st.booleans()), extra=4))
    patches.append(BezierPatch(rng.normal(size=(3, 4, 3))))  # evaluated on its own
    n = 60
    index = rng.integers(0, len(patches), n)
    lo = np.array([[p.domain[0][0], p.domain[1][0]] for p in patches])[index]
    hi = np.array([[p.domain[0][1], p.domain[1][1]] for p in patches])[index]
    uv = lo + (hi - lo) * rng.uniform(0, 1, (n, 2))
    uv[: n // 4] = np.where(rng.random((n // 4, 2)) < 0.5, lo[: n // 4], hi[: n // 4])  # ends
    got = batch_derivatives(patches, index, uv[:, 0], uv[:, 1], order)
    assert got.shape == (order + 1, order + 1, n, 3)
    for k, patch in enumerate(patches):
        at = np.flatnonzero(index == k)
        if not at.size:
            continue
        want = patch.derivatives(uv[at, 0], uv[at, 1], order)
        scale = np.abs(want).max(axis=(2, 3), keepdims=True) + 1.0
        np.testing.assert_allclose(got[:, :, at] / scale, want / scale, rtol=0, atol=1e-10)


def test_small_grids_of_many_splines_at_once():
    """grid_derivatives on a grid smaller than ALONE_FROM points evaluates the B-splines
    all at once: the same numbers as each patch's own grid evaluation."""
    from gshade.geometry import BSplinePatch
    from gshade.geometry.evaluation.patch_groups import grid_derivatives, patch_grid
    from gshade.geometry.evaluation.spline_batches import ALONE_FROM

    rng = np.random.default_rng(8)
    U = [0, 0, 0, 0.3, 1, 1, 1]
    patches = [
        BSplinePatch(rng.normal(size=(4, 3, 3)), (2, 2), (U, [0, 0, 0, 1, 1, 1])),
        BSplinePatch(
            rng.normal(size=(4, 2, 3)), (2, 1), (U, [0, 0, 2, 2]), rng.uniform(0.5, 2, (4, 2))
        ),
        BezierPatch(rng.normal(size=(3, 3, 3))),
    ]
    s, t = np.linspace(0, 1, 5), np.linspace(0, 1, 7)
    assert s.size * t.size < ALONE_FROM
    got = grid_derivatives(patches, s, 2, t)
    for k, patch in enumerate(patches):
        want = patch.derivatives(*patch_grid(patch, s, t), 2)
        np.testing.assert_allclose(got[k], want, rtol=1e-12, atol=1e-12)
