"""What a scene file describes, once validated: the frozen dataclasses and the choices of
its string keys."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..geometry import Patch
from ..runtime.variant import VARIANTS
from ..shape.functions import SHAPE_FUNCTIONS

__all__ = [
    "CAMERA_TYPES",
    "DISPLAYS",
    "LIGHTINGS",
    "VARIANTS",
    "Camera",
    "RenderSettings",
    "Scene",
    "Shape",
    "Surface",
]

DISPLAYS = ("stripes", "colormap", "both")
LIGHTINGS = ("lit", "flat")
CAMERA_TYPES = ("perspective", "orthographic")


@dataclass(frozen=True)
class Surface:
    """One ``[[surface]]``: its type, its patches and where it was defined.

    ``source`` is the location used in messages, e.g. ``scene.toml: [[surface]] 1 (newell)``.
    """

    kind: str
    patches: tuple[Patch, ...] = field(repr=False)
    source: str


@dataclass(frozen=True)
class Shape:
    """The ``[shape]`` table: which shape function, its parameters, and how it is shown.

    ``params`` holds the parameters given in the file (validated; vectors as tuples of
    floats) for ``function`` and, with ``display = "both"``, ``colour_function``; the
    functions' own defaults apply to the rest (see :meth:`params_for`).  Exactly one of
    ``period`` and ``stripes`` is set.
    """

    function: str
    params: dict[str, Any]
    display: str
    period: float | None
    stripes: float | None
    duty: float
    phase: float
    value_range: tuple[float, float] | None
    colormap: str | None
    colour_function: str | None

    def params_for(self, function: str) -> dict[str, Any]:
        """The parameters in :attr:`params` that the shape function ``function`` takes."""
        names = SHAPE_FUNCTIONS[function].parameters
        return {k: v for k, v in self.params.items() if k in names}


@dataclass(frozen=True)
class Camera:
    """The ``[camera]`` table.  ``origin`` / ``target`` None: the renderer frames the scene."""

    type: str
    origin: tuple[float, float, float] | None
    target: tuple[float, float, float] | None
    up: tuple[float, float, float]
    fov: float
    width: float | None


@dataclass(frozen=True)
class RenderSettings:
    """The ``[render]`` table.  ``tessellation`` / ``texture_resolution`` None: automatic."""

    width: int
    height: int
    spp: int
    lighting: str
    variant: str
    seed: int
    tessellation: int | None
    chord_tolerance: float
    texture_resolution: int | None
    junctions: bool = False


@dataclass(frozen=True)
class Scene:
    """A validated scene file.

    ``check`` holds the ``[check]`` table's keys as given (``channels`` as a tuple);
    ``data_files`` the surface data files read (resolved paths); ``text_hash`` the sha256
    of the scene's parsed contents (after overrides) and of the data files' bytes.
    """

    name: str
    path: Path | None
    surfaces: tuple[Surface, ...]
    shape: Shape
    camera: Camera
    render: RenderSettings
    check: dict[str, Any]
    data_files: tuple[Path, ...]
    text_hash: str
    #: ``[sweep]``: dotted scene key -> the values ``gshade batch`` renders the scene with
    sweep: dict[str, tuple[Any, ...]] = field(default_factory=dict)

    @property
    def patches(self) -> tuple[Patch, ...]:
        """All patches of all surfaces, in order."""
        return tuple(p for s in self.surfaces for p in s.patches)
