"""gshade's cache folder: where results keyed by content are kept between runs, and how an
entry is written and read.

The folder is ``$GSHADE_CACHE_DIR``, else ``$XDG_CACHE_HOME/gshade`` (an absolute path) or
``~/.cache/gshade``; ``GSHADE_CACHE_DIR=off`` turns every cache on disk off (``gshade ...
--no-cache`` sets it for one command).  Each cache has a subfolder of its own
(:func:`cache_folder`: ``hole-shape`` for the optimised hole fillings, ``cad`` for the
converted CAD models).

- **Writing** (:func:`write_entry`): into a temporary file beside the entry, renamed onto it
  (``os.replace``): concurrent writers each put a whole file there and a reader never sees a
  part of one.  A subfolder that is a symbolic link (or not a folder) is not written into,
  and an entry that is a link is replaced, never followed.  Nothing is written outside the
  subfolder.  Every failure (a full disk, a read-only folder) is silent: a cache that
  cannot be written is a cache that misses.
- **Reading** (:func:`read_entry`): only a regular file (not a link, a FIFO or a folder) of
  bounded size; anything else is no entry.  What an entry holds is the cache's to check.

Deleting the folder is always safe.

Examples
--------
>>> import os, tempfile
>>> os.environ["GSHADE_CACHE_DIR"] = root = tempfile.mkdtemp()
>>> folder = cache_folder("example")
>>> write_entry(folder, "entry.bin", [b"a whole ", b"entry"])
True
>>> read_entry(folder / "entry.bin", limit=100)
b'a whole entry'
>>> read_entry(folder / "entry.bin", limit=5) is None  # larger than the limit: no entry
True
>>> os.environ["GSHADE_CACHE_DIR"] = "off"
>>> cache_folder("example") is None
True
"""

from __future__ import annotations

import contextlib
import os
import stat
from collections.abc import Iterable
from pathlib import Path

__all__ = [
    "CACHE_VARIABLE",
    "cache_folder",
    "cache_root",
    "read_entry",
    "temporary_prefix",
    "writable_folder",
    "write_entry",
]

#: Environment variable: the folder of gshade's caches (``off``: none on disk).
CACHE_VARIABLE = "GSHADE_CACHE_DIR"


def cache_root() -> Path | None:
    """The folder of gshade's caches: ``$GSHADE_CACHE_DIR``, else ``$XDG_CACHE_HOME/gshade``
    (an absolute path) or ``~/.cache/gshade``; None with ``GSHADE_CACHE_DIR=off`` (or no
    home)."""
    given = os.environ.get(CACHE_VARIABLE, "").strip()
    if given.lower() == "off":
        return None
    if given:
        return Path(given)
    xdg = os.environ.get("XDG_CACHE_HOME", "").strip()
    if xdg and os.path.isabs(xdg):
        return Path(xdg) / "gshade"
    try:
        return Path.home() / ".cache" / "gshade"
    except (RuntimeError, KeyError, OSError):
        return None


def cache_folder(name: str) -> Path | None:
    """The subfolder ``name`` of :func:`cache_root` (None when the caches are off)."""
    root = cache_root()
    return None if root is None else root / name


def writable_folder(folder: Path) -> bool:
    """Make ``folder`` (and the folders above it, mode 0700) if need be; whether it is a
    folder to write entries into: a folder, not a symbolic link to one."""
    try:
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
        return stat.S_ISDIR(os.lstat(folder).st_mode)
    except OSError:
        return False


def temporary_prefix(name: str) -> str:
    """The start of the names of the temporaries of entry ``name`` (hidden, ``.tmp`` at the
    end): a cache's clean-up knows them by it."""
    return f".{name[:16]}."


def write_entry(folder: Path, name: str, parts: Iterable[bytes]) -> bool:
    """Write the entry ``folder/name``, its bytes the ``parts`` one after the other, whole:
    a temporary beside it renamed onto it.  False (nothing left behind) when it cannot be
    written: the folder is a link or no folder, the disk is full, ... ."""
    import tempfile  # here, not on the import path of every command

    if not writable_folder(folder):
        return False
    try:
        fd, temporary = tempfile.mkstemp(prefix=temporary_prefix(name), suffix=".tmp", dir=folder)
    except OSError:
        return False
    try:
        with os.fdopen(fd, "wb") as f:
            for part in parts:
                f.write(part)
        os.replace(temporary, folder / name)  # atomic; a link there is replaced, not followed
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        if not isinstance(exc, OSError):
            raise
        return False
    return True


def read_entry(path: Path, limit: int, touch: bool = False) -> bytes | None:
    """The bytes of the entry ``path``, or None for anything that is not one: missing, a
    symbolic link, not a regular file, larger than ``limit`` bytes, unreadable.  With
    ``touch`` its modification time becomes now (the cache's record of its last use)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOFOLLOW", 0))
    except (OSError, ValueError):
        return None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode) or info.st_size > limit:
            return None
        with os.fdopen(os.dup(fd), "rb") as f:
            data = f.read(limit + 1)
        if touch:
            with contextlib.suppress(OSError, NotImplementedError):
                os.utime(fd)
    except OSError:
        return None
    finally:
        os.close(fd)
    return data if len(data) <= limit else None
