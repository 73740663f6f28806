"""``BSplinePatch.restricted(box)``: the same surface over a sub-box of its domain, exactly."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade.errors import GshadeError
from gshade.geometry import BSplinePatch

from ...support.random_patches import random_net, random_patch

#: Derivative (i, j) may differ by this times the net's size / (hu^i hv^j), with hu, hv the
#: smallest knot spans of the restricted patch: round-off in the net, amplified by the spans.
TOL = 1e-12


def smallest_span(knots) -> float:
    return float(np.diff(np.unique(knots)).min())


def assert_same_surface(original, restricted, u, v, order=2):
    """``restricted`` and ``original`` have the same derivatives at (u, v); returns the
    largest error relative to the net's size (derivatives scaled by the spans)."""
    d0 = original.derivatives(u, v, order)
    d1 = restricted.derivatives(u, v, order)
    hu, hv = (smallest_span(k) for k in restricted.knots)
    size = np.abs(original.points).max()
    worst = 0.0
    for i in range(order + 1):
        for j in range(order + 1 - i):
            err = np.abs(d1[i, j] - d0[i, j]).max() * hu**i * hv**j / size
            assert err <= TOL, f"d{i}{j}: error {err:.3g} x net size"
            worst = max(worst, err)
    return worst


def box_end_choices(knots, lo, hi, rng):
    """Domain ends, knots inside the domain and random points inside spans."""
    inside = [float(x) for x in np.unique(knots) if lo <= x <= hi]
    return sorted({lo, hi, *inside, *(float(x) for x in rng.uniform(lo, hi, 3))})


def draw_range(data, choices):
    a = data.draw(st.sampled_from(choices[:-1]))
    b = data.draw(st.sampled_from([x for x in choices if x > a]))
    return a, b


@settings(max_examples=150, deadline=None)
@given(
    data=st.data(),
    p=st.integers(1, 4),
    q=st.integers(1, 3),
    rational=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
)
def test_restricted_is_the_same_surface_over_the_box(data, p, q, rational, seed):
    rng = np.random.default_rng(seed)
    patch = random_patch(data, rng, p, q, rational, extra=6)  # knots clamped or not
    U, V = patch.knots
    (ul, uh), (vl, vh) = patch.domain
    bu = draw_range(data, box_end_choices(U, ul, uh, rng))
    bv = draw_range(data, box_end_choices(V, vl, vh, rng))
    out = patch.restricted((bu, bv))
    assert out.domain == (bu, bv)
    assert out.degree == (p, q) and out.rational == rational
    u = rng.uniform(*bu, 25)
    v = rng.uniform(*bv, 25)
    assert_same_surface(patch, out, u, v)
    # the box's corners and edges too (one-sided at the ends, like the original's spans)
    assert_same_surface(patch, out, np.array([bu[0], bu[0], bu[0]]), np.array([*bv, v[0]]), 0)


@pytest.mark.parametrize("rational", [False, True])
@pytest.mark.parametrize(
    "U",
    [
        [0, 0, 0, 0, 0.25, 0.5, 0.75, 1, 1, 1, 1],  # uniform, clamped
        [0, 0, 0, 0, 0.1, 0.15, 0.15, 0.7, 1, 1, 1, 1],  # nonuniform, a double knot
        [0, 0.1, 0.3, 0.35, 0.5, 0.6, 0.62, 0.8, 0.85, 0.9, 1.0],  # unclamped, nonuniform
    ],
)
@pytest.mark.parametrize(
    "bu",
    [
        "domain",  # the whole domain
        "knots",  # ends on existing knots
        "inside",  # ends inside spans
        "one span",  # both ends inside one span
        "mixed",  # the domain's start, a point inside a span
    ],
)
def test_box_ends_on_knots_inside_spans_and_at_the_domain_ends(U, bu, rational):
    rng = np.random.default_rng(7)
    p, q = 3, 2
    U = np.array(U, dtype=float)
    V = np.array([0, 0, 0, 0.2, 0.5, 0.5, 1, 1, 1.0])
    P, W = random_net(rng, (len(U) - p - 1, len(V) - q - 1), rational)
    patch = BSplinePatch(P, (p, q), (U, V), W)
    (lo, hi), _ = patch.domain
    interior = np.unique(U[(U > lo) & (U < hi)])
    box_u = {
        "domain": (lo, hi),
        "knots": (float(interior[0]), float(interior[-1])),
        "inside": (lo + 0.37 * (interior[0] - lo), hi - 0.21 * (hi - interior[-1])),
        "one span": (lo + 0.1 * (interior[0] - lo), lo + 0.3 * (interior[0] - lo)),
        "mixed": (lo, float(interior[1]) + 0.013),
    }[bu]
    box = (box_u, (0.2, 0.77))
    out = patch.restricted(box)
    assert out.domain == box
    u = rng.uniform(*box_u, 40)
    v = rng.uniform(0.2, 0.77, 40)
    assert_same_surface(patch, out, u, v)


def test_the_whole_domain_of_a_clamped_patch_gives_the_same_net():
    rng = np.random.default_rng(3)
    U = [0, 0, 0, 0.3, 0.3, 0.6, 1, 1, 1]
    V = [0, 0, 0, 0, 0.5, 1, 1, 1, 1]
    P, W = random_net(rng, (6, 5), True)
    patch = BSplinePatch(P, (2, 3), (U, V), W)
    out = patch.restricted(patch.domain)
    assert out is not patch
    for a, b in zip(out.knots, patch.knots, strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(out.weights, patch.weights)
    # (w P) / w: round-off only
    np.testing.assert_allclose(out.points, patch.points, rtol=1e-15, atol=0)


def test_a_restriction_of_a_restriction_is_the_restriction():
    rng = np.random.default_rng(4)
    U = [0, 0, 0, 0, 0.2, 0.45, 0.5, 0.8, 1, 1, 1, 1]
    P, W = random_net(rng, (8, 8), True)
    patch = BSplinePatch(P, (3, 3), (U, U), W)
    inner = ((0.3, 0.61), (0.05, 0.5))
    twice = patch.restricted(((0.1, 0.9), (0.0, 0.7))).restricted(inner)
    once = patch.restricted(inner)
    for a, b in zip(twice.knots, once.knots, strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_allclose(twice.points, once.points, rtol=0, atol=1e-13)


def test_domain_is_exactly_the_floats_given():
    U = [0, 0, 0, 0.1, 0.3, 0.7, 1, 1, 1]
    patch = BSplinePatch(np.random.default_rng(0).normal(size=(6, 6, 3)), (2, 2), (U, U))
    box = ((0.1 + 0.2, 0.7), (np.float64(1 / 3), 1))
    out = patch.restricted(box)
    assert out.domain == ((0.1 + 0.2, 0.7), (1 / 3, 1.0))
    assert all(type(x) is float for pair in out.domain for x in pair)


def test_the_original_is_unchanged():
    rng = np.random.default_rng(5)
    U = [0, 0, 0, 0.5, 1, 1, 1]
    P, W = random_net(rng, (4, 4), True)
    patch = BSplinePatch(P, (2, 2), (U, U), W)
    before = [a.copy() for a in (patch.points, patch.weights, *patch.knots)]
    domain = patch.domain
    out = patch.restricted(((0.2, 0.6), (0.1, 0.5)))
    after = [patch.points, patch.weights, *patch.knots]
    for a, b in zip(before, after, strict=True):
        np.testing.assert_array_equal(a, b)
    assert patch.domain == domain
    assert type(out) is BSplinePatch
    assert not np.shares_memory(out.points, patch.points)


def circular_cylinder() -> BSplinePatch:
    """A unit-radius half cylinder: rational quadratic circle arcs (weights sqrt(2)/2) in u,
    lines in v, with a knot between the quarter circles."""
    s = np.sqrt(0.5)
    circle = np.array([[1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0]], dtype=float)
    wc = np.array([1, s, 1, s, 1])
    P = np.array([[[x, y, z] for z in (0.0, 2.0)] for x, y in circle])
    W = np.repeat(wc[:, None], 2, axis=1)
    return BSplinePatch(P, (2, 1), ([0, 0, 0, 0.5, 0.5, 1, 1, 1], [0, 0, 1, 1]), W)


def test_weights_are_inserted_with_the_points():
    """Boehm on (w P, w): the restricted cylinder stays on the unit circle.  Inserting the
    points and the weights apart (or keeping the weights) leaves it by up to 0.06."""
    patch = circular_cylinder()
    box = ((0.13, 0.81), (0.25, 0.9))
    out = patch.restricted(box)
    assert out.rational
    u = np.linspace(0.13, 0.81, 41)
    v = np.linspace(0.25, 0.9, 41)
    xyz = out.derivatives(u, v, 0)[0, 0]
    np.testing.assert_allclose(np.hypot(xyz[:, 0], xyz[:, 1]), 1.0, rtol=0, atol=1e-14)
    np.testing.assert_allclose(xyz[:, 2], 2 * v, rtol=0, atol=1e-14)
    assert_same_surface(patch, out, u, v)


def periodic_patch(p: int = 3, k: int = 7) -> BSplinePatch:
    """A closed (periodic) surface as Open CASCADE's ``SetUNotPeriodic`` leaves it: the
    first p poles repeated at the end, uniform unclamped knots, domain [U_p, U_n]."""
    rng = np.random.default_rng(11)
    angles = 2 * np.pi * np.arange(k) / k
    ring = np.stack([np.cos(angles), np.sin(angles)], axis=-1) * rng.uniform(0.8, 1.2, (k, 1))
    ring = np.concatenate([ring, ring[:p]])  # k + p poles
    P = np.array([[[x, y, z] for z in (0.0, 1.0, 2.5)] for x, y in ring])
    W = rng.uniform(0.7, 1.5, (k, 3))
    W = np.concatenate([W, W[:p]])
    U = 0.4 * np.arange(-p, k + p + 1)  # k + 2p + 1 knots: unclamped at both ends
    return BSplinePatch(P, (p, 2), (U, [0, 0, 0, 1, 1, 1]), W)


def test_unclamped_periodic_style_knot_vector():
    patch = periodic_patch()
    (lo, hi), _ = patch.domain
    assert (lo, hi) == (0.0, 0.4 * 7)
    # closed: the seam ends meet
    seam = patch.derivatives(np.array([lo, hi]), np.array([0.3, 0.3]), 0)[0, 0]
    np.testing.assert_allclose(seam[0], seam[1], rtol=0, atol=1e-14)
    rng = np.random.default_rng(2)
    for box_u in [(lo, hi), (lo, 1.3), (0.4, 2.0), (1.1, hi), (0.55, 0.7)]:
        box = (box_u, (0.0, 1.0))
        out = patch.restricted(box)
        assert out.domain == box
        U = out.knots[0]
        np.testing.assert_array_equal(U[:4], box_u[0])  # clamped at the box ends
        np.testing.assert_array_equal(U[-4:], box_u[1])
        assert_same_surface(patch, out, rng.uniform(*box_u, 40), rng.uniform(0, 1, 40))
    # the whole domain: the restricted surface is still closed
    out = patch.restricted(((lo, hi), (0.0, 1.0)))
    seam2 = out.derivatives(np.array([lo, hi]), np.array([0.3, 0.3]), 0)[0, 0]
    np.testing.assert_allclose(seam2, seam, rtol=0, atol=1e-14)


@pytest.mark.parametrize(
    "box, words",
    [
        (((0.5, 0.5), (0.0, 1.0)), "empty u range"),
        (((0.6, 0.5), (0.0, 1.0)), "empty u range"),
        (((0.0, 1.0), (0.7, 0.2)), "empty v range"),
        (((-0.1, 0.5), (0.0, 1.0)), "inside the domain"),
        (((0.0, 1.0), (0.5, 1.0000001)), "inside the domain"),
        (((2.0, 3.0), (0.0, 1.0)), "inside the domain"),
        (((0.0, float("nan")), (0.0, 1.0)), "finite numbers"),
        (((0.0, 1.0), (0.0, float("inf"))), "finite numbers"),
        (((0.0, 1.0),), "finite numbers"),
        ((0.0, 1.0, 0.0, 1.0), "finite numbers"),
        ((("0", "1"), (0.0, 1.0)), "finite numbers"),
        (((True, 1.0), (0.0, 1.0)), "finite numbers"),
        (None, "finite numbers"),
    ],
)
def test_bad_boxes_are_one_line_errors_naming_box(box, words):
    U = [0, 0, 0, 0.5, 1, 1, 1]
    patch = BSplinePatch(np.zeros((4, 4, 3)), (2, 2), (U, U))
    with pytest.raises(GshadeError, match=words) as info:
        patch.restricted(box)
    message = str(info.value)
    assert message.startswith("box: ") and "\n" not in message


@settings(max_examples=120, deadline=None)
@given(
    data=st.data(),
    p=st.integers(1, 4),
    q=st.integers(1, 3),
    rational=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
    past=st.tuples(*[st.floats(0.0, 0.05)] * 4),
)
def test_a_box_past_the_domain_continues_the_end_pieces(data, p, q, rational, seed, past):
    """``restricted(box, beyond=True)`` over a box reaching past the domain is the surface
    :meth:`derivatives_beyond` evaluates there (the end spans' pieces continued, as the
    kernel extrapolates), and no knot is added (a knot line would be a false junction)."""
    rng = np.random.default_rng(seed)
    patch = random_patch(data, rng, p, q, rational, extra=4)
    (ul, uh), (vl, vh) = patch.domain
    wu, wv = uh - ul, vh - vl
    # past each end by up to 5 % of its span (with weights 0.5 .. 2 the continued rational
    # pieces' weights stay positive there)
    su, sv = (
        np.diff(np.unique(k[(k >= lo) & (k <= hi)]))
        for k, (lo, hi) in zip(patch.knots, patch.domain, strict=True)
    )
    box = (
        (ul - past[0] * su[0], uh + past[1] * su[-1]),
        (vl - past[2] * sv[0], vh + past[3] * sv[-1]),
    )
    out = patch.restricted(box, beyond=True)
    assert out.domain == box
    for mine, theirs, (lo, hi) in zip(out.knots, patch.knots, patch.domain, strict=True):
        inner = np.unique(theirs[(theirs > lo) & (theirs < hi)])
        np.testing.assert_array_equal(np.unique(mine[(mine > lo) & (mine < hi)]), inner)
    u = np.concatenate([rng.uniform(*box[0], 30), [box[0][0], box[0][1]]])
    v = np.concatenate([rng.uniform(*box[1], 30), [box[1][1], box[1][0]]])
    want = patch.derivatives_beyond(u, v, 2)
    got = out.derivatives(u, v, 2)
    size = np.abs(want[0, 0]).max()
    for i in range(3):
        for j in range(3 - i):
            scale = size / (wu**i * wv**j)
            err = np.abs(got[i, j] - want[i, j]).max() / scale
            # round-off only: re-blossomed poles of a rational piece over a short span
            # (1e-3 of the domain) carry ~1e-9 into its second derivatives
            assert err < 1e-8, f"d{i}{j}: {err:.3g}"


def test_a_box_past_the_domain_is_refused_unless_asked():
    patch = circular_cylinder()
    with pytest.raises(GshadeError, match="inside the domain"):
        patch.restricted(((-0.01, 1.0), (0.0, 1.0)))
    out = patch.restricted(((-0.01, 1.0), (0.0, 1.0)), beyond=True)
    assert out.domain == ((-0.01, 1.0), (0.0, 1.0))


@pytest.mark.parametrize("rational", [False, True])
def test_a_box_a_round_off_from_a_knot_leaves_no_sliver_span(rational):
    # a CAD face's box 4e-14 short of the knot 6 (a STEP file of Alias AutoStudio's): cut
    # there, the restricted spline had a first span of 4e-14, and its second derivatives at
    # the box's edge were off by 1e13
    rng = np.random.default_rng(7)
    U = np.array([1.0, 2, 2, 2, 3, 4, 5, 6, 7, 8, 9, 10, 10, 10, 11])
    V = np.array([0.0, 0, 0, 0, 1, 1, 1, 1])
    net = rng.normal(size=(len(U) - 4, 4, 3)) * 20
    weights = rng.uniform(0.5, 2.0, size=net.shape[:2]) if rational else None
    patch = BSplinePatch(net, (3, 3), (U, V), weights=weights)
    for u0, u1 in ((6 - 4e-14, 10.0), (2.5, 9 + 3e-14), (6 - 4e-14, 9 + 3e-14)):
        box = ((u0, u1), (0.25, 0.75))
        restricted = patch.restricted(box)
        assert restricted.domain == box  # exactly the box's floats
        assert smallest_span(restricted.knots[0]) >= 0.5  # no sliver span
        u = np.array([u0, u0, u1, u1, 0.5 * (u0 + u1)])
        v = np.array([0.25, 0.75, 0.25, 0.75, 0.5])
        # to order 2: the knots are simple (C2), the third derivatives two-valued there
        d0, d1 = patch.derivatives(u, v, 2), restricted.derivatives(u, v, 2)
        scale = np.abs(d0).max(axis=(2, 3), keepdims=True) + np.abs(net).max()
        assert np.abs(d1 - d0).max() <= 1e-9 * scale.max()
        assert (np.abs(d1 - d0) <= 1e-9 * scale).all()
