"""A scene with settings changed by name, as :func:`gshade.render` takes them: its keywords
(``function``, ``display``, ``width`` … ``camera={...}``, ``set={"shape.period": 0.05}``)
turned into dotted scene keys and checked exactly as a scene file's keys are — loaded from
a path with them as overrides, or set on a loaded Scene's ``[shape]``, ``[camera]`` and
``[render]`` tables and parsed again."""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Mapping
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import GshadeError, show, suggest
from .data_files import DataFiles, data_roots
from .load import load_scene, validate_values
from .model import Camera, Scene, Shape
from .overrides import apply_overrides
from .sections import RENDER_KEYS, SECTION_KEYS, parse_camera, parse_render, parse_shape

__all__ = ["scene_with_settings"]


#: The keywords of :func:`render` that set keys of other tables than ``[render]``.
_KEYWORD_KEYS = {"function": "shape.function", "display": "shape.display"}
#: The tables whose keys a loaded Scene may change (its surfaces are built: they need the file).
_SCENE_TABLES = ("shape", "camera", "render")


def scene_with_settings(
    scene: Scene | str | os.PathLike[str], keywords: Mapping[str, Any]
) -> Scene:
    """The scene (loaded from a path) with :func:`gshade.render`'s keywords applied (None:
    not given) and checked as a scene file's keys are: with a path, as the load's dotted
    overrides; with a loaded Scene, by :func:`_changed` (its values bounded as a file's
    are, :func:`gshade.scene.load.validate_values`).

    Examples
    --------
    >>> from gshade.scene import parse_scene
    >>> scene = parse_scene('[[surface]]\\ntype = "sphere"\\nradius = 1\\n')
    >>> changed = scene_with_settings(scene, {"function": "mean", "width": 64})
    >>> changed.shape.function, changed.render.width
    ('mean', 64)
    >>> scene_with_settings(scene, {"widht": 64})
    Traceback (most recent call last):
    ...
    gshade.errors.GshadeError: render: unknown setting 'widht'; did you mean "width"?
    >>> scene_with_settings(scene, {"set": {"shape.period": 1e300}})
    Traceback (most recent call last):
    ...
    gshade.errors.GshadeError: render(): [shape] period: expected a finite number within ±1e+15, ...
    """
    given = {name: value for name, value in keywords.items() if value is not None}
    changes = _dotted(
        given.pop("set", {}), "set", 'a mapping of dotted scene keys, e.g. {"shape.period": 0.05}'
    )
    for name, value in given.items():
        if name == "camera":
            expected = (
                'a mapping of [camera] keys, e.g. {"origin": [0, -5, 2], "target": [0, 0, 0]}'
            )
            changes.update(_dotted(value, "camera", expected, prefix="camera."))
        elif name in _KEYWORD_KEYS:
            changes[_KEYWORD_KEYS[name]] = _plain(value)
        elif name in RENDER_KEYS:
            changes[f"render.{name}"] = _plain(value)
        else:
            raise _unknown_setting(name)
    if isinstance(scene, (str, os.PathLike)):
        return load_scene(scene, changes)
    if not isinstance(scene, Scene):
        raise GshadeError(
            f"render: expected a Scene or the path of a scene file, got {show(scene)}"
        )
    return _changed(scene, changes) if changes else scene


def _unknown_setting(name: str) -> GshadeError:
    """A keyword :func:`render` does not take: the likeliest meant (a key of ``[shape]``:
    through ``set``, of ``[camera]``: through ``camera``), else those it takes."""
    known = tuple(dict.fromkeys(("function", "display", "camera", "set", *RENDER_KEYS)))
    if name in SECTION_KEYS["shape"]:
        hint = f"; did you mean set={{{json.dumps(f'shape.{name}')}: ...}}?"
    elif name in SECTION_KEYS["camera"]:
        hint = f"; did you mean camera={{{json.dumps(name)}: ...}}?"
    else:
        hint = suggest(name, known) or (
            f" (expected one of: {', '.join(known)}; other scene keys go in set, e.g. "
            'set={"shape.period": 0.05})'
        )
    return GshadeError(f"render: unknown setting {name!r}{hint}")


def _dotted(table: Any, keyword: str, expected: str, prefix: str = "") -> dict[str, Any]:
    """A keyword's mapping (``set``, ``camera``) as dotted scene keys (``prefix`` + key),
    the values plain (:func:`_plain`)."""
    if not isinstance(table, Mapping) or not all(isinstance(key, str) for key in table):
        raise GshadeError(f"render: {keyword}: expected {expected}, got {show(table)}")
    return {prefix + key: _plain(value) for key, value in table.items()}


def _plain(value: Any) -> Any:
    """A value as a scene file would hold it: numpy arrays and tuples as lists, numpy
    scalars as Python numbers (the parsers check the types, as for a file)."""
    if isinstance(value, (np.ndarray, np.generic)):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [_plain(item) for item in value]
    return value


def _changed(scene: Scene, changes: Mapping[str, Any]) -> Scene:
    """``scene`` with dotted keys of its ``[shape]``, ``[camera]`` and ``[render]`` tables
    set: the tables as a scene file would hold them get the keys as ``load_scene``'s
    overrides do, and the scene file's parsers validate them (messages read
    ``render(): [render] width: ...``)."""
    source = "render()"
    for key in changes:
        if key.split(".")[0] not in _SCENE_TABLES:
            raise GshadeError(
                f"{source}: set: {key}: expected a key of [shape], [camera] or [render] with "
                "a loaded Scene (give the scene's path to set the others)"
            )
    tables = {
        "shape": _shape_table(scene.shape),
        "camera": _camera_table(scene.camera),
        "render": {k: v for k, v in asdict(scene.render).items() if v is not None},
    }
    raw = apply_overrides(source, tables, dict(changes))
    validate_values(source, raw)
    # the paths [shape] names: relative to the scene's file (already found: absolute), or to
    # the working folder for a scene built in Python; within that folder or GSHADE_DATA_PATH
    base = Path(scene.path).parent if scene.path is not None else Path.cwd()
    files = DataFiles(base, data_roots(base, None))
    parsers: dict[str, Callable[[str, dict[str, Any]], Any]] = {
        "shape": lambda source, raw: parse_shape(source, raw, files),
        "camera": parse_camera,
        "render": parse_render,
    }
    touched = {key.split(".")[0] for key in changes}
    parsed = {name: parsers[name](source, raw[name]) for name in _SCENE_TABLES if name in touched}
    if "shape" in parsed:  # the files the [shape] names: the new ones for the old
        old = set(scene.shape.data_files())
        kept = [f for f in scene.data_files if f not in old]
        parsed["data_files"] = tuple(dict.fromkeys([*kept, *parsed["shape"].data_files()]))
    return replace(scene, **parsed)


def _shape_table(shape: Shape) -> dict[str, Any]:
    """The ``[shape]`` table a scene file would hold for ``shape``."""
    table: dict[str, Any] = {
        "function": shape.function,
        "display": shape.display,
        "duty": shape.duty,
        "phase": shape.phase,
        **shape.params,
    }
    if shape.period is not None:
        table["period"] = shape.period
    else:
        table["stripes"] = shape.stripes
    if shape.value_range is not None:
        table["range"] = list(shape.value_range)
    if shape.colormap is not None:
        table["colormap"] = shape.colormap
    if shape.colour_function is not None:
        table["colour_function"] = shape.colour_function
    return table


def _camera_table(camera: Camera) -> dict[str, Any]:
    """The ``[camera]`` table a scene file would hold for ``camera``."""
    table: dict[str, Any] = {"type": camera.type, "up": camera.up, "fov": camera.fov}
    for key in ("origin", "target", "width"):
        if getattr(camera, key) is not None:
            table[key] = getattr(camera, key)
    return table
