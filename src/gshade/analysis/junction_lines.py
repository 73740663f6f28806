"""Junction lines: the patch junctions drawn over a rendered picture, coloured by class.

Every junction found by :func:`gshade.analysis.continuity.continuity_report` is drawn as an
anti-aliased line of constant screen width along the shared edge, on each side that is
visible.  The line is found from the image's own exact data channels, not from a
projection of the edge: at a pixel of patch i, the distance to its edge u = u0 in pixels is
|u - u0| / |grad_screen u|, with the screen gradient of u from differences of the ``u``
channel inside patch i.  So the line sits where the surface's edge is, occluded where the
surface hides it.  Only R, G and B change; f, A and the geometric channels stay exact.
"""

from __future__ import annotations

import json

import numpy as np
from numpy.typing import NDArray

from .continuity import Junction

__all__ = ["CLASS_COLOURS", "draw_junctions", "junction_metadata"]

#: Linear RGB of each class, as in the legend: G0 red ... G3 blue; "none" magenta.
CLASS_COLOURS = {
    "none": (0.75, 0.0, 0.75),
    "G0": (0.85, 0.03, 0.03),
    "G1": (1.0, 0.42, 0.0),
    "G2": (0.05, 0.6, 0.1),
    "G3": (0.05, 0.25, 1.0),
}


def _screen_gradient(x: NDArray, patch: NDArray) -> NDArray:
    """|grad x| per pixel (per pixel width), from differences between pixels of the same
    patch: central where both neighbours share the patch, one-sided where one does."""
    norm2 = np.zeros(x.shape)
    for axis in (0, 1):
        fwd = np.zeros(x.shape)
        bwd = np.zeros(x.shape)
        n_fwd = np.zeros(x.shape, bool)
        n_bwd = np.zeros(x.shape, bool)
        lo = [slice(None)] * 2
        hi = [slice(None)] * 2
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        below, above = tuple(lo), tuple(hi)
        same = (patch[below] == patch[above]) & (patch[below] >= 0)
        step = np.where(same, x[above] - x[below], 0.0)
        fwd[below], n_fwd[below] = step, same
        bwd[above], n_bwd[above] = step, same
        count = n_fwd.astype(float) + n_bwd
        derivative = (fwd + bwd) / np.maximum(count, 1.0)
        norm2 += derivative**2
    return np.sqrt(norm2)


def draw_junctions(
    channels: dict[str, NDArray[np.float32]],
    junctions: list[Junction],
    domains: list[tuple[tuple[float, float], tuple[float, float]]],
    width: float = 2.0,
) -> dict[str, NDArray[np.float32]]:
    """Channels with the junctions drawn into R, G, B (new arrays; the others as given).

    Parameters
    ----------
    channels : dict
        An image's channels: R G B A u v patch (as :func:`gshade.render` returns them).
    junctions : list of Junction
        From :func:`gshade.analysis.continuity.continuity_report` on the same patches.
    domains : list
        Each patch's parameter domain ((u0, u1), (v0, v1)).
    width : float
        Line width in pixels (half of it on each side of the edge).
    """
    patch = np.rint(channels["patch"]).astype(np.int64)
    params = {"u": channels["u"].astype(np.float64), "v": channels["v"].astype(np.float64)}
    gradients = {name: _screen_gradient(x, patch) for name, x in params.items()}
    coverage = {cls: np.zeros(patch.shape) for cls in CLASS_COLOURS}
    for junction in junctions:
        for k, side in zip(junction.patches, junction.sides, strict=True):
            name = side[0]
            (u0, u1), (v0, v1) = domains[k]
            edge = {"u0": u0, "u1": u1, "v0": v0, "v1": v1}[side]
            on = patch == k
            if not on.any():
                continue
            g = gradients[name][on]
            distance = np.where(
                g > 0, np.abs(params[name][on] - edge) / np.where(g > 0, g, 1.0), np.inf
            )
            # the line's coverage of the pixel: its half width on this side, box-filtered
            c = np.clip(0.5 * width + 0.5 - distance, 0.0, 1.0)
            acc = coverage[junction.cls]
            acc[on] = np.maximum(acc[on], c)
    out = dict(channels)
    rgb = np.stack([channels[c] for c in "RGB"], -1).astype(np.float64)
    alpha = channels["A"].astype(np.float64)[..., None]
    for cls in reversed(CLASS_COLOURS):  # the weakest junctions drawn last, on top
        c = coverage[cls][..., None]
        rgb = rgb * (1.0 - c) + np.asarray(CLASS_COLOURS[cls]) * c * alpha
    for i, name in enumerate("RGB"):
        out[name] = rgb[..., i].astype(np.float32)
    return out


def junction_metadata(junctions: list[Junction]) -> str:
    """The drawn junctions and the colour legend, as JSON for the image header."""
    return json.dumps(
        {
            "colours": {k: list(v) for k, v in CLASS_COLOURS.items()},
            "junctions": [
                {"patches": list(j.patches), "sides": list(j.sides), "class": j.cls}
                for j in junctions
            ],
        },
        sort_keys=True,
    )
