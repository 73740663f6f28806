"""Reference checks (``gshade check``): render scenes at their check settings and diff them
with references.

Per scene: render at the ``[check]`` table's settings (small defaults, so that a check is
fast), compare with ``references/<name>.exr`` (channels and idiff thresholds from ``[check]``,
defaults below), and report a verdict.  References are written only on request, atomically:
``update`` writes those of new or failing scenes (Blender's rule), ``update_all`` every one.
A scene whose ``[check]`` names a ``reference_model`` is also measured against that geometry
(:func:`gshade.rendering.deviation_image.deviation_image` at the check's settings): it fails
when its largest |d| exceeds ``deviation`` (default
:data:`~gshade.analysis.deviation.RELATIVE_TOLERANCE` of its bounding-box diagonal) or
when none of it is in view, whatever its pixels.  A scene that fails to render is
reported and the others go on.  The HTML report of the results is
:mod:`gshade.regression.report`'s, their JUnit XML :mod:`gshade.regression.junit`'s.
:func:`check_scene` is one scene's check, for a scene file or a loaded scene (the pytest
plugin, :mod:`gshade.app.pytest_plugin`, runs it per test).
"""

from __future__ import annotations

import os
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import GshadeError
from ..io.outputs import distinct_files, output_file
from ..io.printable import printable
from .comparison import (
    ChannelMismatch,
    Comparison,
    Thresholds,
    UnreadableImage,
    compare,
)
from .statistical import z_test

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..rendering.rendered_image import RenderedImage
    from ..scene.model import Scene

__all__ = [
    "CHECK_DEFAULTS",
    "DEFAULT_THRESHOLDS",
    "CheckResult",
    "check",
    "check_scene",
    "find_scenes",
    "missing_references",
]

#: Settings of a check render unless the scene's ``[check]`` table says otherwise.
CHECK_DEFAULTS = {"width": 160, "height": 120, "spp": 4, "channels": ("R", "G", "B", "A", "f")}
#: Thresholds unless the scene's ``[check]`` table says otherwise (docs/how_to/ci.rst gives the
#: measurements behind them).
DEFAULT_THRESHOLDS = Thresholds(
    fail=0.02, failpercent=0.05, hardfail=float("inf"), warn=1e-3, warnpercent=0.0
)
#: Channels stored at full (32-bit) precision in references; the rest are 16-bit halves.
EXACT_CHANNELS = frozenset({"f", "u", "v", "patch", "P.X", "P.Y", "P.Z"})


@dataclass
class CheckResult:
    """One scene's check: ``status`` is PASS, WARNING, FAILURE, ERROR or NEW (no reference
    yet, and one was written).  ``name``, ``message`` and ``log`` are printable text
    (:func:`gshade.io.printable.printable`: a file name's control characters and bytes
    that are not UTF-8 escaped), as terminals, XML, HTML and JSON can show them; ``scene``
    and ``reference`` are the files' real paths.

    A scene with a ``[check] reference_model`` (that file's path) also has ``geometry``, the
    verdict of its deviation from it: PASS (max |d| within ``[check] deviation``), FAILURE
    (beyond it, or nothing in view) or ERROR (the model does not load, or the deviation
    cannot be measured); ``deviation`` holds the numbers
    (:func:`gshade.analysis.deviation.deviation_summary`, with ``b`` the model's name) and
    ``deviation_image`` the picture.  A geometry FAILURE or ERROR makes ``status`` so too
    (``message`` says which part failed), and fails the check even when a reference was
    written."""

    name: str
    scene: Path
    status: str
    message: str
    reference: Path | None = None
    comparison: Comparison | None = None
    written: str = ""  # "created" or "updated" when the reference was (re)written
    seconds: float = 0.0
    image: RenderedImage | None = field(default=None, repr=False)
    log: str = ""
    reference_model: Path | None = None
    geometry: str = ""
    deviation: dict[str, Any] | None = None
    deviation_image: RenderedImage | None = field(default=None, repr=False)

    @property
    def ok(self) -> bool:
        pixels = self.status in ("PASS", "WARNING") or bool(self.written)
        return pixels and self.geometry in ("", "PASS")

    def line(self) -> str:
        tag = f"{self.status} ({self.written} reference)" if self.written else self.status
        return f"{tag:<28} {self.name}: {self.message}"


def find_scenes(paths: list[str] | None) -> list[Path]:
    """Scene files from files and folders (a folder means its *.toml, see
    :func:`gshade.scene.discovery.scene_files`), in order; default scenes/.  Only finding
    none at all is an error."""
    from ..scene.discovery import scene_files

    items = [Path(p) for p in (paths or ["scenes"])]
    found: list[Path] = []
    for item in items:
        found += scene_files(item)
    if not found:
        raise GshadeError(f"{', '.join(map(str, items))}: no scene files (*.toml) found")
    return found


def missing_references(references: str | os.PathLike, *, update: bool) -> bool:
    """Whether the reference folder is to be made (it does not exist, and ``update``); a
    :class:`GshadeError` if it does not exist without ``update``.  Nothing is made."""
    references = Path(references)
    if references.is_dir():
        return False
    if not update:
        raise GshadeError(
            f"{references}: the reference folder does not exist "
            "(use update=True to create it with the current renders)"
        )
    return True


def _thresholds(settings: dict) -> Thresholds:
    keys = ("fail", "failpercent", "hardfail", "warn", "warnpercent")
    given = {k: float(settings[k]) for k in keys if k in settings}
    base = DEFAULT_THRESHOLDS
    return Thresholds(**{k: given.get(k, getattr(base, k)) for k in keys})


def _write_reference(image: RenderedImage, path: Path) -> None:
    from ..io.image import write_exr

    # variances (statistical references) are kept exactly: they scale the z-test
    half = {
        c
        for c in image.channels
        if c not in EXACT_CHANNELS and not c.endswith(".var") and f"{c}.var" not in image.channels
    }
    write_exr(path, image.channels, header=image.metadata, half=half)


def _render_runs(scene: Scene, settings: dict) -> RenderedImage:
    """Render ``runs`` times with independent seeds: the mean of each channel, and for the
    compared channels the variance of that mean in ``C.var`` (for :func:`z_test`)."""
    from ..rendering import render

    runs = int(settings["runs"])
    if runs < 2:
        raise GshadeError(f"[check] runs: expected at least 2 for the statistical test, got {runs}")
    images = [
        render(
            scene,
            width=settings["width"],
            height=settings["height"],
            spp=settings["spp"],
            seed=scene.render.seed + k,
        )
        for k in range(runs)
    ]
    first = images[0]
    channels = dict(first.channels)
    for c in settings["channels"]:
        stack = np.stack([im.channels[c].astype(np.float64) for im in images])
        channels[c] = stack.mean(axis=0).astype(np.float32)
        channels[f"{c}.var"] = (stack.var(axis=0, ddof=1) / runs).astype(np.float32)
    first.channels = channels
    first.metadata = {**first.metadata, "check_runs": str(runs)}
    return first


def check_scene(
    scene: str | os.PathLike | Scene,
    references: str | os.PathLike,
    *,
    update: bool = False,
    update_all: bool = False,
    statistical: bool = False,
) -> CheckResult:
    """Render one scene at its check settings and compare it with its reference.

    Parameters
    ----------
    scene : path-like or Scene
        A scene file (loaded here: a scene that does not load is an ERROR result), or a
        scene already loaded (e.g. with overrides by :func:`gshade.load_scene`).
    references : path-like
        The reference folder: the reference is ``references/<scene name>.exr``.  It must
        exist for a reference to be written.
    update, update_all, statistical : bool
        As :func:`check`'s.

    Returns
    -------
    CheckResult
        Never raises for a scene that fails to load, render or compare: that is the
        result's status (ERROR, FAILURE) and message.
    """
    from ..rendering import render
    from ..scene import load_scene

    start = time.perf_counter()
    references = Path(references)
    if isinstance(scene, (str, os.PathLike)):
        path, loaded = Path(scene), None
    else:
        path, loaded = (scene.path or Path(scene.name)), scene
    name = loaded.name if loaded is not None else path.stem
    try:
        scene = loaded if loaded is not None else load_scene(path)
        name = scene.name
        settings = {**CHECK_DEFAULTS, **scene.check}
        statistical = statistical or settings.get("statistical", False)
        if statistical:
            settings.setdefault("runs", 4)
            if "channels" not in scene.check:
                settings["channels"] = ("R", "G", "B")
            image = _render_runs(scene, settings)
        else:
            image = render(
                scene, width=settings["width"], height=settings["height"], spp=settings["spp"]
            )
    except Exception as exc:  # a broken scene must not stop the others
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        return CheckResult(
            printable(name),  # the file's stem, if the scene did not load
            path,
            "ERROR",
            printable(f"does not render: {reason}"),
            seconds=time.perf_counter() - start,
            log=""
            if isinstance(exc, GshadeError)
            else printable(traceback.format_exc(), keep_lines=True),
        )
    reference = output_file(references, name, ".exr")  # the name was checked at loading
    result = CheckResult(name, path, "FAILURE", "", reference, image=image)
    if not reference.exists():
        result.message = f"no reference {reference}; run with update=True to create it"
    else:
        try:
            if statistical:
                result.comparison = z_test(image, reference, channels=settings["channels"])
            else:
                result.comparison = compare(
                    image,
                    reference,
                    channels=settings["channels"],
                    thresholds=_thresholds(settings),
                )
            result.status = result.comparison.verdict
            result.message = result.comparison.summary()
        except (ChannelMismatch, UnreadableImage) as exc:
            result.message = f"cannot compare: {exc}"
    if update_all or (update and result.status not in ("PASS", "WARNING")):
        existed = reference.exists()
        try:
            distinct_files(
                [("the scene file", path)] + [("the data file", f) for f in scene.data_files],
                [("the reference", reference)],
            )
            _write_reference(image, reference)
        except GshadeError as exc:  # this scene's reference only: the others go on
            result.status, result.message = "ERROR", f"cannot write the reference: {exc}"
        else:
            if existed:
                result.written = "updated"
            else:
                result.written, result.status = "created", "NEW"
                result.message = f"new scene: {reference} written"
    if "reference_model" in settings:
        _check_geometry(result, scene, settings)
    result.message = printable(result.message)  # it names the reference folder
    result.seconds = time.perf_counter() - start
    return result


def _check_geometry(result: CheckResult, scene: Scene, settings: dict[str, Any]) -> None:
    """Measure ``scene`` against its ``[check] reference_model`` at the check's settings and
    add the verdict to ``result`` (see :class:`CheckResult`): its status, its message (``;
    geometry VERDICT: …``), the numbers and the picture."""
    from ..analysis.deviation import RELATIVE_TOLERANCE
    from ..analysis.scene_junctions import scene_diagonal
    from ..rendering.deviation_image import deviation_image
    from ..rendering.deviation_references import read_reference

    model = Path(settings["reference_model"])
    result.reference_model = model
    try:
        reference = read_reference(model)
        tolerance = settings.get("deviation")
        if tolerance is None:
            tolerance = RELATIVE_TOLERANCE * scene_diagonal(scene)
        picture, summary = deviation_image(
            scene,
            reference,
            float(tolerance),
            width=settings["width"],
            height=settings["height"],
            spp=settings["spp"],
        )
    except Exception as exc:  # the pixels' verdict stands, and the other scenes go on
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        result.geometry, result.status = "ERROR", "ERROR"
        result.message += f"; geometry ERROR: [check] reference_model: {reason}"
        if not isinstance(exc, GshadeError):
            result.log = printable(traceback.format_exc(), keep_lines=True)
        return
    result.deviation, result.deviation_image = summary, picture
    if not summary["count"]:
        result.geometry = "FAILURE"
        text = f"incomparable: no point of {scene.name} in view"
    elif summary["max_abs"] > tolerance:
        result.geometry = "FAILURE"
        x, y, z = summary["point"]
        text = (
            f"max |d| {summary['max_abs']:.6g} > {tolerance:.6g} at ({x:.6g}, {y:.6g}, "
            f"{z:.6g}) (face {summary['patch_a']} of {scene.name}, {summary['patch_b']} of "
            f"{reference.name})"
        )
    else:
        result.geometry = "PASS"
        text = f"max |d| {summary['max_abs']:.6g} ≤ {tolerance:.6g}"
    result.message += f"; geometry {result.geometry}: {text}"
    if result.geometry == "FAILURE" and result.status != "ERROR":
        result.status = "FAILURE"


def check(
    scenes: list[Path],
    references: Path,
    *,
    update: bool = False,
    update_all: bool = False,
    statistical: bool = False,
    progress: Callable[[CheckResult], object] | None = None,
) -> list[CheckResult]:
    """Check every scene; ``progress(result)`` is called after each.

    ``statistical`` (or a scene's ``[check] statistical = true``) renders ``runs`` times with
    independent seeds and compares with a z-test against the reference's variances
    (:func:`gshade.regression.statistical.z_test`) instead of thresholds: for noisy ``lit``
    renders across machines or variants."""
    references = Path(references)
    if missing_references(references, update=update or update_all):
        references.mkdir(parents=True)
    results = []
    for path in scenes:
        result = check_scene(
            path, references, update=update, update_all=update_all, statistical=statistical
        )
        results.append(result)
        if progress is not None:
            progress(result)
    return results
