"""Reading and writing: surface data formats (Newell's teapot format, OBJ meshes), images
(EXR, PNG), input files and checked, staged outputs.  Scene files are :mod:`gshade.scene`."""

from .image import linear_to_srgb, read_exr, write_exr, write_png
from .newell import parse_newell, read_newell
from .obj import ObjMesh, parse_obj, read_obj, read_obj_mesh

__all__ = [
    "ObjMesh",
    "linear_to_srgb",
    "parse_newell",
    "parse_obj",
    "read_exr",
    "read_newell",
    "read_obj",
    "read_obj_mesh",
    "write_exr",
    "write_png",
]
