"""The render pipeline: scene -> patches -> mesh + shape textures -> Mitsuba -> image.

:func:`render` runs these stages (each timed under its name in ``RenderedImage.timings``):

1. ``setup``: the settings (``spp`` rounded up to a power of 4, the sample budget) and
   Mitsuba's variant.
2. ``tessellate``: the framing (the camera, when it is not given, frames the surfaces), the
   mesh on a common grid chosen from the chord-error tolerance
   (:mod:`gshade.rendering.sizing`), and the atlas's tile size.
3. ``textures``: the shape function (and the colour function) with exact derivatives on one
   atlas tile per patch (:mod:`gshade.rendering.textures`), and the display style: colour
   range, stripe period, colour map (:mod:`gshade.rendering.style`).
4. ``scene``: the Mitsuba mesh, the integrator and the scene
   (:mod:`gshade.rendering.mitsuba_scene`), and the pixels crossed by the mesh's silhouette
   and boundary edges (:mod:`gshade.rendering.supersampling`).
5. ``render``: one sample through each pixel centre, filtering stripes over the whole pixel:
   the picture, and the atlas coordinates of the surface points.
6. ``supersample``: ``spp`` samples per pixel (box filter, at the strata centres) where the
   picture is discontinuous (``sampling = "edges"``) or everywhere (``"uniform"``, and
   always for ``soft`` light): R G B A and f there; meanwhile, in numpy, the exact hits of
   the centre rays (:func:`gshade.rendering.channels.centre_hits`).
7. ``exact_channels``: P, N, u, v and the patch, exact at the pixel centres
   (:mod:`gshade.rendering.channels`).

With ``junctions`` on, the continuity report is measured before rendering and its lines drawn
after (``junctions``).  Then the legend and the header metadata.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from .. import __version__
from ..errors import GshadeError
from ..limits import MAX_SAMPLES
from ..scene.changes import scene_with_settings
from ..scene.model import Scene
from ..shape import checked_parameters, get_shape_function
from .atlas import Atlas
from .camera import View
from .channels import PICTURE, centre_hits, exact_channels, refuse_non_finite
from .glossy import Convergence, converged_picture
from .integrator import SHAPE_FILM
from .mitsuba_scene import mitsuba_scene, render_centres, render_pixels_of, render_uniform
from .plugins import use_variant
from .reflections import Environment, environment, reflection_channels
from .rendered_image import RenderedImage
from .sizing import chord_tolerance, frame, mesh_resolution, tile_sizes, validate_memory
from .statistics import min_radius_summary, surface_statistics, visible_statistics, widened
from .style import display_style, legend, shape_functions, trimmed_region
from .supersampling import discontinuous_pixels, silhouette_pixels
from .surface_meshes import mesh_parts, planned_vertices
from .tessellate import join_meshes
from .textures import ShapeTextures, shape_textures

if TYPE_CHECKING:
    from ..analysis.continuity import Junction
    from ..analysis.edge_continuity import EdgeLine
    from ..analysis.statistics import ValueStatistics
    from ..scene.model import RenderSettings, Shape
    from ..shape import ShapeFunction
    from .mitsuba_scene import MitsubaScene
    from .sizing import Framing
    from .style import DisplayStyle
    from .tessellate import TriangleMesh

__all__ = ["render", "shape_statistics"]


class _Laps:
    """Stage timings: each lap adds the seconds since the previous one to its name (the
    junctions are measured before tessellating and drawn after the exact channels)."""

    def __init__(self) -> None:
        self.timings: dict[str, float] = {}
        self.clock = time.perf_counter()

    def __call__(self, name: str) -> None:
        now = time.perf_counter()
        self.timings[name] = self.timings.get(name, 0.0) + now - self.clock
        self.clock = now


def render(
    scene_or_path: Scene | str | os.PathLike[str],
    *,
    function: str | None = None,
    display: str | None = None,
    width: int | None = None,
    height: int | None = None,
    spp: int | None = None,
    camera: Mapping[str, Any] | None = None,
    set: Mapping[str, Any] | None = None,
    **render_settings: Any,
) -> RenderedImage:
    r"""Render a scene to an image: its EXR channels, header, legend and writers.

    Every keyword is checked as the scene file's key is (``gshade keys`` lists them); None,
    the default, leaves the scene's value.

    Parameters
    ----------
    scene_or_path : Scene or path-like
        A loaded :class:`gshade.scene.Scene`, or a scene file (or CAD file) to load
        (:func:`gshade.load_scene`).
    function : str, optional
        ``shape.function``: the shape function (``gshade shapes`` lists them).
    display : str, optional
        ``shape.display``: ``"stripes"``, ``"colormap"``, ``"both"`` or ``"bands"``.
    width, height, spp : int, optional
        ``render.width``, ``render.height`` (pixels) and ``render.spp`` (samples per pixel).
    camera : mapping, optional
        ``[camera]`` keys: ``{"origin": [x, y, z], "target": [x, y, z], "type":
        "orthographic", "width": 2.5}`` (also ``up``, ``fov``).
    set : mapping, optional
        Dotted scene keys, ``{"shape.period": 0.05, "camera.fov": 20}``, as ``gshade
        render --set``.  With a path they are applied before the file is validated and may
        name any key (``surface.1.radius``); with a loaded Scene, keys of ``[shape]``,
        ``[camera]`` and ``[render]``.  The keywords above win over ``set``.
    **render_settings
        Other ``[render]`` keys: ``lighting``, ``sampling``, ``variant``, ``seed``,
        ``tessellation``, ``chord_tolerance``, ``texture_resolution``, ``junctions``,
        ``aovs``, ``parabolic``, ``combs``, ``comb_curvature``, ``comb_lines``,
        ``comb_scale``, ``comb_sections``, ``comb_section_direction``.

    Returns
    -------
    RenderedImage
        The channels (``.f``, ``.P``, ``.N``, ``.rgb``, ``.srgb``, ``.srgba``,
        ``image["u"]`` ...), the header metadata, the legend, ``.write_exr`` and
        ``.write_png``.

    Raises
    ------
    GshadeError
        One line: an unknown keyword, with the likeliest meant (``render: unknown setting
        'widht'; did you mean "width"?``); a value the scene file would refuse, naming the
        file (``render()`` for a loaded Scene), the key, what was expected and what was
        given (``render(): [render] width: expected an integer from 1 to 16384, got
        "wide"``).

    Examples
    --------
    >>> import gshade
    >>> from gshade.scene import parse_scene
    >>> sphere = parse_scene('[[surface]]\ntype = "sphere"\nradius = 1\n')
    >>> image = gshade.render(sphere, function="mean", width=32, height=24, spp=1)
    >>> image.shape, image.P.shape, image.rgb.dtype
    ((24, 32), (24, 32, 3), dtype('float32'))
    >>> image.metadata["legend"].startswith("mean")
    True
    """
    keywords = {
        "function": function,
        "display": display,
        "width": width,
        "height": height,
        "spp": spp,
        "camera": camera,
        "set": set,
        **render_settings,
    }
    scene = scene_with_settings(scene_or_path, keywords)
    lap = _Laps()
    settings, where = _settings(scene)
    variant = use_variant(settings.variant)
    env = _environment(scene, where)
    lap("setup")

    framing = frame(scene, settings, where)
    resolution = mesh_resolution(scene, settings, framing)
    junctions = edges = None
    if settings.junctions:  # measured first: overlapping surfaces fail before rendering
        junctions, edges = _measure_junctions(scene, where)
        lap("junctions")
    mesh, atlas, (unmeshed, meshed) = _mesh_and_atlas(scene, settings, framing, resolution, where)
    lap("tessellate")

    functions, mapped = shape_functions(scene.shape)
    parabolic: list[tuple[ShapeFunction, dict]] = (
        [(get_shape_function("gaussian"), {})] if settings.parabolic else []
    )
    tex, region = _textures(scene, mesh, atlas, functions + parabolic)
    style = display_style(scene.shape, mapped, tex, region)
    lap("textures")
    surface = None
    if env is None:  # a reflection has no values over the surface without a view
        surface = surface_statistics(tex, region, scene.patches, *functions[0], _numbers(scene))
    lap("statistics")

    view = framing.view
    mitsuba = mitsuba_scene(mesh, atlas, tex, style, view, settings, scene.shape, env)
    glossy = env is not None and env.roughness > 0
    uniform = settings.sampling == "uniform" or settings.lighting == "soft" or glossy
    silhouettes = None if uniform else silhouette_pixels(mesh, view)
    del mesh, tex, region  # Mitsuba holds its own copies: free ours before rendering
    lap("scene")
    film = render_centres(mitsuba, view, settings)
    lap("render")
    hit = film[..., SHAPE_FILM.index("A")] > 0.5  # where the centre rays meet the surface
    exact = _exact_functions(scene, settings, [] if env is not None else functions)
    # the supersampling pass (Mitsuba's threads) while numpy finds the exact centre hits
    # (they read the centre pass's coordinates, the pass writes the picture's channels)
    with ThreadPoolExecutor(max_workers=1) as pool:
        supersampled = pool.submit(
            _supersample, film, mitsuba, view, settings, silhouettes, atlas, style, scene.shape
        )
        hits = centre_hits(film, hit, atlas, scene.patches, view, exact)
        convergence = supersampled.result()
    lap("supersample")

    channels = exact_channels(film, hit, atlas, scene.patches, view, exact, hits)
    if env is not None:
        channels = reflection_channels(channels, view, env)
    lap("exact_channels")
    refuse_non_finite(where, channels)
    if junctions is not None:
        from ..analysis.junction_lines import draw_junctions

        domains = [p.domain for p in scene.patches]
        channels = draw_junctions(channels, junctions, domains, edges=edges)
        lap("junctions")
    combs = None
    if settings.combs:
        from .comb_overlay import comb_overlay

        try:
            channels, combs = comb_overlay(scene, settings, view, channels)
        except GshadeError as exc:
            raise GshadeError(f"{where}: {exc}") from None
        combs = _renumbered(scene, combs)
        lap("combs")
    umbilics = None
    if settings.parabolic:  # the order-2 overlay: parabolic lines and umbilics
        from ..analysis.umbilics import scene_umbilics

        umbilics = scene_umbilics(scene)
        if umbilics[0]:
            from .comb_lines import draw_rings

            channels = draw_rings(channels, np.array([u.point for u in umbilics[0]]), view)
        lap("umbilics")
    channels["patch"] = _patch_channel(scene, channels["patch"])
    numbers = _statistics(scene, visible_statistics(channels), surface)
    if umbilics is not None:
        numbers.update(_umbilic_numbers(scene, *umbilics))
    legend_notes = _legend_notes(numbers, combs, _length_unit(scene), settings.parabolic)
    if env is not None:
        said_env = (
            (env.describe(),) if convergence is None else (env.describe(), convergence.describe())
        )
        legend_notes = (*said_env, *legend_notes)
    shown = replace(legend(scene.shape, style, _length_unit(scene)), notes=legend_notes)
    metadata = _metadata(scene, settings, variant, view, resolution, atlas, shown.text())
    metadata["statistics"] = json.dumps(numbers, allow_nan=False)
    if combs is not None:
        metadata["combs"] = json.dumps(combs, allow_nan=False)
    lap("statistics")
    if junctions is not None:
        from ..analysis.junction_lines import junction_metadata

        metadata["junctions"] = junction_metadata(junctions)
    lost = left_out_faces(scene, unmeshed)
    if lost:
        metadata["left_out_faces"] = json.dumps(
            [
                {"file": path.name, "face": f.index, "why": f.why, "tried": f.tried}
                for path, f in lost
            ]
        )
    said = cad_notes(scene, meshed)
    if said:
        metadata["cad_notes"] = json.dumps([f"{path.name}: {line}" for path, line in said])
    warnings = [f"{path}: {face.line()}" for path, face in lost]
    notes = [f"{path}: {line}" for path, line in said]
    return RenderedImage(channels, metadata, shown, lap.timings, warnings, notes)


def _textures(
    scene: Scene, mesh: TriangleMesh, atlas: Atlas, functions: list[tuple[ShapeFunction, dict]]
) -> tuple[ShapeTextures, NDArray | None]:
    """The functions' textures, and the texels inside the trimmed faces (None: no face is
    trimmed), from which the ranges and the whole surface's numbers come."""
    tex = shape_textures(scene.patches, atlas, functions)
    trimmed = np.concatenate([np.full(len(s.patches), s.body.trimmed) for s in scene.surfaces])
    if not trimmed.any():
        return tex, None
    return tex, trimmed_region(atlas, mesh.patch, mesh.params, trimmed)


def shape_statistics(scene: Scene | str | os.PathLike, **overrides: Any) -> dict[str, Any]:
    """The numbers of a scene's shape function over its whole surface, without rendering
    (``gshade info --stats``): as a render's header gives them (its ``statistics``), less
    the visible surface's (none for a reflection: it has no value without a view).
    ``overrides`` as for :func:`render`."""
    scene = scene_with_settings(scene, overrides)
    if get_shape_function(scene.shape.function).reflection:
        numbers = _statistics(scene, None, None)
        del numbers["visible"]
        return numbers
    settings, where = _settings(scene)
    framing = frame(scene, settings, where)
    resolution = mesh_resolution(scene, settings, framing)
    mesh, atlas, _ = _mesh_and_atlas(scene, settings, framing, resolution, where)
    functions, _ = shape_functions(scene.shape)
    tex, region = _textures(scene, mesh, atlas, functions[:1])
    surface = surface_statistics(tex, region, scene.patches, *functions[0], _numbers(scene))
    numbers = _statistics(scene, None, surface)
    del numbers["visible"]
    return numbers


def _environment(scene: Scene, where: str) -> Environment | None:
    """The environment a reflection reflects (None for other functions), read before
    anything is rendered: a bad map file fails first."""
    fn = get_shape_function(scene.shape.function)
    if not fn.reflection:
        return None
    try:
        return environment(checked_parameters(fn, scene.shape.params_for(fn.name)))
    except GshadeError as exc:
        raise GshadeError(f"{where}: [shape] map: {exc}") from None


def _supersample(
    film: NDArray,
    mitsuba: MitsubaScene,
    view: View,
    settings: RenderSettings,
    silhouettes: NDArray | None,
    atlas: Atlas,
    style: DisplayStyle,
    shape: Shape,
) -> Convergence | None:
    """Replace the centre pass's picture (:data:`PICTURE`) in ``film`` by ``spp`` samples'
    at the silhouettes' pixels and where the picture jumps (everywhere if ``silhouettes`` is
    None: uniform sampling); a glossy reflection's until two seeds agree
    (:func:`gshade.rendering.glossy.converged_picture`), and how far they do."""
    if mitsuba.glossy:
        picture, convergence = converged_picture(mitsuba, view, settings)
        film[..., : len(PICTURE)] = picture
        return convergence
    if silhouettes is None:
        film[..., : len(PICTURE)] = render_uniform(mitsuba, settings)[..., : len(PICTURE)]
        return None
    # a jump of f this small does not show: a thousandth of a stripe or of the colours
    scale = style.value_range[1] - style.value_range[0]
    if style.bands is not None:  # a thousandth of the levels' span (or of the largest)
        levels = np.asarray(style.bands.edges + style.bands.lines)
        scale = float(np.ptp(levels)) or float(np.abs(levels).max()) or 1.0
    unseen = 1e-3 * float(scale if shape.display in ("colormap", "bands") else style.period)
    stripes = (
        None
        if shape.display in ("colormap", "bands")
        else (float(style.period), shape.phase, shape.duty)
    )
    if get_shape_function(shape.function).reflection:  # the map is box-filtered per sample:
        unseen, stripes = np.inf, None  # more samples only at edges (occlusion's included)
    marked = discontinuous_pixels(film, atlas, unseen, stripes, style.bands)
    pixels = np.flatnonzero(silhouettes | marked)
    if pixels.size and settings.spp > 1:
        picture = render_pixels_of(mitsuba, view, settings, pixels)[:, : len(PICTURE)]
        film.reshape(-1, film.shape[-1])[pixels, : len(PICTURE)] = picture
    return None


def _settings(scene: Scene) -> tuple[RenderSettings, str]:
    """The ``[render]`` settings as rendered (``spp`` rounded up to a power of 4: Mitsuba's
    stratified sampler takes 1, 4, 16, 64, ... samples), checked against the sample budget,
    and the scene's name for messages."""
    settings = scene.render
    spp = 4 ** int(np.ceil(np.log(max(settings.spp, 1)) / np.log(4) - 1e-9))
    if spp != settings.spp:
        settings = replace(settings, spp=spp)
    where = str(scene.path) if scene.path is not None else scene.name
    if settings.width * settings.height * spp > MAX_SAMPLES:
        raise GshadeError(
            f"{where}: [render] width x height x spp: expected at most {MAX_SAMPLES} samples "
            f"(spp rounded up to a power of 4), got {settings.width} x {settings.height} x "
            f"{spp} = {settings.width * settings.height * spp}"
        )
    return settings, where


def _exact_functions(
    scene: Scene, settings: RenderSettings, functions: list[tuple[ShapeFunction, dict]]
) -> dict:
    """The functions evaluated exactly at the pixel centres, by channel: ``f`` the striped
    (or only) one, ``f2`` the colour-mapped one of ``display = "both"``, and each
    ``render.aovs`` name with the scene's parameters for it (``functions`` empty: a
    reflection, whose f :func:`gshade.rendering.reflections.reflection_channels` gives)."""
    from ..shape import get_shape_function

    out = {"f": functions[0]} if functions else {}
    if len(functions) > 1:
        out["f2"] = functions[1]
    for name in settings.aovs:
        out[name] = (get_shape_function(name), scene.shape.params_for(name))
    return out


def _length_unit(scene: Scene) -> str:
    """The scene's length unit: its surfaces' (all one, e.g. ``"mm"``,
    :attr:`gshade.scene.bodies.SurfaceBody.length_unit`), else ``"length"`` (control
    points carry no unit)."""
    units = {s.body.length_unit for s in scene.surfaces}
    if len(units) == 1 and None not in units:
        return str(units.pop())
    return "length"


def _patch_label(scene: Scene) -> str:
    """What the ``patch`` channel numbers: a scene of one surface, its own word for a patch
    (:attr:`gshade.scene.bodies.SurfaceBody.patch_label`: ``"face"`` on a CAD model), else
    ``"patch"`` (the scene's patches; several CAD models' face numbers would collide)."""
    return scene.surfaces[0].body.patch_label if len(scene.surfaces) == 1 else "patch"


def _numbers(scene: Scene) -> NDArray | None:
    """Each patch's number as the ``patch`` channel gives it (:func:`_patch_channel`): on a
    scene of one surface, that surface's own; else None (the index)."""
    if len(scene.surfaces) != 1:
        return None
    return np.asarray(scene.surfaces[0].body.patch_numbers(0, len(scene.patches)))


def _statistics(
    scene: Scene, visible: ValueStatistics | None, surface: ValueStatistics | None
) -> dict[str, Any]:
    """The numbers of a render (:mod:`gshade.rendering.statistics`): the function, what
    its extremes' ``patch`` numbers (``face`` or ``patch``), the summaries over the visible
    and the whole surface, and for ``min_radius`` the smallest radius."""
    out: dict[str, Any] = {"function": scene.shape.function, "patch_label": _patch_label(scene)}
    if visible is not None and surface is not None:  # the visible surface is on the surface
        surface = widened(surface, visible)
    out["visible"] = None if visible is None else visible.as_dict()
    out["surface"] = None if surface is None else surface.as_dict()
    if scene.shape.function == "min_radius" and surface is not None:
        out["min_radius"] = min_radius_summary(surface)
    return out


def _renumbered(scene: Scene, summary: dict[str, Any]) -> dict[str, Any]:
    """A comb summary with its ``patch`` numbers as the ``patch`` channel gives them."""
    numbers = _numbers(scene)
    if numbers is None:
        return summary
    for place in [summary["max"], *summary["inflections"]]:
        if place is not None:
            place["patch"] = int(numbers[place["patch"]])
    return summary


def _umbilic_numbers(scene: Scene, found: list, everywhere: list[int]) -> dict[str, Any]:
    """The umbilics for the header and ``--json``: the isolated points (their ``face`` and
    ``patch`` numbers as the ``patch`` channel gives them) and the patches umbilic all
    over (planes, spheres)."""
    numbers = _numbers(scene)
    label = (lambda k: k) if numbers is None else (lambda k: int(numbers[k]))
    points = []
    for u in found:
        entry = u.as_dict()
        entry["face"] = entry["patch"] = label(u.patch)
        points.append(entry)
    return {"umbilics": points, "umbilic_patches": [label(k) for k in everywhere]}


def _legend_notes(
    numbers: dict[str, Any], combs: dict[str, Any] | None, length: str, parabolic: bool
) -> tuple[str, ...]:
    """The legend's notes: the smallest radius (a ``min_radius`` render) with where it is,
    the umbilics ringed with the parabolic lines, and the combs' scale."""
    from .comb_overlay import comb_note

    notes = []
    radius = numbers.get("min_radius")
    if radius is not None:
        if radius["value"] is None:
            notes.append("smallest radius: none (flat)")
        else:
            x, y, z = radius["point"]
            notes.append(
                f"smallest radius {radius['value']:.4g} {length} ({radius['side']}, "
                f"{numbers['patch_label']} {radius['patch']} at ({x:.4g}, {y:.4g}, {z:.4g}))"
            )
    if parabolic:
        n = len(numbers.get("umbilics", []))
        notes.append(f"parabolic lines in magenta, {n} umbilic{'' if n == 1 else 's'} ringed")
    if combs is not None:
        notes.append(comb_note(combs, length))
    return tuple(notes)


def _patch_channel(scene: Scene, patch: NDArray[np.float32]) -> NDArray[np.float32]:
    """The ``patch`` channel as :func:`_patch_label` says: the scene's patch index (as the
    pipeline numbers them) replaced, on a scene of one surface, by that surface's numbers
    for its patches (:meth:`gshade.scene.bodies.SurfaceBody.patch_numbers`: a CAD model's
    face numbers, which differ from the index once a face is left out or chosen away);
    -1 off the surface."""
    numbers = _numbers(scene)
    if numbers is None:
        return patch
    index = np.rint(patch).astype(np.int64)
    lookup = np.concatenate([numbers, [-1]]).astype(np.float32)  # index -1: the last
    return lookup[np.where(index >= 0, index, len(numbers))]


#: Points per B-rep edge drawn as a junction line.
EDGE_LINE_POINTS = 256


def _measure_junctions(scene: Scene, where: str) -> tuple[list[Junction], list[EdgeLine]]:
    """The continuity report of the patches' junctions (:mod:`gshade.analysis.continuity`)
    and of the CAD surfaces' B-rep edges, with the edges' lines to draw (None without)."""
    from ..analysis.scene_junctions import scene_continuity

    try:
        return scene_continuity(scene, lines=EDGE_LINE_POINTS)
    except GshadeError as exc:
        raise GshadeError(f"{where}: {exc}") from None


def _mesh_and_atlas(
    scene: Scene, settings: RenderSettings, framing: Framing, resolution: int, where: str
) -> tuple[TriangleMesh, Atlas, tuple[list[tuple[Any, Any]], list[tuple[Any, str]]]]:
    """The tessellation (each surface by its body's mesher,
    :mod:`gshade.rendering.surface_meshes`) and the atlas layout, within the memory limit;
    and what the meshers said: the faces left without triangles, (model path, LeftOutFace)
    each, and their notes, (model path, line) each."""
    atlas = Atlas.for_tiles(tile_sizes(scene, framing))
    validate_memory(where, settings, planned_vertices(scene, resolution), atlas.texels)
    deflection = chord_tolerance(scene, settings, framing)
    parts = mesh_parts(scene, resolution, deflection, where)
    mesh = join_meshes([(part.mesh, part.index) for part in parts], resolution)
    validate_memory(where, settings, len(mesh.positions), atlas.texels)
    if len(mesh.faces) == 0:
        raise GshadeError(f"{where}: the tessellation left no triangle")
    lost = [pair for part in parts for pair in part.lost]
    said = [pair for part in parts for pair in part.said]
    return mesh, atlas, (lost, said)


def cad_notes(scene: Scene, meshed: Iterable = ()) -> list:
    """What the readers of the scene's CAD models noted (``CadModel.notes``: the healing,
    sewing undone, objects passed over) and ``meshed``, the mesher's notes: (model path,
    line) each, a model's once."""
    said = dict.fromkeys(note for s in scene.surfaces for note in s.body.notes())  # once
    return list(said) + list(meshed)


def left_out_faces(scene: Scene, unmeshed: Iterable = ()) -> list:
    """The CAD faces a render of ``scene`` leaves out, (model path, LeftOutFace) each in
    order: those the scene's ``cad`` surfaces left out (:attr:`CadFaces.left_out`) and
    ``unmeshed``, those the mesher left without triangles."""
    found = [pair for s in scene.surfaces for pair in s.body.left_out_lines()]
    return sorted([*found, *unmeshed], key=lambda pf: (str(pf[0]), pf[1].index))


def _metadata(
    scene: Scene,
    settings: RenderSettings,
    variant: str,
    view: View,
    resolution: int,
    atlas: Atlas,
    legend_text: str,
) -> dict[str, str]:
    """The EXR header: version, scene, variant, the settings as rendered, the legend, what
    the ``patch`` channel numbers (``"face"``: every surface a CAD model's; else
    ``"patch"``) and the length unit (``"mm"`` ..., ``"length"`` where none is known)."""
    return {
        "gshade_version": __version__,
        "scene_name": scene.name,
        "scene_hash": scene.text_hash,
        "variant": variant,
        "settings": json.dumps(
            {
                "render": asdict(settings),
                "shape": _jsonable(asdict(scene.shape)),
                "camera": {
                    "type": view.type,
                    "origin": view.origin.tolist(),
                    "target": view.target.tolist(),
                    "up": view.up.tolist(),
                    "fov": view.fov,
                    "width": view.width,
                },
                "tessellation": resolution,
                "texture_tile": atlas.tile,
                "texture_texels": atlas.texels,
            },
            sort_keys=True,
        ),
        "legend": legend_text,
        "patch_channel": _patch_label(scene),
        "length_unit": _length_unit(scene),
    }


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    return x
