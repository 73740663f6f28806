"""The ``[[surface]]`` types read from quad meshes and CAD models: ``subdivision`` (the
Catmull–Clark surface of an OBJ mesh), ``hole`` (the same with the holes around its
extraordinary vertices filled) and ``cad`` (the trimmed faces of a STEP, IGES, BREP or 3dm
model).  Registered in :mod:`.surfaces`' registry like every type.
"""

from __future__ import annotations

import weakref
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import GshadeError
from ..geometry import BSplinePatch, Patch
from ..geometry.holes.energy import DOMAINS, FUNCTIONALS
from ..geometry.holes.fairing import FAIRING_FUNCTIONALS
from ..geometry.holes.fairing_cache import optimise_filling
from ..geometry.holes.fill import JUNCTIONS
from ..geometry.holes.surface import filled_surface
from ..geometry.subdivision.stam import subdivision_patches
from ..limits import MAX_HOLE_MESH_FACES, MAX_HOLES, MAX_PATCHES, MAX_SUBDIVISION_LEVELS
from .data_files import DataFiles
from .model import CadFaces
from .surfaces import surface_type
from .tables import REQUIRED, Key, Table, alternatives, is_int, show

__all__ = ["CAD_RENDERED"]


@surface_type(
    "subdivision",
    "the Catmull–Clark surface of a quad mesh",
    Key("file", "path", REQUIRED, "the mesh in OBJ, relative to the scene file"),
    Key(
        "levels",
        f"integer 0–{MAX_SUBDIVISION_LEVELS}",
        0,
        "refinements before the patches are made (each multiplies them by 4)",
    ),
)
def _build_subdivision(t: Table, files: DataFiles) -> list[Patch]:
    levels = t.integer("levels", minimum=None)  # >= 0: subdivision_patches checks it
    if levels > MAX_SUBDIVISION_LEVELS:
        raise t.error(
            "levels",
            f"expected an integer from 0 to {MAX_SUBDIVISION_LEVELS} (each level multiplies "
            f"the patches by 4), got {show(t.data['levels'])}",
        )
    mesh, source = _quad_mesh(t, files)
    if len(mesh.faces) * 4**levels > MAX_PATCHES:
        raise t.error(
            "levels",
            f"expected at most {MAX_PATCHES} patches, got {len(mesh.faces)} faces x "
            f"4^{levels} levels = {len(mesh.faces) * 4**levels}",
        )
    with t.reported():
        return subdivision_patches(
            mesh.vertices, mesh.faces, levels=levels, source=source, face_lines=mesh.face_lines
        )


def _quad_mesh(t: Table, files: DataFiles) -> tuple[Any, str]:
    """The OBJ quad mesh the table's ``file`` names, and its path for messages."""
    from ..io.obj import read_obj_mesh

    name = t.string("file", expected="a path to an OBJ file (a quad mesh)")
    data_file = files.find(t, name)
    with t.reported():
        return read_obj_mesh(data_file), str(data_file)


@surface_type(
    "hole",
    "a Catmull–Clark surface with the holes around its extraordinary vertices filled G1 or G2",
    Key("file", "path", REQUIRED, "the mesh in OBJ, relative to the scene file"),
    Key("continuity", alternatives(tuple(JUNCTIONS)), "G2", "the fillings' continuity"),
    Key(
        "functional",
        alternatives(tuple(FUNCTIONALS)),
        None,
        "the quadratic functional minimised",
        '"thin-plate" (G1), "third-order" (G2)',
    ),
    Key("domain", alternatives(DOMAINS), "square", "the domain the functional is taken over"),
    Key(
        "optimise",
        alternatives(tuple(FAIRING_FUNCTIONALS)),
        None,
        "a measure on the surface lowered",
        "none",
    ),
    Key("iterations", "integer 1–100", 10, "the most Gauss–Newton steps of optimise"),
)
def _build_hole(t: Table, files: DataFiles) -> list[Patch]:
    continuity = t.choice("continuity", tuple(JUNCTIONS))
    functional = t.choice("functional", tuple(FUNCTIONALS))
    domain = t.choice("domain", DOMAINS)
    optimise = t.choice("optimise", tuple(FAIRING_FUNCTIONALS))
    iterations = t.integer("iterations", minimum=1, maximum=100)
    mesh, source = _quad_mesh(t, files)
    if len(mesh.faces) > MAX_HOLE_MESH_FACES:
        raise t.error(
            "file",
            f"expected a mesh of at most {MAX_HOLE_MESH_FACES} faces (it may be refined twice "
            f"before its holes are filled), got {len(mesh.faces)}",
        )
    # vertices in 3 or more faces but not 4: at least every interior extraordinary vertex
    corners = [np.asarray(f, dtype=np.int64) for f in mesh.faces]
    counts = np.bincount(np.concatenate(corners)) if corners else np.zeros(0, np.int64)
    irregular = int(np.count_nonzero((counts >= 3) & (counts != 4)))
    if irregular > MAX_HOLES:
        raise t.error(
            "file",
            f"expected at most {MAX_HOLES} extraordinary vertices (holes to fill), got {irregular}",
        )
    with t.reported():
        surface = filled_surface(
            mesh.vertices,
            mesh.faces,
            continuity,
            functional,
            domain=domain,
            source=source,
            face_lines=mesh.face_lines,
        )
        if optimise is not None:
            fillings = [
                optimise_filling(f, optimise, iterations=iterations) for f in surface.fillings
            ]
            surface = surface.with_fillings(fillings)
        return surface.patches


#: The CAD files a ``cad`` surface renders.
CAD_RENDERED = (".step", ".stp", ".iges", ".igs", ".brep", ".3dm")


def _swapped(patch: BSplinePatch) -> BSplinePatch:
    """The same surface with u and v swapped: its p_u x p_v is the original's -(p_u x p_v)."""
    weights = None if patch.weights is None else np.swapaxes(patch.weights, 0, 1)
    points = np.swapaxes(patch.points, 0, 1)
    return BSplinePatch(points, patch.degree[::-1], patch.knots[::-1], weights)


def _clipped(box: Any, dom: Any) -> tuple[tuple[float, float], tuple[float, float]]:
    """A face's parameter box clipped into its patch's domain."""
    (u0, u1), (v0, v1) = box
    (a0, a1), (b0, b1) = dom
    return (max(u0, a0), min(u1, a1)), (max(v0, b0), min(v1, b1))


def over_box(face: Any) -> Any:
    """A CAD face's surface as a patch over the face's parameter box.

    Where the box (its trims) reaches past the surface's domain, by a file's tolerance, the
    end pieces are continued (:meth:`gshade.geometry.BSplinePatch.restricted` with
    ``beyond``), as the kernel, the edge sampler and the mesh's vertices evaluate the face
    there: a sliver past the domain is shaded from the surface it is on.  Should the
    continued pieces not be a surface (a rational piece whose weights cross zero), the box is
    clipped to the domain instead.
    """
    try:
        return face.patch.restricted(face.box, beyond=True)
    except GshadeError:
        return face.patch.restricted(_clipped(face.box, face.patch.domain))


#: What :func:`_scene_patches` made of each CAD face, by ``id``, while the face lives:
#: (a weak reference to it, (its scene patch or None, why not, what was tried)).
_MADE: dict[int, tuple[weakref.ref, tuple[Any, str, str]]] = {}


def _scene_patches(faces: list) -> list[tuple[Any, str, str]]:
    """Per CAD face, the patch a scene renders (:func:`over_box`, u and v swapped on a
    reversed face: p_u x p_v then points outward), or None, why not and what was tried (no
    patch over its box; a degenerate surface, all faces checked at once).

    Kept per face while it lives: the next scene of the same model (a batch worker's, a
    sweep's: :func:`gshade.cad.cache.find_model` gives the same faces) renders the same
    patch objects, so that neither they nor what is kept per patch (its Bézier cells) is
    made again."""
    from ..geometry.evaluation.regularity import degenerate_patches

    out: dict[int, tuple[Any, str, str]] = {}
    boxed: list[tuple[int, BSplinePatch]] = []
    for k, face in enumerate(faces):
        kept = _MADE.get(id(face))
        if kept is not None and kept[0]() is face:
            out[k] = kept[1]
            continue
        try:
            boxed.append((k, over_box(face)))
        except GshadeError as exc:
            out[k] = (None, str(exc), "restricting its surface to its box")
    bad = dict(degenerate_patches([patch for _, patch in boxed]))  # all faces at once
    for j, (k, patch) in enumerate(boxed):
        if j in bad:
            out[k] = (None, bad[j], "checking its surface")
        else:
            out[k] = (_swapped(patch) if faces[k].reversed else patch, "", "")
        _keep(faces[k], out[k])
    return [out[k] for k in range(len(faces))]


def _keep(face: Any, made: tuple[Any, str, str]) -> None:
    """Keep what was made of ``face`` in :data:`_MADE` until the face is gone."""
    key = id(face)

    def gone(ref: weakref.ref) -> None:
        if _MADE.get(key, (None,))[0] is ref:
            del _MADE[key]

    _MADE[key] = (weakref.ref(face, gone), made)


@surface_type(
    "cad",
    "the trimmed faces of a CAD model (STEP, IGES, BREP, Rhino 3dm), exact, meshed by the kernel",
    Key(
        "file",
        "path (.step .stp .iges .igs .brep .3dm)",
        REQUIRED,
        "the model, relative to the scene file",
    ),
    Key("faces", "list of face numbers (0-based)", None, "the faces rendered", "all"),
    Key("sew", "true or false", None, "sew the faces into shells first", "when unsewn"),
    Key("tolerance", "number > 0", None, "the sewing tolerance (model units)", "from the size"),
    Key(
        "strict",
        "true or false",
        None,
        "a face that cannot be rendered (left out, with a warning, by default) is an error",
        "false",
    ),
)
def _build_cad(t: Table, files: DataFiles) -> tuple[list[Patch], CadFaces]:
    from ..cad import LeftOutFace, in_scene, read_cad, strict_refusal

    name = t.string("file", expected="a path to a STEP, IGES, BREP or 3dm file")
    suffix = Path(name).suffix.lower()
    if suffix not in CAD_RENDERED:
        raise t.error(
            "file",
            f"expected a CAD file ({' '.join(CAD_RENDERED)}), got {show(name)}",
        )
    faces = t.raw("faces")
    if faces is not None and not (
        isinstance(faces, list) and faces and all(is_int(i) and i >= 0 for i in faces)
    ):
        raise t.error(
            "faces", f"expected a list of face numbers (integers >= 0), got {show(faces)}"
        )
    sew = None if "sew" not in t.data else t.boolean("sew")
    tolerance = None if "tolerance" not in t.data else t.number("tolerance", lo=0)
    strict = "strict" in t.data and t.boolean("strict")
    data_file = files.find(t, name)
    try:
        model = read_cad(data_file, sew=sew, tolerance=tolerance)
    except GshadeError as exc:
        raise in_scene(exc, f"{t.file}: {t.prefix}".rstrip(": "), t.file, data_file) from None
    count = model.face_count
    for i in [] if faces is None else [int(i) for i in faces]:
        if i >= count:
            raise t.error(
                "faces",
                f"expected face numbers from 0 to {count - 1} ({data_file.name} has {count} "
                f"faces), got {i}",
            )
    usable = {face.index: face for face in model.faces}
    asked = list(usable) if faces is None else list(dict.fromkeys(int(i) for i in faces))
    left_out = [f for f in model.left_out if faces is None or f.index in asked]
    chosen = [i for i in asked if i in usable]
    if len(chosen) > MAX_PATCHES:
        raise t.error("faces", f"expected at most {MAX_PATCHES} faces, got {len(chosen)}")
    made = _scene_patches([usable[i] for i in chosen])
    patches: list[Patch] = []
    swapped = []
    rendered = []
    for i, (patch, why, tried) in zip(chosen, made, strict=True):
        if patch is None:
            left_out.append(LeftOutFace(i, why, tried))
            continue
        patches.append(patch)
        swapped.append(bool(usable[i].reversed))
        rendered.append(i)
    left_out.sort(key=lambda f: f.index)
    where = f"{t.file}: {t.prefix}".rstrip(": ")
    if left_out and strict:
        raise in_scene(strict_refusal(data_file, left_out), where, t.file, data_file)
    if not rendered:
        raise in_scene(
            GshadeError(f"{data_file}: no usable face among those chosen ({left_out[0].line()})"),
            where,
            t.file,
            data_file,
        )
    return patches, CadFaces(model, tuple(rendered), tuple(swapped), tuple(left_out), strict)
