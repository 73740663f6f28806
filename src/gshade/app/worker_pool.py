"""Worker processes that run one task at a time and outlive each other's deaths.

:class:`WorkerPool` starts up to N processes (the *spawn* context: nothing of the parent's
state is shared), sends each one task at a time over its own pipe, and waits on the result
pipes and the processes' sentinels together (:func:`multiprocessing.connection.wait`), so it
always knows which task each worker runs:

- A worker that dies (``kill -9``, a segfault, an LLVM abort, the kernel's OOM killer) makes
  its task fail with a one-line reason naming the signal or exit status; a fresh worker is
  started for the tasks that remain.
- A task that runs longer than ``timeout`` seconds has its worker killed and fails with
  ``exceeded the time limit of N s``; a fresh worker takes the remaining tasks.
- The time limit counts from when the task is sent: a worker is sent its first task only
  once its initializer has run (imports do not count against the limit).

Workers ignore SIGINT and SIGHUP (the parent decides what Ctrl-C means and stops them), end
at once on SIGTERM after removing their staged temporaries, and on Linux ask the kernel for
a SIGTERM when their parent dies (``PR_SET_PDEATHSIG``): they never outlive it.
:meth:`WorkerPool.close` stops every worker (SIGTERM, a grace period, then SIGKILL) and
reaps it, so that none is left as a zombie or an orphan.
"""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import signal
import sys
import threading
import time
import traceback
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any

from ..errors import GshadeError

__all__ = ["DaskPool", "Outcome", "WorkerPool", "dask_client", "describe_exit", "validate_address"]

#: Seconds a worker is given to end after SIGTERM (or after being asked to stop) before
#: it is killed.
GRACE = 2.0
#: Workers in a row that die before they are ready, after which the pool gives up.
_START_ATTEMPTS = 3
_PR_SET_PDEATHSIG = 1


@dataclass
class Outcome:
    """What became of one task.

    ``error`` is empty when the function returned ``value``; otherwise a one-line reason
    (the worker died, ran out of time, or the function raised) and ``detail`` more text.
    """

    index: int
    value: Any = None
    error: str = ""
    detail: str = ""
    pid: int | None = None
    seconds: float = 0.0


def describe_exit(exitcode: int | None) -> str:
    """A one-line reason for a worker's end from its exit code (negative: a signal)."""
    if exitcode is None:
        return "the worker process stopped answering"
    if exitcode >= 0:
        return f"the worker process died (exit status {exitcode})"
    number = -exitcode
    try:
        name = signal.Signals(number).name
    except ValueError:
        name = "unknown signal"
    hints: dict[int, str] = {
        signal.SIGKILL: ": out of memory?",
        signal.SIGSEGV: ": a crash in compiled code",
        signal.SIGABRT: ": aborted",
    }
    hint = hints.get(number, "")
    return f"the worker process died (killed by signal {number}, {name}{hint})"


@dataclass
class _Worker:
    process: Any  # multiprocessing's SpawnProcess
    conn: Connection
    ready: bool = False
    task: int | None = None
    started: float = 0.0


class WorkerPool:
    """Up to ``size`` worker processes calling ``function(*args)``, one task each at a time.

    Parameters
    ----------
    function : callable
        A module-level function (the workers import it by name); it should not raise.
    size : int
        The most worker processes at once (at least 1).
    timeout : float, optional
        Seconds a task may run before its worker is killed (None: no limit).
    initializer : callable, optional
        Called once in each worker before its first task (e.g. imports to keep warm).

    Use it as a context manager: leaving the block stops every worker.
    """

    def __init__(
        self,
        function: Callable[..., Any],
        size: int,
        *,
        timeout: float | None = None,
        initializer: Callable[[], None] | None = None,
    ) -> None:
        if size < 1:
            raise ValueError(f"size: expected at least 1 worker, got {size}")
        self.function = function
        self.size = size
        self.timeout = timeout if timeout is not None and timeout < float("inf") else None
        self.initializer = initializer
        self._context = multiprocessing.get_context("spawn")
        self._workers: list[_Worker] = []

    def __enter__(self) -> WorkerPool:
        return self

    def __exit__(self, kind: object, exc: object, tb: object) -> None:
        self.close(graceful=kind is None)

    def run(self, tasks: Sequence[tuple], tick: float = 1.0) -> Iterator[Outcome | None]:
        """Run every task (a tuple of arguments) and yield each one's :class:`Outcome` as it
        ends, in any order (``Outcome.index`` is the task's position).

        While nothing ends, ``None`` is yielded every ``tick`` seconds (a chance to report
        progress)."""
        pending = deque(range(len(tasks)))
        failed_starts = 0
        while pending or any(w.task is not None for w in self._workers):
            busy = sum(w.task is not None for w in self._workers)
            while len(self._workers) < min(self.size, busy + len(pending)):
                self._start()
            for worker in self._workers:
                if worker.ready and worker.task is None and pending:
                    outcome = self._send(worker, pending.popleft(), tasks)
                    if outcome is not None:
                        yield outcome
            ready = set(wait(self._waitables(), self._wait_time(tick)))
            ended: list[Outcome] = []
            for worker in list(self._workers):
                if worker.conn in ready or worker.process.sentinel in ready:
                    outcome, alive = self._receive(worker)
                    if not alive:
                        failed_starts = 0 if worker.ready else failed_starts + 1
                        self._retire(worker)
                    if outcome is not None:
                        ended.append(outcome)
                elif self._overdue(worker):
                    ended.append(self._kill_overdue(worker))
            if failed_starts >= _START_ATTEMPTS:
                reason = "the worker processes do not start (see the messages above)"
                ended += [Outcome(index, error=reason) for index in pending]
                pending.clear()
            if ended:
                yield from ended
            elif not ready:
                yield None

    def close(self, graceful: bool = True) -> None:
        """Stop every worker and reap it: asked to stop (``graceful``) or sent SIGTERM, then
        killed if still running after :data:`GRACE` seconds."""
        for worker in self._workers:
            try:
                if graceful and worker.task is None:
                    worker.conn.send(None)
                else:
                    worker.process.terminate()
            except (OSError, ValueError):
                pass
        deadline = time.monotonic() + GRACE
        for worker in self._workers:
            worker.process.join(max(0.0, deadline - time.monotonic()))
            if worker.process.exitcode is None:
                worker.process.kill()
                worker.process.join()
            worker.conn.close()
            worker.process.close()
        self._workers = []

    # ----------------------------------------------------------------- internals

    def _start(self) -> None:
        parent, child = self._context.Pipe()
        process = self._context.Process(
            target=_serve,
            args=(child, self.function, self.initializer, os.getpid()),
            daemon=True,
        )
        with _ignoring_sigint():  # from its very start: Ctrl-C is the parent's to handle
            process.start()
        child.close()  # the worker holds the only other end: its death reads as EOF
        self._workers.append(_Worker(process, parent))

    def _send(self, worker: _Worker, index: int, tasks: Sequence[tuple]) -> Outcome | None:
        try:
            worker.conn.send((index, tasks[index]))
        except (OSError, ValueError):  # the worker is gone: found by the next wait
            pass
        except Exception as exc:  # the arguments cannot be pickled
            return Outcome(index, error=f"cannot send the task to a worker ({exc})")
        worker.task, worker.started = index, time.monotonic()
        return None

    def _waitables(self) -> list:
        return [w.conn for w in self._workers] + [w.process.sentinel for w in self._workers]

    def _wait_time(self, tick: float) -> float:
        if self.timeout is None:
            return tick
        now = time.monotonic()
        deadlines = [w.started + self.timeout - now for w in self._workers if w.task is not None]
        return max(0.0, min([tick, *deadlines]))

    def _receive(self, worker: _Worker) -> tuple[Outcome | None, bool]:
        """The outcome a worker reports (if any) and whether it is still alive."""
        try:
            if worker.conn.poll():
                message = worker.conn.recv()
                if message == "ready":
                    worker.ready = True
                    return None, True
                index, ok, value, detail = message
                outcome = Outcome(index, pid=worker.process.pid, seconds=self._elapsed(worker))
                if ok:
                    outcome.value = value
                else:
                    outcome.error, outcome.detail = value, detail
                worker.task = None
                return outcome, True
        except Exception:  # EOF, or a message cut short by the worker's death
            pass
        if worker.process.is_alive() and not worker.conn.closed:
            worker.process.join(GRACE)  # it closed its pipe: it is ending
        if worker.process.exitcode is None:
            worker.process.kill()
            worker.process.join()
        if worker.task is None:
            return None, False
        outcome = Outcome(
            worker.task,
            error=describe_exit(worker.process.exitcode),
            pid=worker.process.pid,
            seconds=self._elapsed(worker),
        )
        return outcome, False

    def _overdue(self, worker: _Worker) -> bool:
        return (
            self.timeout is not None
            and worker.task is not None
            and time.monotonic() - worker.started >= self.timeout
        )

    def _kill_overdue(self, worker: _Worker) -> Outcome:
        worker.process.kill()
        worker.process.join()
        outcome = Outcome(
            worker.task,  # type: ignore[arg-type]
            error=f"exceeded the time limit of {self.timeout:g} s",
            pid=worker.process.pid,
            seconds=self._elapsed(worker),
        )
        self._retire(worker)
        return outcome

    def _retire(self, worker: _Worker) -> None:
        self._workers.remove(worker)
        worker.conn.close()
        worker.process.join()
        worker.process.close()

    @staticmethod
    def _elapsed(worker: _Worker) -> float:
        return time.monotonic() - worker.started if worker.task is not None else 0.0


class DaskPool:
    """Tasks as Dask tasks on an existing cluster, with :class:`WorkerPool`'s :meth:`run`:
    a task whose future fails (KilledWorker, a lost worker) is an :class:`Outcome` with an
    error.  The cluster's own limits apply (no ``timeout``)."""

    def __init__(self, function: Callable[..., Any], address: str) -> None:
        self.function = function
        self.client = dask_client(address)

    def __enter__(self) -> DaskPool:
        return self

    def __exit__(self, kind: object, exc: object, tb: object) -> None:
        try:
            self.client.close()
        except Exception:
            pass

    def run(self, tasks: Sequence[tuple], tick: float = 1.0) -> Iterator[Outcome | None]:
        """Submit every task and yield each one's :class:`Outcome` as it ends (``None``
        every ``tick`` seconds while nothing does)."""
        columns = [list(column) for column in zip(*tasks, strict=True)]
        futures = self.client.map(self.function, *columns, pure=False)
        waiting = dict(enumerate(futures))
        quiet_since = time.monotonic()
        try:
            while waiting:
                done = [index for index, future in waiting.items() if future.done()]
                for index in done:
                    yield self._outcome(index, waiting.pop(index))
                if done:
                    quiet_since = time.monotonic()
                elif time.monotonic() - quiet_since >= tick:
                    quiet_since = time.monotonic()
                    yield None
                else:
                    time.sleep(0.05)
        finally:
            if waiting:
                self.client.cancel(list(waiting.values()))

    @staticmethod
    def _outcome(index: int, future: Any) -> Outcome:
        try:
            return Outcome(index, future.result())
        except Exception as exc:
            lines = str(exc).strip().splitlines()
            reason = f"{type(exc).__name__}: {lines[0][:200]}" if lines else type(exc).__name__
            return Outcome(index, error=f"the Dask task failed ({reason})", detail=str(exc))


def validate_address(address: str) -> str:
    """``address`` if it is a ``tcp://`` or ``tls://`` address, else a :class:`GshadeError`."""
    if not address.strip():
        raise GshadeError(
            "scheduler: expected a Dask scheduler address such as tcp://host:8786, got an empty one"
        )
    scheme, sep, host = address.partition("://")
    if not sep or scheme not in ("tcp", "tls") or not host.strip():
        raise GshadeError(
            "scheduler: expected a tcp:// or tls:// address such as tcp://host:8786, "
            f"got {address[:100]!r}"
        )
    return address


def dask_client(address: str) -> Any:
    """A Dask client for the scheduler at ``address``; one clear line (a
    :class:`GshadeError`) if Dask is missing, TLS is asked for but Dask's configuration has
    no credentials, or the scheduler cannot be reached."""
    validate_address(address)
    try:
        from distributed import Client, Security
    except ImportError:
        raise GshadeError(
            'scheduler: Dask\'s distributed package is not installed (pip install "gshade[dask]")'
        ) from None
    if address.startswith("tls://"):
        try:
            context = Security().get_connection_args("client")["ssl_context"]
        except Exception as exc:
            raise GshadeError(
                f"scheduler: cannot use Dask's TLS configuration ({type(exc).__name__}: {exc})"
            ) from None
        if context is None:
            raise GshadeError(
                f"scheduler {address}: no TLS credentials: gshade relies on Dask's "
                "configuration for TLS (distributed.comm.tls.ca-file, "
                "distributed.comm.tls.client.cert and .client.key, or the environment "
                "variables DASK_DISTRIBUTED__COMM__TLS__CA_FILE, "
                "DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT and …__CLIENT__KEY)"
            )
    try:
        return Client(address, timeout="10s", set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise GshadeError(
            f"scheduler: cannot reach the Dask scheduler at {address} ({exc})"
        ) from None
    except Exception as exc:
        line = (str(exc).strip().splitlines() or [""])[0][:200]
        raise GshadeError(
            f"scheduler: cannot connect to the Dask scheduler at {address} "
            f"({type(exc).__name__}: {line})"
        ) from None


# ----------------------------------------------------------------- in the worker


@contextmanager
def _ignoring_sigint() -> Iterator[None]:
    """SIGINT ignored meanwhile (a process started then inherits it), in the main thread."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous if previous is not None else signal.SIG_DFL)


def _terminated(signum: int, frame: object) -> None:
    """SIGTERM in a worker: remove its temporaries and end at once (an exception raised here
    could land inside Mitsuba's native code and crash the worker instead)."""
    from ..io.outputs import discard_temporaries

    discard_temporaries()
    os._exit(128 + signum)


def _die_with_parent(parent: int) -> None:
    """Ask Linux for a SIGTERM when the parent dies, and leave if it already has."""
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)
        except (OSError, AttributeError):
            pass
        try:  # the OOM killer should take a worker rather than the batch
            with open("/proc/self/oom_score_adj", "w") as f:
                f.write("500")
        except OSError:
            pass
    if os.getppid() != parent:
        raise SystemExit(128 + signal.SIGTERM)


def _serve(
    conn: Connection,
    function: Callable[..., Any],
    initializer: Callable[[], None] | None,
    parent: int,
) -> None:
    """A worker's life: set up, then one task at a time until told to stop (None) or EOF."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "SIGHUP"):
        signal.signal(signal.SIGHUP, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _terminated)
    _die_with_parent(parent)
    if initializer is not None:
        initializer()
    conn.send("ready")
    while True:
        try:
            message = conn.recv()
        except EOFError:
            return
        if message is None:
            return
        index, args = message
        try:
            reply = (index, True, function(*args), "")
        except Exception as exc:
            line = str(exc).splitlines()[0] if str(exc) else ""
            reply = (index, False, f"{type(exc).__name__}: {line}", traceback.format_exc())
        try:
            conn.send(reply)
        except Exception as exc:  # a result that cannot be pickled
            conn.send((index, False, f"cannot return the result ({exc})", ""))
