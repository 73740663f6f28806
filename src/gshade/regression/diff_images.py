"""Difference images of a comparison: the absolute differences as EXR, a heat map as PNG.

:func:`compare_and_write_diffs` is ``gshade compare``'s core: it creates the difference
images' temporaries before reading the images, so an unwritable target is a usage error
(exit 5) found at once, and writes both files or neither.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import GshadeError
from ..io.outputs import atomic_write, staged, write_to
from .comparison import Comparison, Thresholds, UsageError, compare

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from ..rendering.rendered_image import RenderedImage

__all__ = [
    "compare_and_write_diffs",
    "diff_exr_writer",
    "diff_png_writer",
    "write_diff_exr",
    "write_diff_png",
]


def diff_exr_writer(comparison: Comparison, path: str | os.PathLike) -> Callable[[str], None]:
    """The absolute differences, one channel per compared channel (non-finite as NaN), as
    a function writing them as EXR to a file name (``path`` names the target in errors).
    The header's ``gshade:diff_window`` says where the compared pixels lie in the images."""
    from ..io.image import exr_writer

    difference = comparison.difference
    assert difference is not None, "compare() keeps the differences"
    channels = {
        c: np.abs(difference[..., k]).astype(np.float32) for k, c in enumerate(comparison.channels)
    }
    header = {"gshade:diff_of": ",".join(comparison.channels)}
    w = comparison.window
    if w is not None:  # the compared pixels' place in the images (x_min,y_min,x_max,y_max)
        header["gshade:diff_window"] = f"{w.x_min},{w.y_min},{w.x_max},{w.y_max}"
    return exr_writer(path, channels, header=header)


def diff_png_writer(comparison: Comparison) -> Callable[[str], None]:
    """A heat map of the per-pixel difference (worst channel) with a scale bar, as a
    function writing it as PNG to a file name.  Non-finite differences are drawn in the
    map's 'over' colour (magenta)."""

    def write(name: str) -> None:
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        pixel = comparison.pixel_difference
        assert pixel is not None, "compare() keeps the pixel differences"
        top = comparison.heat_scale
        cmap = matplotlib.colormaps["inferno"].with_extremes(over="magenta")
        h, w = pixel.shape
        dpi = 100
        fig = plt.figure(figsize=(w / dpi + 1.6, h / dpi + 0.4), dpi=dpi)
        try:
            ax = fig.add_axes((0.0, 0.0, w / (w + 160.0), 1.0))
            im = ax.imshow(
                np.where(np.isinf(pixel), top * 2, pixel),
                cmap=cmap,
                vmin=0,
                vmax=top,
                interpolation="nearest",
            )
            ax.set_axis_off()
            cax = fig.add_axes((w / (w + 160.0) + 0.02, 0.1, 0.03, 0.8))
            bar = fig.colorbar(im, cax=cax, extend="max" if np.isinf(pixel).any() else "neither")
            bar.set_label(f"|difference| ({', '.join(comparison.channels)})")
            fig.savefig(name, format="png", dpi=dpi)
        finally:
            plt.close(fig)

    return write


def write_diff_exr(comparison: Comparison, path: str | os.PathLike) -> Path:
    """Write :func:`diff_exr_writer`'s EXR to ``path``, atomically."""
    return atomic_write(path, ".exr", diff_exr_writer(comparison, path))


def write_diff_png(comparison: Comparison, path: str | os.PathLike) -> Path:
    """Write :func:`diff_png_writer`'s heat map to ``path``, atomically."""
    return atomic_write(path, ".png", diff_png_writer(comparison))


class _Unwanted(Exception):
    """Leaves a :func:`gshade.io.outputs.staged` block without writing its files."""


def compare_and_write_diffs(
    test: str | os.PathLike | RenderedImage | dict[str, NDArray],
    reference: str | os.PathLike | RenderedImage | dict[str, NDArray],
    *,
    channels: list[str] | tuple[str, ...] = ("R", "G", "B"),
    thresholds: Thresholds | None = None,
    diff: str | os.PathLike | None = None,
    diff_png: str | os.PathLike | None = None,
    only_if_not_pass: bool = False,
    ssim: bool | None = None,
) -> Comparison:
    """:func:`compare`, and the difference images ``diff`` (EXR) and ``diff_png`` (heat
    map): both or neither (with ``only_if_not_pass``, only when the verdict is not PASS).
    ``ssim`` is :func:`compare`'s; the differences are kept only for the images asked for.

    The targets' temporaries are created before the images are read: an unwritable target
    fails at once, and the targets change only once every file is written.

    Raises
    ------
    UsageError
        If ``diff`` and ``diff_png`` name the same file, or a target cannot be written
        (its folder is missing or read-only, ...): found before the images are read.
    ChannelMismatch, UnreadableImage
        As :func:`compare`.
    """
    targets = [Path(t) for t in (diff, diff_png) if t]
    if len(targets) == 2 and targets[0].absolute() == targets[1].absolute():
        raise UsageError(f"diff and diff_png: expected two different files, got {diff}")
    result, entered = None, False
    try:
        with staged(targets) as names:
            entered = True
            result = compare(
                test,
                reference,
                channels=channels,
                thresholds=thresholds,
                ssim=ssim,
                differences=bool(targets),
            )
            if only_if_not_pass and result.verdict == "PASS":
                raise _Unwanted
            writers = [diff_exr_writer(result, diff)] if diff else []
            writers += [diff_png_writer(result)] if diff_png else []
            for target, writer, name in zip(targets, writers, names, strict=True):
                write_to(name, writer, target)
    except _Unwanted:
        pass
    except GshadeError as exc:
        if entered:
            raise
        raise UsageError(str(exc)) from None  # a target that cannot be written
    assert result is not None  # compare() returned, or raised out of this function
    return result
