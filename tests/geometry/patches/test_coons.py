"""Coons patches interpolate their boundary data; polynomial ones convert exactly to Bézier."""

import numpy as np
import pytest

from gshade import GshadeError
from gshade.geometry import BezierCurve, BezierPatch, BSplineCurve, CoonsPatch


@pytest.fixture
def bicubic():
    return BezierPatch(np.random.default_rng(4).normal(size=(4, 4, 3)))


def boundaries(patch):
    return [patch.boundary(s) for s in ("v0", "v1", "u0", "u1")]


def cross_derivatives(patch):
    """p_v along v = 0, 1 and p_u along u = 0, 1 of a Bézier patch, as Bézier curves."""
    P = patch.points
    m, n = patch.degree
    return {
        "cross_v0": BezierCurve(n * (P[:, 1] - P[:, 0])),
        "cross_v1": BezierCurve(n * (P[:, -1] - P[:, -2])),
        "cross_u0": BezierCurve(m * (P[1] - P[0])),
        "cross_u1": BezierCurve(m * (P[-1] - P[-2])),
    }


def curved_boundaries():
    """Four curves of different kinds and degrees meeting at the corners of a saddle-ish quad."""
    c00, c10, c01, c11 = (np.array(x, float) for x in ([0, 0, 0], [3, 0, 1], [0, 2, 1], [3, 2, 0]))
    v0 = BezierCurve([c00, [1, -0.5, 0.5], [2, 0.4, 1.5], c10])
    v1 = BSplineCurve(
        [c01, [1, 2.5, 1], [2, 2.2, 0.2], [2.5, 2.4, -0.3], c11], 3, [0, 0, 0, 0, 0.4, 1, 1, 1, 1]
    )
    u0 = BezierCurve([c00, [-0.4, 1, 0.2], c01], weights=[1, 2, 1])
    u1 = BezierCurve([c10, [3.3, 1, 0.8], c11], domain=(-2, 5))
    return v0, v1, u0, u1


def test_bilinear_coons_interpolates_its_boundaries():
    v0, v1, u0, u1 = curved_boundaries()
    patch = CoonsPatch(v0, v1, u0, u1)
    t = np.linspace(0, 1, 17)
    z, o = np.zeros_like(t), np.ones_like(t)
    np.testing.assert_allclose(patch(t, z), v0(t), atol=1e-14)
    np.testing.assert_allclose(patch(t, o), v1(t), atol=1e-14)
    np.testing.assert_allclose(patch(z, t), u0(t), atol=1e-14)
    np.testing.assert_allclose(patch(o, t), u1(-2 + 7 * t), atol=1e-14)
    # boundary tangents too (derivative along the edge, with the domain mapped to [0, 1])
    np.testing.assert_allclose(
        patch.derivatives(o, t, 1)[0, 1], 7 * u1.derivatives(-2 + 7 * t, 1)[1], atol=1e-12
    )


def test_derivatives_match_finite_differences():
    patch = CoonsPatch(*curved_boundaries())
    rng = np.random.default_rng(0)
    u, v = rng.uniform(0.1, 0.9, 20), rng.uniform(0.1, 0.9, 20)
    d = patch.derivatives(u, v, 3)
    h = 1e-6
    du = (patch.derivatives(u + h, v, 2) - patch.derivatives(u - h, v, 2)) / (2 * h)
    dv = (patch.derivatives(u, v + h, 2) - patch.derivatives(u, v - h, 2)) / (2 * h)
    for i in range(3):
        for j in range(3 - i):
            np.testing.assert_allclose(du[i, j], d[i + 1, j], atol=1e-4)
            np.testing.assert_allclose(dv[i, j], d[i, j + 1], atol=1e-4)


def test_bicubic_coons_interpolates_cross_derivatives(bicubic):
    cross = cross_derivatives(bicubic)
    # perturb the interior: use cross derivatives of another patch with the same boundary
    patch = CoonsPatch(*boundaries(bicubic), **cross)
    t = np.linspace(0, 1, 11)
    z, o = np.zeros_like(t), np.ones_like(t)
    d = patch.derivatives(np.r_[t, t, z, o], np.r_[z, o, t, t], 1)
    np.testing.assert_allclose(d[0, 1][:11], cross["cross_v0"](t), atol=1e-12)
    np.testing.assert_allclose(d[0, 1][11:22], cross["cross_v1"](t), atol=1e-12)
    np.testing.assert_allclose(d[1, 0][22:33], cross["cross_u0"](t), atol=1e-12)
    np.testing.assert_allclose(d[1, 0][33:], cross["cross_u1"](t), atol=1e-12)


def test_bicubic_coons_reproduces_a_bicubic_patch(bicubic):
    patch = CoonsPatch(*boundaries(bicubic), **cross_derivatives(bicubic))
    rng = np.random.default_rng(1)
    u, v = rng.random(30), rng.random(30)
    np.testing.assert_allclose(patch.derivatives(u, v, 3), bicubic.derivatives(u, v, 3), atol=1e-12)


def test_bilinear_coons_reproduces_a_bilinearly_blended_bezier_patch():
    # a Bézier patch whose interior points are the bilinear Coons points from its boundary
    v0, _, u0, u1 = curved_boundaries()
    v1 = BezierCurve(np.array([[0, 2, 1], [1.5, 2.5, 0.2], [3, 2, 0]], float))
    u0p = BezierCurve([[0, 0, 0], [-0.4, 1, 0.2], [0, 2, 1]])
    u1p = BezierCurve([[3, 0, 1], [3.3, 1, 0.8], [3, 2, 0]])
    patch = CoonsPatch(v0, v1, u0p, u1p)
    bez = patch.to_bezier()
    assert bez.degree == (3, 2)
    rng = np.random.default_rng(2)
    u, v = rng.random(40), rng.random(40)
    np.testing.assert_allclose(bez.derivatives(u, v, 3), patch.derivatives(u, v, 3), atol=1e-12)
    del u0, u1


def test_bicubic_to_bezier_is_exact(bicubic):
    patch = CoonsPatch(*boundaries(bicubic), **cross_derivatives(bicubic))
    np.testing.assert_allclose(patch.to_bezier().points, bicubic.points, atol=1e-13)


def test_to_bezier_refuses_non_polynomial_data():
    with pytest.raises(GshadeError, match="polynomial Bézier"):
        CoonsPatch(*curved_boundaries()).to_bezier()


def test_incompatible_corner_is_named():
    v0, v1, u0, u1 = curved_boundaries()
    moved = BezierCurve(u1.points + np.array([0, 0, 0.01]), domain=u1.domain)
    with pytest.raises(GshadeError, match=r"incompatible corner \(u=1, v=0\): the point"):
        CoonsPatch(v0, v1, u0, moved)


def test_incompatible_twist_is_named(bicubic):
    cross = cross_derivatives(bicubic)
    bent = cross["cross_v0"].points.copy()
    bent[1] += 0.5  # changes the twist at u = 0 but not p_v there
    cross["cross_v0"] = BezierCurve(bent)
    with pytest.raises(GshadeError, match="twist"):
        CoonsPatch(*boundaries(bicubic), **cross)


def test_partial_cross_data_is_rejected(bicubic):
    cross = cross_derivatives(bicubic)
    del cross["cross_u1"]
    with pytest.raises(GshadeError, match="missing cross_u1"):
        CoonsPatch(*boundaries(bicubic), **cross)
