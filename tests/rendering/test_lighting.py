"""``lit`` lighting: deterministic (no random numbers in the shading), the same in every
variant, and Lambertian: c · (AMBIENT + HEAD · max(n·v, 0) + KEY · V · max(n·l, 0))."""

import numpy as np
import pytest

import gshade
from gshade.regression.comparison import Thresholds, compare
from gshade.rendering.camera import View
from gshade.rendering.integrator import AMBIENT, HEAD, KEY
from gshade.runtime.variant import find_llvm
from gshade.scene import parse_scene

# a unit sphere seen along +y, orthographic: the view direction is the same in every pixel
SPHERE = """
[[surface]]
type = "sphere"
radius = 1.0
[shape]
function = "isophotes"
light = [0, -1, 0]
period = 0.125
[camera]
type = "orthographic"
origin = [0, -5, 0]
target = [0, 0, 0]
up = [0, 0, 1]
width = 2.2
[render]
width = 64
height = 48
spp = 1
lighting = "lit"
"""
VIEW = View(
    "orthographic",
    np.array([0.0, -5.0, 0.0]),
    np.zeros(3),
    np.array([0.0, 0.0, 1.0]),
    30.0,
    2.2,
    64,
    48,
)


def interior(A, margin=2):
    """Pixels fully covered, with their neighbours (away from the silhouette)."""
    ok = A == 1.0
    for axis in (0, 1):
        for shift in range(1, margin + 1):
            ok &= np.roll(A, shift, axis) == 1.0
            ok &= np.roll(A, -shift, axis) == 1.0
    return ok


def rgb(image):
    return np.stack([image["R"], image["G"], image["B"]], axis=-1)


@pytest.fixture(scope="module")
def scene():
    return parse_scene(SPHERE)


@pytest.fixture(scope="module")
def lit(scene):
    return gshade.render(scene, variant="llvm_ad_rgb" if find_llvm() else "scalar_rgb")


def test_lit_has_no_random_shading(scene, lit):
    """Another seed changes nothing: no sampler numbers in the lit shading (and the samples
    lie at the strata centres; only the order in which a pixel sums them may change, by an
    ulp)."""
    other = gshade.render(scene, seed=12345, spp=4)
    again = gshade.render(scene, seed=0, spp=4)
    inside = interior(lit["A"])
    assert inside.sum() > 1000
    assert np.abs(rgb(other) - rgb(again))[inside].max() <= 1e-6


def test_soft_light_is_the_sampled_option(scene):
    """``soft`` keeps the sampled sky: it changes with the seed."""
    a = gshade.render(scene, lighting="soft", seed=1, spp=2)
    b = gshade.render(scene, lighting="soft", seed=2, spp=2)
    inside = interior(a["A"])
    assert not np.array_equal(rgb(a)[inside], rgb(b)[inside])


def test_lit_is_lambertian_under_head_and_key_light(scene, lit):
    """lit / flat (same samples: the pixel centres) is AMBIENT + HEAD n·v + KEY max(n·l, 0)
    with the exact normal; where the key light does not reach, it grows with n·v."""
    flat = gshade.render(scene, lighting="flat", variant=lit.metadata["variant"])
    inside = interior(lit["A"])
    assert np.all(flat["R"][inside] > 0)
    factor = lit["R"][inside] / flat["R"][inside]
    n = np.stack([lit["N.X"], lit["N.Y"], lit["N.Z"]], axis=-1)[inside]
    v = -VIEW.forward
    n_v = n @ v
    n = n * np.sign(n_v)[:, None]  # two-sided: the normal towards the viewer
    n_v = np.abs(n_v)
    n_l = n @ np.array(VIEW.key_light())
    expected = AMBIENT + HEAD * n_v + KEY * np.maximum(n_l, 0.0)
    away_from_terminator = np.abs(n_l) > 0.1  # the mesh may shadow itself at grazing light
    assert away_from_terminator.sum() > 500
    err = np.abs(factor - expected)[away_from_terminator]
    assert err.max() < 0.02, err.max()
    unlit = n_l < -0.1
    assert unlit.sum() > 100
    # monotone in n·v (the shading uses the mesh's interpolated normal: allow its noise)
    order = np.argsort(n_v[unlit])
    assert np.all(np.diff(factor[unlit][order]) > -0.005)
    bins = np.array_split(factor[unlit][order], 6)
    assert np.all(np.diff([b.mean() for b in bins]) > 0)
    assert factor[unlit].max() - factor[unlit].min() > 0.1  # and really shaded


@pytest.mark.skipif(find_llvm() is None, reason="llvm_ad_rgb needs libLLVM >= 17")
def test_lit_agrees_across_variants(scene, lit):
    """scalar_rgb and llvm_ad_rgb agree within 0.02 on >= 99.95 % of the pixels, as flat
    renders do (gshade check's default thresholds)."""
    scalar = gshade.render(scene, variant="scalar_rgb")
    assert scalar.metadata["variant"] == "scalar_rgb"
    assert lit.metadata["variant"] == "llvm_ad_rgb"
    result = compare(scalar, lit, channels=["R", "G", "B", "A"], thresholds=Thresholds(fail=0.02))
    assert result.failing_percent <= 0.05, result
