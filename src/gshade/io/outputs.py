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
  that exists as a symbolic link is replaced, not followed; a read-only target is not
  replaced, and a writable one keeps its permission bits.
- Nothing is written through a symbolic link below a folder the user chose: subfolders are
  made by :func:`gshade.io.output_folders.output_folder`, which refuses a link, and inside
  a :func:`confined` folder :func:`staged` refuses a target below it reached through a link.
- No output replaces an input or another output (:func:`distinct_files`, and
  :func:`staged` for its own targets), compared by their resolved paths.
- Folders (subfolders, folders to make, locks): :mod:`gshade.io.output_folders`.
- Names and messages shown (printed, or written into XML, HTML and JSON) go through
  :func:`gshade.io.printable.printable`.
"""

from __future__ import annotations

import os
import re
import socket
import stat
import tempfile
import unicodedata
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from ..errors import GshadeError

__all__ = [
    "HOST",
    "MAX_NAME_BYTES",
    "atomic_write",
    "check_target",
    "confined",
    "discard_temporaries",
    "distinct_files",
    "new_file_mode",
    "output_file",
    "output_name",
    "remove_stale_temporaries",
    "staged",
    "write_all",
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


# --------------------------------------------------------------------------- names


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


def _umask() -> int:
    """The process's umask, read without changing it where the system says it (Linux's
    ``/proc/self/status``); elsewhere set and put back at once."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def new_file_mode() -> int:
    """The permission bits of a new file: 0666 less the process's umask."""
    return 0o666 & ~_umask()


def _target_problem(target: Path) -> str | None:
    """Why ``target`` cannot be written (replaced by a temporary renamed onto it), or None."""
    try:
        st = os.lstat(target)
    except FileNotFoundError:
        st = None
    except (OSError, ValueError) as exc:
        return getattr(exc, "strerror", None) or str(exc)
    if st is not None and stat.S_ISDIR(st.st_mode):
        return "it is a directory"
    if st is not None and not (stat.S_ISREG(st.st_mode) or stat.S_ISLNK(st.st_mode)):
        return "it exists and is not a regular file"
    if st is not None and stat.S_ISREG(st.st_mode) and _read_only(target, st):
        return (
            f"it is read-only (mode {stat.S_IMODE(st.st_mode):04o}; gshade does not replace a "
            "read-only file)"
        )
    if len(os.fsencode(target.name)) > 255:
        return "the file name is longer than 255 bytes"
    return _through_link(target)


def _read_only(path: Path, st: os.stat_result) -> bool:
    """Whether a regular file is read-only: no write bit at all (as root too), or none for
    this process."""
    return not st.st_mode & 0o222 or not os.access(path, os.W_OK)


def check_target(target: str | os.PathLike) -> Path:
    """``target`` if a file can be written there (:func:`staged` would accept it; its folder
    is not looked at), else a :class:`GshadeError` naming it: a directory, a device, a
    read-only file, a name over 255 bytes, a link on the way below a :func:`confined`
    folder.  Nothing is created."""
    path = Path(target)
    problem = _target_problem(path)
    if problem is not None:
        raise GshadeError(f"{path}: cannot write the file: {problem}")
    return path


def _temporary(target: Path) -> str:
    """Create the temporary file that will become ``target`` (in the same folder)."""
    problem = _target_problem(target)
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


def _mode(target: Path) -> int:
    """The permission bits a file replacing ``target`` gets: those of the regular file it
    replaces, else the ordinary ones (0666 less the umask)."""
    try:
        st = os.lstat(target)
    except OSError:
        st = None
    if st is not None and stat.S_ISREG(st.st_mode):
        return stat.S_IMODE(st.st_mode) & 0o777
    return new_file_mode()


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
        directory, a device or a read-only file, its name is too long, it is reached
        through a link below a :func:`confined` folder), or two targets are one file,
        naming the target.
    """
    paths = [Path(t) for t in targets]
    _distinct_outputs([(str(p), p) for p in paths])
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
                os.chmod(name, _mode(path))
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


def write_all(
    jobs: Sequence[tuple[str, Callable[[], Callable[[str], object]], str | os.PathLike]],
) -> None:
    """For each job (name, make, target), :func:`write_to` ``(name, make(), target)``: the
    jobs side by side, a thread each (the writers' encoders and compressors let go of the
    interpreter: an EXR and its PNG take about as long as the longer of the two); the first
    job's error is raised first, once every job has ended."""
    if len(jobs) < 2:
        for name, make, target in jobs:
            write_to(name, make(), target)
        return
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(len(jobs), thread_name_prefix="gshade-write") as pool:
        ends = [pool.submit(lambda j: write_to(j[0], j[1](), j[2]), job) for job in jobs]
    for end in ends:
        end.result()


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


# --------------------------------------------------------------------------- folders

#: The folders of :func:`confined` blocks: (absolute path, as the user wrote it).
_roots: list[tuple[str, str]] = []


@contextmanager
def confined(root: str | os.PathLike) -> Iterator[Path]:
    """A block in which nothing is written through a symbolic link below ``root``.

    ``root`` itself may be a link (the user chose it); but while the block runs,
    :func:`staged` (and so :func:`atomic_write` and every writer) refuses a target whose
    folder lies below ``root`` and is reached through a link there (``root/views ->
    elsewhere``), with a :class:`GshadeError` naming the link.  Blocks nest.
    """
    entry = (os.path.abspath(root), str(root))
    _roots.append(entry)
    try:
        yield Path(root)
    finally:
        _roots.remove(entry)


def _through_link(target: Path) -> str | None:
    """Why ``target`` is reached through a symbolic link below a :func:`confined` folder,
    or None."""
    parent = os.path.abspath(target.parent)
    for root, shown in _roots:
        if not parent.startswith(root.rstrip(os.sep) + os.sep):
            continue
        current = root
        for part in os.path.relpath(parent, root).split(os.sep):
            current = os.path.join(current, part)
            try:
                st = os.lstat(current)
            except OSError:
                break  # missing: creating the temporary says so
            if stat.S_ISLNK(st.st_mode):
                inside = os.path.join(shown, os.path.relpath(current, root))
                return (
                    f"{inside} is a symbolic link (nothing is written through a link inside "
                    f"{shown})"
                )
    return None


# --------------------------------------------------------------------------- inputs


def _input_key(path: str | os.PathLike) -> str:
    return os.path.realpath(path)


def _output_key(path: str | os.PathLike) -> str:
    """Where an output lands: its folder resolved, its own name not (a link there is
    replaced, not followed)."""
    path = Path(path)
    return os.path.join(os.path.realpath(path.parent), path.name)


def _inode(path: str | os.PathLike, follow: bool) -> tuple[int, int] | None:
    try:
        st = os.stat(path) if follow else os.lstat(path)
    except (OSError, ValueError):
        return None
    if not follow and stat.S_ISLNK(st.st_mode):
        return None
    return st.st_dev, st.st_ino


def _same(a_key: str, a_inode: tuple | None, b_key: str, b_inode: tuple | None) -> bool:
    return a_key == b_key or (a_inode is not None and a_inode == b_inode)


def _distinct_outputs(outputs: Sequence[tuple[str, str | os.PathLike]]) -> None:
    """Refuse two ``(label, path)`` outputs that are one file."""
    seen: list[tuple[str, str, tuple | None]] = []
    for label, path in outputs:
        key, inode = _output_key(path), _inode(path, follow=False)
        for other_label, other_key, other_inode in seen:
            if _same(key, inode, other_key, other_inode):
                raise GshadeError(
                    f"{label}: expected a file other than {other_label} (one file cannot hold "
                    "two outputs)"
                )
        seen.append((label, key, inode))


def distinct_files(
    inputs: Iterable[tuple[str, str | os.PathLike]],
    outputs: Iterable[tuple[str, str | os.PathLike | None]],
    *,
    among_outputs: bool = True,
) -> None:
    """Refuse outputs that would replace an input, or each other.

    Files are compared by their resolved paths (an input's links followed; an output's
    folder resolved but not its own name, since a link there is replaced, not followed)
    and, where both exist, by device and inode (hard links, case-insensitive names).

    Parameters
    ----------
    inputs : iterable of (label, path)
        The files the command reads, e.g. ``("the scene file", "scene.toml")``.
    outputs : iterable of (label, path or None)
        The files it writes, e.g. ``("-o", "out.exr")``; None entries are skipped.
    among_outputs : bool
        Also refuse two outputs that are one file.

    Raises
    ------
    GshadeError
        One line: ``LABEL PATH: expected a file other than INPUT ...``.
    """
    wanted = [(label, path) for label, path in outputs if path is not None and str(path)]
    read = [(label, path, _input_key(path), _inode(path, follow=True)) for label, path in inputs]
    for label, path in wanted:
        key, inode = _output_key(path), _inode(path, follow=False)
        for in_label, in_path, in_key, in_inode in read:
            if _same(key, inode, in_key, in_inode):
                raise GshadeError(
                    f"{label} {path}: expected an output other than {in_label} {in_path} "
                    "(it would be replaced)"
                )
    if among_outputs:
        _distinct_outputs([(f"{label} {path}", path) for label, path in wanted])
