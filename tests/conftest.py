"""Shared test helpers: random control nets and knot vectors for property tests."""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
from hypothesis import settings
from hypothesis import strategies as st

from gshade.geometry import BSplinePatch

# CI runs the same examples every time (a red CI must mean a change, not a new draw);
# locally each run explores new ones.
settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")

# gshade's content-keyed caches (the optimised hole fillings) go to a folder of this test
# session's, which its subprocesses inherit, never to the user's ~/.cache
if "GSHADE_CACHE_DIR" not in os.environ:
    os.environ["GSHADE_CACHE_DIR"] = tempfile.mkdtemp(prefix="gshade-tests-cache-")
    atexit.register(shutil.rmtree, os.environ["GSHADE_CACHE_DIR"], True)

ROOT = Path(__file__).resolve().parents[1]
TEAPOT = ROOT / "scenes" / "data" / "teapot.txt"


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
    points = rng.normal(size=(*shape, 3))
    weights = rng.uniform(0.5, 2.0, size=shape) if rational else None
    return points, weights


def interior_parameters(rng, domain, n):
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
