"""A picture's legend as a strip under it (``gshade render --png ... --legend``), so that a
PNG read alone in a report says what it shows: the colour bar over the value range with its
unit (a colour-mapped display), and the legend's line — the function and its order, the
stripe period, the bands, the notes (the smallest radius, the combs' scale) — wrapped to
the picture's width.  Drawn by Matplotlib's Agg; the picture's own pixels are untouched.
"""

from __future__ import annotations

import textwrap

import numpy as np
from numpy.typing import NDArray

from .colour import Legend, srgb_to_linear

__all__ = ["LINE_PIXELS", "with_legend"]

#: Text size and line height in pixels; the colour bar's height and the room for its ticks
FONT_PIXELS, LINE_PIXELS, BAR_PIXELS, TICK_PIXELS = 10.0, 13, 10, 14


def _strip(width: int, legend: Legend) -> NDArray:
    """The strip (h, width, 4) as straight sRGB in [0, 1]."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    dpi = 100.0
    points = 72.0 / dpi
    chars = max(int(width / (0.55 * FONT_PIXELS)) - 2, 10)
    lines = textwrap.wrap(legend.text(), chars) or [""]
    bar = legend.value_range is not None and legend.colormap is not None
    top = (BAR_PIXELS + TICK_PIXELS + 4) if bar else 2
    height = top + LINE_PIXELS * len(lines) + 4
    figure = Figure(figsize=(width / dpi, height / dpi), dpi=dpi, facecolor="white")
    if bar:
        assert legend.value_range is not None
        lo, hi = legend.value_range
        axes = figure.add_axes((0.08, 1.0 - (BAR_PIXELS + 2) / height, 0.84, BAR_PIXELS / height))
        axes.imshow(
            np.linspace(0.0, 1.0, 256)[None, :],
            aspect="auto",
            cmap=legend.colormap,
            extent=(lo, hi, 0.0, 1.0),
        )
        axes.set_yticks([])
        ticks = [lo, hi] if not lo < 0 < hi else [lo, 0.0, hi]
        axes.set_xticks(ticks, [f"{t:.4g}" for t in ticks], fontsize=FONT_PIXELS * points)
        axes.tick_params(length=2, pad=1)
    for k, line in enumerate(lines):
        figure.text(
            4.0 / width,
            1.0 - (top + LINE_PIXELS * (k + 0.8)) / height,
            line,
            fontsize=FONT_PIXELS * points,
            color="black",
        )
    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[:height, :width] / 255.0


def with_legend(rgb: NDArray, alpha: NDArray, legend: Legend) -> tuple[NDArray, NDArray]:
    """The picture (straight linear ``rgb`` (H, W, 3), ``alpha`` (H, W)) with its legend's
    strip below it, opaque white.

    Examples
    --------
    >>> rgb, alpha = np.zeros((20, 200, 3)), np.ones((20, 200))
    >>> out, a = with_legend(rgb, alpha, Legend("mean", 2, "colormap", (-1.0, 1.0), "coolwarm"))
    >>> out.shape[1], out.shape[0] > 20, bool((out[:20] == 0).all())
    (200, True, True)
    """
    strip = _strip(rgb.shape[1], legend)
    linear = srgb_to_linear(strip[..., :3])
    return (
        np.concatenate([rgb, linear], axis=0),
        np.concatenate([alpha, np.ones(strip.shape[:2])], axis=0),
    )
