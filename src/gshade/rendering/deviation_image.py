"""The deviation picture (``gshade deviation``): scene A rendered from its view, every
covered pixel's exact point P on A given its signed distance to scene B's exact surfaces
(:mod:`gshade.analysis.deviation`), shown in tolerance bands.

Channels: A's render's, with ``f`` (and ``f.mean``) the signed deviation at the pixel
centre's P (0 off the surface), ``B.X B.Y B.Z`` the closest point on B and ``B.patch`` its
patch (a CAD model's face number; -1 off the surface).  Colours: within ±T a neutral grey;
beyond, the diverging colour map of d on [-R, R] (R the largest |d|, at least 2T): the
side A's normal points to red, the other blue.  The band edges are box-filtered over each
pixel's footprint like every band (:func:`gshade.display.bands.band_shares`; d's change
across the pixel from its neighbours), and the colours are shaded by the exact normal
toward the eye.  The header's ``deviation`` holds the numbers
(:func:`gshade.analysis.deviation.deviation_summary`) with B's file and the tolerance.
"""

from __future__ import annotations

import json
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..analysis.closest_points import Samples, grid_samples
from ..analysis.deviation import deviation_summary, signed_deviation
from ..analysis.trimmed_faces import TrimTest, boundary_search, trim_test
from ..display import Legend, colour_map
from ..display.bands import band_shares, band_text, settled_on_levels
from ..display.colour import srgb_to_linear
from ..shape.registry import Bands
from .camera import View, header_view
from .rendered_image import RenderedImage
from .tessellate import TriangleMesh

if TYPE_CHECKING:
    from ..scene.model import Scene

__all__ = [
    "DEVIATION_CHANNELS",
    "MAX_SAMPLE_GRID",
    "NEUTRAL",
    "SAMPLE_CHORD",
    "deviation_bands",
    "deviation_image",
    "mesh_samples",
    "sample_mesh",
]

#: The channels a deviation picture adds to A's render's.
DEVIATION_CHANNELS = ("B.X", "B.Y", "B.Z", "B.patch")
#: The chord tolerance of the mesh whose vertices start the closest-point search, relative
#: to the scene's diagonal, and the most grid points a patch side (patches on a grid).
SAMPLE_CHORD, MAX_SAMPLE_GRID = 2e-3, 65
#: The spacing of every patch's grid samples at most, relative to the scene's diagonal.
SAMPLE_SPACING = 5e-3
#: The colour within tolerance (sRGB).
NEUTRAL = (0.78, 0.78, 0.76)


def deviation_bands(tolerance: float) -> Bands:
    """The tolerance bands: below -T, within ±T (a value of exactly ±T is within), above T.

    Examples
    --------
    >>> deviation_bands(0.1).names
    ('beyond, inside', 'within tolerance', 'beyond, outside')
    """
    t = float(tolerance)
    edges = (-t, t) if t > 0 else (0.0,)
    names = (
        ("beyond, inside", "within tolerance", "beyond, outside")
        if t > 0
        else (
            "inside",
            "outside",
        )
    )
    colours = ((0.23, 0.3, 0.75), NEUTRAL, (0.7, 0.02, 0.15))
    return Bands(
        edges,
        names,
        colours if t > 0 else (colours[0], colours[2]),
        closed_above=(1,) if t > 0 else (),
    )


def _footprint(f: NDArray, on: NDArray) -> tuple[NDArray, NDArray]:
    """f's change across one pixel in x and y: central differences where both neighbours
    are on the surface, one-sided where one is, 0 where none."""

    def along(axis: int) -> NDArray:
        ahead, behind = np.roll(f, -1, axis), np.roll(f, 1, axis)
        on_ahead, on_behind = np.roll(on, -1, axis), np.roll(on, 1, axis)
        edge = [slice(None)] * 2
        edge[axis] = slice(-1, None)
        on_ahead[tuple(edge)] = False
        edge[axis] = slice(0, 1)
        on_behind[tuple(edge)] = False
        both = 0.5 * (ahead - behind)
        return np.where(
            on_ahead & on_behind,
            both,
            np.where(on_ahead, ahead - f, np.where(on_behind, f - behind, 0.0)),
        )

    return along(1), along(0)


def sample_mesh(scene: Scene) -> TriangleMesh:
    """A scene's render mesh within :data:`SAMPLE_CHORD` of its diagonal: a CAD model's
    trimmed faces by the kernel's mesher, patches on a grid of at most
    :data:`MAX_SAMPLE_GRID` points a side."""
    from ..analysis.scene_junctions import scene_diagonal
    from .surface_meshes import gridded_patches, mesh_parts
    from .tessellate import join_meshes, max_chord_resolution

    tolerance = SAMPLE_CHORD * scene_diagonal(scene)
    gridded = gridded_patches(scene)
    resolution = 2
    if gridded:
        resolution = int(np.clip(max_chord_resolution(gridded, tolerance), 5, MAX_SAMPLE_GRID))
    parts = mesh_parts(scene, resolution, tolerance, scene.name)
    return join_meshes([(part.mesh, part.index) for part in parts], resolution)


def mesh_samples(scene: Scene, inside: TrimTest | None = None) -> Samples:
    """The coarse search's points of a scene: every patch's grid samples
    (:func:`~gshade.analysis.closest_points.grid_samples`: a periodic face's seam and a
    long tube's far side have samples near them) and the vertices of its
    :func:`sample_mesh` (where a trimmed face's grid may miss its trimmed region), each
    with its patch and (u, v); their reach the longer of the grids' cell diagonals and the
    mesh's edges; with ``inside`` (:func:`gshade.analysis.trimmed_faces.trim_test`), the
    grid samples outside a face's trims left out.  The grids' samples are at most
    :data:`SAMPLE_SPACING` of the diagonal apart (a big face's mesh may have long
    triangles, its vertices far from the foot points of a flat region)."""
    from ..analysis.scene_junctions import scene_diagonal
    from ..geometry.core.patch import unit_to_domain

    mesh = sample_mesh(scene)
    patch = mesh.patch.astype(np.int64)
    domains = np.array([p.domain for p in scene.patches], dtype=np.float64)
    u, v = unit_to_domain(domains, mesh.params[:, 0], mesh.params[:, 1], patch)
    corners = mesh.positions[mesh.faces]
    edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=-1)
    grid = grid_samples(scene.patches, spacing=SAMPLE_SPACING * scene_diagonal(scene))
    if inside is not None:
        kept = inside(grid.patch, grid.uv)
        grid = replace(grid, points=grid.points[kept], patch=grid.patch[kept], uv=grid.uv[kept])
    return Samples(
        np.concatenate([grid.points, mesh.positions]),
        np.concatenate([grid.patch, patch]),
        np.concatenate([grid.uv, np.stack([u, v], -1)]),
        max(grid.reach, float(edges.max(initial=0.0))),
        grid.cell,
    )


def _exact_hits(
    scene: Scene, channels: dict[str, NDArray], view: View
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """P and the unit normal N (n, 3) in double precision where the pixel centres' rays meet
    the surface (the channels hold them in single precision): the rays' Newton solve on the
    exact patches, started from the channels' (u, v); and each hit's patch (n,) and (u, v)
    (n, 2)."""
    from ..geometry.core.differential import derivative_scales, irregular_mask
    from ..geometry.evaluation.regularity import patch_normals
    from .surface_hits import surface_hits

    rows, cols = np.nonzero(channels["patch"] >= 0)
    numbers = _patch_numbers(scene)
    order = np.argsort(numbers)
    index = order[np.searchsorted(numbers[order], channels["patch"][rows, cols].astype(np.int64))]
    domains = np.array([p.domain for p in scene.patches], dtype=np.float64)[index]
    # the channels' single precision may round a parameter just out of its domain
    u = np.clip(channels["u"][rows, cols].astype(np.float64), domains[:, 0, 0], domains[:, 0, 1])
    v = np.clip(channels["v"][rows, cols].astype(np.float64), domains[:, 1, 0], domains[:, 1, 1])
    u, v, d, _ = surface_hits(scene.patches, index, u, v, *view.pixel_rays(rows, cols), steps=3)
    normal = np.cross(d[1, 0], d[0, 1])
    # the normals' limits where the parametrisation is irregular (a collapsed edge)
    irregular = irregular_mask(d[:2, :2], scale=derivative_scales(d[:2, :2], index))
    normal /= np.where(irregular, 1.0, np.linalg.norm(normal, axis=-1))[:, None]
    for k in np.unique(index[irregular]).tolist():
        at = np.flatnonzero(irregular & (index == k))
        normal[at] = patch_normals(scene.patches[k], u[at], v[at]).n
    return d[0, 0], normal, index, np.stack([u, v], -1)


def _patch_numbers(scene: Scene) -> NDArray[np.int64]:
    """Each scene patch's number in the ``patch`` channel: a lone surface's own (a CAD
    model's face numbers), else the index."""
    if len(scene.surfaces) == 1:
        return np.asarray(scene.surfaces[0].body.patch_numbers(0, len(scene.patches)))
    return np.arange(len(scene.patches))


def _shading(channels: dict[str, NDArray], view: View) -> NDArray:
    """Lambert's |<N, toward the eye>| with an ambient part, per pixel, from the exact N."""
    P = np.stack([channels[f"P.{c}"] for c in "XYZ"], -1).astype(np.float64)
    N = np.stack([channels[f"N.{c}"] for c in "XYZ"], -1).astype(np.float64)
    if view.type == "orthographic":
        toward = np.broadcast_to(view.origin - view.target, P.shape)
    else:
        toward = view.origin - P
    with np.errstate(invalid="ignore", divide="ignore"):
        toward = toward / np.linalg.norm(toward, axis=-1, keepdims=True)
    facing = np.abs(np.nan_to_num(np.sum(N * toward, -1)))
    return 0.35 + 0.65 * facing


def deviation_image(
    a: Scene, b: Scene, tolerance: float, **overrides: Any
) -> tuple[RenderedImage, dict[str, Any]]:
    """Scene ``a`` rendered (with ``overrides``, as :func:`gshade.rendering.render`) and
    coloured by its signed deviation from scene ``b`` within ``tolerance`` (see the
    module), and the numbers."""
    from .pipeline import render

    image = render(a, **overrides)
    channels = dict(image.channels)
    on = channels["patch"] >= 0
    H, W = on.shape
    view = header_view(image.metadata, W, H)  # the view the picture was rendered with
    P, N, index, uv = _exact_hits(a, channels, view)
    # a pixel whose exact point lies off A's trimmed face (the render's mesh overhangs
    # the trims by its chord) is no point of A
    trims = trim_test(a)
    if trims is not None:
        kept = trims(index, uv)
        on[on] = kept
        P, N = P[kept], N[kept]
    inside = trim_test(b)
    found = signed_deviation(
        P, N, b.patches, mesh_samples(b, inside), inside=inside, boundary=boundary_search(b)
    )
    f = np.zeros(on.shape)
    f[on] = found.distance
    foot = np.zeros((*on.shape, 3))
    foot[on] = found.closest.point
    patch = np.full(on.shape, -1.0)
    patch[on] = _patch_numbers(b)[found.closest.patch]
    summary = deviation_summary(found.distance, tolerance, P)
    summary["b"] = b.name
    if summary["count"]:
        k = int(np.flatnonzero(on.ravel())[summary["index"]])
        row, col = divmod(k, on.shape[1])
        summary["pixel"] = [col, row]
        summary["patch_a"] = int(channels["patch"][row, col])
        summary["patch_b"] = int(patch[row, col])
    rgb = _colours(f, on, tolerance, summary.get("max_abs") or 0.0)
    unmeasured = (channels["patch"] >= 0) & ~on  # off A's trims: no deviation, neutral
    rgb[unmeasured] = srgb_to_linear(np.asarray(NEUTRAL))
    rgb *= _shading(channels, view)[..., None]
    alpha = channels["A"].astype(np.float64)
    for i, c in enumerate("RGB"):
        channels[c] = (rgb[..., i] * alpha).astype(np.float32)
    channels["f"] = channels["f.mean"] = f.astype(np.float32)
    for i, c in enumerate("XYZ"):
        channels[f"B.{c}"] = foot[..., i].astype(np.float32)
    channels["B.patch"] = patch.astype(np.float32)
    metadata = dict(image.metadata)
    metadata["deviation"] = json.dumps(summary, allow_nan=False)
    length = image.metadata.get("length_unit", "length")
    spread = max(summary.get("max_abs") or 0.0, 2.0 * tolerance) or 1.0
    legend = Legend(
        "deviation",
        0,
        "bands",
        value_range=(-spread, spread),
        colormap="coolwarm",
        units=length,
        bands=band_text(deviation_bands(tolerance), length),
    )
    metadata["legend"] = legend.text()
    return replace(image, channels=channels, metadata=metadata, legend=legend), summary


def _colours(f: NDArray, on: NDArray, tolerance: float, largest: float) -> NDArray:
    """Linear RGB (H, W, 3): the bands of f, box-filtered over the pixels' footprints,
    the beyond-tolerance ones in the diverging map on [-R, R]."""
    bands = deviation_bands(tolerance)
    fx, fy = _footprint(f, on)
    settled, fx, fy = settled_on_levels(f, fx, fy, bands)
    shares, _ = band_shares(settled, fx, fy, bands)
    spread = max(largest, 2.0 * tolerance) or 1.0
    mapped = colour_map(f, on, value_range=(-spread, spread), cmap="coolwarm").rgb
    neutral = srgb_to_linear(np.asarray(NEUTRAL))
    if len(shares) == 3:
        rgb = (shares[0] + shares[2])[..., None] * mapped + shares[1][..., None] * neutral
    else:
        rgb = mapped
    return np.where(on[..., None], rgb, 0.0)
