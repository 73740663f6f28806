"""How a render shows f: which functions, the colour range, the stripe period, the colour
map, and the legend that says so.

The stripes' period is ``period``, or the span of the striped function over the atlas divided
by ``stripes``, moved a little where that would put a constant region's value on a stripe
edge (:func:`period_off_edges`); the colour range is ``range``, or robust percentiles of the
colour-mapped function (symmetric about 0 for signed functions), see
:func:`gshade.display.auto_range`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..display import Legend, auto_range, validate_range
from ..display.bands import band_text
from ..display.colour import edge_offset
from ..display.colour_maps import colour_map_table
from ..scene.model import Shape
from ..shape import SHAPE_FUNCTIONS, Bands, ShapeFunction, function_bands, get_shape_function
from .atlas import Atlas
from .reflections import normal_functions
from .textures import ShapeTextures, texel_areas

__all__ = [
    "UNITS",
    "DisplayStyle",
    "constant_values",
    "display_style",
    "legend",
    "period_off_edges",
    "shape_functions",
]

#: Units of each function's values, for legends.
UNITS = {
    "planar_sections": "length",
    "gaussian": "1/length²",
    "parametrisation_quality": "",
    "draft_angle": "deg",
}


def _units(function: str, params: dict) -> str:
    if function in UNITS:
        return UNITS[function]
    if SHAPE_FUNCTIONS[function].order == 2:
        return "1/length"
    if function == "isophotes":
        return "rad" if params.get("form") == "angle" else ""
    if function == "reflection_lines" and params.get("form") == "infinity":
        return "rad"
    return "length"


def shape_functions(shape: Shape) -> tuple[list[tuple[ShapeFunction, dict]], str]:
    """The functions to evaluate with their parameters (the striped or primary one first,
    then for ``display = "both"`` the colour-mapped one) and the colour-mapped one's name;
    for a reflection, the unit normal's components it is drawn from
    (:func:`gshade.rendering.reflections.normal_functions`)."""
    if get_shape_function(shape.function).reflection:
        return normal_functions(), shape.function
    functions = [(get_shape_function(shape.function), shape.params_for(shape.function))]
    mapped = shape.function
    if shape.display == "both":
        mapped = shape.colour_function or shape.function
        functions.append((get_shape_function(mapped), shape.params_for(mapped)))
    return functions, mapped


@dataclass(frozen=True)
class DisplayStyle:
    """The colour-mapped function ``mapped`` (``signed`` or not) over ``value_range``, with
    ``colormap`` and its linear-RGB table ``lut`` (None for stripes alone), the stripe
    ``period`` in units of the striped function, and the function's ``bands`` for
    ``display = "bands"`` (else None)."""

    mapped: str
    signed: bool
    value_range: tuple[float, float]
    period: float
    colormap: str | None
    lut: np.ndarray | None
    bands: Bands | None = None


def trimmed_region(atlas: Atlas, patch: NDArray, params: NDArray, trimmed: NDArray) -> NDArray:
    """The texels that lie on the surface: every texel of an untrimmed patch's tile, and of
    a trimmed patch (``trimmed[k]``: a CAD face, whose tile covers its parameter box) the
    texels around the mesh's vertices (``patch``, ``params`` = (s, t)), which lie in the
    trimmed region."""
    region = np.zeros((atlas.height, atlas.width), dtype=bool)
    for k in np.flatnonzero(~trimmed):
        rows, cols = atlas.tile_slices(int(k))
        region[rows, cols] = True
    on = trimmed[patch]
    x, y = atlas.texel_positions(patch[on], params[on])
    for row in (np.floor(y), np.ceil(y)):
        for col in (np.floor(x), np.ceil(x)):
            region[row.astype(np.int64), col.astype(np.int64)] = True
    return region


def display_style(
    shape: Shape, mapped: str, tex: ShapeTextures, region: NDArray | None = None
) -> DisplayStyle:
    """The range, period and colour map of a scene's ``[shape]`` for its textures, from the
    texels in ``region`` (default: all; see :func:`trimmed_region`).  With a region (a scene
    with CAD faces), the range and the stripes' span are percentiles by surface area (1–99 %
    and 0.5–99.5 %; see :func:`_area_element`); otherwise the colour range is the 1–99 %
    percentiles of the texels and the stripes' span their whole range."""
    if get_shape_function(shape.function).reflection:  # it draws the map: no range, stripes
        return DisplayStyle(mapped, False, (0.0, 1.0), 1.0, None, None)
    valid = [v > 0 if region is None else (v > 0) & region for v in tex.valid]
    shown = 1 if shape.display == "both" else 0  # the colour-mapped function's textures
    cvals, cvalid = tex.values[shown][..., 0], valid[shown]
    signed = SHAPE_FUNCTIONS[mapped].signed
    area = None if region is None else _area_element(tex)
    value_range = (
        auto_range(cvals, cvalid, signed=signed, weights=area)
        if shape.value_range is None
        else validate_range(shape.value_range)
    )
    span = (0.0, 100.0) if area is None else (0.5, 99.5)
    f_lo, f_hi = auto_range(tex.values[0][..., 0], valid[0], percentiles=span, weights=area)
    period = shape.period
    if period is None:
        assert shape.stripes is not None  # a Shape holds exactly one of period and stripes
        flat = constant_values(tex.values[0][..., 0], valid[0], tex.atlas.all_tile_slices())
        period = period_off_edges((f_hi - f_lo) / shape.stripes, flat, shape.phase, shape.duty)
    lut = colormap = None
    if shape.display == "bands":
        bands = function_bands(shape.function, shape.params_for(shape.function))
        return DisplayStyle(mapped, signed, value_range, period, None, None, bands)
    if shape.display != "stripes":
        from ..display.colour import srgb_to_linear

        colormap = shape.colormap or ("coolwarm" if signed else "viridis")
        lut = srgb_to_linear(colour_map_table(colormap))
    return DisplayStyle(mapped, signed, value_range, period, colormap, lut)


#: The automatic period keeps constant values at least this far (in periods) from an edge,
#: moving by at most :data:`PERIOD_NUDGE` of itself.
EDGE_MARGIN = 0.1
PERIOD_NUDGE = 0.2


def constant_values(
    values: NDArray, valid: NDArray, tiles: Sequence[tuple[slice, slice]]
) -> NDArray[np.float64]:
    """The values of the tiles (patches, faces) on which f is constant: one value per atlas
    tile (``tiles``: its rows and columns, :meth:`gshade.rendering.atlas.Atlas.tile_slices`)
    whose valid texels (at least 4) all hold it (a plane under isophotes, a sphere under
    curvature ...; a cylinder's isophotes, constant only along its axis, are not).

    Examples
    --------
    >>> f = np.zeros((4, 8), np.float32)
    >>> f[:, :4] = 0.7  # the first 4 x 4 tile: constant
    >>> f[:, 4:] = np.linspace(0, 1, 4)  # the second: f varies across it
    >>> tiles = [(slice(0, 4), slice(0, 4)), (slice(0, 4), slice(4, 8))]
    >>> constant_values(f, np.ones((4, 8), bool), tiles).round(6).tolist()
    [0.7]
    """
    v = np.asarray(values, dtype=np.float32)
    ok = np.asarray(valid, dtype=bool)
    flat = []
    for tile in tiles:
        here = ok[tile]
        if np.count_nonzero(here) < 4:
            continue
        f = v[tile][here]
        if f.min() == f.max():
            flat.append(float(f[0]))
    return np.unique(np.asarray(flat, dtype=np.float64))


def period_off_edges(
    period: float, constant: NDArray, phase: float = 0.0, duty: float = 0.5
) -> float:
    """The automatic stripe period ``period``, or the nearest one within
    :data:`PERIOD_NUDGE` of it that keeps every ``constant`` value at least
    :data:`EDGE_MARGIN` periods from a stripe edge (the one keeping them farthest if none
    does): a plane is then well inside one stripe, not on an edge where round-off would
    pick its colour (the span's end, which sets the automatic period, would always be on
    one).  A value 0 is 0 periods whatever the period, and is left on its edge (one colour
    all the same: :func:`gshade.display.colour.settled_on_edges`).

    Examples
    --------
    >>> round(period_off_edges(0.1, np.array([0.7])), 6)  # 7 periods: on an edge; 6.90 with this
    0.1015
    >>> period_off_edges(0.1, np.array([0.725]))  # 7.25: mid-stripe already
    0.1
    """
    constant = np.asarray(constant, dtype=np.float64)
    # 0 is 0 periods whatever the period: it stays on its edge, where the renderer settles it
    constant = constant[np.abs(constant) > 1e-9 * abs(period)]
    if constant.size == 0 or not (np.isfinite(period) and period > 0):
        return period
    nudges = np.linspace(-PERIOD_NUDGE, PERIOD_NUDGE, 161)
    nudges = nudges[np.argsort(np.abs(nudges), kind="stable")]  # the smallest change first
    best, best_margin = period, -1.0
    for nudge in nudges:
        candidate = period * (1.0 + nudge)
        margin = float(np.abs(edge_offset(constant / candidate + phase, duty)).min())
        if margin >= EDGE_MARGIN:
            return float(candidate)
        if margin > best_margin:
            best, best_margin = float(candidate), margin
    return best


def _area_element(tex: ShapeTextures) -> NDArray | None:
    """|p_s x p_t| h_s h_t at each texel (h_s, h_t its tile's spacings): the surface area a
    texel stands for (None if all 0).

    CAD faces differ in size by orders of magnitude, and their tiles much less, so their
    ranges are taken by area: a sliver face's extreme curvature does not set them."""
    area = texel_areas(tex)
    return area if (area > 0).any() else None


def legend(shape: Shape, style: DisplayStyle, length: str = "length") -> Legend:
    """The legend of a render: the function, its colour map and range, its stripes; the
    units in terms of ``length``, the scene's length unit (e.g. ``"mm"``: 1/mm), where one
    is known."""
    fn = get_shape_function(shape.function)
    if fn.reflection:
        return Legend(function=fn.name, order=fn.order, display="reflection")
    units = _units(style.mapped, shape.params_for(style.mapped)).replace("length", length)
    striped = shape.display in ("stripes", "both")
    return Legend(
        function=shape.function,
        order=get_shape_function(shape.function).order,
        display=shape.display,
        value_range=style.value_range if shape.display in ("colormap", "both") else None,
        colormap=style.colormap,
        period=float(style.period) if striped else None,
        duty=shape.duty if striped else None,
        stripe_function=shape.function if shape.display == "both" else None,
        units=units,
        bands=None if style.bands is None else band_text(style.bands, units),
    )
