"""Where outputs go and how they land: checked names, staged writes, no temporaries left.

Every file gshade writes goes through this module:

- A name that becomes a file name (a scene's ``name``, a sweep's label, a reference) is
  checked by :func:`output_name`: no path separators, no ``..``, no NUL or other control
  characters, no leading dot, at most :data:`MAX_NAME_BYTES` bytes in UTF-8.  Joined to the
  folder the user chose by :func:`output_file`, it cannot leave that folder.
- Files are written to temporaries in the target's folder and renamed onto their targets
  only when every one of them was written (:func:`staged`): a reader never sees a
  half-written file, and a command that fails leaves every target as it was.  The
  temporaries are created before the work starts, so an unwritable target fails at once.
- Temporaries carry the writing machine's name and process id
  (``.NAME.HOST.PID-XXXXXXXX.gshade-tmp.SUFFIX``); whatever the way a process ends, those it
  leaves behind are removed by the next run on that machine that writes into that folder
  (:func:`remove_stale_temporaries`); those of other machines are left alone.  A target
  that exists as a symbolic link is replaced, not followed.
"""

from __future__ import annotations

import os
import re
import socket
import stat
import tempfile
import unicodedata
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from functools import cache
from pathlib import Path

from ..errors import GshadeError

__all__ = [
    "HOST",
    "MAX_NAME_BYTES",
    "atomic_write",
    "discard_temporaries",
    "output_file",
    "output_name",
    "remove_stale_temporaries",
    "staged",
    "write_to",
]

#: Longest output name in UTF-8 bytes: with ``.exr``, ``.png`` or ``.log`` it stays well
#: within the 255 bytes that file systems allow a file name.
MAX_NAME_BYTES = 200
#: Characters of the target's name kept in a temporary's name (its full name may be long).
_TEMP_STEM = 40
_TEMPORARY = re.compile(
    r"^\..*\.(?P<host>[A-Za-z0-9_]+)\.(?P<pid>\d+)-[a-z0-9_]{8}\.gshade-tmp(\.[A-Za-z0-9]+)?$"
)
#: This machine's name as temporaries carry it: a folder shared between machines (a Dask
#: cluster's output folder) holds temporaries whose process ids mean nothing here.
HOST = re.sub(r"[^A-Za-z0-9_]", "_", socket.gethostname())[:32] or "host"


def output_name(name: object, what: str = "name") -> str:
    """``name`` if it can name an output file on its own, else a :class:`GshadeError`.

    Parameters
    ----------
    name : str
        The name (without suffix) that becomes ``<folder>/<name>.exr`` and the like.
    what : str
        How messages refer to the name (e.g. ``"scene.toml: name"``).
    """
    if not isinstance(name, str) or not name:
        raise GshadeError(f"{what}: expected a non-empty string, got {name!r}")
    shown = repr(name if len(name) <= 60 else name[:59] + "…")
    bad = next(
        (c for c in name if c in "/\\" or unicodedata.category(c) in ("Cc", "Cf", "Cs")),
        None,
    )
    if bad is not None:
        kind = "a path separator" if bad in "/\\" else f"the control character {bad!r}"
        raise GshadeError(
            f"{what}: expected a name usable as a file name (no path separators or control "
            f"characters), got {shown} with {kind}"
        )
    if ".." in name or name.startswith("."):
        raise GshadeError(
            f"{what}: expected a name usable as a file name (not starting with '.' and without "
            f"'..'), got {shown}"
        )
    size = len(name.encode("utf-8", "surrogatepass"))
    if size > MAX_NAME_BYTES:
        raise GshadeError(
            f"{what}: expected a name of at most {MAX_NAME_BYTES} bytes (UTF-8), got one of "
            f"{size} bytes: {shown}"
        )
    return name


def output_file(folder: str | os.PathLike, name: str, suffix: str, what: str = "name") -> Path:
    """``folder / (name + suffix)`` for a checked name (:func:`output_name`): inside
    ``folder`` whatever ``name`` holds."""
    return Path(folder) / f"{output_name(name, what)}{suffix}"


@cache
def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _temporary(target: Path) -> str:
    """Create the temporary file that will become ``target`` (in the same folder)."""
    problem = None
    try:
        st = os.lstat(target)
    except FileNotFoundError:
        st = None
    except (OSError, ValueError) as exc:
        problem = getattr(exc, "strerror", None) or str(exc)
    if st is not None and stat.S_ISDIR(st.st_mode):
        problem = "it is a directory"
    elif st is not None and not (stat.S_ISREG(st.st_mode) or stat.S_ISLNK(st.st_mode)):
        problem = "it exists and is not a regular file"
    elif problem is None and len(os.fsencode(target.name)) > 255:
        problem = "the file name is longer than 255 bytes"
    if problem is None:
        stem = target.name[:_TEMP_STEM]
        try:
            fd, name = tempfile.mkstemp(
                dir=target.parent,
                prefix=f".{stem}.{HOST}.{os.getpid()}-",
                suffix=f".gshade-tmp{''.join(target.suffixes[-1:])}",
            )
            os.close(fd)
            _live.add(name)
            return name
        except (OSError, ValueError) as exc:
            problem = getattr(exc, "strerror", None) or str(exc)
            if isinstance(exc, FileNotFoundError):
                problem = f"the folder {target.parent} does not exist"
    raise GshadeError(f"{target}: cannot write the file: {problem}")


#: This process's temporaries not yet renamed onto their targets (for signal handlers).
_live: set[str] = set()
#: Folders already rid of stale temporaries by this process.
_cleaned: set[Path] = set()


def _discard(names: Sequence[str]) -> None:
    for name in names:
        _live.discard(name)
        try:
            os.unlink(name)
        except OSError:
            pass


def discard_temporaries() -> None:
    """Remove every temporary this process has open (from a signal handler that is about to
    end the process: nothing it was writing may survive it)."""
    _discard(list(_live))


@contextmanager
def staged(targets: Sequence[str | os.PathLike]) -> Iterator[list[str]]:
    """Temporary file names for ``targets``, renamed onto them when the block succeeds.

    The temporaries are created on entry (so an unwritable target fails before any work);
    on any exit other than success (an exception, ``KeyboardInterrupt``, ``SystemExit``
    from a signal handler) they are removed and the targets are left untouched.

    Raises
    ------
    GshadeError
        If a target cannot be written (its folder is missing or read-only, it is a
        directory or a device, its name is too long), naming the target.
    """
    paths = [Path(t) for t in targets]
    for folder in {p.parent for p in paths} - _cleaned:  # what killed runs left, once
        remove_stale_temporaries(folder)
        _cleaned.add(folder)
    temporaries: list[str] = []
    try:
        for path in paths:
            temporaries.append(_temporary(path))
        yield temporaries
        for path, name in zip(paths, temporaries, strict=True):
            try:
                os.chmod(name, 0o666 & ~_umask())
                os.replace(name, path)
                _live.discard(name)
            except OSError as exc:
                raise GshadeError(f"{path}: cannot write the file: {exc.strerror or exc}") from exc
    except BaseException:
        _discard(temporaries)
        raise


def atomic_write(path: str | os.PathLike, suffix: str, write: Callable[[str], object]) -> Path:
    """Call ``write(temporary_name)``, then move the temporary file onto ``path``.

    ``suffix`` is kept for compatibility: the temporary's name ends in ``path``'s own suffix.
    Errors of ``write`` that are not gshade's (OSError, RuntimeError, ValueError, TypeError
    from a writer library) become a :class:`GshadeError` naming ``path``.
    """
    del suffix
    path = Path(path)
    with staged([path]) as (name,):
        write_to(name, write, path)
    return path


def write_to(name: str, write: Callable[[str], object], target: str | os.PathLike) -> None:
    """``write(name)``, its library's errors (OSError, RuntimeError, ValueError, TypeError)
    turned into a :class:`GshadeError` naming ``target``, the file ``name`` stands for."""
    try:
        write(name)
    except GshadeError:
        raise
    except (OSError, RuntimeError, ValueError, TypeError) as exc:
        raise GshadeError(f"{target}: cannot write the file: {exc}") from exc


def remove_stale_temporaries(folder: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporaries in ``folder`` left by processes of this machine that no longer
    run; return them.  Those of running processes (another gshade writing there) and of
    other machines (a shared folder) are kept."""
    removed: list[Path] = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        match = _TEMPORARY.match(entry.name)
        if match is None or not entry.is_file(follow_symlinks=False):
            continue
        if match.group("host") != HOST or _running(int(match.group("pid"))):
            continue
        try:
            os.unlink(entry.path)
            removed.append(Path(entry.path))
        except OSError:
            pass
    return removed


def _running(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True
    return True
