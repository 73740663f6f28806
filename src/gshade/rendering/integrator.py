"""gshade's Mitsuba integrator: per-sample shape colours from exact shape-function textures.

For every camera ray it intersects the mesh, interpolates (f, f_s, f_t) from the atlas at
the hit's parameters, and turns f into a colour per sample: anti-aliased stripes (the box
filter of :func:`gshade.display.colour.coverage_formula` over the sample's footprint, from the
ray differentials and the exact derivatives), a colour map (a lookup table of a matplotlib
map), or both.  ``flat`` lighting returns that colour; ``lit`` puts it on a two-sided diffuse
surface under soft light (sky occlusion from one cosine-distributed ray, a shadowed key light
and a head light).  AOV ``f`` is f at hits and 0 elsewhere, so that its pixel mean divided
by the coverage A is the mean over the samples that hit.

A second mode (set ``integrator.data = True`` before a render) returns only the hit's atlas
coordinates, for the per-pixel data channels that gshade then evaluates exactly (P, N, u, v,
patch); it reads the same textures.

Traced into one kernel in the ``llvm_ad_rgb`` variant (as fast as Mitsuba's own plugins);
run per sample in ``scalar_rgb``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..display.colour import DARK, LIGHT, UNDEFINED, coverage_formula

__all__ = ["IntegratorSettings", "make_integrator"]

STRIPES, COLORMAP, BOTH = 0, 1, 2
DISPLAY_CODES = {"stripes": STRIPES, "colormap": COLORMAP, "both": BOTH}


@dataclass(frozen=True)
class IntegratorSettings:
    """What the integrator draws (all in world space / units of f)."""

    display: str = "stripes"
    lighting: str = "lit"
    period: float = 0.1
    duty: float = 0.5
    phase: float = 0.0
    value_range: tuple[float, float] = (0.0, 1.0)
    atlas_scale: tuple[float, float] = (1.0, 1.0)
    atlas_size: tuple[int, int, int] = (2, 2, 2)  # width, height, tile (texels)
    key_light: tuple[float, float, float] = (0.0, 0.0, 1.0)


class _DrJitOps:
    """The array operations of :func:`coverage_formula`, for Dr.Jit arrays (or scalars).

    Minimum and maximum are written as compare-and-select: Dr.Jit lowers ``dr.minimum`` to
    LLVM's ``fminimum``, which some LLVM versions cannot compile for x86 in every kernel
    (the process aborts: "Cannot select ... fminimum"), even LLVM 23 (seen here).
    """

    def __init__(self, dr, scalar: bool) -> None:
        select = dr.select
        self.floor = dr.floor
        self.minimum = lambda a, b: select(a < b, a, b)
        self.maximum = lambda a, b: select(a > b, a, b)
        self.abs = dr.abs
        self.select = select
        self.logical_not = (lambda m: not m) if scalar else (lambda m: ~m)

    def clip(self, x, lo, hi):
        return self.minimum(self.maximum(x, lo), hi)


_CLASSES: dict[str, type] = {}


def make_integrator(
    settings: IntegratorSettings,
    textures: dict[str, np.ndarray],
    lut: np.ndarray | None,
):
    """An integrator instance for the active Mitsuba variant.

    ``textures``: 'values' (H, W, 3) float32 = (f, f_s, f_t), 'twist' (H, W) = f_st and
    'valid' (H, W) of the striped/primary function; for ``display == 'both'`` the same as
    'colour_values', 'colour_twist', 'colour_valid' of the colour-mapped function; and the
    surface's 'position', 'tangent_s', 'tangent_t', 'twist_st' (H, W, 3) (see
    :class:`gshade.rendering.textures.ShapeTextures`).  ``lut``: (256, 3) linear RGB map.
    """
    import drjit as dr
    import mitsuba as mi

    variant = mi.variant()
    if variant is None:
        raise RuntimeError("make_integrator: no Mitsuba variant is set (select_variant first)")
    cls = _CLASSES.get(variant)
    if cls is None:
        cls = _define(mi, dr)
        _CLASSES[variant] = cls
    integrator = cls(mi.Properties())
    integrator.configure(settings, textures, lut)
    return integrator


def _define(mi, dr):
    scalar = mi.variant().startswith("scalar")
    ops = _DrJitOps(dr, scalar)
    Float, Float64, Color3f = mi.Float, mi.Float64, mi.Color3f

    def bitmap(array, filter_type="bilinear"):
        return mi.load_dict(
            {
                "type": "bitmap",
                "bitmap": mi.Bitmap(np.ascontiguousarray(array, dtype=np.float32)),
                "raw": True,
                "filter_type": filter_type,
                "wrap_mode": "clamp",
            }
        )

    def packed(arrays):
        """A Dr.Jit texture of the arrays' channels side by side (H, W, sum of channels)."""
        channels = [a[..., None] if a.ndim == 2 else a for a in arrays]
        data = np.ascontiguousarray(np.concatenate(channels, -1), dtype=np.float32)
        return mi.Texture2f(
            mi.TensorXf(data),
            use_accel=False,
            filter_mode=dr.FilterMode.Linear,
            wrap_mode=dr.WrapMode.Clamp,
        )

    def opaque(x):
        return x if scalar else dr.opaque(Float, x)

    class GshadeIntegrator(mi.SamplingIntegrator):
        def configure(self, settings, textures, lut):
            self.data = False
            self.display = DISPLAY_CODES[settings.display]
            self.lit = settings.lighting == "lit"
            # one texture per kind of data, all a texel's channels fetched at once
            self.geometry = packed(
                [textures[k] for k in ("position", "tangent_s", "tangent_t", "twist_st")]
            )  # p, p_s, p_t, p_st: 12 channels
            self.values = packed(
                [textures["values"], textures["twist"], textures["valid"]]
            )  # f, f_s, f_t, f_st, valid
            self.atlas_w, self.atlas_h, self.tile = settings.atlas_size
            if self.display == BOTH:
                self.colour_values = packed(
                    [textures["colour_values"], textures["colour_twist"], textures["colour_valid"]]
                )
            if lut is not None:
                self.lut = bitmap(lut[None, :, :])
                self.lut_size = lut.shape[0]
            self.period = opaque(settings.period)
            self.phase = opaque(settings.phase)
            self.duty = float(settings.duty)
            self.lo = opaque(settings.value_range[0])
            self.inv_span = opaque(1.0 / (settings.value_range[1] - settings.value_range[0]))
            self.ks, self.kt = (opaque(k) for k in settings.atlas_scale)
            self.key = mi.Vector3f(*settings.key_light)

        def aov_names(self):
            return ["x", "y", "hit"] if self.data else ["f"]

        def _lookup(self, g):
            t = ops.clip((g - self.lo) * self.inv_span, 0.0, 1.0)
            si = dr.zeros(mi.SurfaceInteraction3f)
            si.uv = mi.Point2f((t * (self.lut_size - 1) + 0.5) / self.lut_size, 0.5)
            return self.lut.eval(si)

        def _cell(self, si, texture, hit):
            """The texel cell around si.uv inside its tile: the four corner texels (all
            channels, in the order (i, j), (i+1, j), (i, j+1), (i+1, j+1)) and the cell
            coordinates (a, b) in [0, 1]^2."""
            X = si.uv.x * self.atlas_w - 0.5
            Y = si.uv.y * self.atlas_h - 0.5
            c0 = dr.floor((X + 0.5) / self.tile) * self.tile
            r0 = dr.floor((Y + 0.5) / self.tile) * self.tile
            i = ops.clip(dr.floor(X), c0, c0 + self.tile - 2)
            j = ops.clip(dr.floor(Y), r0, r0 + self.tile - 2)
            a = ops.clip(X - i, 0.0, 1.0)
            b = ops.clip(Y - j, 0.0, 1.0)
            # the cell's centre: a linear lookup there reads exactly these four texels
            centre = mi.Point2f((i + 1.0) / self.atlas_w, (j + 1.0) / self.atlas_h)
            return texture.eval_fetch(centre, hit), a, b

        def _hermite(self, corners, a, b, first: int, stride: int = 1):
            """Bicubic Hermite interpolation (error O(h^4)) from exact values and s, t and
            st derivatives at the cell's corners: the channels ``first + k * stride`` for
            k = 0..3 hold the value, d/ds, d/dt and d2/dsdt."""
            h = 1.0 / (self.tile - 1)  # texel spacing in the normalised parameters
            va = (1 - a * a * (3 - 2 * a), a * a * (3 - 2 * a))
            da = (a * (1 - a) * (1 - a) * h, -a * a * (1 - a) * h)
            vb = (1 - b * b * (3 - 2 * b), b * b * (3 - 2 * b))
            db = (b * (1 - b) * (1 - b) * h, -b * b * (1 - b) * h)
            total = 0.0
            for texel, (di, dj) in zip(corners, ((0, 0), (1, 0), (0, 1), (1, 1)), strict=True):
                weights = (va[di] * vb[dj], da[di] * vb[dj], va[di] * db[dj], da[di] * db[dj])
                for k, w in enumerate(weights):
                    total = total + w * texel[first + k * stride]
            return total

        @staticmethod
        def _bilinear(corners, a, b, channel):
            c = [texel[channel] for texel in corners]
            return (c[0] * (1 - a) + c[1] * a) * (1 - b) + (c[2] * (1 - a) + c[3] * a) * b

        def _onto_surface(self, si, ray, hit):
            """Move si.uv from the mesh's interpolated parameters to the exact surface point
            on the ray: one Newton step on p(s, t) = hit + tau d ([p_s p_t -d] (ds, dt, dtau)
            = hit - p by Cramer's rule), with p from bicubic Hermite interpolation."""
            corners, a, b = self._cell(si, self.geometry, hit)
            p = mi.Vector3f(*(self._hermite(corners, a, b, c, 3) for c in range(3)))
            ps = mi.Vector3f(*(self._bilinear(corners, a, b, 3 + c) for c in range(3)))
            pt = mi.Vector3f(*(self._bilinear(corners, a, b, 6 + c) for c in range(3)))
            r = si.p - p
            c = -ray.d
            det = dr.dot(ps, dr.cross(pt, c))
            ok = hit & (dr.abs(det) > 1e-20)
            inv = dr.select(ok, dr.rcp(det), 0.0)
            ds = dr.dot(r, dr.cross(pt, c)) * inv
            dt = dr.dot(ps, dr.cross(r, c)) * inv
            # stay inside this patch's tile (between its first and last texel centres)
            x = si.uv.x + ds / self.ks
            y = si.uv.y + dt / self.kt
            c0 = dr.floor(si.uv.x * self.atlas_w / self.tile) * self.tile
            r0 = dr.floor(si.uv.y * self.atlas_h / self.tile) * self.tile
            x = ops.clip(x, (c0 + 0.5) / self.atlas_w, (c0 + self.tile - 0.5) / self.atlas_w)
            y = ops.clip(y, (r0 + 0.5) / self.atlas_h, (r0 + self.tile - 0.5) / self.atlas_h)
            si.uv = mi.Point2f(dr.select(ok, x, si.uv.x), dr.select(ok, y, si.uv.y))

        def _shape_value(self, si, hit, texture):
            """f (bicubic Hermite), its bilinear slopes (f_s, f_t) and whether it is
            defined (bilinear validity > 1/2), from one fetch of the cell's texels."""
            corners, a, b = self._cell(si, texture, hit)
            f = self._hermite(corners, a, b, 0)
            slopes = (self._bilinear(corners, a, b, 1), self._bilinear(corners, a, b, 2))
            return f, slopes, self._bilinear(corners, a, b, 4) > 0.5

        def sample(self, scene, sampler, ray, medium=None, active=True):
            si = scene.ray_intersect(ray, active)
            hit = active & si.is_valid()
            if self.data:
                self._onto_surface(si, ray, hit)  # a close start for gshade's own Newton
                return (
                    Color3f(0.0),
                    hit,
                    [
                        dr.select(hit, si.uv.x, 0.0),
                        dr.select(hit, si.uv.y, 0.0),
                        dr.select(hit, Float(1.0), Float(0.0)),
                    ],
                )
            si.compute_uv_partials(ray)
            self._onto_surface(si, ray, hit)
            f, (f_s, f_t), defined = self._shape_value(si, hit, self.values)
            if self.display == COLORMAP:
                colour = self._lookup(f)
            else:
                # d f / d(screen x, y) = f_s ds/dx + f_t dt/dx, with (s, t) from atlas coordinates
                fx = f_s * si.duv_dx.x * self.ks + f_t * si.duv_dx.y * self.kt
                fy = f_s * si.duv_dy.x * self.ks + f_t * si.duv_dy.y * self.kt
                s = Float64(f) / Float64(self.period) + Float64(self.phase)
                a = Float64(fx) / Float64(self.period)
                b = Float64(fy) / Float64(self.period)
                cov = Float(coverage_formula(s, a, b, self.duty, ops))
                colour = Color3f(DARK) * cov + Color3f(LIGHT) * (1.0 - cov)
                if self.display == BOTH:
                    g, _, colour_defined = self._shape_value(si, hit, self.colour_values)
                    colour = self._lookup(g) * (1.0 - 0.65 * cov)
                    defined = defined & colour_defined
            colour = dr.select(defined, colour, Color3f(UNDEFINED))
            if self.lit:
                n = si.sh_frame.n
                n = dr.select(dr.dot(n, ray.d) > 0, -n, n)  # two-sided: face the viewer
                frame = mi.Frame3f(n)
                sky_dir = frame.to_world(mi.warp.square_to_cosine_hemisphere(sampler.next_2d()))
                sky = dr.select(scene.ray_test(si.spawn_ray(sky_dir), hit), 0.0, 1.0)
                key_cos = ops.maximum(dr.dot(n, self.key), 0.0)
                key = dr.select(
                    scene.ray_test(si.spawn_ray(self.key), hit & (key_cos > 0)), 0.0, key_cos
                )
                head = ops.maximum(-dr.dot(n, ray.d), 0.0)
                colour = colour * (0.45 * sky + 0.45 * key + 0.25 * head)
            colour = dr.select(hit, colour, Color3f(0.0))
            return colour, hit, [dr.select(hit, f, 0.0)]

    return GshadeIntegrator
