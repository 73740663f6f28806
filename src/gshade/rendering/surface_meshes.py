"""The render mesh of a scene, each surface meshed by the mesher registered for its body
(:mod:`gshade.scene.bodies`): patches exact over their domains on the common
(resolution x resolution) grid, all at once; a CAD model's trimmed faces by the kernel's
mesher within the chord tolerance (:func:`gshade.rendering.tessellate.tessellate_faces`).
The parts are joined in the scene's patch order (:func:`~gshade.rendering.tessellate.join_meshes`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from ..scene.bodies import CadFaces, PatchBody
from ..scene.model import Scene
from .tessellate import TriangleMesh, tessellate, tessellate_faces

__all__ = ["MESHERS", "MeshPart", "Mesher", "gridded_patches", "mesh_parts", "planned_vertices"]


@dataclass
class MeshPart:
    """A part of the render mesh: its triangles, the scene's index of each of its patches,
    and what its mesher said: the faces it left without triangles ((file,
    :class:`gshade.cad.LeftOutFace`) each) and its notes ((file, line) each)."""

    mesh: TriangleMesh
    index: NDArray[np.int32]
    lost: list[tuple[Any, Any]] = field(default_factory=list)
    said: list[tuple[Any, str]] = field(default_factory=list)


@dataclass(frozen=True)
class Mesher:
    """How the surfaces of one body are meshed: ``mesh(members, resolution, deflection,
    scene)`` with ``members`` their (surface, the scene's indices of its patches) and
    ``scene`` the scene's file and where messages say it is, and the
    vertices known before (``planned(members, resolution)``), which the memory check counts
    first; ``on_grid``: whether it meshes them on the common grid, whose resolution their
    chord errors then set (:func:`gridded_patches`)."""

    mesh: Callable[..., list[MeshPart]]
    planned: Callable[[Sequence[tuple[Any, NDArray[np.int32]]], int], int]
    on_grid: bool = False


def _grid(
    members: Sequence[tuple[Any, NDArray[np.int32]]],
    resolution: int,
    deflection: float,
    scene: tuple,
) -> list[MeshPart]:
    """All the members' patches on the common grid, in one tessellation."""
    patches = [p for surface, _ in members for p in surface.patches]
    mesh = tessellate(patches, resolution)
    if len(mesh.faces) == 0:
        raise GshadeError(
            f"{scene[1]}: [render] tessellation: {resolution} vertices per patch side leave no "
            "triangle (the patches collapse at that resolution); expected a larger value"
        )
    return [MeshPart(mesh, np.concatenate([index for _, index in members]))]


def _cad(
    members: Sequence[tuple[Any, NDArray[np.int32]]],
    resolution: int,
    deflection: float,
    scene: tuple,
) -> list[MeshPart]:
    """Each member's trimmed faces from the kernel's mesher."""
    from ..cad import in_scene

    out = []
    for surface, index in members:
        cad, path = surface.body, surface.body.model.path
        try:
            faces, lost, said = tessellate_faces(cad, surface.patches, deflection)
        except GshadeError as exc:
            raise in_scene(exc, surface.source, scene[0], path) from None
        out.append(MeshPart(faces, index, [(path, f) for f in lost], [(path, s) for s in said]))
    return out


#: The mesher of each body.
MESHERS: dict[type, Mesher] = {
    PatchBody: Mesher(
        _grid, lambda members, r: sum(len(s.patches) for s, _ in members) * r**2, on_grid=True
    ),
    CadFaces: Mesher(_cad, lambda members, r: 0),
}


def _members(scene: Scene) -> dict[type, list[tuple[Any, NDArray[np.int32]]]]:
    """The scene's surfaces by the type of their body, each with its patches' indices."""
    out: dict[type, list] = {}
    start = 0
    for surface in scene.surfaces:
        index = np.arange(start, start + len(surface.patches), dtype=np.int32)
        out.setdefault(type(surface.body), []).append((surface, index))
        start += len(surface.patches)
    return out


def gridded_patches(scene: Scene) -> list:
    """The patches meshed on the common grid (:attr:`Mesher.on_grid`), whose chord errors
    set its resolution."""
    return [
        patch
        for kind, members in _members(scene).items()
        if MESHERS[kind].on_grid
        for surface, _ in members
        for patch in surface.patches
    ]


def planned_vertices(scene: Scene, resolution: int) -> int:
    """The vertices the render mesh will have that are known before meshing."""
    return sum(MESHERS[kind].planned(m, resolution) for kind, m in _members(scene).items())


def mesh_parts(scene: Scene, resolution: int, deflection: float, where: str) -> list[MeshPart]:
    """The scene's surfaces meshed, by body, in the order their bodies first appear.

    ``where`` names the scene in messages; a CAD model's error is said about the scene's
    surface that reads it (:func:`gshade.cad.in_scene`).
    """
    said = (scene.path, where)
    return [
        part
        for kind, members in _members(scene).items()
        for part in MESHERS[kind].mesh(members, resolution, deflection, said)
    ]
