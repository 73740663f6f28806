"""The Mitsuba side of a render: the mesh, the integrator, the scene and its passes.

The centre pass sends one ray through each pixel centre (its footprint the whole pixel): the
picture, and the atlas coordinates of the surface point it meets, where the picture is
discontinuous (see :mod:`gshade.rendering.integrator`).  The supersampling pass renders
``spp`` samples per pixel (box filter, at the strata centres) at the pixels listed, or at
every pixel (:func:`render_uniform`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..runtime.llvm import import_drjit
from ..runtime.variant import mitsuba
from ..scene.model import RenderSettings, Shape
from .atlas import Atlas
from .camera import View
from .integrator import IntegratorSettings, make_integrator
from .pixel_sensor import pixel_list_sensor
from .reflections import Environment
from .style import DisplayStyle
from .tessellate import TriangleMesh
from .textures import ShapeTextures

__all__ = [
    "MitsubaScene",
    "mitsuba_scene",
    "render_centres",
    "render_pixels_of",
    "render_uniform",
]


@dataclass(frozen=True)
class MitsubaScene:
    """A loaded Mitsuba scene (mesh, camera with its ``spp`` sampler, integrator);
    ``glossy``: whether its picture is a glossy reflection's (random: see
    :mod:`gshade.rendering.glossy`)."""

    scene: Any
    sampler: dict
    glossy: bool = False


def _mesh(mi: Any, mesh: TriangleMesh, atlas: Atlas) -> Any:
    """The Mitsuba mesh: positions, normals, faces, and texture coordinates in the atlas."""
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
    return mi_mesh


def mitsuba_scene(
    mesh: TriangleMesh,
    atlas: Atlas,
    tex: ShapeTextures,
    style: DisplayStyle,
    view: View,
    settings: RenderSettings,
    shape: Shape,
    environment: Environment | None = None,
) -> MitsubaScene:
    """The scene of the mesh seen by the view's sensor, with both integrators configured
    from the textures and the display style (``settings``: ``[render]``, ``shape``:
    ``[shape]``)."""
    mi = mitsuba()

    integrator_settings = IntegratorSettings(
        display=shape.display if environment is None else "reflection",
        lighting=settings.lighting,
        period=float(style.period),
        duty=shape.duty,
        phase=shape.phase,
        value_range=(float(style.value_range[0]), float(style.value_range[1])),
        atlas=atlas,
        key_light=view.key_light(),
        bands=style.bands,
        parabolic=settings.parabolic,
        environment=environment,
    )
    random = settings.lighting == "soft" or (environment is not None and environment.roughness > 0)
    sensor = view.sensor(mi, settings.spp, settings.seed, "jittered" if random else "symmetric")
    scene = mi.load_dict(
        {
            "type": "scene",
            "integrator": make_integrator(integrator_settings, tex, style.lut),
            # sample symmetrically (strata centres, no random numbers) so that f's pixel mean
            # is exact for f linear across the pixel and flat and lit pictures are the same
            # in every variant; soft light and a glossy reflection jitter (they need random
            # samples anyway)
            "sensor": sensor,
            "surface": _mesh(mi, mesh, atlas),
        }
    )
    return MitsubaScene(
        scene, sensor["sampler"], environment is not None and environment.roughness > 0
    )


def render_centres(
    scene: MitsubaScene, view: View, settings: RenderSettings
) -> NDArray[np.float32]:
    """The centre pass, one ray through each pixel centre: the film (H, W, channels),
    channels :data:`gshade.rendering.integrator.SHAPE_FILM`."""
    mi = mitsuba()

    sensor = mi.load_dict(view.sensor(mi, 1, settings.seed, sampler="centre"))
    mi.render(scene.scene, sensor=sensor, seed=settings.seed, spp=1)
    return _developed(sensor)


def render_pixels_of(
    scene: MitsubaScene, view: View, settings: RenderSettings, pixels: NDArray[np.int64]
) -> NDArray[np.float32]:
    """The supersampling pass at ``pixels`` (flat indices): (n, channels), ``spp`` samples
    each, the values a render of the whole film would give there."""
    mi = mitsuba()

    camera = scene.scene.sensors()[0]
    width, height = view.image_width, view.image_height
    sensor = pixel_list_sensor(camera, pixels, width, height, scene.sampler)
    mi.render(scene.scene, sensor=sensor, seed=settings.seed, spp=settings.spp)
    film = _developed(sensor)
    return film.reshape(-1, film.shape[-1])[: len(pixels)]


def render_uniform(scene: MitsubaScene, settings: RenderSettings) -> NDArray[np.float32]:
    """The supersampling pass at every pixel: the film (H, W, channels)."""
    mi = mitsuba()

    mi.render(scene.scene, seed=settings.seed, spp=settings.spp)
    return _developed(scene.scene.sensors()[0])


def _developed(sensor: Any) -> NDArray[np.float32]:
    """The sensor's film as a numpy array (H, W, channels); Dr.Jit's memory of the render
    handed back to the system, so that what follows in numpy does not add to it."""
    dr = import_drjit()

    film = np.asarray(sensor.film().develop())  # a view of Dr.Jit's float32 array, no copy
    dr.sync_thread()
    dr.flush_malloc_cache()
    return film
