"""Many B-splines' Bézier cells (gshade.geometry.evaluation.bezier_cells.Splines) give each
patch's own points and first derivatives at its knots, an ulp either side of them and past its ends,
with the knot lines C0 (a point's cell is the knot interval it lies in, as the patch's own
span search finds it, however many splines share the table's search)."""

import numpy as np

from gshade.geometry import BSplinePatch
from gshade.geometry.evaluation.bezier_cells import Splines


def test_cells_equal_each_patch_own_derivatives_beside_its_knots():
    rng = np.random.default_rng(4)
    splines, patches = Splines(), []
    for k in range(300):  # spline k's search keys lie near k: coarse for the last ones
        lo = rng.uniform(-3, 3)
        U = [lo] * 3 + [lo + 0.3, lo + 0.3, lo + 1.7] + [lo + 2] * 3  # a C0 knot at lo + 0.3
        V = [0, 0, 0, 0.6, 0.6, 1, 1, 1]
        patch = BSplinePatch(rng.normal(size=(6, 5, 3)), (2, 2), (U, V), rng.uniform(1, 2, (6, 5)))
        patches.append(patch)
        assert splines.add_patch(patch) == k
    splines.freeze()
    which, u, v = [], [], []
    for k, patch in enumerate(patches[-20:], start=len(patches) - 20):
        ku, kv = (np.unique(knots) for knots in patch.knots)
        uu = np.concatenate([ku, np.nextafter(ku, -np.inf), np.nextafter(ku, np.inf)])
        uu = np.concatenate([uu, rng.uniform(ku[0] - 0.1, ku[-1] + 0.1, 20)])
        vv = rng.choice(
            np.concatenate([kv, np.nextafter(kv, -np.inf), np.nextafter(kv, np.inf)]), uu.size
        )
        which.append(np.full(uu.size, k))
        u.append(uu)
        v.append(vv)
    which, u, v = np.concatenate(which), np.concatenate(u), np.concatenate(v)
    s, s_u, s_v = splines.evaluate(which, u, v)
    for k in np.unique(which):
        at = which == k
        d = patches[k].derivatives_beyond(u[at], v[at], 1)
        scale = np.abs(d).max()
        for got, want in ((s, d[0, 0]), (s_u, d[1, 0]), (s_v, d[0, 1])):
            np.testing.assert_allclose(got[at], want, rtol=0, atol=1e-10 * scale)


def test_one_clamped_span_is_its_own_cell():
    """A B-spline of one clamped knot span is a Bézier curve (patch) over it: its cell is its
    net, exactly, and the table evaluates it (and past its ends) as the patch does."""
    from gshade.geometry.evaluation.bezier_cells import to_bezier

    rng = np.random.default_rng(11)
    for p in range(1, 6):
        net = rng.normal(size=(p + 1, 4))
        breaks, cells = to_bezier(np.array([-1.5] * (p + 1) + [2.0] * (p + 1)), p, net)
        assert np.array_equal(breaks, [-1.5, 2.0]) and np.array_equal(cells[0], net)
    splines, patches = Splines(), []
    for rational in (False, True):
        for p, q in ((1, 1), (2, 1), (3, 3)):
            a, c = rng.uniform(-3, 3, 2)
            knots = ([a] * (p + 1) + [a + 0.7] * (p + 1), [c] * (q + 1) + [c + 2.5] * (q + 1))
            w = rng.uniform(0.5, 2.0, (p + 1, q + 1)) if rational else None
            patch = BSplinePatch(rng.normal(size=(p + 1, q + 1, 3)), (p, q), knots, w)
            splines.add_patch(patch)
            patches.append(patch)
    splines.freeze()
    for k, patch in enumerate(patches):
        (u0, u1), (v0, v1) = patch.domain
        u = rng.uniform(u0 - 0.2, u1 + 0.2, 50)  # inside and past the ends
        v = rng.uniform(v0 - 0.2, v1 + 0.2, 50)
        s, s_u, s_v = splines.evaluate(np.full(50, k), u, v)
        d = patch.derivatives_beyond(u, v, 1)
        scale = np.abs(d).max()
        for got, want in ((s, d[0, 0]), (s_u, d[1, 0]), (s_v, d[0, 1])):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * scale)
