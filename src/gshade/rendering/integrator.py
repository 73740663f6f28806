"""gshade's Mitsuba integrator: shape colours from exact shape-function textures, and what
the exact channels and the choice of supersampled pixels need.

``gshade_shape`` (:data:`SHAPE_PLUGIN`, registered with Mitsuba by name): for every camera
ray it intersects the mesh, moves the hit onto the surface interpolated from the atlas (one
Newton step), interpolates (f, f_s, f_t) there, and turns f into a colour per sample:
anti-aliased stripes (the box filter of :func:`gshade.display.colour.coverage_formula` over
the sample's footprint, from the ray differentials and the exact derivatives), a colour map
(a lookup table of a matplotlib map), or both.  ``flat`` lighting returns that colour c.
``lit`` puts it on a two-sided diffuse surface under deterministic light, with no random
numbers in the shading::

    c · (AMBIENT + HEAD · max(n·v, 0) + KEY · V(l) · max(n·l, 0))

(n the normal turned towards the viewer, v the direction to the eye, l the key light's
direction, V(l) one shadow ray towards the key light: 0 or 1), so that a lit picture has no
grain and is the same in every variant.  ``soft`` is the earlier soft light, which samples
the sky: ``c · (0.45 · S + 0.45 · V(l) · max(n·l, 0) + 0.25 · max(n·v, 0))`` with S the
visibility along one cosine-distributed random ray per sample (ambient occlusion; grainy at
a few samples per pixel, and different between variants).

Its AOVs (:data:`SHAPE_FILM`), 0 where the ray meets nothing: ``f``, so that its pixel mean
divided by the coverage A is the mean over the samples that hit; ``x``, ``y``, the hit's atlas
coordinates after the Newton step, a close start for gshade's own exact Newton step
(:mod:`gshade.rendering.surface_hits`) when the sample is the pixel's centre; ``flags``,
1 where f (and the colour function) is defined plus 2 where the key light faces the point but
is shadowed; ``f_x``, ``f_y``, the derivatives of f along the image's columns and rows, per
pixel.  From one sample at each pixel centre,
these tell where the picture is discontinuous (:mod:`gshade.rendering.supersampling`).

Traced into one kernel in the ``llvm_ad_rgb`` variant (as fast as Mitsuba's own plugins);
run per sample in ``scalar_rgb``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..display.bands import (
    LINE_COLOUR,
    PARABOLIC_COLOUR,
    PARABOLIC_LINES,
    band_shares,
    settled_on_levels,
)
from ..display.colour import (
    DARK,
    LIGHT,
    UNDEFINED,
    coverage_formula,
    settled_on_edges,
    srgb_to_linear,
)
from ..runtime.llvm import import_drjit
from ..runtime.variant import mitsuba
from .atlas import GEOMETRY, SHAPE, Atlas, bilinear, cell_centre, hermite, locate_cell, tile_bounds
from .newton import newton_step
from .reflection_sampling import ReflectionSampling
from .textures import ShapeTextures

if TYPE_CHECKING:
    from ..shape import Bands
    from .reflections import Environment

__all__ = [
    "SHAPE_FILM",
    "SHAPE_PLUGIN",
    "IntegratorSettings",
    "ShapeIntegrator",
    "make_integrator",
]

STRIPES, COLORMAP, BOTH, BANDS, REFLECTION = 0, 1, 2, 3, 4
DISPLAY_CODES = {
    "stripes": STRIPES,
    "colormap": COLORMAP,
    "both": BOTH,
    "bands": BANDS,
    "reflection": REFLECTION,
}

#: the Mitsuba plugin name of the integrator
SHAPE_PLUGIN = "gshade_shape"
#: the film channels a render gives: R G B A, then the integrator's AOVs
SHAPE_FILM = ("R", "G", "B", "A", "f", "x", "y", "flags", "f_x", "f_y")
#: ``flags``: f (and the colour function) defined; the key light shadowed (a reflection: the
#: reflected ray meets the surface itself)
DEFINED, SHADOWED = 1, 2

#: the packed textures' channels that the integrators read (see gshade.rendering.atlas)
_P = [GEOMETRY.hermite_channels("p", c) for c in range(3)]
_P_S = [GEOMETRY.channel("p_s", c) for c in range(3)]
_P_T = [GEOMETRY.channel("p_t", c) for c in range(3)]
_F, _F_S, _F_T = SHAPE.hermite_channels("f"), SHAPE.channel("f_s"), SHAPE.channel("f_t")
_VALID = SHAPE.channel("valid")

#: ``lit``'s weights: a constant ambient term, a head light (at the eye) and the key light
AMBIENT, HEAD, KEY = 0.3, 0.4, 0.45
#: ``soft``'s weights: sky (one random cosine-distributed ray), key light, head light
SOFT_SKY, SOFT_KEY, SOFT_HEAD = 0.45, 0.45, 0.25

#: Rays this close to the interpolated tangent plane (|det [p_s p_t -d]| at most this, in
#: float32) keep the mesh's parameters.
TINY = 1e-20


@dataclass(frozen=True)
class IntegratorSettings:
    """What the integrators draw (all in world space / units of f)."""

    display: str = "stripes"
    lighting: str = "lit"
    period: float = 0.1
    duty: float = 0.5
    phase: float = 0.0
    value_range: tuple[float, float] = (0.0, 1.0)
    atlas: Atlas = field(default_factory=lambda: Atlas.for_patches(1, 2))
    key_light: tuple[float, float, float] = (0.0, 0.0, 1.0)
    #: display = "bands": the function's bands
    bands: Bands | None = None
    #: the parabolic lines (K = 0) drawn over the picture, from the last function's textures
    parabolic: bool = False
    #: display = "reflection": the environment reflected (the textures: n_x, n_y, n_z)
    environment: Environment | None = None


def make_integrator(
    settings: IntegratorSettings, textures: ShapeTextures, lut: np.ndarray | None
) -> Any:
    """The shape integrator for the active Mitsuba variant.

    ``textures``: the atlas images of the surface and of the functions (the striped or
    primary one first; for ``display == 'both'`` the colour-mapped one second).  ``lut``:
    (256, 3) linear RGB map, or None for stripes alone.
    """
    mi = mitsuba()

    if mi.variant() is None:
        raise RuntimeError("make_integrator: no Mitsuba variant is set (use_variant first)")
    geometry = _texture(mi, GEOMETRY.pack(textures.geometry()))
    values = [_texture(mi, SHAPE.pack(textures.function(k))) for k in range(len(textures.values))]
    shape = mi.load_dict({"type": SHAPE_PLUGIN})
    shape.configure(settings, geometry, values, lut, textures.periods)
    return shape


def _texture(mi: Any, data: np.ndarray) -> Any:
    """A Dr.Jit texture of a packed (H, W, channels) float32 image."""
    dr = import_drjit()

    return mi.Texture2f(
        mi.TensorXf(data),
        use_accel=False,
        filter_mode=dr.FilterMode.Linear,
        wrap_mode=dr.WrapMode.Clamp,
    )


def _bitmap(mi: Any, array: np.ndarray, filter_type: str = "bilinear") -> Any:
    """A raw, clamped Mitsuba bitmap texture of a float image."""
    return mi.load_dict(
        {
            "type": "bitmap",
            "bitmap": mi.Bitmap(np.ascontiguousarray(array, dtype=np.float32)),
            "raw": True,
            "filter_type": filter_type,
            "wrap_mode": "clamp",
        }
    )


class ShapeIntegrator(ReflectionSampling):
    """The shape function's picture (R G B A) and the AOVs :data:`SHAPE_FILM` names.

    The methods of ``gshade_shape``, put on the active variant's ``mi.SamplingIntegrator``
    with the variant's parts ``mi``, ``dr``, ``ops`` and ``scalar`` by
    :func:`gshade.rendering.plugins.variant_class`.
    """

    mi: Any
    dr: Any
    ops: Any
    scalar: bool

    def _opaque(self, x: float) -> Any:
        """x as a value the traced kernel reads (not a constant baked into it)."""
        return x if self.scalar else self.dr.opaque(self.mi.Float, x)

    def to_string(self) -> str:
        return f"{type(self).__name__}[{self.mi.variant()}]"

    def configure(
        self,
        settings: IntegratorSettings,
        geometry: Any,
        values: list[Any],
        lut: np.ndarray | None,
        periods: Sequence[float | None] = (),
    ) -> None:
        """Set what to draw: the settings, the atlas textures of the surface and of the
        functions (see :func:`make_integrator`), the colour map's lookup table, and the
        periods of the functions' values where they wrap
        (:attr:`gshade.rendering.textures.ShapeTextures.periods`)."""
        self.geometry = geometry  # p, p_s, p_t, p_st: 12 channels, fetched at once
        atlas = settings.atlas
        self.atlas_w, self.atlas_h = atlas.width, atlas.height
        # where the tiles are: per block its patch, per patch its tile (Dr.Jit arrays;
        # Python lists in the scalar variants)
        self.tiles = atlas.tiles(self.ops, (lambda a: a.tolist()) if self.scalar else self.mi.Float)
        self.display = DISPLAY_CODES[settings.display]
        self.lighting = settings.lighting  # 'flat', 'lit' or 'soft'
        self.values = values[0]  # f, f_s, f_t, f_st, valid
        periods = (*periods, *([None] * len(values)))  # of the values that wrap
        self.value_period = periods[0]
        if self.display == BOTH:
            self.colour_values, self.colour_period = values[1], periods[1]
        if lut is not None:
            self.lut = _bitmap(self.mi, lut[None, :, :])
            self.lut_size = lut.shape[0]
        self.period = self._opaque(settings.period)
        self.phase = self._opaque(settings.phase)
        self.duty = float(settings.duty)
        self.lo = self._opaque(settings.value_range[0])
        self.inv_span = self._opaque(1.0 / (settings.value_range[1] - settings.value_range[0]))
        self.key = self.mi.Vector3f(*settings.key_light)
        self.bands = settings.bands
        self.parabolic = settings.parabolic
        if self.parabolic:
            self.parabolic_values = values[-1]
            linear = srgb_to_linear(np.asarray(PARABOLIC_COLOUR, dtype=np.float64))
            self.parabolic_colour = self.mi.Color3f(*map(float, linear))
        if self.bands is not None:
            linear = srgb_to_linear(np.asarray(self.bands.colours, dtype=np.float64))
            self.band_colours = [self.mi.Color3f(*map(float, c)) for c in linear]
        if settings.environment is not None:
            self._configure_reflection(settings.environment, values)

    def aov_names(self) -> list[str]:
        return list(SHAPE_FILM[4:])

    def _cell(self, si: Any, texture: Any, hit: Any) -> tuple[Any, Any]:
        """The cell around si.uv inside its tile: the four corner texels (all channels)
        and the cell (:func:`gshade.rendering.atlas.locate_cell`)."""
        cell = locate_cell(si.uv.x, si.uv.y, self.atlas_w, self.atlas_h, self.tiles, self.ops)
        centre = self.mi.Point2f(
            cell_centre(cell.i, self.atlas_w), cell_centre(cell.j, self.atlas_h)
        )
        return texture.eval_fetch(centre, hit), cell

    def _onto_surface(self, si: Any, ray: Any, hit: Any) -> None:
        """Move si.uv from the mesh's interpolated parameters to the surface point on the
        ray: one Newton step (:func:`gshade.rendering.newton.newton_step`) from the mesh
        hit, with p from bicubic Hermite interpolation, p_s and p_t bilinear."""
        mi, dr, ops = self.mi, self.dr, self.ops
        corners, cell = self._cell(si, self.geometry, hit)
        a, b = cell.a, cell.b
        p = mi.Vector3f(*(hermite(corners, a, b, cell.spacing, ch) for ch in _P))
        ps = mi.Vector3f(*(bilinear(corners, a, b, ch) for ch in _P_S))
        pt = mi.Vector3f(*(bilinear(corners, a, b, ch) for ch in _P_T))
        ds, dt, _, solvable = newton_step(ps, pt, ray.d, si.p - p, ops, TINY, with_t=False)
        ok = hit & solvable
        # stay inside this patch's tile (between its first and last texel centres); d(s,
        # t) / d(atlas x, y) = (W / (S - 1), H / (T - 1))
        S, T = cell.columns, cell.rows
        x = ops.clip(
            si.uv.x + ds * (S - 1.0) / self.atlas_w, *tile_bounds(cell.c0, S, self.atlas_w)
        )
        y = ops.clip(
            si.uv.y + dt * (T - 1.0) / self.atlas_h, *tile_bounds(cell.r0, T, self.atlas_h)
        )
        si.uv = mi.Point2f(dr.select(ok, x, si.uv.x), dr.select(ok, y, si.uv.y))

    def _lookup(self, g: Any) -> Any:
        """The colour map's colour of the value g (clamped to the value range)."""
        mi, dr = self.mi, self.dr
        t = self.ops.clip((g - self.lo) * self.inv_span, 0.0, 1.0)
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.uv = mi.Point2f((t * (self.lut_size - 1) + 0.5) / self.lut_size, 0.5)
        return self.lut.eval(si)

    def _shape_value(
        self, si: Any, hit: Any, texture: Any, period: float | None = None
    ) -> tuple[Any, Any, Any, Any]:
        """f (bicubic Hermite), its bilinear slopes (f_s, f_t) and whether it is
        defined (bilinear validity > 1/2), from one fetch of the cell's texels; and the
        cell (its tile's columns and rows).

        Where f's values are angles that wrap (``period`` P), the corners' values are taken
        within P / 2 of the first corner's before the interpolation (across the wrap of an
        atan2 they differ by about P) and f is wrapped into [-P / 2, P / 2) after it."""
        corners, cell = self._cell(si, texture, hit)
        a, b = cell.a, cell.b
        if period is not None:
            corners = [self._unwrapped(texel, corners[0][_F[0]], period) for texel in corners]
        f = hermite(corners, a, b, cell.spacing, _F)
        if period is not None:
            f = f - period * self.ops.floor(f / period + 0.5)
        slopes = (bilinear(corners, a, b, _F_S), bilinear(corners, a, b, _F_T))
        return f, slopes, bilinear(corners, a, b, _VALID) > 0.5, cell

    def _unwrapped(self, texel: Any, first: Any, period: float) -> list:
        """A corner texel's channels with its value f moved by whole periods to within
        period / 2 of ``first``."""
        channels = list(texel)
        f = channels[_F[0]]
        channels[_F[0]] = f - period * self.ops.floor((f - first) / period + 0.5)
        return channels

    def _screen_slopes(self, si: Any, cell: Any, f_s: Any, f_t: Any) -> tuple[Any, Any]:
        """d f / d(screen x, y) = f_s ds/dx + f_t dt/dx (and for y), from the slopes in the
        tile's (s, t): d(s, t) / d(atlas x, y) = (W / (S - 1), H / (T - 1))."""
        ks = self.atlas_w / (cell.columns - 1.0)
        kt = self.atlas_h / (cell.rows - 1.0)
        fx = f_s * si.duv_dx.x * ks + f_t * si.duv_dx.y * kt
        fy = f_s * si.duv_dy.x * ks + f_t * si.duv_dy.y * kt
        return fx, fy

    def _level_shares(
        self, f: Any, fx: Any, fy: Any, bands: Bands, sampler: Any
    ) -> tuple[list[Any], Any]:
        """The bands' and the lines' shares of the sample's footprint, settled on the levels
        (:func:`gshade.display.bands.band_shares`; a sample covers 1/sqrt(spp) of the
        pixel's side, as Mitsuba scales the ray differentials)."""
        mi = self.mi
        spread = 1.0 / float(np.sqrt(sampler.sample_count()))
        f64, fx64, fy64 = settled_on_levels(
            mi.Float64(f), mi.Float64(fx), mi.Float64(fy), bands, self.ops
        )
        return band_shares(f64, fx64, fy64, bands, spread, self.ops)

    def _bands(self, f: Any, fx: Any, fy: Any, sampler: Any) -> Any:
        """The bands' colour over the sample's footprint, with the lines over it."""
        mi, bands = self.mi, self.bands
        assert bands is not None
        shares, line = self._level_shares(f, fx, fy, bands, sampler)
        colour = self.band_colours[0] * mi.Float(shares[0])
        for share, band_colour in zip(shares[1:], self.band_colours[1:], strict=True):
            colour = colour + band_colour * mi.Float(share)
        on_line = mi.Float(line)
        return colour * (1.0 - on_line) + mi.Color3f(LINE_COLOUR) * on_line

    def _parabolic_lines(self, si: Any, hit: Any, colour: Any, sampler: Any) -> Any:
        """The parabolic lines (K = 0) drawn over ``colour`` in
        :data:`gshade.display.bands.PARABOLIC_COLOUR`: a line of
        :data:`gshade.display.bands.LINE_WIDTH` pixels, box-filtered as the bands' lines are,
        from K's own textures (a plane or a cylinder, K = 0 throughout: no line)."""
        k, (k_s, k_t), defined, cell = self._shape_value(si, hit, self.parabolic_values)
        kx, ky = self._screen_slopes(si, cell, k_s, k_t)
        _, line = self._level_shares(k, kx, ky, PARABOLIC_LINES, sampler)
        on_line = self.dr.select(defined, self.mi.Float(line), 0.0)
        return colour * (1.0 - on_line) + self.parabolic_colour * on_line

    def _light(self, scene: Any, sampler: Any, si: Any, ray: Any, hit: Any) -> tuple[Any, Any]:
        """The diffuse shading factor (see the module's docstring) and whether the key
        light is shadowed (it faces the point, the shadow ray is blocked): deterministic
        for ``lit``; ``soft`` adds the sky's visibility along one random ray."""
        mi, dr, ops = self.mi, self.dr, self.ops
        n = si.sh_frame.n
        n = dr.select(dr.dot(n, ray.d) > 0, -n, n)  # two-sided: face the viewer
        key_cos = ops.maximum(dr.dot(n, self.key), 0.0)
        # one shadow ray towards the (directional) key light
        facing = hit & (key_cos > 0)
        shadowed = scene.ray_test(si.spawn_ray(self.key), facing)
        key = dr.select(shadowed, 0.0, key_cos)
        head = ops.maximum(-dr.dot(n, ray.d), 0.0)
        if self.lighting == "soft":
            frame = mi.Frame3f(n)
            sky_dir = frame.to_world(mi.warp.square_to_cosine_hemisphere(sampler.next_2d()))
            sky = dr.select(scene.ray_test(si.spawn_ray(sky_dir), hit), 0.0, 1.0)
            return SOFT_SKY * sky + SOFT_KEY * key + SOFT_HEAD * head, facing & shadowed
        return AMBIENT + KEY * key + HEAD * head, facing & shadowed

    def sample(
        self, scene: Any, sampler: Any, ray: Any, medium: Any = None, active: Any = True
    ) -> tuple[Any, Any, list[Any]]:
        """Mitsuba's ``SamplingIntegrator.sample``: the colour, whether the ray hit, and the
        AOVs ``f x y flags f_x f_y`` of one sample."""
        mi, dr, ops = self.mi, self.dr, self.ops
        Float, Float64, Color3f = mi.Float, mi.Float64, mi.Color3f
        si = scene.ray_intersect(ray, active)
        hit = active & si.is_valid()
        si.compute_uv_partials(ray)
        self._onto_surface(si, ray, hit)
        if self.display == REFLECTION:
            colour, f, defined, occluded = self._reflection(scene, sampler, si, ray, hit)
            colour = dr.select(hit, dr.select(defined, colour, Color3f(UNDEFINED)), Color3f(0.0))
            flags = dr.select(defined, 1.0, 0.0) + dr.select(occluded, 2.0, 0.0)
            aovs = [dr.select(hit, x, 0.0) for x in (f, si.uv.x, si.uv.y, flags)]
            return colour, hit, [*aovs, Float(0.0), Float(0.0)]
        f, (f_s, f_t), defined, cell = self._shape_value(si, hit, self.values, self.value_period)
        fx, fy = self._screen_slopes(si, cell, f_s, f_t)
        if self.display == COLORMAP:
            colour = self._lookup(f)
        elif self.display == BANDS:
            colour = self._bands(f, fx, fy, sampler)
        else:
            s = Float64(f) / Float64(self.period) + Float64(self.phase)
            a = Float64(fx) / Float64(self.period)
            b = Float64(fy) / Float64(self.period)
            s, a, b = settled_on_edges(s, a, b, self.duty, ops)  # a constant f: one colour
            cov = Float(coverage_formula(s, a, b, self.duty, ops))
            colour = Color3f(DARK) * cov + Color3f(LIGHT) * (1.0 - cov)
            if self.display == BOTH:
                g, _, colour_defined, _ = self._shape_value(
                    si, hit, self.colour_values, self.colour_period
                )
                colour = self._lookup(g) * (1.0 - 0.65 * cov)
                defined = defined & colour_defined
        colour = dr.select(defined, colour, Color3f(UNDEFINED))
        if self.parabolic:
            colour = self._parabolic_lines(si, hit, colour, sampler)
        shadowed = dr.zeros(mi.Bool)
        if self.lighting != "flat":
            light, shadowed = self._light(scene, sampler, si, ray, hit)
            colour = colour * light
        colour = dr.select(hit, colour, Color3f(0.0))
        flags = dr.select(defined, 1.0, 0.0) + dr.select(shadowed, 2.0, 0.0)
        return (
            colour,
            hit,
            [
                dr.select(hit, f, 0.0),
                dr.select(hit, si.uv.x, 0.0),
                dr.select(hit, si.uv.y, 0.0),
                dr.select(hit, flags, 0.0),
                dr.select(hit, fx, 0.0),
                dr.select(hit, fy, 0.0),
            ],
        )
