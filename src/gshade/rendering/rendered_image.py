"""A rendered image: named channels (the EXR contract), metadata, and writers.

Channels (float32 arrays of shape (height, width)): ``R G B`` (the picture, linear, alpha
premultiplied), ``A`` (coverage 0-1), ``f`` (the shape function's exact value where the ray
through the pixel centre meets the surface), ``f.mean`` (its mean over the pixel's samples
that hit the surface), ``P.X P.Y P.Z`` (world position) and ``N.X N.Y N.Z`` (exact unit
normal, n = p_u x p_v / |p_u x p_v|) and ``u v`` (patch parameters) at that centre hit,
``patch`` (patch index there, -1 where none).  Where the centre ray meets no surface,
``f``, ``P``, ``N``, ``u`` and ``v`` hold 0 (``f.mean`` 0 where no sample hit).
"""

from __future__ import annotations

import html
import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

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
    changed) to tell whoever asked for the render.

    ``image["u"]`` is a channel; :attr:`f`, :attr:`P`, :attr:`N`, :attr:`rgb` (linear, as
    the EXR), :attr:`srgb` and :attr:`srgba` (the picture as the PNG shows it) are numpy
    arrays; Jupyter shows the image as the page ``gshade render --html`` writes (or as the
    PNG)."""

    channels: dict[str, NDArray[np.float32]]
    metadata: dict[str, str]
    legend: Legend | None = None
    timings: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def shape(self) -> tuple[int, int]:
        """(height, width) in pixels."""
        return self.channels["R"].shape

    @property
    def f(self) -> NDArray[np.float32]:
        """The shape function at the pixel centres, shape (height, width): channel ``f``,
        exact where the centre ray meets the surface, 0 where it meets none (``patch``
        -1 there)."""
        return self.channels["f"]

    @property
    def P(self) -> NDArray[np.float32]:
        """The surface points at the pixel centres, shape (height, width, 3): channels
        ``P.X P.Y P.Z``, world coordinates; 0 where the centre ray meets no surface
        (``patch`` -1 there)."""
        return np.stack([self.channels[f"P.{axis}"] for axis in "XYZ"], -1)

    @property
    def N(self) -> NDArray[np.float32]:
        """The unit normals at the pixel centres, shape (height, width, 3): channels
        ``N.X N.Y N.Z``, p_u x p_v / |p_u x p_v| of the surface's patch; 0 where the centre
        ray meets no surface (``patch`` -1 there)."""
        return np.stack([self.channels[f"N.{axis}"] for axis in "XYZ"], -1)

    @property
    def rgb(self) -> NDArray[np.float32]:
        """Channels ``R G B`` as the EXR holds them, shape (height, width, 3): linear,
        premultiplied by the coverage :attr:`alpha`.  The picture as the PNG shows it is
        :attr:`srgb`."""
        return np.stack([self.channels[c] for c in "RGB"], -1)

    @property
    def srgba(self) -> NDArray[np.uint8]:
        """The PNG's pixels, shape (height, width, 4): 8-bit sRGB colour, not premultiplied
        (:func:`gshade.io.image.srgb8` of :attr:`straight_rgb`), and the coverage
        :attr:`alpha` linearly, as :meth:`write_png` writes them:
        ``matplotlib.pyplot.imshow(image.srgba)`` shows the picture on the page."""
        from ..io.image import srgb8  # OpenEXR loads with io.image: when first needed

        return srgb8(self.straight_rgb, self.alpha)

    @property
    def srgb(self) -> NDArray[np.float32]:
        """The picture's colours as the PNG shows them, shape (height, width, 3): the codes
        of :attr:`srgba` / 255, floats in [0, 1]; 0 (black) where no surface covers the
        pixel (the PNG is transparent there)."""
        return (self.srgba[..., :3] / np.float32(255)).astype(np.float32)

    @property
    def alpha(self) -> NDArray[np.float32]:
        """Channel ``A``: the coverage, 0 to 1."""
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

    def _repr_png_(self) -> bytes:
        """The PNG :meth:`write_png` writes, as bytes (Jupyter shows it)."""
        with tempfile.TemporaryDirectory(prefix="gshade-") as folder:
            path = Path(folder) / "picture.png"
            self.png_writer(path)(str(path))
            return path.read_bytes()

    def _repr_html_(self) -> str:
        """The page ``gshade render --html`` writes, in an iframe (``srcdoc``) for Jupyter:
        zoom, every channel under the cursor, false colours
        (:func:`gshade.display.html_view.view_page`), the image labelled as the command
        labels it, by the EXR's default name (``SCENE_NAME.exr``).  Every channel is
        embedded bit for bit: a large image makes a large cell (megabytes)."""
        from ..display.html_view import view_page

        label = f"{self.metadata.get('scene_name', 'image')}.exr"
        page = view_page([(self.channels, self.metadata)], labels=[label])
        height = min(max(self.shape[0] + 160, 480), 900)
        return (
            f'<iframe srcdoc="{html.escape(page, quote=True)}" width="100%" '
            f'height="{height}" style="border: 0" title="{html.escape(label, quote=True)}">'
            "</iframe>"
        )
