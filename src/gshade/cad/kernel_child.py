"""The kernel's child process: what runs there (:mod:`gshade.cad.process` starts it and
talks to it).

The child (forked by :mod:`gshade.cad.zygote`, or started as ``python -m
gshade.cad.kernel_child PARENT_PID``) dies with its parent (:func:`die_with_parent`) and
answers requests on its stdin/stdout (:func:`serve`): "read" a file, "load" a cached read,
"keep" (its shape's bytes for the cache), or run a :func:`~gshade.cad.process.kernel_operation`
on its model, each within the bounds the request gives (address space, CPU time).  A
request is a length (:data:`~gshade.cad.process.MESSAGE_HEADER`) and a pickle from the
parent; an answer is ("ok", value), ("error", line), ("failed", what the kernel raised) or
("memory", None), which the parent unpickles through its allow-list.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import signal
import sys
from typing import Any

from ..errors import GshadeError
from .process import (
    CHILD_MODULES,
    MESSAGE_HEADER,
    OPERATION_MODULES,
    OPERATIONS,
    OUT_OF_MEMORY,
    at_memory_limit,
)

__all__ = ["die_with_parent", "serve"]


def die_with_parent(parent: int) -> None:
    """Be killed when the parent ends (Linux), even while deep in the kernel."""
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            import ctypes

            ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    if os.getppid() != parent:  # the parent ended before the line above
        os._exit(1)


def _bound(memory: int, seconds: float) -> None:
    """Limit the child's address space to what it holds plus ``memory`` bytes, and its CPU
    time to what it used plus ``seconds`` on every core (an orphan guard: the parent's
    wall-clock deadline comes first)."""
    try:
        import resource
    except ImportError:  # not POSIX
        return
    with open("/proc/self/statm") as f:
        held = int(f.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    for which, soft in (
        (resource.RLIMIT_AS, held + max(int(memory), 0)),
        (
            resource.RLIMIT_CPU,
            int(sum(os.times()[:2]) + seconds * (os.cpu_count() or 1)) + 10,
        ),
    ):
        _, hard = resource.getrlimit(which)
        if hard != resource.RLIM_INFINITY:
            soft = min(soft, hard)
        with contextlib.suppress(OSError, ValueError):
            resource.setrlimit(which, (soft, hard))


def serve(parent: int) -> None:
    """Answer the parent's requests on the inherited stdin/stdout until it closes them."""
    import importlib

    die_with_parent(parent)
    requests = os.fdopen(os.dup(0), "rb")
    answers = os.fdopen(os.dup(1), "wb")
    # the kernel prints banners and warnings: away from the answers, into the log
    devnull = os.open(os.devnull, os.O_RDONLY)
    os.dup2(devnull, 0)
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    model: Any = None
    while True:
        header = requests.read(MESSAGE_HEADER.size)
        if len(header) < MESSAGE_HEADER.size:
            return
        operation, args, kwargs, memory, seconds = pickle.loads(
            requests.read(MESSAGE_HEADER.unpack(header)[0])
        )
        try:
            if operation == "read":
                from .readers import read_cad, reader_module

                path, sew, tolerance = args
                reader_module(path)  # the libraries are loaded outside the bounds
                for name in CHILD_MODULES:
                    importlib.import_module(name)
                _bound(memory, seconds)
                model = read_cad(path, sew, tolerance, isolated=False)
                from dataclasses import replace

                answer: tuple[str, Any] = ("ok", replace(model, brep=None))
            elif operation == "load":  # a cached read: the model and its shape's bytes
                from .cache import restored_model
                from .readers import reader_module

                cached, shape, path = args
                model = None
                reader_module(path)  # the libraries are loaded outside the bounds
                for name in CHILD_MODULES:
                    importlib.import_module(name)
                importlib.import_module("OCP.BinTools")
                _bound(memory, seconds)
                model = restored_model(cached, shape, path)
                answer = ("ok", model.face_count)
            elif operation == "keep":  # the model's shape, for the cache
                from .cache import shape_bytes

                if model is None or model.brep is None:
                    raise GshadeError("no model here to keep")
                _bound(memory, seconds)
                answer = ("ok", shape_bytes(model.brep))
            else:
                module, _, _ = operation.partition(":")
                if module in OPERATION_MODULES:
                    importlib.import_module(module)
                if operation not in OPERATIONS or model is None:
                    raise GshadeError(f"no kernel operation {operation!r} on a model here")
                _bound(memory, seconds)
                answer = ("ok", OPERATIONS[operation](model, *args, **kwargs))
        except GshadeError as exc:  # perhaps because an allocation failed at the limit
            answer = ("memory", None) if at_memory_limit() else ("error", str(exc))
        except MemoryError:
            answer = ("memory", None)
        except Exception as exc:
            if any(m in f"{type(exc).__name__} {exc}" for m in OUT_OF_MEMORY):
                answer = ("memory", None)
            else:
                text = (str(exc).strip().splitlines() or [""])[0][:200]
                answer = ("failed", type(exc).__name__ + (f": {text}" if text else ""))
        try:
            data = pickle.dumps(answer, protocol=5)
        except MemoryError:
            data = pickle.dumps(("memory", None), protocol=5)
        answers.write(MESSAGE_HEADER.pack(len(data)) + data)
        answers.flush()


if __name__ == "__main__":  # the child: python -m gshade.cad.kernel_child PARENT_PID
    import numpy as np

    from gshade.cad import kernel_child  # the module, not this __main__ copy

    np.seterr(all="ignore")
    kernel_child.serve(int(sys.argv[1]))
    os._exit(0)
