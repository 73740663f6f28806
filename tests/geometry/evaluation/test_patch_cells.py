"""Bézier cells in one Dr.Jit kernel (gshade.geometry.evaluation.patch_cells) give each patch's own
points and first derivatives, on knot lines, at the domain's ends and past them."""

import numpy as np
import pytest

from gshade.geometry import BezierPatch, BSplinePatch
from gshade.geometry.evaluation.patch_cells import PatchCells, cell_groups
from gshade.shape.kernels import backend

pytestmark = pytest.mark.skipif(backend() != "drjit", reason="no usable libLLVM here")


def _patches(rng, rational: bool):
    """Patches of degree (3, 2): two B-splines (a double and a triple knot: C1 and C0
    knot lines, a long and a shifted domain) and a Bézier patch."""

    def weights(shape):
        return rng.uniform(0.5, 2.0, shape) if rational else None

    U = [0, 0, 0, 0, 0.3, 0.3, 0.7, 1, 1, 1, 1]
    V = [2, 2, 2, 2.5, 2.5, 3, 3, 3]
    a = BSplinePatch(rng.normal(size=(7, 5, 3)), (3, 2), (U, V), weights((7, 5)))
    U2 = [0, 0, 0, 0, 10, 10, 10, 20, 20, 20, 20]
    b = BSplinePatch(rng.normal(size=(7, 3, 3)), (3, 2), (U2, [0, 0, 0, 1, 1, 1]), weights((7, 3)))
    c = BezierPatch(rng.normal(size=(4, 3, 3)), weights((4, 3)), domain=((-1, 0.5), (4, 6)))
    return [a, b, c]


@pytest.mark.parametrize("order", [0, 1, 2, 3])
@pytest.mark.parametrize("rational", [False, True])
def test_cells_equal_each_patch_own_derivatives(rational, order):
    rng = np.random.default_rng(11 + rational)
    patches = _patches(rng, rational)
    cells = PatchCells(patches)
    member, u, v = [], [], []
    for k, p in enumerate(patches):
        (u0, u1), (v0, v1) = p.domain
        knots_u = np.unique(p.knots[0]) if isinstance(p, BSplinePatch) else np.array([u0, u1])
        knots_v = np.unique(p.knots[1]) if isinstance(p, BSplinePatch) else np.array([v0, v1])
        uu = np.concatenate([rng.uniform(u0, u1, 300), knots_u, np.repeat(u0, 3)])
        vv = np.concatenate(
            [rng.uniform(v0, v1, 300), rng.choice(knots_v, knots_u.size), [v0, v1, 0.5 * (v0 + v1)]]
        )
        member.append(np.full(uu.size, k))
        u.append(uu)
        v.append(vv)
    member, u, v = np.concatenate(member), np.concatenate(u), np.concatenate(v)
    d = cells.derivatives(member, u, v, order)
    assert d.shape == (order + 1, order + 1, u.size, 3)
    for k, p in enumerate(patches):
        at = member == k
        expected = p.derivatives(u[at], v[at], order)
        scale = np.abs(expected).max()
        np.testing.assert_allclose(d[:, :, at], expected, rtol=0, atol=1e-11 * scale)


def test_groups_by_degree_and_kind():
    rng = np.random.default_rng(5)
    a, b, c = _patches(rng, False)
    r = _patches(rng, True)[0]
    other = BezierPatch(rng.normal(size=(2, 2, 3)))
    groups, others = cell_groups([a, r, b, other, c, object()])
    assert groups == {((3, 2), False): [0, 2, 4], ((3, 2), True): [1], ((1, 1), False): [3]}
    assert others == [5]
    with pytest.raises(ValueError):
        PatchCells([a, r])
    # a patch of more knot intervals than a table holds goes by numpy
    knots = np.concatenate([[0.0], np.linspace(0.0, 1.0, 150), [1.0]])
    fine = BSplinePatch(rng.normal(size=(150, 150, 3)), (1, 1), (knots, knots))
    assert cell_groups([fine, a]) == ({((3, 2), False): [1]}, [0])


def test_many_patches_equal_each_patch_own_derivatives_with_and_without_drjit():
    """Points on patches of two degrees, rational and not, a sphere (rational B-spline
    with collapsed edges) and a patch of another kind (Coons, by numpy), shuffled."""
    from gshade.geometry import BezierCurve, CoonsPatch, sphere
    from gshade.geometry.evaluation.patch_cells import ManyPatches

    rng = np.random.default_rng(8)
    bezier = BezierPatch(rng.normal(size=(3, 4, 3)))
    net = rng.normal(size=(4, 4, 3))  # a Coons patch of a Bézier net's boundary
    coons = CoonsPatch(
        BezierCurve(net[:, 0]), BezierCurve(net[:, -1]), BezierCurve(net[0]), BezierCurve(net[-1])
    )
    patches = [*_patches(rng, False), *_patches(rng, True), sphere(2.0), bezier, coons]
    index = rng.integers(0, len(patches), 3000)
    dom = np.array([p.domain for p in patches])[index]
    u = dom[:, 0, 0] + rng.random(index.size) * (dom[:, 0, 1] - dom[:, 0, 0])
    v = dom[:, 1, 0] + rng.random(index.size) * (dom[:, 1, 1] - dom[:, 1, 0])
    many = ManyPatches(patches, drjit=True)
    assert len(many.groups) == 4 and list(many.group[-2:]) == [many.group[-2], -1]  # Coons
    a = many.derivatives(index, u, v, 2)
    b = ManyPatches(patches, drjit=False).derivatives(index, u, v, 2)
    for k, p in enumerate(patches):
        at = index == k
        expected = p.derivatives(u[at], v[at], 2)
        scale = np.abs(expected).max()
        np.testing.assert_allclose(a[:, :, at], expected, rtol=0, atol=1e-11 * scale)
        np.testing.assert_allclose(b[:, :, at], expected, rtol=0, atol=1e-11 * scale)
