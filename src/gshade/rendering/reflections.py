"""Studio reflections: the ``environment`` shape function's map, the textures it is drawn
from, and its exact channels.

The surface is a mirror: at a point with unit normal n seen along the unit ray direction v,
it reflects the world direction ``r = v - 2 <v, n> n`` (Kiciak's reflection lines are the
case of a map of stripes at infinity, Section 6.2).  The renderer
(:class:`gshade.rendering.integrator.ShapeIntegrator`) draws it per sample from the exact
normal, interpolated from textures of n's three components (:func:`normal_functions`: n's
jets, exact at the texels), and reads the map in gshade's latitude-longitude convention
(:mod:`gshade.rendering.environment_maps`) as the exact mean over the sample's footprint
(a summed-area table: deterministic, anti-aliased, no speckle at any ``spp``; a footprint
under a texel reads a one-texel box, which is bilinear interpolation of the texels).  A
reflected ray that meets the surface itself shows :data:`OCCLUDED`.  With ``roughness`` > 0
the surface is a glossy conductor: Mitsuba's ``roughconductor`` (GGX) samples the reflected
directions.

The exact channels (:func:`reflection_channels`): ``refl.X``, ``refl.Y``, ``refl.Z``, the
unit reflection direction r at the point where the ray through the pixel centre meets the
exact surface (from the exact normal N there), and ``f``, the map's luminance
(:data:`LUMINANCE`) in that direction (the texels bilinearly interpolated; the surface's
occlusion of itself is the picture's alone).

References
----------
.. [1] P. Kiciak, *Geometric Continuity of Curves and Surfaces*, Morgan & Claypool, 2016,
   Section 6.2 (reflection lines).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..shape import ShapeFunction, get_shape_function
from ..shape.functions import LIGHTBOX
from .environment_files import read_environment_map
from .environment_maps import SummedArea, direction_to_map, lightbox

if TYPE_CHECKING:
    from .camera import View

__all__ = [
    "LIGHTBOX_WIDTH",
    "LUMINANCE",
    "OCCLUDED",
    "REFLECTION_CHANNELS",
    "Environment",
    "environment",
    "normal_functions",
    "reflection_channels",
    "reflection_directions",
    "view_directions",
]

#: The built-in lightbox's width in texels (0.35 degrees a texel).
LIGHTBOX_WIDTH = 1024
#: Rec. 709 luminance weights of linear RGB: f = <LUMINANCE, colour>.
LUMINANCE = (0.2126, 0.7152, 0.0722)
#: The linear colour a reflected ray shows where it meets the surface itself.
OCCLUDED = (0.01, 0.01, 0.01)
#: The EXR channels of the reflection direction, after N's.
REFLECTION_CHANNELS = ("refl.X", "refl.Y", "refl.Z")


@dataclass(frozen=True)
class Environment:
    """An environment map (H, W = 2H, 3) float32 linear RGB, turned ``rotation`` degrees
    about +z, reflected by a surface of GGX ``roughness`` (0: a mirror); ``name`` says which
    (legends)."""

    map: NDArray[np.float32]
    rotation: float = 0.0
    roughness: float = 0.0
    name: str = LIGHTBOX
    summed: SummedArea = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "summed", SummedArea(self.map))

    @property
    def width(self) -> int:
        return int(self.map.shape[1])

    @property
    def height(self) -> int:
        return int(self.map.shape[0])

    def radiance(self, r: NDArray) -> NDArray[np.float64]:
        """The map's colour (N, 3) in the directions r (N, 3): its texels bilinearly
        interpolated (a one-texel box)."""
        c, row = direction_to_map(r, self.width, self.height, self.rotation)
        return self.summed.point(c, row)

    def describe(self) -> str:
        """The legend's phrase: what is reflected, and how."""
        surface = (
            "mirror" if self.roughness == 0 else f"glossy conductor (GGX alpha {self.roughness:g})"
        )
        turned = f", turned {self.rotation:g} deg about +z" if self.rotation else ""
        return f"{surface} reflecting {self.name}{turned}"


@lru_cache(maxsize=4)
def _lightbox(strips: int, strip_width: float) -> NDArray[np.float32]:
    m = lightbox(strips, strip_width, LIGHTBOX_WIDTH)
    m.flags.writeable = False
    return m


def environment(params: dict[str, Any]) -> Environment:
    """The environment a render's checked ``environment`` parameters name: the lightbox
    (:func:`gshade.rendering.environment_maps.lightbox` of ``strips`` and ``strip_width``,
    :data:`LIGHTBOX_WIDTH` texels wide) or the map file ``map``
    (:func:`gshade.rendering.environment_files.read_environment_map`).

    Raises
    ------
    GshadeError
        One line naming the map file: missing, unreadable, not a lat-long map.

    Examples
    --------
    >>> env = environment({"map": "lightbox", "rotation": 0.0, "roughness": 0.0,
    ...                    "strips": 5, "strip_width": 8.0})
    >>> env.map.shape, env.describe()
    ((512, 1024, 3), 'mirror reflecting lightbox (5 strips, 8 deg wide)')
    """
    rotation, roughness = float(params["rotation"]), float(params["roughness"])
    if params["map"] == LIGHTBOX:
        strips, width = int(params["strips"]), float(params["strip_width"])
        name = f"lightbox ({strips} strip{'' if strips == 1 else 's'}, {width:g} deg wide)"
        return Environment(_lightbox(strips, width), rotation, roughness, name)
    path = Path(os.fspath(params["map"]))
    return Environment(read_environment_map(path), rotation, roughness, path.name)


def normal_functions() -> list[tuple[ShapeFunction, dict[str, Any]]]:
    """The functions whose textures the renderer draws a reflection from: the unit normal's
    components n_x, n_y, n_z (isophotes ``<n, e_k>`` of the axes, with their exact slopes)."""
    isophotes = get_shape_function("isophotes")
    return [(isophotes, {"light": tuple(axis), "form": "cos"}) for axis in np.eye(3)]


def reflection_directions(directions: NDArray, normals: NDArray) -> NDArray[np.float64]:
    """r = v - 2 <v, n> n of unit view directions v (N, 3) at unit normals n (N, 3) (either
    side: r is the same for -n).

    Examples
    --------
    >>> reflection_directions(np.array([[0.6, 0.0, -0.8]]), np.array([[0.0, 0.0, 1.0]]))
    array([[0.6, 0. , 0.8]])
    """
    v = np.asarray(directions, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    return v - 2.0 * np.einsum("ij,ij->i", v, n)[:, None] * n


def view_directions(view: View, points: NDArray) -> NDArray[np.float64]:
    """The unit directions (N, 3) in which the eye sees ``points`` (N, 3): from the eye
    (a perspective view) or the view's forward direction (orthographic)."""
    if view.type == "orthographic":
        return np.broadcast_to(view.forward, points.shape).astype(np.float64)
    v = points - view.origin
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def reflection_channels(
    channels: dict[str, NDArray[np.float32]], view: View, env: Environment
) -> dict[str, NDArray[np.float32]]:
    """The channels with ``f`` and ``refl.X/Y/Z`` at the pixels the centre rays hit (patch
    >= 0): r from the exact normal N at the exact point P seen from the eye
    (:func:`view_directions`), f the map's luminance
    there (0 off the surface); f goes before ``f.mean``, r after ``N.Z``."""
    H, W = channels["patch"].shape
    at = np.flatnonzero(channels["patch"].ravel() >= 0)
    normals = np.stack([channels[f"N.{a}"].ravel()[at] for a in "XYZ"], -1).astype(np.float64)
    points = np.stack([channels[f"P.{a}"].ravel()[at] for a in "XYZ"], -1).astype(np.float64)
    r = reflection_directions(view_directions(view, points), normals)
    r /= np.linalg.norm(r, axis=1, keepdims=True)
    f = env.radiance(r) @ np.asarray(LUMINANCE)
    made = {"f": f, **{name: r[:, k] for k, name in enumerate(REFLECTION_CHANNELS)}}
    images = {}
    for name, values in made.items():
        image = np.zeros(H * W, np.float32)
        image[at] = values
        images[name] = image.reshape(H, W)
    out: dict[str, NDArray[np.float32]] = {}
    for name, image in channels.items():
        if name == "f.mean":
            out["f"] = images["f"]
        out[name] = image
        if name == "N.Z":
            out.update({c: images[c] for c in REFLECTION_CHANNELS})
    return out
