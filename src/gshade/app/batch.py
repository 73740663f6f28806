"""``gshade batch``: render many scenes (and sweeps over their keys) into one folder.

Scenes (files, folders, globs) and sweeps (``shape.function=isophotes,gaussian``: one
render per value; several sweeps multiply) become jobs (:mod:`gshade.app.jobs`), each
rendering ``DIR/<name>.exr`` and ``DIR/<name>.png`` (a sweep's are named after its values:
``teapot--function=gaussian``).  Jobs run in worker processes (:mod:`gshade.app.worker_pool`,
also with one worker) that keep Mitsuba and the compiled kernels warm between scenes.  A job
fails alone, with a one-line reason and a log in ``DIR/logs/``, whatever the cause: a scene
that does not load (even a ``RecursionError``), a name that cannot name a file, a worker that
dies (a crash, the OOM killer) or runs past the time limit.  Up-to-date outputs (the EXR
header's ``batch_hash``: scene text, data files, overrides, gshade version; ``batch_png``:
the PNG's sha256) are skipped unless forced.  ``DIR/manifest.json`` lists every job and is
rewritten as they end.  Outputs are staged (:func:`gshade.io.outputs.staged`): nothing
partial is left, and a re-run removes the temporaries a killed run left.  One batch at a
time writes into a folder (:func:`gshade.io.output_folders.folder_lock`; another is refused
at once, so that the manifest names what is on disk), nothing is written through a symbolic
link inside it (``DIR/logs`` may not be one), and no output replaces a scene file.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import time
from contextlib import ExitStack
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from .. import __version__
from ..errors import GshadeError
from .jobs import (
    Job,
    expand_scenes,
    failure_reason,
    failure_trace,
    log_stem,
    parse_sweeps,
    plan_jobs,
)

if TYPE_CHECKING:
    from .worker_pool import DaskPool, Outcome, WorkerPool

__all__ = [
    "BUSY",
    "DEFAULT_TIMEOUT",
    "Job",
    "JobResult",
    "expand_scenes",
    "job_status",
    "parse_sweeps",
    "plan_jobs",
    "render_job",
    "run_batch",
    "validate_batch_options",
]

#: Default time limit of one job, in seconds.
DEFAULT_TIMEOUT = 3600.0
#: The message of a batch refused because another writes into its folder.
BUSY = "another batch is writing here (wait for it to end, or choose another folder)"


@dataclass
class JobResult:
    """What became of a job: ``status`` is "rendered", "up to date" or "failed";
    ``warnings`` the CAD faces its render left out, a line each."""

    name: str
    scene: str
    status: str
    message: str = ""
    seconds: float = 0.0
    hash: str = ""
    outputs: list[str] = field(default_factory=list)
    log: str | None = None
    warnings: list[str] = field(default_factory=list)


def validate_batch_options(workers: int, timeout: float, scheduler: str | None = None) -> None:
    """Refuse fewer than 1 worker, a time limit not above 0, a scheduler address that is
    empty or not ``tcp://`` / ``tls://``, and a scheduler without Dask's ``distributed``
    installed (a :class:`GshadeError`, one line)."""
    from .worker_pool import validate_address

    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise GshadeError(f"workers: expected at least 1 worker, got {workers}")
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not timeout > 0:
        raise GshadeError(f"timeout: expected a number of seconds above 0, got {timeout}")
    if scheduler is not None:
        validate_address(scheduler)
        try:
            found = importlib.util.find_spec("distributed") is not None
        except (ImportError, ValueError):  # a broken installation, or sys.modules[...] = None
            found = False
        if not found:
            raise GshadeError(
                "scheduler: Dask's distributed package is not installed "
                '(pip install "gshade[dask]")'
            )


# ----------------------------------------------------------------- one job


def _job_hash(scene_hash: str) -> str:
    return hashlib.sha256(f"{scene_hash}\0gshade {__version__}".encode()).hexdigest()


def _sha256(path: str | os.PathLike) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            digest.update(chunk)
    return digest.hexdigest()


def _up_to_date(exr: Path, png: Path, digest: str) -> bool:
    """Whether the EXR records ``digest`` and the sha256 of the PNG beside it."""
    from ..io.image import read_exr_header

    try:
        if not (exr.is_file() and png.is_file()):
            return False
        header = read_exr_header(exr)
        return header.get("batch_hash") == digest and header.get("batch_png") == _sha256(png)
    except (GshadeError, OSError):
        return False


def _identity(path: Path) -> tuple[int, int, int] | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_ino, st.st_mtime_ns, st.st_size


def _outputs(folder: Path, name: str) -> tuple[Path, Path]:
    from ..io.outputs import output_file

    return output_file(folder, name, ".exr"), output_file(folder, name, ".png")


def _write_log(out: Path, job: Job, text: str) -> str | None:
    """Write ``DIR/logs/<name>.log`` (replacing, never following, what is there); its path,
    or None if it cannot be written."""
    from ..io.output_folders import output_folder
    from ..io.outputs import atomic_write, distinct_files, output_file

    name = job.log or job.name
    try:
        path = output_file(out / "logs", name, ".log")
    except GshadeError:  # a Job made by hand, with a name that cannot name a file
        path = out / "logs" / f"{log_stem(name)}.log"
    try:
        out.mkdir(parents=True, exist_ok=True)  # (a job's status asked for by hand)
        output_folder(out, "logs")  # never through a symbolic link
        distinct_files([("the scene file", job.scene)], [("the log", path)])
        atomic_write(path, ".log", lambda tmp: Path(tmp).write_text(text, errors="replace"))
    except (GshadeError, OSError):
        return None
    return str(path)


def _fail(result: JobResult, out: Path, job: Job, message: str, detail: str = "") -> JobResult:
    result.status = "failed"
    result.message = message
    result.log = _write_log(out, job, f"{job.scene} {dict(job.overrides)}\n{message}\n\n{detail}")
    return result


def _not_onto_the_scene(job: Job, *outputs: Path) -> None:
    """Refuse a job whose outputs would replace its scene file."""
    from ..io.outputs import distinct_files

    distinct_files([("the scene file", job.scene)], [("the output", p) for p in outputs])


def job_status(job: Job, folder: str, force: bool) -> JobResult:
    """Whether a job's outputs are up to date (status "up to date") or not ("todo");
    "failed" if it cannot run (see :class:`Job`) or its scene does not load.  Cheap:
    nothing is rendered."""
    out = Path(folder)
    result = JobResult(job.name, job.scene, "todo")
    if job.error:
        return _fail(result, out, job, job.error, job.detail)
    try:
        from ..scene import load_scene

        exr, png = _outputs(out, job.name)
        result.outputs = [str(exr), str(png)]
        _not_onto_the_scene(job, exr, png)
        scene_hash = job.scene_hash or load_scene(job.scene, dict(job.overrides)).text_hash
        result.hash = _job_hash(scene_hash)
    except Exception as exc:
        return _fail(result, out, job, failure_reason(exc, job.scene), failure_trace(exc))
    if not force and _up_to_date(exr, png, result.hash):
        result.status = "up to date"
    return result


def render_job(job: Job, folder: str) -> JobResult:
    """Render one job (in a worker process): the EXR and the PNG staged together (renamed
    only when both are written), the PNG's sha256 in the EXR header.  Never raises an
    :class:`Exception`; a failure is the result's status "failed" and a log."""
    start = time.perf_counter()
    out = Path(folder)
    result = JobResult(job.name, job.scene, "failed")
    if job.error:
        return _fail(result, out, job, job.error, job.detail)
    try:
        from ..io.outputs import staged, write_to
        from ..rendering import render
        from ..scene import load_scene

        exr, png = _outputs(out, job.name)
        result.outputs = [str(exr), str(png)]
        scene = load_scene(job.scene, dict(job.overrides))
        result.hash = _job_hash(scene.text_hash)
        with staged([exr, png]) as (exr_temporary, png_temporary):
            image = render(scene)
            write_to(png_temporary, image.png_writer(png), png)
            image.metadata = {
                **image.metadata,
                "batch_hash": result.hash,
                "batch_png": _sha256(png_temporary),
            }
            write_to(exr_temporary, image.exr_writer(exr), exr)
        result.status = "rendered"
        result.warnings = list(image.warnings)
    except Exception as exc:
        _fail(result, out, job, failure_reason(exc, job.scene), failure_trace(exc))
    result.seconds = time.perf_counter() - start
    return result


def _warm_worker() -> None:
    from ..runtime.own_process import configure_own_process

    configure_own_process()  # the worker process is gshade's, as the command's is
    import gshade.rendering.pipeline  # noqa: F401  (imports Mitsuba's side once)


# ----------------------------------------------------------------- the batch


class _Progress:
    """The results so far, the progress bar, and manifest.json rewritten as jobs end (at
    most 5 % of the time goes into rewriting it; :meth:`flush` catches up)."""

    def __init__(self, out: Path, jobs: list[Job], show: bool) -> None:
        from tqdm import tqdm

        self.out, self.jobs = out, jobs
        self.results: list[JobResult | None] = [None] * len(jobs)
        #: job index -> (hash, the EXR's identity before the run) for the jobs to render
        self.expected: dict[int, tuple[str, tuple | None]] = {}
        self.bar = tqdm(total=len(jobs), unit="scene", disable=not show, dynamic_ncols=True)
        self._dirty, self._written, self._cost = False, 0.0, 0.0

    def finish(self, k: int, result: JobResult) -> None:
        self.results[k] = result
        self.bar.update()
        self._dirty = True
        self.flush()

    def flush(self, now: bool = False) -> None:
        if now or (self._dirty and time.monotonic() - self._written >= 20 * self._cost):
            start = time.monotonic()
            _write_manifest(self.out, self.jobs, self.results)
            self._written = time.monotonic()
            self._cost, self._dirty = self._written - start, False

    def expect(self, k: int, result: JobResult) -> None:
        self.expected[k] = (result.hash, _identity(Path(result.outputs[0])))

    def found_on_disk(self, k: int) -> JobResult | None:
        """A job's result decided from its outputs: complete and of this job's hash (status
        "rendered" if this run wrote them, else "up to date"), or None."""
        digest, before = self.expected[k]
        job = self.jobs[k]
        exr, png = _outputs(self.out, job.name)
        if not _up_to_date(exr, png, digest):
            return None
        status = "up to date" if _identity(exr) == before else "rendered"
        return JobResult(job.name, job.scene, status, hash=digest, outputs=[str(exr), str(png)])

    def close(self) -> None:
        """Record the jobs without a result whose outputs are complete; write the manifest."""
        for k in self.expected:
            if self.results[k] is None:
                found = self.found_on_disk(k)
                if found is not None:
                    self.finish(k, found)
        self.bar.close()
        self.flush(now=True)


def _output_folder(folder: str | os.PathLike, jobs: list[Job]) -> list[Path]:
    """The folders to make for the output folder
    (:func:`gshade.io.output_folders.missing_folders`), once everything that can be refused
    was: it is not a file, its ``logs`` is not a symbolic link, ``manifest.json`` is no
    scene file.  Nothing is made."""
    from ..io.output_folders import missing_folders, output_folder
    from ..io.outputs import distinct_files

    out = Path(folder)
    to_make = missing_folders(out, f"{out}: cannot write to the output folder")
    if not to_make:
        output_folder(out, "logs", create=False)
    distinct_files(
        [("the scene file", s) for s in dict.fromkeys(job.scene for job in jobs)],
        [("the manifest", out / "manifest.json")],
    )
    return to_make


def run_batch(
    jobs: list[Job],
    folder: str | os.PathLike,
    *,
    workers: int = 1,
    force: bool = False,
    progress: bool | None = None,
    scheduler: str | None = None,
    timeout: float = DEFAULT_TIMEOUT,
) -> list[JobResult]:
    """Run the jobs in ``workers`` worker processes, or on the Dask cluster at ``scheduler``
    (``tcp://host:port`` or ``tls://host:port``; needs ``gshade[dask]``), writing
    ``manifest.json`` as they end.

    A job running longer than ``timeout`` seconds is stopped and fails (on Dask, the
    cluster's own limits apply instead).  On an interruption (``KeyboardInterrupt``,
    ``SystemExit`` from a signal) the workers are stopped, their temporaries removed and the
    manifest written, with the jobs whose outputs are complete recorded as done; then the
    exception goes on.  The output folder must be reachable under the same path from every
    worker.  Workers are started from this thread, which must outlive them (on Linux they
    are sent SIGTERM when it ends).
    """
    from ..io.output_folders import created_folders, folder_lock
    from ..io.outputs import confined, remove_stale_temporaries
    from .worker_pool import DaskPool, WorkerPool

    validate_batch_options(workers, timeout, scheduler)
    out = Path(folder)
    with ExitStack() as stack:
        # the cluster is reached first: a scheduler that is not there makes nothing
        dask = stack.enter_context(DaskPool(render_job, scheduler)) if scheduler else None
        # made once nothing is left to refuse; removed again if still empty on a failure
        stack.enter_context(created_folders(_output_folder(out, jobs)))
        stack.enter_context(folder_lock(out, BUSY))  # one batch at a time writes here
        stack.enter_context(confined(out))  # nothing through a link inside it
        remove_stale_temporaries(out)  # those a killed run left
        state = _Progress(out, jobs, progress if progress is not None else os.isatty(2))
        todo: list[int] = []
        try:
            for k, job in enumerate(jobs):  # up-to-date outputs are found without any worker
                result = job_status(job, str(out), force)
                if result.status == "todo":
                    state.expect(k, result)
                    todo.append(k)
                else:
                    state.finish(k, result)
            state.flush(now=True)  # every job listed before the first render
            if todo and dask is not None:
                _collect(state, todo, dask)
            elif todo:
                size = min(workers, len(todo))
                with WorkerPool(
                    render_job, size, timeout=timeout, initializer=_warm_worker
                ) as pool:
                    _collect(state, todo, pool)
        finally:
            state.close()
            if scheduler is None:
                remove_stale_temporaries(out)
    return [r for r in state.results if r is not None]


def _collect(state: _Progress, todo: list[int], pool: WorkerPool | DaskPool) -> None:
    """Run the jobs ``todo`` on ``pool``, recording each result as it comes."""
    from ..io.outputs import remove_stale_temporaries
    from .worker_pool import WorkerPool

    local = isinstance(pool, WorkerPool)
    for outcome in pool.run([(state.jobs[k], str(state.out)) for k in todo]):
        if outcome is None:  # nothing ended for a while
            state.flush()
            continue
        k = todo[outcome.index]
        if not outcome.error:
            state.finish(k, outcome.value)
            continue
        # the worker died or ran out of time: its temporaries go, its outputs may be whole
        if local:  # (the pids in the temporaries' names of a cluster's workers are not ours)
            remove_stale_temporaries(state.out)
        state.finish(k, state.found_on_disk(k) or _worker_failure(state, k, outcome))


def _worker_failure(state: _Progress, k: int, outcome: Outcome) -> JobResult:
    job = state.jobs[k]
    exr, png = _outputs(state.out, job.name)
    result = JobResult(job.name, job.scene, "failed", seconds=outcome.seconds)
    result.hash, result.outputs = state.expected[k][0], [str(exr), str(png)]
    detail = outcome.detail or f"worker process {outcome.pid}, after {outcome.seconds:.1f} s\n"
    return _fail(result, state.out, job, outcome.error, detail)


def _write_manifest(out: Path, jobs: list[Job], results: list[JobResult | None]) -> None:
    from ..io.outputs import atomic_write

    entries = [
        asdict(r) if r is not None else {"name": j.name, "scene": j.scene, "status": "not run"}
        for j, r in zip(jobs, results, strict=True)
    ]
    manifest = {"gshade_version": __version__, "jobs": entries}
    atomic_write(
        out / "manifest.json",
        ".json",
        lambda tmp: Path(tmp).write_text(json.dumps(manifest, indent=2)),
    )
