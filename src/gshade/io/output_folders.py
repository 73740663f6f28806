"""Output folders: subfolders made never through a link, the folders a command needs made
only once nothing is left to refuse (and removed again if it fails), and a lock for a folder
written by one command at a time.  Files are written into them by :mod:`gshade.io.outputs`.
"""

from __future__ import annotations

import errno
import os
import stat
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import NoReturn

from ..errors import GshadeError
from .outputs import new_file_mode, output_name

__all__ = ["LOCK_NAME", "created_folders", "folder_lock", "missing_folders", "output_folder"]


def output_folder(parent: str | os.PathLike, name: str, *, create: bool = True) -> Path:
    """The subfolder ``parent/name`` of an output folder, made if need be (``create``),
    never through a symbolic link.

    Parameters
    ----------
    parent : path-like
        The folder the user chose (it may itself be a link).
    name : str
        The subfolder's name (``"views"``, ``"logs"``): one name, checked by
        :func:`output_name`.
    create : bool
        Make it when it does not exist; with False only check what is there.

    Returns
    -------
    Path
        ``parent / name``.

    Raises
    ------
    GshadeError
        If it exists as a symbolic link (even to a folder) or as something other than a
        folder, or cannot be made, naming it.
    """
    folder = Path(parent) / output_name(name, f"{parent}: subfolder")
    if create:
        try:
            os.mkdir(folder)
        except FileExistsError:
            pass
        except OSError as exc:
            raise GshadeError(f"{folder}: cannot create the folder ({exc.strerror})") from None
    try:
        st = os.lstat(folder)
    except FileNotFoundError:
        if create:
            raise GshadeError(f"{folder}: cannot create the folder (it vanished)") from None
        return folder
    except OSError as exc:
        raise GshadeError(f"{folder}: cannot use the folder ({exc.strerror})") from None
    if stat.S_ISLNK(st.st_mode):
        raise GshadeError(
            f"{folder}: expected a folder, got a symbolic link (nothing is written through a "
            f"link inside {parent})"
        )
    if not stat.S_ISDIR(st.st_mode):
        raise GshadeError(f"{folder}: expected a folder, got a file that is not one")
    return folder


def missing_folders(folder: str | os.PathLike, head: str | None = None) -> list[Path]:
    """The folders to make so that ``folder`` exists, outermost first (none if it exists);
    nothing is made.

    Raises
    ------
    GshadeError
        If ``folder`` or the nearest existing path above it is not a folder, or the folders
        could not be made there (no write permission): ``HEAD (why)``, ``head`` by default
        ``FOLDER: cannot create the folder``.
    """
    path = Path(folder)
    head = head or f"{path}: cannot create the folder"
    missing: list[Path] = []
    current = path
    while True:
        try:
            st = os.stat(current)  # links are followed: the user chose this path
        except (FileNotFoundError, NotADirectoryError):  # (a file on the way: said below)
            missing.append(current)
            if current.parent == current:
                break
            current = current.parent
            continue
        except (OSError, ValueError) as exc:
            reason = getattr(exc, "strerror", None) or str(exc)
            raise GshadeError(f"{head} ({current}: {reason})") from None
        if not stat.S_ISDIR(st.st_mode):
            raise GshadeError(f"{head} ({current} exists and is not a folder)")
        if missing and not os.access(current, os.W_OK | os.X_OK):
            raise GshadeError(f"{head} ({current}: permission denied)")
        break
    return missing[::-1]


@contextmanager
def created_folders(folders: Iterable[str | os.PathLike]) -> Iterator[list[Path]]:
    """Make ``folders`` (as :func:`missing_folders` lists them, outermost first) for a
    block; if the block fails, those still empty are removed again.

    Raises
    ------
    GshadeError
        If one cannot be made (those made before it are removed), naming it.
    """
    made: list[Path] = []

    def undo() -> None:
        for path in reversed(made):
            try:
                os.rmdir(path)
            except OSError:
                pass

    for folder in dict.fromkeys(Path(f) for f in folders):
        try:
            os.mkdir(folder)
        except FileExistsError:
            continue
        except OSError as exc:
            undo()
            raise GshadeError(f"{folder}: cannot create the folder ({exc.strerror})") from None
        made.append(folder)
    try:
        yield made
    except BaseException:
        undo()
        raise


#: The lock file :func:`folder_lock` falls back on where a folder cannot be locked itself.
LOCK_NAME = ".gshade.lock"


@contextmanager
def folder_lock(folder: str | os.PathLike, busy: str) -> Iterator[Path]:
    """Hold an exclusive lock on ``folder`` for a block, or refuse at once.

    The folder itself is locked (``flock`` on the directory: nothing is written into it);
    where its file system cannot lock a directory (NFS emulates ``flock`` with POSIX locks,
    which need a file open for writing) the lock is taken on the empty hidden file
    ``folder/.gshade.lock`` instead, which then stays (removing it would race with the next
    run).  The lock is not waited for: while another process holds it, a
    :class:`GshadeError` ``FOLDER: BUSY`` is raised and nothing is written.  It ends with
    the block, or with the process however it ends.

    Raises
    ------
    GshadeError
        If the folder is locked, is not a writable folder, or cannot be locked.
    """
    import fcntl

    path = Path(folder)

    def refuse(exc: OSError, what: str = "") -> NoReturn:
        reason = f"{what}is a symbolic link" if exc.errno == errno.ELOOP else exc.strerror
        raise GshadeError(f"{folder}: cannot write to the output folder ({reason})") from None

    try:
        fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    except OSError as exc:
        refuse(exc)
    try:
        if not os.access(path, os.W_OK | os.X_OK):
            raise GshadeError(f"{folder}: cannot write to the output folder (permission denied)")
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise GshadeError(f"{folder}: {busy}") from None
        except OSError:  # a directory this file system cannot lock: a lock file there
            os.close(fd)
            fd = -1
            flags = os.O_RDWR | os.O_CREAT | os.O_CLOEXEC | getattr(os, "O_NOFOLLOW", 0)
            try:
                fd = os.open(path / LOCK_NAME, flags, new_file_mode())
            except OSError as exc:
                refuse(exc, f"{path / LOCK_NAME} ")
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise GshadeError(f"{folder}: {busy}") from None
            except OSError as exc:
                raise GshadeError(
                    f"{folder}: cannot lock the output folder ({exc.strerror})"
                ) from None
        yield path
    finally:
        if fd >= 0:
            os.close(fd)
