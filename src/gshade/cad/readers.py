"""Reading CAD files: the readers, registered by file extension in one table, and
:func:`read_cad`, which reads in a bounded child process and keeps what it read
(:mod:`gshade.cad.cache`).

A reader is a module with ``read(path, *, sew, tolerance) -> CadModel``: :mod:`gshade.cad.occt`
(Open CASCADE through cadquery-ocp) and :mod:`gshade.cad.rhino` (openNURBS through rhino3dm),
each an optional dependency (``pip install "gshade[cad]"``).
"""

from __future__ import annotations

import importlib
import os
from pathlib import Path
from typing import Any, NamedTuple

from ..errors import GshadeError
from .model import CadModel

__all__ = [
    "CAD_EXTENSIONS",
    "INSTALL",
    "READERS",
    "Reader",
    "in_scene",
    "read_cad",
    "reader_module",
]


class Reader(NamedTuple):
    """A reader: its module and the library it needs."""

    module: str
    library: str


#: The readers, by name.
READERS = {
    "occt": Reader("gshade.cad.occt", "OCP"),
    "3dm": Reader("gshade.cad.rhino", "rhino3dm"),
}

#: The CAD file extensions and the reader of each.
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
        Read in a child process of its own (:mod:`gshade.cad.process`), which keeps the
        kernel's shape: the model's ``shape`` is then a
        :class:`~gshade.cad.process.KernelProcess`, and a file that crashes, hangs or
        exhausts the kernel is one error.  False reads here: ``shape`` is the kernel's own
        (for code that works on it), and a damaged file may take this process down.

    Notes
    -----
    An isolated read is converted once (:mod:`gshade.cad.cache`): the same file (by
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

    Examples
    --------
    A 10 x 20 x 30 box made with the kernel (OCP), written to STEP in a temporary folder
    and read here (``isolated=False``: no child process, nothing cached):

    >>> import shutil, tempfile
    >>> from pathlib import Path
    >>> from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    >>> from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
    >>> folder = Path(tempfile.mkdtemp())
    >>> writer = STEPControl_Writer()
    >>> _ = writer.Transfer(BRepPrimAPI_MakeBox(10.0, 20.0, 30.0).Shape(), STEPControl_AsIs)
    >>> _ = writer.Write(str(folder / "box.step"))
    >>> model = read_cad(folder / "box.step", isolated=False)
    >>> model.face_count, model.unit, sorted({face.kind for face in model.faces})
    (6, 'mm', ['plane'])
    >>> (model.bounds[1] - model.bounds[0]).round(9).tolist()
    [10.0, 20.0, 30.0]
    >>> shutil.rmtree(folder)
    """
    path = Path(path)
    reader = CAD_EXTENSIONS.get(path.suffix.lower())
    if reader is None:
        raise GshadeError(
            f"{path}: expected a CAD file ({', '.join(CAD_EXTENSIONS)}), got the extension "
            f"{path.suffix or '(none)'!r}"
        )
    if isolated:
        if not _installed(READERS[reader].library):  # said here, without a child to start
            raise GshadeError(
                f"{path}: reading {path.suffix} files needs the CAD libraries ({INSTALL}): "
                f"no module named {READERS[reader].library!r}"
            )
        return _read_isolated(path, sew, tolerance)
    return reader_module(path).read(path, sew=sew, tolerance=tolerance)


def _read_isolated(path: Path, sew: bool | None, tolerance: float | None) -> CadModel:
    """:func:`read_cad` in a child process, converted once (:mod:`gshade.cad.cache`): a
    model of the same read in use here shares its child; a cached read comes back without
    the kernel, its child started when an operation the cache does not answer needs it;
    else the file is read, and the read kept."""
    from . import cache as cad_cache

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
    from . import cache as cad_cache
    from .process import KernelProcess

    kernel = KernelProcess(path, None if key is None else cad_cache.Answers(key))
    model, answer = _read_in(kernel, path, sew, tolerance)
    model.brep = kernel
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
    from . import cache as cad_cache

    if cad_cache.keeping() and cad_cache.model_key(path, sew, tolerance) == key:
        try:
            shape = kernel.call("keep", doing="keeping its shape")
        except GshadeError:
            return False
        cad_cache.store_model(key, path, model, answer, shape)
    return True


def _restored(entry: Any, key: str, sew: bool | None, tolerance: float | None) -> CadModel:
    """The cached read ``entry`` (a :class:`gshade.cad.cache.ModelEntry`) as a model whose
    child is started when first needed, and then given the cached shape (in the child, as
    any read: a cached shape the kernel cannot read costs a read of the file, kept anew)."""
    from ..limits import cad_read_memory
    from . import cache as cad_cache
    from .process import KernelProcess

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
    model.brep = kernel
    return model


def _numbers(model: CadModel) -> tuple:
    """What a model's kernel operations rely on: its faces' numbers, rendered and left out,
    and its kernel shape's."""
    rendered = tuple(face.index for face in model.faces)
    return rendered, tuple(f.index for f in model.left_out), model.kernel_numbers()


def reader_module(path: str | os.PathLike) -> Any:
    """The module that reads ``path`` (:mod:`gshade.cad.occt` or
    :mod:`gshade.cad.rhino`), imported; a GshadeError naming the install command when its
    library is missing."""
    path = Path(path)
    try:
        module = importlib.import_module(READERS[CAD_EXTENSIONS[path.suffix.lower()]].module)
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
