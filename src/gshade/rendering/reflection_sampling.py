"""The shape integrator's reflection of an environment map, per sample: the mirror's exact
box-filtered lookup, the occlusion ray, and the glossy conductor sampled by Mitsuba (see
:mod:`gshade.rendering.reflections` for what is drawn and why).

:class:`ReflectionSampling`'s methods are part of ``gshade_shape``
(:class:`gshade.rendering.integrator.ShapeIntegrator` inherits them; the plugin's class for
a Mitsuba variant is made from both, :func:`gshade.rendering.plugins.variant_class`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .environment_maps import map_position, table_integral
from .reflections import LUMINANCE, OCCLUDED

if TYPE_CHECKING:
    from .reflections import Environment

__all__ = ["GLOSSY_STRATA", "ReflectionSampling"]

#: A glossy sample reads the map over the solid angle 1 / (GLOSSY_STRATA pdf(wo)) about its
#: direction: the lobe's share of one of this many strata (a kernel over the sampled
#: directions, the same at every pixel whatever its samples: a blur that shrank with a
#: pixel's own count would leave the pixels sampled more sharper than their neighbours)
GLOSSY_STRATA = 64.0


class ReflectionSampling:
    """The reflection's methods of the shape integrator (they use its ``mi``, ``dr``,
    ``ops``, ``scalar``, ``_shape_value`` and ``_screen_slopes``)."""

    mi: Any
    dr: Any
    ops: Any
    scalar: bool
    _shape_value: Any
    _screen_slopes: Any

    def _configure_reflection(self, env: Environment, values: list[Any]) -> None:
        """The normal's textures, the map's summed-area tables (float64: a one-texel box's
        sum is a difference of sums over the whole map) and, for a glossy surface, Mitsuba's
        ``roughconductor``."""
        mi = self.mi
        self.normal_values = values[:3]
        self.map_w, self.map_h = env.width, env.height
        tables = env.summed.channel_tables()
        self.map_tables = [t if self.scalar else mi.Float64(t) for t in tables]
        self.rotation = float(np.radians(env.rotation))
        self.glossy: Any = None
        if env.roughness > 0:
            self.glossy = mi.load_dict(
                {
                    "type": "roughconductor",
                    "material": "none",
                    "distribution": "ggx",
                    "alpha": float(env.roughness),
                }
            )

    def _map_mean(self, column: Any, row: Any, half_c: Any, half_r: Any) -> Any:
        """The map's exact mean over the box of half-sides (half_c, half_r) texels about
        (column, row), each at least half a texel (a one-texel box: the texels bilinearly
        interpolated), columns wrapping, rows clamped to the map
        (:func:`gshade.rendering.environment_maps.table_integral`)."""
        mi, ops = self.mi, self.ops
        F = mi.Float64
        w, h = self.map_w, self.map_h
        hc = ops.clip(F(half_c), 0.5, 0.5 * w)
        hr = ops.maximum(F(half_r), 0.5)
        c0, c1 = F(column) - hc, F(column) + hc
        r0, r1 = ops.maximum(F(row) - hr, 0.0), ops.minimum(F(row) + hr, float(h))
        corners = [
            table_integral(self.map_tables, w, h, c, r, ops)
            for c, r in ((c1, r1), (c0, r1), (c1, r0), (c0, r0))
        ]
        area = (c1 - c0) * (r1 - r0)
        means = [(a - b - c + d) / area for a, b, c, d in zip(*corners, strict=True)]
        return mi.Color3f(*(mi.Float(x) for x in means))

    def _reflection(self, scene: Any, sampler: Any, si: Any, ray: Any, hit: Any) -> tuple:
        """The environment reflected at one sample (see :mod:`gshade.rendering.reflections`):
        the colour, f (its luminance, the map's unoccluded), where defined, and whether the
        reflected ray meets the surface itself: the map's mean over the mirror's footprint
        (:meth:`_footprint`) about r = v - 2 <v, n> n, or a glossy sample
        (:meth:`_glossy`)."""
        mi, dr, ops = self.mi, self.dr, self.ops
        parts = [self._shape_value(si, hit, tex) for tex in self.normal_values]
        defined = parts[0][2] & parts[1][2] & parts[2][2]
        n = dr.normalize(mi.Vector3f(*(p[0] for p in parts)))
        slopes = [self._screen_slopes(si, p[3], *p[1]) for p in parts]
        vn = dr.dot(ray.d, n)
        r = dr.normalize(ray.d - 2.0 * vn * n)
        half_c, half_r = self._footprint(ray, n, slopes, r)
        if self.glossy is not None:
            return self._glossy(scene, sampler, si, ray, hit, n, defined, (half_c, half_r))
        column, row = map_position(r.x, r.y, r.z, self.map_w, self.map_h, self.rotation, ops)
        colour = self._map_mean(column, row, half_c, half_r)
        f = dr.dot(mi.Color3f(*LUMINANCE), colour)
        occluded = self._occluded(scene, si, ray, r, hit & defined)
        return dr.select(occluded, mi.Color3f(*OCCLUDED), colour), f, defined, occluded

    def _footprint(self, ray: Any, n: Any, slopes: list, r: Any) -> tuple[Any, Any]:
        """The mirror's footprint about r in map texels: dr/dx = dv/dx - 2 (<dv/dx, n> +
        <v, dn/dx>) n - 2 <v, n> dn/dx, from the ray differentials and n's slopes, carried
        into texels by the map's Jacobian (dphi = (x dy - y dx) / rho^2, dtheta =
        (z (x dx + y dy) / rho - rho dz) with rho^2 = x^2 + y^2, for a unit r); then the
        half-sides of the box whose column and row spreads (variances) are the sample's (a
        parallelogram of sides (dc/dx, dr/dx), (dc/dy, dr/dy) spreads its columns as a box
        of width sqrt(dc/dx^2 + dc/dy^2) does)."""
        mi, dr, ops = self.mi, self.dr, self.ops
        v, w, h = ray.d, self.map_w, self.map_h
        vn = dr.dot(v, n)
        spans = []
        for k, d_ray in ((0, ray.d_x), (1, ray.d_y)):
            dv = dr.select(ray.has_differentials, d_ray - v, 0.0)
            dn = mi.Vector3f(*(s[k] for s in slopes))
            d_r = dv - 2.0 * (dr.dot(dv, n) + dr.dot(v, dn)) * n - 2.0 * vn * dn
            rho2 = ops.maximum(r.x * r.x + r.y * r.y, 1e-12)
            rho = dr.sqrt(rho2)
            d_phi = (r.x * d_r.y - r.y * d_r.x) / rho2
            d_theta = r.z * (r.x * d_r.x + r.y * d_r.y) / rho - rho * d_r.z
            spans.append((d_phi * (w / (2 * np.pi)), d_theta * (h / np.pi)))
        half_c = 0.5 * dr.sqrt(spans[0][0] * spans[0][0] + spans[1][0] * spans[1][0])
        half_r = 0.5 * dr.sqrt(spans[0][1] * spans[0][1] + spans[1][1] * spans[1][1])
        return half_c, half_r

    def _occluded(self, scene: Any, si: Any, ray: Any, r: Any, active: Any) -> Any:
        """Whether the ray along r from the sample meets the surface; a direction that
        leaves the exact surface but dips under the mesh's triangle (near grazing) is not
        traced."""
        dr = self.dr
        ng = dr.select(dr.dot(si.n, ray.d) > 0, -si.n, si.n)
        leaves = active & (dr.dot(r, ng) > 0)
        return leaves & scene.ray_test(si.spawn_ray(r), leaves)

    def _glossy(
        self,
        scene: Any,
        sampler: Any,
        si: Any,
        ray: Any,
        hit: Any,
        n: Any,
        defined: Any,
        footprint: tuple[Any, Any],
    ) -> tuple:
        """A glossy conductor: one direction wo sampled by Mitsuba's ``roughconductor`` in
        the frame of the exact normal (turned towards the viewer), weighted by the BSDF's
        weight (f cos / pdf), the map read over the directions the sample stands for: a
        square of solid angle 1 / (:data:`GLOSSY_STRATA` pdf(wo)) about wo, its spread
        widened by the mirror's ``footprint`` (the sample's share of the pixel), averaged
        by :meth:`_map_mean`."""
        mi, dr, ops = self.mi, self.dr, self.ops
        n = dr.select(dr.dot(n, ray.d) > 0, -n, n)
        si.sh_frame = mi.Frame3f(n)
        si.wi = si.to_local(-ray.d)
        active = hit & defined
        bs, weight = self.glossy.sample(
            mi.BSDFContext(), si, sampler.next_1d(active), sampler.next_2d(active), active
        )
        wo = si.to_world(bs.wo)
        sampled = active & (bs.pdf > 0)
        w, h = self.map_w, self.map_h
        column, row = map_position(wo.x, wo.y, wo.z, w, h, self.rotation, ops)
        half = 0.5 * dr.sqrt(1.0 / (GLOSSY_STRATA * ops.maximum(bs.pdf, 1e-12)))  # radians
        sin_theta = ops.maximum(dr.sqrt(wo.x * wo.x + wo.y * wo.y), 1e-6)
        lobe_c, lobe_r = half / sin_theta * (w / (2 * np.pi)), half * (h / np.pi)
        # and the pixel's own footprint (the mirror's, about wo): the directions a sample
        # stands for across the pixel as well as across the lobe
        half_c = dr.sqrt(lobe_c * lobe_c + footprint[0] * footprint[0])
        half_r = dr.sqrt(lobe_r * lobe_r + footprint[1] * footprint[1])
        colour = self._map_mean(column, row, half_c, half_r) * weight
        colour = dr.select(sampled, colour, mi.Color3f(0.0))
        f = dr.dot(mi.Color3f(*LUMINANCE), colour)
        occluded = self._occluded(scene, si, ray, wo, sampled)
        return dr.select(occluded, mi.Color3f(*OCCLUDED), colour), f, defined, occluded
