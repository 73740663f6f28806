"""``gshade figure``: multi-panel figures for reports, laid out with matplotlib.

A figure spec (TOML) names the rows (scene files) and the columns (overrides applied to
every row's scene, e.g. another shape function); every panel is rendered with gshade and
placed in a grid with its title, a colour bar for colour-mapped panels (range, the
function's name, order and units) and the stripe period for striped panels::

    title = "The order ladder"
    rows = ["../junctions-isophotes.toml"]      # relative to the spec
    row_labels = ["G1 pair (left), G2 pair (right)"]   # optional
    width = 640                                 # panel size in pixels (optional)
    height = 360
    spp = 4                                     # optional
    same_range = true                           # one colour range per row (optional)
    frame = "tight"                             # or "scene" (optional)
    margin = 0.05                               # tight framing's margin (optional)
    camera = { fov = 30 }                       # camera keys for every row (optional)
    [[column]]
    label = "planar sections"
    set = { "shape.function" = "planar_sections", "shape.stripes" = 30 }
    junctions = true                            # the junction overlay (optional; also
                                                # combs, parabolic)

One camera per row: every panel of a row is rendered with the same resolved camera, so that
the panels compare point for point.  It is the row's scene camera (with the spec's
``camera`` keys), resolved on the union of the surfaces of the row's panels (columns that
change the surfaces included).  A column's ``set`` may not hold ``camera.*`` keys (that would
give a row several cameras) nor ``render.width`` / ``render.height`` (the spec's ``width``
and ``height`` are every panel's).

``frame = "tight"`` (the default) fits that camera on the surfaces: the bounding box of their
projection fills the panel up to ``margin`` (a fraction of the panel's width and height on
each side, default :data:`MARGIN`) on one axis and is centred on the other.  A perspective
camera keeps its eye (given or automatic) and turns toward the surfaces with the field of
view that fits them: the scene's own picture, enlarged (rendered at full resolution, not a
crop of pixels).  An orthographic one keeps its direction, moves across the view onto the
surfaces and takes the view width that fits them.  ``frame = "scene"`` renders the row's
camera as the scene resolves it.  The figure's metadata records every row's camera, and
each panel's scene hash is that of the row's scene with the column's overrides and the
resolved camera (``gshade render ROW --set camera.origin=... ...`` renders the panel).

``junctions = true`` in a column (or ``"render.junctions" = true`` in its ``set``) draws the
junctions over that column's panels, coloured by continuity class; the note under the panel
names the classes drawn and their colours (G0 red, G1 orange, G2 green, G3 blue; magenta
where the surfaces do not even meet).  ``combs = true`` and ``parabolic = true`` draw those
overlays (``render.combs``, ``render.parabolic``); the notes under the panel give the
combs' scale, the umbilics ringed and, for ``min_radius``, the smallest radius.

PNG is written at 300 dpi; PDF and SVG are vector around the raster panels.  The figure's
metadata records gshade's version, every panel's scene hash and every row's camera.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import __version__
from ..errors import GshadeError, show

if TYPE_CHECKING:
    from types import ModuleType

    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..rendering.rendered_image import RenderedImage
    from ..scene.model import Scene

__all__ = ["FRAMES", "MARGIN", "FigureSpec", "load_figure_spec", "make_figure", "row_camera"]

_KEYS = (
    "title",
    "rows",
    "row_labels",
    "column",
    "width",
    "height",
    "spp",
    "same_range",
    "frame",
    "margin",
    "camera",
)
#: A column's overlays (true or false) and the scene keys they stand for.
OVERLAYS = {
    "junctions": "render.junctions",
    "combs": "render.combs",
    "parabolic": "render.parabolic",
}
_COLUMN_KEYS = ("label", "set", *OVERLAYS)
FORMATS = ("png", "pdf", "svg")
#: How a row's camera is framed: fitted on the surfaces, or as the scene resolves it.
FRAMES = ("tight", "scene")
#: Default empty fraction of a tightly framed panel on each side of the surfaces.
MARGIN = 0.05
#: Largest margin (a panel at least a tenth filled).
MAX_MARGIN = 0.45
#: The junction classes' colours, as the notes under a panel name them.
JUNCTION_COLOUR_NAMES = {
    "none": "magenta",
    "G0": "red",
    "G1": "orange",
    "G2": "green",
    "G3": "blue",
}


@dataclass
class Column:
    label: str
    overrides: dict


@dataclass
class Panel:
    """A rendered panel: its scene, image, column and the overrides it was loaded with."""

    scene: Any
    image: Any
    column: Column
    overrides: dict


@dataclass
class FigureSpec:
    path: Path
    title: str
    rows: list[Path]
    row_labels: list[str]
    columns: list[Column]
    width: int = 480
    height: int = 360
    spp: int = 4
    same_range: bool = False
    frame: str = "tight"
    margin: float = MARGIN
    camera: dict = field(default_factory=dict)
    hashes: dict = field(default_factory=dict)
    cameras: dict = field(default_factory=dict)


def load_figure_spec(path: str | os.PathLike) -> FigureSpec:
    """Read and check a figure spec; errors name the file and the key."""
    from ..scene.tables import read_toml

    path = Path(path)
    raw = read_toml(path, "a figure spec (TOML)")
    for key in raw:
        if key not in _KEYS:
            raise GshadeError(f"{path}: {key}: unknown key (expected one of: {', '.join(_KEYS)})")
    rows = raw.get("rows")
    if not (isinstance(rows, list) and rows and all(isinstance(r, str) for r in rows)):
        raise GshadeError(f"{path}: rows: expected a list of scene files, got {rows!r}")
    row_paths = [(path.parent / r) for r in rows]
    for r in row_paths:
        if not r.is_file():
            raise GshadeError(f"{path}: rows: no such scene file {r}")
    labels = raw.get("row_labels", [r.stem for r in row_paths])
    if not (isinstance(labels, list) and len(labels) == len(rows)):
        raise GshadeError(f"{path}: row_labels: expected {len(rows)} labels, got {labels!r}")
    columns = []
    for k, col in enumerate(raw.get("column", []), start=1):
        columns.append(_column(path, k, col))
    if not columns:
        columns = [Column("", {})]
    spec = FigureSpec(path, str(raw.get("title", "")), row_paths, [str(x) for x in labels], columns)
    for key in ("width", "height", "spp"):
        if key in raw:
            value = raw[key]
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise GshadeError(f"{path}: {key}: expected a positive integer, got {value!r}")
            setattr(spec, key, value)
    if "same_range" in raw:
        if not isinstance(raw["same_range"], bool):
            raise GshadeError(f"{path}: same_range: expected true or false")
        spec.same_range = raw["same_range"]
    if "frame" in raw:
        if raw["frame"] not in FRAMES:
            raise GshadeError(
                f"{path}: frame: expected one of: {', '.join(map(repr, FRAMES))}, "
                f"got {raw['frame']!r}"
            )
        spec.frame = raw["frame"]
    if "margin" in raw:
        value = raw["margin"]
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            value = None
        if value is None or not 0 <= value <= MAX_MARGIN:
            raise GshadeError(
                f"{path}: margin: expected a number in [0, {MAX_MARGIN}] (the fraction of the "
                f"panel left empty on each side), got {raw['margin']!r}"
            )
        spec.margin = float(value)
    if "camera" in raw:
        if not isinstance(raw["camera"], dict):
            raise GshadeError(f"{path}: camera: expected a table of [camera] keys")
        from ..scene.sections import CAMERA_KEYS

        for key in raw["camera"]:
            if key not in CAMERA_KEYS:
                raise GshadeError(
                    f"{path}: camera: {key}: unknown key (expected one of: "
                    f"{', '.join(CAMERA_KEYS)})"
                )
        spec.camera = {f"camera.{k}": v for k, v in raw["camera"].items()}
    _check_texts(spec)
    return spec


def _check_texts(spec: FigureSpec) -> None:
    """Every text the figure draws, checked to be one matplotlib can typeset (text with an
    even number of unescaped ``$`` is mathtext), before any panel is rendered: the title,
    each row label, each column's label and, with several rows, the panel titles
    ``ROW: COLUMN`` made of them.

    Raises
    ------
    GshadeError
        ``SPEC: KEY: expected text matplotlib can typeset (mathtext between $ signs), got
        "...": MATPLOTLIB'S REASON``.
    """
    texts = [("title", spec.title)]
    texts += [(f"row_labels[{r}]", label) for r, label in enumerate(spec.row_labels)]
    texts += [(f"[[column]] {c} label", col.label) for c, col in enumerate(spec.columns, 1)]
    if len(spec.rows) > 1:  # a panel's title joins its row's label and its column's label
        for r, label in enumerate(spec.row_labels):
            for c, col in enumerate(spec.columns, start=1):
                if col.label:
                    key = f"row_labels[{r}] with [[column]] {c} label (the panel's title)"
                    texts.append((key, f"{label}: {col.label}"))
    if not any("$" in text for _, text in texts):
        return
    from matplotlib import cbook
    from matplotlib.mathtext import MathTextParser

    parser = MathTextParser("path")
    for key, text in texts:
        if not cbook.is_math_text(text):
            continue
        try:
            parser.parse(text, dpi=72)
        except (ValueError, RuntimeError, KeyError) as exc:
            lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
            reason = lines[-1] if lines else type(exc).__name__
            reason = "".join(ch if ch.isprintable() else ascii(ch)[1:-1] for ch in reason)
            raise GshadeError(
                f"{spec.path}: {key}: expected text matplotlib can typeset (mathtext between "
                f"$ signs), got {show(text)}: {reason[:200]}"
            ) from None


def _column(path: Path, k: int, col: Any) -> Column:
    """A ``[[column]]`` table, checked: its keys, its ``set`` (no camera nor image size:
    those are the row's and the figure's) and its overlays (:data:`OVERLAYS`)."""
    where = f"{path}: [[column]] {k}"
    if not isinstance(col, dict):
        raise GshadeError(f"{where}: expected a table")
    for key in col:
        if key not in _COLUMN_KEYS:
            raise GshadeError(
                f"{where}: {key}: unknown key (expected one of: {', '.join(_COLUMN_KEYS)})"
            )
    overrides = col.get("set", {})
    if not isinstance(overrides, dict):
        raise GshadeError(f"{where}: set: expected a table of scene keys")
    overrides = _flatten(overrides)
    for key in overrides:
        if key.startswith("camera.") or key == "camera":
            raise GshadeError(
                f"{where}: set: {key}: a row has one camera (its panels compare point for "
                "point); set camera keys in the spec's camera table or in the row's scene"
            )
        if key in ("render.width", "render.height"):
            raise GshadeError(
                f"{where}: set: {key}: every panel has the spec's size; set the spec's "
                f"{key.split('.')[1]} instead"
            )
    for overlay, key in OVERLAYS.items():
        if overlay not in col:
            continue
        if not isinstance(col[overlay], bool):
            raise GshadeError(
                f"{where}: {overlay}: expected true or false, got {show(col[overlay])}"
            )
        if overrides.get(key, col[overlay]) != col[overlay]:
            raise GshadeError(f"{where}: {overlay}: contradicts set's {key}")
        overrides[key] = col[overlay]
    return Column(str(col.get("label", "")), overrides)


def _flatten(table: dict, prefix: str = "") -> dict:
    out = {}
    for key, value in table.items():
        if isinstance(value, dict):
            out.update(_flatten(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def _load(scene_path: Path, overrides: dict, spec: FigureSpec) -> Scene:
    """The row's scene with the figure's size and camera keys and the given overrides."""
    from ..scene import load_scene

    all_overrides = {
        "render.width": spec.width,
        "render.height": spec.height,
        "render.spp": spec.spp,
        **spec.camera,
        **overrides,
    }
    return load_scene(scene_path, all_overrides)


def _panel(scene_path: Path, overrides: dict, column: Column, spec: FigureSpec) -> Panel:
    from ..rendering import render

    scene = _load(scene_path, overrides, spec)
    return Panel(scene, render(scene), column, overrides)


def row_camera(spec: FigureSpec, row: Path) -> dict:
    """The camera every panel of a row is rendered with.

    Parameters
    ----------
    spec : FigureSpec
        The figure: its columns, size, ``camera`` keys, ``frame`` and ``margin``.
    row : Path
        One of its rows' scene files.

    Returns
    -------
    dict
        Scene overrides: ``camera.type``, ``.origin``, ``.target``, ``.up``, ``.fov`` and,
        orthographic, ``.width``.

    Notes
    -----
    The row's scene camera (with the spec's ``camera`` keys) is resolved on the union of
    the surfaces of the row's panels (one load per distinct set of a column's ``surface.*``
    overrides), then, with ``frame = "tight"``, fitted on them with the spec's margin
    (:func:`gshade.rendering.camera.fit_view`).

    Raises
    ------
    GshadeError
        ``SPEC: frame: row ROW: ...`` where no fitted view shows the surfaces (a
        perspective eye among them).
    """
    from ..rendering.camera import fit_view, frame_view
    from ..rendering.sizing import extent_points

    geometries: dict[str, dict] = {}
    for col in spec.columns:
        surface = {k: v for k, v in col.overrides.items() if k.split(".")[0] == "surface"}
        geometries.setdefault(json.dumps(surface, sort_keys=True, default=str), surface)
    scenes = [_load(row, surface, spec) for surface in geometries.values()]
    points = np.concatenate([extent_points(scene) for scene in scenes])
    try:
        view = frame_view(scenes[0].camera, points, spec.width, spec.height)
    except GshadeError as exc:  # "[camera] ...": the row's scene camera with the spec's keys
        raise GshadeError(f"{spec.path}: row {row}: {exc}") from None
    if spec.frame == "tight":
        try:
            view = fit_view(view, points, spec.margin)
        except GshadeError as exc:
            raise GshadeError(f"{spec.path}: frame: row {row}: {exc}") from None
    camera = {
        "camera.type": view.type,
        "camera.origin": [float(c) for c in view.origin],
        "camera.target": [float(c) for c in view.target],
        "camera.up": [float(c) for c in view.up],
        "camera.fov": float(view.fov),
    }
    if view.width is not None:
        camera["camera.width"] = float(view.width)
    return camera


def _display_rgb(image: RenderedImage) -> np.ndarray:
    """sRGB picture over white, for the panels."""
    from ..io.image import linear_to_srgb

    a = image.alpha[..., None]
    rgb = image.straight_rgb
    return np.clip(linear_to_srgb(np.clip(rgb, 0, 1)) * a + (1 - a), 0, 1)


def make_figure(spec: FigureSpec, output: str | os.PathLike) -> Path:
    """Render every panel and write the figure (format from the file's suffix)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from ..io.image import atomic_write

    output = Path(output)
    fmt = output.suffix.lower().lstrip(".")
    if fmt not in FORMATS:
        raise GshadeError(f"{output}: expected a .png, .pdf or .svg file")
    panels = []
    for r, row in enumerate(spec.rows):
        camera = row_camera(spec, row)
        spec.cameras[spec.row_labels[r]] = {k.split(".")[1]: v for k, v in camera.items()}
        row_panels = [_panel(row, {**col.overrides, **camera}, col, spec) for col in spec.columns]
        if spec.same_range:
            row_panels = _same_range(row, row_panels, spec)
        panels.append(row_panels)
        for panel in row_panels:
            spec.hashes[f"{spec.row_labels[r]} / {panel.column.label}"] = panel.scene.text_hash
    fig = _draw(plt, spec, panels)
    meta_text = json.dumps(
        {"gshade_version": __version__, "scene_hashes": spec.hashes, "cameras": spec.cameras}
    )
    metadata = {
        "png": {"Software": f"gshade {__version__}", "Description": meta_text},
        "pdf": {"Creator": f"gshade {__version__}", "Subject": meta_text},
        "svg": {"Creator": f"gshade {__version__}", "Description": meta_text},
    }[fmt]

    def save(tmp: str) -> None:
        fig.savefig(tmp, format=fmt, dpi=300, metadata=metadata)

    try:
        return atomic_write(output, f".{fmt}", save)
    finally:
        plt.close(fig)


#: The layout, in inches: a picture's width, the gaps between panels and around the
#: figure, the bands above a picture (its title) and below it (a line of notes, a colour bar
#: with its ticks and label) and the figure title's.
_PANEL_WIDTH, _GAP, _EDGE = 3.2, 0.2, 0.08
_TITLE_BAND, _NOTES_BAND, _BAR_BAND, _BAR_HEIGHT, _SUPTITLE_BAND = 0.28, 0.24, 0.55, 0.09, 0.4
#: The notes under a picture wrap at this many characters (8 pt in a picture's width), each
#: further line adding _NOTE_LINE inches.
_NOTE_CHARACTERS, _NOTE_LINE = 56, 0.15


def _draw(plt: ModuleType, spec: FigureSpec, panels: list[list[Panel]]) -> Figure:
    """The matplotlib figure: the panels in a grid, every picture of one size (the bands
    under a row are as tall as its panels' notes and colour bars need)."""
    nrows, ncols = len(panels), len(panels[0])
    pic_w = _PANEL_WIDTH
    pic_h = pic_w * spec.height / spec.width
    under = [  # per panel: the height of its notes and colour bar under the picture
        [(_notes_height(p.image), _BAR_BAND if _has_bar(p.image) else 0.0) for p in row_panels]
        for row_panels in panels
    ]
    top = _SUPTITLE_BAND if spec.title else _EDGE
    row_h = [_TITLE_BAND + pic_h + max(n + b for n, b in row) for row in under]
    fig_w = 2 * _EDGE + ncols * pic_w + (ncols - 1) * _GAP
    fig_h = top + sum(row_h) + (nrows - 1) * _GAP + _EDGE
    fig = plt.figure(figsize=(fig_w, fig_h))
    if spec.title:
        fig.suptitle(spec.title, y=1.0 - 0.1 / fig_h, va="top")
    y = fig_h - top  # the top of the current row, inches from the bottom
    for r, row_panels in enumerate(panels):
        pic_top = y - _TITLE_BAND
        for c, panel in enumerate(row_panels):
            x = _EDGE + c * (pic_w + _GAP)
            ax = fig.add_axes((x / fig_w, (pic_top - pic_h) / fig_h, pic_w / fig_w, pic_h / fig_h))
            title = panel.column.label or panel.image.legend.function
            title = title if nrows == 1 else f"{spec.row_labels[r]}: {title}"
            bar_y = pic_top - pic_h - under[r][c][0] - _BAR_HEIGHT - 0.06
            bar = (
                (x + 0.05 * pic_w) / fig_w,
                bar_y / fig_h,
                0.9 * pic_w / fig_w,
                _BAR_HEIGHT / fig_h,
            )
            _draw_panel(fig, ax, panel.image, title, bar)
        y -= row_h[r] + _GAP
    return fig


def _notes(image: Any) -> list[str]:
    """The notes under a panel: the stripes' period, the bands in words, the junction
    classes drawn, the legend's notes (the combs' scale, the umbilics ringed, the smallest
    radius)."""
    legend = image.legend
    notes = []
    if legend.period is not None:
        of = f" of {legend.stripe_function}" if legend.stripe_function else ""
        notes.append(f"stripes{of} every {legend.period:.3g}")
    if legend.display == "bands" and legend.bands:
        notes.append(f"bands: {legend.bands}")
    classes = _junction_classes(image)
    if classes:
        named = ", ".join(f"{c} {JUNCTION_COLOUR_NAMES[c]}" for c in classes)
        notes.append(f"junctions: {named}")
    notes.extend(legend.notes)
    return notes


def _note_lines(image: Any) -> list[str]:
    """The notes under a panel, wrapped to the picture's width."""
    import textwrap

    return textwrap.wrap("; ".join(_notes(image)), _NOTE_CHARACTERS, break_on_hyphens=False)


def _notes_height(image: Any) -> float:
    """The height (inches) of the band the notes under a panel take (none: 0)."""
    lines = len(_note_lines(image))
    return _NOTES_BAND + (lines - 1) * _NOTE_LINE if lines else 0.0


def _has_bar(image: Any) -> bool:
    return image.legend.value_range is not None and bool(image.legend.colormap)


def _draw_panel(
    fig: Figure, ax: Axes, image: Any, title: str, bar: tuple[float, float, float, float]
) -> None:
    """A panel: the picture, its title, the notes under it and, for a colour-mapped
    picture, the colour bar in its own axes at ``bar`` (figure fractions)."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    ax.imshow(_display_rgb(image), interpolation="nearest")
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title(title, fontsize=9)
    notes = _note_lines(image)
    if notes:
        ax.set_xlabel("\n".join(notes), fontsize=8, labelpad=3)
    if _has_bar(image):
        legend = image.legend
        lo, hi = legend.value_range
        colourbar = fig.colorbar(
            ScalarMappable(Normalize(lo, hi), cmap=legend.colormap),
            ax=ax,  # the panel it belongs to (unused for the layout: cax is given)
            cax=fig.add_axes(bar),
            orientation="horizontal",
        )
        units = f" [{legend.units}]" if legend.units else ""
        colourbar.set_label(f"{legend.function} (order {legend.order}){units}", fontsize=8)
        colourbar.ax.tick_params(labelsize=7)


def _junction_classes(image: RenderedImage) -> list[str]:
    """The continuity classes of the junctions drawn over a panel (in the legend's order)."""
    if "junctions" not in image.metadata:
        return []
    drawn = {j["class"] for j in json.loads(image.metadata["junctions"])["junctions"]}
    return [c for c in JUNCTION_COLOUR_NAMES if c in drawn]


def _same_range(row: Path, row_panels: list[Panel], spec: FigureSpec) -> list[Panel]:
    """Re-render a row's colour-mapped panels of the same function with one shared range."""
    by_function: dict[str, list[int]] = {}
    for k, panel in enumerate(row_panels):
        legend = panel.image.legend
        if legend.value_range is not None and "shape.range" not in panel.column.overrides:
            by_function.setdefault(legend.function, []).append(k)
    for indices in by_function.values():
        if len(indices) < 2:
            continue
        lo = min(row_panels[k].image.legend.value_range[0] for k in indices)
        hi = max(row_panels[k].image.legend.value_range[1] for k in indices)
        for k in indices:
            panel = row_panels[k]
            overrides = {**panel.overrides, "shape.range": [lo, hi]}
            row_panels[k] = _panel(row, overrides, panel.column, spec)
    return row_panels
