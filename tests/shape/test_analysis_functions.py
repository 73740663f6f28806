"""The analysis functions against closed forms: ``draft_angle`` (order 1) on the sphere, a
cone and planes; ``min_radius`` (order 2) on the sphere, cylinder, torus and ellipsoid."""

import numpy as np
import pytest

from gshade import GshadeError
from gshade.geometry import (
    BezierPatch,
    BSplineCurve,
    BSplinePatch,
    regularised_derivatives,
    revolve,
    sphere,
    unit_normal,
)
from gshade.shape import SHAPE_FUNCTIONS, evaluate

from ..support import curvature_oracles

BACKENDS = ["numpy", "drjit"]


def _backend(name):
    if name == "drjit":
        from gshade.shape.kernels import backend

        if backend() != "drjit":
            pytest.skip("no usable libLLVM here: only the numpy backend runs")
    return name


def _grid(patch, n=25):
    u, v = patch.parameter_grid(n, n)
    return regularised_derivatives(patch, u, v, 3).d


# --------------------------------------------------------------------------- draft angle


@pytest.mark.parametrize("backend", BACKENDS)
def test_draft_on_a_sphere_is_the_latitude_about_the_pull_direction(backend):
    """delta = arcsin <n, d>: on a sphere, the latitude of the point about the pole d (with
    the patch's normal, which points inward here: minus the latitude)."""
    _backend(backend)
    d = _grid(sphere(2.0))
    rng = np.random.default_rng(5)
    for pull in rng.normal(size=(4, 3)):
        pull = pull / np.linalg.norm(pull)
        f = evaluate("draft_angle", d, direction=pull, backend=backend).f
        p = d[0, 0] / np.linalg.norm(d[0, 0], axis=-1)[..., None]
        latitude = np.degrees(np.arcsin(np.clip(p @ pull, -1, 1)))
        poles = np.abs(p[..., 2]) > 0.999  # regularised derivatives there: near the limit
        np.testing.assert_allclose(f[~poles], -latitude[~poles], atol=1e-9)
        np.testing.assert_allclose(f[poles], -latitude[poles], atol=1e-2)


@pytest.mark.parametrize("backend", BACKENDS)
def test_draft_on_a_cone_is_its_half_angle_everywhere(backend):
    """A cone of radii r0 at z = 0 and r1 < r0 at z = h leans by atan((r0 - r1) / h) from its
    axis: that is its draft, one sign for the outward normal, the other for the inward."""
    _backend(backend)
    r0, r1, h = 2.0, 1.2, 3.0
    cone = revolve(BSplineCurve([[r0, 0.0], [r1, h]], 1, [0, 0, 1, 1]))
    d = _grid(cone)
    f = evaluate("draft_angle", d, direction=[0, 0, 1], backend=backend).f
    n = unit_normal(d).n
    outward = np.sign(np.sum(n[..., :2] * d[0, 0][..., :2], -1))
    half_angle = np.degrees(np.arctan((r0 - r1) / h))
    np.testing.assert_allclose(f, outward * half_angle, atol=1e-10)
    assert abs(outward.sum()) == outward.size  # one orientation over the whole patch


def test_draft_of_planes_walls_and_faces_along_the_pull():
    """A plane parallel to d: 0 exactly (the parting line); facing d: +90; a plane tilted
    by t from d: t; its slope is 0 (a constant is one colour)."""
    for tilt in (0.0, 1.0, 3.0, 45.0, -2.5):
        t = np.radians(tilt)
        # a wall through the origin, spanned by x and (0, sin t, cos t): n = (0, -cos, sin)
        P = np.array(
            [[[0, 0, 0], [0, np.sin(t), np.cos(t)]], [[1, 0, 0], [1, np.sin(t), np.cos(t)]]]
        )
        res = evaluate("draft_angle", BezierPatch(P).derivatives(*np.full((2, 5), 0.3), 2))
        np.testing.assert_allclose(res.f, tilt, atol=1e-12)
        np.testing.assert_allclose(res.gradient, 0.0, atol=1e-12)
    flat = BezierPatch(np.array([[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]], float))
    assert evaluate("draft_angle", flat.derivatives(0.5, 0.5, 2)).f == pytest.approx(90.0)


# --------------------------------------------------------------------------- radius limits


def _largest(k1, k2):
    return np.where(np.abs(k1) >= np.abs(k2), k1, k2)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("surface", ["sphere", "cylinder", "torus"])
def test_min_radius_is_the_curvature_of_largest_magnitude(surface, backend):
    """On closed-form surfaces (derivatives written out by hand), with its sign; the
    surface gradient matches that of the principal curvature it follows."""
    _backend(backend)
    o = curvature_oracles.surface(surface)
    res = evaluate("min_radius", o.d, backend=backend)
    assert res.valid.all()
    np.testing.assert_allclose(res.f, _largest(o.k_around, o.k_along), rtol=1e-12, atol=1e-12)


def _ellipsoid(a, b, c):
    s = sphere(1.0)
    return BSplinePatch(s.points * np.array([a, b, c]), s.degree, s.knots, s.weights)


@pytest.mark.parametrize("backend", BACKENDS)
def test_min_radius_on_an_ellipsoid_matches_its_closed_form(backend):
    """x^2/a^2 + y^2/b^2 + z^2/c^2 = 1: K = 1 / (a b c h^2)^2 and |H| = |x^2 + y^2 + z^2 - a^2
    - b^2 - c^2| / (2 (a b c)^2 h^3), h^2 = x^2/a^4 + y^2/b^4 + z^2/c^4; the largest curvature
    is |H| + sqrt(H^2 - K), of the sign of H (the patch's normal points inward: +)."""
    _backend(backend)
    a, b, c = 3.0, 2.0, 1.0
    d = _grid(_ellipsoid(a, b, c), 31)
    x, y, z = np.moveaxis(d[0, 0], -1, 0)
    h = np.sqrt(x**2 / a**4 + y**2 / b**4 + z**2 / c**4)
    K = 1.0 / (a * b * c * h**2) ** 2
    H = np.abs(x**2 + y**2 + z**2 - a**2 - b**2 - c**2) / (2 * (a * b * c) ** 2 * h**3)
    expected = H + np.sqrt(np.maximum(H**2 - K, 0.0))
    f = evaluate("min_radius", d, backend=backend).f
    np.testing.assert_allclose(f, expected, rtol=1e-6)  # the poles: regularised derivatives
    inner = slice(1, -1)
    np.testing.assert_allclose(
        f.reshape(31, 31)[inner], expected.reshape(31, 31)[inner], rtol=1e-10
    )
    assert f.max() == pytest.approx(
        a / c**2, rel=1e-3
    )  # the smallest radius: c^2 / a at (±a, 0, 0)


# --------------------------------------------------------------------------- the registry


@pytest.mark.parametrize(
    ("name", "params", "message"),
    [
        (
            "draft_angle",
            {"min_angle": 90},
            r"draft_angle: min_angle: expected degrees in \[0, 90\)",
        ),
        ("draft_angle", {"min_angle": -1}, "min_angle: expected degrees"),
        ("draft_angle", {"direction": [0, 0, 0]}, "direction: expected a direction"),
        ("min_radius", {"limit": 0}, "min_radius: limit: expected a positive length, got 0"),
        ("min_radius", {"limit": float("inf")}, "limit: expected a positive length"),
        ("min_radius", {"limit": "5 mm"}, "limit: expected a number"),
    ],
)
def test_bad_analysis_parameters_name_the_parameter(name, params, message):
    d = sphere(1.0).derivatives(0.3, 0.3, 3)
    with pytest.raises(GshadeError, match=message):
        evaluate(name, d, **params)


def test_the_analyses_are_registered_with_their_order_and_parameters():
    draft, radius = SHAPE_FUNCTIONS["draft_angle"], SHAPE_FUNCTIONS["min_radius"]
    assert (draft.order, radius.order) == (1, 2)
    assert set(draft.parameters) == {"direction", "min_angle"}
    assert set(radius.parameters) == {"limit"}
    assert draft.signed and radius.signed
