"""Kiciak's shape functions (Chapter 6): the scalar fields whose level lines show continuity.

Each shape function is a formula in the surface derivatives.  Its *order* is the highest
derivative order it uses; on a G^n surface its level lines ("characteristic lines") are of
class G^(n - order).  Every function returns, with its values, the surface gradient
grad_S f = [f_u f_v] I^-1 [p_u; p_v], computed exactly by carrying first-order jets through
the formula (it needs one more derivative order than the function itself).

Conventions: N = p_u x p_v, n = N / |N|; vectors given as parameters need not be unit.

Each function is declared once, in its own section below: its formula, the
:class:`~gshade.shape.kernels.Layout` of its packed parameters (per form where the forms
differ), its ``pack`` and its ``_register`` call.  To add one, add a section here and nothing
else:

1. ``_MINE = Layout(("light", 3), ("scale", 1))``: the numbers the formula needs, by name and
   length (every layout ends with ``irregular``, the threshold ``evaluate`` sets);
2. ``def _mine(vec, p, form, xp)``: the formula on jets (:mod:`gshade.shape.jets`), reading
   ``p.light``, ``p.scale``, ``p.irregular`` and returning (jet of f, valid or None, eye or
   None); ``vec(i, j)`` is the jet vector of d^(i+j) p / du^i dv^j;
3. ``def _pack_mine(fn, kw)``: from the checked parameters ``kw`` to
   ``(form, _MINE, {"light": ..., "scale": ...})`` (raise :class:`GshadeError` for bad ones);
4. ``_register("mine", order, summary, _mine, _pack_mine, light=Parameter(...), ...)``.

Nothing is placed by offset: ``Layout.pack`` builds the vector and ``Layout.read`` gives the
formula each field by name; Dr.Jit still receives each number as an opaque value.  The README's
list of functions is documentation to update by hand.
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
from .jets import arccos, arctan2, cross, dot, jabs, sqrt
from .kernels import Formula, Layout

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


def _register(
    name: str,
    order: int,
    summary: str,
    formula: Formula,
    pack: Callable[[str, dict[str, Any]], Packed] | None = None,
    *,
    eye: bool = False,
    signed: bool = False,
    **parameters: Parameter,
) -> None:
    SHAPE_FUNCTIONS[name] = ShapeFunction(
        name, order, eye, signed, summary, dict(parameters), formula, pack or _no_parameters
    )


# --------------------------------------------------------------------------- planar sections

_PLANAR = Layout(("direction", 3))


def _planar_sections(vec, p, form, xp):
    return dot(vec(0, 0), p.direction), None, None


def _pack_planar(fn, kw):
    return "", _PLANAR, {"direction": kw["direction"]}


_register(
    "planar_sections",
    0,
    "f = <p, v>: sections by the planes perpendicular to v (contour lines)",
    _planar_sections,
    _pack_planar,
    direction=Parameter("direction", (0.0, 0.0, 1.0), "normal v of the section planes"),
)

# --------------------------------------------------------------------------- isophotes

_ISOPHOTES = Layout(("light", 3))


def _isophotes(vec, p, form, xp):
    N = cross(vec(1, 0), vec(0, 1))
    length = sqrt(dot(N, N), xp)
    f = dot(N, p.light) / length
    return (arccos(f, xp) if form == "angle" else f), length.f > p.irregular, None


def _pack_isophotes(fn, kw):
    return kw["form"], _ISOPHOTES, {"light": kw["light"]}


_register(
    "isophotes",
    1,
    "f = <n, l> (form 'cos') or the angle arccos <n, l> (form 'angle', evenly spaced)",
    _isophotes,
    _pack_isophotes,
    light=Parameter("direction", (0.0, 0.0, 1.0), "light direction l"),
    form=Parameter(
        "choice", "cos", "cos: f = <n, l>; angle: f = arccos <n, l> (radians)", ("cos", "angle")
    ),
)

# --------------------------------------------------------------------------- reflection lines

#: plane: eye e, a point p0 of the light plane, its direction a2, c = a1 x a2
_REFLECTION_PLANE = Layout(("eye", 3), ("origin", 3), ("a2", 3), ("c", 3))
#: infinity: eye e, a x w and w (f = 0 along w)
_REFLECTION_INFINITY = Layout(("eye", 3), ("across", 3), ("reference", 3))


def _reflection_lines(vec, p, form, xp):
    """r = w - 2 <w, N> N / <N, N> with w = p - e; plane: s = <(p - p0) x a2, r> / <c, r>."""
    pt = vec(0, 0)
    N = cross(vec(1, 0), vec(0, 1))
    NN = dot(N, N)
    w = tuple(pt[i] - p.eye[i] for i in range(3))
    eye = dot(w, w).f == 0.0
    valid = NN.f > p.irregular * p.irregular
    t = 2.0 * (dot(w, N) / NN)
    r = tuple(w[i] - t * N[i] for i in range(3))
    if form == "infinity":
        return arctan2(dot(r, p.across), dot(r, p.reference), xp), valid, eye
    c = p.c
    q = tuple(pt[i] - p.origin[i] for i in range(3))
    cr = dot(r, c)
    mu_sign = -dot(q, c).f * cr.f  # the sign of the ray parameter at the light plane
    valid = valid & (cr.f != 0.0) & (mu_sign > 0.0)
    return dot(cross(q, p.a2), r) / cr, valid, eye


def _pack_reflection(fn, kw):
    if kw["form"] == "plane":
        c = _frame(fn, kw["a1"], kw["a2"])
        values = {"eye": kw["eye_point"], "origin": kw["origin"], "a2": kw["a2"], "c": c}
        return "plane", _REFLECTION_PLANE, values
    a, w = kw["axis"], kw["reference"]
    if w is None:
        w = _perpendicular(a)
    w = w - np.dot(w, a) * a
    if np.linalg.norm(w) < 1e-9:
        raise GshadeError(
            f"{fn}: reference: expected a direction not parallel to axis {a.tolist()}"
        )
    w = w / np.linalg.norm(w)
    values = {"eye": kw["eye_point"], "across": np.cross(a, w), "reference": w}
    return "infinity", _REFLECTION_INFINITY, values


_register(
    "reflection_lines",
    1,
    "reflections of light lines seen from the eye: lines in a plane (Kiciak: f = s of the hit "
    "point p0 + s a1 + t a2, undefined where the reflected ray misses the plane) or lines at "
    "infinity parallel to an axis (zebra: f = angle of r about the axis)",
    _reflection_lines,
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

# --------------------------------------------------------------------------- highlight lines

#: plane: p0, the light lines' direction a2, c = a1 x a2 and |c|
_HIGHLIGHT_PLANE = Layout(("origin", 3), ("a2", 3), ("c", 3), ("c_norm", 1))
#: distance: a point A of the light line and its unit direction E
_HIGHLIGHT_DISTANCE = Layout(("origin", 3), ("direction", 3))


def _highlight_lines(vec, p, form, xp):
    """plane: s = <(p - p0) x a2, N> / <c, N>;  distance: <E x N, p - A> / |E x N|."""
    pt = vec(0, 0)
    N = cross(vec(1, 0), vec(0, 1))
    length = xp.sqrt(xp.maximum(dot(N, N).f, 0.0))
    valid = length > p.irregular
    q = tuple(pt[i] - p.origin[i] for i in range(3))
    if form == "distance":
        EN = cross(N, p.direction)  # N x E = -(E x N)
        norm = sqrt(dot(EN, EN), xp)
        return -(dot(EN, q) / norm), valid & (norm.f > 1e-12 * length), None
    cn = dot(N, p.c)
    valid = valid & (xp.abs(cn.f) > 1e-12 * length * p.c_norm)
    return dot(cross(q, p.a2), N) / cn, valid, None


def _pack_highlight(fn, kw):
    if kw["form"] == "plane":
        c = _frame(fn, kw["a1"], kw["a2"])
        values = {"origin": kw["origin"], "a2": kw["a2"], "c": c, "c_norm": np.linalg.norm(c)}
        return "plane", _HIGHLIGHT_PLANE, values
    values = {"origin": kw["origin"], "direction": kw["a2"] / np.linalg.norm(kw["a2"])}
    return "distance", _HIGHLIGHT_DISTANCE, values


_register(
    "highlight_lines",
    1,
    "light lines hit by the surface normal lines (Beier–Chen; independent of the eye): plane "
    "form (Kiciak: f = s of the hit point p0 + s a1 + t a2) or the signed distance "
    "d = <E x n, p - A> / |E x n| to the light line A + λE",
    _highlight_lines,
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

# --------------------------------------------------------------------------- parametrisation


def _parametrisation_quality(vec, p, form, xp):
    pu, pv = vec(1, 0), vec(0, 1)
    E, F, G = dot(pu, pu), dot(pu, pv), dot(pv, pv)
    s = E + G
    dEG = E - G
    return (dEG * dEG + 4.0 * (F * F)) / (s * s), s.f > 0.0, None


_register(
    "parametrisation_quality",
    1,
    "q = ((E - G)^2 + 4F^2) / (E + G)^2: 0 where the parametrisation is conformal",
    _parametrisation_quality,
)

# --------------------------------------------------------------------------- curvatures


def _curvature(which: str) -> Formula:
    def formula(vec, p, form, xp):
        """K = (L'N' - M'^2)/W^4, H = (E N' - 2F M' + G L')/(2 W^3), W = |N|, L' = <p_uu, N>,
        ...; ((k1 - k2)/2)^2 = ((G L' - E N')^2 / 4 + (G M' - F N')(E M' - F L')) / W^6."""
        pu, pv = vec(1, 0), vec(0, 1)
        N = cross(pu, pv)
        W2 = dot(N, N)
        valid = W2.f > p.irregular * p.irregular
        E, F, G = dot(pu, pu), dot(pu, pv), dot(pv, pv)
        L, M, Nn = dot(vec(2, 0), N), dot(vec(1, 1), N), dot(vec(0, 2), N)
        inv2 = 1.0 / W2
        inv4 = inv2 * inv2
        K = (L * Nn - M * M) * inv4
        if which == "gaussian":
            return K, valid, None
        H = (E * Nn - 2.0 * (F * M) + G * L) / (2.0 * (W2 * sqrt(W2, xp)))
        if which == "mean":
            return H, valid, None
        if which == "rms":
            return sqrt(2.0 * (H * H) - K, xp), valid, None
        gap = G * L - E * Nn
        disc = 0.25 * (gap * gap) + (G * M - F * Nn) * (E * M - F * L)
        root = sqrt(disc * (inv4 * inv2), xp)
        if which == "max_principal":
            return H + root, valid, None
        if which == "min_principal":
            return H - root, valid, None
        return jabs(H + root, xp) + jabs(H - root, xp), valid, None  # absolute

    return formula


_register("gaussian", 2, "Gaussian curvature K = k1 k2", _curvature("gaussian"), signed=True)
_register(
    "mean",
    2,
    "mean curvature H = (k1 + k2) / 2, signed w.r.t. n = p_u x p_v",
    _curvature("mean"),
    signed=True,
)
_register(
    "max_principal",
    2,
    "the larger principal curvature k1 = H + sqrt(H^2 - K)",
    _curvature("max_principal"),
    signed=True,
)
_register(
    "min_principal",
    2,
    "the smaller principal curvature k2 = H - sqrt(H^2 - K)",
    _curvature("min_principal"),
    signed=True,
)
_register("absolute", 2, "absolute curvature |k1| + |k2|", _curvature("absolute"))
_register(
    "rms",
    2,
    "root mean square curvature sqrt((k1^2 + k2^2) / 2) = sqrt(2H^2 - K)",
    _curvature("rms"),
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
        raise GshadeError(f"{fn.name}: has no formula")
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
