"""CAD models (STEP, IGES, BREP, Rhino 3dm) as exact faces: the data model and the reader.

A model is a list of faces, each an exact NURBS surface (the kernel's own B-spline form, or
the exact rational form of a plane, cylinder, cone, sphere, torus, surface of revolution or
extrusion) with the parameter box of its trimmed region and its trimming loops.  The readers
are :mod:`gshade.io.cad_occt` (Open CASCADE through cadquery-ocp: ``.step .stp .iges .igs
.brep``) and :mod:`gshade.io.cad_3dm` (openNURBS through rhino3dm: ``.3dm``); both are an
optional dependency (``pip install "gshade[cad]"``).
"""

from __future__ import annotations

import bisect
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from ..geometry.bspline import BSplinePatch

__all__ = [
    "CAD_EXTENSIONS",
    "INSTALL",
    "CadFace",
    "CadModel",
    "LeftOutFace",
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

#: The file extensions read as CAD models, and the reader of each.
CAD_EXTENSIONS = {
    ".step": "occt",
    ".stp": "occt",
    ".iges": "occt",
    ".igs": "occt",
    ".brep": "occt",
    ".3dm": "3dm",
}

#: What to install when the CAD libraries are missing.
INSTALL = 'pip install "gshade[cad]"'
#: The library each reader needs.
_LIBRARIES = {"occt": "OCP", "3dm": "rhino3dm"}


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
    arcs : ((a0, a1) or None, (b0, b1) or None)
        Per parameter, the angle range when the kernel's parameter is an angle (cylinders,
        cones, spheres, tori read without the kernel's NURBS conversion) and ``patch`` runs
        along it as :func:`gshade.geometry.revolution.arc`; None when the kernel's parameter
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
    (``CadFace.index``); ``left_out`` the faces it cannot use (still invalid after the
    kernel's healing, or failing to convert or evaluate: :class:`LeftOutFace`), and
    ``notes`` what the reader changed or passed over, a line each (the kernel's healing,
    sewing undone, objects hidden in Rhino).  ``shape`` is the kernel's
    shape, whose faces are all of them, face ``i`` the ``i``-th (STEP, IGES, BREP: as read and
    healed, or NURBS-converted where gshade does not build a face's surface itself; .3dm:
    rebuilt from the file's B-rep), or the :class:`~gshade.io.cad_process.KernelProcess`
    that holds it (a model read ``isolated``); ``kernel_faces`` the numbers of the shape's
    faces in its order where it lacks some (a .3dm face the kernel could not build), None
    where face ``i`` is its ``i``-th (:meth:`kernel_numbers`).  ``precision`` is the distance
    accuracy the file declares (a STEP file's global uncertainty, model units; 0 where none is
    declared).
    """

    path: Path
    faces: list[CadFace]
    unit: str
    bounds: tuple[NDArray[np.float64], NDArray[np.float64]]
    shape: object | None = None
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
    (:func:`gshade.geometry.revolution.arc_parameters` along angles)."""
    if arcs == (None, None):
        return uv
    from ..geometry.revolution import arc_parameters

    out = np.array(uv, dtype=np.float64)
    for d, span in enumerate(arcs):
        if span is not None:
            out[:, d] = arc_parameters(out[:, d], *span)
    return out


def trimmed_points(
    face: CadFace, n: int = 17, loop_points: int | None = None
) -> NDArray[np.float64]:
    """Points (m, 3) of a face's trimmed region, standing for its extent: the points of its
    loops (at most ``loop_points`` a loop, default 4 n; all with 0) and of the n x n grid of
    its box that lie inside them (an odd number of loops around; the box's grid for a face
    without loops)."""
    from matplotlib.path import Path as Polygon

    (u0, u1), (v0, v1) = face.box
    u, v = np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n), indexing="ij")
    grid = np.stack([u.ravel(), v.ravel()], -1)
    if face.loops:
        around = sum(Polygon(loop).contains_points(grid).astype(int) for loop in face.loops)
        most = 4 * n if loop_points is None else loop_points
        edges = [loop[:: max(1, len(loop) // most)] if most else loop for loop in face.loops]
        grid = np.concatenate([grid[np.asarray(around) % 2 == 1], *edges])
    (a0, a1), (b0, b1) = face.patch.domain
    return np.asarray(
        face.patch(np.clip(grid[:, 0], a0, a1), np.clip(grid[:, 1], b0, b1)), float
    ).reshape(-1, 3)


def faces_bounds(faces: list[CadFace]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The bounding box (lo, hi) of the faces' trimmed regions, from their
    :func:`trimmed_points` (points on the exact surfaces: tight up to the sampling)."""
    points = np.concatenate([trimmed_points(face, 65, 0) for face in faces])
    return points.min(axis=0), points.max(axis=0)


def read_cad(
    path: str | os.PathLike,
    sew: bool | None = None,
    tolerance: float | None = None,
    isolated: bool = True,
) -> CadModel:
    """Read a CAD file into exact faces (reader chosen by the file's extension).

    Parameters
    ----------
    path : path-like
        ``.step .stp .iges .igs .brep .3dm``.
    sew : bool, optional
        Sew the faces into shells before anything else (default: when the file holds
        unsewn faces, as IGES files usually do).
    tolerance : float, optional
        The sewing tolerance in model units (default: from the model's size).
    isolated : bool
        Read in a child process of its own (:mod:`gshade.io.cad_process`), which keeps the
        kernel's shape: the model's ``shape`` is then a
        :class:`~gshade.io.cad_process.KernelProcess`, and a file that crashes, hangs or
        exhausts the kernel is one error.  False reads here: ``shape`` is the kernel's own
        (for code that works on it), and a damaged file may take this process down.

    Notes
    -----
    An isolated read is converted once (:mod:`gshade.io.cad_cache`): the same file (by
    content) read with the same options is given back from the cache on disk (the model;
    its child, started when an operation whose answer is not kept needs it, is given the
    kernel's shape as read, healed and converted), or shares the child of a model of it
    still in use here; ``GSHADE_CACHE_DIR=off`` keeps nothing on disk.

    Raises
    ------
    GshadeError
        One line naming the file: an unknown extension, the CAD libraries missing (with the
        install command), a file the kernel cannot read, that holds no surfaces, or (when
        isolated) that crashes the kernel, or makes it overrun its time or memory.
    """
    path = Path(path)
    reader = CAD_EXTENSIONS.get(path.suffix.lower())
    if reader is None:
        raise GshadeError(
            f"{path}: expected a CAD file ({', '.join(CAD_EXTENSIONS)}), got the extension "
            f"{path.suffix or '(none)'!r}"
        )
    if isolated:
        if not _installed(_LIBRARIES[reader]):  # said here, without a child to start
            raise GshadeError(
                f"{path}: reading {path.suffix} files needs the CAD libraries ({INSTALL}): "
                f"no module named {_LIBRARIES[reader]!r}"
            )
        return _read_isolated(path, sew, tolerance)
    return reader_module(path).read(path, sew=sew, tolerance=tolerance)


def _read_isolated(path: Path, sew: bool | None, tolerance: float | None) -> CadModel:
    """:func:`read_cad` in a child process, converted once (:mod:`gshade.io.cad_cache`): a
    model of the same read in use here shares its child; a cached read comes back without
    the kernel, its child started when an operation the cache does not answer needs it;
    else the file is read, and the read kept."""
    from . import cad_cache

    key = cad_cache.model_key(path, sew, tolerance)
    if key is None:  # not a regular file: the reader says what is wrong with it
        return _read_afresh(path, sew, tolerance, None)
    model = cad_cache.live_model(key, path)
    if model is None:
        entry = cad_cache.find_model(key, path)
        if entry is not None:
            model = _restored(entry, key, sew, tolerance)
    if model is None:
        model = _read_afresh(path, sew, tolerance, key)
    return cad_cache.remember(key, path, model)


def _read_afresh(
    path: Path, sew: bool | None, tolerance: float | None, key: str | None
) -> CadModel:
    """Read the file in a new child; with a cache ``key``, keep the read."""
    from . import cad_cache
    from .cad_process import KernelProcess

    kernel = KernelProcess(path, None if key is None else cad_cache.Answers(key))
    model, answer = _read_in(kernel, path, sew, tolerance)
    model.shape = kernel
    if key is not None and not _kept(kernel, key, path, sew, tolerance, model, answer):
        return _read_afresh(path, sew, tolerance, None)  # the child went with the keeping
    return model


def _read_in(
    kernel: Any, path: Path, sew: bool | None, tolerance: float | None
) -> tuple[CadModel, bytes]:
    """The child ``kernel`` reads the file: the model, and the child's answer that gave it."""
    from ..limits import cad_read_memory

    try:
        size = path.stat().st_size
    except OSError:  # the reader says what is wrong with it
        size = 0
    model: CadModel
    model, answer = kernel.request(
        "read", (path, sew, tolerance), doing="reading it", memory=cad_read_memory(size)
    )
    return model, answer


def _kept(
    kernel: Any,
    key: str,
    path: Path,
    sew: bool | None,
    tolerance: float | None,
    model: CadModel,
    answer: bytes,
) -> bool:
    """Keep the read the child ``kernel`` made (when the cache is on and the file did not
    change meanwhile); False when the child ended asking for its shape."""
    from . import cad_cache

    if cad_cache.keeping() and cad_cache.model_key(path, sew, tolerance) == key:
        try:
            shape = kernel.call("keep", doing="keeping its shape")
        except GshadeError:
            return False
        cad_cache.store_model(key, path, model, answer, shape)
    return True


def _restored(entry: Any, key: str, sew: bool | None, tolerance: float | None) -> CadModel:
    """The cached read ``entry`` (a :class:`gshade.io.cad_cache.ModelEntry`) as a model whose
    child is started when first needed, and then given the cached shape (in the child, as
    any read: a cached shape the kernel cannot read costs a read of the file, kept anew)."""
    from ..limits import cad_read_memory
    from . import cad_cache
    from .cad_process import KernelProcess

    model: CadModel = entry.model
    path, numbers, count = model.path, _numbers(model), model.face_count
    cached = (entry.answer, entry.shape, str(path))  # not the model: no cycle through it
    memory = cad_read_memory(len(entry.answer) + len(entry.shape))

    def prepare(kernel: KernelProcess) -> None:
        try:
            if kernel.call("load", cached, doing="reading it", memory=memory) == count:
                return
        except GshadeError:  # a crash, an overrun or a refusal: the entry costs a read
            pass
        kernel.restart()
        fresh, answer = _read_in(kernel, path, sew, tolerance)
        if _numbers(fresh) != numbers:
            raise GshadeError(f"{path}: the file changed while it was in use; read it again")
        if not _kept(kernel, key, path, sew, tolerance, fresh, answer):
            raise GshadeError(f"{path}: the CAD kernel's process ended keeping its shape")

    kernel = KernelProcess(path, cad_cache.Answers(key), start=False)
    kernel.later(prepare)
    model.shape = kernel
    return model


def _numbers(model: CadModel) -> tuple:
    """What a model's kernel operations rely on: its faces' numbers, rendered and left out,
    and its kernel shape's."""
    rendered = tuple(face.index for face in model.faces)
    return rendered, tuple(f.index for f in model.left_out), model.kernel_numbers()


def reader_module(path: str | os.PathLike) -> Any:
    """The module that reads ``path`` (:mod:`gshade.io.cad_occt` or
    :mod:`gshade.io.cad_3dm`), imported; a GshadeError naming the install command when its
    library is missing."""
    path = Path(path)
    try:
        if CAD_EXTENSIONS.get(path.suffix.lower()) == "3dm":
            from . import cad_3dm as module
        else:
            from . import cad_occt as module  # type: ignore[no-redef]
    except ImportError as exc:
        raise GshadeError(
            f"{path}: reading {path.suffix} files needs the CAD libraries ({INSTALL}): {exc}"
        ) from None
    return module


def in_scene(
    error: GshadeError, where: str, scene: str | os.PathLike, path: str | os.PathLike
) -> GshadeError:
    """A CAD file's error (it names the file ``path``) as said about the scene that reads
    it: ``WHERE: ERROR`` (``where`` names the scene file and its surface), or the error as
    it is when the scene is that CAD file (a CAD file given as the scene: named once)."""
    try:
        if os.path.samefile(scene, path):
            return error
    except (OSError, TypeError):
        pass
    return GshadeError(f"{where}: {error}")


def _installed(module: str) -> bool:
    """Whether ``module`` can be imported (found, not imported)."""
    import importlib.util

    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError, AttributeError):
        return False


def usable(face: CadFace, n: int = 5) -> CadFace:
    """The face, checked to evaluate to finite points and first derivatives at an n x n
    grid of its box; a GshadeError saying what does not (the reader leaves it out)."""
    (u0, u1), (v0, v1) = face.box
    if not all(np.isfinite(x) for x in (u0, u1, v0, v1)) or u1 <= u0 or v1 <= v0:
        raise GshadeError(f"its parameter box {face.box} is empty or not finite")
    (a0, a1), (b0, b1) = face.patch.domain
    u, v = np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n), indexing="ij")
    with np.errstate(all="ignore"):
        d = np.asarray(
            face.patch.derivatives(np.clip(u.ravel(), a0, a1), np.clip(v.ravel(), b0, b1), 1)
        )
    if not np.isfinite(d).all():
        raise GshadeError("its surface does not evaluate to finite points (NaN or infinity)")
    return face
