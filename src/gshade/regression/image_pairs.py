"""Two images on one pixel grid, as ``gshade compare`` reads them: EXR paths, rendered
images or dicts of channels, their data windows placed within the same display window (the
union of the data windows, 0 outside an image's own, as OpenImageIO's idiff does).

:func:`aligned_planes` keeps each channel in its stored type (float16, float32 or float64:
the same values as float64, in less memory); :func:`aligned_channels` makes them float64."""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from ..io.image import ExrWindow

if TYPE_CHECKING:
    from ..rendering.rendered_image import RenderedImage

__all__ = [
    "ChannelMismatch",
    "LoadedImage",
    "UnreadableImage",
    "aligned_channels",
    "aligned_planes",
    "load_channels",
    "load_image",
]


class ChannelMismatch(GshadeError):
    """The images differ in size, or a compared channel is missing."""


class UnreadableImage(GshadeError):
    """An image file could not be read."""


def load_channels(
    image: str | os.PathLike | RenderedImage | dict[str, NDArray],
) -> tuple[dict[str, NDArray], str]:
    """Channels of a path (EXR), a :class:`~gshade.rendering.rendered_image.RenderedImage`
    or a dict of arrays."""
    loaded = load_image(image)
    return loaded.channels, loaded.name


@dataclass
class LoadedImage:
    channels: dict[str, NDArray]
    name: str
    #: an EXR's data and display windows; None for arrays (both at the origin)
    data: ExrWindow | None = None
    display: ExrWindow | None = None


def load_image(
    image: str | os.PathLike | RenderedImage | dict[str, NDArray], *, half: bool = False
) -> LoadedImage:
    """An EXR path, a rendered image or a dict of arrays as a :class:`LoadedImage`; an EXR's
    channels as float32 arrays, or with ``half`` its HALF channels as float16 ones."""
    if isinstance(image, (str, os.PathLike)):
        from ..io.image import read_exr_planes, read_exr_windows

        try:
            if half:
                planes, _, data, display = read_exr_planes(image)
                return LoadedImage(dict(planes), str(image), data, display)
            channels, _, data, display = read_exr_windows(image)
        except GshadeError as exc:
            raise UnreadableImage(str(exc)) from None
        return LoadedImage(dict(channels), str(image), data, display)
    if hasattr(image, "channels"):
        return LoadedImage(dict(image.channels), "<image>")
    if isinstance(image, dict):
        return LoadedImage(image, "<channels>")
    raise GshadeError(f"image: expected an EXR path, an image or a dict of channels, got {image!r}")


def aligned_channels(
    test: LoadedImage, reference: LoadedImage, channels: list[str]
) -> tuple[dict[str, NDArray[np.float64]], dict[str, NDArray[np.float64]], ExrWindow, ExrWindow]:
    """Both images' ``channels`` as float64 arrays over the same pixels: the union of their
    data windows (0 outside an image's own), and that window and the display window.

    Raises :class:`ChannelMismatch` for a missing channel, channels of different sizes or
    different display windows."""
    a, b, region, display = aligned_planes(test, reference, channels)
    return (
        {c: np.asarray(p, dtype=np.float64) for c, p in a.items()},
        {c: np.asarray(p, dtype=np.float64) for c, p in b.items()},
        region,
        display,
    )


def aligned_planes(
    test: LoadedImage, reference: LoadedImage, channels: list[str]
) -> tuple[dict[str, NDArray], dict[str, NDArray], ExrWindow, ExrWindow]:
    """:func:`aligned_channels`, the arrays C-contiguous in their own type where it is
    float16, float32 or float64 (else float64)."""
    windows = []
    for image in (test, reference):
        missing = [c for c in channels if c not in image.channels]
        if missing:
            raise ChannelMismatch(
                f"{image.name}: expected channel(s) {', '.join(missing)}, found "
                f"{', '.join(sorted(image.channels)) or 'none'}"
            )
        shape = np.shape(image.channels[channels[0]])
        if len(shape) != 2:
            raise ChannelMismatch(
                f"{image.name}: channel {channels[0]!r}: expected a 2-D array (height, width), "
                f"got shape {shape}"
            )
        for c in channels[1:]:
            if np.shape(image.channels[c]) != shape:
                other = np.shape(image.channels[c])
                raise ChannelMismatch(
                    f"{image.name}: channel {c!r}: expected the size {shape[1]}x{shape[0]} of "
                    f"channel {channels[0]!r}, got {_size(other)}"
                )
        data = image.data or ExrWindow.of_shape(shape)
        windows.append((data, image.display or data))
    (data_a, display_a), (data_b, display_b) = windows
    if display_a != display_b:
        if (display_a.width, display_a.height) != (display_b.width, display_b.height):
            raise ChannelMismatch(
                f"{test.name}: expected the reference's size {display_b.width}x"
                f"{display_b.height}, got {display_a.width}x{display_a.height}"
            )
        raise ChannelMismatch(
            f"{test.name}: expected the reference's display window {display_b}, got "
            f"{display_a} (the same size, placed elsewhere)"
        )
    region = ExrWindow(
        min(data_a.x_min, data_b.x_min),
        min(data_a.y_min, data_b.y_min),
        max(data_a.x_max, data_b.x_max),
        max(data_a.y_max, data_b.y_max),
    )
    area = max(
        display_a.width * display_a.height,
        data_a.width * data_a.height + data_b.width * data_b.height,
    )
    if region.width * region.height > 4 * area:  # hostile windows: no giant allocation
        raise ChannelMismatch(
            f"{test.name}: expected data windows near the reference's {data_b} (both within "
            f"or near the display window {display_a}), got {data_a}: comparing them would "
            f"take {region.width}x{region.height} pixels"
        )
    out = []
    for image, (data, _) in zip((test, reference), windows, strict=True):
        planes = {}
        for c in channels:
            plane = np.asarray(image.channels[c])
            if plane.dtype not in _KEPT:
                plane = plane.astype(np.float64)
            if data != region:
                placed = np.zeros((region.height, region.width), plane.dtype)
                y, x = data.y_min - region.y_min, data.x_min - region.x_min
                placed[y : y + data.height, x : x + data.width] = plane
                plane = placed
            planes[c] = np.ascontiguousarray(plane)
        out.append(planes)
    return out[0], out[1], region, display_a


#: The types that :func:`aligned_planes` keeps: exactly float64 once subtracted in float64.
_KEPT = (np.dtype(np.float16), np.dtype(np.float32), np.dtype(np.float64))


def _size(shape: tuple[int, ...]) -> str:
    return f"{shape[1]}x{shape[0]}" if len(shape) == 2 else f"shape {shape}"
