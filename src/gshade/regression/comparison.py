"""Comparing two images channel by channel, with idiff's thresholds and verdicts.

Per compared channel, and over all of them, the metrics are: the largest absolute error and
where it is, the mean absolute error, the RMSE, the PSNR (with the data range stated), and
the number and share of pixels over the thresholds; SSIM (scikit-image, explicit
``data_range``) is computed on the tone-mapped picture when R, G and B are compared (by
default in :func:`compare`; ``gshade compare`` only with ``--ssim``: it is slow).

The images are compared in their stored types, a block of pixels at a time
(:mod:`.blockwise`), with the figures of the whole-image float64 computation to the last bit.

The verdict follows OpenImageIO's ``idiff``: a pixel's difference is the largest absolute
difference over the compared channels (NaN or infinity in either image never matches: the
difference is then infinite).  FAILURE if more than ``failpercent`` % of the pixels differ
by more than ``fail``, or any by more than ``hardfail``; else WARNING if more than
``warnpercent`` % differ by more than ``warn``; else PASS.

Images are compared by position, as idiff does: EXR data windows are honoured (the compared
pixels are the union of the two data windows, a pixel outside an image's data window reads
0, coordinates are the images' own) and the display windows must be equal.

"Overall" (and a channel group's) metrics are those of each pixel's difference, the worst
channel's: its largest value, and its mean, RMSE and PSNR over the pixels; the PSNR's data
range is that of each pixel's largest reference value over the channels.  idiff's own
figures, over every compared value (pixel x channel) with its PSNR peak max(1, largest
magnitude), are :class:`ValueMetrics` (``all_values``).  :data:`DEFINITIONS` says so in
``--json``, where non-finite numbers are null.

Exit statuses of ``gshade compare`` (:data:`EXIT_STATUS`): idiff's 0 PASS, 1 WARNING,
2 FAILURE, 3 size or channel mismatch, 4 unreadable file; and 5 for a usage error (a bad
argument, an output that cannot be written), so that 2 always means "the images differ".
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from ..io.image import ExrWindow
from .blockwise import Reduction, reduce_blocks
from .image_pairs import (
    ChannelMismatch,
    LoadedImage,
    UnreadableImage,
    aligned_planes,
    load_channels,
    load_image,
)
from .metrics import (
    ChannelMetrics,
    ValueMetrics,
    pixel_metrics,
    reduced_metrics,
    value_metrics,
)

if TYPE_CHECKING:
    import os

    from ..rendering.rendered_image import RenderedImage

__all__ = [
    "DEFINITIONS",
    "EXIT_STATUS",
    "ChannelMismatch",
    "Comparison",
    "Thresholds",
    "UnreadableImage",
    "UsageError",
    "ValueMetrics",
    "channel_groups",
    "compare",
    "heat_map",
    "load_channels",
    "pixel_metrics",
]

#: Exit statuses of ``gshade compare``: idiff's 0-4, and 5 for usage errors.
EXIT_STATUS = {"PASS": 0, "WARNING": 1, "FAILURE": 2, "MISMATCH": 3, "UNREADABLE": 4, "USAGE": 5}

#: What the metrics mean: ``--json`` and ``summary.json`` carry this as ``definitions``.
DEFINITIONS = {
    "pixels": "the compared pixels: the union of the two images' data windows ('window', "
    "inclusive x_min, y_min, x_max, y_max), where a pixel outside an image's data window "
    "reads 0; the display windows are equal",
    "pixel difference": "a pixel's largest absolute difference over the compared channels "
    "(idiff's); infinite where either image is NaN or infinite in a compared channel (never "
    "a match); failing_pixels and warning_pixels count the pixels whose difference exceeds "
    "fail and warn",
    "per_channel": "metrics of one channel's absolute differences, over the pixels",
    "overall": "metrics of the pixel difference (each pixel's worst channel), over the pixels; "
    "per_group: the same over a group's channels (RGB, P, N, uv)",
    "max_error": "the largest absolute difference; max_at: its pixel (x, y) in the image's "
    "pixel coordinates, the first in row-major order on ties; max_channel: the first "
    "compared channel with that difference at that pixel",
    "mean_error": "the mean of the absolute differences over the pixels (overall: of the "
    "pixel differences, not of every value)",
    "rmse": "the square root of the mean squared absolute difference, over the same values as "
    "mean_error",
    "psnr": "20 log10(data_range / rmse) in dB; data_range: max - min of the reference's "
    "finite values (overall and groups: of each pixel's largest reference value over the "
    "channels), 1 where that is 0",
    "all_values": "idiff's mean error, RMS error and PSNR: over every compared value (pixel x "
    "channel); the PSNR's peak is max(1, the largest magnitude in either image)",
    "nonfinite": "pixels where the test or the reference is NaN or infinite (in the channel; "
    "overall and groups: in any of their channels); nonfinite_test and nonfinite_reference "
    "count each image's",
    "null": "a value that is not a finite number: the PSNR of equal channels (+inf); the "
    "errors, mean, RMSE and PSNR where a pixel is NaN or infinite (see nonfinite); an "
    "infinite hardfail",
}


class UsageError(GshadeError):
    """A bad argument of a comparison (thresholds, channels, difference-image targets)."""


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
class Comparison:
    """The outcome of comparing a test image with a reference."""

    verdict: str
    channels: list[str]
    size: tuple[int, int]  # (width, height) of the compared pixels (see window)
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
    #: idiff's per-value mean, RMS error and PSNR (None for the z-test)
    all_values: ValueMetrics | None = None
    #: the compared pixels (the union of the data windows) and the images' display window
    window: ExrWindow | None = None
    display_window: ExrWindow | None = None

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
            "test": self.test,
            "max_channel": self.overall.max_channel,
            "nonfinite_pixels": {
                "either": self.overall.nonfinite,
                "test": self.overall.nonfinite_test,
                "reference": self.overall.nonfinite_reference,
            },
            "all_values": asdict(self.all_values) if self.all_values is not None else None,
            "window": _box(self.window),
            "display_window": _box(self.display_window),
            "definitions": DEFINITIONS,
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
            where = f" at ({o.max_at[0]}, {o.max_at[1]}) in {o.max_channel}"
        ssim = f", SSIM {self.ssim:.5f}" if self.ssim is not None else ""
        nonfinite = ""
        if o.nonfinite:
            nonfinite = (
                f"; {o.nonfinite} pixel{'s' if o.nonfinite != 1 else ''} NaN or infinite "
                f"(test {o.nonfinite_test}, reference {o.nonfinite_reference})"
            )
        return (
            f"{self.verdict}: {self.failing_percent:.4g}% of {self.pixels} pixels over "
            f"{self.thresholds.fail:g} (warn {self.warning_percent:.4g}% over "
            f"{self.thresholds.warn:g}); max error {o.max_error:.4g}{where}, mean "
            f"{o.mean_error:.4g}, RMSE {o.rmse:.4g}, PSNR {o.psnr:.4g} dB (per pixel: the "
            f"worst channel){ssim}{nonfinite}"
        )


def _box(window: ExrWindow | None) -> list[int] | None:
    if window is None:
        return None
    return [window.x_min, window.y_min, window.x_max, window.y_max]


def _plain(x: Any) -> Any:
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


def _tone_map(rgb: NDArray) -> NDArray:
    """Linear RGB -> [0, 1] display values (clipped sRGB curve), for SSIM."""
    from ..io.image import linear_to_srgb

    return linear_to_srgb(np.clip(np.nan_to_num(rgb, nan=0.0), 0.0, 1.0))


def _ssim(a: dict[str, NDArray], b: dict[str, NDArray]) -> float | None:
    """SSIM of the tone-mapped pictures (None below 7x7 pixels)."""
    from skimage.metrics import structural_similarity

    ta = _tone_map(np.stack([np.asarray(a[c], dtype=np.float64) for c in "RGB"], -1))
    tb = _tone_map(np.stack([np.asarray(b[c], dtype=np.float64) for c in "RGB"], -1))
    if min(ta.shape[:2]) < 7:
        return None
    return float(structural_similarity(ta, tb, data_range=1.0, channel_axis=-1))


def _compared(image: LoadedImage, channels: list[str]) -> LoadedImage:
    """The image with only the compared channels, if it has them all (else as it is, for
    the mismatch's message)."""
    if not all(c in image.channels for c in channels):
        return image
    kept = {c: image.channels[c] for c in channels}
    return LoadedImage(kept, image.name, image.data, image.display)


def compare(
    test: str | os.PathLike | RenderedImage | dict[str, NDArray],
    reference: str | os.PathLike | RenderedImage | dict[str, NDArray],
    *,
    channels: list[str] | tuple[str, ...] = ("R", "G", "B"),
    thresholds: Thresholds | None = None,
    ssim: bool | None = None,
    differences: bool = True,
) -> Comparison:
    """Compare a test image with a reference (paths, rendered images or channel dicts).

    EXR images are compared by position: over the union of their data windows (a pixel
    outside an image's data window reads 0), with coordinates (``max_at``) in the images'
    pixel space; their display windows must be equal.  The images are read in their stored
    types and compared a block of pixels at a time (:mod:`.blockwise`).

    Parameters
    ----------
    ssim : bool, optional
        Compute SSIM (when R, G and B are compared, on at least 7x7 pixels; it takes whole
        float64 copies of R, G and B and about as long as the rest of the comparison): by
        default (None) whenever R, G and B are compared; ``gshade compare`` asks for it
        with ``--ssim``.
    differences : bool
        Keep the differences (``difference``, ``pixel_difference``: for the difference
        images and heat maps); without them the comparison needs little memory beyond the
        images.

    Raises
    ------
    ChannelMismatch
        Different sizes (display windows), or a requested channel missing from either image.
    UnreadableImage
        A file that cannot be read as EXR.
    UsageError
        No channel names.

    Examples
    --------
    Two 4x4 RGB images as channel dicts, one pixel (x = 2, y = 1) off by 0.25 in G:

    >>> import numpy as np
    >>> reference = {c: np.full((4, 4), 0.5, dtype=np.float32) for c in "RGB"}
    >>> test = {c: plane.copy() for c, plane in reference.items()}
    >>> test["G"][1, 2] = 0.75
    >>> result = compare(test, reference, thresholds=Thresholds(fail=0.1))
    >>> result.verdict, result.failing, result.pixels, result.exit_status
    ('FAILURE', 1, 16, 2)
    >>> result.overall.max_error, result.overall.max_at, result.overall.max_channel
    (0.25, (2, 1), 'G')
    >>> round(result.overall.rmse, 12), round(result.overall.psnr, 4)  # flat reference: range 1
    (0.0625, 24.0824)

    With 10 % of the pixels allowed to fail, the pixel still exceeds ``warn`` (1e-6):

    >>> compare(test, reference, thresholds=Thresholds(fail=0.1, failpercent=10)).verdict
    'WARNING'
    """
    thresholds = thresholds or Thresholds()
    channels = list(channels)
    if not channels or not all(isinstance(c, str) and c for c in channels):
        raise UsageError(f"channels: expected one or more channel names, got {channels!r}")
    loaded = _compared(load_image(test, half=True), channels)  # the rest freed before
    a, b, window, display = aligned_planes(
        loaded, _compared(load_image(reference, half=True), channels), channels
    )
    groups = [
        [channels.index(c) for c in members]
        for members in channel_groups(channels).values()
        if len(members) > 1
    ]
    test_planes, reference_planes = [a[c] for c in channels], [b[c] for c in channels]
    blocks = reduce_blocks(
        test_planes,
        reference_planes,
        [*groups, list(range(len(channels)))],
        (thresholds.fail, thresholds.warn, thresholds.hardfail),
        keep=differences,
    )

    def magnitude_at(k: int, pixel: int) -> float:
        ta, tb = float(test_planes[k].flat[pixel]), float(reference_planes[k].flat[pixel])
        if not (math.isfinite(ta) and math.isfinite(tb)):
            return float("inf")
        return abs(ta - tb)  # may overflow to infinity, as the arrays' differences

    origin, width = (window.x_min, window.y_min), window.width

    def metrics(red: Reduction) -> ChannelMetrics:
        names = [channels[k] for k in red.members]
        return reduced_metrics(red, width, origin, names, magnitude_at)

    *group_reductions, overall = [metrics(red) for red in blocks.groups]
    per_group = dict(
        zip(
            (g for g, members in channel_groups(channels).items() if len(members) > 1),
            group_reductions,
            strict=True,
        )
    )
    n = window.width * window.height
    if blocks.failing > thresholds.failpercent / 100.0 * n or blocks.hardfail:
        verdict = "FAILURE"
    elif blocks.warning > thresholds.warnpercent / 100.0 * n:
        verdict = "WARNING"
    else:
        verdict = "PASS"
    rgb = {"R", "G", "B"} <= set(channels)
    shape = (window.height, window.width, len(channels))
    return Comparison(
        verdict=verdict,
        channels=channels,
        size=(window.width, window.height),
        thresholds=thresholds,
        per_channel={c: metrics(red) for c, red in zip(channels, blocks.channels, strict=True)},
        overall=overall,
        failing=blocks.failing,
        warning=blocks.warning,
        pixels=n,
        ssim=_ssim(a, b) if rgb and ssim is not False else None,
        difference=None if blocks.difference is None else blocks.difference.reshape(shape),
        pixel_difference=None
        if blocks.pixel_difference is None
        else blocks.pixel_difference.reshape(shape[:2]),
        per_group=per_group,
        all_values=value_metrics(blocks, n * len(channels)),
        window=window,
        display_window=display,
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
