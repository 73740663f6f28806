"""Summaries of a function's samples (gshade.analysis.statistics) against numpy and by hand."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade.analysis.statistics import (
    BINS,
    PERCENTILES,
    Extreme,
    summarised,
    value_statistics,
    weighted_percentiles,
)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1e6, 1e6), min_size=1, max_size=60))
def test_equal_weights_give_numpys_percentiles(values):
    expected = np.percentile(values, PERCENTILES, method="inverted_cdf")
    np.testing.assert_allclose(
        weighted_percentiles(values, PERCENTILES, np.ones(len(values))), expected, atol=1e-6
    )
    np.testing.assert_allclose(weighted_percentiles(values, PERCENTILES), expected)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(["normal", "few", "spread", "outlier"]))
def test_many_weighted_samples_give_numpys_percentiles(seed, kind):
    """Above BINS samples the weights are binned and one bin sorted a percentile: the
    same sample as numpy's full sort (integer weights: the same sums in any order), with
    ties, a few distinct values, values over many decades, one far outlier, zero weights."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(BINS + 1, 4 * BINS))
    values = {
        "normal": lambda: rng.normal(size=n),
        "few": lambda: rng.integers(0, 5, n).astype(float),
        "spread": lambda: np.exp(rng.normal(0, 10, n)),
        "outlier": lambda: np.append(rng.normal(size=n - 1), 1e12),
    }[kind]()
    weights = rng.integers(0, 6, n).astype(float)
    expected = np.percentile(values, PERCENTILES, weights=weights, method="inverted_cdf")
    np.testing.assert_array_equal(weighted_percentiles(values, PERCENTILES, weights), expected)


def test_a_sample_counts_by_its_area():
    """Two values, one on three times the area of the other: three quarters of the surface
    lies at the first; a sample repeated three times weighs the same."""
    by_area = weighted_percentiles([1.0, 2.0], [10, 50, 90], [3.0, 1.0])
    repeated = weighted_percentiles([1.0, 1.0, 1.0, 2.0], [10, 50, 90])
    np.testing.assert_array_equal(by_area, repeated)
    np.testing.assert_array_equal(by_area, [1.0, 1.0, 2.0])


def test_the_extremes_say_where_they_are():
    rng = np.random.default_rng(2)
    f = rng.normal(size=50)
    points = rng.normal(size=(50, 3))
    s = value_statistics(f, np.arange(50) % 7, np.arange(50) / 50, np.ones(50), points)
    k, j = int(np.argmin(f)), int(np.argmax(f))
    assert (s.minimum.value, s.minimum.patch, s.minimum.u) == (f[k], k % 7, k / 50)
    assert s.maximum.point == tuple(points[j])
    assert s.mean == pytest.approx(f.mean()) and s.count == 50
    assert s.percentiles[50] == np.sort(f)[24]  # the smallest with half the samples at or below
    assert set(s.as_dict()) == {"count", "min", "max", "mean", "percentiles", "singular"}
    assert value_statistics([], [], [], [], np.zeros((0, 3))) is None


def test_extremes_leave_out_singular_samples():
    """Samples where the parametrisation is singular (a pole's limits) count in the mean
    and the percentiles but not as extremes, unless there is nothing else."""
    f = np.array([0.5, 1e9, -1e9, 0.25, 0.75])
    regular = np.array([True, False, False, True, True])

    def place(k):
        return Extreme(float(f[k]), k, 0.0, 0.0, (0.0, 0.0, 0.0))

    s = summarised(f, place, regular=regular)
    assert (s.minimum.patch, s.maximum.patch, s.singular) == (3, 4, 2)
    assert s.mean == pytest.approx(f.mean())
    everywhere = summarised(f, place, regular=np.zeros(5, bool))
    assert (everywhere.minimum.patch, everywhere.maximum.patch) == (2, 1)
