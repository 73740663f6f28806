"""Random B-spline data for the property tests: knot vectors (a hypothesis strategy),
control nets, parameters inside a domain, whole patches."""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st

from gshade.geometry import BSplinePatch


@st.composite
def knot_vectors(draw, degree: int, n_points: int, clamped: bool | None = None):
    """Nonuniform knot vectors, clamped (interior multiplicities up to the degree) or not."""
    if clamped is None:
        clamped = draw(st.booleans())
    if clamped:
        k = n_points - degree - 1
        values = sorted(draw(st.lists(st.integers(1, 19), min_size=k, max_size=k)))
        interior, seen = [], {}
        for x in values:
            seen[x] = seen.get(x, 0) + 1
            extra = max(0, seen[x] - degree)  # beyond multiplicity p: nudge apart
            interior.append(x / 20 + 0.001 * extra)
        return np.array([0.0] * (degree + 1) + sorted(interior) + [1.0] * (degree + 1))
    k = n_points + degree + 1
    steps = draw(st.lists(st.integers(1, 4), min_size=k - 1, max_size=k - 1))
    knots = np.concatenate([[0.0], np.cumsum(steps)])  # strictly increasing, nonuniform
    return knots / knots[-1]


def random_net(rng: np.random.Generator, shape: tuple[int, ...], rational: bool):
    """Normal random points of ``shape`` (and weights in [0.5, 2] where ``rational``)."""
    points = rng.normal(size=(*shape, 3))
    weights = rng.uniform(0.5, 2.0, size=shape) if rational else None
    return points, weights


def interior_parameters(rng, domain, n):
    """``n`` random parameters inside ``domain`` (lo, hi), away from its ends."""
    lo, hi = domain
    return lo + (hi - lo) * rng.uniform(0.02, 0.98, n)


def random_patch(data, rng, p: int, q: int, rational: bool, extra: int) -> BSplinePatch:
    """A B-spline patch of degrees (p, q) with up to ``extra`` more control points per
    direction than the minimum, random knots (clamped or not) and a random net."""
    nu, nv = p + 1 + data.draw(st.integers(0, extra)), q + 1 + data.draw(st.integers(0, extra))
    U = data.draw(knot_vectors(p, nu))
    V = data.draw(knot_vectors(q, nv))
    P, W = random_net(rng, (nu, nv), rational)
    return BSplinePatch(P, (p, q), (U, V), W)
