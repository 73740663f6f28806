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
from ..geometry.patch_cells import ManyPatches
from ..shape import ShapeFunction, evaluate
from ..shape.kernels import backend

__all__ = ["centre_values"]


def centre_values(
    channels: dict[str, NDArray[np.float32]],
    patches: list[Patch] | tuple[Patch, ...],
    functions: dict[str, tuple[ShapeFunction, dict]],
) -> dict[str, NDArray[np.float32]]:
    """Per channel name, its function's exact value at each pixel's centre hit.

    Parameters
    ----------
    channels : dict
        The exact channels (``patch``, ``u``, ``v``) of a render.
    patches : sequence of Patch
        The scene's patches, as the ``patch`` channel numbers them.
    functions : dict
        Channel name -> (shape function, its parameters).
    """
    shape = channels["patch"].shape
    patch = np.rint(channels["patch"]).astype(np.int64).ravel()
    hits = np.flatnonzero(patch >= 0)
    order = hits[np.argsort(patch[hits], kind="stable")]  # the hits, patch by patch
    out = {name: np.zeros(patch.size, dtype=np.float32) for name in functions}
    highest = max((fn.order for fn, _ in functions.values()), default=0)  # f needs order k
    u_all, v_all = channels["u"].ravel(), channels["v"].ravel()
    many = ManyPatches(patches, drjit=backend() == "drjit")
    domains = np.array([p.domain for p in patches], dtype=np.float64)
    for start in range(0, order.size, BLOCK):  # one evaluation of each function a block
        block = order[start : start + BLOCK]
        on = patch[block]
        lo, hi = domains[on, :, 0], domains[on, :, 1]
        u = np.clip(u_all[block].astype(np.float64), lo[:, 0], hi[:, 0])
        v = np.clip(v_all[block].astype(np.float64), lo[:, 1], hi[:, 1])
        d = many.derivatives(on, u, v, highest)
        if highest >= 1:
            _regularise(d, patches, on, u, v)
        for name, (fn, params) in functions.items():
            out[name][block] = evaluate(
                fn, d[: fn.order + 2, : fn.order + 2], gradient=False, **params
            ).f
    return {name: values.reshape(shape) for name, values in out.items()}


#: Centre hits per evaluation of the functions (bounds the derivatives' memory).
BLOCK = 1 << 18


def _regularise(d: NDArray, patches, on: NDArray, u: NDArray, v: NDArray) -> None:
    """Replace, in place, the derivatives of the patches ``on`` (sorted) that are irregular
    at some of their points by :func:`gshade.geometry.regularised_derivatives` (each patch
    on its own scale, limits from inside)."""
    order = d.shape[0] - 1
    for at in np.split(np.arange(on.size), np.flatnonzero(np.diff(on)) + 1):
        if at.size and irregular_mask(d[:, :, at]).any():
            p = patches[int(on[at[0]])]
            d[:, :, at] = regularised_derivatives(p, u[at], v[at], order).d
