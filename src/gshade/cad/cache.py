"""Converted CAD models kept by content: a file is read and converted once.

Reading a CAD file (the kernel's parse, healing and NURBS conversion, gshade's faces) takes
seconds: 4.4 s for a 305-face STEP part.  A batch, a sweep or a check renders one file
many times, so :func:`gshade.cad.read_cad` keeps what a read gives:

- **on disk**, in ``cad`` under gshade's cache folder (:mod:`gshade.runtime.cache_folder`:
  ``$GSHADE_CACHE_DIR``, else ``$XDG_CACHE_HOME/gshade`` or ``~/.cache/gshade``;
  ``GSHADE_CACHE_DIR=off`` or ``--no-cache``: nothing on disk), an entry ``KEY.model`` a
  model: the kernel process's answer (the faces, left-out faces and notes: the pickled
  :class:`~gshade.cad.CadModel`) and the kernel's shape as read, healed and converted
  (Open CASCADE's binary B-rep, ``BinTools``).  The kernel's operations on the model (the
  mesh, the edges: answers of :func:`~gshade.cad.process.kernel_operation`) are kept
  beside it (:class:`Answers`: ``KEY.answer``).  A hit gives back the model without the
  kernel; its kernel process is started only for an operation whose answer is not kept,
  and then given the cached shape (:func:`restored_model`, in milliseconds, in its own
  child as any read: a cached shape that crashes the kernel costs a read of the file,
  not the render).  So a second render at the same size asks the kernel nothing.
- **in memory**, while a model of the file is in use in this process (:func:`live_model`):
  a second read of it shares the model's kernel process; and the models of the entries
  found last (:data:`RECENT_MODELS`): an entry found again (checked on disk as any) gives
  a model with the same face objects, not unpickled again (a batch worker's next job).

The key (:func:`gshade.cad.cache_keys.model_key`) is a SHA-256 of the file's content (its
bytes, streamed), its reader (by extension), the reading options (``sew``, ``tolerance``;
``strict`` is applied after reading, so one entry serves both), gshade's version and the
source of the modules that read and convert with that reader (a change to them is another
conversion; an answer's key adds the source of its operation's module, the mesher's or the
edges'), and the kernel's versions (numpy, the installed cadquery-ocp and rhino3dm). An
entry is trusted only whole: a regular file (not a link) of bounded size, its header naming
the same key, each part of the size and SHA-256 the header gives, the model unpickled
through the kernel answers' allow-list (:func:`gshade.cad.process.allowed_answer`, never a
plain ``pickle.load``), its face count the header's and the shape's. Anything else is a
miss, read afresh and written anew. Entries are written whole
(:func:`~gshade.runtime.cache_folder.write_entry`: concurrent batch workers each rename a
whole file into place). The folder is bounded (:data:`CACHE_BYTES`): after each write, the
entries used longest ago go first (an entry's modification time is its last use: a hit sets
it).
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import re
import stat
import threading
import time
import weakref
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ..errors import GshadeError
from ..runtime.cache_folder import cache_folder, read_entry, write_entry
from .cache_keys import ENTRY_FORMAT, answer_key, model_key
from .model import CadModel
from .process import allowed_answer

__all__ = [
    "CACHE_BYTES",
    "CACHE_NAME",
    "Answers",
    "ModelEntry",
    "cached",
    "find_model",
    "keeping",
    "live_model",
    "model_key",
    "remember",
    "restored_model",
    "shape_bytes",
    "store_model",
]

#: The subfolder of the cache folder that holds the CAD entries.
CACHE_NAME = "cad"
#: The most bytes the CAD entries take together; the entries used longest ago are removed.
CACHE_BYTES = 2**30
#: The longest header line read (its JSON: key, kind, parts' sizes and checksums).
_MAX_HEADER = 2**16
#: Entry names: the key (SHA-256, hex) and the kind.
_ENTRY = re.compile(r"[0-9a-f]{64}\.(model|answer)")
#: Temporaries older than this (seconds) were left by a process that died while writing.
_STALE_SECONDS = 3600.0


# --------------------------------------------------------------------------- entries


def _folder() -> Path | None:
    return cache_folder(CACHE_NAME)


def keeping() -> bool:
    """Whether reads are kept on disk (the cache folder is not off)."""
    return _folder() is not None


def _write(key: str, kind: str, parts: list[bytes], **header: Any) -> bool:
    """Write the entry ``KEY.KIND`` of ``parts`` (a header gives their sizes and
    checksums), then keep the folder within :data:`CACHE_BYTES`."""
    folder = _folder()
    size = sum(len(p) for p in parts)
    if folder is None or size > CACHE_BYTES // 2:
        return False
    checks = [[len(p), hashlib.sha256(p).hexdigest()] for p in parts]
    head = json.dumps({**header, "key": key, "kind": kind, "parts": checks}).encode()
    name = f"{key}.{kind}"
    written = write_entry(folder, name, [ENTRY_FORMAT, head, b"\n", *parts])
    if written:
        _evict(folder, keep=name)
    return written


def _read(key: str, kind: str) -> tuple[dict, list[bytes]] | None:
    """The header and parts of the entry ``KEY.KIND``, or None for anything but a whole
    entry of this key (see the module)."""
    folder = _folder()
    if folder is None:
        return None
    data = read_entry(folder / f"{key}.{kind}", CACHE_BYTES, touch=True)
    if data is None or not data.startswith(ENTRY_FORMAT):
        return None
    end = data.find(b"\n", len(ENTRY_FORMAT), len(ENTRY_FORMAT) + _MAX_HEADER)
    if end < 0:
        return None
    try:
        header = json.loads(data[len(ENTRY_FORMAT) : end].decode("utf-8"))
        if not isinstance(header, dict) or header.get("key") != key:
            return None
        if header.get("kind") != kind:
            return None
        parts, at = [], end + 1
        for size, digest in header["parts"]:
            part = data[at : at + int(size)]
            if len(part) != size or hashlib.sha256(part).hexdigest() != digest:
                return None
            parts.append(part)
            at += size
    except (ValueError, TypeError, KeyError, UnicodeDecodeError, RecursionError):
        return None
    if at != len(data):
        return None
    return header, parts


def _evict(folder: Path, keep: str) -> None:
    """Remove the entries used longest ago (by modification time) until the folder's
    entries take at most :data:`CACHE_BYTES` (never ``keep``), and the temporaries that
    writers which died left behind.  Only regular files named as entries are counted and
    removed; links and other files are left alone."""
    now = time.time()
    entries, total = [], 0
    try:
        with os.scandir(folder) as listing:
            for item in listing:
                try:
                    st = item.stat(follow_symlinks=False)
                except OSError:
                    continue
                if not stat.S_ISREG(st.st_mode):
                    continue
                if item.name.startswith(".") and item.name.endswith(".tmp"):
                    if now - st.st_mtime > _STALE_SECONDS:
                        _remove(folder / item.name)
                elif _ENTRY.fullmatch(item.name):
                    entries.append((st.st_mtime_ns, item.name, st.st_size))
                    total += st.st_size
    except OSError:
        return
    for _, name, size in sorted(entries):
        if total <= CACHE_BYTES:
            break
        if name != keep:
            _remove(folder / name)
            total -= size


def _remove(path: Path) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


@dataclass
class ModelEntry:
    """A cached read: the model (its ``brep`` None), the kernel process's answer it was
    unpickled from, and the kernel's shape (``BinTools`` bytes) for a new process."""

    model: CadModel
    answer: bytes
    shape: bytes


#: The models of the cached reads this process found last (:func:`find_model`), by (key,
#: path): the digest of the entry's model part and the model.
RECENT_MODELS = 4
_recent: dict[tuple[str, str], tuple[str, CadModel]] = {}


def find_model(key: str, path: str | os.PathLike) -> ModelEntry | None:
    """The cached read of ``key``, checked (see the module), its model's ``path`` set to
    ``path``; None when there is none to trust.

    An entry whose model part is the one of the :data:`RECENT_MODELS` found last here is
    not unpickled again: its model comes back as a model of its own with the same face
    objects, so that what is kept per patch (its Bézier cells) serves the next render of
    the file in a batch worker or a sweep."""
    found = _read(key, "model")
    if found is None:
        return None
    header, parts = found
    if len(parts) != 2:
        return None
    answer, shape = parts
    named = header.get("names")  # the path the model's messages name, if they do
    if named is not None and named != str(path):
        return None
    where, digest = (key, str(path)), str(header["parts"][0][1])
    with _live_lock:
        recent = _recent.pop(where, None)
        if recent is not None and recent[0] == digest:
            _recent[where] = recent  # the last used, last
    if recent is not None and recent[0] == digest:
        return ModelEntry(_copy(recent[1]), answer, shape)
    model = _unpickled(answer, header)
    if model is None:
        return None
    model.path, model.brep = Path(path), None
    with _live_lock:
        _recent[where] = (digest, _copy(model))
        while len(_recent) > RECENT_MODELS:
            del _recent[next(iter(_recent))]
    return ModelEntry(model, answer, shape)


def _copy(model: CadModel) -> CadModel:
    """A model of its own (its lists new) with the same faces."""
    return replace(
        model, faces=list(model.faces), left_out=list(model.left_out), notes=list(model.notes)
    )


def _unpickled(answer: bytes, header: dict) -> CadModel | None:
    """The model of an entry's answer part, or None where it is not one to trust."""
    try:
        kind, model = allowed_answer(answer)
    except Exception:  # whatever a foreign entry's bytes raise in the unpickler: a miss
        return None
    if kind != "ok" or not isinstance(model, CadModel):
        return None
    if model.face_count != header.get("faces") or not model.faces:
        return None
    return model


def cached(path: str | os.PathLike) -> bool:
    """Whether a read of ``path`` with the default options is kept (an entry by that name
    is there; :func:`find_model` checks it): the command line then starts no kernel
    before it is needed."""
    folder, key = _folder(), model_key(path, None, None)
    return folder is not None and key is not None and (folder / f"{key}.model").is_file()


def store_model(
    key: str, path: str | os.PathLike, model: CadModel, answer: bytes, shape: bytes
) -> bool:
    """Keep a read: ``answer`` (the kernel process's answer that gave ``model``) and the
    kernel's ``shape`` (:func:`shape_bytes`); whether it was written."""
    said = [*model.notes, *(f"{f.why} {f.tried}" for f in model.left_out)]
    names = str(path) if any(str(path) in line for line in said) else None
    return _write(key, "model", [answer, shape], faces=model.face_count, names=names)


class Answers:
    """The kernel's answers to operations on one cached model (``KEY.answer`` entries,
    their key from the model's and the operation's name and arguments): what
    :class:`~gshade.cad.process.KernelProcess` asks before it asks the kernel."""

    def __init__(self, key: str) -> None:
        self.key = key

    def _key(self, operation: str, args: tuple, kwargs: dict) -> str | None:
        """The answer's key (:func:`gshade.cad.cache_keys.answer_key`); None for a call
        not to keep."""
        return answer_key(self.key, operation, args, kwargs)

    def get(self, operation: str, args: tuple, kwargs: dict) -> bytes | None:
        """The answer kept for the call (the child's answer message), or None."""
        key = self._key(operation, args, kwargs)
        found = None if key is None else _read(key, "answer")
        return None if found is None or len(found[1]) != 1 else found[1][0]

    def put(self, operation: str, args: tuple, kwargs: dict, answer: bytes) -> None:
        """Keep the child's answer message to the call."""
        key = self._key(operation, args, kwargs)
        if key is not None:
            _write(key, "answer", [answer], model=self.key, operation=operation)


# --------------------------------------------------------------------------- the kernel


def shape_bytes(shape: Any) -> bytes:
    """The kernel's shape in Open CASCADE's binary format (no triangulations: the mesher
    makes its own), exact: read back it has the same faces in the same order, with the same
    orientations, surfaces, curves and tolerances (in the kernel's child)."""
    from OCP.BinTools import BinTools, BinTools_FormatVersion

    stream = io.BytesIO()
    version = BinTools_FormatVersion.BinTools_FormatVersion_CURRENT
    BinTools.Write_s(shape, stream, False, False, version)
    return stream.getvalue()


def restored_model(answer: bytes, shape: bytes, path: str) -> CadModel:
    """A cached model with its kernel shape, in the kernel's child: ``answer`` unpickled
    through the allow-list, ``shape`` read by the kernel (:func:`shape_bytes`), checked to
    have the model's kernel faces.

    Raises
    ------
    GshadeError
        When the entry is no such model (the caller reads the file afresh).
    """
    from OCP.BinTools import BinTools
    from OCP.TopoDS import TopoDS_Shape

    from .kernel import shape_faces

    kind, model = allowed_answer(answer)
    if kind != "ok" or not isinstance(model, CadModel):
        raise GshadeError(f"{path}: the cached read is not a model")
    kernel_shape = TopoDS_Shape()
    BinTools.Read_s(kernel_shape, io.BytesIO(shape))
    faces = 0 if kernel_shape.IsNull() else len(shape_faces(kernel_shape))
    if faces != len(model.kernel_numbers()):
        raise GshadeError(f"{path}: the cached shape has {faces} faces for the model's")
    model.path, model.brep = Path(path), kernel_shape
    return model


# --------------------------------------------------------------------------- in memory

# (key, path, pid) -> the kernel process of a model in use, and the model without it
_live: dict[tuple[str, str, int], tuple[weakref.ref, CadModel]] = {}
_live_lock = threading.Lock()


def live_model(key: str, path: str | os.PathLike) -> CadModel | None:
    """A model of the same read that this process still uses (its kernel process running):
    a new :class:`~gshade.cad.CadModel` with the same faces and kernel process; None
    when there is none."""
    with _live_lock:
        found = _live.get((key, str(path), os.getpid()))
    if found is None:
        return None
    kernel = found[0]()
    if kernel is None or not kernel.running:
        return None
    template = found[1]
    return replace(
        template,
        faces=list(template.faces),
        left_out=list(template.left_out),
        notes=list(template.notes),
        brep=kernel,
    )


def remember(key: str, path: str | os.PathLike, model: CadModel) -> CadModel:
    """Note ``model`` (its ``brep`` a kernel process) as in use, for :func:`live_model`,
    while its kernel process lives; the model."""
    where = (key, str(path), os.getpid())

    def gone(_: object) -> None:
        with _live_lock:
            if _live.get(where, (None,))[0] is ref:
                del _live[where]

    ref = weakref.ref(model.brep, gone)
    with _live_lock:
        _live[where] = (ref, replace(model, brep=None))
    return model
