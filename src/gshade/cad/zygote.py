"""The CAD kernel's child processes, started fast: forked from one that has the kernel's
libraries loaded already.

A new Python process takes 0.6-0.9 s to load Open CASCADE, openNURBS and numpy, and every
model is read in a process of its own (:mod:`gshade.cad.process`).  So the first model
read starts a *zygote* (``python -m gshade.cad.zygote``) that loads them once and then,
on request, forks a child per model (in milliseconds), handing it the pipes this process
talks to it through (``SCM_RIGHTS`` over a Unix socket).  The children are the zygote's: it
reaps them when asked, and :class:`Forked` gives them the face of a
:class:`subprocess.Popen` (``pid``, ``stdin``, ``stdout``, ``poll``, ``wait``, ``kill``).

Lifetimes: the zygote dies with this process (``PR_SET_PDEATHSIG``, set against a thread of
this process that lives as long as the process), each child with the zygote.  Where no
zygote runs (it could not start, or died), a child is started on its own, as a new Python
process (:func:`start_child` falls back to it).
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from typing import Any

__all__ = ["Forked", "prestart", "start_child"]

#: Seconds the zygote may take to load the kernel's libraries, or to answer a request.
_READY_SECONDS = 120.0
_ANSWER_SECONDS = 30.0

_zygotes: dict[int, _Zygote] = {}  # this process's (by pid: a forked process starts its own)
_lock = threading.Lock()


def start_child(log: Any) -> Any:
    """A child process serving :func:`gshade.cad.kernel_child.serve` on its stdin/stdout,
    its stderr into ``log`` (a file): forked from the zygote, else started on its own."""
    zygote = _zygote()
    if zygote is not None:
        try:
            return zygote.fork(log.fileno())
        except (OSError, ValueError):
            _forget(zygote)
    return subprocess.Popen(
        [sys.executable, "-m", "gshade.cad.kernel_child", str(os.getpid())],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=log,
        close_fds=True,
    )


def prestart() -> None:
    """Start the zygote now, without waiting for it: it loads the kernel's libraries while
    this process goes on (e.g. the command line, given a CAD file, loading its own)."""
    _zygote()


def _zygote() -> _Zygote | None:
    with _lock:
        zygote = _zygotes.get(os.getpid())
        if zygote is None and os.environ.get("GSHADE_CAD_ZYGOTE", "") != "off":
            try:
                zygote = _zygotes[os.getpid()] = _Zygote()
            except (OSError, ValueError):
                return None
        return zygote


def _forget(zygote: _Zygote) -> None:
    with _lock:
        if _zygotes.get(os.getpid()) is zygote:
            del _zygotes[os.getpid()]
    zygote.close()


class _Zygote:
    """The zygote, seen from here: a Unix socket to it."""

    def __init__(self) -> None:
        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        started: list[Any] = []

        def start_and_stay() -> None:  # the zygote's parent thread: alive till the end
            try:
                started.append(
                    subprocess.Popen(
                        [
                            sys.executable,
                            "-m",
                            "gshade.cad.zygote",
                            str(os.getpid()),
                            str(theirs.fileno()),
                        ],
                        pass_fds=(theirs.fileno(),),
                        stdin=subprocess.DEVNULL,
                        stdout=subprocess.DEVNULL,
                        stderr=subprocess.DEVNULL,
                    )
                )
            except OSError as exc:
                started.append(exc)
            threading.Event().wait()

        threading.Thread(target=start_and_stay, name="gshade-cad-zygote", daemon=True).start()
        while not started:
            time.sleep(0.005)
        theirs.close()
        if isinstance(started[0], OSError):
            ours.close()
            raise started[0]
        self.process: subprocess.Popen = started[0]
        self.socket = ours
        self.lock = threading.RLock()
        self.ready = False  # said by the zygote once it has loaded the libraries

    def wait_ready(self) -> None:
        with self.lock:
            if not self.ready:
                if self._ask(None, _READY_SECONDS) != b"ready":
                    raise OSError("the CAD kernel's zygote did not start")
                self.ready = True

    def _ask(self, message: bytes | None, seconds: float, fds: list[int] | None = None) -> bytes:
        """Send ``message`` (with ``fds``) and return the answer, waiting in Python."""
        with self.lock:
            if message is not None:
                socket.send_fds(self.socket, [message], fds or [])
            deadline = time.monotonic() + seconds
            self.socket.settimeout(0.25)
            while True:
                try:
                    answer = self.socket.recv(64)
                    break
                except TimeoutError:
                    if time.monotonic() > deadline or self.process.poll() is not None:
                        raise OSError("the CAD kernel's zygote does not answer") from None
            if not answer:
                raise OSError("the CAD kernel's zygote has ended")
            return answer

    def fork(self, log: int) -> Forked:
        self.wait_ready()
        requests = os.pipe()
        answers = os.pipe()
        try:
            pid = int(self._ask(b"fork", _ANSWER_SECONDS, [requests[0], answers[1], log]))
        except BaseException:
            for fd in (*requests, *answers):
                os.close(fd)
            raise
        os.close(requests[0])
        os.close(answers[1])
        return Forked(self, pid, os.fdopen(requests[1], "wb"), os.fdopen(answers[0], "rb"))

    def status(self, pid: int) -> int | None:
        """The child's exit status (negative: the signal) once it has ended, else None."""
        answer = self._ask(b"wait %d" % pid, _ANSWER_SECONDS)
        return None if answer == b"running" else int(answer)

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self.socket.close()
        with contextlib.suppress(OSError):
            self.process.kill()
            self.process.wait()


class Forked:
    """A child of the zygote, with the face of a :class:`subprocess.Popen`."""

    def __init__(self, zygote: _Zygote, pid: int, stdin: Any, stdout: Any) -> None:
        self.zygote, self.pid, self.stdin, self.stdout = zygote, pid, stdin, stdout
        self.returncode: int | None = None

    def poll(self) -> int | None:
        if self.returncode is None:
            try:
                self.returncode = self.zygote.status(self.pid)
            except (OSError, ValueError):  # the zygote is gone, and its children with it
                self.returncode = -signal.SIGKILL
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.poll() is None:
            if deadline is not None and time.monotonic() > deadline:
                raise subprocess.TimeoutExpired(f"CAD kernel child {self.pid}", timeout or 0.0)
            time.sleep(0.01)
        assert self.returncode is not None
        return self.returncode

    def kill(self) -> None:
        if self.returncode is None:  # not yet reaped: the pid is still this child's
            with contextlib.suppress(ProcessLookupError):
                os.kill(self.pid, signal.SIGKILL)


# --- the zygote ------------------------------------------------------------------------


def _preload() -> None:
    """Load what the children use, once: the readers of every CAD format,
    :data:`gshade.cad.process.CHILD_MODULES` and the kernel's binary shape format (of a
    cached read: :mod:`gshade.cad.cache`); what is not installed is left out."""
    import importlib

    from .process import CHILD_MODULES
    from .readers import CAD_EXTENSIONS, reader_module

    for module in CHILD_MODULES:
        with contextlib.suppress(Exception):
            importlib.import_module(module)
    for extension in CAD_EXTENSIONS:
        with contextlib.suppress(Exception):
            reader_module(f"model{extension}")
    with contextlib.suppress(Exception):  # what reads and writes a cached shape
        importlib.import_module("OCP.BinTools")


def _zygote_main(parent: int, fd: int) -> None:
    from gshade.cad import kernel_child

    kernel_child.die_with_parent(parent)
    link = socket.socket(fileno=fd)
    _preload()
    link.send(b"ready")
    me = os.getpid()
    while True:
        try:
            message, fds, _, _ = socket.recv_fds(link, 64, 3)
        except OSError:
            return
        if not message:
            return  # this process's parent has closed its end
        if message == b"fork" and len(fds) == 3:
            pid = os.fork()
            if pid == 0:  # the child: the pipes become its stdin, stdout and stderr
                try:
                    link.close()
                    for target, source in enumerate(fds):
                        os.dup2(source, target)
                    for source in fds:
                        if source > 2:
                            os.close(source)
                    kernel_child.serve(me)
                finally:
                    os._exit(0)
            for source in fds:
                os.close(source)
            link.send(b"%d" % pid)
        elif message.startswith(b"wait "):
            for source in fds:
                os.close(source)
            try:
                done, status = os.waitpid(int(message[5:]), os.WNOHANG)
                answer = b"running" if done == 0 else b"%d" % os.waitstatus_to_exitcode(status)
            except (ChildProcessError, ValueError):
                answer = b"%d" % -signal.SIGKILL  # not (or no longer) a child
            link.send(answer)
        else:
            for source in fds:
                os.close(source)
            link.send(b"?")


if __name__ == "__main__":  # python -m gshade.cad.zygote PARENT_PID SOCKET_FD
    import numpy as np

    from gshade.cad import zygote as cad_zygote  # the module, not this __main__ copy

    np.seterr(all="ignore")
    cad_zygote._zygote_main(int(sys.argv[1]), int(sys.argv[2]))
    os._exit(0)
