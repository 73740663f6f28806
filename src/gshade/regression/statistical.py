"""The statistical comparison of noisy renders (``gshade check --statistical``): a per-pixel
Welch z-test of two images' means against their variances, as Mitsuba's own render tests."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .comparison import Comparison, Thresholds, pixel_metrics
from .image_pairs import ChannelMismatch, aligned_channels, load_image

if TYPE_CHECKING:
    import os

    from numpy.typing import NDArray

    from ..rendering.rendered_image import RenderedImage

__all__ = ["z_test"]


def z_test(
    test: str | os.PathLike | RenderedImage | dict[str, NDArray],
    reference: str | os.PathLike | RenderedImage | dict[str, NDArray],
    *,
    channels: list[str] | tuple[str, ...] = ("R", "G", "B"),
    significance: float = 0.01,
    required_percent: float = 99.75,
) -> Comparison:
    """Statistical comparison of noisy renders, as Mitsuba's own render tests do.

    Both images carry, for each compared channel C, the per-pixel mean in C and the variance
    of that mean in ``C.var`` (from independent runs).  Each pixel-channel gets a two-sided
    Welch z-test, z = (mu_test - mu_ref) / sqrt(var_test + var_ref), with the significance
    level Šidák-corrected for the number of tests, 1 - (1 - significance)^(1 / M).  PASS if
    at least ``required_percent`` % of the pixel-channels pass (and none is NaN), else
    FAILURE.  The failing count is that of the pixel-channels rejected.
    """
    from scipy.special import erfc

    channels = list(channels)
    needed = channels + [f"{c}.var" for c in channels]
    test_image, reference_image = load_image(test), load_image(reference)
    for image in (test_image, reference_image):
        missing = [c for c in needed if c not in image.channels]
        if missing:
            raise ChannelMismatch(
                f"{image.name}: the statistical test needs channel(s) {', '.join(missing)} "
                "(means and variances from several runs)"
            )
    a, b, window, display = aligned_channels(test_image, reference_image, needed)
    diff = np.stack([np.asarray(a[c], float) - np.asarray(b[c], float) for c in channels], -1)
    var = np.stack(
        [np.asarray(a[f"{c}.var"], float) + np.asarray(b[f"{c}.var"], float) for c in channels], -1
    )
    tiny = 1e-12
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.abs(diff) / np.sqrt(np.maximum(var, 0.0) + tiny)
    p = erfc(z / np.sqrt(2.0))
    tests = p.size
    level = 1.0 - (1.0 - significance) ** (1.0 / tests)
    rejected = ~(p >= level)  # NaN never passes
    failing = int(np.count_nonzero(rejected))
    passing_percent = 100.0 * (tests - failing) / tests
    verdict = "PASS" if passing_percent >= required_percent else "FAILURE"
    magnitude = np.where(np.isfinite(diff), np.abs(diff), np.inf)
    pixel = magnitude.max(axis=-1)
    origin = (window.x_min, window.y_min)
    per_channel = {}
    for k, c in enumerate(channels):
        fa, fb = np.isfinite(a[c]), np.isfinite(b[c])
        d = np.where(fa & fb, diff[..., k], np.nan)
        per_channel[c] = pixel_metrics(
            d, b[c], origin=origin, test_finite=fa, reference_finite=fb, names=[c]
        )
    overall = pixel_metrics(
        np.where(np.isinf(pixel), np.nan, pixel),
        np.zeros_like(pixel),
        origin=origin,
        test_finite=np.isfinite(np.stack([a[c] for c in channels])).all(axis=0),
        reference_finite=np.isfinite(np.stack([b[c] for c in channels])).all(axis=0),
        magnitudes=magnitude,
        names=channels,
    )
    return Comparison(
        verdict=verdict,
        channels=channels,
        size=(window.width, window.height),
        thresholds=Thresholds(failpercent=100.0 - required_percent),
        per_channel=per_channel,
        overall=overall,
        failing=failing,
        warning=failing,
        pixels=tests,
        difference=diff,
        pixel_difference=pixel,
        test="z-test",
        window=window,
        display_window=display,
    )
