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
from ..geometry.core.differential import derivative_scales
from ..shape import ShapeFunction, evaluate

__all__ = ["centre_values", "highest_order"]


def centre_values(
    patches: list[Patch] | tuple[Patch, ...],
    index: NDArray,
    u: NDArray,
    v: NDArray,
    d: NDArray,
    functions: dict[str, tuple[ShapeFunction, dict]],
) -> dict[str, NDArray[np.float64]]:
    """Per channel name, its function's exact value at each centre hit.

    Parameters
    ----------
    patches : sequence of Patch
        The scene's patches, as ``index`` numbers them.
    index, u, v : ndarray, shape (N,)
        Each hit's patch (sorted, best: a patch's hits side by side) and parameters.
    d : ndarray, shape (k + 1, k + 1, N, 3)
        The patches' derivatives there, of orders up to the functions' highest order k (at
        least 1); replaced in place by their regularised limits at irregular points.
    functions : dict
        Channel name -> (shape function, its parameters).
    """
    if d.shape[0] > 1:
        _regularise(d, patches, np.asarray(index), u, v)
    return {
        name: evaluate(fn, d[: fn.order + 2, : fn.order + 2], gradient=False, **params).f
        for name, (fn, params) in functions.items()
    }


def highest_order(functions: dict[str, tuple[ShapeFunction, dict]]) -> int:
    """The derivatives' order the functions need at the hits: their highest, at least 1."""
    return max([1, *(fn.order for fn, _ in functions.values())])


def _regularise(
    d: NDArray,
    patches: list[Patch] | tuple[Patch, ...],
    on: NDArray,
    u: NDArray,
    v: NDArray,
) -> None:
    """Replace, in place, the derivatives of the patches ``on`` that are irregular
    at some of their points by :func:`gshade.geometry.regularised_derivatives` (each patch
    on its own scale, limits from inside)."""
    order = d.shape[0] - 1
    irregular = irregular_mask(d, scale=derivative_scales(d, on))
    for k in np.unique(on[irregular]):
        at = np.flatnonzero(on == k)
        d[:, :, at] = regularised_derivatives(patches[int(k)], u[at], v[at], order).d
