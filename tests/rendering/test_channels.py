"""The exact channels' assembly: from synthetic picture and centre-pass films, an atlas,
patches and a view, every channel comes out at the right pixel with the patch's own values."""

import numpy as np
import pytest

from gshade.errors import GshadeError
from gshade.geometry import BezierPatch
from gshade.rendering.atlas import Atlas
from gshade.rendering.camera import View
from gshade.rendering.channels import centre_hits, exact_channels, refuse_non_finite
from gshade.rendering.integrator import SHAPE_FILM
from gshade.rendering.rendered_image import CHANNELS
from gshade.shape import get_shape_function

H, W = 30, 44  # not square: rows and columns must not be swapped


def patches():
    """Two bicubic patches side by side over [0, 1] x [0, 1] and [1, 2] x [0, 1] (x = u +
    offset, y = v exactly), curved in z; the second on the domain [2, 4] x [-1, 0]."""
    rng = np.random.default_rng(11)
    out = []
    for k, domain in enumerate((((0.0, 1.0), (0.0, 1.0)), ((2.0, 4.0), (-1.0, 0.0)))):
        net = np.zeros((4, 4, 3))
        net[..., 0] = np.linspace(0, 1, 4)[:, None] + k
        net[..., 1] = np.linspace(0, 1, 4)[None, :]
        net[..., 2] = rng.normal(scale=0.3, size=(4, 4))
        out.append(BezierPatch(net, domain=domain))
    return out


def view():
    """Looking straight down -z at the two patches, a little wider than they are."""
    return View(
        "orthographic",
        np.array([1.0, 0.5, 5.0]),
        np.array([1.0, 0.5, 0.0]),
        np.array([0.0, 1.0, 0.0]),
        45.0,
        2.4,
        W,
        H,
    )


def films(atlas, surfaces, camera):
    """The picture's and the centre pass's films, and what each pixel should get: the patch
    hit by the ray through the pixel centre, its normalised parameters (exact: x = s + k,
    y = t)."""
    rng = np.random.default_rng(12)
    rows, cols = np.divmod(np.arange(H * W), W)
    origin, _ = camera.pixel_rays(rows, cols)
    x, y = origin[:, 0], origin[:, 1]
    k = np.where(x < 1.0, 0, 1)
    s, t = x - k, y
    hit = (x > 0.0) & (x < 2.0) & (y > 0.0) & (y < 1.0)
    hit[rng.random(H * W) < 0.1] = False  # some pixels the centre pass missed
    image = np.zeros((H, W, len(SHAPE_FILM)), np.float32)
    coverage = rng.choice([0.0, 0.25, 1.0], (H, W))
    for c in "RGB":
        image[..., SHAPE_FILM.index(c)] = rng.random((H, W)) * coverage
    image[..., SHAPE_FILM.index("A")] = coverage
    f_mean = rng.normal(size=(H, W))
    image[..., SHAPE_FILM.index("f")] = f_mean * coverage  # the film sums f over samples
    data = np.zeros((H, W, len(SHAPE_FILM)), np.float32)
    # the centre pass's start: within float32 round-off of the exact parameters
    start = np.clip(np.stack([s, t], -1) + rng.uniform(-1e-6, 1e-6, (H * W, 2)), 0, 1)
    xy = atlas.texcoords(k, start)
    for name, values in (("x", xy[:, 0]), ("y", xy[:, 1]), ("A", hit)):
        data[..., SHAPE_FILM.index(name)] = np.where(hit, values, 0.0).reshape(H, W)
    return image, data, hit.reshape(H, W), k.reshape(H, W), s.reshape(H, W), t.reshape(H, W)


def test_every_channel_at_its_pixel():
    surfaces, camera = patches(), view()
    atlas = Atlas.for_patches(2, 9)
    image, data, hit, k, s, t = films(atlas, surfaces, camera)
    film = image.copy()
    for c in ("x", "y"):  # the centre pass's coordinates beside the samples' picture
        film[..., SHAPE_FILM.index(c)] = data[..., SHAPE_FILM.index(c)]
    heights = (get_shape_function("planar_sections"), {"direction": (0.0, 0.0, 1.0)})
    slope = (get_shape_function("mean"), {})
    functions = {"f": heights, "f2": slope}
    out = exact_channels(
        film, data[..., SHAPE_FILM.index("A")] > 0.5, atlas, surfaces, camera, functions
    )
    assert list(out) == [*CHANNELS, "f2"]
    assert all(a.shape == (H, W) and a.dtype == np.float32 for a in out.values())
    A = image[..., SHAPE_FILM.index("A")]
    for c in "RGBA":
        np.testing.assert_array_equal(out[c], image[..., SHAPE_FILM.index(c)])
    f_sum = image[..., SHAPE_FILM.index("f")].astype(np.float64)
    covered = A > 0
    np.testing.assert_allclose(out["f.mean"][covered], f_sum[covered] / A[covered], rtol=1e-6)
    assert np.all(out["f.mean"][~covered] == 0)
    # pixels the centre pass missed: no surface data, unless the pixel is fully covered and its
    # centre ray meets a surface (it slipped through): then its exact hit, from a neighbour's
    rows, cols = np.divmod(np.arange(H * W), W)
    x, y = camera.pixel_rays(rows, cols)[0][:, :2].T
    on_surface = ((x > 0.0) & (x < 2.0) & (y > 0.0) & (y < 1.0)).reshape(H, W)
    recovered = ~hit & (A >= 1) & on_surface
    assert recovered.any()
    missed = ~hit & ~recovered
    np.testing.assert_array_equal(out["patch"][missed], -1.0)
    for c in ("P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z", "u", "v"):
        assert not out[c][missed].any(), c
    # hits: the patch, its own parameters, point and unit normal there
    exact = hit | recovered
    np.testing.assert_array_equal(out["patch"][exact], k[exact])
    assert set(np.unique(k[hit])) == {0, 1}
    for index, patch in enumerate(surfaces):
        at = exact & (k == index)
        (u0, u1), (v0, v1) = patch.domain
        u, v = u0 + (u1 - u0) * s[at], v0 + (v1 - v0) * t[at]
        np.testing.assert_allclose(out["u"][at], u, atol=1e-6 * (u1 - u0))
        np.testing.assert_allclose(out["v"][at], v, atol=1e-6 * (v1 - v0))
        d = patch.derivatives(u, v, 1)
        P = np.stack([out[f"P.{c}"][at] for c in "XYZ"], -1)
        np.testing.assert_allclose(P, d[0, 0], atol=1e-6)
        n = np.cross(d[1, 0], d[0, 1])
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        N = np.stack([out[f"N.{c}"][at] for c in "XYZ"], -1)
        np.testing.assert_allclose(N, n, atol=1e-6)
        # the functions at the same hit: f the height <P, z>, f2 H of the patch there
        np.testing.assert_allclose(out["f"][at], P[:, 2], atol=1e-6)
        d2 = patch.derivatives(u, v, 2)
        pu, pv = d2[1, 0], d2[0, 1]
        E, F, G = (np.sum(a * b, -1) for a, b in ((pu, pu), (pu, pv), (pv, pv)))
        L, M, Nn = (np.sum(d2[i, j] * n, -1) for i, j in ((2, 0), (1, 1), (0, 2)))
        mean = (E * Nn - 2 * F * M + G * L) / (2 * (E * G - F * F))
        np.testing.assert_allclose(out["f2"][at], mean, atol=1e-5 * max(1.0, np.abs(mean).max()))
    assert not out["f"][missed].any() and not out["f2"][missed].any()


def test_centre_hits_found_apart_give_the_same_channels():
    """The pipeline finds the centre hits while the supersampling pass writes the picture's
    channels: they read only the centre pass's coordinates, and the channels made from them
    are those of one call on the finished film."""
    surfaces, camera = patches(), view()
    atlas = Atlas.for_patches(2, 9)
    image, data, centre, *_ = films(atlas, surfaces, camera)
    film = image.copy()
    for c in ("x", "y"):
        film[..., SHAPE_FILM.index(c)] = data[..., SHAPE_FILM.index(c)]
    functions = {"f": (get_shape_function("mean"), {})}
    early = film.copy()  # the picture not yet written: only x and y are read
    for c in ("R", "G", "B", "A", "f"):
        early[..., SHAPE_FILM.index(c)] = np.nan
    hits = centre_hits(early, centre, atlas, surfaces, camera, functions)
    assert hits.pixels.size == int(centre.sum()) and np.isfinite(hits.d).all()
    apart = exact_channels(film, centre, atlas, surfaces, camera, functions, hits)
    whole = exact_channels(film, centre, atlas, surfaces, camera, functions)
    assert list(apart) == list(whole)
    for name in whole:
        np.testing.assert_array_equal(apart[name], whole[name], err_msg=name)


def test_non_finite_channels_are_refused():
    channels = {"f": np.zeros((2, 2), np.float32), "u": np.zeros((2, 2), np.float32)}
    refuse_non_finite("scene", channels)
    channels["u"][0, 1] = np.inf
    with pytest.raises(GshadeError, match=r"scene: the render gave non-finite values \(1 pixels"):
        refuse_non_finite("scene", channels)
