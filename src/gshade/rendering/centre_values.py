"""Shape functions' exact values at each pixel's centre hit: the point P, N, u, v describe.

The picture's colour is the mean over the pixel's samples of the (interpolated) function;
the data channels are exact at the point where the ray through the pixel centre meets the
surface.  Here every function asked for is evaluated there, from the patch's exact
derivatives at (patch, u, v) (Kiciak, ch. 6: shape functions of order k need derivatives
of order k; at collapsed edges their regularised limits): ``f`` for the striped (or only)
function, ``f2`` for the colour-mapped one of
``display = "both"``, and one channel per ``render.aovs`` name.  Pixels whose centre ray
meets no surface hold 0.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..geometry import Patch, irregular_mask, regularised_derivatives
from ..shape import ShapeFunction, evaluate
from .channels import CentreHits

__all__ = ["centre_values"]


def centre_values(
    hits: CentreHits,
    patches: list[Patch] | tuple[Patch, ...],
    functions: dict[str, tuple[ShapeFunction, dict]],
) -> dict[str, NDArray[np.float32]]:
    """Per channel name, its function's exact value at each pixel's centre hit.

    Parameters
    ----------
    hits : CentreHits
        The render's exact centre hits (:func:`gshade.rendering.channels.centre_hits`),
        with derivatives up to the functions' highest order.
    patches : sequence of Patch
        The scene's patches, as the hits number them.
    functions : dict
        Channel name -> (shape function, its parameters).
    """
    H, W = hits.shape
    out = {name: np.zeros(H * W, dtype=np.float32) for name in functions}
    highest = max((fn.order for fn, _ in functions.values()), default=0)  # f needs order k
    if highest > hits.order:
        raise ValueError(f"hits: derivatives up to order {highest} needed, got {hits.order}")
    d = hits.derivatives[: max(highest, 1) + 1, : max(highest, 1) + 1]
    if highest >= 1:  # irregular points: each patch on its own scale, limits from inside
        by_patch = np.argsort(hits.patch, kind="stable")
        bounds = np.flatnonzero(np.diff(hits.patch[by_patch])) + 1
        for at in np.split(by_patch, bounds):
            if at.size and irregular_mask(d[:, :, at]).any():
                p = patches[int(hits.patch[at[0]])]
                d[:, :, at] = regularised_derivatives(p, hits.u[at], hits.v[at], highest).d
    for start in range(0, hits.pixels.size, BLOCK):  # one evaluation of each function a block
        block = slice(start, start + BLOCK)
        for name, (fn, params) in functions.items():
            out[name][hits.pixels[block]] = evaluate(
                fn, d[: fn.order + 2, : fn.order + 2, block], gradient=False, **params
            ).f
    return {name: values.reshape(H, W) for name, values in out.items()}


#: Centre hits per evaluation of the functions (bounds the derivatives' memory).
BLOCK = 1 << 18
