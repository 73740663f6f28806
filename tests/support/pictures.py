"""Checks on rendered pictures shared by the tests."""

from __future__ import annotations

import numpy as np
from scipy import ndimage


def silhouette_of(A: np.ndarray) -> np.ndarray:
    """The pixels not connected to the image border through uncovered pixels."""
    label, _ = ndimage.label(A == 0)
    edge = np.unique(np.concatenate([label[0], label[-1], label[:, 0], label[:, -1]]))
    return ~np.isin(label, edge[edge > 0])
