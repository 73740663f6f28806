"""matplotlib's colour maps as tables of sRGB colours, kept in the cache folder.

A render that shows a colour map needs a table of its colours; matplotlib holds them, and
importing it costs a command more than all of its colour-map work.  So the tables of
matplotlib's own maps are kept in gshade's cache folder (subfolder ``colour-maps``, see
:mod:`gshade.runtime.cache_folder`), keyed by the name, the table's size and the installed
matplotlib (the modification times and sizes of its files that define the maps): a process
that has not imported matplotlib reads the table from there, and a name found there is a
colour map's.

A process that has imported matplotlib asks it directly (its registry may hold maps that
the program registered); an entry is written only by a process that imported matplotlib for
the lookup itself, so the folder holds matplotlib's own maps alone.  An entry that is not a
whole table of finite colours in [0, 1] is no entry.

Examples
--------
>>> table = colour_map_table("viridis", 5)
>>> table.shape, bool(((0 <= table) & (table <= 1)).all())
((5, 3), True)
>>> validate_colormap("viridis")
'viridis'
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError, show, suggest
from ..runtime.cache_folder import cache_folder, read_entry, write_entry

__all__ = ["colour_map_table", "validate_colormap"]

#: The cache folder's subfolder of the tables.
SUBFOLDER = "colour-maps"
#: matplotlib's files whose contents make its maps (their times and sizes key the entries).
_MAP_FILES = ("__init__.py", "_cm.py", "_cm_listed.py", "colors.py")
#: The longest table kept (entries larger than this many colours are no entries).
MAX_COLOURS = 1 << 16


def colour_map_table(name: str, size: int = 256) -> NDArray[np.float64]:
    """The sRGB colours (size, 3) of matplotlib's colour map ``name`` at ``size`` equally
    spaced points of [0, 1] (both ends included).

    Raises
    ------
    GshadeError
        If ``name`` is not a colour map's (:func:`validate_colormap`'s message).
    """
    kept = _kept_table(name, size)
    if kept is not None:
        return kept
    own_import = "matplotlib" not in sys.modules
    maps = _matplotlib_maps(name)
    table = np.asarray(maps[name](np.linspace(0.0, 1.0, size))[:, :3], dtype=np.float64)
    where = _entry_path(name, size)
    if own_import and where is not None:
        write_entry(where.parent, where.name, [table.astype("<f8").tobytes()])
    return table


def validate_colormap(name: Any) -> str:
    """The name of a matplotlib colour map, checked (with the nearest name when it is not one).

    Raises
    ------
    GshadeError
        ``colormap: expected the name of a matplotlib colour map ...``.
    """
    if isinstance(name, str) and _kept_table(name, 256) is not None:
        return name
    _matplotlib_maps(name)
    return name


def _matplotlib_maps(name: Any) -> Any:
    """matplotlib's registry of colour maps, ``name`` checked to be in it."""
    import matplotlib

    if not (isinstance(name, str) and name in matplotlib.colormaps):
        hint = suggest(name, list(matplotlib.colormaps)) if isinstance(name, str) else ""
        raise GshadeError(
            f'colormap: expected the name of a matplotlib colour map (e.g. "viridis"), got '
            f"{show(name)}{hint}"
        )
    return matplotlib.colormaps


def _kept_table(name: Any, size: int) -> NDArray[np.float64] | None:
    """The kept table of ``name`` at ``size`` colours; None without one (or in a process
    that has imported matplotlib)."""
    if "matplotlib" in sys.modules or not isinstance(name, str) or not 1 < size <= MAX_COLOURS:
        return None
    where = _entry_path(name, size)
    if where is None:
        return None
    data = read_entry(where, limit=size * 3 * 8)
    if data is None or len(data) != size * 3 * 8:
        return None
    table = np.frombuffer(data, dtype="<f8").reshape(size, 3).astype(np.float64)
    if not (np.isfinite(table).all() and (table >= 0).all() and (table <= 1).all()):
        return None
    return table


def _entry_path(name: str, size: int) -> Path | None:
    """Where the table of ``name`` at ``size`` colours is kept for the installed matplotlib
    (None without a cache folder or matplotlib)."""
    folder = cache_folder(SUBFOLDER)
    installed = _installed_matplotlib()
    if folder is None or installed is None:
        return None
    key = hashlib.sha256(f"{name}\0{size}\0{installed}".encode()).hexdigest()[:32]
    return folder / f"{key}.f8"


def _installed_matplotlib() -> str | None:
    """The installed matplotlib, as its map files' paths, times and sizes (no import)."""
    try:
        spec = importlib.util.find_spec("matplotlib")
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.origin:
        return None
    folder = os.path.dirname(spec.origin)
    parts = []
    for file in _MAP_FILES:
        try:
            info = os.stat(os.path.join(folder, file))
        except OSError:
            return None
        parts.append(f"{file}:{info.st_mtime_ns}:{info.st_size}")
    return f"{folder}|" + "|".join(parts)
