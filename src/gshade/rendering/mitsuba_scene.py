"""The Mitsuba side of a render: the mesh, the two integrators, the scene and its passes.

The shape pass renders R G B A and f with ``spp`` samples per pixel (box filter, fixed
seed); the data pass sends one ray through each pixel centre for the atlas coordinates of
the surface point it meets (see :mod:`gshade.rendering.integrator`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .atlas import Atlas
from .camera import View
from .integrator import IntegratorSettings, make_integrators
from .style import DisplayStyle
from .tessellate import TriangleMesh
from .textures import ShapeTextures

__all__ = ["MitsubaScene", "mitsuba_scene", "render_data", "render_shape"]


@dataclass(frozen=True)
class MitsubaScene:
    """A loaded Mitsuba scene (mesh, sensor, shape integrator) and the data integrator."""

    scene: Any
    data_integrator: Any


def _mesh(mi, mesh: TriangleMesh, atlas: Atlas):
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
    settings,
    shape,
) -> MitsubaScene:
    """The scene of the mesh seen by the view's sensor, with both integrators configured
    from the textures and the display style (``settings``: ``[render]``, ``shape``:
    ``[shape]``)."""
    import mitsuba as mi

    integrator_settings = IntegratorSettings(
        display=shape.display,
        lighting=settings.lighting,
        period=float(style.period),
        duty=shape.duty,
        phase=shape.phase,
        value_range=(float(style.value_range[0]), float(style.value_range[1])),
        atlas=atlas,
        key_light=view.key_light(),
    )
    shape_integrator, data_integrator = make_integrators(integrator_settings, tex, style.lut)
    scene = mi.load_dict(
        {
            "type": "scene",
            "integrator": shape_integrator,
            # sample symmetrically (strata centres, no random numbers) so that f's pixel mean
            # is exact for f linear across the pixel and flat and lit pictures are the same
            # in every variant; soft light jitters (it needs random samples anyway)
            "sensor": view.sensor(
                mi,
                settings.spp,
                settings.seed,
                "jittered" if settings.lighting == "soft" else "symmetric",
            ),
            "surface": _mesh(mi, mesh, atlas),
        }
    )
    return MitsubaScene(scene, data_integrator)


def render_shape(scene: MitsubaScene, settings) -> NDArray[np.float32]:
    """The shape pass: the film (H, W, 5), channels
    :data:`gshade.rendering.integrator.SHAPE_FILM`."""
    import mitsuba as mi

    sensor = scene.scene.sensors()[0]
    mi.render(scene.scene, seed=settings.seed, spp=settings.spp)
    return np.array(sensor.film().bitmap(), dtype=np.float32)


def render_data(scene: MitsubaScene, view: View, settings) -> NDArray[np.float32]:
    """The data pass, one ray through each pixel centre: the film (H, W, 7), channels
    :data:`gshade.rendering.integrator.DATA_FILM`."""
    import drjit as dr
    import mitsuba as mi

    sensor = mi.load_dict(view.sensor(mi, 1, settings.seed, sampler="centre"))
    mi.render(
        scene.scene, sensor=sensor, integrator=scene.data_integrator, seed=settings.seed, spp=1
    )
    data = np.array(sensor.film().bitmap(), dtype=np.float32)
    dr.sync_thread()
    return data
