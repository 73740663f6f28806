"""Batch jobs: scenes (files, folders, globs) and sweeps into the renders ``gshade batch`` runs.

Sweeps (``shape.function=isophotes,gaussian``: one render per value; several sweeps
multiply; a scene's ``[sweep]`` table adds its own) name their outputs after their values
(``teapot--function=gaussian``).  Planning never fails for one scene: whatever goes wrong
(a scene that does not load, a sweep over a key it lacks, a name that cannot name a file)
becomes a job with ``error`` set, which fails alone when the batch runs.
"""

from __future__ import annotations

import itertools
import json
import math
import re
import traceback
from dataclasses import dataclass, replace
from pathlib import Path

from ..errors import GshadeError

__all__ = ["MAX_JOBS_PER_SCENE", "Job", "expand_scenes", "parse_sweeps", "plan_jobs"]

#: The most jobs the sweeps of one scene may make.
MAX_JOBS_PER_SCENE = 10_000


@dataclass(frozen=True)
class Job:
    """One render: a scene file, its overrides and the output name.

    ``error`` (one line) and ``detail`` (for the log) are set when the job cannot run: its
    scene does not load, its name cannot name a file, an earlier job has the same name.
    ``log`` is its log's name when ``name`` cannot be (empty: ``name``).  ``scene_hash`` is
    the scene's ``text_hash`` with the overrides, as planning found it (empty: not known).
    """

    scene: str
    overrides: tuple[tuple[str, object], ...]
    name: str
    error: str = ""
    detail: str = ""
    log: str = ""
    scene_hash: str = ""


def expand_scenes(items: list[str]) -> list[Path]:
    """Scene files from files, folders (their *.toml) and glob patterns (see
    :func:`gshade.scene.discovery.scene_files`), in order, each once; a folder or a pattern
    without scene files is an error."""
    from ..scene.discovery import is_pattern, scene_files

    found: list[Path] = []
    for item in items:
        matches = scene_files(item, patterns=True)
        if not matches and is_pattern(item):
            raise GshadeError(f"{item}: the pattern matches no scene file")
        if not matches:
            raise GshadeError(f"{item}: the folder has no scene files (*.toml)")
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
    strings).  Errors name the sweep: ``sweep 'ITEM': ...``."""
    from ..scene import parse_overrides

    sweeps = []
    for item in items:
        key, sep, values = item.partition("=")
        if not sep or not key.strip() or not values.strip():
            raise GshadeError(f"sweep {item!r}: expected key=value1,value2,…")
        try:
            parsed = [
                parse_overrides([f"{key.strip()}={v}"])[key.strip()] for v in _split_values(values)
            ]
        except GshadeError:
            raise
        except Exception as exc:  # e.g. RecursionError, or an integer of 5000 digits
            raise GshadeError(failure_reason(exc, f"sweep {item[:60]!r}")) from None
        sweeps.append((key.strip(), parsed))
    return sweeps


def _label(key: str, value: object) -> str:
    text = value if isinstance(value, str) else json.dumps(value, separators=(",", ""))
    return re.sub(r"[^A-Za-z0-9._=+,\[\]-]+", "_", f"{key.rsplit('.', 1)[-1]}={text}")


def failure_reason(exc: BaseException, where: str) -> str:
    """One line for an exception: gshade's own message, or ``where: Type: message``."""
    lines = str(exc).strip().splitlines()
    text = lines[0] if lines else ""
    if not isinstance(exc, GshadeError):
        text = f"{where}: {type(exc).__name__}" + (f": {text}" if text else "")
    return text if len(text) <= 300 else text[:299] + "…"


def failure_trace(exc: BaseException) -> str:
    """The exception's traceback, its last frames only (a RecursionError has thousands)."""
    return "".join(traceback.format_exception(type(exc), exc, exc.__traceback__, limit=-30))


def _broken(path: Path, overrides: tuple, name: str, exc: BaseException) -> Job:
    return Job(str(path), overrides, name, failure_reason(exc, str(path)), failure_trace(exc))


def _scene_jobs(path: Path, sweeps: list[tuple[str, list[object]]]) -> list[Job]:
    """The jobs of one scene: one per combination of its sweeps' values."""
    from ..io.outputs import output_name
    from ..scene import load_scene

    try:
        loaded = load_scene(path)
    except Exception as exc:  # a broken scene fails on its own; the others go on
        return [_broken(path, (), path.stem, exc)]
    # the scene's [sweep] table, with the command line's sweeps added (and winning)
    combined = {**dict(loaded.sweep), **dict(sweeps)}
    count = math.prod(len(values) for values in combined.values())
    if count > MAX_JOBS_PER_SCENE:
        raise GshadeError(
            f"{path}: expected sweeps making at most {MAX_JOBS_PER_SCENE} jobs of one scene, "
            f"got {count}"
        )
    jobs = []
    for combo in itertools.product(*combined.values()):
        overrides = tuple(zip(combined, combo, strict=True))
        name = loaded.name
        try:
            name = "--".join([name, *(_label(k, v) for k, v in overrides)])
            # e.g. a sweep over a key the scene does not have
            scene = load_scene(path, dict(overrides)) if overrides else loaded
            output_name(name, f"{path}: output name")
        except Exception as exc:
            jobs.append(_broken(path, overrides, name, exc))
        else:
            jobs.append(Job(str(path), overrides, name, scene_hash=scene.text_hash))
    return jobs


def log_stem(name: str) -> str:
    """A file name for a job's log when the job's own name cannot be one."""
    return re.sub(r"[^A-Za-z0-9._=+,-]+|\.\.+", "_", name).lstrip(".")[:100] or "job"


def plan_jobs(scenes: list[Path], sweeps: list[tuple[str, list[object]]]) -> list[Job]:
    """Every scene with every combination of its ``[sweep]`` values and the command line's.

    Never raises for a scene: one that does not load (whatever the error), a sweep over a
    key it does not have, more than :data:`MAX_JOBS_PER_SCENE` combinations or a name that
    cannot name a file (:func:`gshade.io.outputs.output_name`) give jobs with ``error`` set,
    which fail on their own when the batch runs.  Of two jobs with the same output name the
    first is rendered and the later ones fail (they would overwrite its outputs).
    """
    from ..io.outputs import output_name

    jobs: list[Job] = []
    for path in map(Path, scenes):
        try:
            jobs += _scene_jobs(path, sweeps)
        except Exception as exc:
            jobs.append(_broken(path, (), path.stem, exc))
    first: dict[str, Job] = {}
    logs: set[str] = set()
    for k, job in enumerate(jobs):
        if not job.error and job.name in first:
            job = replace(
                job,
                error=f"{job.scene}: expected a name of its own, got {job.name!r}, the output "
                f'name of {first[job.name].scene} too (set name = "…" in one of them)',
            )
        elif not job.error:
            first[job.name] = job
        try:
            log = output_name(job.name) if job.name not in logs else ""
        except GshadeError:
            log = ""
        if not log:
            job = replace(job, log=f"{log_stem(job.name)}--job{k + 1}")
        logs.add(job.log or job.name)
        jobs[k] = job
    return jobs
