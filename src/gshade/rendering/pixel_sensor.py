"""A Mitsuba sensor that renders a list of another sensor's pixels.

``gshade_pixels`` (:data:`PIXELS_PLUGIN`, registered with Mitsuba by name) has a film of
virtual pixels, one per listed pixel of the camera: a sample at (k + o) of virtual pixel k
becomes the camera's ray through (col_k + o, row_k + o).  With the camera's sampler, a
render of it gives exactly the listed pixels of a render of the whole camera film (the same
strata, rays and ray differentials, scaled by 1/sqrt(spp) as Mitsuba does), in the order
listed: the supersampling pass renders only the pixels where the picture needs it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..runtime.variant import mitsuba

__all__ = ["PIXELS_PLUGIN", "PixelSensor", "pixel_list_sensor"]

PIXELS_PLUGIN = "gshade_pixels"


def pixel_list_sensor(
    camera: Any, pixels: NDArray[np.int64], width: int, height: int, sampler: dict
) -> Any:
    """A sensor whose film's first ``len(pixels)`` pixels (row-major) are ``pixels`` (flat
    indices, row-major, into the ``camera``'s ``width`` x ``height`` film), sampled by
    ``sampler`` (a Mitsuba dict)."""
    mi = mitsuba()
    n = len(pixels)
    # a square film: both coordinates below sqrt(n) <= 2^14 (at most 2^28 pixels listed), so
    # a float32 film position keeps a sample's place to 2^-10 of a pixel or better
    columns = int(np.ceil(np.sqrt(n)))
    sensor = mi.load_dict(
        {
            "type": PIXELS_PLUGIN,
            "film": {
                "type": "hdrfilm",
                "width": columns,
                "height": -(-n // columns),
                "rfilter": {"type": "box"},
                "pixel_format": "rgba",
            },
            "sampler": sampler,
        }
    )
    sensor.aim(camera, pixels % width, pixels // width, (width, height))
    return sensor


class PixelSensor:
    """Virtual pixel k is the camera's pixel (rows[k], cols[k]).

    The methods of ``gshade_pixels``, put on the active variant's ``mi.Sensor`` with the
    variant's parts ``mi``, ``dr`` and ``scalar`` by
    :func:`gshade.rendering.plugins.variant_class`.
    """

    mi: Any
    dr: Any
    scalar: bool
    film: Callable[[], Any]  # mi.Sensor's
    #: how many pixels are listed (none until :meth:`aim`)
    count = 0

    def aim(self, camera: Any, cols: NDArray, rows: NDArray, size: tuple[int, int]) -> None:
        """List the pixels (cols[k], rows[k]) of ``camera``'s film of ``size`` (width,
        height)."""
        self.camera, self.count = camera, len(cols)
        self.inv_size = (1.0 / size[0], 1.0 / size[1])
        if self.scalar:
            self.cols, self.rows = cols.tolist(), rows.tolist()
        else:  # exact in float32: image sides are at most 2^24
            self.cols, self.rows = self.mi.Float(cols), self.mi.Float(rows)

    def _camera_position(self, position: Any) -> Any:
        """The camera's film position (in [0, 1]^2) of a position on this film."""
        mi, dr = self.mi, self.dr
        size = self.film().crop_size()
        at = mi.Vector2f(position.x * size.x, position.y * size.y)
        pixel = dr.floor(at)
        offset = at - pixel
        k = mi.UInt32(pixel.y) * size.x + mi.UInt32(pixel.x)
        if self.scalar:
            k = min(int(k), self.count - 1)
            col, row = self.cols[k], self.rows[k]
        else:
            k = dr.minimum(k, self.count - 1)
            col, row = dr.gather(mi.Float, self.cols, k), dr.gather(mi.Float, self.rows, k)
        return mi.Point2f((col + offset.x) * self.inv_size[0], (row + offset.y) * self.inv_size[1])

    def sample_ray_differential(
        self, time: Any, sample1: Any, sample2: Any, sample3: Any, active: Any = True
    ) -> Any:
        """The camera's ray (with differentials) through the listed pixel's sample."""
        position = self._camera_position(sample2)
        return self.camera.sample_ray_differential(time, sample1, position, sample3, active)

    def sample_ray(
        self, time: Any, sample1: Any, sample2: Any, sample3: Any, active: Any = True
    ) -> Any:
        """The camera's ray through the listed pixel's sample."""
        position = self._camera_position(sample2)
        return self.camera.sample_ray(time, sample1, position, sample3, active)

    def bbox(self) -> Any:
        return self.camera.bbox()

    def to_string(self) -> str:
        return f"PixelSensor[{self.count} pixels]"
