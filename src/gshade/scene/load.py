"""Reading a scene file: TOML, the bounds every value meets, the overrides, the tables in
turn (the small ones first, so that their mistakes show before surface data are read), the
surfaces, and the scene's hash."""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..errors import GshadeError, show
from ..geometry.evaluation.regularity import degenerate_patch
from ..limits import MAX_MAGNITUDE, MAX_NESTING, MAX_PATCHES, MAX_STRING
from .data_files import DataFiles, data_roots
from .model import Scene
from .overrides import apply_overrides
from .sections import parse_camera, parse_check, parse_render, parse_shape, parse_sweep
from .surfaces import SURFACE_TYPES, build_surface
from .tables import REQUIRED, Key, Table, declare_keys, parse_toml, read_toml

__all__ = ["TOP_KEYS", "load_scene", "parse_scene", "validate_values"]

_TABLE = "its keys' defaults"
TOP_KEYS = declare_keys(
    Key("name", "string", None, "the output name: <name>.exr, <name>.png", "the file's stem"),
    Key("surface", "one or more [[surface]] tables", REQUIRED, "the surfaces"),
    Key("shape", "table", None, "the shape function and how it is shown", _TABLE),
    Key("camera", "table", None, "the view", _TABLE),
    Key("render", "table", None, "the image and its sampling", _TABLE),
    Key("check", "table", None, "gshade check's render size, thresholds, reference model", _TABLE),
    Key("sweep", "table", None, "values gshade batch renders the scene with", _TABLE),
)


# --------------------------------------------------------------------------- value bounds


def _location(parts: Sequence[str | int], raw: dict[str, Any]) -> str:
    """Where a value sits, as messages name it: ``[[surface]] 2 (bezier): points[0][3]``,
    ``[camera] fov``, ``name``."""
    rest = list(parts)
    head = ""
    if len(rest) >= 2 and rest[0] == "surface" and isinstance(rest[1], int):
        table = raw["surface"][rest[1]]
        kind = table.get("type") if isinstance(table, dict) else None
        shown = f" ({kind})" if isinstance(kind, str) and kind in SURFACE_TYPES else ""
        head, rest = f"[[surface]] {rest[1] + 1}{shown}: ", rest[2:]
    elif len(rest) >= 2 and isinstance(rest[0], str) and isinstance(rest[1], str):
        head, rest = f"[{rest[0]}] ", rest[1:]
    text = ""
    for p in rest:
        text += f"[{p}]" if isinstance(p, int) else (f".{p}" if text else p)
    return (head + text).strip().rstrip(":") or "(top level)"


def validate_values(file: str, raw: dict[str, Any]) -> None:
    """Bounds every scene value must meet whatever its key: numbers finite and within
    ±MAX_MAGNITUDE (integers too: no overflow when they become floats), strings of at
    most MAX_STRING characters, keys short and printable, nesting at most MAX_NESTING
    deep.  One iterative pass, so that no depth or size of input can exhaust the stack."""
    stack: list[tuple[Any, tuple[str | int, ...]]] = [(raw, ())]
    while stack:
        value, parts = stack.pop()
        if len(parts) > MAX_NESTING:
            raise GshadeError(
                f"{file}: {_location(parts[:3], raw)}: expected arrays and tables nested at most "
                f"{MAX_NESTING} deep, got deeper ones"
            )
        if isinstance(value, dict):
            for key, item in value.items():
                if len(key) > 64 or not key.isprintable():
                    where = _location(parts, raw) if parts else "a key"
                    raise GshadeError(
                        f"{file}: {where}: expected keys of at most 64 printable characters, "
                        f"got {json.dumps(key[:40])}" + ("…" if len(key) > 40 else "")
                    )
                stack.append((item, (*parts, key)))
            stack[len(stack) - len(value) :] = reversed(stack[len(stack) - len(value) :])
        elif isinstance(value, list):  # pushed last to first: the first offender is reported
            stack.extend((value[k], (*parts, k)) for k in range(len(value) - 1, -1, -1))
        elif isinstance(value, bool):
            continue
        elif isinstance(value, (int, float)):
            if not abs(value) <= MAX_MAGNITUDE:  # NaN fails as well
                shown = show(value) if isinstance(value, float) else _big(value)
                raise GshadeError(
                    f"{file}: {_location(parts, raw)}: expected a finite number within "
                    f"±{MAX_MAGNITUDE:g}, got {shown}"
                )
        elif isinstance(value, str) and len(value) > MAX_STRING:
            raise GshadeError(
                f"{file}: {_location(parts, raw)}: expected a string of at most {MAX_STRING} "
                f"characters, got {len(value)}"
            )


def _big(x: int) -> str:
    digits = str(abs(x))
    sign = "-" if x < 0 else ""
    return f"{sign}{digits[:3]}…({len(digits)} digits)" if len(digits) > 20 else f"{x}"


# --------------------------------------------------------------------------- the scene


def _table(file: str, raw: dict[str, Any], name: str) -> dict[str, Any]:
    value = raw.get(name, {})
    if not isinstance(value, dict):
        raise GshadeError(f"{file}: {name}: expected a table [{name}], got {show(value)}")
    return value


def _hash(raw: dict[str, Any], data_files: Sequence[Path]) -> str:
    h = hashlib.sha256(b"gshade-scene-1\0")
    text = json.dumps(raw, sort_keys=True, separators=(",", ":"), ensure_ascii=False, default=str)
    h.update(text.encode("utf-8"))
    for f in data_files:  # in pieces: a map may be large
        with open(f, "rb") as file:
            h.update(b"\0" + os.fstat(file.fileno()).st_size.to_bytes(8, "little"))
            while piece := file.read(1 << 20):
                h.update(piece)
    return h.hexdigest()


def _build(
    raw: dict[str, Any],
    file: str,
    path: Path | None,
    base: Path,
    overrides: dict[str, Any] | None,
    data_path: Sequence[str | os.PathLike] | None = None,
    strict: bool = False,
) -> Scene:
    from ..io.outputs import output_name

    validate_values(file, raw)
    if overrides:
        raw = apply_overrides(file, raw, dict(overrides))
        validate_values(file, raw)
    if strict:
        raw = _strict(raw)
    top = Table(file, "", raw, TOP_KEYS)
    top.reject_unknown()
    if "name" in raw:
        name = output_name(top.string("name", expected="a non-empty string"), f"{file}: name")
    else:
        default = path.stem if path is not None else "scene"
        name = output_name(default, f"{file}: name (the file's stem; set name = ...)")
    if "surface" not in raw:
        raise GshadeError(f"{file}: [[surface]]: missing; expected at least one [[surface]] table")
    tables = raw["surface"]
    if not isinstance(tables, list) or not tables:
        raise GshadeError(
            f"{file}: surface: expected one or more [[surface]] tables (an array of tables), "
            f"got {show(tables)}"
        )
    # The small tables first, so that their mistakes show before surface data are read.
    roots = data_roots(base, data_path)
    shape = parse_shape(file, _table(file, raw, "shape"), DataFiles(base, roots))
    camera = parse_camera(file, _table(file, raw, "camera"))
    render = parse_render(file, _table(file, raw, "render"))
    check = parse_check(file, _table(file, raw, "check"), DataFiles(base, roots))
    sweep = parse_sweep(file, _table(file, raw, "sweep"))
    surfaces, data_files = [], []
    count = 0
    for index, table in enumerate(tables, start=1):
        surface, data_file = build_surface(file, index, table, base, roots)
        surfaces.append(surface)
        if data_file is not None and data_file.resolve() not in data_files:
            data_files.append(data_file.resolve())
        count += len(surface.patches)
        if count > MAX_PATCHES:
            raise GshadeError(
                f"{surface.source}: expected at most {MAX_PATCHES} patches in a scene, got "
                f"{count} by this surface"
            )
        bad = degenerate_patch(surface.patches)
        if bad is not None:
            which = f" patch {bad[0]}" if len(surface.patches) > 1 else ""
            raise GshadeError(f"{surface.source}:{which} degenerate: {bad[1]}")
    for data_file in shape.data_files():  # a map: no output may replace it either
        if data_file not in data_files:
            data_files.append(data_file)
    return Scene(
        name=name,
        path=path,
        surfaces=tuple(surfaces),
        shape=shape,
        camera=camera,
        render=render,
        check=check,
        data_files=tuple(data_files),
        text_hash=_hash(raw, data_files),
        sweep=sweep,
    )


def load_scene(
    path: str | os.PathLike,
    overrides: dict[str, object] | None = None,
    *,
    data_path: Sequence[str | os.PathLike] | None = None,
    strict: bool = False,
) -> Scene:
    """Read and validate a scene file.

    Parameters
    ----------
    path : path-like
        The TOML scene file (a regular file of at most 16 MB); surface data files are found
        relative to its directory, and must lie within it (symbolic links resolved).  A CAD
        file (``.step .stp .iges .igs .brep .3dm``) is a scene of its one ``cad`` surface
        with the default shape (isophotes lit along the automatic view: :data:`CAD_LIGHT`),
        camera and render settings, named after the file's stem.
    overrides : dict, optional
        Dotted key -> value (see :func:`parse_overrides`), applied to the file's contents
        before validation.  When an override changes ``shape.function`` (or
        ``shape.colour_function``), the file's parameters that only the replaced function
        takes are dropped.
    data_path : sequence of path-like, optional
        Further folders data files may lie in; default: those in the environment variable
        ``GSHADE_DATA_PATH`` (separated by ``os.pathsep``).
    strict : bool
        Every ``cad`` surface strict (its key ``strict = true``): a face that cannot be
        rendered is an error, not a warning.

    Returns
    -------
    Scene

    Raises
    ------
    GshadeError
        One line naming the file, the table and key, what was expected and what was found.

    Examples
    --------
    A scene of one bilinear Bézier patch (z = uv), written to a temporary folder, and read
    as it is and with the shape function overridden:

    >>> import shutil, tempfile
    >>> from pathlib import Path
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / "saddle.toml").write_text('''
    ... [[surface]]
    ... type = "bezier"
    ... points = [[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 1]]]
    ... [shape]
    ... function = "mean"
    ... ''')
    >>> scene = load_scene(folder / "saddle.toml")
    >>> scene.name, scene.surfaces[0].kind, len(scene.patches), scene.shape.function
    ('saddle', 'bezier', 1, 'mean')
    >>> scene.render.width, scene.render.height, scene.camera.origin  # defaults; framed later
    (1024, 768, None)
    >>> load_scene(folder / "saddle.toml", {"shape.function": "gaussian"}).shape.function
    'gaussian'
    >>> shutil.rmtree(folder)
    """
    from ..cad import CAD_EXTENSIONS
    from ..io.files import require_regular_file

    path = Path(path)
    base = path.parent
    if path.suffix.lower() in CAD_EXTENSIONS:  # a CAD file: a scene of that one surface
        # a folder, FIFO or link loop named like a CAD file is said to be one, not "no such file"
        require_regular_file(path, "a CAD file")
        try:
            model = path.resolve() if path.is_symlink() else path  # its folder holds it
        except (OSError, RuntimeError) as exc:  # changed since: a loop now
            raise GshadeError(
                f"{path}: cannot read the file ({getattr(exc, 'strerror', None) or exc})"
            ) from None
        raw: dict[str, Any] = {
            "surface": [{"type": "cad", "file": model.name}],
            "shape": {"light": list(CAD_LIGHT)},
        }
        base = model.parent
    elif path.suffix.lower() in OTHER_GEOMETRY:
        raise GshadeError(
            f"{path}: expected a scene file (TOML) or a CAD file ({' '.join(CAD_EXTENSIONS)}), "
            f"got a {path.suffix} file"
        )
    else:
        raw = read_toml(path, "a scene file (TOML)")
    return _build(raw, str(path), path, base, overrides, data_path, strict)


def _strict(raw: dict[str, Any]) -> dict[str, Any]:
    """The scene with ``strict = true`` in each of its ``cad`` surfaces."""
    tables = raw.get("surface")
    if not isinstance(tables, list):
        return raw
    raw = dict(raw)
    raw["surface"] = [
        {**t, "strict": True} if isinstance(t, dict) and t.get("type") == "cad" else t
        for t in tables
    ]
    return raw


#: The isophotes' light of a CAD file given as a scene: along the automatic camera's view
#: (not the default z), so that the walls parallel to z of a machined part do not all sit
#: on a stripe's edge (<n, l> = 0 there), where round-off would pick each pixel's colour.
CAD_LIGHT = (0.55, -0.75, 0.45)

#: Geometry files that are neither scenes nor readable CAD models (named, not parsed as TOML).
OTHER_GEOMETRY = frozenset(
    ".stl .obj .ply .off .3mf .gltf .glb .fbx .dxf .dwg .sat .sab .x_t .x_b .jt .sldprt "
    ".catpart .prt .ipt".split()
)


def parse_scene(
    text: str,
    *,
    source: str = "<string>",
    base: str | os.PathLike = ".",
    overrides: dict[str, object] | None = None,
    data_path: Sequence[str | os.PathLike] | None = None,
) -> Scene:
    """Validate a scene given as TOML text (``Scene.path`` is None, the default name "scene").

    ``source`` names the text in messages; data files are found relative to ``base`` (and
    must lie within it or ``data_path``).  See :func:`load_scene`.
    """
    return _build(parse_toml(text, source), source, None, Path(base), overrides, data_path)
