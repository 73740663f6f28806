"""Supersampling where the picture is discontinuous: the pixel-list sensor reproduces a full
render's pixels, silhouettes and jumps are found, thin features are not lost, and a render
that samples edges only agrees with one that samples every pixel."""

import numpy as np
import pytest

import gshade
from gshade.rendering import pipeline
from gshade.rendering.atlas import Atlas
from gshade.rendering.camera import View
from gshade.rendering.integrator import SHAPE_FILM
from gshade.rendering.supersampling import discontinuous_pixels, silhouette_pixels
from gshade.rendering.tessellate import TriangleMesh
from gshade.runtime.variant import find_llvm
from gshade.scene import parse_scene

from ..support.scenes_text import SPHERE

VARIANTS = ["scalar_rgb"] + (["llvm_ad_rgb"] if find_llvm() else [])


def sphere(size: int, spp: int = 16, lighting: str = "lit") -> str:
    return (
        SPHERE.replace("512", str(size))
        .replace("spp = 4", f"spp = {spp}")
        .replace('lighting = "flat"', f'lighting = "{lighting}"')
    )


@pytest.mark.parametrize("variant", VARIANTS)
def test_the_pixel_list_sensor_gives_a_full_renders_pixels(variant, monkeypatch):
    """Every pixel listed (all of them): the same values as sampling every pixel, to float32
    round-off: the same strata, rays and ray differentials (the stripes' footprints)."""
    scene = parse_scene(sphere(40, spp=4))
    uniform = gshade.render(scene, sampling="uniform", variant=variant)
    monkeypatch.setattr(pipeline, "discontinuous_pixels", lambda c, *a: np.ones(c.shape[:2], bool))
    listed = gshade.render(scene, variant=variant)
    for c in ("R", "G", "B", "A", "f.mean"):
        np.testing.assert_allclose(listed[c], uniform[c], atol=2e-5, err_msg=c)
    assert listed["A"].min() == 0 and 0 < listed["A"][20].mean() < 1


def test_edges_only_agree_with_every_pixel_sampled():
    """Stripes, lit, a sphere whose isophotes' extremum lies on a stripe edge: the pictures
    agree to 0.02 everywhere and to 5e-3 on 99 % of the pixels (the rest: stripe edges, where
    16 small linear footprints and one whole-pixel one differ by f's curvature)."""
    scene = parse_scene(sphere(160))
    edges = gshade.render(scene)
    uniform = gshade.render(scene, sampling="uniform")
    diff = np.max([np.abs(edges[c] - uniform[c]) for c in "RGBA"], axis=0)
    assert diff.max() < 0.02, diff.max()
    assert (diff > 5e-3).mean() < 0.01
    assert np.array_equal(edges["P.X"], uniform["P.X"])  # the same centre pass


def test_a_feature_thinner_than_a_pixel_is_not_lost():
    """A strip a third of a pixel wide between pixel centres: no centre ray meets it, yet its
    silhouette edges mark the pixels it crosses, which then cover it as a full render does."""
    strip = """
[[surface]]
type = "bezier"
points = [[[-0.9, 0, -0.02], [-0.9, 0, 0.0]], [[0.9, 0, -0.02], [0.9, 0, 0.0]]]
[shape]
function = "planar_sections"
display = "stripes"
period = 0.5
[camera]
type = "orthographic"
origin = [0, -5, 0]
target = [0, 0, 0]
up = [0, 0, 1]
width = 2.4
[render]
width = 40
height = 40
spp = 16
lighting = "flat"
"""
    # a pixel is 0.06 high: the strip z in [-0.02, 0] lies between the centres at +-0.03
    scene = parse_scene(strip)
    edges = gshade.render(scene)
    uniform = gshade.render(scene, sampling="uniform")
    assert uniform["A"].sum() > 5  # the strip is there, thin
    np.testing.assert_allclose(edges["A"], uniform["A"], atol=1e-6)


def film(H=12, W=16):
    """A centre-pass film of one patch covering everything, f = 0.01 x (column), smooth."""
    c = np.zeros((H, W, len(SHAPE_FILM)), np.float32)
    cols = np.arange(W, dtype=np.float32)[None, :]
    c[..., SHAPE_FILM.index("A")] = 1
    c[..., SHAPE_FILM.index("x")] = 0.1 + 0.8 * cols / W
    c[..., SHAPE_FILM.index("y")] = 0.5
    c[..., SHAPE_FILM.index("flags")] = 1
    c[..., SHAPE_FILM.index("f")] = 0.01 * cols
    c[..., SHAPE_FILM.index("f_x")] = 0.01
    return c


def marked_columns(marked):
    assert np.array_equal(marked, np.broadcast_to(marked[:1], marked.shape)), "not per column"
    return np.flatnonzero(marked[0]).tolist()


ATLAS = Atlas.for_patches(2, 8)  # two tiles side by side: x < 0.5 patch 0, else patch 1
STRIPES = (0.1, 0.0, 0.5)  # period, phase, duty


def test_a_smooth_picture_needs_one_sample():
    c = film()
    c[..., SHAPE_FILM.index("x")] = 0.2  # one patch
    assert not discontinuous_pixels(c, ATLAS, 1e-4, STRIPES).any()
    # colour-mapped, f spans 0.01 a pixel: less than SPREAD = 10 changes of 1e-2
    assert not discontinuous_pixels(c, ATLAS, 1e-2).any()


@pytest.mark.parametrize(
    "change",
    ["miss", "patch", "shadow", "undefined", "f jumps"],
)
def test_each_discontinuity_marks_the_pixels_beside_it(change):
    c = film()
    c[..., SHAPE_FILM.index("x")] = 0.2
    right = (slice(None), slice(9, None))
    if change == "miss":
        c[right] = 0
    elif change == "patch":
        c[..., SHAPE_FILM.index("x")][right] = 0.7
    elif change == "shadow":
        c[..., SHAPE_FILM.index("flags")][right] = 3
    elif change == "undefined":
        c[..., SHAPE_FILM.index("flags")][right] = 0
    else:
        c[..., SHAPE_FILM.index("f")][right] += 0.05
    assert marked_columns(discontinuous_pixels(c, ATLAS, 1e-4, STRIPES)) == [8, 9]


def test_bending_f_needs_samples_near_a_stripe_edge_or_when_colour_mapped():
    c = film()
    c[..., SHAPE_FILM.index("x")] = 0.2
    # f = 0.3 + 0.5 (k - 8)^2 / 100 along the columns, its derivative 0.01 (k - 8): a minimum
    k = np.arange(16, dtype=np.float32)
    c[..., SHAPE_FILM.index("f")] = 0.3 + 0.5 * (k - 8) ** 2 / 100
    c[..., SHAPE_FILM.index("f_x")] = 0.01 * (k - 8)
    # the minimum just below a stripe edge (period 1, edges at 0 and 0.305): the stripe's tip
    tip = discontinuous_pixels(c, ATLAS, 1e-3, (1.0, 0.0, 0.305))
    assert 8 in marked_columns(tip)
    # far from any edge, a stripe hides the bending
    assert not discontinuous_pixels(c, ATLAS, 1e-3, (1.0, 0.0, 0.9)).any()
    # colour-mapped: f spans 0.01 |k - 8| over a pixel, more than SPREAD = 10 visible changes
    # of 1e-3 away from the minimum
    assert marked_columns(discontinuous_pixels(c, ATLAS, 1e-3)) == [*range(7), *range(10, 16)]


def test_silhouettes_of_a_closed_mesh_are_its_outline():
    """A tessellated sphere seen from afar: the marked pixels lie along its projected outline
    (within two pixels), all around it, and not inside."""
    scene = parse_scene(sphere(64))
    from gshade.rendering.sizing import frame
    from gshade.rendering.tessellate import tessellate

    framing = frame(scene, scene.render, "test")
    mesh = tessellate(scene.patches, 40)
    view = framing.view
    marked = silhouette_pixels(mesh, view)
    rows, cols = np.nonzero(marked)
    origin, _ = view.pixel_rays(rows, cols)
    # orthographic along y: the outline is the unit circle in x, z
    r = np.hypot(origin[:, 0], origin[:, 2])
    pixel = view.pixel_size(5.0)
    assert np.abs(r - 1.0).max() < 2.5 * pixel  # the pixels it crosses and their neighbours
    angles = np.arctan2(origin[:, 2], origin[:, 0])
    assert np.histogram(angles, bins=36, range=(-np.pi, np.pi))[0].min() > 0


def test_silhouettes_are_found_behind_a_perspective_eye_too():
    """A quad that reaches behind the eye: its edges in front are rasterised; nothing
    breaks."""
    view = View(
        "perspective",
        np.array([0.0, 0.0, 0.0]),
        np.array([0.0, 1.0, 0.0]),
        np.array([0.0, 0.0, 1.0]),
        60.0,
        None,
        32,
        24,
    )
    positions = np.array([[-1.0, -5, -0.5], [1, -5, -0.5], [1, 5, -0.5], [-1, 5, -0.5]])
    mesh = TriangleMesh(
        positions,
        np.tile([0.0, 0.0, 1.0], (4, 1)),
        np.zeros((4, 2)),
        np.zeros(4, np.int32),
        np.array([[0, 1, 2], [0, 2, 3]], np.int32),
        2,
    )
    marked = silhouette_pixels(mesh, view)
    assert marked.any() and not marked.all()
    assert marked[:, 0].any() and marked[:, -1].any()  # the side edges leave at the sides
    assert marked[14].any() and not marked[:10].any()  # the far edge, below the horizon
