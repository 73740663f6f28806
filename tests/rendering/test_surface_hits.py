"""Exact ray–surface hits: the Dr.Jit kernel for Bézier patches and the numpy path agree,
and both land on the known surface point."""

import numpy as np
import pytest

from gshade.geometry import BezierPatch, sphere
from gshade.io import read_newell
from gshade.rendering.surface_hits import patch_evaluator, surface_hits
from gshade.shape.kernels import backend

from ..support.paths import TEAPOT


def aimed_rays(patches, rng, n=4000):
    """Rays through known surface points p(u*, v*) from random directions, and starting
    parameters about 1e-6 away from (u*, v*), as close as the render's centre pass gets."""
    index = rng.integers(0, len(patches), n)
    s = rng.uniform(0.05, 0.95, (n, 2))
    u_true, v_true, points = np.empty(n), np.empty(n), np.empty((n, 3))
    normals = np.empty((n, 3))
    for k in np.unique(index):
        at = index == k
        (u0, u1), (v0, v1) = patches[k].domain
        u_true[at] = u0 + (u1 - u0) * s[at, 0]
        v_true[at] = v0 + (v1 - v0) * s[at, 1]
        d = patches[k].derivatives(u_true[at], v_true[at], 1)
        points[at] = d[0, 0]
        normals[at] = np.cross(d[1, 0], d[0, 1])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    # well-conditioned (not grazing) rays: at least ~60 degrees from the tangent plane
    direction = -normals + 0.5 * rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    origin = points - 7.0 * direction
    u = u_true + 1e-6 * rng.normal(size=n)
    v = v_true + 1e-6 * rng.normal(size=n)
    for k in np.unique(index):  # keep the starts inside the domains
        at = index == k
        (u0, u1), (v0, v1) = patches[k].domain
        u[at], v[at] = np.clip(u[at], u0, u1), np.clip(v[at], v0, v1)
    return index, u, v, origin, direction, u_true, v_true, points


@pytest.mark.parametrize("name", ["drjit", "numpy"])
def test_one_step_lands_on_the_surface_point(name):
    if name == "drjit" and backend() != "drjit":
        pytest.skip("no usable libLLVM here")
    patches = read_newell(TEAPOT)
    rng = np.random.default_rng(3)
    index, u, v, origin, direction, u_true, v_true, points = aimed_rays(patches, rng)
    uu, vv, d, settled = surface_hits(patches, index, u, v, origin, direction, name)
    assert settled.mean() > 0.999
    # a ray may cross the surface twice: compare where the step settled on the aimed point
    near = settled & (np.linalg.norm(d[0, 0] - points, axis=1) < 1e-6)
    assert near.mean() > 0.99
    # the point itself to round-off; the parameters too, except where the parametrisation
    # is nearly singular (the teapot's collapsed edges), where they are ill-conditioned
    error = np.linalg.norm(d[0, 0][near] - points[near], axis=1)
    assert np.median(error) < 1e-11 and np.quantile(error, 0.995) < 1e-10
    exact = (np.abs(uu - u_true) < 1e-10) & (np.abs(vv - v_true) < 1e-10)
    assert exact[near].mean() > 0.995
    for k in np.unique(index):  # the derivatives are the patch's own at the result
        at = index == k
        np.testing.assert_allclose(
            d[:, :, at], patches[k].derivatives(uu[at], vv[at], 1)[:2, :2], atol=1e-12
        )


def test_the_kernel_and_numpy_agree_and_misses_keep_their_start():
    if backend() != "drjit":
        pytest.skip("no usable libLLVM here")
    rng = np.random.default_rng(4)
    P = np.zeros((4, 5, 3))
    P[..., 0] = np.arange(4)[:, None]
    P[..., 1] = np.arange(5)[None, :]
    P[..., 2] = rng.normal(scale=0.4, size=(4, 5))
    patches = [
        BezierPatch(P, domain=((0.0, 2.0), (1.0, 1.5))),  # degree (3, 4), a scaled domain
        BezierPatch(P[:, ::-1] + [0, 0, 1]),
        sphere(1.5),  # rational: always through numpy
    ]
    index, u, v, origin, direction, *_ = aimed_rays(patches, rng, 3000)
    origin = origin.copy()
    origin[:50] += 100.0 * np.cross(direction[:50], [0.3, 0.5, 0.8])  # these miss
    a = surface_hits(patches, index, u, v, origin, direction, "drjit")
    b = surface_hits(patches, index, u, v, origin, direction, "numpy")
    np.testing.assert_array_equal(a[3], b[3])
    assert not a[3][:50].any() and a[3][50:].mean() > 0.99
    for x, y in zip(a[:3], b[:3], strict=True):
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(a[0][:50], u[:50])  # missed: the start values


def test_the_newton_step_is_exact_on_a_plane_for_every_array_library():
    """p(u, v) = q + u a + v b: one step from anywhere reaches the ray's point, with the
    numpy operations and Dr.Jit's (fused and written-out products)."""
    from gshade.rendering.newton import newton_step, ray_residual
    from gshade.runtime.backend import NUMPY, drjit_ops

    rng = np.random.default_rng(5)
    n = 200
    q, a, b = np.array([0.3, -1.0, 2.0]), np.array([1.0, 0.2, 0.1]), np.array([-0.3, 1.0, 0.4])
    u_true, v_true = rng.uniform(-1, 1, (2, n))
    point = q + u_true[:, None] * a + v_true[:, None] * b
    direction = rng.normal(size=(n, 3)) + np.cross(a, b)
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    origin = point - 3.0 * direction
    u, v = u_true + rng.normal(size=n), v_true + rng.normal(size=n)
    p = q + u[:, None] * a + v[:, None] * b
    pu, pv = np.broadcast_to(a, (n, 3)), np.broadcast_to(b, (n, 3))
    t, r = ray_residual(p, origin, direction, NUMPY)
    du, dv, dt, ok = newton_step(pu, pv, direction, r, NUMPY, 1e-300)
    assert ok.all()
    # grazing rays (d in the tangent plane) take no step
    graze = newton_step(pu, pv, np.broadcast_to(a, (n, 3)), r, NUMPY, 1e-300)
    assert not graze[3].any() and not graze[0].any() and not graze[1].any()
    np.testing.assert_allclose(u + du, u_true, atol=1e-12)
    np.testing.assert_allclose(v + dv, v_true, atol=1e-12)
    np.testing.assert_allclose(t + dt, 3.0, atol=1e-12)
    if backend() != "drjit":
        return
    from drjit.llvm import Array3f64

    def vec(x):
        return Array3f64(*(np.ascontiguousarray(x[:, c]) for c in range(3)))

    for fused in (True, False):
        ops = drjit_ops(fused=fused)
        t, r = ray_residual(vec(p), vec(origin), vec(direction), ops)
        du, dv, dt, ok = newton_step(vec(pu), vec(pv), vec(direction), r, ops, 1e-300)
        assert np.array(ok).all()
        np.testing.assert_allclose(u + np.array(du), u_true, atol=1e-12)
        np.testing.assert_allclose(v + np.array(dv), v_true, atol=1e-12)
        np.testing.assert_allclose(np.array(t + dt), 3.0, atol=1e-12)


def test_an_evaluator_kept_across_calls_gives_the_same_hits():
    """The evaluator built once (as the render's blocks of hits share it) is the one the
    step evaluates with: the same hits as one built per call, and another set of patches'
    evaluator lands elsewhere."""
    patches = read_newell(TEAPOT)
    rng = np.random.default_rng(5)
    index, u, v, origin, direction, *_ = aimed_rays(patches, rng, n=500)
    kept = patch_evaluator(patches)
    alone = surface_hits(patches, index, u, v, origin, direction)
    shared = surface_hits(patches, index, u, v, origin, direction, evaluator=kept)
    for a, b in zip(alone, shared, strict=True):
        np.testing.assert_array_equal(a, b)
    moved = [BezierPatch(p.points + 1.0) for p in patches]
    other = surface_hits(patches, index, u, v, origin, direction, evaluator=patch_evaluator(moved))
    assert not np.allclose(other[2][0, 0], alone[2][0, 0])
