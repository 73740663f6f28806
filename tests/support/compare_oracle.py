"""The whole-image comparison that ``compare`` computed before it worked block by block
(issue 15): the oracle that the block-wise figures must equal to the last bit."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from gshade.regression.comparison import (
    ChannelMetrics,
    Comparison,
    Thresholds,
    UsageError,
    ValueMetrics,
    _tone_map,
    channel_groups,
    pixel_metrics,
)
from gshade.regression.image_pairs import aligned_channels, load_image


def _value_metrics(
    ta: NDArray[np.float64], tb: NDArray[np.float64], magnitude: NDArray[np.float64]
) -> ValueMetrics:
    """idiff's figures over every value of the stacked channels (..., channel)."""
    values = int(magnitude.size)
    finite = np.isfinite(ta) & np.isfinite(tb)
    peak = 1.0
    if np.any(finite):
        peak = max(1.0, float(np.abs(ta[finite]).max()), float(np.abs(tb[finite]).max()))
    if not finite.all():
        inf = float("inf")
        return ValueMetrics(inf, inf, -inf, peak, values)
    mean = float(magnitude.mean()) if values else 0.0
    rmse = float(np.sqrt(np.mean(magnitude**2))) if values else 0.0
    psnr = float("inf") if rmse == 0 else float(20 * np.log10(peak / rmse))
    return ValueMetrics(mean, rmse, psnr, peak, values)


def direct_compare(
    test,
    reference,
    *,
    channels: list[str] | tuple[str, ...] = ("R", "G", "B"),
    thresholds: Thresholds | None = None,
) -> Comparison:
    """The comparison as whole-image numpy expressions."""
    thresholds = thresholds or Thresholds()
    channels = list(channels)
    if not channels or not all(isinstance(c, str) and c for c in channels):
        raise UsageError(f"channels: expected one or more channel names, got {channels!r}")
    a, b, window, display = aligned_channels(load_image(test), load_image(reference), channels)
    origin = (window.x_min, window.y_min)
    per_channel = {}
    diffs = []
    for c in channels:
        ta, tb = a[c], b[c]
        fa, fb = np.isfinite(ta), np.isfinite(tb)
        with np.errstate(invalid="ignore", over="ignore"):
            diff = ta - tb
        diff[~(fa & fb)] = np.nan
        per_channel[c] = pixel_metrics(
            diff, tb, origin=origin, test_finite=fa, reference_finite=fb, names=[c]
        )
        diffs.append(diff)
    stack = np.stack(diffs, -1)
    magnitude = np.where(np.isfinite(stack), np.abs(stack), np.inf)
    pixel = magnitude.max(axis=-1)  # idiff: the worst channel of each pixel
    test_values = np.stack([a[c] for c in channels], -1)
    reference_values = np.stack([b[c] for c in channels], -1)

    def worst_of(idx: list[int]) -> ChannelMetrics:
        worst = magnitude[..., idx].max(axis=-1)
        return pixel_metrics(
            np.where(np.isinf(worst), np.nan, worst),
            reference_values[..., idx].max(axis=-1),
            origin=origin,
            test_finite=np.isfinite(test_values[..., idx]).all(axis=-1),
            reference_finite=np.isfinite(reference_values[..., idx]).all(axis=-1),
            magnitudes=magnitude[..., idx],
            names=[channels[k] for k in idx],
        )

    overall = worst_of(list(range(len(channels))))
    per_group = {}
    for group, members in channel_groups(channels).items():
        if len(members) > 1:
            per_group[group] = worst_of([channels.index(c) for c in members])
    n = pixel.size
    nonfinite = np.isinf(pixel)  # NaN or infinity in either image: never a match
    failing = int(np.count_nonzero(nonfinite | (pixel > thresholds.fail)))
    warning = int(np.count_nonzero(nonfinite | (pixel > thresholds.warn)))
    if failing > thresholds.failpercent / 100.0 * n or np.any(pixel > thresholds.hardfail):
        verdict = "FAILURE"
    elif warning > thresholds.warnpercent / 100.0 * n:
        verdict = "WARNING"
    else:
        verdict = "PASS"
    ssim = None
    if {"R", "G", "B"} <= set(channels):
        from skimage.metrics import structural_similarity

        ta = _tone_map(np.stack([a[c] for c in "RGB"], -1))
        tb = _tone_map(np.stack([b[c] for c in "RGB"], -1))
        if min(ta.shape[:2]) >= 7:
            ssim = float(structural_similarity(ta, tb, data_range=1.0, channel_axis=-1))
    return Comparison(
        verdict=verdict,
        channels=channels,
        size=(window.width, window.height),
        thresholds=thresholds,
        per_channel=per_channel,
        overall=overall,
        failing=failing,
        warning=warning,
        pixels=n,
        ssim=ssim,
        difference=stack,
        pixel_difference=pixel,
        per_group=per_group,
        all_values=_value_metrics(test_values, reference_values, magnitude),
        window=window,
        display_window=display,
    )
