"""The keys of the CAD cache (:mod:`gshade.cad.cache`): what a converted model and a kernel
operation's answer depend on.

A model's key (:func:`model_key`) is a SHA-256 of the file's content (its bytes, streamed;
remembered per file signature in this process), its reader (by extension), the reading
options (``sew``, ``tolerance``) and :func:`fingerprint`: the entry format, gshade's
version, the source of the modules that read and convert with that reader
(:data:`SOURCES`, :data:`READER_SOURCES`), numpy's version and the kernel's as installed.
An answer's key (:func:`answer_key`) adds the operation, its arguments and the source of
its module (:data:`OPERATION_SOURCES`).
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import stat
from functools import lru_cache
from pathlib import Path

from ..limits import MAX_DATA_FILE_BYTES
from .readers import CAD_EXTENSIONS

__all__ = [
    "ENTRY_FORMAT",
    "OCCT_SOURCES",
    "OPERATION_SOURCES",
    "READER_SOURCES",
    "SOURCES",
    "answer_key",
    "fingerprint",
    "model_key",
]

#: The first line of a cache entry (a new format is a new line: old entries are then
#: misses, their keys other).
ENTRY_FORMAT = b"gshade cad cache 1\n"

#: The modules (relative to the package, as globs) whose source a read depends on: every
#: reader's, and each reader's own (tests/cad/test_cad_cache.py checks that these hold what
#: the readers import).
SOURCES = (
    "cad/model.py",
    "cad/readers.py",
    "cad/cache.py",
    "cad/cache_keys.py",
    "io/files.py",
    "errors.py",
    "limits.py",
    "runtime/native.py",
    "runtime/drjit_arrays.py",
    "runtime/llvm.py",
    "geometry/patches/bspline.py",
    "geometry/patches/bezier.py",
    "geometry/evaluation/bezier_cells.py",
    "geometry/core/bernstein.py",
    "geometry/core/blas_threads.py",
    "geometry/core/knots.py",
    "geometry/core/patch.py",
    "geometry/evaluation/patch_cells.py",
    "geometry/core/rational.py",
    "geometry/patches/revolution.py",
    "geometry/evaluation/spline_batches.py",
)
OCCT_SOURCES = (
    "cad/occt.py",
    "cad/kernel.py",
    "cad/healing.py",
    "cad/quadrics.py",
    "cad/step_accuracy.py",
)
READER_SOURCES = {
    "occt": OCCT_SOURCES,
    "3dm": ("cad/rhino*.py", *OCCT_SOURCES),
}
#: The modules whose source the kernel's operations depend on, beside the read's, by the
#: operations' module.
OPERATION_SOURCES = {
    "gshade.cad.mesh": ("cad/mesh.py", "geometry/evaluation/spline_batches.py"),
    "gshade.cad.edges": ("cad/edges.py",),
}


# --------------------------------------------------------------------------- the key


def model_key(path: str | os.PathLike, sew: bool | None, tolerance: float | None) -> str | None:
    """The key (SHA-256, hex) of reading ``path`` with ``sew`` and ``tolerance``: its
    content's hash, its reader, the options and :func:`fingerprint`; None for a path
    that is not a regular file of at most :data:`gshade.limits.MAX_DATA_FILE_BYTES` (the
    reader says what is wrong with it)."""
    path = Path(path)
    content = _content_hash(path)
    if content is None:
        return None
    suffix = path.suffix.lower()
    reader = CAD_EXTENSIONS.get(suffix, "")
    options = [content, reader, suffix, sew, _number(tolerance)]
    depends = fingerprint(SOURCES, *READER_SOURCES.get(reader, ()))
    return hashlib.sha256(depends + json.dumps(options).encode()).hexdigest()


def _number(value: float | None) -> str | None:
    """A tolerance as text that names its float exactly (``repr``)."""
    return None if value is None else repr(float(value))


_hashes: dict[tuple, str] = {}  # (path, device, inode, size, mtime, ctime) -> content hash


def _signature(path: Path) -> tuple | None:
    """What identifies a file's content without reading it (its path, device, inode, size
    and times), or None for what is not a regular file."""
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return None
    if not stat.S_ISREG(st.st_mode):
        return None
    return (str(path), st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)


def _content_hash(path: Path) -> str | None:
    """The SHA-256 of the file's bytes, read in chunks (remembered by its
    :func:`_signature` in this process); None for what is not a regular file of bounded
    size or cannot be read."""
    signature = _signature(path)
    if signature is None or signature[3] > MAX_DATA_FILE_BYTES:
        return None
    if signature in _hashes:
        return _hashes[signature]
    h = hashlib.sha256()
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
        with os.fdopen(fd, "rb") as f:
            if not stat.S_ISREG(os.fstat(f.fileno()).st_mode):
                return None
            while chunk := f.read(2**20):
                h.update(chunk)
    except (OSError, ValueError):
        return None
    if _signature(path) != signature:  # it changed while being read
        return None
    if len(_hashes) > 1024:
        _hashes.clear()
    _hashes[signature] = digest = h.hexdigest()
    return digest


@lru_cache(maxsize=8)
def fingerprint(*sources: str | tuple[str, ...]) -> bytes:
    """What a conversion depends on besides the file and the options: the entry format,
    gshade's version, the source of the modules ``sources`` (globs relative to the package,
    or tuples of them), numpy's version and the kernel's (:func:`_kernel_versions`)."""
    import numpy as np

    from .. import __version__

    h = hashlib.sha256(ENTRY_FORMAT + f"{__version__} numpy {np.__version__}".encode())
    h.update(json.dumps(_kernel_versions()).encode())
    package = Path(__file__).resolve().parents[1]
    patterns = [p for group in sources for p in ((group,) if isinstance(group, str) else group)]
    for pattern in patterns:
        for source in sorted(package.glob(pattern)):
            h.update(source.relative_to(package).as_posix().encode())
            try:
                h.update(hashlib.sha256(source.read_bytes()).digest())
            except OSError:
                h.update(b"unreadable")
    return h.digest()


def _kernel_versions() -> list[list[str]]:
    """The kernel's libraries as installed: per module (OCP, rhino3dm) where it is and the
    distributions beside it (``cadquery_ocp_novtk-8.0.1.1.0.dist-info``), without importing
    them (a second)."""
    import importlib.util

    found = []
    for module, distribution in (("OCP", "cadquery_ocp"), ("rhino3dm", "rhino3dm")):
        try:
            spec = importlib.util.find_spec(module)
        except (ImportError, ValueError):
            spec = None
        if spec is None or not spec.origin:
            found.append([module, "missing"])
            continue
        site = Path(spec.origin).parent.parent
        try:
            names = sorted(n for n in os.listdir(site) if n.startswith(distribution) and "-" in n)
        except OSError:
            names = []
        found.append([module, str(spec.origin), *names])
    return found


def answer_key(model: str, operation: str, args: tuple, kwargs: dict) -> str | None:
    """The key of the answer to ``operation`` ("module:name") with ``args`` and ``kwargs``
    on the model keyed ``model``: with the source of the operation's module
    (:data:`OPERATION_SOURCES`); None for an operation not kept, or arguments that do not
    pickle."""
    module = operation.partition(":")[0]
    if module not in OPERATION_SOURCES:
        return None
    try:
        call = pickle.dumps((operation, args, sorted(kwargs.items())), protocol=5)
    except Exception:  # arguments that do not pickle: not kept
        return None
    h = hashlib.sha256(fingerprint(OPERATION_SOURCES[module]))
    h.update(f"{model} {operation} ".encode() + call)
    return h.hexdigest()
