"""``gshade batch``: render many scenes (and sweeps over their keys) into one folder.

Scenes (files, folders, globs) and sweeps (``--sweep shape.function=isophotes,gaussian``:
one render per value; several sweeps multiply) become jobs.  Each job renders to
``DIR/<name>.exr`` and ``DIR/<name>.png``; a sweep's outputs are named after their values
(``teapot--function=gaussian``).  Jobs run in worker processes that import gshade and
Mitsuba once and keep their compiled kernels warm between scenes.  A job whose output is up
to date (the same scene text and data files, overrides and gshade version, recorded as
``batch_hash`` in the EXR header) is skipped unless forced.  A failing job is reported with
a one-line reason and a log file, and the others go on; ``DIR/manifest.json`` lists every
job.  Outputs are written atomically, so an interrupted batch leaves no partial files.
"""

from __future__ import annotations

import glob
import hashlib
import itertools
import json
import os
import re
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field
from pathlib import Path

from . import __version__
from .errors import GshadeError

__all__ = ["Job", "JobResult", "expand_scenes", "parse_sweeps", "plan_jobs", "run_batch"]


@dataclass(frozen=True)
class Job:
    """One render: a scene file, its overrides and the output name."""

    scene: str
    overrides: tuple[tuple[str, object], ...]
    name: str


@dataclass
class JobResult:
    name: str
    scene: str
    status: str  # "rendered", "up to date", "failed"
    message: str = ""
    seconds: float = 0.0
    hash: str = ""
    outputs: list[str] = field(default_factory=list)
    log: str | None = None


def expand_scenes(items: list[str]) -> list[Path]:
    """Scene files from files, folders (their *.toml) and glob patterns, in order, once."""
    found: list[Path] = []
    for item in items:
        if any(ch in item for ch in "*?["):
            matches = [Path(p) for p in sorted(glob.glob(item, recursive=True))]
            if not matches:
                raise GshadeError(f"{item}: the pattern matches no scene file")
        elif Path(item).is_dir():
            matches = sorted(Path(item).glob("*.toml"))
            if not matches:
                raise GshadeError(f"{item}: the folder has no scene files (*.toml)")
        elif Path(item).is_file():
            matches = [Path(item)]
        else:
            raise GshadeError(f"{item}: no such scene file or folder")
        for m in matches:
            if m.resolve() not in {f.resolve() for f in found}:
                found.append(m)
    return found


def _split_values(text: str) -> list[str]:
    """Split 'a,b,[1,2,3]' at the commas outside brackets and quotes."""
    parts, depth, quote, current = [], 0, None, ""
    for ch in text:
        if quote:
            quote = None if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(current)
            current = ""
            continue
        current += ch
    parts.append(current)
    return [p.strip() for p in parts if p.strip()]


def parse_sweeps(items: list[str]) -> list[tuple[str, list[object]]]:
    """``key=v1,v2,…`` items into (dotted key, values); values are TOML (bare words are
    strings)."""
    from .io.scene import parse_overrides

    sweeps = []
    for item in items:
        key, sep, values = item.partition("=")
        if not sep or not key.strip() or not values.strip():
            raise GshadeError(f"--sweep {item!r}: expected key=value1,value2,…")
        parsed = [
            parse_overrides([f"{key.strip()}={v}"])[key.strip()] for v in _split_values(values)
        ]
        sweeps.append((key.strip(), parsed))
    return sweeps


def _label(key: str, value: object) -> str:
    text = value if isinstance(value, str) else json.dumps(value, separators=(",", ""))
    return re.sub(r"[^A-Za-z0-9._=+,\[\]-]+", "_", f"{key.rsplit('.', 1)[-1]}={text}")


def plan_jobs(scenes: list[Path], sweeps: list[tuple[str, list[object]]]) -> list[Job]:
    """Every scene with every combination of its ``[sweep]`` values and the command line's
    (names checked unique)."""
    from .io.scene import load_scene

    jobs = []
    for path in scenes:
        try:
            loaded = load_scene(path)
            base, own = loaded.name, dict(loaded.sweep)
        except GshadeError:
            base, own = None, {}  # a broken scene fails on its own when run; the others go on
        # the scene's [sweep] table, with the command line's sweeps added (and winning)
        combined = {**own, **dict(sweeps)}
        keys = list(combined)
        for combo in itertools.product(*combined.values()) if combined else [()]:
            overrides = tuple(zip(keys, combo, strict=True))
            if base is not None and overrides:
                load_scene(path, dict(overrides))  # a sweep over a bad key stops the batch
            name = "--".join([base or path.stem, *(_label(k, v) for k, v in overrides)])
            jobs.append(Job(str(path), overrides, name))
    names = [j.name for j in jobs]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise GshadeError(
            f"batch: two jobs would write {duplicates[0]}.exr (scenes with the same name); "
            "rename one of them"
        )
    return jobs


def _job_hash(scene_hash: str) -> str:
    return hashlib.sha256(f"{scene_hash}\0gshade {__version__}".encode()).hexdigest()


def _up_to_date(exr: Path, png: Path, digest: str) -> bool:
    if not (exr.exists() and png.exists()):
        return False
    try:
        from .io.image import read_exr_header

        return read_exr_header(exr).get("batch_hash") == digest
    except GshadeError:
        return False


def _failed(result: JobResult, job: Job, out: Path, exc: BaseException) -> JobResult:
    result.status = "failed"
    result.message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    log = out / "logs" / f"{job.name}.log"
    log.parent.mkdir(parents=True, exist_ok=True)
    log.write_text(f"{job.scene} {dict(job.overrides)}\n{traceback.format_exc()}")
    result.log = str(log)
    return result


def check_job(job: Job, folder: str, force: bool) -> JobResult:
    """Whether a job's outputs are up to date (status "up to date") or not ("todo");
    "failed" if its scene does not load.  Cheap: nothing is rendered."""
    out = Path(folder)
    exr, png = out / f"{job.name}.exr", out / f"{job.name}.png"
    result = JobResult(job.name, job.scene, "todo", outputs=[str(exr), str(png)])
    try:
        from .io.scene import load_scene

        result.hash = _job_hash(load_scene(job.scene, dict(job.overrides)).text_hash)
    except Exception as exc:
        return _failed(result, job, out, exc)
    if not force and _up_to_date(exr, png, result.hash):
        result.status = "up to date"
    return result


def render_job(job: Job, folder: str) -> JobResult:
    """Render one job (in a worker process); never raises."""
    start = time.perf_counter()
    out = Path(folder)
    exr, png = out / f"{job.name}.exr", out / f"{job.name}.png"
    result = JobResult(job.name, job.scene, "failed", outputs=[str(exr), str(png)])
    try:
        from .io.scene import load_scene
        from .rendering import render

        scene = load_scene(job.scene, dict(job.overrides))
        result.hash = _job_hash(scene.text_hash)
        image = render(scene)
        image.metadata = {**image.metadata, "batch_hash": result.hash}
        image.write_exr(exr)
        image.write_png(png)
        result.status = "rendered"
    except Exception as exc:
        _failed(result, job, out, exc)
    result.seconds = time.perf_counter() - start
    return result


def _warm_worker() -> None:
    import gshade.rendering.pipeline  # noqa: F401  (imports Mitsuba's side once)


def run_batch(
    jobs: list[Job],
    folder: str | os.PathLike,
    *,
    workers: int = 1,
    force: bool = False,
    progress: bool | None = None,
    scheduler: str | None = None,
) -> list[JobResult]:
    """Run the jobs in ``workers`` processes (1: in this process), or on the Dask cluster at
    ``scheduler`` (``tcp://host:port``; needs ``gshade[dask]``), writing manifest.json.

    The output folder must be reachable under the same path from every worker."""
    from tqdm import tqdm

    out = Path(folder)
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".gshade-write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as exc:
        raise GshadeError(f"{out}: cannot write to the output folder ({exc.strerror})") from None
    if workers < 1:
        raise GshadeError(f"-j: expected at least 1 worker, got {workers}")
    show = progress if progress is not None else os.isatty(2)
    bar = tqdm(total=len(jobs), unit="scene", disable=not show, dynamic_ncols=True)
    results: list[JobResult] = []
    todo = []
    for job in jobs:  # up-to-date outputs are found here, without starting any worker
        state = check_job(job, str(out), force)
        if state.status == "todo":
            todo.append(job)
        else:
            results.append(state)
            bar.update()
    client = _dask_client(scheduler) if scheduler else None
    try:
        if client is not None:
            try:
                futures = client.map(render_job, todo, folder=str(out), pure=False)
                for _, result in _dask_as_completed(futures):
                    results.append(result)
                    bar.update()
            finally:
                client.close()
        elif workers == 1 or len(todo) <= 1:
            for job in todo:
                results.append(render_job(job, str(out)))
                bar.update()
        else:
            import multiprocessing

            context = multiprocessing.get_context("spawn")
            n = min(workers, len(todo))
            with ProcessPoolExecutor(n, mp_context=context, initializer=_warm_worker) as pool:
                futures = [pool.submit(render_job, job, str(out)) for job in todo]
                try:
                    for future in as_completed(futures):
                        results.append(future.result())
                        bar.update()
                except BaseException:
                    pool.shutdown(cancel_futures=True)
                    raise
    finally:
        bar.close()
        order = {job.name: k for k, job in enumerate(jobs)}
        results.sort(key=lambda r: order.get(r.name, 0))
        _write_manifest(out, jobs, results)
    return results


def _dask_client(address: str):
    """A Dask client for the scheduler at ``address``; a clear error if Dask is missing or
    the scheduler cannot be reached."""
    try:
        from distributed import Client
    except ImportError:
        raise GshadeError(
            '--scheduler: Dask\'s distributed package is not installed (pip install "gshade[dask]")'
        ) from None
    try:
        return Client(address, timeout="10s", set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise GshadeError(
            f"--scheduler: cannot reach the Dask scheduler at {address} ({exc})"
        ) from None


def _dask_as_completed(futures):
    """The futures' results, in submission order (the client need not be the default)."""
    for future in futures:
        yield future, future.result()


def _write_manifest(out: Path, jobs: list[Job], results: list[JobResult]) -> None:
    from .io.image import atomic_write

    done = {r.name for r in results}
    entries = [asdict(r) for r in results] + [
        {"name": j.name, "scene": j.scene, "status": "not run"} for j in jobs if j.name not in done
    ]
    manifest = {"gshade_version": __version__, "jobs": entries}
    atomic_write(
        out / "manifest.json",
        ".json",
        lambda tmp: Path(tmp).write_text(json.dumps(manifest, indent=2)),
    )
