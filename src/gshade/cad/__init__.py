"""CAD models as exact faces: the model (:mod:`.model`), the readers by file extension
(:mod:`.readers`; Open CASCADE in :mod:`.occt`, Rhino in :mod:`.rhino`), the kernel in a
bounded child process (:mod:`.process`, :mod:`.zygote`), reads kept by content
(:mod:`.cache`), the watertight mesh (:mod:`.mesh`) and the edges shared by faces
(:mod:`.edges`).

Importing this package loads no CAD library: the readers import theirs when they read.
"""

from .model import (
    CadFace,
    CadModel,
    LeftOutFace,
    arc_map,
    faces_bounds,
    no_usable_face,
    strict_refusal,
    trimmed_points,
    usable,
)
from .readers import CAD_EXTENSIONS, INSTALL, READERS, Reader, in_scene, read_cad, reader_module

__all__ = [
    "CAD_EXTENSIONS",
    "INSTALL",
    "READERS",
    "CadFace",
    "CadModel",
    "LeftOutFace",
    "Reader",
    "arc_map",
    "faces_bounds",
    "in_scene",
    "no_usable_face",
    "read_cad",
    "reader_module",
    "strict_refusal",
    "trimmed_points",
    "usable",
]
