"""Stripes (anti-aliasing against supersampling) and colour maps."""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from gshade import GshadeError
from gshade.display import (
    Legend,
    auto_range,
    colour_map,
    combine,
    stripe_coverage,
    stripe_period,
    stripes,
)
from gshade.display.colour import DARK


def indicator(s, duty):
    return (s - np.floor(s) < duty).astype(float)


@settings(max_examples=300, deadline=None)
@given(
    s=st.floats(-100, 100),
    w=st.floats(1e-3, 1.0),
    duty=st.floats(0.1, 0.9),
)
def test_one_dimensional_box_filter_matches_256_samples(s, w, duty):
    samples = s + w * ((np.arange(256) + 0.5) / 256 - 0.5)
    assert abs(stripe_coverage(s, w, duty=duty) - indicator(samples, duty).mean()) < 1e-2


# widths are 0 or at least 1e-9 of a stripe period (below that no filter is meaningful)
WIDTHS = st.floats(-3.0, 3.0).filter(lambda x: x == 0 or abs(x) > 1e-9)


@settings(max_examples=300, deadline=None)
@given(s=st.floats(-100, 100), a=WIDTHS, b=WIDTHS, duty=st.floats(0.1, 0.9))
@example(s=-1.25, a=1e-8, b=1e-8, duty=0.5)  # found with --hypothesis-seed=12 and 24
@example(s=0.3, a=1.5e-9, b=1.5e-9, duty=0.5)
@example(s=0.75, a=3e-6, b=3e-7, duty=0.5)  # two-D filter, far from an edge
def test_pixel_box_filter_is_the_mean_over_the_pixel(s, a, b, duty):
    """s linear over a square pixel: the coverage is the exact mean of the stripe indicator."""
    x = (np.arange(512) + 0.5) / 512 - 0.5
    X, Y = np.meshgrid(x, x)
    fine = indicator(s + a * X + b * Y, duty).mean()
    assert abs(stripe_coverage(s, a, b, duty=duty) - fine) < 1e-2


@pytest.mark.parametrize(
    ("s", "a", "b"),
    [(0.99999, 6.103515625e-05, 6.103515625e-05), (0.5, 1e-7, 5e-8), (3.0, 2e-6, 2e-6)],
)
def test_tiny_pixel_footprints_at_a_stripe_edge(s, a, b):
    """Found by hypothesis: footprints much smaller than a period, next to an edge."""
    x = (np.arange(512) + 0.5) / 512 - 0.5
    X, Y = np.meshgrid(x, x)
    fine = indicator(s + a * X + b * Y, 0.5).mean()
    assert abs(stripe_coverage(s, a, b, duty=0.5) - fine) < 1e-2


def test_tiny_footprints_away_from_the_edges_are_the_point_sample():
    """A footprint that reaches no stripe edge lies on one stripe: exactly 0 or 1 (the
    trapezoid CDF lost everything to cancellation there for footprints below 1e-7)."""
    s = np.linspace(-100, 100, 200_001)
    fract = s - np.floor(s)
    away = np.minimum(np.minimum(fract, np.abs(fract - 0.5)), 1 - fract) > 1e-6
    for width in (1e-7, 1e-8, 3e-9, 1.5e-9, 2e-6):
        for a, b in ((width, width), (width, 0.4 * width), (width, 0.0)):
            cov = stripe_coverage(s[away], a, b, duty=0.5)
            np.testing.assert_array_equal(cov, indicator(s[away], 0.5))


def test_the_renderer_draws_a_tiny_footprint_stripe_as_it_is(tmp_path):
    """Planar sections of a sphere with period 1e8 and phase 0.4: s = 0.4 +- 1e-8 on the
    whole sphere, one dark stripe (the integrator uses the same formula in Dr.Jit)."""
    import gshade
    from gshade.scene import parse_scene

    scene = parse_scene(
        '[[surface]]\ntype = "sphere"\n[shape]\nfunction = "planar_sections"\n'
        "direction = [0, 0, 1]\nperiod = 1e8\nphase = 0.4\n"
        '[render]\nwidth = 80\nheight = 60\nspp = 4\nlighting = "flat"\n'
    )
    image = gshade.render(scene)
    covered = image.channels["A"] > 0.999
    dark = image.channels["R"][covered] / image.channels["A"][covered]
    assert covered.sum() > 1000
    np.testing.assert_allclose(dark, DARK[0], atol=1e-3)


def test_pixel_box_filter_against_256_samples_on_average():
    rng = np.random.default_rng(0)
    x = (np.arange(16) + 0.5) / 16 - 0.5
    X, Y = np.meshgrid(x, x)
    errors = []
    for _ in range(2000):
        s, a, b, duty = rng.uniform(-20, 20), *rng.uniform(-2, 2, 2), rng.uniform(0.2, 0.8)
        ref = indicator(s + a * X + b * Y, duty).mean()  # 256-sample supersampled reference
        errors.append(abs(stripe_coverage(s, a, b, duty=duty) - ref))
    assert np.mean(errors) < 1e-2


def test_dense_stripes_fade_to_grey_not_moire():
    s = np.linspace(0, 1000, 10001)
    cov = stripe_coverage(s, 50.0, duty=0.5)
    np.testing.assert_allclose(cov, 0.5, atol=1e-2)
    cov2 = stripe_coverage(s, 40.0, 33.0, duty=0.3)
    np.testing.assert_allclose(cov2, 0.3, atol=1e-2)


def test_zero_width_is_the_hard_indicator_and_stripes_mix_two_colours():
    s = np.array([0.1, 0.6, 1.2, -0.3])
    np.testing.assert_array_equal(stripe_coverage(s), [1, 0, 1, 0])
    rgb, cov = stripes(s * 0.2, 0.2, dark=(0, 0, 0), light=(1, 1, 1))
    np.testing.assert_allclose(rgb[..., 0], 1 - cov)
    np.testing.assert_allclose(rgb[:, 0], [0, 1, 0, 1])
    assert stripe_period(None, 20, (-1.0, 1.0)) == 0.1


def test_colour_map_ranges_and_clamping():
    f = np.linspace(-2, 2, 401)
    cm = colour_map(f, value_range=(-1, 1), signed=True)
    assert cm.value_range == (-1, 1)
    assert cm.below == 100 and cm.above == 100
    np.testing.assert_allclose(cm.rgb[0], cm.rgb[50])  # clamped
    # a diverging map is symmetric about 0: the middle is neutral
    mid = cm.rgb[200]
    assert np.ptp(mid) < 0.15
    auto = colour_map(f, signed=True)
    lo, hi = auto.value_range
    assert lo == -hi and 1.9 < hi <= 2.0
    viridis = colour_map(np.linspace(0, 1, 11))
    assert viridis.value_range[0] >= 0 and viridis.rgb.shape == (11, 3)
    assert np.all(np.diff(viridis.rgb.sum(-1)) > 0)  # perceptually uniform: lightness rises


def test_undefined_values_are_flagged_and_never_nan():
    f = np.array([0.0, np.nan, 1.0, np.inf])
    cm = colour_map(f, np.array([True, True, False, True]))
    assert cm.undefined == 3
    assert np.all(np.isfinite(cm.rgb))
    lo, hi = auto_range(np.array([np.nan, 3.0, 3.0]))
    assert lo < 3 < hi


def test_both_at_once_and_the_legend():
    rgb = np.full((4, 3), 0.8)
    out = combine(rgb, np.array([0, 0.5, 1, 0]))
    np.testing.assert_allclose(out[:, 0], [0.8, 0.8 * (1 - 0.325), 0.8 * 0.35, 0.8])
    legend = Legend(
        "mean", 2, "both", (-1.5, 1.5), "coolwarm", 0.1, 0.5, "isophotes", units="1/length"
    )
    text = legend.text()
    assert "mean (order 2)" in text and "coolwarm on [-1.5, 1.5] 1/length" in text
    assert "stripes of isophotes every 0.1" in text
    assert legend.as_dict()["function"] == "mean"


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (
            lambda: colour_map(np.zeros(3), value_range=(1, 1)),
            r"^range: expected \[min, max\] with min < max, got \[1, 1\]$",
        ),
        (lambda: colour_map(np.zeros(3), value_range=(2, 1)), "min < max"),
        (
            lambda: colour_map(np.zeros(3), value_range=(0, np.inf)),
            r"^range: expected \[min, max\], two finite numbers, got \[0, inf\]$",
        ),
        (lambda: colour_map(np.zeros(3), value_range=(0,)), r"range: expected \[min, max\], two"),
        (lambda: stripe_period(None, 10, (1, 1)), r"range: expected \[min, max\] with min < max"),
        (
            lambda: colour_map(np.zeros(3), cmap="nope"),
            r'^colormap: expected the name of a matplotlib colour map \(e.g. "viridis"\), '
            r'got "nope"',
        ),
        (lambda: colour_map(np.zeros(3), cmap="viridus"), 'got "viridus"; did you mean "viridis"'),
        (lambda: stripe_coverage(0.5, duty=1.5), "duty: expected a number in"),
        (lambda: stripes(np.zeros(2), 0.0), "period: expected a positive number"),
        (lambda: stripe_period(None, None, None), "exactly one of period or count"),
    ],
)
def test_bad_colour_input(call, message):
    with pytest.raises(GshadeError, match=message):
        call()
