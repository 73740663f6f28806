"""EXR files written by the tests themselves (OpenEXR's own writer): images with a data
window away from the origin, inside a display window of their own."""

from __future__ import annotations

import numpy as np


def write_windowed(path, channels, origin=(0, 0), display=None):
    """An EXR whose data window starts at `origin` (x, y); display window (x0, y0, x1, y1),
    by default the data window's size at the origin."""
    import OpenEXR

    h, w = next(iter(channels.values())).shape
    x0, y0 = origin
    d = display or (0, 0, w - 1, h - 1)
    header = {
        "compression": OpenEXR.ZIPS_COMPRESSION,
        "type": OpenEXR.scanlineimage,
        "dataWindow": (np.array([x0, y0], np.int32), np.array([x0 + w - 1, y0 + h - 1], np.int32)),
        "displayWindow": (np.array(d[:2], np.int32), np.array(d[2:], np.int32)),
    }
    pixels = {k: np.ascontiguousarray(v, np.float32) for k, v in channels.items()}
    OpenEXR.File(header, pixels).write(str(path))
    return path
