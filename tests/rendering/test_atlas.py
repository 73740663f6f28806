"""The atlas layout, written once: textures with known values per texel read back at given
(patch, s, t) through the numpy lookup and through the integrators' Dr.Jit lookup.

The expected texels are written here from the documented layout (patch k's tile at texel
column (k mod cols) T and row (k div cols) T, texel centres on s_i = i / (T - 1)), not with
gshade's own addressing, so that a change of the layout in any one place goes red."""

import numpy as np
import pytest

from gshade.geometry import BezierPatch
from gshade.rendering.atlas import BLOCK, GEOMETRY, SHAPE, Atlas, Packing
from gshade.rendering.textures import ShapeTextures, shape_textures
from gshade.shape import get_shape_function

TILE, PATCHES = 6, 5  # 3 x 2 tiles of 6 x 6 texels; the last tile of the grid is unused
COLS = 3


def texel_parameters(atlas):
    """Patch index, s and t of every texel (H, W) by the documented layout: texel (r, c) is
    patch k's where row0_k <= r < row0_k + T_k and col0_k <= c < col0_k + S_k, at
    s = (c - col0_k) / (S_k - 1), t = (r - row0_k) / (T_k - 1); k = PATCHES in the gaps."""
    rows, cols = np.mgrid[0 : atlas.height, 0 : atlas.width]
    k = np.full(rows.shape, PATCHES)
    s = np.zeros(rows.shape)
    t = np.zeros(rows.shape)
    for i, (r0, c0, (S, T)) in enumerate(zip(atlas.row0, atlas.col0, atlas.sizes, strict=True)):
        mine = (rows >= r0) & (rows < r0 + T) & (cols >= c0) & (cols < c0 + S)
        assert (k[mine] == PATCHES).all()  # no two tiles overlap
        k[mine] = i
        s[mine] = (cols[mine] - c0) / (S - 1)
        t[mine] = (rows[mine] - r0) / (T - 1)
    return k, s, t


def f_of(k, s, t):
    """A bicubic (here bilinear) function per patch, reproduced exactly by Hermite data."""
    return 10.0 * k + 3.0 * s - 2.0 * t + 1.5 * s * t


def p_of(k, s, t):
    """A plane per patch (so that one Newton step onto it is exact)."""
    return np.stack([k + s, 2.0 * k + t, 0.5 * s + 0.25 * t], -1)


def known_textures(atlas):
    k, s, t = texel_parameters(atlas)
    values = np.stack([f_of(k, s, t), 3.0 + 1.5 * t, -2.0 + 1.5 * s], -1)
    valid = (k != 1).astype(np.float32)  # f undefined on patch 1
    p = p_of(k, s, t)
    p_s = np.broadcast_to([1.0, 0.0, 0.5], p.shape)
    p_t = np.broadcast_to([0.0, 1.0, 0.25], p.shape)
    f32 = np.float32
    return ShapeTextures(
        atlas,
        [values.astype(f32)],
        [np.full(k.shape, 1.5, f32)],
        [valid],
        p.astype(f32),
        p_s.astype(f32),
        p_t.astype(f32),
        np.zeros(p.shape, f32),
    )


def sample_points(rng, n=400):
    """(patch, s, t), tile borders and corners included."""
    k = rng.integers(0, PATCHES, n)
    st = rng.uniform(0.0, 1.0, (n, 2))
    st[: n // 4] = rng.choice([0.0, 1.0], (n // 4, 2))  # corners
    st[n // 4 : n // 2, 0] = rng.choice([0.0, 1.0], n // 4)  # left and right edges
    return k, st


#: Tiles of several sizes, (columns, rows) in multiples of the block, packed into shelves.
SIZES = ((16, 8), (8, 8), (24, 16), (8, 40), (40, 24))


@pytest.fixture(params=["one size", "several sizes"])
def atlas(request):
    if request.param == "one size":
        atlas = Atlas.for_patches(PATCHES, TILE)
        # the documented layout: tile k at column (k mod 3) T and row (k div 3) T
        assert (atlas.width, atlas.height) == (18, 12)
        k = np.arange(PATCHES)
        np.testing.assert_array_equal(atlas.col0, (k % COLS) * TILE)
        np.testing.assert_array_equal(atlas.row0, (k // COLS) * TILE)
    else:
        atlas = Atlas.for_tiles(SIZES)
        np.testing.assert_array_equal(atlas.sizes, SIZES)
        assert not (atlas.row0 % BLOCK).any() and not (atlas.col0 % BLOCK).any()
        assert (atlas.row0 + atlas.sizes[:, 1] <= atlas.height).all()
        assert (atlas.col0 + atlas.sizes[:, 0] <= atlas.width).all()
        # packed: the atlas at most twice the tiles' texels
        assert atlas.width * atlas.height <= 2 * sum(S * T for S, T in SIZES)
    return atlas


def test_texcoords_and_locate_follow_the_layout(atlas):
    k, st = sample_points(np.random.default_rng(1))
    xy = atlas.texcoords(k, st)
    # the documented addressing: the texel centre of s = i / (T - 1) in patch k's tile
    S, T = atlas.sizes[k, 0], atlas.sizes[k, 1]
    expected_x = (atlas.col0[k] + 0.5 + st[:, 0] * (S - 1)) / atlas.width
    expected_y = (atlas.row0[k] + 0.5 + st[:, 1] * (T - 1)) / atlas.height
    np.testing.assert_allclose(xy, np.stack([expected_x, expected_y], -1), rtol=0, atol=1e-15)
    patch, back = atlas.locate(xy)
    np.testing.assert_array_equal(patch, k)
    np.testing.assert_allclose(back, st, atol=1e-12)


def test_numpy_lookup_gives_back_the_values(atlas):
    tex = known_textures(atlas)
    k, st = sample_points(np.random.default_rng(2))
    xy = atlas.texcoords(k, st)
    s, t = st[:, 0], st[:, 1]
    values = SHAPE.pack(tex.function(0))
    np.testing.assert_allclose(atlas.interpolate(values, SHAPE, "f", xy), f_of(k, s, t), atol=1e-4)
    np.testing.assert_allclose(
        atlas.interpolate(values, SHAPE, "f_s", xy), 3.0 + 1.5 * t, atol=1e-5
    )
    np.testing.assert_allclose(atlas.interpolate(values, SHAPE, "f_t", xy), -2 + 1.5 * s, atol=1e-5)
    valid = atlas.interpolate(values, SHAPE, "valid", xy)
    np.testing.assert_array_equal(valid > 0.5, k != 1)
    geometry = GEOMETRY.pack(tex.geometry())
    p = np.stack([atlas.interpolate(geometry, GEOMETRY, "p", xy, c) for c in range(3)], -1)
    np.testing.assert_allclose(p, p_of(k, s, t), atol=1e-5)


def test_packing_names_the_channels():
    assert [GEOMETRY.channel("p_t", c) for c in range(3)] == [6, 7, 8]
    assert GEOMETRY.hermite_channels("p", 2) == (2, 5, 8, 11)
    assert SHAPE.hermite_channels("f") == (0, 1, 2, 3) and SHAPE.channel("valid") == 4
    packed = Packing((("a", 1), ("b", 2))).pack({"a": np.zeros((2, 3)), "b": np.ones((2, 3, 2))})
    assert packed.shape == (2, 3, 3) and packed.dtype == np.float32
    assert packed[..., 0].max() == 0 and packed[..., 1:].min() == 1
    with pytest.raises(KeyError):
        SHAPE.channel("g")
    with pytest.raises(ValueError, match="b has 1 channels, expected 2"):
        Packing((("b", 2),)).pack({"b": np.zeros((2, 3))})


@pytest.fixture
def integrator(atlas):
    from gshade.rendering.integrator import IntegratorSettings, make_integrator
    from gshade.rendering.plugins import use_variant

    if use_variant("auto") != "llvm_ad_rgb":
        pytest.skip("the vectorised Dr.Jit lookup needs the llvm_ad_rgb variant")
    settings = IntegratorSettings(display="stripes", lighting="flat", atlas=atlas)
    return make_integrator(settings, known_textures(atlas), None)


def surface_interactions(xy):
    import drjit as dr
    import mitsuba as mi

    si = dr.zeros(mi.SurfaceInteraction3f, len(xy))
    si.uv = mi.Point2f(mi.Float(xy[:, 0].astype(np.float32)), mi.Float(xy[:, 1].astype(np.float32)))
    return si, mi.Bool(np.ones(len(xy), dtype=bool))


def test_the_integrators_lookup_gives_back_the_values(atlas, integrator):
    shape = integrator
    k, st = sample_points(np.random.default_rng(3))
    s, t = st[:, 0], st[:, 1]
    si, hit = surface_interactions(atlas.texcoords(k, st))
    f, (f_s, f_t), defined, _ = shape._shape_value(si, hit, shape.values)
    # float32 atlas coordinates: s and t within ~2e-7 / (T - 1) of the asked ones
    np.testing.assert_allclose(np.array(f), f_of(k, s, t), atol=2e-4)
    np.testing.assert_allclose(np.array(f_s), 3.0 + 1.5 * t, atol=2e-5)
    np.testing.assert_allclose(np.array(f_t), -2.0 + 1.5 * s, atol=2e-5)
    np.testing.assert_array_equal(np.array(defined), k != 1)


def test_the_integrators_newton_step_lands_on_the_interpolated_surface(atlas, integrator):
    """From a start near (s, t), the ray through p(k, s, t) leads the integrator's one
    Newton step (through the surface textures) to the atlas coordinates of (k, s, t)."""
    import mitsuba as mi

    rng = np.random.default_rng(4)
    k, st = sample_points(rng)
    target = p_of(k, st[:, 0], st[:, 1])
    start = np.clip(st + rng.uniform(-0.05, 0.05, st.shape), 0.0, 1.0)
    si, hit = surface_interactions(atlas.texcoords(k, start))
    direction = np.array([0.3, -0.2, -1.0]) / np.linalg.norm([0.3, -0.2, -1.0])

    def vector(cls, a):
        return cls(*(mi.Float(np.ascontiguousarray(a[:, c], dtype=np.float32)) for c in range(3)))

    si.p = vector(mi.Point3f, target)  # the mesh hit: here on the surface itself
    d = np.broadcast_to(direction, target.shape)
    ray = mi.Ray3f(vector(mi.Point3f, target - 4.0 * d), vector(mi.Vector3f, d))
    integrator._onto_surface(si, ray, hit)
    uv = np.stack([np.array(si.uv.x), np.array(si.uv.y)], -1)
    np.testing.assert_allclose(uv, atlas.texcoords(k, st), atol=2e-6)


def test_shape_textures_place_each_patch_where_the_layout_says(atlas):
    rng = np.random.default_rng(5)
    patches = []
    for k in range(PATCHES):
        net = np.zeros((4, 4, 3))
        net[..., 0] = np.linspace(0, 1, 4)[:, None] + k
        net[..., 1] = np.linspace(0, 1, 4)[None, :]
        net[..., 2] = rng.normal(scale=0.3, size=(4, 4))
        patches.append(BezierPatch(net))
    tex = shape_textures(patches, atlas, [(get_shape_function("gaussian"), {})])
    k, s, t = texel_parameters(atlas)
    used = k < PATCHES
    for index in range(PATCHES):
        at = used & (k == index)
        expected = patches[index](s[at], t[at])  # rows follow t, columns s
        np.testing.assert_allclose(tex.position[at], expected, atol=1e-6)
    assert not tex.position[~used].any() and not tex.valid[0][~used].any()
