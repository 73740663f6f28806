"""Bands: a function's values shown as a few flat colours split at levels, with sharp lines.

``display = "bands"`` is how the analyses read (:class:`gshade.shape.registry.Bands`): draft
angle as undercut / too little / enough, the smallest radius as below the limit on either
side / within it, with the parting line drawn over them.  As for stripes, every colour is
box-filtered over the pixel's footprint: f's change across the pixel (``fx``, ``fy``), for
f linear in the pixel, gives the fraction of the pixel below a level t as the trapezoid
CDF at t - f (:func:`gshade.display.colour.trapezoid_cdf`), so band i's share is
``below(t_(i+1)) - below(t_i)``; a line of width w pixels at a level t covers the share
between t - h and t + h, h = w |grad f| / 2 (|grad f| the change across one pixel).

A value within round-off of a level (the renderer's single-precision textures) with a
footprint narrower still is put on the level (:data:`gshade.display.colour.SETTLE_ULPS`),
so that a face at exactly the level (a wall parallel to the pull direction: draft 0) is one
colour, not salt and pepper.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..runtime.backend import NUMPY_NAN, ArrayOps
from ..shape.registry import Bands
from .colour import DARK, SETTLE_ULPS, srgb_to_linear, trapezoid_cdf

__all__ = [
    "LINE_COLOUR",
    "LINE_WIDTH",
    "PARABOLIC_COLOUR",
    "PARABOLIC_LINES",
    "band_colours",
    "band_shares",
    "band_text",
    "settled_on_levels",
]

#: the width (pixels) and colour of the lines drawn over bands
LINE_WIDTH = 1.5
LINE_COLOUR = DARK
#: the parabolic lines (K = 0) as bands of K: one band (never drawn) and a line at 0; drawn
#: over any display in this colour (sRGB magenta: apart from stripes and colour maps)
PARABOLIC_LINES = Bands((), ("K",), ((0.0, 0.0, 0.0),), lines=(0.0,))
PARABOLIC_COLOUR = (1.0, 0.0, 0.75)


def _levels_scale(bands: Bands) -> float:
    levels = np.abs(np.asarray(bands.edges + bands.lines, dtype=np.float64))
    return float(levels.max()) if levels.size and levels.max() > 0 else 1.0


def settled_on_levels(
    f: Any, fx: Any, fy: Any, bands: Bands, ops: ArrayOps = NUMPY_NAN
) -> tuple[Any, Any, Any]:
    """f and its footprint (fx, fy) with f put exactly on a level (an edge or a line) and
    the footprint set to 0 where f lies within round-off of it (:data:`SETTLE_ULPS` ulps of
    a single-precision level, at least 2^-20 of the largest level) and the footprint is
    narrower still; elsewhere as they are."""
    floor = _levels_scale(bands) * 2.0**-20
    for t in sorted(set(bands.edges + bands.lines)):
        tol = max(abs(t) * SETTLE_ULPS * 2.0**-24, floor)
        settle = (ops.abs(f - t) <= tol) & ((ops.abs(fx) + ops.abs(fy)) <= tol)
        f = ops.select(settle, t + 0.0 * f, f)
        fx = ops.select(settle, 0.0 * fx, fx)
        fy = ops.select(settle, 0.0 * fy, fy)
    return f, fx, fy


def band_shares(
    f: Any, fx: Any, fy: Any, bands: Bands, spread: Any = 1.0, ops: ArrayOps = NUMPY_NAN
) -> tuple[list[Any], Any]:
    """Each band's share of the pixel and the lines' share, for f with its change across
    the footprint (``fx``, ``fy``; already settled, :func:`settled_on_levels`).

    ``spread``: the footprint's size in pixels (a renderer's sample covers 1/sqrt(spp) of
    the pixel's side): the lines keep their width in pixels.

    Examples
    --------
    >>> from gshade.shape.registry import Bands
    >>> b = Bands((0.0, 1.0), ("low", "mid", "high"), ((1, 0, 0), (0, 1, 0), (0, 0, 1)))
    >>> shares, line = band_shares(np.array([0.5, 1.0, 0.9]), np.array([0.0, 0.0, 0.4]), 0.0, b)
    >>> [np.round(s, 3).tolist() for s in shares], line.tolist()
    ([[0.0, 0.0, 0.0], [1.0, 0.0, 0.75], [0.0, 1.0, 0.25]], [0.0, 0.0, 0.0])
    """
    a = ops.maximum(ops.abs(fx), ops.abs(fy))
    b = ops.minimum(ops.abs(fx), ops.abs(fy))
    below = []
    for k, t in enumerate(bands.edges):
        if k in bands.closed_above:  # a value at t lies below it
            below.append(1.0 - trapezoid_cdf(f - t, a, b, ops))
        else:
            below.append(trapezoid_cdf(t - f, a, b, ops))
    cuts = [0.0 * f, *below, 1.0 + 0.0 * f]
    shares = [ops.maximum(cuts[i + 1] - cuts[i], 0.0) for i in range(len(bands.names))]
    line = 0.0 * f
    if bands.lines:
        h = (0.5 * LINE_WIDTH) * ops.sqrt(fx * fx + fy * fy) / spread
        for t in bands.lines:
            on = trapezoid_cdf(t + h - f, a, b, ops) - trapezoid_cdf(t - h - f, a, b, ops)
            line = ops.maximum(line, on)
    return shares, ops.clip(line, 0.0, 1.0)


def band_colours(
    f: ArrayLike, fx: ArrayLike, fy: ArrayLike, bands: Bands, spread: float = 1.0
) -> NDArray[np.float64]:
    """The bands' colours (linear RGB, shape (..., 3)) of f over footprints (fx, fy): the
    numpy form of what the renderer draws (:func:`band_shares`).

    Examples
    --------
    >>> from gshade.shape.registry import Bands
    >>> b = Bands((0.0,), ("below", "above"), ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)))
    >>> band_colours(np.array([-1.0, 0.0, 1.0]), 0.0, 0.0, b)[:, 0].tolist()
    [0.0, 1.0, 1.0]
    """
    f = np.asarray(f, dtype=np.float64)
    fx = np.broadcast_to(np.asarray(fx, dtype=np.float64), f.shape)
    fy = np.broadcast_to(np.asarray(fy, dtype=np.float64), f.shape)
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):  # unselected branches
        f, fx, fy = settled_on_levels(f, fx, fy, bands)
        shares, line = band_shares(f, fx, fy, bands, spread)
    colours = srgb_to_linear(np.asarray(bands.colours, dtype=np.float64))
    rgb = sum(s[..., None] * c for s, c in zip(shares, colours, strict=True))
    return rgb * (1.0 - line[..., None]) + line[..., None] * np.asarray(LINE_COLOUR)


def band_text(bands: Bands, units: str = "") -> str:
    """The bands in words, e.g. 'undercut < 0 <= too little draft < 1 <= enough draft deg'."""
    parts = [bands.names[0]]
    for k, (t, name) in enumerate(zip(bands.edges, bands.names[1:], strict=True)):
        below, above = ("<=", "<") if k in bands.closed_above else ("<", "<=")
        parts.append(f"{below} {t:.4g} {above} {name}")
    text = " ".join(parts) + (f" ({units})" if units else "")
    if bands.lines:
        text += "; lines at " + ", ".join(f"{t:.4g}" for t in bands.lines)
    return text
