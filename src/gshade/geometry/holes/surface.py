"""A Catmull–Clark surface with its extraordinary vertices' holes filled (Kiciak ch. 5).

The limit surface of a quad mesh is bicubic wherever its faces are regular; around every
interior extraordinary vertex (EV) the n faces form a hole (:mod:`.hole`), which is filled
with n Bézier patches joined G1 or G2 to each other and C1 or C2 to the surroundings
(:mod:`.hole_fill`).  The result replaces Stam's patches there: the surface of
:func:`filled_surface` is the subdivision surface's bicubic part plus the fillings.

The holes never share a face: :func:`~gshade.geometry.holes.ring.find_holes` cuts them where every
hole's corners f_i are regular (so no two EVs are opposite corners of a face), or after a
refinement, after which no face has two EVs.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...errors import SurfaceDataError
from ..core.blas_threads import single_threaded_blas
from ..core.patch import Patch
from ..subdivision.quad_mesh import MeshTopology
from ..subdivision.stam import face_patches
from .fill import HoleFilling, fill_hole
from .ring import Hole, find_holes

__all__ = ["FilledSurface", "filled_surface"]


@dataclass(frozen=True)
class FilledSurface:
    """A filled surface: the patches of the faces outside the holes (``outside``, in face
    order), the ``holes`` and their ``fillings`` (in the same order)."""

    outside: list[Patch]
    holes: list[Hole]
    fillings: list[HoleFilling]

    @property
    def patches(self) -> list[Patch]:
        """All patches: ``outside``, then each filling's n patches."""
        return self.outside + [p for f in self.fillings for p in f.patches]

    def with_fillings(self, fillings: Sequence[HoleFilling]) -> FilledSurface:
        """The same surface with other fillings of the same holes (e.g. optimised ones)."""
        return FilledSurface(self.outside, self.holes, list(fillings))


@single_threaded_blas
def filled_surface(
    vertices: ArrayLike,
    faces: Iterable[Sequence[int] | NDArray[np.integer]],
    continuity: str = "G1",
    functional: str | None = None,
    *,
    domain: str = "square",
    source: str | None = None,
    face_lines: Sequence[int] | None = None,
) -> FilledSurface:
    """The Catmull–Clark surface of a quad mesh with the holes around its interior
    extraordinary vertices filled (see :func:`~gshade.geometry.holes.fill.fill_hole` for the
    parameters of the filling).

    Returns
    -------
    FilledSurface
        Its ``patches``: exact bicubic (or, next to the mesh boundary, Stam) patches of the
        faces outside the holes, then n patches per hole, counter-clockwise from the hole's
        face 0.

    Raises
    ------
    SurfaceDataError
        For an invalid mesh, one without interior extraordinary vertices (nothing to
        fill), or one with an extraordinary vertex on its boundary.
    GshadeError
        For bad filling parameters.
    """
    holes = find_holes(vertices, faces, source=source, face_lines=face_lines)
    if not holes:
        where = f"{source}: " if source else ""
        raise SurfaceDataError(
            f"{where}expected a mesh with an interior vertex of valence other than 4 (a hole "
            "to fill), found none"
        )
    P, F = holes[0].points, holes[0].faces
    filled = set(np.concatenate([h.hole_faces for h in holes]).tolist())
    outside = face_patches(
        P, MeshTopology(F, len(P)), (f for f in range(len(F)) if f not in filled)
    )
    fillings = [fill_hole(hole, continuity, functional, domain=domain) for hole in holes]
    return FilledSurface(outside, holes, fillings)
