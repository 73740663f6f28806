"""Kiciak's shape functions (Chapter 6): the scalar fields whose level lines show continuity.

Each shape function is a formula in the surface derivatives.  Its *order* is the highest
derivative order it uses; on a G^n surface its level lines ("characteristic lines") are of
class G^(n - order).  Every function returns, with its values, the surface gradient
grad_S f = [f_u f_v] I^-1 [p_u; p_v], computed exactly by carrying first-order jets through
the formula (it needs one more derivative order than the function itself).

Conventions: N = p_u x p_v, n = N / |N|; vectors given as parameters need not be unit.

Each function is declared once, in its own section below: its formula, the
:class:`~gshade.shape.kernels.Layout` of its packed parameters (per form where the forms
differ), its ``pack`` and its :func:`~gshade.shape.registry.register` call.  To add one, add
a section here and nothing else (:mod:`gshade.shape.registry` holds the machinery: the
table, parameter checking, :func:`~gshade.shape.registry.evaluate`):

1. ``_MINE = Layout(("light", 3), ("scale", 1))``: the numbers the formula needs, by name and
   length (every layout ends with ``irregular``, the threshold ``evaluate`` sets);
2. ``def _mine(vec, p, form, xp)``: the formula on jets (:mod:`gshade.geometry.core.jets`), reading
   ``p.light``, ``p.scale``, ``p.irregular`` and returning (jet of f, valid or None, eye or
   None); ``vec(i, j)`` is the jet vector of d^(i+j) p / du^i dv^j;
3. ``def _pack_mine(fn, kw)``: from the checked parameters ``kw`` to
   ``(form, _MINE, {"light": ..., "scale": ...})`` (raise :class:`GshadeError` for bad ones);
4. ``register("mine", order, summary, _mine, _pack_mine, light=Parameter(...), ...)``.

Nothing is placed by offset: ``Layout.pack`` builds the vector and ``Layout.read`` gives the
formula each field by name; Dr.Jit still receives each number as an opaque value.  The docs'
list of functions (docs/reference/generated/shape_functions.rst) is made from the registry.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError, show
from ..geometry.core.differential import (
    first_form,
    fundamental_forms,
    gaussian_from_forms,
    mean_from_forms,
    principal_half_gap,
)
from ..geometry.core.jets import arccos, arctan2, cross, dot, jabs, sqrt
from .kernels import Formula, Layout
from .registry import (
    SHAPE_FUNCTIONS,
    Bands,
    Parameter,
    ShapeFunction,
    ShapeValues,
    checked_parameters,
    evaluate,
    function_bands,
    function_period,
    get_shape_function,
    register,
    validate_parameter,
    validate_parameters,
)

if TYPE_CHECKING:
    from types import SimpleNamespace

    from ..geometry.core.jets import Backend, Jet
    from .registry import Packed

__all__ = [
    "SHAPE_FUNCTIONS",
    "Bands",
    "Parameter",
    "ShapeFunction",
    "ShapeValues",
    "checked_parameters",
    "evaluate",
    "function_bands",
    "function_period",
    "get_shape_function",
    "validate_parameter",
    "validate_parameters",
]

# --------------------------------------------------------------------------- light-line frames


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


# --------------------------------------------------------------------------- planar sections

_PLANAR = Layout(("direction", 3))


def _planar_sections(
    vec: Callable[[int, int], Any], p: SimpleNamespace, form: str, xp: Backend
) -> tuple[Jet, Any, Any]:
    return dot(vec(0, 0), p.direction), None, None


def _pack_planar(fn: str, kw: dict[str, Any]) -> Packed:
    return "", _PLANAR, {"direction": kw["direction"]}


register(
    "planar_sections",
    0,
    "f = <p, v>: sections by the planes perpendicular to v (contour lines)",
    _planar_sections,
    _pack_planar,
    direction=Parameter("direction", (0.0, 0.0, 1.0), "normal v of the section planes"),
)

# --------------------------------------------------------------------------- isophotes

_ISOPHOTES = Layout(("light", 3))


def _isophotes(
    vec: Callable[[int, int], Any], p: SimpleNamespace, form: str, xp: Backend
) -> tuple[Jet, Any, Any]:
    N = cross(vec(1, 0), vec(0, 1))
    length = sqrt(dot(N, N), xp)
    f = dot(N, p.light) / length
    return (arccos(f, xp) if form == "angle" else f), length.f > p.irregular, None


def _pack_isophotes(fn: str, kw: dict[str, Any]) -> Packed:
    return kw["form"], _ISOPHOTES, {"light": kw["light"]}


register(
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


def _reflection_lines(
    vec: Callable[[int, int], Any], p: SimpleNamespace, form: str, xp: Backend
) -> tuple[Jet, Any, Any]:
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


def _pack_reflection(fn: str, kw: dict[str, Any]) -> Packed:
    if kw["form"] == "plane":
        c = _frame(fn, kw["a1"], kw["a2"])
        values = {"eye": kw["eye_point"], "origin": kw["origin"], "a2": kw["a2"], "c": c}
        return "plane", _REFLECTION_PLANE, values
    a, w = kw["axis"], kw["reference"]
    if w is None:
        w = _perpendicular(a)
    given = w
    w = w - np.dot(w, a) * a
    if np.linalg.norm(w) < 1e-9:
        raise GshadeError(
            f"{fn}: reference: expected a direction not parallel to axis {a.tolist()}, "
            f"got {given.tolist()}"
        )
    w = w / np.linalg.norm(w)
    values = {"eye": kw["eye_point"], "across": np.cross(a, w), "reference": w}
    return "infinity", _REFLECTION_INFINITY, values


register(
    "reflection_lines",
    1,
    "reflections of light lines seen from the eye: lines in a plane (Kiciak: f = s of the hit "
    "point p0 + s a1 + t a2, undefined where the reflected ray misses the plane) or lines at "
    "infinity parallel to an axis (zebra: f = angle of r about the axis)",
    _reflection_lines,
    _pack_reflection,
    eye=True,
    period=lambda kw: 2 * np.pi if kw["form"] == "infinity" else None,
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


def _highlight_lines(
    vec: Callable[[int, int], Any], p: SimpleNamespace, form: str, xp: Backend
) -> tuple[Jet, Any, Any]:
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


def _pack_highlight(fn: str, kw: dict[str, Any]) -> Packed:
    if kw["form"] == "plane":
        c = _frame(fn, kw["a1"], kw["a2"])
        values = {"origin": kw["origin"], "a2": kw["a2"], "c": c, "c_norm": np.linalg.norm(c)}
        return "plane", _HIGHLIGHT_PLANE, values
    values = {"origin": kw["origin"], "direction": kw["a2"] / np.linalg.norm(kw["a2"])}
    return "distance", _HIGHLIGHT_DISTANCE, values


register(
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


def _parametrisation_quality(
    vec: Callable[[int, int], Any], p: SimpleNamespace, form: str, xp: Backend
) -> tuple[Jet, Any, Any]:
    E, F, G = first_form(vec(1, 0), vec(0, 1))
    s = E + G
    dEG = E - G
    return (dEG * dEG + 4.0 * (F * F)) / (s * s), s.f > 0.0, None


register(
    "parametrisation_quality",
    1,
    "q = ((E - G)^2 + 4F^2) / (E + G)^2: 0 where the parametrisation is conformal",
    _parametrisation_quality,
)

# --------------------------------------------------------------------------- curvatures


def _curvature(which: str) -> Formula:
    def formula(
        vec: Callable[[int, int], Any], p: SimpleNamespace, form: str, xp: Backend
    ) -> tuple[Jet, Any, Any]:
        """K, H and k1,2 = H +- (k1 - k2) / 2 of the forms w.r.t. N = p_u x p_v
        (:mod:`gshade.geometry.core.differential`); rms = sqrt(2 H^2 - K)."""
        f = fundamental_forms(vec(1, 0), vec(0, 1), vec(2, 0), vec(1, 1), vec(0, 2))
        valid = f.W2.f > p.irregular * p.irregular
        if which == "gaussian":
            return gaussian_from_forms(f), valid, None
        H = mean_from_forms(f, sqrt(f.W2, xp))
        if which == "mean":
            return H, valid, None
        if which == "rms":
            return sqrt(2.0 * (H * H) - gaussian_from_forms(f), xp), valid, None
        root = principal_half_gap(f, lambda x: sqrt(x, xp))
        if which == "max_principal":
            return H + root, valid, None
        if which == "min_principal":
            return H - root, valid, None
        return jabs(H + root, xp) + jabs(H - root, xp), valid, None  # absolute

    return formula


#: the sign of K: hyperbolic (saddle) points, elliptic or flat ones
GAUSSIAN_COLOURS = ((0.30, 0.45, 0.85), (0.93, 0.62, 0.25))


def _gaussian_bands(kw: dict[str, Any]) -> Bands:
    """The sign of K in two tones, the parabolic lines (K = 0) drawn over them; K exactly 0
    (a plane, a cylinder: one colour) lies in the band above."""
    names = ("hyperbolic (K < 0)", "elliptic or flat (K >= 0)")
    return Bands((0.0,), names, GAUSSIAN_COLOURS, lines=(0.0,))


register(
    "gaussian",
    2,
    "Gaussian curvature K = k1 k2",
    _curvature("gaussian"),
    signed=True,
    bands=_gaussian_bands,
)
register(
    "mean",
    2,
    "mean curvature H = (k1 + k2) / 2, signed w.r.t. n = p_u x p_v",
    _curvature("mean"),
    signed=True,
)
register(
    "max_principal",
    2,
    "the larger principal curvature k1 = H + sqrt(H^2 - K)",
    _curvature("max_principal"),
    signed=True,
)
register(
    "min_principal",
    2,
    "the smaller principal curvature k2 = H - sqrt(H^2 - K)",
    _curvature("min_principal"),
    signed=True,
)
register("absolute", 2, "absolute curvature |k1| + |k2|", _curvature("absolute"))
register(
    "rms",
    2,
    "root mean square curvature sqrt((k1^2 + k2^2) / 2) = sqrt(2H^2 - K)",
    _curvature("rms"),
)

# --------------------------------------------------------------------------- draft angle

_DRAFT = Layout(("direction", 3))
DEGREES = 180.0 / np.pi


def _draft_angle(
    vec: Callable[[int, int], Any], p: SimpleNamespace, form: str, xp: Backend
) -> tuple[Jet, Any, Any]:
    """delta = atan2(<N, d>, |N x d|) in degrees: arcsin <n, d> without arcsin's loss of
    accuracy (and infinite slope) where n is nearly d."""
    N = cross(vec(1, 0), vec(0, 1))
    across = cross(N, p.direction)
    delta = arctan2(dot(N, p.direction), sqrt(dot(across, across), xp), xp)
    return delta * DEGREES, dot(N, N).f > p.irregular * p.irregular, None


def _pack_draft(fn: str, kw: dict[str, Any]) -> Packed:
    if not 0.0 <= kw["min_angle"] < 90.0:
        raise GshadeError(
            f"{fn}: min_angle: expected degrees in [0, 90), got {show(kw['min_angle'])}"
        )
    return "", _DRAFT, {"direction": kw["direction"]}


#: Draft bands (the colours of mould-design tools): undercut, too little draft, enough
DRAFT_COLOURS = ((0.86, 0.16, 0.12), (0.98, 0.80, 0.12), (0.22, 0.66, 0.28))


def _draft_bands(kw: dict[str, Any]) -> Bands:
    """Undercut below 0, too little in [0, min_angle), enough from min_angle; the parting
    line at 0.  (min_angle 0: no band of too little.)"""
    if kw["min_angle"] == 0.0:
        return Bands((0.0,), ("undercut", "draft"), DRAFT_COLOURS[::2], lines=(0.0,))
    names = ("undercut", "too little draft", "enough draft")
    return Bands((0.0, float(kw["min_angle"])), names, DRAFT_COLOURS, lines=(0.0,))


register(
    "draft_angle",
    1,
    "draft angle delta = arcsin <n, d> in degrees, for the pull direction d: 0 where the "
    "surface is parallel to d (the parting line), positive where n leans along d (it can "
    "be pulled), negative = undercut",
    _draft_angle,
    _pack_draft,
    signed=True,
    bands=_draft_bands,
    direction=Parameter("direction", (0.0, 0.0, 1.0), "pull direction d"),
    min_angle=Parameter("number", 1.0, "the least draft (degrees) the bands accept"),
)

# --------------------------------------------------------------------------- radius limits

_RADIUS = Layout()


def _largest_curvature(
    vec: Callable[[int, int], Any], p: SimpleNamespace, form: str, xp: Backend
) -> tuple[Jet, Any, Any]:
    """k = H + sign(H) (k1 - k2) / 2: the principal curvature of largest magnitude, 1 / the
    smallest radius (signed as H; sign(0) = +1)."""
    f = fundamental_forms(vec(1, 0), vec(0, 1), vec(2, 0), vec(1, 1), vec(0, 2))
    valid = f.W2.f > p.irregular * p.irregular
    H = mean_from_forms(f, sqrt(f.W2, xp))
    root = principal_half_gap(f, lambda x: sqrt(x, xp))
    return H + root * xp.select(H.f < 0.0, -1.0, 1.0), valid, None


def _pack_radius(fn: str, kw: dict[str, Any]) -> Packed:
    if not (np.isfinite(kw["limit"]) and kw["limit"] > 0.0):
        raise GshadeError(f"{fn}: limit: expected a positive length, got {show(kw['limit'])}")
    return "", _RADIUS, {}


#: Radius bands: below the limit curving away from n (convex for an outward n), at or
#: above the limit, below the limit curving towards n (concave)
RADIUS_COLOURS = ((0.84, 0.19, 0.15), (0.86, 0.86, 0.84), (0.17, 0.40, 0.80))


def _radius_bands(kw: dict[str, Any]) -> Bands:
    """|k| > 1 / limit: below the radius limit, on the side the sign of k tells (a radius
    equal to the limit is within it)."""
    k = 1.0 / float(kw["limit"])
    names = ("convex below limit", "within limit", "concave below limit")
    return Bands((-k, k), names, RADIUS_COLOURS, closed_above=(1,))


register(
    "min_radius",
    2,
    "k = the principal curvature of largest magnitude, 1 / the smallest radius of curvature "
    "(signed as mean: negative where the surface curves away from n, convex for an outward "
    "n); bands against the radius limit",
    _largest_curvature,
    _pack_radius,
    signed=True,
    bands=_radius_bands,
    limit=Parameter("number", 1.0, "the radius limit (model length units): a tool radius"),
)

# --------------------------------------------------------------------------- environment

_NO_LAYOUT = Layout()

#: The built-in environment's name (gshade's studio, :func:`gshade.rendering.lightbox`).
LIGHTBOX = "lightbox"
#: The lightbox's strips (fewest, most) and their width's bounds in degrees (open).
LIGHTBOX_STRIPS, LIGHTBOX_STRIP_WIDTH = (1, 64), (0.0, 90.0)
#: The glossy conductor's roughness (GGX alpha): 0 is a mirror.
MAX_ROUGHNESS = 1.0


def _pack_environment(fn: str, kw: dict[str, Any]) -> Packed:
    """The environment's parameters checked (it has no formula: the renderer draws it)."""
    strips = kw["strips"]
    lo, hi = LIGHTBOX_STRIPS
    if not (float(strips).is_integer() and lo <= strips <= hi):
        raise GshadeError(f"{fn}: strips: expected an integer in [{lo}, {hi}], got {show(strips)}")
    lo_w, hi_w = LIGHTBOX_STRIP_WIDTH
    if not lo_w < kw["strip_width"] < hi_w:
        raise GshadeError(
            f"{fn}: strip_width: expected degrees in ({lo_w:g}, {hi_w:g}), "
            f"got {show(kw['strip_width'])}"
        )
    if not np.isfinite(kw["rotation"]):
        raise GshadeError(f"{fn}: rotation: expected finite degrees, got {show(kw['rotation'])}")
    if not 0.0 <= kw["roughness"] <= MAX_ROUGHNESS:
        raise GshadeError(
            f"{fn}: roughness: expected a number in [0, {MAX_ROUGHNESS:g}] (0: a mirror), "
            f"got {show(kw['roughness'])}"
        )
    return "", _NO_LAYOUT, {}


register(
    "environment",
    1,
    "the surface as a mirror (roughness > 0: a glossy conductor) reflecting an environment "
    "map seen from the camera: r = v - 2 <v, n> n (v the view ray, n the exact unit normal) "
    "reads the map at column atan2(r_y, r_x) / 2 pi W and row acos(r_z) / pi H; f = the "
    "luminance reflected",
    None,
    _pack_environment,
    eye=True,
    map=Parameter(
        "file",
        LIGHTBOX,
        'the environment: "lightbox" (gshade\'s studio of strip lights over a soft floor) or '
        "a latitude-longitude map, OpenEXR or Radiance HDR (its path relative to the scene "
        "file)",
        (LIGHTBOX,),
    ),
    rotation=Parameter("number", 0.0, "degrees the map is turned about world +z (up)"),
    roughness=Parameter(
        "number", 0.0, "0: a mirror; up to 1: a glossy conductor of this GGX roughness alpha"
    ),
    strips=Parameter("number", 5, "lightbox: the number of strip lights overhead (1 to 64)"),
    strip_width=Parameter("number", 8.0, "lightbox: each strip's width in degrees"),
)
