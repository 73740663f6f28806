"""Bands' colours (gshade.display.bands) against what they mean: the trapezoid CDF against
a direct integral, one colour for a value at a level whatever its round-off, the side a
value exactly at an edge falls on."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade.display.bands import band_colours, band_shares, band_text, settled_on_levels
from gshade.display.colour import trapezoid_cdf
from gshade.shape import function_bands


@settings(max_examples=60, deadline=None)
@given(
    x=st.floats(-2, 2),
    a=st.floats(0, 1.5),
    b=st.floats(0, 1.5),
)
def test_trapezoid_cdf_is_the_footprints_mass_below_x(x, a, b):
    """The mass of a X + b Y (X, Y uniform on [-1/2, 1/2]) below x, against the mean over a
    fine grid of (X, Y) (midpoints: error O(1 / n))."""
    a, b = max(a, b), min(a, b)
    n = 1200
    grid = (np.arange(n) + 0.5) / n - 0.5
    values = a * grid[:, None] + b * grid[None, :]
    direct = (values < x).mean()
    with np.errstate(over="ignore"):  # the branch not taken may overflow
        assert trapezoid_cdf(np.array(x), a, b) == pytest.approx(direct, abs=2.5 / n)


def test_a_value_at_a_level_is_one_colour_whatever_its_round_off():
    """A wall along the pull direction: draft 0 give or take single-precision noise, slopes
    of noise too; settled, every pixel is the band above the edge, and no line is drawn."""
    bands = function_bands("draft_angle", {"min_angle": 3.0})
    rng = np.random.default_rng(1)
    f = rng.normal(scale=1e-7, size=1000)
    fx, fy = rng.normal(scale=1e-8, size=(2, 1000))
    colours = band_colours(f, fx, fy, bands)
    assert len(np.unique(colours, axis=0)) == 1
    np.testing.assert_allclose(colours[0], band_colours(np.array([1.0]), 0.0, 0.0, bands)[0])
    unsettled, _ = band_shares(f, fx, fy, bands)
    assert len(np.unique(np.round(unsettled[0], 6))) > 1  # the noise alone picks the band
    settled = settled_on_levels(np.array([1e-3]), np.array([0.0]), np.array([0.0]), bands)
    assert settled[0][0] == 1e-3  # a real value near the level is left alone


def test_the_edge_goes_to_the_band_its_meaning_says():
    """Draft exactly the least accepted is enough; a radius exactly the limit is within it,
    on either side."""
    draft = function_bands("draft_angle", {"min_angle": 3.0})
    shares, _ = band_shares(np.array([3.0, 0.0]), 0.0, 0.0, draft)
    assert [s.tolist() for s in shares] == [[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]]
    radius = function_bands("min_radius", {"limit": 4.0})
    shares, _ = band_shares(np.array([-0.25, 0.25, 0.26, -0.26]), 0.0, 0.0, radius)
    assert [s.tolist() for s in shares] == [[0, 0, 0, 1], [1, 1, 0, 0], [0, 0, 1, 0]]


def test_the_bands_say_themselves():
    assert band_text(function_bands("draft_angle", {"min_angle": 1.0}), "deg") == (
        "undercut < 0 <= too little draft < 1 <= enough draft (deg); lines at 0"
    )
    assert band_text(function_bands("min_radius", {"limit": 4.0}), "1/mm") == (
        "convex below limit < -0.25 <= within limit <= 0.25 < concave below limit (1/mm)"
    )
