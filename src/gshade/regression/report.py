"""The report of a reference check: an HTML page (the images embedded as PNG), failures
first, ``summary.json`` with every scene's verdict, message and metrics, and for every
rendered scene an inspectable view (``views/NAME.html``, :mod:`gshade.display.html_view`:
exact values under the cursor, new and reference flipped, side by side and differenced),
the failures' views shown in the report itself.  A scene checked against a geometric
reference (``[check] reference_model``) also shows its deviation numbers and picture (with
its legend), and ``summary.json`` its ``geometry`` verdict and ``deviation`` numbers."""

from __future__ import annotations

import base64
import html
import io
import json
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..analysis.deviation import deviation_rows
from ..errors import GshadeError
from ..io.printable import printable
from .check import CheckResult
from .comparison import Comparison, heat_map

if TYPE_CHECKING:
    from ..rendering.rendered_image import RenderedImage

__all__ = ["deviation_page", "deviation_table", "write_report"]

_ORDER = {"ERROR": 0, "FAILURE": 1, "WARNING": 2, "NEW": 3, "PASS": 4}


def _encode_png(img: np.ndarray) -> str:
    """An 8-bit image as a data: URL, for embedding in the report."""
    import imageio.v3 as iio

    buf = io.BytesIO()
    iio.imwrite(buf, img, extension=".png")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _picture(channels: dict) -> str | None:
    """The picture as its PNG shows it, as a data: URL (None without R, G and B)."""
    from ..io.image import srgb8, straight_rgb

    if not all(c in channels for c in "RGB"):
        return None
    return _encode_png(srgb8(straight_rgb(channels), channels.get("A")))


#: A reference image as read: channels (float16 where the EXR stores halves) and header.
_Image = tuple[dict, dict]


def _reference(r: CheckResult) -> _Image | None:
    """The scene's reference, read once for its thumbnail and its view (None if it was just
    written, is missing or does not read: the verdict says so)."""
    from ..io.image import read_exr_planes

    if r.reference is None or not r.reference.exists() or r.written:
        return None
    try:
        channels, header, _, _ = read_exr_planes(r.reference)
    except GshadeError:
        return None
    return dict(channels), dict(header)


def _figures(r: CheckResult, reference: _Image | None) -> str:
    """The new image, the reference (unless just written) and the difference heat map."""
    cells = []
    if r.image is not None:
        cells.append(("new", _picture(r.image.channels)))
    if reference is not None:
        as_float32 = {k: np.asarray(v, dtype=np.float32) for k, v in reference[0].items()}
        cells.append(("reference", _picture(as_float32)))
    if r.comparison is not None:
        label = f"|difference| (max {r.comparison.overall.max_error:.3g})"
        cells.append((label, _encode_png(heat_map(r.comparison))))
    if r.deviation_image is not None and r.deviation is not None:
        label = f"deviation from {printable(r.deviation['b'])} (±{r.deviation['tolerance']:.6g})"
        cells.append((label, _deviation_picture(r.deviation_image)))
    return "".join(
        f'<figure><img src="{src}" alt="{html.escape(label)}"><figcaption>'
        f"{html.escape(label)}</figcaption></figure>"
        for label, src in cells
        if src
    )


def _deviation_picture(image: RenderedImage) -> str:
    """The deviation picture with its legend's strip below it, as a data: URL."""
    from ..display.legend_strip import with_legend
    from ..io.image import srgb8

    rgb, alpha = image.straight_rgb, image.alpha
    if image.legend is not None:
        rgb, alpha = with_legend(rgb, alpha, image.legend)
    return _encode_png(srgb8(rgb, alpha))


def _deviation(r: CheckResult) -> str:
    """The deviation numbers of a scene with a reference model, as a table."""
    if r.reference_model is None or r.deviation is None:
        return ""
    rows = [("geometry", r.geometry), ("reference model", printable(r.reference_model))]
    return deviation_table(rows + deviation_rows(r.deviation, r.name))


def deviation_table(rows: list[tuple[str, str]]) -> str:
    """(label, text) rows as an HTML table, the text escaped."""
    return (
        '<table class="deviation">'
        + "".join(f"<tr><th>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>" for k, v in rows)
        + "</table>"
    )


def deviation_page(image: RenderedImage, summary: dict[str, Any], title: str) -> str:
    """A page of its own for ``gshade deviation --html``: the picture with its legend and
    the numbers (:func:`gshade.analysis.deviation.deviation_rows`; those over A's whole
    surface and the Hausdorff distances where measured), every text escaped."""
    parts = [
        '<!doctype html><html><head><meta charset="utf-8">',
        f"<title>{html.escape(title)}</title><style>{_STYLE}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>",
        f'<img alt="deviation" src="{_deviation_picture(image)}">',
        "<h2>in view</h2>",
        deviation_table(deviation_rows(summary, summary.get("a", "A"))),
    ]
    if "whole" in summary:
        parts += ["<h2>over the whole surface</h2>"]
        parts.append(deviation_table(deviation_rows(summary["whole"], summary.get("a", "A"))))
    if "hausdorff" in summary:
        h = summary["hausdorff"]
        parts.append("<h2>Hausdorff distance</h2>")
        parts.append(
            deviation_table(
                [
                    ("A to B", f"{h['a_to_b']:.9g}"),
                    ("B to A", f"{h['b_to_a']:.9g}"),
                    ("both ways", f"{h['both']:.9g}"),
                    ("sampled", f"{h['samples']} points of each, by area"),
                ]
            )
        )
    parts.append("</body></html>")
    return "".join(parts)


def _metrics(comparison: Comparison | None) -> str:
    """The per-channel metrics as a table."""
    if comparison is None:
        return ""
    return (
        "<table><tr><th>channel</th><th>max</th><th>mean</th><th>RMSE</th>"
        "<th>PSNR (dB)</th></tr>"
        + "".join(
            f"<tr><td>{html.escape(c)}</td><td>{m.max_error:.4g}</td>"
            f"<td>{m.mean_error:.4g}</td><td>{m.rmse:.4g}</td><td>{m.psnr:.4g}</td></tr>"
            for c, m in comparison.per_channel.items()
        )
        + "</table>"
    )


def _write_view(
    r: CheckResult, reference: _Image | None, folder: Path, taken: set[str]
) -> tuple[str | None, list[str]]:
    """Write the scene's view page (new and, if there is one, reference) into
    ``folder/views``: its path relative to ``folder`` (None without a new image, or when the
    page cannot be made) and the notes for the scene's section, one line each: the header
    attributes left out of the view (a hostile or broken reference), or why there is no
    view.  Nothing here ends the report: a bad reference costs its scene's view at most."""
    from ..display.html_view import view_writer
    from ..io.output_folders import output_folder
    from ..io.outputs import atomic_write

    if r.image is None:
        return None, []
    images: list = [(r.image.channels, r.image.metadata)]
    labels = ["new"]
    if reference is not None:
        images.append(reference)
        labels.append("reference")
    stem = re.sub(r"[^\w.-]", "_", r.name) or "scene"
    name, k = stem, 1
    while name in taken:
        name, k = f"{stem}-{k}", k + 1
    taken.add(name)
    target = folder / "views" / f"{name}.html"
    try:
        writer = view_writer(images, target, labels=labels, title=r.name)
        notes = [_named(note, r) for note in writer.notes]
        output_folder(folder, "views")  # made if need be, never through a link
        atomic_write(target, ".html", writer)
    except (GshadeError, OSError) as exc:
        return None, [f"no view: {_named(str(exc), r)}"]
    except Exception as exc:  # a bug must not cost the other scenes their report
        return None, [f"no view: {type(exc).__name__}: {exc} (a bug: please report it)"]
    return f"views/{name}.html", notes


def _named(text: str, r: CheckResult) -> str:
    """A note of the view's as the report says it: the images by their files."""
    for label, path in (("reference", r.reference), ("new", None)):
        if text.startswith(f"{label}: "):
            return f"{path or 'the new image'}: {text.removeprefix(label + ': ')}"
    return text


def _section(r: CheckResult, reference: _Image | None, view: str | None, notes: list[str]) -> str:
    """One scene's section: verdict, message, pictures, metrics, the view (and notes on it)
    and the log."""
    status = f"{r.status} ({r.written} reference)" if r.written else r.status
    inspect = ""
    if view is not None:
        href = html.escape(view)
        inspect = (
            f'<p><a href="{href}">inspect: exact values under the cursor, new and reference '
            "flipped, side by side, differenced</a></p>"
        )
        if r.status in ("FAILURE", "ERROR") and not r.written:
            inspect += f'<iframe src="{href}" title="{html.escape(r.name)}"></iframe>'
    inspect += "".join(f'<p class="note">{html.escape(note)}</p>' for note in notes)
    return (
        f'<section class="{html.escape(r.status.lower())}"><h2>{html.escape(status)}: '
        f"{html.escape(r.name)}</h2><p>{html.escape(str(r.scene))}: "
        f"{html.escape(r.message)}</p>{_figures(r, reference)}{_metrics(r.comparison)}"
        f"{_deviation(r)}{inspect}"
        + (f"<pre>{html.escape(r.log)}</pre>" if r.log else "")
        + "</section>"
    )


def _geometry_entry(r: CheckResult) -> dict[str, Any]:
    """summary.json's geometry of a scene with a reference model (nothing without one)."""
    if r.reference_model is None:
        return {}
    return {
        "reference_model": printable(r.reference_model),
        "geometry": r.geometry,
        "deviation": r.deviation,
    }


_STYLE = (
    "body{font-family:sans-serif;margin:1em}figure{display:inline-block;margin:4px}"
    "img{image-rendering:pixelated;background:#444;max-width:480px}"
    "section{border-top:1px solid #ccc;padding:.5em 0}.failure h2,.error h2{color:#b00}"
    ".warning h2{color:#a60}.pass h2{color:#070}td,th{padding:0 .6em;text-align:right}"
    "iframe{width:100%;height:720px;border:1px solid #ccc}"
    ".deviation th{text-align:left}"
    ".note{border-left:3px solid #c80;padding:2px 6px;background:#fff6e0}"
)


def write_report(results: list[CheckResult], folder: Path) -> Path:
    """Write ``report.html`` and ``summary.json`` into ``folder`` (created if need be).

    Parameters
    ----------
    results : list of CheckResult
        As :func:`gshade.regression.check.check` returns them.
    folder : path-like

    Returns
    -------
    Path
        The HTML page (images embedded), failures first; each rendered scene's view page in
        ``folder/views`` (self-contained), the failures' views framed in the report.
    """
    from ..io.image import atomic_write

    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise GshadeError(f"{folder}: cannot create the report folder ({exc.strerror})") from None
    ordered = sorted(
        results,
        key=lambda r: (_ORDER.get(r.status, 0) if not (r.written and r.ok) else 4, r.name),
    )
    counts = {s: sum(r.status == s for r in results) for s in _ORDER}
    taken: set[str] = set()
    sections, views, notes = [], {}, {}
    for r in ordered:
        reference = _reference(r)
        views[id(r)], notes[id(r)] = _write_view(r, reference, folder, taken)
        sections.append(_section(r, reference, views[id(r)], notes[id(r)]))
    page = (
        "<!DOCTYPE html><html><head><meta charset='utf-8'><title>gshade check</title><style>"
        + _STYLE
        + "</style></head><body><h1>gshade check</h1><p>"
        + ", ".join(f"{n} {html.escape(s)}" for s, n in counts.items())
        + "</p>"
        + "".join(sections)
        + "</body></html>"
    )
    atomic_write(
        folder / "report.html", ".html", lambda tmp: Path(tmp).write_text(page, encoding="utf-8")
    )
    summary = {
        "counts": counts,
        "scenes": [
            {
                "name": r.name,
                "scene": str(r.scene),
                "status": r.status,
                "message": r.message,
                "written": r.written or None,
                "seconds": round(r.seconds, 3),
                "metrics": r.comparison.as_dict() if r.comparison is not None else None,
                "view": views.get(id(r)),
                "view_notes": notes.get(id(r), []),
                **_geometry_entry(r),
            }
            for r in ordered
        ],
    }
    atomic_write(
        folder / "summary.json",
        ".json",
        lambda tmp: Path(tmp).write_text(json.dumps(summary, indent=2)),
    )
    return folder / "report.html"
