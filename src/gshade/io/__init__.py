"""Reading and writing: surface data formats, scene files and images."""

from .image import linear_to_srgb, read_exr, write_exr, write_png
from .newell import parse_newell, read_newell
from .obj import ObjMesh, parse_obj, read_obj, read_obj_mesh
from .scene import (
    Camera,
    RenderSettings,
    Scene,
    Shape,
    Surface,
    load_scene,
    parse_overrides,
    parse_scene,
)

__all__ = [
    "Camera",
    "ObjMesh",
    "RenderSettings",
    "Scene",
    "Shape",
    "Surface",
    "linear_to_srgb",
    "load_scene",
    "parse_newell",
    "parse_obj",
    "parse_overrides",
    "parse_scene",
    "read_exr",
    "read_newell",
    "read_obj",
    "read_obj_mesh",
    "write_exr",
    "write_png",
]
