"""Scene files (TOML): the surfaces, the shape function and its display, camera and render.

``gshade keys`` (:func:`~gshade.scene.keys.scene_keys`) lists every table and key, what it
accepts, its default and its meaning, from the same declarations the parsers use; the
docs/reference/scene_files.rst shows them as a commented file.

Every error is a :class:`~gshade.errors.GshadeError` whose one-line message names the
file, the table and key, what was expected and what was found, e.g.
``scene.toml: [camera] fov: expected a number in (0, 180), got "wide"``.

Modules: :mod:`.model` (the validated scene), :mod:`.tables` (TOML files, typed table
access and key declarations), :mod:`.surfaces` (the surface types), :mod:`.data_files`
(where data files may lie), :mod:`.sections` (the other tables), :mod:`.overrides` (dotted
keys set before validation), :mod:`.load` (reading a file), :mod:`.discovery` (the scene
files a folder or a pattern names), :mod:`.keys` (the reference).
"""

from .data_files import DATA_PATH_VARIABLE
from .load import load_scene, parse_scene
from .model import (
    CAMERA_TYPES,
    DISPLAYS,
    LIGHTINGS,
    SAMPLINGS,
    VARIANTS,
    Camera,
    RenderSettings,
    Scene,
    Shape,
    Surface,
    validate_view,
)
from .overrides import parse_overrides
from .sections import validate_render_settings
from .surfaces import SURFACE_TYPES

__all__ = [
    "CAMERA_TYPES",
    "DATA_PATH_VARIABLE",
    "DISPLAYS",
    "LIGHTINGS",
    "SAMPLINGS",
    "SURFACE_TYPES",
    "VARIANTS",
    "Camera",
    "RenderSettings",
    "Scene",
    "Shape",
    "Surface",
    "load_scene",
    "parse_overrides",
    "parse_scene",
    "validate_render_settings",
    "validate_view",
]
