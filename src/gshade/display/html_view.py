"""One self-contained HTML page to look into EXR images: the picture, zoom and pan, every
data channel under the cursor, false colours, the junctions, and with a second image flip,
side by side and the difference.

The page loads nothing: its script, style and data are inline (the script and style are
the package's files ``display/view/view.js`` and ``view.css``).  Each image's channels are
embedded bit for bit (:mod:`gshade.display.view_data`: half channels as halves, float32 as
float32), so the readout prints the values the EXR holds, with the digits that read back
to them (at most 9 significant digits for float32, 5 for half).  The picture is shown as
gshade's PNGs show it (straight colour, sRGB, 8 bits).

Nothing read from a file is trusted: the header attributes the page shows are validated
(:mod:`gshade.display.view_header`; a bad one is left out with a note on the page and in
:attr:`PageWriter.notes`), every size is bounded before anything is allocated, the page's
script keeps channel names out of object keys (``Map``) and puts every text into the page
as text (``textContent``), never as markup.
"""

from __future__ import annotations

import html
import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from importlib import resources
from pathlib import Path
from typing import cast

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from .view_data import (
    ENCODING,
    colour_table,
    junction_seams,
    pack_planes,
    picture_rgba8,
    scalar_scales,
)
from .view_header import ViewHeader, view_header

__all__ = [
    "MAX_CHANNELS",
    "MAX_CHANNEL_NAME",
    "MAX_IMAGES",
    "MAX_PIXELS",
    "MAX_VALUES",
    "PageWriter",
    "ViewParts",
    "view_data",
    "view_page",
    "view_parts",
    "view_writer",
    "write_view",
]

#: An image: an EXR file, or its channels and header as :func:`gshade.io.image.read_exr`
#: (or ``read_exr_planes``, whose float16 arrays stay halves) return them.
Image = str | os.PathLike | tuple[Mapping[str, NDArray], Mapping[str, object]]

#: Images one page shows (new, reference and a third, e.g. a difference EXR).
MAX_IMAGES = 3
#: Pixels of one image (4096 x 4096): a larger page is more than a browser holds well.
MAX_PIXELS = 1 << 24
#: Channels of one image, the longest channel name (characters), and the most channel
#: values of one page (all images): 2**29 float32 values are 2 GiB in the browser.
MAX_CHANNELS = 256
MAX_CHANNEL_NAME = 1024
MAX_VALUES = 1 << 29
#: The channels' order in the readout (the others follow in the file's order).
_ORDER = ("f", "f.mean", "f2")
_TAIL = (
    *("P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z", "refl.X", "refl.Y", "refl.Z"),
    *("u", "v", "patch", "R", "G", "B", "A"),
)


@dataclass(frozen=True)
class ViewParts:
    """A view as parts of a page, for pages that embed it (one view per page).

    ``style`` goes into a ``<style>`` element, ``markup`` (the view's element and its data)
    into the body, ``script`` into a ``<script>`` element after it."""

    style: str
    markup: str
    script: str


@cache
def _asset(name: str) -> str:
    return (resources.files("gshade.display") / "view" / name).read_text(encoding="utf-8")


def _as_list(images: Image | Sequence[Image]) -> list[Image]:
    if isinstance(images, (str, os.PathLike)):
        return [images]
    if isinstance(images, tuple) and len(images) == 2 and isinstance(images[0], Mapping):
        return [cast(Image, images)]  # one (channels, header) pair
    if not isinstance(images, Sequence):
        raise GshadeError(
            f"images: expected EXR paths or (channels, header) pairs, got {type(images).__name__}"
        )
    return list(cast(Sequence[Image], images))


def _load(image: Image, k: int) -> tuple[dict[str, NDArray], dict[str, object], str]:
    """Channels (float16 or float32 arrays), header and a default label; the file's size
    bounded before it is read (:func:`gshade.io.image.read_exr_planes`)."""
    if isinstance(image, (str, os.PathLike)):
        from ..io.image import read_exr_planes

        channels, header, _, _ = read_exr_planes(image)
        return dict(channels), dict(header), Path(image).name
    if not (
        isinstance(image, tuple)
        and len(image) == 2
        and isinstance(image[0], Mapping)
        and isinstance(image[1], Mapping)
    ):
        raise GshadeError(
            f"images[{k}]: expected an EXR path or a (channels, header) pair of dicts, got "
            f"{type(image).__name__}"
        )
    out: dict[str, NDArray] = {}
    for name, data in image[0].items():
        if not isinstance(name, str):
            raise GshadeError(f"images[{k}]: expected channel names as strings, got {name!r}")
        a = np.asarray(data)
        if a.dtype.kind not in "biuf" or a.ndim != 2:
            raise GshadeError(
                f"images[{k}]: channel {name!r}: expected a 2-D array of real numbers, got "
                f"shape {a.shape} and dtype {a.dtype}"
            )
        out[str(name)] = a if a.dtype in (np.float16, np.float32) else a.astype(np.float32)
    return out, dict(image[1]), f"image {'ABC'[k]}"


def _check_sizes(loaded: list, labels: list[str]) -> tuple[int, int]:
    shapes = []
    for (channels, _, _), label in zip(loaded, labels, strict=True):
        if not channels:
            raise GshadeError(f"{label}: expected an image with channels, got none")
        if len(channels) > MAX_CHANNELS:
            raise GshadeError(
                f"{label}: expected at most {MAX_CHANNELS} channels, got {len(channels)}"
            )
        for name in channels:
            if not name or len(name) > MAX_CHANNEL_NAME:
                raise GshadeError(
                    f"{label}: expected channel names of 1 to {MAX_CHANNEL_NAME} characters, "
                    f"got one of {len(name)}"
                )
        found = {a.shape for a in channels.values()}
        if len(found) != 1:
            raise GshadeError(f"{label}: expected channels of one size, got {sorted(found)}")
        shapes.append(found.pop())
    if len(set(shapes)) != 1:
        sizes = ", ".join(
            f"{w}x{h} ({label})" for (h, w), label in zip(shapes, labels, strict=True)
        )
        raise GshadeError(f"images: expected images of one size, got {sizes}")
    h, w = shapes[0]
    if h * w > MAX_PIXELS or 0 in (h, w):
        raise GshadeError(
            f"images: expected at most {MAX_PIXELS} pixels (4096 x 4096) per image, got {w}x{h}"
        )
    values = h * w * sum(len(channels) for channels, _, _ in loaded)
    if values > MAX_VALUES:
        raise GshadeError(
            f"images: expected at most {MAX_VALUES} channel values in one page, got {values} "
            f"({w}x{h} pixels, {sum(len(c) for c, _, _ in loaded)} channels)"
        )
    return w, h


def _ordered(names: list[str]) -> list[str]:
    first = [n for n in _ORDER if n in names]
    last = [n for n in _TAIL if n in names]
    return first + [n for n in names if n not in first and n not in last] + last


def _channel_entries(channels: Mapping[str, NDArray]) -> list[dict]:
    """Each channel packed (:func:`gshade.display.view_data.pack_planes`) with its stored
    type; a channel equal bit for bit to an earlier one refers to it (``same_as``)."""
    entries: list[dict] = []
    kept: list[tuple[str, NDArray]] = []
    for name in _ordered(list(channels)):
        a = np.ascontiguousarray(channels[name])
        stored = "float16" if a.dtype == np.float16 else "float32"
        bits = a.view(np.uint16 if stored == "float16" else np.uint32)
        twin = next((n for n, b in kept if b.dtype == bits.dtype and np.array_equal(b, bits)), None)
        if twin is not None:
            entries.append({"name": name, "stored": stored, "same_as": twin})
            continue
        kept.append((name, bits))
        entries.append({"name": name, "stored": stored, "data": pack_planes(bits)})
    return entries


def _is_cad(header: Mapping[str, object], junctions: Sequence[Mapping]) -> bool:
    """Whether the image shows a CAD model, whose ``patch`` channel numbers faces: the
    header's ``patch_channel`` says ``"face"`` (gshade 0.8 writes it), or (older images) its
    junctions are B-rep edges, or an attribute says so (``cad``, a length unit)."""
    numbered = header.get("patch_channel", header.get("gshade:patch_channel"))
    if numbered in ("face", "patch"):
        return numbered == "face"
    if any("edge" in j for j in junctions):
        return True
    unit = header.get("length_unit", header.get("gshade:length_unit"))
    flag = str(header.get("cad", header.get("gshade:cad", ""))).lower()
    return flag in ("1", "true", "yes") or (isinstance(unit, str) and unit not in ("", "length"))


def _image_data(channels: dict, header: ViewHeader, label: str) -> dict:
    junctions = header.junctions
    seams = None
    if junctions and "patch" in channels:
        planes = junction_seams(channels["patch"], junctions)
        if planes.shape[2]:
            seams = {"count": int(planes.shape[2]), "data": pack_planes(planes)}
    picture = picture_rgba8(channels)
    return {
        "label": label,
        "header": header.attributes,
        "settings": header.settings,
        "channels": _channel_entries(channels),
        "picture": None if picture is None else pack_planes(picture),
        "cad": _is_cad(header.attributes, junctions),
        "junctions": junctions or None,
        "junction_colours": header.colours,
        "left_out": header.left_out,
        "seams": seams,
    }


def view_data(
    images: Image | Sequence[Image],
    *,
    labels: Sequence[str] | None = None,
    title: str | None = None,
) -> dict:
    """The page's data (JSON-ready): what :func:`view_page` embeds.  See there."""
    items = _as_list(images)
    if not 1 <= len(items) <= MAX_IMAGES:
        raise GshadeError(f"images: expected 1 to {MAX_IMAGES} images, got {len(items)}")
    if labels is not None and (
        isinstance(labels, str)
        or len(labels) != len(items)
        or not all(isinstance(s, str) for s in labels)
    ):
        raise GshadeError(f"labels: expected {len(items)} strings (one per image), got {labels!r}")
    loaded = [_load(image, k) for k, image in enumerate(items)]
    names = list(labels) if labels is not None else [label for _, _, label in loaded]
    width, height = _check_sizes(loaded, names)
    headers = [view_header(header) for _, header, _ in loaded]
    scales = scalar_scales([c for c, _, _ in loaded], headers[0].settings)
    import matplotlib

    for s in scales.values():  # a header's unknown map: gshade's default
        if s["colormap"] not in matplotlib.colormaps:
            s["colormap"] = "coolwarm" if s["signed"] else "viridis"
    maps = {s["colormap"] for s in scales.values()} | {"inferno"}
    scene = headers[0].attributes.get("scene_name", "")
    sources = [
        str(item) if isinstance(item, (str, os.PathLike)) else name
        for item, name in zip(items, names, strict=True)
    ]
    data = {
        "format": 1,
        "encoding": ENCODING,
        "title": " / ".join(names) if title is None else str(title),
        "scene": scene if isinstance(scene, str) else "",
        "width": width,
        "height": height,
        "images": [
            _image_data(channels, header, name)
            for (channels, _, _), header, name in zip(loaded, headers, names, strict=True)
        ],
        "scales": scales,
        "colormaps": {name: colour_table(name) for name in sorted(maps)},
        "difference": [0, 1] if len(loaded) > 1 else None,
        "notes": [
            f"{source}: {note}"
            for source, header in zip(sources, headers, strict=True)
            for note in header.notes
        ],
    }
    return data


def _data_script(data: dict) -> str:
    text = json.dumps(data, allow_nan=False, separators=(",", ":"), ensure_ascii=True)
    # nothing in the data can end the script element or open a comment
    text = text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")
    return f'<script type="application/json" class="gshade-view-data">{text}</script>'


def view_parts(
    images: Image | Sequence[Image],
    *,
    labels: Sequence[str] | None = None,
    title: str | None = None,
) -> ViewParts:
    """The view as the parts of a page that embeds it (see :class:`ViewParts`); the
    parameters as for :func:`view_page`."""
    return _parts(view_data(images, labels=labels, title=title))


def _parts(data: dict) -> ViewParts:
    markup = f'<div class="gshade-view" data-gshade-view></div>\n{_data_script(data)}'
    return ViewParts(_asset("view.css"), markup, _asset("decode.js") + _asset("view.js"))


def view_page(
    images: Image | Sequence[Image],
    *,
    labels: Sequence[str] | None = None,
    title: str | None = None,
) -> str:
    """One self-contained HTML page showing 1 to 3 images.

    Parameters
    ----------
    images : path-like or (channels, header), or a sequence of 1 to 3 of them
        EXR files, or images as :func:`gshade.io.image.read_exr_planes` (half channels
        kept as float16, shown with half precision) or :func:`gshade.io.image.read_exr`
        returns them (all float32); all of one size.  With two or more, the page flips
        between them, shows them side by side, and shows the difference of the first two
        (new, reference) as a heat map; the readout shows every image's values and the
        difference.
    labels : sequence of str, optional
        One per image (default: the file names, or "image A", "image B" ...).
    title : str, optional
        The page's title (default: the labels).

    Returns
    -------
    str
        The page: no external resources, every channel embedded bit for bit.

    Raises
    ------
    GshadeError
        For a missing or unreadable file, a file that is not an OpenEXR image or is larger
        than ``limits.MAX_IMAGE_FILE_BYTES``, images of different sizes, more than
        :data:`MAX_PIXELS` pixels, :data:`MAX_CHANNELS` channels or :data:`MAX_VALUES`
        values, naming the image.  A malformed header attribute is no error: it is left
        out, and the page says so (``notes``; :mod:`gshade.display.view_header`).
    """
    return _page(view_data(images, labels=labels, title=title))


def _page(data: dict) -> str:
    parts = _parts(data)
    heading = html.escape(data["title"])
    return (
        '<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f"<title>{heading} · gshade view</title>\n"
        f"<style>\n{parts.style}</style>\n</head>\n<body>\n{parts.markup}\n"
        f"<script>\n{parts.script}</script>\n</body>\n</html>\n"
    )


@dataclass(frozen=True)
class PageWriter:
    """A page built (its errors raised), written to a file name given later (a temporary:
    :func:`gshade.io.outputs.staged`) by calling it.  ``notes``: the header attributes
    left out of the page, one line each (``FILE: header ATTRIBUTE: expected ..., got
    ...; shown without it``), for the command to say."""

    page: bytes
    target: Path
    notes: tuple[str, ...] = ()

    def __call__(self, name: str) -> None:
        try:
            Path(name).write_bytes(self.page)
        except OSError as exc:
            raise GshadeError(
                f"{self.target}: cannot write the file: {exc.strerror or exc}"
            ) from None


def view_writer(
    images: Image | Sequence[Image],
    output: str | os.PathLike,
    *,
    labels: Sequence[str] | None = None,
    title: str | None = None,
) -> PageWriter:
    """The page built now (errors raised now), as a :class:`PageWriter` writing it to a
    file name given later (a temporary: :func:`gshade.io.outputs.staged`).  ``output`` is
    the target the errors of writing name."""
    data = view_data(images, labels=labels, title=title)
    return PageWriter(_page(data).encode("utf-8"), Path(output), tuple(data["notes"]))


def write_view(
    images: Image | Sequence[Image],
    output: str | os.PathLike,
    *,
    labels: Sequence[str] | None = None,
    title: str | None = None,
) -> Path:
    """Write :func:`view_page` to ``output`` atomically; returns ``output``."""
    from ..io.outputs import atomic_write

    return atomic_write(output, ".html", view_writer(images, output, labels=labels, title=title))
