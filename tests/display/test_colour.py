"""Stripes (anti-aliasing against supersampling and the exact mean) and colour maps."""

import math
from fractions import Fraction

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
@example(s=1.203125, a=1e-8, b=1e-8, duty=0.375)  # issue 14: 0.98879 where the mean is 1
@example(s=0.375, a=1e-8, b=1e-8, duty=0.375)  # on a fall, a tiny footprint: 1/2
@example(s=2.0, a=1e-8, b=0.0, duty=0.375)  # on a rise, one-D: 1/2
@example(s=-0.625, a=1.5e-9, b=1e-9, duty=0.375)  # on a fall below 0
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


def exact_mean(s, a, b, duty):
    """The exact mean of the stripe indicator over the square pixel, s + a X + b Y with X, Y
    uniform on [-1/2, 1/2], in rational arithmetic from the float arguments: the dark
    intervals [k, k + duty) overlapped with the pixel, edge by edge, through the area of
    the part of the pixel below each edge (the trapezoid distribution's CDF)."""
    s, d = Fraction(s), Fraction(duty)
    a, b = sorted((abs(Fraction(a)), abs(Fraction(b))), reverse=True)
    hi, lo = (a + b) / 2, (a - b) / 2

    def below(x):  # the area of {a X + b Y < x} in the unit square
        if x <= -hi:
            return Fraction(0)
        if x >= hi:
            return Fraction(1)
        if x <= -lo:  # a < 0 not reached: a >= b and a > 0 here
            return (x + hi) ** 2 / (2 * a * b)
        if x <= lo:
            return Fraction(1, 2) + x / a
        return 1 - (hi - x) ** 2 / (2 * a * b)

    if a == 0:
        return float(s - math.floor(s) < d)
    total = Fraction(0)
    for k in range(math.floor(s - hi) - 1, math.ceil(s + hi) + 1):
        total += below(k + d - s) - below(k - s)
    return float(total)


TINY = [0.0, 1e-12, 1e-8]
EDGES = [0.0, 0.375, 1.0, -0.625, 1e6, 1e6 + 0.375, -1e6 + 0.375, 123456.0]


@pytest.mark.parametrize("edge", EDGES)
@pytest.mark.parametrize("width", TINY)
def test_tiny_footprints_are_the_exact_mean_to_1e_6(edge, width):
    """Footprints of 0, 1e-12 and 1e-8 periods on, next to and away from stripe edges (also
    at s ~ 1e6): the coverage is the exact mean of the indicator (not the difference of
    antiderivatives over O(1) arguments, which cancels to ~1e-16 / (a b))."""
    duty = 0.375
    for offset in (0.0, 0.3, -0.3, 0.7, 3.0, -3.0, 0.25, 1e4):
        s = edge + offset * width if offset != 1e4 else edge + 0.2
        for a, b in ((width, width), (width, 0.4 * width), (width, 1e-3 * width), (width, 0.0)):
            got = float(stripe_coverage(s, a, b, duty=duty))
            assert abs(got - exact_mean(s, a, b, duty)) < 1e-6, (s, a, b)


def test_the_issue_example_is_exact():
    """Issue 14: stripe_coverage(1.203125, 1e-8, 1e-8, duty=0.375) gave 0.98879."""
    assert stripe_coverage(1.203125, 1e-8, 1e-8, duty=0.375) == 1.0
    assert exact_mean(1.203125, 1e-8, 1e-8, 0.375) == 1.0


def test_negative_s_next_to_an_edge_keeps_its_last_bit():
    """For -1/2 < s < 0, s - floor(s) rounds; a footprint of 1e-15 periods at that edge must
    still see where s lies (the rounding error of fract(s) is carried)."""
    for s, duty in ((-0.3, 0.7), (-0.3 + 2**-54, 0.7), (-(2**-60), 0.5), (-0.4, 0.6)):
        for a, b in ((1e-15, 1e-15), (1e-16, 0.0), (3e-16, 1e-16)):
            got = float(stripe_coverage(s, a, b, duty=duty))
            assert abs(got - exact_mean(s, a, b, duty)) < 1e-6, (s, a, b, duty)


def test_thin_pixels_across_many_stripes_are_exact():
    """|ds/dy| far below |ds/dx| (the gradient along a pixel axis): the exact mean, not the
    box of width a + b (off by up to ~b / a)."""
    rng = np.random.default_rng(5)
    for _ in range(300):
        s, a = rng.uniform(-50, 50), 10 ** rng.uniform(-1, 1.5)
        b, duty = a * 10 ** rng.uniform(-12, -2), rng.uniform(0.1, 0.9)
        got = float(stripe_coverage(s, a, b, duty=duty))
        assert abs(got - exact_mean(s, a, b, duty)) < 1e-6, (s, a, b, duty)


# footprints from 1e-15 to 30 periods (and 0): log-uniform, so that tiny ones are drawn
LOG_WIDTHS = st.one_of(st.just(0.0), st.floats(-15.0, 1.5).map(lambda e: 10.0**e))


@settings(max_examples=300, deadline=None)
@given(
    s=st.one_of(st.floats(-100, 100), st.integers(-(10**6), 10**6).map(float)),
    nudge=st.floats(-2.0, 2.0),
    a=LOG_WIDTHS,
    ratio=st.one_of(st.just(0.0), st.just(1.0), st.floats(1e-12, 1.0)),
    duty=st.sampled_from([0.5, 0.375, 0.1, 0.9]) | st.floats(0.1, 0.9),
)
@example(s=1.0, nudge=0.203125 / 1e-8, a=1e-8, ratio=1.0, duty=0.375)  # issue 14: s=1.203125
@example(s=-1.0, nudge=-0.25 / 1e-8, a=1e-8, ratio=1.0, duty=0.5)
@example(s=0.0, nudge=0.3, a=1e-12, ratio=1.0, duty=0.375)
@example(s=1e6, nudge=0.375 / 1e-8, a=1e-8, ratio=0.0, duty=0.375)
def test_coverage_is_the_exact_mean_to_1e_6(s, nudge, a, ratio, duty):
    """Any footprint, any position (s is an edge-ish value plus ``nudge`` footprints): the
    coverage is the exact mean of the indicator over the pixel to 1e-6."""
    s = float(s + nudge * a)
    b = a * ratio
    got = float(stripe_coverage(s, a, b, duty=duty))
    assert abs(got - exact_mean(s, a, b, duty)) < 1e-6


def test_tiny_footprints_are_the_same_on_drjit():
    """The renderer's Dr.Jit path of the same formula, at tiny footprints next to edges and
    a duty that is not a float32 number (a select of two Python numbers is float32 there)."""
    from gshade.shape.kernels import backend

    if backend() != "drjit":
        pytest.skip("no usable libLLVM here")
    from drjit.llvm import Float64

    from gshade.display.colour import coverage_formula
    from gshade.runtime.backend import drjit_ops

    rng = np.random.default_rng(2)
    edges = rng.integers(-1000, 1000, 4000) + rng.choice([0.0, 0.4], 4000)
    a = 10 ** rng.uniform(-13, -1, 4000)
    b = a * rng.choice([0.0, 1e-3, 0.5, 1.0], 4000)
    s = edges + a * rng.uniform(-1, 1, 4000)
    s[:500] = rng.uniform(-0.5, 0.0, 500)
    got = np.array(coverage_formula(Float64(s), Float64(a), Float64(b), 0.4, drjit_ops()))
    np.testing.assert_allclose(got, stripe_coverage(s, a, b, duty=0.4), rtol=0, atol=1e-12)
    for i in range(0, 4000, 97):
        assert abs(got[i] - exact_mean(s[i], a[i], b[i], 0.4)) < 1e-6


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
