"""Reading input files with one-line errors that name the file and what went wrong.

Inputs must be regular files of bounded size: a FIFO, a device (``/dev/zero``) or a socket
given where a scene, a data file or an image is expected is refused at once, without
blocking or reading without end.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from ..errors import GshadeError

__all__ = ["describe_fields", "file_kind", "read_bytes", "require_regular_file"]

_KINDS = (
    (stat.S_ISDIR, "a directory"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def file_kind(path: str | os.PathLike) -> str | None:
    """What a path names that is not a regular file (``"a directory"``, ``"a FIFO (named
    pipe)"``, ...), following symbolic links; None for a regular file.

    Raises
    ------
    OSError
        As :func:`os.stat` does (no such file, a symbolic-link loop, no permission).
    """
    mode = os.stat(path).st_mode
    for test, kind in _KINDS:
        if test(mode):
            return kind
    return None if stat.S_ISREG(mode) else "not a regular file"


def require_regular_file(
    path: str | os.PathLike, expected: str, error: type[GshadeError] = GshadeError
) -> Path:
    """``path``, checked to name an existing regular file (symbolic links followed).

    Raises
    ------
    error
        ``PATH: no such file``, ``PATH: cannot read the file (Too many levels of symbolic
        links)`` (a link loop, or another reason the system gives), or ``PATH: expected
        EXPECTED (a regular file), got a directory`` (a FIFO, a device, a socket).
    """
    path = Path(path)
    try:
        kind = file_kind(path)
    except FileNotFoundError:
        raise error(f"{path}: no such file") from None
    except (OSError, ValueError) as exc:
        raise error(
            f"{path}: cannot read the file ({getattr(exc, 'strerror', None) or exc})"
        ) from None
    if kind is not None:
        raise error(f"{path}: expected {expected} (a regular file), got {kind}")
    return path


def read_bytes(
    path: str | os.PathLike,
    expected: str,
    error: type[GshadeError] = GshadeError,
    size: int = -1,
    limit: int | None = None,
) -> bytes:
    """The bytes of a regular file (its first ``size`` if given).

    Parameters
    ----------
    path : path-like
    expected : str
        What the file should be, for messages ("an OBJ file").
    error : type
        The GshadeError subclass to raise.
    size : int
        Read at most this many bytes (-1: all).
    limit : int, optional
        Refuse files larger than this many bytes.

    Raises
    ------
    error
        Naming the file when it does not exist, is not a regular file (a directory, FIFO,
        device or socket), is larger than ``limit``, or cannot be read.
    """
    path = Path(path)
    try:
        # O_NONBLOCK: opening a FIFO must not wait for a writer
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise error(f"{path}: no such file") from None
    except IsADirectoryError:
        raise error(f"{path}: expected {expected}, got a directory") from None
    except (OSError, ValueError) as exc:
        raise error(
            f"{path}: cannot read the file ({getattr(exc, 'strerror', None) or exc})"
        ) from None
    try:
        info = os.fstat(fd)
        for test, kind in _KINDS:
            if test(info.st_mode):
                raise error(f"{path}: expected {expected} (a regular file), got {kind}")
        if limit is not None and info.st_size > limit:
            raise error(
                f"{path}: expected {expected} of at most {limit / 2**20:g} MB, got "
                f"{info.st_size / 2**20:.1f} MB"
            )
        os.set_blocking(fd, True)
        with os.fdopen(os.dup(fd), "rb") as f:
            return f.read(size)
    except OSError as exc:
        raise error(f"{path}: cannot read the file ({exc.strerror or exc})") from None
    finally:
        os.close(fd)


def describe_fields(fields: list[str]) -> str:
    """What a line of a data file held, without its content (which may be a secret that
    should not reach a CI log): ``a line of 3 fields (not shown)``."""
    n = len(fields)
    return f"a line of {n} field{'s' if n != 1 else ''} (not shown)" if n else "an empty line"
