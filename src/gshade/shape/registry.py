"""The shape-function registry: what a shape function is (:class:`ShapeFunction`, its
:class:`Parameter`), the table of them (:data:`SHAPE_FUNCTIONS`, filled by
:mod:`gshade.shape.functions`, where each is declared once with :func:`register`), the
checking of parameters, and :func:`evaluate`, which runs one on a derivatives array.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import GshadeError, one_of, show, suggest
from ..geometry.core.differential import IRREGULAR_TOL
from ..geometry.core.differential import derivative_scale as _derivative_scale
from ..limits import MIN_DIRECTION
from . import kernels
from .kernels import Formula, Layout

__all__ = [
    "RGB",
    "SHAPE_FUNCTIONS",
    "Bands",
    "Packed",
    "Parameter",
    "ShapeFunction",
    "ShapeValues",
    "evaluate",
    "function_bands",
    "function_period",
    "get_shape_function",
    "register",
    "validate_parameter",
    "validate_parameters",
]


class ShapeValues(NamedTuple):
    """Values f (shape (...)), surface gradient (shape (..., 3), or None), validity, and
    the parametric partials (f_u, f_v) (shape (..., 2), or None).

    ``valid`` is False where the function is undefined (e.g. the reflected ray misses the
    light plane, or the point is irregular); values there are finite (never NaN).
    """

    f: NDArray[np.float64]
    gradient: NDArray[np.float64] | None
    valid: NDArray[np.bool_]
    partials: NDArray[np.float64] | None = None


@dataclass(frozen=True)
class Parameter:
    """A shape function's parameter: its kind and default.

    Kinds: ``choice`` (one of ``choices``), ``number``, ``point``, ``vector``,
    ``direction`` (3 numbers) and ``file`` (one of the names ``choices`` or the path of a
    data file, found relative to the scene file as a surface's ``file`` is).
    """

    kind: str
    default: Any
    help: str
    choices: tuple[str, ...] = ()


RGB = tuple[float, float, float]


@dataclass(frozen=True)
class Bands:
    """A function's values split into named bands at ``edges`` (t_1 < ... < t_n: band 0 is
    f < t_1, band i is t_i <= f < t_(i+1), band n is f >= t_n), each drawn in its
    ``colours`` entry (sRGB), with ``lines``: levels drawn as sharp lines over them (the
    parting line, draft 0).  A value exactly at an edge lies in the band above it, or, where
    ``closed_above`` names the edge's index, in the band below (a radius equal to the
    limit is within it)."""

    edges: tuple[float, ...]
    names: tuple[str, ...]
    colours: tuple[RGB, ...]
    lines: tuple[float, ...] = ()
    closed_above: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        if len(self.names) != len(self.edges) + 1 or len(self.colours) != len(self.names):
            raise ValueError("Bands: expected one name and one colour per band (edges + 1)")
        if list(self.edges) != sorted(set(self.edges)):
            raise ValueError(f"Bands: edges: expected increasing levels, got {self.edges}")


#: what a shape function's ``pack`` returns: its form (the formula's option, "" if none), the
#: layout of its parameters and their values by field name
Packed = tuple[str, Layout, dict[str, Any]]

_NO_PARAMETERS = Layout()


def _no_parameters(fn: str, kw: dict[str, Any]) -> Packed:
    return "", _NO_PARAMETERS, {}


@dataclass(frozen=True)
class ShapeFunction:
    """A registered shape function.

    ``order``: the highest derivative order it uses; ``eye_dependent``: whether it changes
    with the eye point; ``signed``: whether its values have a meaningful sign (a diverging
    colour map centred on 0 suits it); ``parameters``: name -> :class:`Parameter`.
    """

    name: str
    order: int
    eye_dependent: bool
    signed: bool
    summary: str
    parameters: dict[str, Parameter] = field(default_factory=dict)
    #: the formula (see :data:`gshade.shape.kernels.Formula`)
    formula: Formula | None = field(default=None, repr=False)
    #: (name, checked parameters) -> (form, layout, the values of its fields)
    pack: Callable[[str, dict[str, Any]], Packed] = field(default=_no_parameters, repr=False)
    #: checked parameters -> the bands of ``display = "bands"`` (None: it has none)
    bands: Callable[[dict[str, Any]], Bands] | None = field(default=None, repr=False)
    #: checked parameters -> the period of f where its values are angles that wrap (an
    #: atan2 in (-pi, pi]: the renderer interpolates across the wrap), None where they do not
    period: Callable[[dict[str, Any]], float | None] | None = field(default=None, repr=False)

    @property
    def reflection(self) -> bool:
        """Whether the renderer draws it from the unit normal and the view (no formula)."""
        return self.formula is None

    def __call__(self, d: ArrayLike, *, gradient: bool = True, **params: Any) -> ShapeValues:
        return evaluate(self, d, gradient=gradient, **params)


SHAPE_FUNCTIONS: dict[str, ShapeFunction] = {}


def get_shape_function(name: str) -> ShapeFunction:
    """Look a shape function up by name."""
    try:
        return SHAPE_FUNCTIONS[name]
    except (KeyError, TypeError):
        raise GshadeError(
            f"function: expected one of {', '.join(SHAPE_FUNCTIONS)}, got {name!r}"
        ) from None


# --------------------------------------------------------------------------- parameters


def _unknown(fn: ShapeFunction, name: Any) -> GshadeError:
    known = ", ".join(fn.parameters) or "none"
    return GshadeError(f"{fn.name}: unknown parameter {name!r}; expected one of: {known}")


#: The longest ``file`` parameter accepted (a path), in characters.
MAX_PATH_CHARS = 4096


def _file(name: str, x: Any, choices: tuple[str, ...]) -> str:
    if (
        not isinstance(x, str)
        or not x
        or len(x) > MAX_PATH_CHARS
        or any(ord(c) < 32 or ord(c) == 127 for c in x)
    ):
        hint = f"{one_of(choices)} or " if choices else ""
        raise GshadeError(
            f"{name}: expected {hint}a file's path (at most {MAX_PATH_CHARS} printable "
            f"characters), got {show(x)}"
        )
    return x


def _vector(name: str, x: Any, *, nonzero: bool, unit: bool) -> NDArray:
    try:
        v = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        v = None
    if v is None or v.shape != (3,) or not np.all(np.isfinite(v)):
        raise GshadeError(f"{name}: expected 3 finite numbers [x, y, z], got {show(x)}")
    if nonzero and not math.hypot(*v) >= MIN_DIRECTION:
        raise GshadeError(
            f"{name}: expected a direction [x, y, z] of length at least {MIN_DIRECTION:g}, "
            f"got {show(x)}"
        )
    return v / np.linalg.norm(v) if unit else v


def validate_parameter(function: str | ShapeFunction, name: str, value: Any) -> Any:
    """One parameter of a shape function checked against its declaration (the one place
    its rule is written): a choice among its ``choices``; a ``point``: 3 finite numbers; a
    ``vector`` or ``direction``: 3 finite numbers of length at least
    :data:`gshade.limits.MIN_DIRECTION` (a direction is returned normalised); a
    ``number``: a number; a ``file``: one of its ``choices`` or a path (a non-empty string of
    printable characters; where it lies is the scene reader's to check).  None stands for a
    vector left out (a default of None).

    Raises
    ------
    GshadeError
        ``NAME: expected ..., got ...`` (an unknown name: ``FUNCTION: unknown parameter``).
    """
    fn = function if isinstance(function, ShapeFunction) else get_shape_function(function)
    spec = fn.parameters.get(name)
    if spec is None:
        raise _unknown(fn, name)
    if spec.kind == "choice":
        if not (isinstance(value, str) and value in spec.choices):
            hint = suggest(value, spec.choices) if isinstance(value, str) else ""
            raise GshadeError(
                f"{name}: expected one of {one_of(spec.choices)}, got {show(value)}{hint}"
            )
        return value
    if spec.kind in ("direction", "point", "vector"):
        if value is None:
            return None
        return _vector(name, value, nonzero=spec.kind != "point", unit=spec.kind == "direction")
    if spec.kind == "number":
        try:
            return float(value)
        except (TypeError, ValueError):
            raise GshadeError(f"{name}: expected a number, got {show(value)}") from None
    if spec.kind == "file":
        return _file(name, value, spec.choices)
    return value


def validate_parameters(function: str | ShapeFunction, params: dict[str, Any]) -> dict[str, Any]:
    """All parameters of a shape function: those given, checked by
    :func:`validate_parameter`, and the defaults of the rest.

    Raises
    ------
    GshadeError
        ``FUNCTION: NAME: expected ..., got ...``, or an unknown parameter.
    """
    fn = function if isinstance(function, ShapeFunction) else get_shape_function(function)
    unknown = sorted(set(params) - set(fn.parameters))
    if unknown:
        raise _unknown(fn, unknown[0])
    out: dict[str, Any] = {}
    for name, spec in fn.parameters.items():
        try:
            out[name] = validate_parameter(fn, name, params.get(name, spec.default))
        except GshadeError as exc:
            raise GshadeError(f"{fn.name}: {exc}") from None
    return out


# --------------------------------------------------------------------------- registry


def register(
    name: str,
    order: int,
    summary: str,
    formula: Formula | None,
    pack: Callable[[str, dict[str, Any]], Packed] | None = None,
    *,
    eye: bool = False,
    signed: bool = False,
    bands: Callable[[dict[str, Any]], Bands] | None = None,
    period: Callable[[dict[str, Any]], float | None] | None = None,
    **parameters: Parameter,
) -> None:
    """Declare a shape function: the one place its name, order, summary, formula, parameters,
    properties and bands are given (``formula`` None: a reflection, drawn by the
    renderer; see :attr:`ShapeFunction.reflection`)."""
    SHAPE_FUNCTIONS[name] = ShapeFunction(
        name,
        order,
        eye,
        signed,
        summary,
        dict(parameters),
        formula,
        pack or _no_parameters,
        bands,
        period,
    )


def function_period(function: str | ShapeFunction, params: dict[str, Any]) -> float | None:
    """The period of a function's values for its parameters (checked here) where they are
    angles that wrap (``reflection_lines`` of form ``infinity``: 2 pi), else None.

    Examples
    --------
    >>> import gshade.shape
    >>> round(function_period("reflection_lines", {"form": "infinity"}), 6)
    6.283185
    >>> function_period("mean", {}) is None
    True
    """
    fn = function if isinstance(function, ShapeFunction) else get_shape_function(function)
    if fn.period is None:
        return None
    return fn.period(checked_parameters(fn, params))


def function_bands(function: str | ShapeFunction, params: dict[str, Any]) -> Bands:
    """The bands of a function with bands, for its parameters (checked here).

    Raises
    ------
    GshadeError
        ``display: expected a function with bands (...), got NAME``, or a bad parameter.
    """
    fn = function if isinstance(function, ShapeFunction) else get_shape_function(function)
    if fn.bands is None:
        with_bands = ", ".join(k for k, f in SHAPE_FUNCTIONS.items() if f.bands is not None)
        raise GshadeError(
            f'display: "bands" expected a function with bands ({with_bands}), got {fn.name}'
        )
    return fn.bands(checked_parameters(fn, params))


def checked_parameters(function: str | ShapeFunction, params: dict[str, Any]) -> dict[str, Any]:
    """:func:`validate_parameters`, then the rules between them and on their values that
    the function's ``pack`` holds (``min_angle`` in [0, 90), ``axis`` not along
    ``reference`` ...): what a scene is checked with when it is read.

    Raises
    ------
    GshadeError
        ``FUNCTION: NAME: expected ..., got ...``.

    Examples
    --------
    >>> import gshade.shape
    >>> checked_parameters("draft_angle", {"min_angle": 90})
    Traceback (most recent call last):
    ...
    gshade.errors.GshadeError: draft_angle: min_angle: expected degrees in [0, 90), got 90.0
    """
    fn = function if isinstance(function, ShapeFunction) else get_shape_function(function)
    kw = validate_parameters(fn, params)
    fn.pack(fn.name, kw)
    return kw


# --------------------------------------------------------------------------- evaluation


def evaluate(
    function: str | ShapeFunction,
    d: ArrayLike,
    *,
    gradient: bool = True,
    partials: bool = False,
    backend: str = "auto",
    **params: Any,
) -> ShapeValues:
    """Evaluate a shape function on a derivatives array.

    Parameters
    ----------
    function : str or ShapeFunction
        Name (see :data:`SHAPE_FUNCTIONS`) or the function itself.
    d : ndarray, shape (order + 1, order + 1, ..., 3)
        Derivatives from ``Patch.derivatives`` (regularised at irregular points, if any:
        :func:`gshade.geometry.regularised_derivatives`).  The function's order is needed
        for f, one more for the gradient.
    gradient : bool
        Whether to compute the surface gradient grad_S f = [f_u f_v] I^-1 [p_u; p_v].
    partials : bool
        Whether to return the parametric partial derivatives (f_u, f_v) too (they need the
        same extra derivative order as the gradient).
    backend : {"auto", "drjit", "numpy"}
        Where the formula runs: Dr.Jit's LLVM backend (one compiled, multithreaded kernel;
        "auto" picks it wherever a libLLVM >= 17 is available) or numpy.
    **params
        The function's parameters (``SHAPE_FUNCTIONS[name].parameters``).

    Returns
    -------
    ShapeValues
        ``f`` (shape (...)), ``gradient`` (shape (..., 3) or None), ``valid`` (bool).
    """
    fn = function if isinstance(function, ShapeFunction) else get_shape_function(function)
    kw = validate_parameters(fn, params)
    form, layout, values = fn.pack(fn.name, kw)
    d = np.asarray(d, dtype=np.float64)
    if d.ndim < 3 or d.shape[0] != d.shape[1] or d.shape[-1] != 3:
        raise GshadeError(f"derivatives: expected shape (order+1, order+1, ..., 3), got {d.shape}")
    need = fn.order + (1 if gradient or partials else 0)
    if d.shape[0] - 1 < need:
        raise GshadeError(
            f"{fn.name}: needs derivatives of order {need} (order {fn.order}"
            f"{' + 1 for the gradient' if gradient or partials else ''}), got order "
            f"{d.shape[0] - 1}"
        )
    shape = d.shape[2:-1]
    flat = d.reshape(d.shape[0], d.shape[1], -1, 3)
    if fn.order >= 1:  # irregular points (|p_u x p_v| ~ 0) are flagged, as in geometry
        values = {**values, "irregular": IRREGULAR_TOL * _derivative_scale(flat) ** 2}
    if fn.formula is None:
        raise GshadeError(
            f"{fn.name}: has no value at a point without a view (a reflection the renderer "
            "draws); expected a function with a formula"
        )
    f, grad, valid, eye, fuv = kernels.run(
        fn.formula,
        form,
        layout,
        layout.pack(**values),
        flat,
        gradient,
        backend,
        with_partials=partials,
    )
    if eye.any():
        raise GshadeError(
            f"{fn.name}: eye_point: expected a point off the surface, got "
            f"{kw['eye_point'].tolist()}, which lies on it"
        )
    # kernels.run returns the gradient and the partials exactly when they were asked for
    gradient_out = None if grad is None else np.moveaxis(grad, 0, -1).reshape((*shape, 3))
    partials_out = None if fuv is None else np.moveaxis(fuv, 0, -1).reshape((*shape, 2))
    return ShapeValues(f.reshape(shape), gradient_out, valid.reshape(shape), partials_out)
