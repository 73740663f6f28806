"""What a scene file describes, once validated: the frozen dataclasses and the choices of
its string keys."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError, show
from ..geometry import Patch
from ..limits import MIN_DIRECTION
from ..runtime.variant import VARIANTS
from ..shape.functions import SHAPE_FUNCTIONS
from .bodies import PATCHES, CadFaces, SurfaceBody

__all__ = [
    "CAMERA_TYPES",
    "DISPLAYS",
    "LIGHTINGS",
    "SAMPLINGS",
    "VARIANTS",
    "CadFaces",
    "Camera",
    "RenderSettings",
    "Scene",
    "Shape",
    "Surface",
    "validate_view",
]

DISPLAYS = ("stripes", "colormap", "both", "bands")
LIGHTINGS = ("lit", "flat", "soft")
#: where a render takes ``spp`` samples per pixel (one at the centre elsewhere)
SAMPLINGS = ("edges", "uniform")
CAMERA_TYPES = ("perspective", "orthographic")


@dataclass(frozen=True)
class Surface:
    """One ``[[surface]]``: its type, its patches and where it was defined.

    ``source`` is the location used in messages, e.g. ``scene.toml: [[surface]] 1 (newell)``.
    ``cad`` is set for the ``cad`` type only (None otherwise): its patches are the faces'
    untrimmed boxes, and the render meshes the trimmed faces from it instead of the grid.
    ``body`` says what the patches stand for, whatever the type.
    """

    kind: str
    patches: tuple[Patch, ...] = field(repr=False)
    source: str
    cad: CadFaces | None = field(default=None, repr=False, compare=False)

    @property
    def body(self) -> SurfaceBody:
        """What the patches stand for (:mod:`gshade.scene.bodies`): the CAD model's faces
        (``cad``), else patches exact over their domains."""
        return PATCHES if self.cad is None else self.cad


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

    def data_files(self) -> tuple[Path, ...]:
        """The files its functions' ``file`` parameters name (an environment's map; not
        one of the parameter's names, such as ``"lightbox"``), resolved."""
        found: dict[Path, None] = {}
        for function in (self.function, self.colour_function):
            if function is None:
                continue
            for name, spec in SHAPE_FUNCTIONS[function].parameters.items():
                value = self.params.get(name)
                if spec.kind == "file" and value is not None and value not in spec.choices:
                    found[Path(value).resolve()] = None
        return tuple(found)


def _point(name: str, value: Any) -> NDArray:
    try:
        v = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        v = None
    if v is None or v.shape != (3,) or not np.all(np.isfinite(v)):
        raise GshadeError(f"{name}: expected 3 finite numbers [x, y, z], got {show(value)}")
    return v


def validate_view(origin: Any, target: Any, up: Any) -> None:
    """A camera's vectors, the one place their rule is written: ``up`` a direction (of
    length at least :data:`gshade.limits.MIN_DIRECTION`), ``target`` a point other than
    ``origin``, and ``up`` not parallel to ``target - origin`` (the sine of the angle
    between them above 1e-9).  ``origin`` and ``target`` None: not yet known (the renderer
    frames the surfaces, then checks the view it chose).

    Raises
    ------
    GshadeError
        ``up: ...`` or ``target: ...``, showing the values as given.
    """
    u = _point("up", up)
    o = None if origin is None else _point("origin", origin)
    t = None if target is None else _point("target", target)
    if not math.hypot(*u) >= MIN_DIRECTION:
        raise GshadeError(
            f"up: expected a direction [x, y, z] of length at least {MIN_DIRECTION:g}, "
            f"got {show(up)}"
        )
    if o is None or t is None:
        return
    view = t - o
    if not np.any(view):
        raise GshadeError(f"target: expected a point other than origin, got {show(target)}")
    if np.linalg.norm(np.cross(view, u)) <= 1e-9 * np.linalg.norm(view) * np.linalg.norm(u):
        raise GshadeError(
            f"up: expected a direction not parallel to target - origin {view.tolist()}, "
            f"got {show(up)}"
        )


def _floats(v: Any) -> tuple[float, float, float] | None:
    return None if v is None else (float(v[0]), float(v[1]), float(v[2]))


@dataclass(frozen=True)
class Camera:
    """The ``[camera]`` table.  ``origin`` / ``target`` None: the renderer frames the scene.

    The vectors are checked on construction (:func:`validate_view`), so that a Camera is
    valid however it was made, and kept as tuples of floats.
    """

    type: str
    origin: tuple[float, float, float] | None
    target: tuple[float, float, float] | None
    up: tuple[float, float, float]
    fov: float
    width: float | None

    def __post_init__(self) -> None:
        validate_view(self.origin, self.target, self.up)
        for name in ("origin", "target", "up"):
            object.__setattr__(self, name, _floats(getattr(self, name)))


#: Which part of a curve's curvature vector a comb shows.
COMB_CURVATURES = ("space", "normal", "geodesic")
#: The curves combs run along: patch boundaries and B-rep edges, knot lines, planar sections.
COMB_LINES = ("edges", "knots", "sections")


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
    aovs: tuple[str, ...] = ()
    sampling: str = "edges"
    parabolic: bool = False
    combs: bool = False
    comb_curvature: str = "space"
    comb_lines: tuple[str, ...] = ("edges",)
    #: spine length per unit of curvature (length²); None: automatic
    comb_scale: float | None = None
    #: the planes of the ``"sections"`` comb lines and their normal (None: automatic)
    comb_sections: int = 8
    comb_section_direction: tuple[float, float, float] | None = None


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
