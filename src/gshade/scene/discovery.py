"""Finding scene files: what a file, a folder or a glob pattern names.

:func:`scene_files` is the rule ``gshade check`` and ``gshade batch`` share (a folder means
its ``*.toml``, sorted by name); each command adds its own: ``check`` a default folder and
one error when nothing is found at all, ``batch`` glob patterns, an error for each folder or
pattern without scene files, and each file once.
"""

from __future__ import annotations

import glob
import os
from pathlib import Path

from ..errors import GshadeError

__all__ = ["SCENE_FILES", "is_pattern", "scene_files"]

#: The scene files of a folder.
SCENE_FILES = "*.toml"


def is_pattern(item: str) -> bool:
    """Whether ``item`` is a glob pattern (has ``*``, ``?`` or ``[``)."""
    return any(ch in item for ch in "*?[")


def scene_files(item: str | os.PathLike, *, patterns: bool = False) -> list[Path]:
    """The scene files one item names.

    Parameters
    ----------
    item : path-like
        A folder (its ``*.toml``, sorted by name), any other existing path or symbolic link
        (itself: one that is not a regular file, or a link that leads nowhere, is refused
        when it is read), or with ``patterns`` a glob
        pattern (the paths it matches, sorted; ``**`` matches folders recursively).
    patterns : bool
        Expand glob patterns.

    Returns
    -------
    list of Path
        Possibly empty: a folder or a pattern may name no scene file.

    Raises
    ------
    GshadeError
        ``ITEM: no such scene file or folder`` for a path that does not exist.
    """
    text = os.fspath(item)
    if patterns and is_pattern(text):
        return [Path(p) for p in sorted(glob.glob(text, recursive=True))]
    path = Path(text)
    if path.is_dir():
        return sorted(path.glob(SCENE_FILES))
    if path.exists() or path.is_symlink():  # a link loop or a dangling link: reading says so
        return [path]
    raise GshadeError(f"{text}: no such scene file or folder")
