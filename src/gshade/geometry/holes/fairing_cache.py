"""Optimised hole fillings, cached by content: the optimisation of
:func:`gshade.geometry.holes.fairing.optimise_fairing` is seconds a hole, and a scene that loads
again (a batch's planning and its job, a check, a figure's panels) gives the same points.

:func:`optimise_filling` (what a scene's ``optimise`` key runs: seconds per hole) keeps its
results by content: the key is a SHA-256 of the start x0, the basis Z, n, the
degree, the measure, the steps, ``free``, the versions of gshade, numpy and scipy and the
source of the modules the result depends on, so an entry is found only for the same
computation.  Entries live in memory (:data:`CACHE_ENTRIES` per process) and on disk,
one small file per filling in :func:`cache_folder` (``$GSHADE_CACHE_DIR``, else
``$XDG_CACHE_HOME/gshade`` or ``~/.cache/gshade``, subfolder ``hole-shape``;
``GSHADE_CACHE_DIR=off``: memory only).  A file is written to a temporary beside it and
renamed (concurrent writers each put a whole file there), and one read back is trusted only
if it is a regular file (not a link) of bounded size, its header names the same key, its
checksum and shape fit, its points are finite, its move x - x0 lies in the span of Z (so
the junction conditions hold as for a fresh result) and its ``final_check`` is what the
points give; otherwise it is ignored and recomputed (and overwritten).  Deleting the folder
is always safe.
"""

from __future__ import annotations

import hashlib
import json
import threading
import time
from collections import OrderedDict
from dataclasses import asdict, fields, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...runtime.cache_folder import CACHE_VARIABLE, read_entry, write_entry
from ...runtime.cache_folder import cache_folder as shared_cache_folder
from ..core.blas_threads import single_threaded_blas
from .fairing import (
    FAIRING_FUNCTIONALS,
    FREE,
    ITERATIONS,
    FairingReport,
    fairing_value,
    optimise_fairing,
)
from .fill import HoleFilling, filling_patches

__all__ = ["CACHE_ENTRIES", "CACHE_VARIABLE", "cache_folder", "optimise_filling"]


@single_threaded_blas
def optimise_filling(
    filling: HoleFilling, measure: str, *, iterations: int = ITERATIONS, free: str = "all"
) -> HoleFilling:
    """The hole filling with ``measure`` lowered by :func:`optimise_fairing` within the space
    of fillings meeting the same conditions (``filling.free_basis``); ``fairing`` holds the
    report, ``energy`` stays the quadratic solution's.

    The result is cached by content, in memory and on disk (module docstring, *Cache*): the
    same filling, measure, steps and ``free`` give the same points without the optimisation.
    """
    start = time.perf_counter()
    n = len(filling.patches)
    x0, Z = np.asarray(filling.nets, dtype=np.float64), np.asarray(filling.free_basis)
    key = None
    if isinstance(measure, str) and measure in FAIRING_FUNCTIONALS and free in FREE:
        key = _cache_key(x0, Z, n, filling.degree, measure, iterations, free)
    found = None if key is None else _cached(key, x0, Z, n, filling.degree, measure)
    if found is not None:
        x, info = found
        info = replace(info, seconds=time.perf_counter() - start, cached=True)
    else:
        x, info = optimise_fairing(
            x0, Z, n, filling.degree, measure, iterations=iterations, free=free
        )
        if key is not None:
            _store(key, x, info)
    patches = filling_patches(x, n, filling.degree)
    return replace(filling, patches=patches, nets=x, fairing=info)


# --------------------------------------------------------------------------- the cache

#: Optimised fillings kept in memory per process (the least recently used go first).
CACHE_ENTRIES = 512
#: The first line of a cache file, and the largest file read (n = 100 patches of degree 9:
#: 240 kB of points).
_MAGIC = b"gshade hole-shape cache 1\n"
_MAX_CACHE_FILE = 4 * 2**20
#: A cached move x - x0 must lie in the span of Z to this (relative to the points' size).
_SPAN_TOL = 1e-9
_memory: OrderedDict[str, tuple[NDArray[np.float64], FairingReport]] = OrderedDict()
_lock = threading.Lock()


def cache_folder() -> Path | None:
    """The folder of the cached optimised fillings: ``$GSHADE_CACHE_DIR/hole-shape``, else
    ``$XDG_CACHE_HOME/gshade/hole-shape`` (an absolute path) or
    ``~/.cache/gshade/hole-shape``; None with ``GSHADE_CACHE_DIR=off`` (or no home)
    (:func:`gshade.runtime.cache_folder.cache_folder`)."""
    return shared_cache_folder("hole-shape")


@lru_cache(maxsize=1)
def _fingerprint() -> bytes:
    """What a result depends on besides its inputs: the versions and the source of the
    modules of the optimisation (an edit to them is another computation)."""
    import scipy

    from ... import __version__
    from ..core import bernstein, differential, jets
    from . import fairing, fill

    h = hashlib.sha256(f"{__version__} {np.__version__} {scipy.__version__}".encode())
    modules = (fairing.__file__, jets.__file__, differential.__file__, bernstein.__file__)
    for module in (*modules, fill.__file__):
        try:
            h.update(Path(str(module)).read_bytes())
        except OSError:
            h.update(str(module).encode())
    return h.digest()


def _cache_key(
    x0: NDArray[np.float64],
    Z: NDArray[np.float64],
    n: int,
    degree: int,
    measure: str,
    iterations: Any,
    free: str,
) -> str | None:
    """The SHA-256 (hex) naming one optimisation; None for inputs that are not arrays of
    numbers (the optimisation says what is wrong with them)."""
    if Z.dtype.kind not in "fiu" or isinstance(iterations, bool):
        return None
    if not isinstance(iterations, (int, np.integer)):
        return None
    h = hashlib.sha256(_MAGIC + _fingerprint())
    head = [int(n), int(degree), measure, int(iterations), free, x0.shape, Z.shape]
    h.update(json.dumps(head).encode())
    h.update(np.ascontiguousarray(x0, dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(Z, dtype="<f8").tobytes())
    return h.hexdigest()


def _cached(
    key: str,
    x0: NDArray[np.float64],
    Z: NDArray[np.float64],
    n: int,
    degree: int,
    measure: str,
) -> tuple[NDArray[np.float64], FairingReport] | None:
    """The cached result of ``key``: from memory, else from a file checked to be sound."""
    with _lock:
        if key in _memory:
            _memory.move_to_end(key)
            x, info = _memory[key]
            return x.copy(), info
    folder = cache_folder()
    if folder is None:
        return None
    found = _read_entry(folder / f"{key}.bin", key, x0.shape)
    if found is None:
        return None
    x, info = found
    if not _sound(x, info, x0, Z, n, degree, measure):
        return None
    _remember(key, x, info)
    return x, info


def _read_entry(
    path: Path, key: str, shape: tuple[int, ...]
) -> tuple[NDArray[np.float64], FairingReport] | None:
    """A cache file's points and report, or None for any file that is not a whole entry of
    this key (missing, a link, not a regular file, too large, truncated, another format)."""
    data = read_entry(path, _MAX_CACHE_FILE)
    if data is None:
        return None
    try:
        if not data.startswith(_MAGIC) or len(data) > _MAX_CACHE_FILE:
            return None
        end = data.index(b"\n", len(_MAGIC))
        header = json.loads(data[len(_MAGIC) : end].decode("utf-8"))
        payload = data[end + 1 :]
        if not isinstance(header, dict) or header.get("key") != key:
            return None
        if header.get("sha256") != hashlib.sha256(payload).hexdigest():
            return None
        if len(payload) != 8 * int(np.prod(shape)):
            return None
        x = np.frombuffer(payload, dtype="<f8").astype(np.float64).reshape(shape)
        report = _report(header.get("info"))
    except (ValueError, TypeError, KeyError, UnicodeDecodeError, RecursionError):
        return None
    if report is None or not np.all(np.isfinite(x)):
        return None
    return x, report


def _report(raw: Any) -> FairingReport | None:
    """A :class:`FairingReport` from a cache file's JSON, each field of its type."""
    if not isinstance(raw, dict):
        return None
    kinds: dict[str, type] = {"float": float, "int": int, "bool": bool, "str": str}
    values: dict[str, Any] = {}
    for f in fields(FairingReport):
        if f.name in ("cached", "seconds"):
            continue
        value: Any = raw.get(f.name)
        kind = kinds[str(f.type)]
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if type(value) is not kind:
            return None
        if isinstance(value, str) and len(value) > 1000:
            return None
        values[f.name] = value
    if values["measure"] not in FAIRING_FUNCTIONALS:
        return None
    return FairingReport(seconds=0.0, **values)


def _sound(
    x: NDArray[np.float64],
    info: FairingReport,
    x0: NDArray[np.float64],
    Z: NDArray[np.float64],
    n: int,
    degree: int,
    measure: str,
) -> bool:
    """Whether cached points are a filling this optimisation could give: x - x0 in the span
    of Z (the junction conditions hold) and the report's ``final_check`` theirs."""
    if info.measure != measure:
        return False
    move = x - x0
    scale = max(1.0, float(np.abs(x0).max()))
    if Z.shape[1]:
        Y = np.linalg.lstsq(Z, move, rcond=None)[0]
        move = move - Z @ Y
    if not float(np.abs(move).max()) <= _SPAN_TOL * scale:
        return False
    check = fairing_value(x, n, degree, measure, quadrature=2 * info.quadrature)
    return bool(abs(check - info.final_check) <= 1e-9 * max(abs(check), 1e-300))


def _remember(key: str, x: NDArray[np.float64], info: FairingReport) -> None:
    with _lock:
        _memory[key] = (x.copy(), replace(info, cached=False))
        _memory.move_to_end(key)
        while len(_memory) > CACHE_ENTRIES:
            _memory.popitem(last=False)


def _store(key: str, x: NDArray[np.float64], info: FairingReport) -> None:
    """Keep a result in memory and, best effort, on disk (an unwritable folder: memory)."""
    _remember(key, x, info)
    folder = cache_folder()
    if folder is None:
        return
    payload = np.ascontiguousarray(x, dtype="<f8").tobytes()
    report = {k: v for k, v in asdict(info).items() if k not in ("cached", "seconds")}
    header = {"key": key, "sha256": hashlib.sha256(payload).hexdigest(), "info": report}
    write_entry(folder, f"{key}.bin", [_MAGIC, json.dumps(header).encode(), b"\n", payload])
