"""The metrics of a comparison: of one channel, or of the pixel difference of a channel group
(the worst channel of each pixel), and idiff's figures over every value.

:func:`pixel_metrics` computes them from whole arrays (the statistical test's);
:func:`reduced_metrics` and :func:`value_metrics` from :func:`.blockwise.reduce_blocks`'s
block-by-block reductions, with the same values to the last bit.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .blockwise import Blocks, Reduction

__all__ = ["ChannelMetrics", "ValueMetrics", "pixel_metrics", "reduced_metrics", "value_metrics"]


@dataclass
class ChannelMetrics:
    """Error metrics of one channel, or of the pixel difference (each pixel's worst channel)
    of a group of channels or of all compared channels (see :data:`DEFINITIONS`)."""

    max_error: float
    max_at: tuple[int, int] | None  # (x, y) of the largest error, None if there is none
    mean_error: float
    rmse: float
    psnr: float
    data_range: float
    nonfinite: int  # pixels non-finite in either image
    nonfinite_test: int = 0  # pixels non-finite in the test image
    nonfinite_reference: int = 0  # pixels non-finite in the reference
    #: the channel of the largest error (the first compared channel with it at max_at)
    max_channel: str | None = None


@dataclass
class ValueMetrics:
    """idiff's mean error, RMS error and PSNR: over every compared value (pixel x channel),
    with the PSNR's ``peak`` max(1, the largest magnitude in either image).  Infinite (JSON
    null) where a value is NaN or infinite."""

    mean_error: float
    rmse: float
    psnr: float
    peak: float
    values: int


def pixel_metrics(
    diff: NDArray,
    ref: NDArray,
    *,
    origin: tuple[int, int] = (0, 0),
    test_finite: ArrayLike | None = None,
    reference_finite: ArrayLike | None = None,
    magnitudes: NDArray | None = None,
    names: list[str] | None = None,
) -> ChannelMetrics:
    """Metrics of |test - ref| (NaN/Inf where either is non-finite, counted as infinite).

    ``origin`` is the image coordinates of the arrays' first pixel; ``test_finite`` and
    ``reference_finite`` say where each image is finite (for the per-image counts); with
    ``magnitudes`` (..., channel) and their ``names``, the channel of the largest error is
    the first one reaching it at its pixel."""
    finite = np.isfinite(diff)
    nonfinite = int(diff.size - np.count_nonzero(finite))
    counts = [
        int(diff.size - np.count_nonzero(f)) if f is not None else nonfinite
        for f in (test_finite, reference_finite)
    ]
    d = np.where(finite, np.abs(diff), np.inf)
    if d.size == 0:
        return ChannelMetrics(0.0, None, 0.0, 0.0, float("inf"), 0.0, 0)
    flat = int(np.argmax(d))  # the first largest, in row-major order
    y, x = np.unravel_index(flat, d.shape[:2])
    max_error = float(d.flat[flat])
    good = d[finite]
    mean = float(good.mean()) if nonfinite == 0 else float("inf")
    rmse = float(np.sqrt(np.mean(good**2))) if nonfinite == 0 else float("inf")
    r = ref[np.isfinite(ref)]
    data_range = float(r.max() - r.min()) if r.size else 0.0
    if data_range <= 0:
        data_range = 1.0
    if nonfinite:
        psnr = float("-inf")
    elif rmse == 0:
        psnr = float("inf")
    else:
        psnr = float(20 * np.log10(data_range / rmse))
    at = (int(x) + origin[0], int(y) + origin[1]) if max_error > 0 else None
    channel = None
    if at is not None and names:
        # the first of the channels (in the compared order) with the largest error there
        first = 0 if magnitudes is None else int(np.argmax(magnitudes[y, x] == max_error))
        channel = names[first]
    return ChannelMetrics(
        max_error, at, mean, rmse, psnr, data_range, nonfinite, counts[0], counts[1], channel
    )


def reduced_metrics(
    red: Reduction,
    width: int,
    origin: tuple[int, int],
    names: list[str],
    magnitude_at: Callable[[int, int], float],
) -> ChannelMetrics:
    """:func:`pixel_metrics` of a channel's or group's pixel difference, from its
    reductions; ``magnitude_at(channel, pixel)``: a channel's difference at a pixel."""
    if red.n == 0:
        return ChannelMetrics(0.0, None, 0.0, 0.0, float("inf"), 0.0, 0)
    y, x = divmod(red.max_index, width)
    max_error = red.max_error
    mean = rmse = float("inf")
    if red.nonfinite == 0:
        mean = red.sum.result() / red.n
        rmse = float(np.sqrt(red.sum_of_squares.result() / red.n))
    data_range = 0.0
    if red.reference_min <= red.reference_max:
        data_range = red.reference_max - red.reference_min
    if data_range <= 0:
        data_range = 1.0
    at = (x + origin[0], y + origin[1]) if max_error > 0 else None
    channel = None
    if at is not None:  # the first of the channels (in the compared order) with it there
        channel = names[0]
        for k, name in zip(red.members, names, strict=True):
            if magnitude_at(k, red.max_index) == max_error:
                channel = name
                break
    return ChannelMetrics(
        max_error,
        at,
        mean,
        rmse,
        _psnr(data_range, rmse, red.nonfinite),
        data_range,
        red.nonfinite,
        red.nonfinite_test,
        red.nonfinite_reference,
        channel,
    )


def _psnr(data_range: float, rmse: float, nonfinite: int) -> float:
    if nonfinite:
        return float("-inf")
    if rmse == 0:
        return float("inf")
    with np.errstate(divide="ignore"):  # an infinite RMSE (an overflowing difference)
        return float(20 * np.log10(data_range / rmse))


def value_metrics(blocks: Blocks, values: int) -> ValueMetrics:
    """idiff's figures over every compared value (pixel x channel)."""
    peak = 1.0 if blocks.peak is None else max(1.0, blocks.peak)
    if not blocks.values_finite:
        inf = float("inf")
        return ValueMetrics(inf, inf, -inf, peak, values)
    mean = blocks.values.result() / values if values else 0.0
    rmse = float(np.sqrt(blocks.values_of_squares.result() / values)) if values else 0.0
    with np.errstate(divide="ignore"):  # an infinite RMSE (an overflowing difference)
        psnr = float("inf") if rmse == 0 else float(20 * np.log10(peak / rmse))
    return ValueMetrics(mean, rmse, psnr, peak, values)
