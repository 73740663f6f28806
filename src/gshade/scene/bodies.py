"""What a surface's patches stand for: its *body*, one protocol that every kind of surface
implements, so that sizing, the header, ``info`` and the analyses ask it rather than branch
on kinds.

Two bodies:

- :data:`PATCHES`, patches exact over their whole domains (Bézier, B-spline, Coons,
  subdivision, hole fillings …): their extent is their surface, they carry no unit, each
  is a *patch*;
- :class:`CadFaces`, the faces of a CAD model (:class:`gshade.cad.CadModel`), one patch
  each over the face's box: their extent is the trimmed region, their unit the model's,
  each is a *face*, and the model's reader may have noted things and left faces out.

A body answers for the patches of its surface (``patches``, in order).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..geometry import Patch
from ..geometry.core.patch import EXTENT_GRID
from ..geometry.evaluation.patch_groups import grid_derivatives

__all__ = ["PATCHES", "CadFaces", "PatchBody", "SurfaceBody"]

#: Per side, the samples of a face's grid standing for its projected size (tile sizes).
TILE_GRID = 9


class SurfaceBody(Protocol):
    """What a surface's patches stand for (see the module)."""

    @property
    def patch_label(self) -> str:
        """What one patch is called in messages, tables and the EXR header
        (``patch_channel``)."""
        ...

    @property
    def trimmed(self) -> bool:
        """Whether the patches overstate the surface (trimmed faces): a texture's automatic
        range is then taken over the trimmed region only."""
        ...

    @property
    def length_unit(self) -> str | None:
        """The unit of the patches' coordinates (``"mm"`` …), None where none is known."""
        ...

    def extent_points(self, patches: Sequence[Patch]) -> NDArray[np.float64]:
        """Points (n, 3) standing for the surface's extent (the camera frames them)."""
        ...

    def tile_extents(self, patches: Sequence[Patch]) -> Iterator[NDArray[np.float64]]:
        """Per patch, a grid of points (a, b, 3) standing for what its texture tile covers."""
        ...

    def size_points(self, patches: Sequence[Patch]) -> NDArray[np.float64]:
        """Points (n, 3) whose box is the surface's size (its continuity tolerances')."""
        ...

    def patch_numbers(self, first: int, count: int) -> NDArray[np.int64]:
        """The numbers of its ``count`` patches in messages and the ``patch`` channel, the
        first of them the scene's patch ``first``: the scene's running index, or a CAD
        model's face numbers (as ``info``, the warnings and the edge rows number them)."""
        ...

    def notes(self) -> list[tuple[Any, str]]:
        """What the reader noted: (file, line) each."""
        ...

    def left_out_lines(self) -> list[tuple[Any, Any]]:
        """What is left out of the render: (file, :class:`gshade.cad.LeftOutFace`) each."""
        ...

    def info_lines(self) -> list[str]:
        """What ``gshade info`` says of the body beyond its patches, a line each."""
        ...


@dataclass(frozen=True)
class PatchBody:
    """Patches exact over their whole domains (see the module)."""

    patch_label: str = "patch"
    trimmed: bool = False

    @property
    def length_unit(self) -> str | None:
        return None

    def extent_points(self, patches: Sequence[Patch]) -> NDArray[np.float64]:
        grid = np.linspace(0.0, 1.0, EXTENT_GRID)
        return grid_derivatives(list(patches), grid)[:, 0, 0].reshape(-1, 3)

    def tile_extents(self, patches: Sequence[Patch]) -> Iterator[NDArray[np.float64]]:
        """A patch's control net (its convex hull holds the patch), or a 5 x 5 grid of its
        surface where it has none."""
        for p in patches:
            points = getattr(p, "points", None)
            if points is not None and np.ndim(points) == 3:
                yield np.asarray(points)
            else:
                yield np.asarray(p(*p.parameter_grid(5, 5))).reshape(5, 5, 3)

    def size_points(self, patches: Sequence[Patch]) -> NDArray[np.float64]:
        return np.concatenate([p(*p.parameter_grid(9, 9)).reshape(-1, 3) for p in patches])

    def patch_numbers(self, first: int, count: int) -> NDArray[np.int64]:
        return first + np.arange(count, dtype=np.int64)

    def notes(self) -> list[tuple[Any, str]]:
        return []

    def left_out_lines(self) -> list[tuple[Any, Any]]:
        return []

    def info_lines(self) -> list[str]:
        return []


#: The body of every surface that is not a CAD model's.
PATCHES = PatchBody()


@dataclass(frozen=True)
class CadFaces:
    """What a ``cad`` surface renders: the model read (:class:`gshade.cad.CadModel`, with
    the kernel's shape), the face numbers rendered (one patch each, in order) and, per face,
    whether its patch has u and v swapped (a reversed face, so that p_u x p_v points
    outward); the faces of those chosen that are left out (:class:`gshade.cad.LeftOutFace`,
    by the reader or the scene) and whether the surface is ``strict`` (a face left out is an
    error, also one the mesher leaves).  Its patches are the faces' untrimmed boxes."""

    model: Any = field(repr=False)
    faces: tuple[int, ...]
    swapped: tuple[bool, ...]
    left_out: tuple[Any, ...] = ()
    strict: bool = False
    patch_label: str = field(default="face", init=False)
    trimmed: bool = field(default=True, init=False)

    @property
    def length_unit(self) -> str | None:
        unit = self.model.unit
        return None if unit in (None, "unknown") else str(unit)

    def extent_points(self, patches: Sequence[Patch]) -> NDArray[np.float64]:
        """The points of the faces' trimmed regions (:func:`gshade.cad.trimmed_points`,
        as the reader kept them: :func:`gshade.cad.model.faces_extents`)."""
        from ..cad.model import faces_extents
        from ..shape.kernels import backend

        faces = [self.model.face(i) for i in self.faces]
        return np.concatenate(faces_extents(faces, drjit=backend() == "drjit"))

    def tile_extents(self, patches: Sequence[Patch]) -> Iterator[NDArray[np.float64]]:
        """A TILE_GRID x TILE_GRID grid of each face's surface over its box (the rational
        arcs' control points lie off the surface, overstating it), all faces at once."""
        from ..geometry.evaluation.patch_groups import grid_derivatives

        yield from grid_derivatives(list(patches), np.linspace(0.0, 1.0, TILE_GRID))[:, 0, 0]

    def size_points(self, patches: Sequence[Patch]) -> NDArray[np.float64]:
        """The corners of the model's bounding box."""
        return np.atleast_2d(np.asarray(self.model.bounds, dtype=np.float64))

    def patch_numbers(self, first: int, count: int) -> NDArray[np.int64]:
        return np.asarray(self.faces, dtype=np.int64)

    def patch_uv(self, places: ArrayLike, uv: NDArray[np.float64]) -> NDArray[np.float64]:
        """The kernel's (u, v) of the faces at ``places`` in :attr:`faces` (one place, or
        one a row of ``uv``), in the order of their scene patches: (v, u) on a swapped face.

        Examples
        --------
        >>> faces = CadFaces(model=None, faces=(4, 7), swapped=(False, True))
        >>> faces.patch_uv([0, 1], np.array([[0.1, 0.2], [0.1, 0.2]])).tolist()
        [[0.1, 0.2], [0.2, 0.1]]
        """
        swapped = np.asarray(self.swapped, dtype=bool)[np.asarray(places, dtype=np.int64)]
        return np.where(np.atleast_1d(swapped)[..., None], uv[..., ::-1], uv)

    def notes(self) -> list[tuple[Any, str]]:
        return [(self.model.path, line) for line in self.model.notes]

    def left_out_lines(self) -> list[tuple[Any, Any]]:
        return [(self.model.path, face) for face in self.left_out]

    def info_lines(self) -> list[str]:
        """The model's unit and bounding box, and per face chosen: its surface kind, exact
        or approximated (with the error), degrees, rational, trimmed, inner loops; or why
        it is left out."""
        model = self.model
        lo, hi = model.bounds
        lost = f" ({len(model.left_out)} left out)" if model.left_out else ""
        lines = [
            f"model: {model.face_count} faces{lost}, unit {model.unit}, bounding box "
            f"[{', '.join(f'{x:.6g}' for x in lo)}] .. [{', '.join(f'{x:.6g}' for x in hi)}]",
            f"{'face':>5}  {'kind':<10}  {'exact':<16}  degree   rational  trimmed  holes",
        ]
        left_out = {face.index: face for face in self.left_out}
        for i in sorted([*self.faces, *left_out]):
            if i in left_out:
                face = left_out[i]
                lines.append(f"{i:>5}  left out: {face.why} (tried: {face.tried})")
                continue
            face = model.face(i)
            exact = "exact" if face.exact else f"approx {face.error:.2g} {model.unit}"
            degree = f"{face.patch.degree[0]}x{face.patch.degree[1]}"
            lines.append(
                f"{i:>5}  {face.kind:<10}  {exact:<16}  {degree:<7}  "
                f"{'yes' if face.patch.rational else 'no':<8}  "
                f"{'yes' if face.trimmed else 'no':<7}  {face.inner_loops}"
            )
        return lines
