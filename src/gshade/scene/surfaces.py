"""The ``[[surface]]`` types: a registry of builders, one a type, each declared with the
keys it accepts (what each takes, its default, what it means).

A builder gets its surface's table (a :class:`~gshade.scene.tables.Table` whose getters
default to the declared defaults) and the :class:`DataFiles` its ``file`` key may name,
and returns the surface's patches.  The registry's order is :data:`SURFACE_TYPES`, the
order messages list the types in; the types read from meshes and CAD models are in
:mod:`.mesh_and_cad_surfaces`.  The readers of data files (``gshade.io``) are imported when
first used: ``gshade.io`` re-exports this package.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import GshadeError
from ..geometry import (
    BetaSplinePatch,
    BezierCurve,
    BezierPatch,
    BSplinePatch,
    CoonsPatch,
    Patch,
    cylinder,
    sphere,
    torus,
)
from ..geometry.splines.gammaspline import GammaSplinePatch
from ..geometry.splines.junctions import CLASSES, junction_patch
from ..geometry.splines.nuspline import ENDS as NU_ENDS
from ..geometry.splines.nuspline import NuSplinePatch
from ..limits import MAX_DEGREE
from .data_files import DataFiles
from .model import CadFaces, Surface
from .tables import (
    REQUIRED,
    Key,
    Table,
    alternatives,
    declare_keys,
    is_int,
    is_number,
    one_of,
    show,
    suggest,
)

__all__ = ["SURFACES", "SURFACE_TYPES", "TYPE_KEY", "SurfaceType", "build_surface"]

NEWELL_UP = ("z", "y", "x")


@dataclass(frozen=True)
class SurfaceType:
    """A ``[[surface]]`` type: what it makes, the keys it takes besides ``type``, and the
    function that builds its patches from its table."""

    name: str
    description: str
    keys: dict[str, Key]
    #: the patches, or (for ``cad``) the patches and what the render meshes them from
    build: Callable[[Table, DataFiles], list[Patch] | tuple[list[Patch], CadFaces]]


#: The surface types by name, in the order they are registered (and listed).
SURFACES: dict[str, SurfaceType] = {}


def surface_type(name: str, description: str, *keys: Key) -> Callable:
    """Register the decorated function as the builder of the surface type ``name``."""

    def register(build: Callable[..., Any]) -> Callable:
        SURFACES[name] = SurfaceType(name, description, declare_keys(*keys), build)
        return build

    return register


# --------------------------------------------------------------------------- value helpers

_NET = ("(m+1) rows of n+1 points [x, y, z]", "a row of points [x, y, z]", "a point [x, y, z]")
_WEIGHTS = ("(m+1) rows of n+1 positive numbers", "a row of positive numbers")
_CURVE = ("a list of Bézier control points [x, y, z]", "a point [x, y, z]")


def _bezier_net(t: Table, key: str, levels: Sequence[str] = _NET) -> np.ndarray:
    """A Bézier control net (or, with ``_CURVE`` levels, polygon) of degree at most
    ``MAX_DEGREE`` in each direction."""
    points = t.array(key, levels, 3)
    degree = max(points.shape[:-1]) - 1
    if degree > MAX_DEGREE:
        raise t.error(
            key,
            f"expected at most {MAX_DEGREE + 1} points per row and column (degree "
            f"{MAX_DEGREE}), got degree {degree}",
        )
    return points


def _weights(t: Table) -> np.ndarray | None:
    return t.array("weights", _WEIGHTS) if "weights" in t.data else None


def _number_or_list(t: Table, key: str, what: str) -> Any:
    """A number (one value for all) or a list of numbers (``what`` says what each is for,
    in messages); absent: the default.  Their bounds and count are the patch's to check."""
    expected = f"a number or a list of numbers ({what})"
    x = t.raw(key, expected=expected)
    if x is None:
        return None

    def ok(v: Any) -> bool:
        return is_number(v) and math.isfinite(v)

    if ok(x):
        return float(x)
    if isinstance(x, list) and all(ok(v) for v in x):
        return [float(v) for v in x]
    raise t.error(key, f"expected {expected}, got {show(x)}")


# --------------------------------------------------------------------------- the types

_POINTS = Key("points", "(m+1) rows of n+1 points [x, y, z]", REQUIRED, "the control net")
_RATIONAL = Key("weights", "(m+1) rows of n+1 numbers > 0", None, "rational weights", "all 1")


@surface_type(
    "newell",
    "bicubic Bézier patches from a file in Newell's format (the Utah teapot's)",
    Key("file", "path", REQUIRED, "the data file, relative to the scene file"),
    Key("up", alternatives(NEWELL_UP), "z", "the data's up axis"),
)
def _build_newell(t: Table, files: DataFiles) -> list[Patch]:
    from ..io.newell import read_newell

    name = t.string("file", expected="a path to a file in Newell's format")
    up = t.choice("up", NEWELL_UP)
    data_file = files.find(t, name)
    with t.reported():
        return list(read_newell(data_file, up=up))


@surface_type(
    "bezier",
    "one Bézier patch, rational if weights are given",
    Key("points", f"{_POINTS.accepts}, degree ≤ {MAX_DEGREE}", REQUIRED, "the control net"),
    _RATIONAL,
)
def _build_bezier(t: Table, files: DataFiles) -> list[Patch]:
    points = _bezier_net(t, "points")
    weights = _weights(t)
    with t.reported():
        return [BezierPatch(points, weights)]


@surface_type(
    "bspline",
    "one B-spline patch, rational (NURBS) if weights are given",
    Key("degree", f"[p, q], integers 1–{MAX_DEGREE}", REQUIRED, "the degrees in u and v"),
    Key("knots_u", "rows + p + 1 numbers", REQUIRED, "the knot vector in u"),
    Key("knots_v", "points per row + q + 1 numbers", REQUIRED, "the knot vector in v"),
    _POINTS,
    _RATIONAL,
)
def _build_bspline(t: Table, files: DataFiles) -> list[Patch]:
    degree = t.raw("degree", expected="[p, q], two integers >= 1")
    if not (
        isinstance(degree, list)
        and len(degree) == 2
        and all(is_int(d) and 1 <= d <= MAX_DEGREE for d in degree)
    ):
        raise t.error(
            "degree",
            f"expected [p, q], two integers from 1 to {MAX_DEGREE}, got {show(degree)}",
        )
    knots = [
        t.array(k, (f"a list of knots ({d}: number of points + degree + 1 numbers)",))
        for k, d in (("knots_u", "u"), ("knots_v", "v"))
    ]
    points = t.array("points", _NET, 3)
    weights = _weights(t)
    with t.reported():
        return [BSplinePatch(points, tuple(degree), tuple(knots), weights)]


_BOUNDARY = "[[x, y, z], …] (Bézier points)"
_CROSS = "none: bilinear"


@surface_type(
    "coons",
    "a Coons patch of four Bézier boundary curves (bicubic with cross-boundary derivatives)",
    Key("v0", _BOUNDARY, REQUIRED, "the boundary p(u, 0)"),
    Key("v1", _BOUNDARY, REQUIRED, "the boundary p(u, 1)"),
    Key("u0", _BOUNDARY, REQUIRED, "the boundary p(0, v)"),
    Key("u1", _BOUNDARY, REQUIRED, "the boundary p(1, v)"),
    Key("cross_v0", _BOUNDARY, None, "the cross-boundary derivative p_v(u, 0)", _CROSS),
    Key("cross_v1", _BOUNDARY, None, "the cross-boundary derivative p_v(u, 1)", _CROSS),
    Key("cross_u0", _BOUNDARY, None, "the cross-boundary derivative p_u(0, v)", _CROSS),
    Key("cross_u1", _BOUNDARY, None, "the cross-boundary derivative p_u(1, v)", _CROSS),
)
def _build_coons(t: Table, files: DataFiles) -> list[Patch]:
    curves: dict[str, BezierCurve] = {}
    for key, declared in t.keys.items():
        if declared.default is REQUIRED or key in t.data:
            points = _bezier_net(t, key, _CURVE)
            with t.reported(key):
                curves[key] = BezierCurve(points)
    with t.reported():
        return [
            CoonsPatch(
                curves["v0"],
                curves["v1"],
                curves["u0"],
                curves["u1"],
                cross_v0=curves.get("cross_v0"),
                cross_v1=curves.get("cross_v1"),
                cross_u0=curves.get("cross_u0"),
                cross_u1=curves.get("cross_u1"),
            )
        ]


def _solid(make: Callable[..., Patch]) -> Callable[[Table, DataFiles], list[Patch]]:
    """The builder of an exact solid: ``make`` given the declared keys' numbers (> 0)."""

    def build(t: Table, files: DataFiles) -> list[Patch]:
        sizes = [t.number(key, lo=0) for key in t.keys]
        with t.reported():
            return [make(*sizes)]

    return build


#: The exact solids: name, patch function, what it is, the keys (its arguments, in order).
_SOLIDS = (
    ("sphere", sphere, "a sphere about the origin", Key("radius", "number > 0", 1.0, "the radius")),
    (
        "torus",
        torus,
        "a torus about the z axis",
        Key("major", "number > minor", 2.0, "the radius of the tube's centre circle, in z = 0"),
        Key("minor", "number > 0", 0.5, "the tube's radius"),
    ),
    (
        "cylinder",
        cylinder,
        "a cylinder about the z axis, 0 ≤ z ≤ height, without caps",
        Key("radius", "number > 0", 1.0, "the radius"),
        Key("height", "number > 0", 1.0, "the height"),
    ),
)
for _name, _make, _description, *_keys in _SOLIDS:
    surface_type(_name, f"{_description} (exact rational NURBS)", *_keys)(_solid(_make))


#: What one knot line in u or v is, in a grid of points.
_ROWS = {"u": "rows", "v": "points per row"}


def _per_junction(direction: str, k: int) -> Key:
    """``beta1_u``, ..., ``beta2_v``: β1 or β2 in one direction, per junction."""
    bound = "> 0" if k == 1 else "≥ 0"
    accepts = f"number {bound}, or one per interior junction ({_ROWS[direction]} − 4)"
    what = "bias" if k == 1 else "tension"
    return Key(f"beta{k}_{direction}", accepts, None, f"the {what} in {direction}", f"beta{k}")


@surface_type(
    "betaspline",
    "a cubic β-spline surface (G2, with bias β1 and tension β2)",
    Key("points", "at least 4 rows of at least 4 points [x, y, z]", REQUIRED, "the control net"),
    Key("beta1", "number > 0", 1.0, "the bias (1: a uniform B-spline)"),
    Key("beta2", "number ≥ 0", 0.0, "the tension"),
    *(_per_junction(direction, k) for direction in "uv" for k in (1, 2)),
)
def _build_betaspline(t: Table, files: DataFiles) -> list[Patch]:
    # the net's size and the values' bounds are BetaSplinePatch's to check
    points = t.array("points", _NET, 3)
    beta1 = t.number("beta1")
    beta2 = t.number("beta2")
    per_direction = {}
    for d, rows in (("u", points.shape[0]), ("v", points.shape[1])):
        what = f"one per interior junction in {d}: {_ROWS[d]} ({rows}) - 4"
        for key in (f"beta1_{d}", f"beta2_{d}"):
            per_direction[key] = _number_or_list(t, key, what)
    with t.reported():
        return [BetaSplinePatch(points, beta1, beta2, **per_direction)]


@surface_type(
    "gammaspline",
    "a bicubic γ-spline surface (Boehm's G2 splines in B-spline form, with shape parameters γ)",
    Key("points", "at least 4 rows of at least 4 points [x, y, z]", REQUIRED, "the control net"),
    Key("gamma", "number > 0", 1.0, "the shape parameter (1: a cubic B-spline)"),
    *(
        Key(
            f"gamma_{d}",
            f"number > 0, or one per interior junction ({_ROWS[d]} − 4)",
            None,
            f"the shape parameters in {d}",
            "gamma",
        )
        for d in "uv"
    ),
    *(
        Key(
            f"knots_{d}",
            f"{_ROWS[d]} + 4 strictly increasing numbers",
            None,
            f"the B-spline knot vector in {d}",
            "−3, −2, …",
        )
        for d in "uv"
    ),
)
def _build_gammaspline(t: Table, files: DataFiles) -> list[Patch]:
    # the net's size, the values' bounds and the knots' count and order are
    # GammaSplinePatch's to check
    points = t.array("points", _NET, 3)
    given: dict[str, Any] = {}
    for k, d in enumerate("uv"):
        count, rows = points.shape[k], _ROWS[d]
        what = f"one per interior junction in {d}: {rows} ({count}) - 4"
        given[f"gamma_{d}"] = _number_or_list(t, f"gamma_{d}", what)
        if f"knots_{d}" in t.data:
            expected = f"a list of {count + 4} strictly increasing knots ({count} {rows} + 4)"
            given[f"knots_{d}"] = t.array(f"knots_{d}", (expected,))
    with t.reported():
        return [GammaSplinePatch(points, t.number("gamma"), **given)]


@surface_type(
    "nuspline",
    "a bicubic ν-spline surface interpolating a grid of points (G2, with tensions ν)",
    Key("points", "rows of points [x, y, z]", REQUIRED, "the grid to interpolate"),
    *(
        Key(f"nu_{d}", f"number ≥ 0, or one per knot ({_ROWS[d]})", 0.0, f"the tensions in {d}")
        for d in "uv"
    ),
    *(
        Key(
            f"knots_{d}",
            f"{_ROWS[d]} (+ 1 if closed) increasing numbers",
            None,
            f"the knots in {d}",
            "0, 1, 2, …",
        )
        for d in "uv"
    ),
    Key(
        "ends",
        f"{alternatives(NU_ENDS)}, or a pair [u, v] of them",
        "natural",
        "the end conditions",
    ),
)
def _build_nuspline(t: Table, files: DataFiles) -> list[Patch]:
    # the names of the ends, the knots' count and order and the tensions' count and bounds
    # are NuSplinePatch's to check
    points = t.array("points", _NET, 3)
    ends = t.raw("ends")
    if not (
        isinstance(ends, str)
        or (isinstance(ends, list) and len(ends) == 2 and all(isinstance(e, str) for e in ends))
    ):
        raise t.error(
            "ends",
            f"expected one of {one_of(NU_ENDS)} or a pair [u, v] of them, got {show(ends)}",
        )
    closed = [e == "closed" for e in ([ends] * 2 if isinstance(ends, str) else ends)]
    given: dict[str, Any] = {"ends": tuple(ends) if isinstance(ends, list) else ends}
    for k, d in enumerate("uv"):
        count = points.shape[k]
        rows = _ROWS[d]
        if f"knots_{d}" in t.data:
            wrap = " + 1, closed" if closed[k] else ""
            expected = f"a list of {count + closed[k]} increasing knots ({count} {rows}{wrap})"
            given[f"knots_{d}"] = t.array(f"knots_{d}", (expected,))
        given[f"nu_{d}"] = _number_or_list(t, f"nu_{d}", f"one per knot: {count} {rows}")
    with t.reported():
        return [NuSplinePatch(points, **given)]


def _connection(key: str, default: float, junctions: str) -> Key:
    return Key(key, "number", default, f"connection parameter of {junctions} junctions")


@surface_type(
    "junction",
    "a Bézier patch and a second one meeting it along v = 1 with the given continuity",
    Key("points", f"{_POINTS.accepts}, degree ≤ {MAX_DEGREE}", REQUIRED, "the first patch"),
    Key("continuity", alternatives(CLASSES), REQUIRED, "the junction's class"),
    _connection("alpha", 0.0, "G1–G3"),
    Key("beta", "number > 0", 1.0, "connection parameter of G1–G3 junctions"),
    _connection("gamma", 0.0, "G2, G3"),
    _connection("delta", 0.0, "G2, G3"),
    _connection("epsilon", 0.0, "G3"),
    _connection("zeta", 0.0, "G3"),
)
def _build_junction(t: Table, files: DataFiles) -> list[Patch]:
    points = _bezier_net(t, "points")
    # the class, and beta > 0, are junction_patch's to check
    continuity = t.string("continuity", expected=f"one of {one_of(CLASSES)}")
    names = ("alpha", "beta", "gamma", "delta", "epsilon", "zeta")
    connection = {key: t.number(key) for key in names}
    with t.reported():
        first = BezierPatch(points)
        return [first, junction_patch(first, continuity, **connection)]


# the types read from meshes and CAD models (subdivision, hole, cad), registered here so
# that the listing keeps its order
from . import mesh_and_cad_surfaces  # noqa: E402, F401

#: The surface types, in the order messages list them.
SURFACE_TYPES = tuple(SURFACES)
#: The key every surface has.
TYPE_KEY = Key("type", "a type below", REQUIRED, "the kind of surface")


def build_surface(
    file: str, index: int, raw: Any, base: Path, roots: Sequence[Path]
) -> tuple[Surface, Path | None]:
    """The ``index``-th (1-based) ``[[surface]]`` of ``file`` and the data file it read."""
    head = f"[[surface]] {index}"
    if not isinstance(raw, dict):
        raise GshadeError(f"{file}: {head}: expected a table, got {show(raw)}")
    kind = raw.get("type", REQUIRED)
    if kind is REQUIRED:
        raise GshadeError(f"{file}: {head}: type: missing; expected one of {one_of(SURFACE_TYPES)}")
    if kind not in SURFACE_TYPES or not isinstance(kind, str):
        hint = suggest(kind, SURFACE_TYPES) if isinstance(kind, str) else ""
        raise GshadeError(
            f"{file}: {head}: type: expected one of {one_of(SURFACE_TYPES)}, got {show(kind)}{hint}"
        )
    spec = SURFACES[kind]
    t = Table(file, f"{head} ({kind}): ", raw, spec.keys)
    t.reject_unknown(("type", *spec.keys))
    files = DataFiles(base, roots)
    built = spec.build(t, files)
    patches, cad = built if isinstance(built, tuple) else (built, None)
    return Surface(kind, tuple(patches), f"{file}: {head} ({kind})", cad), files.used
