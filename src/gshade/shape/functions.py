"""Kiciak's shape functions (Chapter 6): the scalar fields whose level lines show continuity.

Each shape function is a formula in the surface derivatives.  Its *order* is the highest
derivative order it uses; on a G^n surface its level lines ("characteristic lines") are of
class G^(n - order).  Every function returns, with its values, the surface gradient
grad_S f = [f_u f_v] I^-1 [p_u; p_v], computed exactly by carrying first-order jets through
the formula (it needs one more derivative order than the function itself).

Conventions: N = p_u x p_v, n = N / |N|; vectors given as parameters need not be unit.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import GshadeError
from ..geometry.differential import IRREGULAR_TOL
from ..geometry.differential import derivative_scale as _derivative_scale
from . import kernels

__all__ = [
    "SHAPE_FUNCTIONS",
    "ShapeFunction",
    "ShapeValues",
    "evaluate",
    "get_shape_function",
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
    """A shape function's parameter: its kind ('vector', 'choice', 'number') and default."""

    kind: str
    default: Any
    help: str
    choices: tuple[str, ...] = ()


def _no_parameters(fn: str, kw: dict[str, Any]) -> tuple[int, NDArray]:
    return 0, np.zeros(24)


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
    code: int = field(default=-1, repr=False)
    #: (name, checked parameters) -> (the kernel's option, its 24 parameter numbers)
    pack: Callable[[str, dict[str, Any]], tuple[int, NDArray]] = field(
        default=_no_parameters, repr=False
    )

    def __call__(self, d: ArrayLike, *, gradient: bool = True, **params) -> ShapeValues:
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


def _vector(fn: str, name: str, x: Any, *, nonzero: bool = True, unit: bool = False) -> NDArray:
    try:
        v = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        v = None
    if v is None or v.shape != (3,) or not np.all(np.isfinite(v)):
        raise GshadeError(f"{fn}: {name}: expected 3 finite numbers [x, y, z], got {x!r}")
    length = float(np.linalg.norm(v))
    if nonzero and length == 0:
        raise GshadeError(f"{fn}: {name}: expected a non-zero direction, got {x!r}")
    return v / length if unit else v


def _check_params(fn: ShapeFunction, params: dict) -> dict:
    unknown = sorted(set(params) - set(fn.parameters))
    if unknown:
        known = ", ".join(fn.parameters) or "none"
        raise GshadeError(f"{fn.name}: unknown parameter {unknown[0]!r}; expected one of: {known}")
    out: dict[str, Any] = {}
    for name, spec in fn.parameters.items():
        x = params.get(name, spec.default)
        if spec.kind == "choice":
            if x not in spec.choices:
                raise GshadeError(
                    f"{fn.name}: {name}: expected one of {', '.join(spec.choices)}, got {x!r}"
                )
        elif spec.kind in ("direction", "point", "vector"):
            if x is None:
                out[name] = None
                continue
            x = _vector(
                fn.name, name, x, nonzero=spec.kind != "point", unit=spec.kind == "direction"
            )
        elif spec.kind == "number":
            try:
                x = float(x)
            except (TypeError, ValueError):
                raise GshadeError(f"{fn.name}: {name}: expected a number, got {x!r}") from None
        out[name] = x
    return out


def _frame(fn: str, a1: NDArray, a2: NDArray) -> NDArray:
    c = np.cross(a1, a2)
    if np.linalg.norm(c) <= 1e-12 * np.linalg.norm(a1) * np.linalg.norm(a2):
        raise GshadeError(
            f"{fn}: a1, a2: expected two non-parallel directions spanning the light plane, "
            f"got a1 = {a1.tolist()} and a2 = {a2.tolist()}"
        )
    return c


def _perpendicular(a: NDArray) -> NDArray:
    """A unit vector perpendicular to the unit vector a (the coordinate axis least along a)."""
    e = np.eye(3)[int(np.argmin(np.abs(a)))]
    w = e - np.dot(e, a) * a
    return w / np.linalg.norm(w)


# --------------------------------------------------------------------------- registry


def _register(name, code, order, summary, pack=None, *, eye=False, signed=False, **parameters):
    SHAPE_FUNCTIONS[name] = ShapeFunction(
        name, order, eye, signed, summary, dict(parameters), code, pack or _no_parameters
    )


def _pack(*vectors, at: int = 0) -> NDArray:
    prm = np.zeros(24)
    for v in vectors:
        prm[at : at + len(v)] = v
        at += len(v)
    return prm


def _pack_planar(fn, kw):
    return 0, _pack(kw["direction"])


def _pack_isophotes(fn, kw):
    return int(kw["form"] == "angle"), _pack(kw["light"])


def _pack_reflection(fn, kw):
    if kw["form"] == "plane":
        c = _frame(fn, kw["a1"], kw["a2"])
        return 0, _pack(kw["eye_point"], kw["origin"], kw["a1"], kw["a2"], np.zeros(6), c)
    a, w = kw["axis"], kw["reference"]
    if w is None:
        w = _perpendicular(a)
    w = w - np.dot(w, a) * a
    if np.linalg.norm(w) < 1e-9:
        raise GshadeError(
            f"{fn}: reference: expected a direction not parallel to axis {a.tolist()}"
        )
    w = w / np.linalg.norm(w)
    return 1, _pack(kw["eye_point"], np.zeros(9), np.cross(a, w), w)


def _pack_highlight(fn, kw):
    if kw["form"] == "plane":
        c = _frame(fn, kw["a1"], kw["a2"])
        return 0, _pack(kw["origin"], kw["a1"], kw["a2"], c, [np.linalg.norm(c)])
    return 1, _pack(kw["origin"], np.zeros(3), kw["a2"] / np.linalg.norm(kw["a2"]))


_register(
    "planar_sections",
    kernels.PLANAR,
    0,
    "f = <p, v>: sections by the planes perpendicular to v (contour lines)",
    _pack_planar,
    direction=Parameter("direction", (0.0, 0.0, 1.0), "normal v of the section planes"),
)
_register(
    "isophotes",
    kernels.ISOPHOTES,
    1,
    "f = <n, l> (form 'cos') or the angle arccos <n, l> (form 'angle', evenly spaced)",
    _pack_isophotes,
    light=Parameter("direction", (0.0, 0.0, 1.0), "light direction l"),
    form=Parameter(
        "choice", "cos", "cos: f = <n, l>; angle: f = arccos <n, l> (radians)", ("cos", "angle")
    ),
)
_register(
    "reflection_lines",
    kernels.REFLECTION,
    1,
    "reflections of light lines seen from the eye: lines in a plane (Kiciak: f = s of the hit "
    "point p0 + s a1 + t a2, undefined where the reflected ray misses the plane) or lines at "
    "infinity parallel to an axis (zebra: f = angle of r about the axis)",
    _pack_reflection,
    eye=True,
    eye_point=Parameter("point", (0.0, -10.0, 5.0), "eye point e"),
    form=Parameter(
        "choice", "plane", "plane: light lines in a plane; infinity: zebra", ("plane", "infinity")
    ),
    origin=Parameter("point", (0.0, 0.0, 10.0), "plane: a point p0 of the light plane"),
    a1=Parameter("vector", (1.0, 0.0, 0.0), "plane: direction across the light lines"),
    a2=Parameter("vector", (0.0, 1.0, 0.0), "plane: direction of the light lines"),
    axis=Parameter("direction", (0.0, 1.0, 0.0), "infinity: direction a of the light lines"),
    reference=Parameter("direction", None, "infinity: direction w ⊥ a where f = 0"),
)
_register(
    "highlight_lines",
    kernels.HIGHLIGHT,
    1,
    "light lines hit by the surface normal lines (Beier–Chen; independent of the eye): plane "
    "form (Kiciak: f = s of the hit point p0 + s a1 + t a2) or the signed distance "
    "d = <E x n, p - A> / |E x n| to the light line A + λE",
    _pack_highlight,
    form=Parameter(
        "choice", "plane", "plane: Kiciak's form; distance: Beier–Chen's d", ("plane", "distance")
    ),
    origin=Parameter("point", (0.0, 0.0, 10.0), "plane: p0; distance: a point A of the line"),
    a1=Parameter("vector", (1.0, 0.0, 0.0), "plane: direction across the light lines"),
    a2=Parameter(
        "vector",
        (0.0, 1.0, 0.0),
        "plane: direction of the light lines; distance: the line's direction E",
    ),
)
_register(
    "parametrisation_quality",
    kernels.PARAMETRISATION,
    1,
    "q = ((E - G)^2 + 4F^2) / (E + G)^2: 0 where the parametrisation is conformal",
)
_register("gaussian", kernels.GAUSSIAN, 2, "Gaussian curvature K = k1 k2", signed=True)
_register(
    "mean",
    kernels.MEAN,
    2,
    "mean curvature H = (k1 + k2) / 2, signed w.r.t. n = p_u x p_v",
    signed=True,
)
_register(
    "max_principal",
    kernels.MAX_PRINCIPAL,
    2,
    "the larger principal curvature k1 = H + sqrt(H^2 - K)",
    signed=True,
)
_register(
    "min_principal",
    kernels.MIN_PRINCIPAL,
    2,
    "the smaller principal curvature k2 = H - sqrt(H^2 - K)",
    signed=True,
)
_register("absolute", kernels.ABSOLUTE, 2, "absolute curvature |k1| + |k2|")
_register(
    "rms", kernels.RMS, 2, "root mean square curvature sqrt((k1^2 + k2^2) / 2) = sqrt(2H^2 - K)"
)


# --------------------------------------------------------------------------- evaluation


def evaluate(
    function: str | ShapeFunction,
    d: ArrayLike,
    *,
    gradient: bool = True,
    partials: bool = False,
    backend: str = "auto",
    **params,
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
    kw = _check_params(fn, params)
    option, prm = fn.pack(fn.name, kw)
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
        prm[kernels.IRREGULAR] = IRREGULAR_TOL * _derivative_scale(flat) ** 2
    f, grad, valid, eye, fuv = kernels.run(
        fn.code, option, prm, flat, gradient, backend, with_partials=partials
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
