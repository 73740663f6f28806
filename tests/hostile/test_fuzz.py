"""Fuzz test: mutated scenes (tests/support/fuzz_scenes.py) through ``load_scene`` and a small
render.

Every case must end in one of two ways:

- a finite image (every channel finite, of the size asked for), which is then written as an
  EXR; or
- a :class:`GshadeError` whose message is one line and names the scene file, with no file
  written in the scene's folder.

Never another exception, never a hang, never gigabytes.  The cases run in worker processes
(``GSHADE_FUZZ_JOBS``, default 2) that keep gshade, Mitsuba and the compiled kernels warm;
inside a worker each case runs under SIGALRM (``GSHADE_FUZZ_TIMEOUT`` seconds, default 300),
which fails it with the Python location where it was.  The alarm is a hang guard, not a
speed test: the slowest case takes seconds (loading hole-valence-mean-g2-optimised.toml, 10 s
of shape optimisation without its cache, gshade.geometry.holes.fairing), ten times that on a busy
machine, so only a case that is really stuck reaches it.  A case stuck in native code (where
SIGALRM cannot get through: measured, a degree-40 patch's Newton kernel in LLVM) or whose
worker grows past ``GSHADE_FUZZ_MEMORY_GB`` (default 4) resident is failed by the parent,
with the worker's stack (faulthandler), and the worker replaced; so is a worker that dies.

Cases that set a render size (width, height, spp, tessellation) render with the scene's own
settings when the work is small; when it is absurd (a side over 10^6 pixels, over 10^9
samples, a tessellation over 10^5) the load or the render must refuse it with a GshadeError
naming a limit.  Every other case renders at 16 x 12 pixels, 1 spp.

The cases: the issue's named probes (``P01``...``P27``: absurd sizes, 5000 digits, 3000
nested ``[``, a degree-40 patch, a zero-size sphere, hostile names, ...) and
``GSHADE_FUZZ_COUNT`` (default 300) random mutations, ``GSHADE_FUZZ_SEED`` (default 1)
(case i depends only on the seed and i); ``GSHADE_FUZZ_REPORT=FILE`` writes one JSON line per
case (label, outcome, exception type, gshade code location, message, warnings).  One case
in this process, for a debugger: ``python -m tests.hostile.test_fuzz 0153 P14`` (label prefixes).
"""

from __future__ import annotations

import faulthandler
import json
import os
import queue
import re
import select
import signal
import subprocess
import sys
import threading
import time
import traceback
import warnings
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pytest

import gshade
from gshade import GshadeError

from ..support.fuzz_scenes import (
    CASE_TIMEOUT,
    ROOT,
    Case,
    CaseTimeout,
    alarm,
    cases,
    dumps,
    listing,
    probes,
    rss_of,
    write_variant,
)

pytestmark = pytest.mark.slow  # every scene mutation through load_scene and a render

COUNT = int(os.environ.get("GSHADE_FUZZ_COUNT", "300"))
SEED = int(os.environ.get("GSHADE_FUZZ_SEED", "1"))
JOBS = max(1, int(os.environ.get("GSHADE_FUZZ_JOBS", str(min(2, os.cpu_count() or 1)))))
#: How long a worker may take to start (import gshade and Mitsuba): a hang guard too.
START_TIMEOUT = 300.0
MEMORY_GB = float(os.environ.get("GSHADE_FUZZ_MEMORY_GB", "4"))
REPORT = os.environ.get("GSHADE_FUZZ_REPORT")
IN_WORKER = bool(os.environ.get("GSHADE_FUZZ_WORKER"))

#: A small render (16 x 12, 1 spp) for every case that is not about the render's size.
SMALL = {"width": 16, "height": 12, "spp": 1}
#: Size cases render with their own settings up to this much work ...
SMALL_SAMPLES, SMALL_SIDE, SMALL_TESSELLATION = 32 * 24 * 64, 64, 64
#: ... and must be refused beyond this.
ABSURD_SIDE, ABSURD_SAMPLES, ABSURD_TESSELLATION = 10**6, 10**9, 10**5
LIMIT_WORDS = re.compile(
    r"at most|maximum|limit|too (large|big|many|high|long)|exceed|<=|≤|up to|no more than|"
    r"larger than|greater than|above|below|from \S+ to \S+|within|between|in \[",
    re.IGNORECASE,
)

CASES = [] if IN_WORKER else probes() + cases(COUNT, SEED)


# --------------------------------------------------------------------------- one case


def _short_frame(filename: str, lineno: int | str, name: str) -> str:
    path = filename.replace("\\", "/")
    for marker in ("/gshade/", "/site-packages/", "/lib/python3.", "/tests/"):
        if marker in path:
            path = path.split(marker, 1)[1]
            if marker == "/gshade/":
                path = "gshade/" + path
            elif marker == "/lib/python3.":
                path = path.split("/", 1)[-1]
            break
    return f"{path}:{lineno} {name}"


def _where(exc: BaseException) -> str:
    """The innermost gshade frame of the traceback (and the innermost frame if elsewhere)."""
    frames = [f for f in traceback.extract_tb(exc.__traceback__) if f.name != "on_alarm"]
    if not frames:
        return "?"
    ours = [f for f in frames if "/gshade/" in f.filename.replace("\\", "/")]
    last = ours[-1] if ours else frames[-1]
    text = _short_frame(last.filename, last.lineno, last.name)
    if ours and frames[-1] is not ours[-1]:
        f = frames[-1]
        text += f" -> {_short_frame(f.filename, f.lineno, f.name)}"
    return text


def _first_line(text: str, limit: int = 160) -> str:
    lines = text.strip().splitlines() or [""]
    line = lines[0]
    return line if len(line) <= limit else line[: limit - 1] + "…"


def _spp_rounded(spp: int) -> int:
    r = 1
    while r < spp:
        r *= 4
    return r


def _work(render) -> tuple[bool, bool]:
    """(small, absurd) for a scene's render settings."""
    w, h, spp, tess = render.width, render.height, render.spp, render.tessellation
    samples = w * h * _spp_rounded(spp)
    small = w <= SMALL_SIDE and h <= SMALL_SIDE and samples <= SMALL_SAMPLES
    small = small and (tess is None or tess <= SMALL_TESSELLATION)
    absurd = w > ABSURD_SIDE or h > ABSURD_SIDE or samples > ABSURD_SAMPLES
    absurd = absurd or (tess is not None and tess > ABSURD_TESSELLATION)
    return small, absurd


def _absurd_in_label(case: Case) -> bool:
    """Whether a size case set an absurd value (then a load error must name a limit; an
    invalid value such as -1, 1.5 or "32" only has to be refused)."""
    m = re.search(r"render\.(width|height|spp|tessellation)(=height)?=(.*)$", case.label)
    if not m:
        return False
    value = m.group(3)
    if re.fullmatch(r"\d+digits", value):
        return True
    if not value.isdigit():
        return False
    x = int(value)
    if m.group(1) == "tessellation":
        return x > ABSURD_TESSELLATION
    if m.group(1) == "spp":
        return x * 32 * 24 > ABSURD_SAMPLES
    return x > ABSURD_SIDE or (m.group(2) is not None and x * x > ABSURD_SAMPLES)


class Outcome:
    def __init__(self, case: Case, folder: Path):
        self.label = case.label
        self.kind = case.kind
        self.folder = str(folder)
        self.stage = ""
        self.problems: list[str] = []
        self.exc_type = ""
        self.where = ""
        self.message = ""
        self.warnings: list[str] = []
        self.seconds = 0.0

    def show(self, text: str) -> str:
        """A message for the report: its first line, without the case's folder."""
        return _first_line(text.replace(self.folder + os.sep, ""))

    def exception(self, stage: str, exc: BaseException) -> None:
        self.stage, self.exc_type, self.where = stage, type(exc).__name__, _where(exc)
        self.message = self.show(str(exc))
        root, seen = exc, {id(exc)}
        while (inner := root.__cause__ or root.__context__) is not None and id(inner) not in seen:
            root = inner
            seen.add(id(root))
        if root is not exc:  # e.g. Dr.Jit's "error while performing a custom operation (see above)"
            self.message += f" <- {type(root).__name__} @ {_where(root)}: {self.show(str(root))}"
        self.problems.append(f"[{stage}] {self.exc_type} @ {self.where}: {self.message}")

    def error(self, stage: str, message: str, path: Path, before: dict, *,
              need_limit: bool = False, need_file: bool = True) -> None:  # fmt: skip
        """Check a GshadeError: one line, names the scene file, leaves no file behind."""
        self.stage, self.exc_type, self.message = stage, "GshadeError", self.show(message)
        bad = []
        lines = message.strip().splitlines()
        if not lines:
            bad.append("empty message")
        elif len(lines) > 1:
            bad.append(f"{len(lines)} lines")
        if need_file and str(path) not in message and path.name not in message:
            bad.append("does not name the scene file")
        if need_limit and not LIMIT_WORDS.search(message):
            bad.append("does not name a limit")
        after = listing(path.parent)
        if after != before:
            changed = sorted(k for k in after if after[k] != before.get(k))
            bad.append(f"files written on error: {', '.join(changed) or 'files removed'}")
        if bad:
            self.problems.append(f"[{stage}] GshadeError ({'; '.join(bad)}): {self.message}")


def _stage(name: str) -> None:
    """Tell the parent (which reads the worker's stdout) where a case is."""
    if IN_WORKER:
        sys.stdout.write(f"\nFUZZ-STAGE {name}\n")
        sys.stdout.flush()


def run_case(case: Case, folder: Path) -> Outcome:
    """Load and render one variant in this process (under SIGALRM); the outcome says what
    went wrong, if anything."""
    out = Outcome(case, folder)
    path = write_variant(folder, case)
    before = listing(folder)
    start = time.perf_counter()
    stage, absurd = "load", False
    # warnings are not failures here (tests/support/hostile_run.py counts the command line's extra
    # stderr lines); the report lists them
    with alarm(CASE_TIMEOUT), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            _stage(stage)
            scene = gshade.load_scene(path)
            stage = "render"
            _stage(stage)
            if case.size:
                _, absurd = _work(scene.render)
                width, height = scene.render.width, scene.render.height
                image = gshade.render(scene)
            else:
                width, height = SMALL["width"], SMALL["height"]
                image = gshade.render(scene, **SMALL)
            bad = [k for k, c in image.channels.items() if not np.isfinite(c).all()]
            if absurd:
                out.problems.append("[render] rendered absurd settings instead of refusing them")
            if bad:
                out.problems.append(f"[render] image with non-finite channels: {', '.join(bad)}")
            shape = image.channels["R"].shape
            if shape != (height, width):
                out.problems.append(f"[render] {shape[1]}x{shape[0]} image, asked {width}x{height}")
            if not out.problems:
                stage = "write"
                _stage(stage)
                before = listing(folder)
                image.write_exr(folder / "out.exr")
            out.stage = stage if out.problems else "ok"
        except GshadeError as exc:
            out.error(
                stage,
                str(exc),
                path,
                before,
                need_limit=absurd if stage == "render" else _absurd_in_label(case),
                need_file=stage != "write",
            )
        except CaseTimeout as exc:
            out.stage, out.exc_type, out.where = stage, "timeout", _where(exc)
            out.problems.append(f"[{stage}] {exc} @ {out.where}")
        except Exception as exc:
            out.exception(stage, exc)
    out.seconds = time.perf_counter() - start
    seen = dict.fromkeys(f"{w.category.__name__}: {w.message}" for w in caught)
    out.warnings = [_first_line(w, 120) for w in seen]
    return out


# --------------------------------------------------------------------------- workers


def _worker_main() -> None:
    """A worker: JSON requests on stdin, ``FUZZ-RESULT {json}`` lines on stdout."""
    faulthandler.register(signal.SIGUSR1, file=sys.stderr, all_threads=False)
    from gshade.rendering import render  # noqa: F401 - import Mitsuba before the first case

    sys.stdout.write("\nFUZZ-READY\n")
    sys.stdout.flush()
    for line in sys.stdin:
        request = json.loads(line)
        outcome = run_case(Case(**request["case"]), Path(request["folder"]))
        sys.stdout.write("\nFUZZ-RESULT " + json.dumps(vars(outcome)) + "\n")
        sys.stdout.flush()


_FRAME = re.compile(r'File "([^"]+)", line (\d+) in (\S+)')


class Worker:
    """One worker process, restarted after it hangs, grows or dies."""

    def __init__(self, log: Path):
        self.log_path = log
        self.proc: subprocess.Popen | None = None

    def _start(self) -> None:
        self.log = open(self.log_path, "ab")  # lives as long as the worker
        env = dict(os.environ, GSHADE_FUZZ_WORKER="1", PYTHONUNBUFFERED="1")
        self.proc = subprocess.Popen(
            [sys.executable, "-c", f"from {__name__} import _worker_main; _worker_main()"],
            cwd=ROOT,
            env=env,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self.log,
            start_new_session=True,
        )
        self.buffer = b""
        kind, _ = self._wait(time.monotonic() + START_TIMEOUT, None)
        if kind != "READY":
            raise RuntimeError(f"a fuzz worker did not start: {kind}; see {self.log_path}")

    def stop(self) -> None:
        if self.proc is not None:
            try:
                os.killpg(self.proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            self.proc.wait()
            self.log.close()
            self.proc = None

    def _lines(self, until: float):
        """Complete stdout lines that arrive before ``until`` (monotonic)."""
        fd = self.proc.stdout.fileno()
        ready, _, _ = select.select([fd], [], [], max(0.0, min(0.1, until - time.monotonic())))
        if ready:
            chunk = os.read(fd, 1 << 16)
            if not chunk:
                return None  # EOF: the worker died
            self.buffer += chunk
        *lines, self.buffer = self.buffer.split(b"\n")
        return [line.decode("utf-8", "replace") for line in lines]

    def _wait(self, deadline: float, out: Outcome | None):
        """("READY" | "RESULT" | "dead" | "memory" | "timeout", data)."""
        while True:
            lines = self._lines(deadline)
            if lines is None:
                self.proc.wait()
                return "dead", self.proc.returncode
            for line in lines:
                if line.startswith("FUZZ-READY"):
                    return "READY", None
                if line.startswith("FUZZ-STAGE ") and out is not None:
                    out.stage = line.split(" ", 1)[1]
                if line.startswith("FUZZ-RESULT "):
                    return "RESULT", json.loads(line.split(" ", 1)[1])
            rss = rss_of(self.proc.pid)
            if rss > MEMORY_GB * 2**30:
                return "memory", rss
            if time.monotonic() > deadline:
                return "timeout", None

    def _native_stack(self, offset: int) -> str:
        """The worker's innermost gshade frame, from a faulthandler dump (SIGUSR1)."""
        try:
            os.kill(self.proc.pid, signal.SIGUSR1)
            time.sleep(0.5)
            self.log.flush()
            with open(self.log_path, "rb") as f:
                f.seek(offset)
                text = f.read().decode("utf-8", "replace")
        except OSError:
            return "?"
        frames = _FRAME.findall(text)
        ours = [f for f in frames if "/gshade/" in f[0]]
        f = (ours or frames or [("?", "?", "?")])[0]  # faulthandler: innermost first
        return _short_frame(*f)

    def run(self, case: Case, folder: Path) -> Outcome:
        if self.proc is None:
            self._start()
        offset = self.log_path.stat().st_size
        request = {"case": asdict(case), "folder": str(folder)}
        out = Outcome(case, folder)
        try:
            self.proc.stdin.write((json.dumps(request) + "\n").encode())
            self.proc.stdin.flush()
        except BrokenPipeError:
            pass
        start = time.monotonic()
        kind, data = self._wait(start + CASE_TIMEOUT + 15, out)
        if kind == "RESULT":
            vars(out).update(data)
            return out
        stage = out.stage or "?"
        out.seconds = time.monotonic() - start
        if kind == "timeout":
            out.exc_type, out.where = "timeout", self._native_stack(offset)
            out.problems.append(
                f"[{stage}] still running after {out.seconds:.0f} s in native code "
                f"(SIGALRM did not get through) @ {out.where}"
            )
        elif kind == "memory":
            out.exc_type, out.where = "memory", self._native_stack(offset)
            out.problems.append(f"[{stage}] memory above {MEMORY_GB:g} GB @ {out.where}")
        else:
            with open(self.log_path, "rb") as f:
                f.seek(offset)
                tail = f.read().decode("utf-8", "replace").strip().splitlines()
            why = f"killed by signal {-data}" if data < 0 else f"exit {data}"
            out.exc_type = "signal" if data < 0 else "exit"
            out.problems.append(f"[{stage}] worker {why}: {_first_line(tail[-1] if tail else '')}")
        self.stop()
        return out


def run_all(selected: list[Case], base: Path, jobs: int = JOBS) -> dict[str, Outcome]:
    todo: queue.Queue = queue.Queue()
    for i, case in enumerate(selected):
        todo.put((i, case))
    results: dict[str, Outcome] = {}
    failures: list[BaseException] = []

    def work(k: int) -> None:
        worker = Worker(base / f"worker{k}.log")
        try:
            while True:
                try:
                    i, case = todo.get_nowait()
                except queue.Empty:
                    return
                results[case.label] = worker.run(case, base / f"case{i:04d}")
        except BaseException as exc:  # re-raised in the test
            failures.append(exc)
        finally:
            worker.stop()

    threads = [threading.Thread(target=work, args=(k,)) for k in range(max(1, jobs))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    if failures:
        raise failures[0]
    if REPORT:
        with open(REPORT, "w", encoding="utf-8") as f:
            for case in selected:
                f.write(json.dumps(vars(results[case.label]), ensure_ascii=True) + "\n")
    return results


# --------------------------------------------------------------------------- the tests


@pytest.fixture(scope="module")
def outcomes(request, tmp_path_factory) -> dict[str, Outcome]:
    """Every selected case, run once in the workers (so that -k picks a few)."""
    selected = [
        item.callspec.params["case"]
        for item in request.session.items
        if getattr(item, "originalname", None) == "test_fuzzed_scene"
    ]
    return run_all(selected, tmp_path_factory.mktemp("fuzz"))


def test_writer_round_trip():
    """The fuzzer's TOML writer gives every project scene back unchanged."""
    from ..support.fuzz_scenes import _bases, tomllib

    for stem, doc in _bases():
        assert tomllib.loads(dumps(doc)) == doc, stem
    text = 'a\x00\x1f\x7f"\\\n\U0001f600'
    assert tomllib.loads(dumps({"s": text, "n": [1e308, 5e-324, -0.0, 10**400]})) == {
        "s": text,
        "n": [1e308, 5e-324, -0.0, 10**400],
    }


@pytest.mark.parametrize("case", CASES, ids=[c.label for c in CASES])
def test_fuzzed_scene(case: Case, outcomes: dict[str, Outcome]):
    outcome = outcomes[case.label]
    if outcome.problems:
        pytest.fail(f"{case.label}: " + " | ".join(outcome.problems), pytrace=False)


if __name__ == "__main__":  # pragma: no cover - cases in this process, by label prefix
    import tempfile

    for prefix in sys.argv[1:]:
        for case in [c for c in CASES if c.label.startswith(prefix)]:
            with tempfile.TemporaryDirectory() as tmp:
                result = run_case(case, Path(tmp))
                print(case.label, result.problems or "ok", f"{result.seconds:.2f} s")
