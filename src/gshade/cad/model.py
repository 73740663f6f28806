"""CAD models (STEP, IGES, BREP, Rhino 3dm) as exact faces: the data model.

A model is a list of faces, each an exact NURBS surface (the kernel's own B-spline form, or
the exact rational form of a plane, cylinder, cone, sphere, torus, surface of revolution or
extrusion) with the parameter box of its trimmed region and its trimming loops.  The readers
(:mod:`gshade.cad.readers`, by file extension) make them: :mod:`gshade.cad.occt` (Open
CASCADE through cadquery-ocp: ``.step .stp .iges .igs .brep``) and :mod:`gshade.cad.rhino`
(openNURBS through rhino3dm: ``.3dm``); both are an optional dependency
(``pip install "gshade[cad]"``).
"""

from __future__ import annotations

import bisect
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from ..geometry.core.patch import EXTENT_GRID
from ..geometry.patches.bspline import BSplinePatch

__all__ = [
    "CadFace",
    "CadModel",
    "LeftOutFace",
    "arc_map",
    "faces_bounds",
    "faces_extents",
    "no_usable_face",
    "strict_refusal",
    "trimmed_points",
    "usable",
]

#: Samples per side of a face's box for the model's bounding box (tight to the sampling).
BOUNDS_GRID = 65
#: Samples per side of a face's box where it must evaluate to finite points (else left out).
USABLE_GRID = 5


@dataclass
class CadFace:
    """One face of a model, exact.

    Attributes
    ----------
    index : int
        The face's number in the model (0-based, in the kernel's traversal order).
    kind : str
        The kernel's surface type: ``"bspline"``, ``"bezier"``, ``"plane"``, ``"cylinder"``,
        ``"cone"``, ``"sphere"``, ``"torus"``, ``"revolution"``, ``"extrusion"``,
        ``"offset"``, ``"other"``.
    patch : BSplinePatch
        The surface in NURBS form over its whole knot domain; the face uses ``box`` of it.
    box : ((u0, u1), (v0, v1))
        The parameter box of the face (its trimming loops lie inside).
    reversed : bool
        True when the face's outward normal is -(p_u x p_v) (a ``TopAbs_REVERSED`` face).
    exact : bool
        True when ``patch`` is the surface itself; False for an approximation within
        ``error`` (model units).
    error : float
        The largest distance between ``patch`` and the kernel's surface (0 when exact).
    loops : list of ndarray (n, 2)
        Trimming loops in (u, v), the outer loop first, then the holes; each closed polyline
        (last point = first) within ``loop_tolerance`` of the exact trimming curve.
    loop_tolerance : float
        How far (in parameter units) the loops' polylines may lie from the exact curves.
    trimmed : bool
        False when the face is its whole parameter box.
    extent : ndarray (m, 3) or None
        Its :func:`trimmed_points` once :func:`faces_extents` has found them (the reader
        does, so that a cached model keeps them), else None.
    arcs : ((a0, a1) or None, (b0, b1) or None)
        Per parameter, the angle range when the kernel's parameter is an angle (cylinders,
        cones, spheres, tori read without the kernel's NURBS conversion) and ``patch`` runs
        along it as :func:`gshade.geometry.patches.revolution.arc`; None when the kernel's parameter
        is the patch's.  :meth:`to_patch` maps the kernel's (u, v) (its mesh, its trimming
        curves) to the patch's.
    """

    index: int
    kind: str
    patch: BSplinePatch
    box: tuple[tuple[float, float], tuple[float, float]]
    reversed: bool = False
    exact: bool = True
    error: float = 0.0
    loops: list[NDArray[np.float64]] = field(default_factory=list)
    loop_tolerance: float = 0.0
    trimmed: bool = False
    arcs: tuple[tuple[float, float] | None, tuple[float, float] | None] = (None, None)
    extent: NDArray[np.float64] | None = field(default=None, repr=False, compare=False)

    def to_patch(self, uv: NDArray[np.float64]) -> NDArray[np.float64]:
        """The patch's parameters (n, 2) of the kernel's (u, v) (n, 2) (:func:`arc_map`)."""
        return arc_map(uv, self.arcs)

    @property
    def inner_loops(self) -> int:
        """The number of holes (loops after the outer one)."""
        return max(len(self.loops) - 1, 0)


@dataclass(frozen=True)
class LeftOutFace:
    """A face of a model that is not rendered: its number (as ``gshade info`` lists the
    model's faces), what is wrong with it and what was tried.

    Examples
    --------
    >>> LeftOutFace(3, "a trimming wire intersects itself", "the kernel's healing").line()
    "face 3 left out: a trimming wire intersects itself (tried: the kernel's healing)"
    """

    index: int
    why: str
    tried: str

    def line(self) -> str:
        """The one line said about the face: ``face N left out: WHY (tried: TRIED)``."""
        return f"face {self.index} left out: {self.why} (tried: {self.tried})"


def no_usable_face(path: str | os.PathLike, left_out: list[LeftOutFace]) -> GshadeError:
    """The error of a model whose faces are all left out (``left_out``, in order)."""
    return GshadeError(f"{path}: no usable face ({len(left_out)} left out; {left_out[0].line()})")


def strict_refusal(path: str | os.PathLike, left_out: list[LeftOutFace]) -> GshadeError:
    """The error of a strict ``cad`` surface that leaves faces out (``left_out``, in
    order): the first one named, the others counted."""
    more = f", and {len(left_out) - 1} more faces" if len(left_out) > 1 else ""
    return GshadeError(f"{path}: {left_out[0].line()}{more} (strict: every face must be rendered)")


@dataclass
class CadModel:
    """A CAD file's faces, its length unit (e.g. ``"mm"``) and bounding box (lo, hi) (of
    the trimmed faces, sampled: :func:`faces_bounds`).

    ``faces`` are the faces gshade renders, in the file's order, each with its number
    (``CadFace.index``); ``left_out`` the faces it cannot use (still invalid after the kernel's
    healing, or failing to convert or evaluate: :class:`LeftOutFace`), and ``notes`` what the
    reader changed or passed over, a line each (the kernel's healing, sewing undone, objects
    hidden in Rhino).  ``brep`` is the kernel's B-rep (its shape), whose faces are all of them,
    face ``i`` the ``i``-th (STEP, IGES, BREP: as read and healed, or NURBS-converted where
    gshade does not build a face's surface itself; .3dm: rebuilt from the file's B-rep), or the
    :class:`~gshade.cad.process.KernelProcess` that holds it (a model read ``isolated``);
    ``kernel_faces`` the numbers of the shape's faces in its order where it lacks some (a .3dm
    face the kernel could not build), None where face ``i`` is its ``i``-th
    (:meth:`kernel_numbers`).  ``precision`` is the distance accuracy the file declares (a STEP
    file's global uncertainty, model units; 0 where none is declared).
    """

    path: Path
    faces: list[CadFace]
    unit: str
    bounds: tuple[NDArray[np.float64], NDArray[np.float64]]
    brep: object | None = None
    precision: float = 0.0
    left_out: list[LeftOutFace] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    kernel_faces: tuple[int, ...] | None = None

    def kernel_numbers(self) -> tuple[int, ...]:
        """The face numbers of the kernel shape's faces, in its order."""
        if self.kernel_faces is not None:
            return self.kernel_faces
        return tuple(range(self.face_count))

    @property
    def face_count(self) -> int:
        """The number of faces in the file (rendered and left out)."""
        return len(self.faces) + len(self.left_out)

    def face(self, index: int) -> CadFace:
        """The face numbered ``index`` (a KeyError when it is left out or out of range);
        ``faces`` are in the order of their numbers."""
        k = bisect.bisect_left(self.faces, index, key=lambda face: face.index)
        if k < len(self.faces) and self.faces[k].index == index:
            return self.faces[k]
        raise KeyError(index)

    def reason_left_out(self, index: int) -> LeftOutFace | None:
        """The face ``index``'s :class:`LeftOutFace`, or None when it is rendered."""
        return next((f for f in self.left_out if f.index == index), None)


def arc_map(
    uv: NDArray[np.float64],
    arcs: tuple[tuple[float, float] | None, tuple[float, float] | None],
) -> NDArray[np.float64]:
    """Kernel parameters (n, 2) as a patch's whose parameters run along exact rational arcs
    (``arcs``: per parameter its angle range, or None where the kernel's parameter is the
    patch's): exact, the same point of the surface
    (:func:`gshade.geometry.patches.revolution.arc_parameters` along angles)."""
    if arcs == (None, None):
        return uv
    from ..geometry.patches.revolution import arc_parameters

    out = np.array(uv, dtype=np.float64)
    for d, span in enumerate(arcs):
        if span is not None:
            out[:, d] = arc_parameters(out[:, d], *span)
    return out


def trimmed_points(
    face: CadFace, n: int = EXTENT_GRID, loop_points: int | None = None
) -> NDArray[np.float64]:
    """Points (m, 3) of a face's trimmed region, standing for its extent: the points of its
    loops (at most ``loop_points`` a loop, default 4 n; all with 0) and of the n x n grid of
    its box that lie inside them (an odd number of loops around, a loop's points counted
    inside it; the box's grid for a face without loops)."""
    return faces_trimmed_points([face], n, loop_points)[0]


def faces_trimmed_points(
    faces: list[CadFace],
    n: int = EXTENT_GRID,
    loop_points: int | None = None,
    drjit: bool = False,
) -> list[NDArray[np.float64]]:
    """:func:`trimmed_points` of each face, the surfaces evaluated at all faces' points at
    once (:class:`gshade.geometry.evaluation.patch_cells.ManyPatches`; its Dr.Jit kernel with
    ``drjit``, never in a kernel process: it forks)."""
    from skimage.measure import points_in_poly

    from ..geometry.evaluation.patch_cells import ManyPatches

    most = 4 * n if loop_points is None else loop_points
    grids, on_loop, index, u, v = [], [], [], [], []
    for k, face in enumerate(faces):
        (u0, u1), (v0, v1) = face.box
        (a0, a1), (b0, b1) = face.patch.domain
        gu, gv = np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n), indexing="ij")
        grid = np.stack([gu.ravel(), gv.ravel()], -1)
        edges = (
            np.concatenate([lp[:: max(1, len(lp) // most)] if most else lp for lp in face.loops])
            if face.loops
            else np.empty((0, 2))
        )
        grids.append(grid)
        on_loop.append(edges.shape[0])  # the loops' points after the grid's
        uv = np.concatenate([grid, edges])
        index.append(np.full(len(uv), k))
        u.append(np.clip(uv[:, 0], a0, a1))
        v.append(np.clip(uv[:, 1], b0, b1))
    many = ManyPatches([f.patch for f in faces], drjit=drjit)
    points = many.derivatives(np.concatenate(index), np.concatenate(u), np.concatenate(v), 0)
    out, at = [], 0
    for face, grid, count in zip(faces, grids, on_loop, strict=True):
        on_grid = points[0, 0, at : at + len(grid)]
        on_loops = points[0, 0, at + len(grid) : at + len(grid) + count]
        at += len(grid) + count
        if not face.loops:
            out.append(on_grid)
            continue
        around = sum(points_in_poly(grid, lp).astype(int) for lp in face.loops)
        out.append(np.concatenate([on_grid[np.asarray(around) % 2 == 1], on_loops]))
    return out


def faces_extents(faces: list[CadFace], drjit: bool = False) -> list[NDArray[np.float64]]:
    """Each face's :func:`trimmed_points` (the defaults), standing for its extent: kept on
    the face (``CadFace.extent``), those not yet found evaluated all at once
    (:func:`faces_trimmed_points`)."""
    missing = [face for face in faces if face.extent is None]
    if missing:
        for face, points in zip(missing, faces_trimmed_points(missing, drjit=drjit), strict=True):
            face.extent = points
    return [face.extent for face in faces]  # type: ignore[misc]


def faces_bounds(faces: list[CadFace]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The bounding box (lo, hi) of the faces' trimmed regions, from their
    :func:`trimmed_points` (points on the exact surfaces: tight up to the sampling)."""
    points = np.concatenate(faces_trimmed_points(faces, BOUNDS_GRID, 0))
    return points.min(axis=0), points.max(axis=0)


def usable(face: CadFace, n: int = USABLE_GRID) -> CadFace:
    """The face, checked to evaluate to finite points and first derivatives at an n x n
    grid of its box; a GshadeError saying what does not (the reader leaves it out)."""
    (u0, u1), (v0, v1) = face.box
    if not all(np.isfinite(x) for x in (u0, u1, v0, v1)) or u1 <= u0 or v1 <= v0:
        raise GshadeError(f"its parameter box {face.box} is empty or not finite")
    (a0, a1), (b0, b1) = face.patch.domain
    us = np.clip(np.linspace(u0, u1, n), a0, a1)
    vs = np.clip(np.linspace(v0, v1, n), b0, b1)
    with np.errstate(all="ignore"):
        d = np.asarray(face.patch.derivatives_grid(us, vs, 1))
    if not np.isfinite(d).all():
        raise GshadeError("its surface does not evaluate to finite points (NaN or infinity)")
    return face
