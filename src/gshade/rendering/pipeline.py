"""The render pipeline: scene -> patches -> mesh + shape textures -> Mitsuba -> image.

1. Resolve the camera (framing the surfaces when it is not given).
2. Tessellate on a common grid chosen from the chord-error tolerance (the smaller of
   ``chord_tolerance`` times the bounding-box diagonal and half a pixel at the nearest point).
3. Evaluate the shape function (and the colour function) with exact gradients on one texture
   tile per patch, with about one texel per pixel of the patch's projected size.
4. Render with gshade's integrator: R G B A and f from ``spp`` samples per pixel (box
   filter, fixed seed), then one pass through the pixel centres for the patch parameters.
5. Evaluate P and N exactly at those parameters.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import asdict, replace

import numpy as np

from .. import __version__
from ..display import Legend, auto_range
from ..errors import GshadeError
from ..geometry import patch_normals, unit_normal
from ..geometry.patch import unit_to_domain
from ..geometry.patch_groups import grid_derivatives
from ..limits import (
    MAX_SAMPLES,
    MIN_CHORD_TOLERANCE,
    gigabytes,
    memory_limit,
    render_memory,
)
from ..runtime.variant import select_variant
from ..shape import SHAPE_FUNCTIONS, get_shape_function
from .camera import frame_view
from .integrator import IntegratorSettings, make_integrator
from .rendered_image import RenderedImage
from .surface_hits import surface_hits
from .tessellate import max_chord_resolution, tessellate
from .textures import Atlas, shape_textures

__all__ = ["render"]

#: Smallest bounding-box diagonal rendered: the curvatures of smaller surfaces (1/length²)
#: and their gradients leave single precision.
MIN_EXTENT = 1e-9
#: Nearest depth, as a fraction of the bounding-box diagonal, that sets the tessellation's
#: and the textures' resolution: a camera inside the surfaces (or touching them) must not
#: ask for the finest mesh and atlas everywhere.
NEAREST_FRACTION = 1e-2
#: Bounds on the texels per patch side, and on the whole atlas.
MIN_TILE, MAX_TILE, MAX_ATLAS_TEXELS = 8, 512, 4096 * 4096
#: The most mesh vertices of an automatic tessellation.
MAX_VERTICES = 4_000_000


def _budget(pixels: int, most: int) -> int:
    """Automatic mesh vertices or atlas texels for an image: 16 per pixel (at least 2^18,
    at most ``most``); a camera close to or inside the surfaces asks for more than a small
    image can show."""
    return int(np.clip(16 * pixels, 2**18, most))


#: Units of each function's values, for legends.
UNITS = {"planar_sections": "length", "gaussian": "1/length²", "parametrisation_quality": ""}


def _units(function: str, params: dict) -> str:
    if function in UNITS:
        return UNITS[function]
    if SHAPE_FUNCTIONS[function].order == 2:
        return "1/length"
    if function == "isophotes":
        return "rad" if params.get("form") == "angle" else ""
    if function == "reflection_lines" and params.get("form") == "infinity":
        return "rad"
    return "length"


def _nearest_distance(view, lo, hi) -> float:
    """Distance from the eye to the nearest point of the bounding box along the view axis."""
    corners = np.array(
        [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    )
    depth = (corners - view.origin) @ view.forward
    return float(max(depth.min(), NEAREST_FRACTION * np.linalg.norm(hi - lo)))


def _tile_size(scene, view, patches, lo, hi) -> int:
    if scene.render.texture_resolution:
        return int(np.clip(scene.render.texture_resolution, 2, MAX_TILE))
    size = 0.0
    for p in patches:
        pts = p.points.reshape(-1, 3) if hasattr(p, "points") else p(*p.parameter_grid(5, 5))
        pts = pts.reshape(-1, 3)
        extent = float(np.linalg.norm(np.ptp(pts, axis=0)))
        depth = float((pts.mean(axis=0) - view.origin) @ view.forward)
        depth = max(depth, NEAREST_FRACTION * float(np.linalg.norm(hi - lo)))
        size = max(size, extent / view.pixel_size(depth))
    # f is smooth and interpolated bicubically from exact values and derivatives: a texel
    # every three pixels leaves errors far below what a picture (or a 1e-3 diff) shows
    tile = int(np.clip(np.ceil(size / 3) + 1, MIN_TILE, MAX_TILE))
    pixels = scene.render.width * scene.render.height
    cap = int(np.sqrt(_budget(pixels, MAX_ATLAS_TEXELS) / len(patches)))
    return max(2, min(tile, cap))


def _check_scale(where: str, lo: np.ndarray, hi: np.ndarray) -> float:
    """The bounding box's diagonal, checked to be renderable in single precision: Mitsuba
    stores positions, and gshade's textures the shape function's values, as float32."""
    diag = float(np.linalg.norm(hi - lo))
    size = float(np.abs(np.concatenate([lo, hi])).max())
    if not np.isfinite(diag) or diag < MIN_EXTENT:
        raise GshadeError(
            f"{where}: the surfaces span {diag:.3g} (bounding-box diagonal): expected at least "
            f"{MIN_EXTENT:g}, so that curvatures stay within single precision"
        )
    if diag < 1e-6 * size:
        raise GshadeError(
            f"{where}: the surfaces span {diag:.3g} at a distance {size:.3g} from the origin: "
            "expected a span of at least 1e-6 of that distance (single-precision positions)"
        )
    return diag


def _check_memory(where: str, settings, vertices: int, texels: int) -> None:
    """Refuse a render whose estimated peak memory exceeds :func:`gshade.limits.memory_limit`."""
    pixels = settings.width * settings.height
    need, limit = render_memory(pixels, vertices, texels), memory_limit()
    if need > limit:
        raise GshadeError(
            f"{where}: the render would need about {gigabytes(need)} ({settings.width} x "
            f"{settings.height} pixels, {vertices} mesh vertices, {texels} texels); the limit is "
            f"{gigabytes(limit)} (GSHADE_MEMORY_LIMIT, default 3/4 of this machine's memory)"
        )


def render(scene, **overrides) -> RenderedImage:
    """Render a scene (a :class:`gshade.io.scene.Scene` or a path) to an image.

    Keyword overrides replace ``[render]`` settings (width, height, spp, lighting, variant,
    seed, tessellation, chord_tolerance, texture_resolution); with a path, ``set`` may hold
    dotted scene keys (``{"shape.period": 0.05}``) applied before validation.
    """
    dotted = overrides.pop("set", None) or {}
    if isinstance(scene, (str, os.PathLike)):
        from ..scene import load_scene

        scene = load_scene(scene, dotted)
    elif dotted:
        raise GshadeError("set: dotted overrides need a scene path, not a loaded Scene")
    if overrides:
        from ..scene import check_render_settings

        try:
            settings = replace(scene.render, **overrides)
        except TypeError as exc:
            raise GshadeError(f"render: unknown setting ({exc})") from None
        scene = replace(scene, render=check_render_settings(settings, "render()"))
    timings: dict[str, float] = {}
    clock = time.perf_counter()

    def lap(name: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        timings[name] = now - clock
        clock = now

    settings = scene.render
    # Mitsuba's stratified sampler takes square powers of two: 1, 4, 16, 64, ... samples
    spp = 4 ** int(np.ceil(np.log(max(settings.spp, 1)) / np.log(4) - 1e-9))
    if spp != settings.spp:
        settings = replace(settings, spp=spp)
    where = str(scene.path) if scene.path is not None else scene.name
    if settings.width * settings.height * spp > MAX_SAMPLES:
        raise GshadeError(
            f"{where}: [render] width x height x spp: expected at most {MAX_SAMPLES} samples "
            f"(spp rounded up to a power of 4), got {settings.width} x {settings.height} x "
            f"{spp} = {settings.width * settings.height * spp}"
        )
    patches = scene.patches
    variant = select_variant(settings.variant)
    import drjit as dr
    import mitsuba as mi

    lap("setup")
    box = grid_derivatives(patches, np.linspace(0.0, 1.0, 17))[:, 0, 0].reshape(-1, 3)
    lo, hi = box.min(axis=0), box.max(axis=0)
    diag = _check_scale(where, lo, hi)
    view = frame_view(scene.camera, box, settings.width, settings.height)
    if settings.tessellation:
        resolution = int(settings.tessellation)
    else:
        tol = settings.chord_tolerance * diag
        if scene.camera.type == "perspective" or view.width is not None:
            tol = min(tol, 0.5 * view.pixel_size(_nearest_distance(view, lo, hi)))
        # no finer than single precision resolves (a tiny view must not ask for more)
        resolution = max_chord_resolution(patches, max(tol, MIN_CHORD_TOLERANCE * diag))
        # keep the mesh within what the image can show (a few million vertices at most)
        budget = _budget(settings.width * settings.height, MAX_VERTICES)
        resolution = min(resolution, max(2, int(np.sqrt(budget / len(patches)))))
    junctions = None
    if settings.junctions:  # measured first: overlapping surfaces fail before rendering
        from ..analysis.continuity import continuity_report

        try:
            junctions = continuity_report(list(patches))
        except GshadeError as exc:
            raise GshadeError(f"{where}: {exc}") from None
        lap("junctions")
    shape = scene.shape
    tile = _tile_size(scene, view, patches, lo, hi)
    _check_memory(where, settings, len(patches) * resolution**2, len(patches) * tile**2)
    mesh = tessellate(patches, resolution)
    if len(mesh.faces) == 0:
        raise GshadeError(
            f"{where}: [render] tessellation: {resolution} vertices per patch side leave no "
            "triangle (the patches collapse at that resolution); expected a larger value"
        )
    lap("tessellate")

    function = get_shape_function(shape.function)
    atlas = Atlas.for_patches(len(patches), tile)
    functions = [(function, shape.params_for(shape.function))]
    mapped = shape.function
    if shape.display == "both":
        mapped = shape.colour_function or shape.function
        functions.append((get_shape_function(mapped), shape.params_for(mapped)))
    tex = shape_textures(patches, atlas, functions)
    textures = {
        "values": tex.values[0],
        "twist": tex.twist[0],
        "valid": tex.valid[0],
        "position": tex.position,
        "tangent_s": tex.tangent_s,
        "tangent_t": tex.tangent_t,
        "twist_st": tex.twist_st,
    }
    if shape.display == "both":
        textures["colour_values"], textures["colour_valid"] = tex.values[1], tex.valid[1]
        textures["colour_twist"] = tex.twist[1]
    cvals, cvalid = tex.values[-1][..., 0], tex.valid[-1] > 0
    signed = SHAPE_FUNCTIONS[mapped].signed
    value_range = shape.value_range or auto_range(cvals, cvalid, signed=signed)
    f_lo, f_hi = auto_range(tex.values[0][..., 0], tex.valid[0] > 0, percentiles=(0.0, 100.0))
    period = shape.period if shape.period is not None else (f_hi - f_lo) / shape.stripes
    lut = None
    if shape.display != "stripes":
        import matplotlib

        from ..display.colour import _srgb_to_linear

        cmap = shape.colormap or ("coolwarm" if signed else "viridis")
        lut = _srgb_to_linear(matplotlib.colormaps[cmap](np.linspace(0, 1, 256))[:, :3])
    lap("textures")

    mi_mesh = mi.Mesh(
        "surface",
        len(mesh.positions),
        len(mesh.faces),
        has_vertex_normals=True,
        has_vertex_texcoords=True,
    )
    params = mi.traverse(mi_mesh)
    params["vertex_positions"] = mesh.positions.astype(np.float32).ravel()
    params["vertex_normals"] = mesh.normals.astype(np.float32).ravel()
    params["vertex_texcoords"] = atlas.texcoords(mesh.patch, mesh.params).astype(np.float32).ravel()
    params["faces"] = mesh.faces.astype(np.uint32).ravel()
    params.update()
    isettings = IntegratorSettings(
        display=shape.display,
        lighting=settings.lighting,
        period=float(period),
        duty=shape.duty,
        phase=shape.phase,
        value_range=(float(value_range[0]), float(value_range[1])),
        atlas_scale=atlas.scale,
        atlas_size=(atlas.width, atlas.height, atlas.tile),
        key_light=view.key_light(),
    )
    integrator = make_integrator(isettings, textures, lut)
    mi_scene = mi.load_dict(
        {
            "type": "scene",
            "integrator": integrator,
            # flat pictures are data: sample symmetrically so that f's pixel mean is exact for f
            # linear across the pixel; lit ones jitter (soft light needs random samples anyway)
            "sensor": view.sensor(
                mi,
                settings.spp,
                settings.seed,
                "symmetric" if settings.lighting == "flat" else "jittered",
            ),
            "surface": mi_mesh,
        }
    )
    lap("scene")
    sensor = mi_scene.sensors()[0]
    mi.render(mi_scene, seed=settings.seed, spp=settings.spp)
    image = np.array(sensor.film().bitmap(), dtype=np.float32)  # R G B A f
    lap("render")

    data_sensor = mi.load_dict(view.sensor(mi, 1, settings.seed, sampler="centre"))
    integrator.data = True  # the same textures, traced into the data kernel
    mi.render(mi_scene, sensor=data_sensor, integrator=integrator, seed=settings.seed, spp=1)
    data = np.array(data_sensor.film().bitmap(), dtype=np.float32)  # R G B A x y hit
    dr.sync_thread()
    lap("render_data")

    channels = _channels(image, data, atlas, patches, view)
    lap("exact_channels")
    broken = {c: int((~np.isfinite(a)).sum()) for c, a in channels.items()}
    broken = {c: n for c, n in broken.items() if n}
    if broken:  # a truthful picture or none: never an image with NaN in it
        raise GshadeError(
            f"{where}: the render gave non-finite values ("
            + ", ".join(f"{n} pixels of {c}" for c, n in broken.items())
            + "): the surface data or shape parameters lie outside what gshade evaluates"
        )
    if junctions is not None:
        from ..analysis.junction_lines import draw_junctions

        channels = draw_junctions(channels, junctions, [p.domain for p in patches])
        lap("junctions")
    legend = Legend(
        function=shape.function,
        order=function.order,
        display=shape.display,
        value_range=None if shape.display == "stripes" else tuple(value_range),
        colormap=None if lut is None else (shape.colormap or ("coolwarm" if signed else "viridis")),
        period=None if shape.display == "colormap" else float(period),
        duty=None if shape.display == "colormap" else shape.duty,
        stripe_function=shape.function if shape.display == "both" else None,
        units=_units(mapped, shape.params_for(mapped)),
    )
    metadata = {
        "gshade_version": __version__,
        "scene_name": scene.name,
        "scene_hash": scene.text_hash,
        "variant": variant,
        "settings": json.dumps(
            {
                "render": asdict(settings),
                "shape": _jsonable(asdict(shape)),
                "camera": {
                    "type": view.type,
                    "origin": view.origin.tolist(),
                    "target": view.target.tolist(),
                    "up": view.up.tolist(),
                    "fov": view.fov,
                    "width": view.width,
                },
                "tessellation": resolution,
                "texture_tile": atlas.tile,
            },
            sort_keys=True,
        ),
        "legend": legend.text(),
    }
    if junctions is not None:
        from ..analysis.junction_lines import junction_metadata

        metadata["junctions"] = junction_metadata(junctions)
    return RenderedImage(channels, metadata, legend, timings)


def _jsonable(x):
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    return x


def _channels(image: np.ndarray, data: np.ndarray, atlas: Atlas, patches, view) -> dict:
    """The EXR channels: the picture, coverage and f from the samples; P, N, u, v and the
    patch index where the ray through the pixel centre meets the exact surface."""
    H, W = image.shape[:2]
    A = image[..., 3]
    f = np.where(A > 0, image[..., 4] / np.where(A > 0, A, 1.0), 0.0)
    hit = np.flatnonzero(data[..., 6].ravel() > 0.5)
    patch_index, st = atlas.locate(data[..., 4:6].reshape(-1, 2)[hit].astype(np.float64))
    domains = np.array([p.domain for p in patches], dtype=np.float64)[patch_index]
    u, v = unit_to_domain(domains, st[:, 0], st[:, 1])
    u, v, d, _ = surface_hits(patches, patch_index, u, v, *view.pixel_rays(hit // W, hit % W))
    normal = unit_normal(d)
    n = normal.n
    if not normal.regular.all():  # limits at collapsed edges need higher derivatives
        irr = np.flatnonzero(~normal.regular)
        for k in np.unique(patch_index[irr]):
            at = irr[patch_index[irr] == k]
            n[at] = patch_normals(patches[k], u[at], v[at]).n
    P = np.zeros((H * W, 3))
    N = np.zeros((H * W, 3))
    U = np.zeros(H * W)
    V = np.zeros(H * W)
    patch_of = np.full(H * W, -1.0)
    P[hit], N[hit], U[hit], V[hit], patch_of[hit] = d[0, 0], n, u, v, patch_index
    P, N = P.reshape(H, W, 3), N.reshape(H, W, 3)
    U, V = U.reshape(H, W), V.reshape(H, W)
    out = {"R": image[..., 0], "G": image[..., 1], "B": image[..., 2], "A": A, "f": f}
    for name, arr in (("P", P), ("N", N)):
        for c, axis in enumerate("XYZ"):
            out[f"{name}.{axis}"] = arr[..., c]
    out["u"], out["v"] = U, V
    out["patch"] = patch_of.reshape(H, W)
    return {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in out.items()}
