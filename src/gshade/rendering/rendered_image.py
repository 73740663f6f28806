"""A rendered image: named channels (the EXR contract), metadata, and writers.

Channels (float32 arrays of shape (height, width)): ``R G B`` (the picture, linear, alpha
premultiplied), ``A`` (coverage 0-1), ``f`` (the shape function: mean over the pixel's
samples that hit the surface, 0 where none), ``P.X P.Y P.Z`` (world position) and
``N.X N.Y N.Z`` (exact unit normal, n = p_u x p_v / |p_u x p_v|) and ``u v`` (patch
parameters) at the pixel centre, ``patch`` (patch index at the pixel centre, -1 where none).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

import numpy as np
from numpy.typing import NDArray

from ..display import Legend

__all__ = ["CHANNELS", "RenderedImage"]

CHANNELS = (
    "R",
    "G",
    "B",
    "A",
    "f",
    "f.mean",
    "P.X",
    "P.Y",
    "P.Z",
    "N.X",
    "N.Y",
    "N.Z",
    "u",
    "v",
    "patch",
)


@dataclass
class RenderedImage:
    """Channels, header metadata (strings), the legend and the stage timings (seconds); the
    warnings (a CAD face left out, a line each) and notes (what the kernel's healing
    changed) to tell whoever asked for the render."""

    channels: dict[str, NDArray[np.float32]]
    metadata: dict[str, str]
    legend: Legend | None = None
    timings: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def shape(self) -> tuple[int, int]:
        return self.channels["R"].shape

    @property
    def rgb(self) -> NDArray[np.float32]:
        return np.stack([self.channels[c] for c in "RGB"], -1)

    @property
    def alpha(self) -> NDArray[np.float32]:
        return self.channels["A"]

    @property
    def straight_rgb(self) -> NDArray[np.float64]:
        """The picture not premultiplied by the coverage (for PNGs and figures)."""
        from ..io.image import straight_rgb  # OpenEXR loads with io.image: when first needed

        return straight_rgb(self.channels)

    def __getitem__(self, name: str) -> NDArray[np.float32]:
        return self.channels[name]

    def exr_writer(self, path: str | os.PathLike) -> Callable[[str], None]:
        """All channels (float32) and the metadata, checked now, as a function writing them to
        a file name given later (see :func:`gshade.io.image.exr_writer`)."""
        from ..io.image import exr_writer

        names = [*CHANNELS, *(k for k in self.channels if k not in CHANNELS)]  # f2, aovs
        return exr_writer(path, {k: self.channels[k] for k in names}, header=self.metadata)

    def png_writer(self, path: str | os.PathLike, legend: bool = False) -> Callable[[str], None]:
        """The picture as an sRGB PNG with alpha, as a function writing it to a file name
        given later; with ``legend``, its legend's strip below it
        (:func:`gshade.display.legend_strip.with_legend`)."""
        from ..io.image import png_writer

        rgb, alpha = self.straight_rgb, self.alpha
        if legend and self.legend is not None:
            from ..display.legend_strip import with_legend

            rgb, alpha = with_legend(rgb, alpha, self.legend)
        return png_writer(path, rgb, alpha)

    def write_exr(self, path: str | os.PathLike) -> None:
        """Write all channels (float32) and the metadata, atomically."""
        self.write(exr=path)

    def write_png(self, path: str | os.PathLike) -> None:
        """Write the picture as an sRGB PNG with alpha, atomically."""
        self.write(png=path)

    def write(
        self, exr: str | os.PathLike | None = None, png: str | os.PathLike | None = None
    ) -> None:
        """Write the EXR and / or the PNG: both are renamed onto their targets only when both
        were written (:func:`gshade.io.outputs.staged`)."""
        from ..io.outputs import staged, write_all

        writers = [(p, w) for p, w in ((exr, self.exr_writer), (png, self.png_writer)) if p]
        with staged([p for p, _ in writers]) as names:
            write_all(
                [(name, partial(w, p), p) for (p, w), name in zip(writers, names, strict=True)]
            )
