"""Many B-spline patches at once (``gshade.geometry.spline_batches``) against each patch's
own ``derivatives``: the same numbers up to round-off, for any degrees, knots (clamped or
not), weights and points on any of the patches."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade.geometry import BezierPatch
from gshade.geometry.spline_batches import batch_derivatives

from .conftest import random_patch


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
