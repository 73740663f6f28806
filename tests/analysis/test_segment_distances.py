"""Distances of points to segments (gshade.analysis.coverage.segment_distances) against every
segment measured, for segments of very different lengths (a long one whose middle is far
from the points it is nearest to)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade.analysis.coverage import segment_distances


def _brute(q, a, b):
    ab, ap = b[None] - a[None], q[:, None] - a[None]
    t = np.clip(np.sum(ap * ab, -1) / np.sum(ab * ab, -1), 0.0, 1.0)
    return np.linalg.norm(ap - t[..., None] * ab, axis=-1).min(axis=1)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 60))
def test_segment_distances_equal_every_segment_measured(seed, count):
    rng = np.random.default_rng(seed)
    a = rng.uniform(-1, 1, (count, 3))
    b = a + rng.normal(size=(count, 3)) * rng.uniform(0, 1, (count, 1)) ** 4
    a[0], b[0] = [-50.0, 0.0, 0.0], [50.0, 0.0, 0.3]  # long: its middle far from most points
    q = rng.uniform(-3, 3, (300, 3))
    found = segment_distances(q, np.stack([a, b], 1))
    np.testing.assert_allclose(found, _brute(q, a, b), rtol=1e-12, atol=1e-14)


def test_no_segment_is_infinitely_far():
    assert np.isinf(segment_distances([[0.0, 0.0, 0.0]], np.zeros((0, 2, 3)))).all()
