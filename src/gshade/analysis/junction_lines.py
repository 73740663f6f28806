"""Junction lines: the patch junctions drawn over a rendered picture, coloured by class.

Every junction found by :func:`gshade.analysis.continuity.continuity_report` is drawn as an
anti-aliased line of constant screen width along the shared edge, on each side that is
visible (a B-spline patch's interior knot line, :mod:`gshade.analysis.knot_lines`, along
u = u* on its own patch).  The line is found from the image's own exact data channels, not from a
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
from .edge_continuity import EdgeLine

__all__ = ["CLASS_COLOURS", "DECIDING", "deciding_place", "draw_junctions", "junction_metadata"]

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
    dx, dy = _screen_derivatives(x, patch)
    return np.sqrt(dx**2 + dy**2)


def _screen_derivatives(x: NDArray, patch: NDArray) -> tuple[NDArray, NDArray]:
    """dx/d(column) and dx/d(row) per pixel, as :func:`_screen_gradient` takes them."""
    out = []
    for axis in (1, 0):
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
        out.append((fwd + bwd) / np.maximum(count, 1.0))
    return out[0], out[1]


def draw_junctions(
    channels: dict[str, NDArray[np.float32]],
    junctions: list[Junction],
    domains: list[tuple[tuple[float, float], tuple[float, float]]],
    width: float = 2.0,
    edges: list[EdgeLine] | None = None,
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
    edges : list of EdgeLine, optional
        B-rep edges (:func:`gshade.analysis.scene_junctions.scene_continuity`): each drawn
        along its parameter curves on its faces' pixels, at the pixel distance
        |J^-1 (c - (u, v))| to the nearest point c of the curve, J = d(u, v)/d(pixel) from
        the ``u`` and ``v`` channels; the junctions with ``edge`` set are drawn this way.
    """
    patch = np.rint(channels["patch"]).astype(np.int64)
    params = {"u": channels["u"].astype(np.float64), "v": channels["v"].astype(np.float64)}
    gradients = {name: _screen_gradient(x, patch) for name, x in params.items()}
    coverage = {cls: np.zeros(patch.shape) for cls in CLASS_COLOURS}
    for junction in junctions:
        for k, name, edge in _iso_lines(junction, domains):
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
    if edges:
        _draw_edges(coverage, edges, params, patch, len(domains), width)
    out = dict(channels)
    rgb = np.stack([channels[c] for c in "RGB"], -1).astype(np.float64)
    alpha = channels["A"].astype(np.float64)[..., None]
    for cls in reversed(CLASS_COLOURS):  # the weakest junctions drawn last, on top
        c = coverage[cls][..., None]
        rgb = rgb * (1.0 - c) + np.asarray(CLASS_COLOURS[cls]) * c * alpha
    for i, name in enumerate("RGB"):
        out[name] = rgb[..., i].astype(np.float32)
    return out


def _draw_edges(
    coverage: dict, edges: list[EdgeLine], params: dict, patch: NDArray, patches: int, width: float
) -> None:
    """Draw ``edges`` into ``coverage`` (per class, in place) along their parameter curves
    on their faces' pixels (see :func:`draw_junctions`), in time proportional to the pixels
    near each curve's box: a face's pixels sorted by u once, each curve's found by
    bisection, then those within reach."""
    jacobian = (*_screen_derivatives(params["u"], patch), *_screen_derivatives(params["v"], patch))
    flat_patch = patch.ravel()
    by_patch = np.argsort(flat_patch, kind="stable")
    starts = np.searchsorted(flat_patch[by_patch], np.arange(patches + 1))
    faces: dict[int, tuple] = {}
    for line in edges:
        flat: NDArray = coverage[line.cls].reshape(-1)  # a view: written through
        for k, curve in line.curves:
            if k not in faces:  # the face's pixels by u, their (u, v), J and scale, once
                pixels = by_patch[starts[k] : starts[k + 1]]
                pixels = pixels[np.argsort(params["u"].ravel()[pixels], kind="stable")]
                J = [x.ravel()[pixels] for x in jacobian]
                uv = np.stack([params["u"].ravel()[pixels], params["v"].ravel()[pixels]], -1)
                scale = _uv_per_pixel(J)
                faces[k] = (pixels, uv, J, scale, _stretch(J, scale))
            pixels, uv, J, scale, stretch = faces[k]
            if not pixels.size:
                continue
            # only the pixels the line can cover: within the farthest reach of the curve's
            # box, then each within its own
            box = float(_reach(stretch.max(initial=0.0), curve, width, scale)) * scale
            lo, hi = curve.min(axis=0) - box, curve.max(axis=0) + box
            first = int(np.searchsorted(uv[:, 0], lo[0], side="left"))
            last = int(np.searchsorted(uv[:, 0], hi[0], side="right"))
            v = uv[first:last, 1]
            near = first + np.flatnonzero((v >= lo[1]) & (v <= hi[1]))
            if not near.size:
                continue
            reach = _reach(stretch[near], curve, width, scale)
            distance = _curve_distance(uv[near], [x[near] for x in J], curve, reach, scale)
            at = pixels[near]
            flat[at] = np.maximum(flat[at], np.clip(0.5 * width + 0.5 - distance, 0.0, 1.0))


def _iso_lines(junction: Junction, domains: list) -> list[tuple[int, str, float]]:
    """The iso-parameter lines (patch, "u" or "v", value) that draw a junction: its two
    sides, or a scene patch's knot line; none for a B-rep edge or a CAD face's knot line
    (drawn from ``edges``)."""
    line = junction.knot
    if line is not None:
        return [(junction.patches[0], line.direction, line.knot)] if line.on == "patch" else []
    if junction.sides is None:
        return []
    out = []
    for k, side in zip(junction.patches, junction.sides, strict=True):
        (u0, u1), (v0, v1) = domains[k]
        out.append((k, side[0], {"u0": u0, "u1": u1, "v0": v0, "v1": v1}[side]))
    return out


#: The search for a pixel's nearest curve points reaches this many line widths plus pixels.
SEARCH_WIDTHS, SEARCH_PIXELS = 4.0, 8.0


def _uv_per_pixel(J: list[NDArray]) -> NDArray:
    """A face's (u, v) per pixel: the medians of |(u_x, u_y)| and |(v_x, v_y)| over its
    pixels (1 where none), the scale in which :func:`_curve_distance` searches."""
    ux, uy, vx, vy = J
    ok = np.abs(ux * vy - uy * vx) > 0
    scale = np.array(
        [
            np.median(np.hypot(ux, uy)[ok]) if ok.any() else 1.0,
            np.median(np.hypot(vx, vy)[ok]) if ok.any() else 1.0,
        ]
    )
    return np.where(scale > 0, scale, 1.0)


def _curve_distance(
    uv: NDArray, J: list[NDArray], curve: NDArray, reach: NDArray, scale: NDArray
) -> NDArray:
    """Pixel distance from each pixel (its (u, v), its Jacobian [[u_x, u_y], [v_x, v_y]])
    to the polyline ``curve`` (m, 2) in (u, v): the nearest of the segments at the pixel's
    few nearest curve points (searched in (u, v) / ``scale``, about a pixel a unit), each
    mapped to pixels by J^-1; inf where no point lies within the pixel's ``reach``
    (:func:`_reach`)."""
    from scipy.spatial import cKDTree

    ux, uy, vx, vy = J
    det = ux * vy - uy * vx
    ok = np.abs(det) > 0
    safe = np.where(ok, det, 1.0)
    inverse = np.stack([vy / safe, -uy / safe, -vx / safe, ux / safe], -1)  # J^-1, row-major
    k = min(4, len(curve))
    bound = float(reach.max()) if reach.size else 0.0
    found = cKDTree(curve / scale).query(uv / scale, k=k, distance_upper_bound=bound)
    dist = np.reshape(found[0], (len(uv), k))
    index = np.reshape(found[1], (len(uv), k))
    best = np.full(len(uv), np.inf)
    near = ok & (dist[:, 0] <= reach)
    if not near.any():
        return best
    m = len(curve)
    i = index[near]  # (n, k): the nearest points, m where fewer lie within the bound
    # the curve points before, at and after each, in pixels from the pixel: (3, n, k, 2)
    P = np.stack(
        [
            _to_pixels(inverse[near], curve[np.clip(i + j, 0, m - 1)] - uv[near, None])
            for j in (-1, 0, 1)
        ]
    )
    A, AB = P[:2], P[1:] - P[:2]  # the segments before and after each point
    length2 = np.sum(AB * AB, -1)
    t = np.clip(-np.sum(A * AB, -1) / np.where(length2 > 0, length2, 1.0), 0.0, 1.0)
    d = np.linalg.norm(A + t[..., None] * AB, axis=-1)
    best[near] = np.where(i < m, d, np.inf).min(axis=(0, 2))
    return best


def _stretch(J: list[NDArray], scale: NDArray) -> NDArray:
    """Per pixel, the largest singular value of J / ``scale``: how far, at most, one pixel
    reaches in the scaled (u, v) that :func:`_curve_distance` searches in."""
    su, sv = scale
    ux, uy, vx, vy = J[0] / su, J[1] / su, J[2] / sv, J[3] / sv
    frobenius = ux * ux + uy * uy + vx * vx + vy * vy
    det = ux * vy - uy * vx
    return np.sqrt(0.5 * (frobenius + np.sqrt(np.maximum(frobenius**2 - 4 * det * det, 0))))


def _reach(stretch: NDArray, curve: NDArray, width: float, scale: NDArray) -> NDArray:
    """Per pixel, how far (in the scaled (u, v)) the curve point nearest to it can lie
    when the line covers it: a curve point within 0.5 width + 0.5 pixels lies within that
    times the pixel's ``stretch`` (:func:`_stretch`), a curve vertex within half a segment
    more.  Pixels farther off are left uncovered, which changes no pixel; no reach exceeds
    the search's bound (:data:`SEARCH_WIDTHS`, :data:`SEARCH_PIXELS`)."""
    step = np.linalg.norm(np.diff(curve, axis=0) / scale, axis=1)
    half_segment = 0.5 * float(step.max()) if step.size else 0.0
    reach = (0.5 * width + 0.5) * stretch * (1 + 1e-9) + half_segment
    return np.minimum(reach, SEARCH_WIDTHS * width + SEARCH_PIXELS)


def _to_pixels(inverse: NDArray, duv: NDArray) -> NDArray:
    """J^-1 (du, dv) for each row (inverse row-major (n, 4), duv (n, ..., 2))."""
    inverse = inverse.reshape(inverse.shape[:1] + (1,) * (duv.ndim - 2) + (4,))
    return np.stack(
        [
            inverse[..., 0] * duv[..., 0] + inverse[..., 1] * duv[..., 1],
            inverse[..., 2] * duv[..., 0] + inverse[..., 3] * duv[..., 1],
        ],
        -1,
    )


def junction_metadata(junctions: list[Junction]) -> str:
    """The drawn junctions (patches and sides, or faces and edge; class and measures) and the
    colour legend, as JSON for the image header."""
    return json.dumps(
        {
            "colours": {k: list(v) for k, v in CLASS_COLOURS.items()},
            "junctions": [_drawn(j) for j in junctions],
        },
        sort_keys=True,
    )


#: The measures each junction carries in the header (those of ``gshade continuity``).
MEASURES = ("gap", "normal_angle_deg", "curvature_jump", "curvature_gradient_jump")


def _drawn(j: Junction) -> dict:
    """A junction as the header lists it: its patches and sides, or its faces and edge, or
    its patch (face) and knot line; its class and measures (a non-finite measure as text,
    "inf", so that the JSON is strict)."""
    measures = {}
    for name in MEASURES:
        x = float(getattr(j, name))
        measures[name] = x if np.isfinite(x) else str(x)
    measures.update(deciding_place(j))
    if j.knot is not None:
        where = j.knot.as_dict(j.patches[0])
        return {"patches": list(j.patches), **where, "class": j.cls, **measures}
    if j.sides is None:
        return {"edge": j.edge, "patches": list(j.patches), "class": j.cls, **measures}
    return {"patches": list(j.patches), "sides": list(j.sides), "class": j.cls, **measures}


#: The measure that keeps each class from the next: where it is largest is where to look.
DECIDING = {
    "none": "gap",
    "G0": "normal_angle_deg",
    "G1": "curvature_jump",
    "G2": "curvature_gradient_jump",
    "G3": "curvature_gradient_jump",
}


def deciding_place(j: Junction) -> dict:
    """Where the measure that decides the junction's class (:data:`DECIDING`) is largest,
    as flat header fields: ``at_measure`` (its name), ``at_t`` (the fraction along the
    junction), ``at_x``, ``at_y``, ``at_z`` (the point); {} when not measured."""
    if not j.max_at:
        return {}
    name = DECIDING[j.cls]
    place = j.max_at[name]
    x, y, z = place["point"]
    if not np.isfinite([place["t"], x, y, z]).all():
        return {}
    return {"at_measure": name, "at_t": place["t"], "at_x": x, "at_y": y, "at_z": z}
