"""The CAD kernel in a process of its own: a corrupt file costs its scene, never the run.

Open CASCADE's and openNURBS's readers are native code, and on a corrupt file (one changed
byte is enough: a misspelt entity name, a knot count of -3, a file cut in half) they may
crash the process (SIGSEGV), loop for minutes without returning to Python (so that a
SIGTERM handler, which is Python, never runs), or allocate gigabytes for a file of a
kilobyte.  So every kernel call on a model runs in a child process of its own, one per
model, started when the model is read and ended when the model is dropped (forked from a
process that has the kernel's libraries loaded: :mod:`gshade.cad.zygote`; what runs there:
:mod:`gshade.cad.kernel_child`):

- **reading** (:func:`gshade.cad.read_cad`) in the child; the faces come back (exact
  patches, boxes, loops: plain arrays), the kernel's shape stays in the child;
- **operations** on the model's shape (meshing, the edges' parameter curves): functions
  marked with :func:`kernel_operation` run in the child on its model when the model's
  ``shape`` is a :class:`KernelProcess`, and in this process when it is the kernel's shape;
- **a cached read** (:mod:`gshade.cad.cache`): the child is given the model and the
  kernel's shape as a read kept them ("load"), and is asked for the shape after a read
  ("keep"); the answers to operations are looked up in the cache first (``answers``).

Each call is bounded in wall-clock time (:func:`kernel_seconds`: ``GSHADE_CAD_TIMEOUT``,
default :data:`gshade.limits.CAD_SECONDS`, or less inside :func:`kernel_time_limit`), in CPU
time (so that an orphaned child ends by itself) and in address space (reading:
:func:`gshade.limits.cad_read_memory` of the file's size; operations:
:func:`gshade.limits.memory_limit`).  A crash, an overrun or a runaway allocation is one
:class:`~gshade.errors.GshadeError` naming the file ("the CAD kernel crashed (SIGSEGV)
reading it", "... took longer than 120 s reading it", "... needed more than 1.2 GB reading
it"), and the child is gone; this process is unharmed and answers signals at once (it waits
for the child in Python).  The child dies with this process (``PR_SET_PDEATHSIG``).

Results come back pickled and are unpickled with an allow-list of classes
(:class:`_Results`): a child whose memory a hostile file corrupted cannot make this process
run code.
"""

from __future__ import annotations

import contextlib
import functools
import io
import os
import pickle
import select
import signal
import struct
import subprocess
import tempfile
import time
import weakref
from collections.abc import Callable, Iterator
from typing import Any, ClassVar, Protocol, TypeVar

from ..errors import GshadeError
from ..limits import CAD_SECONDS, memory_limit

__all__ = [
    "CHILD_MODULES",
    "MESSAGE_HEADER",
    "OPERATIONS",
    "OPERATION_MODULES",
    "OUT_OF_MEMORY",
    "AnswerStore",
    "KernelProcess",
    "allowed_answer",
    "at_memory_limit",
    "kernel_operation",
    "kernel_seconds",
    "kernel_time_limit",
]

F = TypeVar("F", bound=Callable[..., Any])

MESSAGE_HEADER = struct.Struct(">Q")
#: The largest message the child may send (a mesh of ~10^7 triangles with its arrays).
_MAX_MESSAGE = 4 * 2**30
#: Seconds between checks of the deadline while waiting (signals are handled at once).
_POLL = 0.25

#: Functions the child may be asked to run: "module:name" -> the function on the model.
OPERATIONS: dict[str, Callable[..., Any]] = {}
#: Modules whose marked functions the child may import to find them.
OPERATION_MODULES = ("gshade.cad.model", "gshade.cad.mesh", "gshade.cad.edges")
#: What a child loads before its bounds are set, beside the file's reader (the zygote loads
#: them, and the readers, once for all its children: :mod:`gshade.cad.zygote`).
CHILD_MODULES = (
    "numpy",
    "skimage.measure",
    *OPERATION_MODULES,
    "gshade.cad.readers",
    "gshade.cad.cache",
)

#: What native code's exceptions say when an allocation (or a library's mapping) failed.
OUT_OF_MEMORY = ("OutOfMemory", "bad_alloc", "failed to map segment", "Cannot allocate")

_limit: list[float] = []  # kernel_time_limit's stack


def kernel_seconds() -> float:
    """The wall-clock seconds one kernel call may take: ``GSHADE_CAD_TIMEOUT`` (a positive
    number), default :data:`gshade.limits.CAD_SECONDS`; less inside
    :func:`kernel_time_limit`."""
    text = os.environ.get("GSHADE_CAD_TIMEOUT", "").strip()
    seconds = float(CAD_SECONDS)
    if text:
        try:
            seconds = float(text)
        except ValueError:
            seconds = -1.0
        if not (0 < seconds < 1e9):
            raise GshadeError(
                f"GSHADE_CAD_TIMEOUT: expected a positive number of seconds, got {text[:40]!r}"
            )
    return min([seconds, *_limit])


@contextlib.contextmanager
def kernel_time_limit(seconds: float | None) -> Iterator[None]:
    """Within the block, no kernel call takes longer than ``seconds`` (None: no change), e.g.
    a batch's ``timeout`` for the scenes its planning loads."""
    if seconds is None or not seconds > 0:
        yield
        return
    _limit.append(float(seconds))
    try:
        yield
    finally:
        _limit.pop()


def kernel_operation(doing: str) -> Callable[[F], F]:
    """Mark ``function(model, ...)`` as a kernel operation: when ``model.brep`` is a
    :class:`KernelProcess`, the call runs in that process on its model (``doing`` names it
    in messages: "meshing it"); otherwise here."""

    def mark(function: F) -> F:
        key = f"{function.__module__}:{function.__name__}"
        OPERATIONS[key] = function

        @functools.wraps(function)
        def run(model: Any, *args: Any, **kwargs: Any) -> Any:
            kernel = getattr(model, "brep", None)
            if isinstance(kernel, KernelProcess):
                return kernel.call(key, args, kwargs, doing)
            return function(model, *args, **kwargs)

        return run  # type: ignore[return-value]

    return mark


class AnswerStore(Protocol):
    """Where a :class:`KernelProcess` looks for its operations' answers before it asks the
    child, and keeps them (:class:`gshade.cad.cache.Answers`): the child's answer
    messages, as they came."""

    def get(self, operation: str, args: tuple, kwargs: dict) -> bytes | None: ...

    def put(self, operation: str, args: tuple, kwargs: dict, answer: bytes) -> None: ...


class KernelProcess:
    """A child process holding one CAD model's kernel shape; it stands in for the shape
    (``CadModel.brep``) in this process.

    Parameters
    ----------
    path : path-like
        The model's file, for messages.
    answers : AnswerStore, optional
        The answers to its :func:`kernel_operation` calls kept from earlier runs: a call
        found there is not sent to the child, and the child's answers are kept there.
    start : bool
        Start the child now; False leaves it to :meth:`later`.
    """

    def __init__(
        self, path: str | os.PathLike, answers: AnswerStore | None = None, start: bool = True
    ) -> None:
        self.path = str(path)
        self.answers = answers
        self._process: Any = None  # a Popen, or the zygote's Forked
        self._prepare: Callable[[KernelProcess], None] | None = None
        self._finalizer: Any = None
        if start:
            self._start()

    def _start(self) -> None:
        from .zygote import start_child

        log = tempfile.TemporaryFile()
        try:
            self._process = start_child(log)
        except OSError as exc:
            log.close()
            raise GshadeError(
                f"{self.path}: cannot start the CAD kernel's process ({exc})"
            ) from None
        self._finalizer = weakref.finalize(self, _stop, self._process, log)

    def later(self, prepare: Callable[[KernelProcess], None]) -> None:
        """Start the child only when it is first needed (a call that ``answers`` does not
        hold): then ``prepare(self)`` gives it its model (a cached read:
        :mod:`gshade.cad.cache`), and may :meth:`restart` it."""
        self._prepare = prepare

    @property
    def _child(self) -> Any:
        """The child, started (and prepared) if it is still to be."""
        prepare, self._prepare = self._prepare, None
        if prepare is not None:
            self._start()
            try:
                prepare(self)
            except BaseException:
                self.close()
                raise
        return self._process

    def restart(self) -> None:
        """End the child and start a new one (without a model)."""
        self.close()
        self._start()

    def __repr__(self) -> str:
        if self._prepare is not None:
            state = "not started"
        else:
            state = "running" if self._process is not None else "ended"
        return f"<KernelProcess of {self.path} ({state})>"

    @property
    def running(self) -> bool:
        """Whether the child is there to answer (to be started when needed, or not closed
        and not ended)."""
        if self._prepare is not None:
            return True
        child = self._process
        return child is not None and child.poll() is None

    def close(self) -> None:
        """End the child (its model is gone)."""
        self._prepare = None
        if self._finalizer is not None:
            self._finalizer()
        self._process = None

    def call(
        self,
        operation: str,
        args: tuple = (),
        kwargs: dict | None = None,
        doing: str = "working on it",
        memory: int | None = None,
    ) -> Any:
        """Run ``operation`` ("module:name" of a :func:`kernel_operation`, or "read") in the
        child on its model, within :func:`kernel_seconds` and ``memory`` bytes of address
        space more than it holds (default :func:`gshade.limits.memory_limit`); its result.
        A :func:`kernel_operation` whose answer ``answers`` holds is answered from there.

        Raises
        ------
        GshadeError
            The operation's own one-line error, or one line naming the file when the child
            crashed, overran its time or memory, or had ended already.
        """
        kwargs = kwargs or {}
        kept = self.answers if ":" in operation else None
        if kept is not None:
            found = kept.get(operation, args, kwargs)
            if found is not None:
                try:
                    kind, value = allowed_answer(found)
                except Exception:  # a foreign entry, whatever its bytes raise: asked anew
                    kind = ""
                if kind == "ok":
                    return value
        value, answer = self.request(operation, args, kwargs, doing, memory)
        if kept is not None:
            kept.put(operation, args, kwargs, answer)
        return value

    def request(
        self,
        operation: str,
        args: tuple = (),
        kwargs: dict | None = None,
        doing: str = "working on it",
        memory: int | None = None,
    ) -> tuple[Any, bytes]:
        """:meth:`call`, always asking the child: its result, and the child's answer
        message that gave it (for :mod:`gshade.cad.cache`)."""
        from ..limits import gigabytes

        child = self._child
        if child is None or child.poll() is not None:
            raise GshadeError(
                f"{self.path}: the CAD kernel's process has ended (after an earlier failure)"
            )
        seconds = kernel_seconds()
        budget = memory_limit() if memory is None else memory
        request = pickle.dumps((operation, args, kwargs or {}, budget, seconds), protocol=5)
        data = b""
        watch = _MemoryWatch(child.pid)
        try:
            _send(child, request)
            data = _receive(child, time.monotonic() + seconds, watch)
            kind, value = _Results.answer(data)
        except _Overrun:
            self.close()
            raise GshadeError(
                f"{self.path}: the CAD kernel took longer than {seconds:g} s {doing} "
                "(GSHADE_CAD_TIMEOUT sets the limit)"
            ) from None
        except (pickle.UnpicklingError, ValueError, EOFError, TypeError) as exc:
            self.close()
            raise GshadeError(
                f"{self.path}: the CAD kernel gave an answer gshade does not accept {doing} "
                f"({type(exc).__name__}: {str(exc)[:200]})"
            ) from None
        except (_Ended, OSError) as exc:
            status = None
            with contextlib.suppress(subprocess.TimeoutExpired):
                status = child.wait(2.0)  # it closed its end: it is ending
            self.close()
            if watch.exhausted and status is not None and status < 0:
                kind = "memory"  # it crashed where an allocation failed
            else:
                raise GshadeError(
                    f"{self.path}: the CAD kernel {_ending(child, status, exc)} {doing}; "
                    "the file is probably damaged"
                ) from None
        except BaseException:  # a signal or Ctrl-C while waiting: the child goes with us
            self.close()
            raise
        if kind == "ok":
            return value, data
        if kind == "failed":
            raise GshadeError(f"{self.path}: the CAD kernel failed {doing} ({value})")
        if kind == "memory":  # its memory is spent (a MemoryError or a crash at the limit)
            self.close()
            raise GshadeError(
                f"{self.path}: the CAD kernel needed more than {gigabytes(budget)} {doing} "
                "(GSHADE_MEMORY_LIMIT sets the limit); the file is probably damaged"
            )
        raise GshadeError(str(value))


class _Overrun(Exception):
    pass


#: A peak address space this close to the limit (bytes) counts as having reached it.
_MEMORY_MARGIN = 64 * 2**20


def at_memory_limit(pid: int | str = "self") -> bool:
    """Whether the process's peak address space (``/proc``: VmPeak) reached its limit
    (``RLIMIT_AS``), within :data:`_MEMORY_MARGIN`; False where that cannot be read."""
    try:
        with open(f"/proc/{pid}/status") as f:
            peak = next(int(s.split()[1]) * 1024 for s in f if s.startswith("VmPeak:"))
        with open(f"/proc/{pid}/limits") as f:
            limit = next(s.split()[3] for s in f if s.startswith("Max address space"))
    except (OSError, StopIteration, IndexError, ValueError):
        return False
    return limit.isdigit() and peak >= int(limit) - _MEMORY_MARGIN


class _MemoryWatch:
    """The child's peak address space against its limit, sampled while waiting for it: a
    native allocation that fails at the limit often crashes rather than raise, and then
    this tells why."""

    def __init__(self, pid: int) -> None:
        self.pid = pid
        self.exhausted = False

    def __call__(self) -> None:
        self.exhausted = self.exhausted or at_memory_limit(self.pid)


class _Ended(Exception):
    pass


def _stop(child: Any, log: Any) -> None:
    """Kill the child (it may be deep in the kernel, ignoring SIGTERM) and reap it."""
    try:
        if child.poll() is None:
            child.kill()
        child.wait()
    except OSError:
        pass
    for stream in (child.stdin, child.stdout, log):
        with contextlib.suppress(OSError, ValueError):
            if stream is not None:
                stream.close()


def _ending(child: Any, status: int | None, exc: BaseException) -> str:
    """How the child ended, in words: "crashed (SIGSEGV)", "ended with status 3"."""
    code = child.returncode if status is None else status
    if code is not None and code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = f"signal {-code}"
        if name == "SIGXCPU":
            return "ran out of CPU time"
        return f"crashed ({name})"
    if code is not None:
        return f"ended unexpectedly (status {code})"
    return f"stopped answering ({type(exc).__name__})"


def _send(child: Any, message: bytes) -> None:
    assert child.stdin is not None
    try:
        child.stdin.write(MESSAGE_HEADER.pack(len(message)) + message)
        child.stdin.flush()
    except (BrokenPipeError, ValueError):
        raise _Ended from None


def _receive(child: Any, deadline: float, tick: Callable[[], None]) -> bytes:
    """One message from the child, waiting in Python (signals are handled) until
    ``deadline``, calling ``tick`` while it waits."""
    assert child.stdout is not None
    fd = child.stdout.fileno()
    header = _read_exactly(fd, MESSAGE_HEADER.size, deadline, tick)
    (size,) = MESSAGE_HEADER.unpack(header)
    if size > _MAX_MESSAGE:
        raise ValueError(f"a message of {size} bytes")
    return _read_exactly(fd, size, deadline, tick)


def _read_exactly(fd: int, size: int, deadline: float, tick: Callable[[], None]) -> bytes:
    chunks = bytearray()
    while len(chunks) < size:
        left = deadline - time.monotonic()
        if left <= 0:
            raise _Overrun
        ready, _, _ = select.select([fd], [], [], min(left, _POLL))
        if not ready:
            tick()
            continue
        chunk = os.read(fd, min(size - len(chunks), 2**24))
        if not chunk:
            raise _Ended
        chunks += chunk
    return bytes(chunks)


def allowed_answer(data: bytes) -> tuple[str, Any]:
    """A child's answer message (kind, value), unpickled through the allow-list of plain
    data and gshade's CAD result classes (:class:`_Results`): never code to run."""
    return _Results.answer(data)


class _Results(pickle.Unpickler):
    """Unpickles only plain data and gshade's CAD result classes."""

    ALLOWED: ClassVar[frozenset[tuple[str, str]]] = frozenset(
        {
            ("pathlib", "PosixPath"),
            ("pathlib", "WindowsPath"),
            ("pathlib", "Path"),
            ("pathlib._local", "PosixPath"),
            ("pathlib._local", "WindowsPath"),
            ("numpy", "ndarray"),
            ("numpy", "dtype"),
            ("numpy.core.multiarray", "_reconstruct"),
            ("numpy._core.multiarray", "_reconstruct"),
            ("numpy.core.multiarray", "scalar"),
            ("numpy._core.multiarray", "scalar"),
            ("numpy.core.numeric", "_frombuffer"),
            ("numpy._core.numeric", "_frombuffer"),
            ("gshade.cad.model", "CadFace"),
            ("gshade.cad.model", "CadModel"),
            ("gshade.cad.model", "LeftOutFace"),
            ("gshade.cad.mesh", "FaceMesh"),
            ("gshade.cad.edges", "CadEdge"),
            ("gshade.geometry.patches.bspline", "BSplinePatch"),
            ("gshade.geometry.core.patch", "BSplineBasis"),
        }
    )

    def find_class(self, module: str, name: str) -> Any:
        if (module, name) not in self.ALLOWED:
            raise pickle.UnpicklingError(f"{module}.{name} is not a CAD result")
        return super().find_class(module, name)

    @classmethod
    def answer(cls, data: bytes) -> tuple[str, Any]:
        kind, value = cls(io.BytesIO(data)).load()
        if kind not in ("ok", "error", "failed", "memory"):
            raise ValueError(f"an answer of kind {kind!r}")
        return kind, value
