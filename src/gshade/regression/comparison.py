"""Comparing two images channel by channel, with idiff's thresholds and verdicts.

Per compared channel, and over all of them, the metrics are: the largest absolute error and
where it is, the mean absolute error, the RMSE, the PSNR (with the data range stated), and
the number and share of pixels over the thresholds; SSIM (scikit-image, explicit
``data_range``) is computed on the tone-mapped picture when R, G and B are compared.

The verdict follows OpenImageIO's ``idiff``: a pixel's difference is the largest absolute
difference over the compared channels (NaN or infinity in either image never matches: the
difference is then infinite).  FAILURE if more than ``failpercent`` % of the pixels differ
by more than ``fail``, or any by more than ``hardfail``; else WARNING if more than
``warnpercent`` % differ by more than ``warn``; else PASS.

Exit statuses of ``gshade compare`` (:data:`EXIT_STATUS`): idiff's 0 PASS, 1 WARNING,
2 FAILURE, 3 size or channel mismatch, 4 unreadable file; and 5 for a usage error (a bad
argument, an output that cannot be written), so that 2 always means "the images differ".
"""

from __future__ import annotations

import math
import os
from dataclasses import asdict, dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError

__all__ = [
    "EXIT_STATUS",
    "ChannelMismatch",
    "Comparison",
    "Thresholds",
    "UsageError",
    "channel_groups",
    "compare",
    "heat_map",
    "load_channels",
    "z_test",
]

#: Exit statuses of ``gshade compare``: idiff's 0-4, and 5 for usage errors.
EXIT_STATUS = {"PASS": 0, "WARNING": 1, "FAILURE": 2, "MISMATCH": 3, "UNREADABLE": 4, "USAGE": 5}


class UsageError(GshadeError):
    """A bad argument of a comparison (thresholds, channels, difference-image targets)."""


class ChannelMismatch(GshadeError):
    """The images differ in size, or a compared channel is missing."""


class UnreadableImage(GshadeError):
    """An image file could not be read."""


@dataclass(frozen=True)
class Thresholds:
    """idiff's thresholds: ``fail``/``warn`` per pixel, ``*percent`` of the pixels.

    ``fail`` and ``warn`` are finite numbers >= 0, the percentages lie in [0, 100], and
    ``hardfail`` is a number >= 0 or infinity (the default: no hard limit); anything else
    raises a :class:`UsageError` naming the threshold.
    """

    fail: float = 1e-6
    failpercent: float = 0.0
    hardfail: float = float("inf")
    warn: float = 1e-6
    warnpercent: float = 0.0

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            number = isinstance(value, (int, float)) and not isinstance(value, bool)
            if not number or not value >= 0 or (name != "hardfail" and math.isinf(value)):
                expected = "a number >= 0 or inf" if name == "hardfail" else "a finite number >= 0"
                raise UsageError(f"{name}: expected {expected}, got {value!r}")
            if name.endswith("percent") and value > 100:
                raise UsageError(f"{name}: expected a percentage from 0 to 100, got {value!r}")


@dataclass
class ChannelMetrics:
    """Error metrics of one channel (or of all compared channels together)."""

    max_error: float
    max_at: tuple[int, int] | None  # (x, y) of the largest error
    mean_error: float
    rmse: float
    psnr: float
    data_range: float
    nonfinite: int


@dataclass
class Comparison:
    """The outcome of comparing a test image with a reference."""

    verdict: str
    channels: list[str]
    size: tuple[int, int]  # (width, height)
    thresholds: Thresholds
    per_channel: dict[str, ChannelMetrics]
    overall: ChannelMetrics
    failing: int
    warning: int
    pixels: int
    ssim: float | None = None
    difference: NDArray[np.float64] | None = field(default=None, repr=False)
    #: per pixel, the largest absolute difference over the channels (inf where non-finite)
    pixel_difference: NDArray[np.float64] | None = field(default=None, repr=False)
    #: metrics of channel groups with several members (RGB, P, N, uv): the worst channel
    per_group: dict[str, ChannelMetrics] = field(default_factory=dict)
    #: "thresholds" (idiff's rule) or "z-test" (:func:`z_test`: ``pixels`` counts
    #: pixel-channels and ``failing`` the rejected ones)
    test: str = "thresholds"

    @property
    def heat_scale(self) -> float:
        """The top of the heat maps' scale: the largest finite pixel difference (or 1)."""
        assert self.pixel_difference is not None, "compare() keeps the pixel differences"
        finite = self.pixel_difference[np.isfinite(self.pixel_difference)]
        return float(finite.max()) if finite.size and finite.max() > 0 else 1.0

    @property
    def exit_status(self) -> int:
        return EXIT_STATUS[self.verdict]

    @property
    def failing_percent(self) -> float:
        return 100.0 * self.failing / self.pixels

    @property
    def warning_percent(self) -> float:
        return 100.0 * self.warning / self.pixels

    def as_dict(self) -> dict:
        """The metrics as plain JSON values; non-finite numbers (the infinite PSNR of equal
        images, the errors where a pixel is NaN or infinite) are ``None`` (JSON null)."""
        out = {
            "verdict": self.verdict,
            "channels": self.channels,
            "size": list(self.size),
            "thresholds": asdict(self.thresholds),
            "pixels": self.pixels,
            "failing_pixels": self.failing,
            "failing_percent": self.failing_percent,
            "warning_pixels": self.warning,
            "warning_percent": self.warning_percent,
            "ssim": self.ssim,
            "overall": asdict(self.overall),
            "per_channel": {k: asdict(v) for k, v in self.per_channel.items()},
            "per_group": {k: asdict(v) for k, v in self.per_group.items()},
        }
        return _plain(out)

    def summary(self) -> str:
        """One line, e.g. 'FAILURE: 1.2% of 786432 pixels over 0.01, max 0.31 at (410, 96) in G'."""
        o = self.overall
        if self.test == "z-test":
            return (
                f"{self.verdict}: {100 - self.failing_percent:.4g}% of {self.pixels} "
                f"pixel-channels pass the z-test (need "
                f"{100 - self.thresholds.failpercent:.4g}%); max |difference| "
                f"{o.max_error:.4g}, mean {o.mean_error:.4g}"
            )
        where = ""
        if o.max_at is not None:
            worst = max(self.per_channel, key=lambda c: _order(self.per_channel[c].max_error))
            where = f" at ({o.max_at[0]}, {o.max_at[1]}) in {worst}"
        ssim = f", SSIM {self.ssim:.5f}" if self.ssim is not None else ""
        return (
            f"{self.verdict}: {self.failing_percent:.4g}% of {self.pixels} pixels over "
            f"{self.thresholds.fail:g} (warn {self.warning_percent:.4g}% over "
            f"{self.thresholds.warn:g}); max error {o.max_error:.4g}{where}, mean "
            f"{o.mean_error:.4g}, RMSE {o.rmse:.4g}, PSNR {o.psnr:.4g} dB{ssim}"
        )


def _order(x: float) -> float:
    return float("inf") if x != x else x


def _plain(x):
    """``x`` with numpy scalars as Python numbers and non-finite floats as None."""
    if isinstance(x, dict):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def channel_groups(channels: list[str]) -> dict[str, list[str]]:
    """Channels grouped as the EXR contract names them: R, G, B -> "RGB"; "P.X", "P.Y",
    "P.Z" -> "P"; u, v -> "uv"; any other "name.part" -> "name"; the rest alone."""
    groups: dict[str, list[str]] = {}
    for c in channels:
        if c in ("R", "G", "B"):
            key = "RGB"
        elif c in ("u", "v"):
            key = "uv"
        else:
            key = c.split(".", 1)[0]
        groups.setdefault(key, []).append(c)
    return groups


def load_channels(image) -> tuple[dict[str, NDArray], str]:
    """Channels of a path (EXR), a :class:`~gshade.rendering.rendered_image.RenderedImage`
    or a dict of arrays."""
    if isinstance(image, (str, os.PathLike)):
        from ..io.image import read_exr

        try:
            channels, _ = read_exr(image)
        except GshadeError as exc:
            raise UnreadableImage(str(exc)) from None
        return channels, str(image)
    if hasattr(image, "channels"):
        return dict(image.channels), "<image>"
    if isinstance(image, dict):
        return image, "<channels>"
    raise GshadeError(f"image: expected an EXR path, an image or a dict of channels, got {image!r}")


def _metrics(diff: NDArray, ref: NDArray) -> ChannelMetrics:
    """Metrics of |test - ref| (NaN/Inf where either is non-finite, counted as infinite)."""
    finite = np.isfinite(diff)
    nonfinite = int(diff.size - np.count_nonzero(finite))
    d = np.where(finite, np.abs(diff), np.inf)
    if d.size == 0:
        return ChannelMetrics(0.0, None, 0.0, 0.0, float("inf"), 0.0, 0)
    flat = int(np.argmax(d))
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
    at = (int(x), int(y)) if max_error > 0 else None
    return ChannelMetrics(max_error, at, mean, rmse, psnr, data_range, nonfinite)


def _tone_map(rgb: NDArray) -> NDArray:
    """Linear RGB -> [0, 1] display values (clipped sRGB curve), for SSIM."""
    from ..io.image import linear_to_srgb

    return linear_to_srgb(np.clip(np.nan_to_num(rgb, nan=0.0), 0.0, 1.0))


def compare(
    test,
    reference,
    *,
    channels: list[str] | tuple[str, ...] = ("R", "G", "B"),
    thresholds: Thresholds | None = None,
) -> Comparison:
    """Compare a test image with a reference (paths, rendered images or channel dicts).

    Raises
    ------
    ChannelMismatch
        Different sizes, or a requested channel missing from either image.
    UnreadableImage
        A file that cannot be read as EXR.
    UsageError
        No channel names.
    """
    thresholds = thresholds or Thresholds()
    channels = list(channels)
    if not channels or not all(isinstance(c, str) and c for c in channels):
        raise UsageError(f"channels: expected one or more channel names, got {channels!r}")
    a, name_a = load_channels(test)
    b, name_b = load_channels(reference)
    for name, image in ((name_a, a), (name_b, b)):
        missing = [c for c in channels if c not in image]
        if missing:
            raise ChannelMismatch(
                f"{name}: expected channel(s) {', '.join(missing)}, found "
                f"{', '.join(sorted(image)) or 'none'}"
            )
    shape_a, shape_b = a[channels[0]].shape, b[channels[0]].shape
    if shape_a != shape_b:
        raise ChannelMismatch(
            f"{name_a}: expected the reference's size {shape_b[1]}x{shape_b[0]}, "
            f"got {shape_a[1]}x{shape_a[0]}"
        )
    per_channel = {}
    diffs = []
    for c in channels:
        ta = np.asarray(a[c], dtype=np.float64)
        tb = np.asarray(b[c], dtype=np.float64)
        with np.errstate(invalid="ignore", over="ignore"):
            diff = ta - tb
        diff[~(np.isfinite(ta) & np.isfinite(tb))] = np.nan
        per_channel[c] = _metrics(diff, tb)
        diffs.append(diff)
    stack = np.stack(diffs, -1)
    magnitude = np.where(np.isfinite(stack), np.abs(stack), np.inf)
    pixel = magnitude.max(axis=-1)  # idiff: the worst channel of each pixel
    overall = _metrics(
        np.where(np.isinf(pixel), np.nan, pixel),
        np.stack([np.asarray(b[c], dtype=np.float64) for c in channels], -1).max(axis=-1),
    )
    per_group = {}
    for group, members in channel_groups(channels).items():
        if len(members) > 1:
            idx = [channels.index(c) for c in members]
            worst = magnitude[..., idx].max(axis=-1)
            refs = np.stack([np.asarray(b[c], dtype=np.float64) for c in members], -1)
            per_group[group] = _metrics(np.where(np.isinf(worst), np.nan, worst), refs.max(axis=-1))
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

        ta = _tone_map(np.stack([a[c] for c in "RGB"], -1).astype(np.float64))
        tb = _tone_map(np.stack([b[c] for c in "RGB"], -1).astype(np.float64))
        if min(ta.shape[:2]) >= 7:
            ssim = float(structural_similarity(ta, tb, data_range=1.0, channel_axis=-1))
    return Comparison(
        verdict=verdict,
        channels=channels,
        size=(shape_a[1], shape_a[0]),
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
    )


def heat_map(comparison: Comparison) -> NDArray[np.uint8]:
    """The per-pixel difference as an RGB image (inferno on [0, heat_scale]; magenta where
    non-finite), for reports."""
    import matplotlib

    pixel = comparison.pixel_difference
    assert pixel is not None, "compare() keeps the pixel differences"
    rgba = matplotlib.colormaps["inferno"](np.clip(pixel / comparison.heat_scale, 0, 1))
    rgba[np.isinf(pixel)] = (1, 0, 1, 1)
    return np.round(rgba[..., :3] * 255).astype(np.uint8)


def z_test(
    test,
    reference,
    *,
    channels=("R", "G", "B"),
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

    a, name_a = load_channels(test)
    b, name_b = load_channels(reference)
    channels = list(channels)
    needed = channels + [f"{c}.var" for c in channels]
    for name, image in ((name_a, a), (name_b, b)):
        missing = [c for c in needed if c not in image]
        if missing:
            raise ChannelMismatch(
                f"{name}: the statistical test needs channel(s) {', '.join(missing)} (means "
                "and variances from several runs)"
            )
    if a[channels[0]].shape != b[channels[0]].shape:
        sa, sb = a[channels[0]].shape, b[channels[0]].shape
        raise ChannelMismatch(
            f"{name_a}: expected the reference's size {sb[1]}x{sb[0]}, got {sa[1]}x{sa[0]}"
        )
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
    per_channel = {
        c: _metrics(diff[..., k], np.asarray(b[c], float)) for k, c in enumerate(channels)
    }
    return Comparison(
        verdict=verdict,
        channels=channels,
        size=(pixel.shape[1], pixel.shape[0]),
        thresholds=Thresholds(failpercent=100.0 - required_percent),
        per_channel=per_channel,
        overall=_metrics(np.where(np.isinf(pixel), np.nan, pixel), np.zeros_like(pixel)),
        failing=failing,
        warning=failing,
        pixels=tests,
        difference=diff,
        pixel_difference=pixel,
        test="z-test",
    )
