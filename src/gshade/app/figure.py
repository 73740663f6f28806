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
    [[column]]
    label = "planar sections"
    set = { "shape.function" = "planar_sections", "shape.stripes" = 30 }

PNG is written at 300 dpi; PDF and SVG are vector around the raster panels.  The figure's
metadata records gshade's version and every panel's scene hash.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import GshadeError

__all__ = ["FigureSpec", "load_figure_spec", "make_figure"]

_KEYS = ("title", "rows", "row_labels", "column", "width", "height", "spp", "same_range")
_COLUMN_KEYS = ("label", "set")
FORMATS = ("png", "pdf", "svg")


@dataclass
class Column:
    label: str
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
    hashes: dict = field(default_factory=dict)


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
        if not isinstance(col, dict):
            raise GshadeError(f"{path}: [[column]] {k}: expected a table")
        for key in col:
            if key not in _COLUMN_KEYS:
                raise GshadeError(
                    f"{path}: [[column]] {k}: {key}: unknown key "
                    f"(expected one of: {', '.join(_COLUMN_KEYS)})"
                )
        overrides = col.get("set", {})
        if not isinstance(overrides, dict):
            raise GshadeError(f"{path}: [[column]] {k}: set: expected a table of scene keys")
        columns.append(Column(str(col.get("label", "")), _flatten(overrides)))
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
    return spec


def _flatten(table: dict, prefix: str = "") -> dict:
    out = {}
    for key, value in table.items():
        if isinstance(value, dict):
            out.update(_flatten(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def _panel(scene_path: Path, overrides: dict, spec: FigureSpec):
    from ..rendering import render
    from ..scene import load_scene

    all_overrides = {
        "render.width": spec.width,
        "render.height": spec.height,
        "render.spp": spec.spp,
        **overrides,
    }
    scene = load_scene(scene_path, all_overrides)
    return scene, render(scene)


def _display_rgb(image) -> np.ndarray:
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
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    from ..io.image import atomic_write

    output = Path(output)
    fmt = output.suffix.lower().lstrip(".")
    if fmt not in FORMATS:
        raise GshadeError(f"{output}: expected a .png, .pdf or .svg file")
    panels = []
    for r, row in enumerate(spec.rows):
        row_panels = [(*_panel(row, col.overrides, spec), col) for col in spec.columns]
        if spec.same_range:
            row_panels = _same_range(row, row_panels, spec)
        panels.append(row_panels)
        for scene, _, col in row_panels:
            spec.hashes[f"{spec.row_labels[r]} / {col.label}"] = scene.text_hash
    nrows, ncols = len(spec.rows), len(spec.columns)
    aspect = spec.height / spec.width
    panel_w = 3.2
    fig, axes = plt.subplots(
        nrows,
        ncols,
        figsize=(panel_w * ncols, (panel_w * aspect + 0.9) * nrows + 0.4),
        squeeze=False,
    )
    if spec.title:
        fig.suptitle(spec.title)
    for r, row_panels in enumerate(panels):
        for c, (_, image, col) in enumerate(row_panels):
            ax = axes[r][c]
            ax.imshow(_display_rgb(image), interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            legend = image.legend
            title = col.label or legend.function
            ax.set_title(title if nrows == 1 else f"{spec.row_labels[r]}: {title}", fontsize=9)
            notes = []
            if legend.period is not None:
                of = f" of {legend.stripe_function}" if legend.stripe_function else ""
                notes.append(f"stripes{of} every {legend.period:.3g}")
            if legend.value_range is not None and legend.colormap:
                lo, hi = legend.value_range
                bar = fig.colorbar(
                    ScalarMappable(Normalize(lo, hi), cmap=legend.colormap),
                    ax=ax,
                    orientation="horizontal",
                    fraction=0.06,
                    pad=0.04,
                )
                units = f" [{legend.units}]" if legend.units else ""
                bar.set_label(f"{legend.function} (order {legend.order}){units}", fontsize=8)
                bar.ax.tick_params(labelsize=7)
            if notes:
                ax.set_xlabel("; ".join(notes), fontsize=8)
    fig.tight_layout()
    meta_text = json.dumps({"gshade_version": __version__, "scene_hashes": spec.hashes})
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


def _same_range(row: Path, row_panels: list, spec: FigureSpec) -> list:
    """Re-render a row's colour-mapped panels of the same function with one shared range."""
    by_function: dict[str, list[int]] = {}
    for k, (_, image, col) in enumerate(row_panels):
        legend = image.legend
        if legend.value_range is not None and "shape.range" not in col.overrides:
            by_function.setdefault(legend.function, []).append(k)
    for indices in by_function.values():
        if len(indices) < 2:
            continue
        lo = min(row_panels[k][1].legend.value_range[0] for k in indices)
        hi = max(row_panels[k][1].legend.value_range[1] for k in indices)
        for k in indices:
            col = row_panels[k][2]
            scene, image = _panel(row, {**col.overrides, "shape.range": [lo, hi]}, spec)
            row_panels[k] = (scene, image, col)
    return row_panels
