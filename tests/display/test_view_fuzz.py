"""The `gshade view` page fuzzed in a real browser (Playwright driving Debian's Chromium, as
tests/display/test_view_browser.py): EXRs with hostile channel names (``__proto__``, ``length``,
markup, quotes, control characters, 300 characters ...) and hostile header values
(malformed JSON, wrong types, huge sizes, NaN, markup in every text).  Every page must
mount without a page or console error, execute none of the injected markup (the
``window.__pwned`` flag its handlers would set stays unset, no element is made from it), and
read out every channel's value on hover.

Skipped without Chromium or Playwright, except where CI is set (then they fail).
``GSHADE_SCREENSHOTS=DIR`` keeps screenshots of a hostile page and of a plain one.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from gshade.display.html_view import view_page
from gshade.io.image import write_exr

from ..support.hostile_headers import HOSTILE

pytestmark = pytest.mark.slow  # hostile pages in a real browser

#: Markup that would set window.__pwned if the page ever made elements of it or ran it.
PWN = "window.__pwned=1"
MARKUP = [
    f"<img src=x onerror={PWN}>",
    f'"><svg onload="{PWN}">',
    f"</script><script>{PWN}</script>",
    f"<iframe srcdoc='<script>parent.{PWN}</script>'></iframe>",
    f"javascript:{PWN}//",
]

#: Channel names a page must keep apart from JavaScript's own names and from markup.
NAMES = [
    "__proto__",
    "constructor",
    "length",
    "toString",
    "hasOwnProperty",
    "valueOf",
    "picture",
    "N",
    *MARKUP[:2],
    "q\"uo'te",
    "back\\slash",
    "ctl\x01\x1f\x7f",
    "tab\tnew\nline",
    "ümlaut ✓ 𝔽 中",
    "y" * 300,
]

W, H = 6, 4


def values(k: int) -> np.ndarray:
    """Channel k's pixels: distinct exact binary fractions, so each readout is checkable."""
    return ((np.arange(W * H, dtype=np.float32).reshape(H, W) + 1) / 64 + k).astype(np.float32)


def picture() -> dict[str, np.ndarray]:
    channels = {
        c: np.full((H, W), v, np.float32) for c, v in zip("RGBA", (0.2, 0.4, 0.6, 1), strict=True)
    }
    channels["f"] = values(100)
    channels["patch"] = np.array([[0, 0, 1, 1, 2, 2]] * H, np.float32)
    return channels


def text_header(markup: str) -> dict[str, object]:
    """Markup in every text attribute the page shows (and in the settings and junctions)."""
    settings = {
        "shape": {
            "function": markup,
            "display": markup,
            "colormap": markup,
            "colour_function": markup,
            "params": {markup: markup},
            "period": 0.1,
        },
        "render": {"width": 6, "height": 4, "spp": 1, "lighting": markup},
        markup: markup,
    }
    junctions = {
        "colours": {"G1": [1.0, 0.4, 0.0]},
        "junctions": [
            {"class": "G1", "patches": [0, 1], "sides": ["u1", "u0"], "gap": "inf", "note": markup},
            {"class": "G2", "patches": [1, 2], "sides": ["u1", "u0"], "gap": 1e-9},
        ],
    }
    return {
        "scene_name": markup,
        "legend": markup,
        "gshade_version": markup,
        "variant": markup,
        "length_unit": markup,
        markup: markup,
        "settings": json.dumps(settings),
        "junctions": json.dumps(junctions),
    }


def _cases() -> dict[str, tuple[list, str]]:
    """Each page: its images ((channels, header) pairs) and title."""
    cases: dict[str, tuple[list, str]] = {}
    channels = picture()
    channels.update({name: values(k) for k, name in enumerate(NAMES)})
    cases["channel-names"] = ([(channels, {})], "names")
    cases["channel-names-pair"] = ([(channels, {}), (picture(), {})], "names / plain")
    for k, markup in enumerate(MARKUP):
        cases[f"markup-{k}"] = ([(picture(), text_header(markup))] * 2, markup)
    for name, (attribute, value) in HOSTILE.items():
        cases[f"header-{name}"] = ([(picture(), {attribute: value})], name)
    huge = json.dumps({"junctions": [{"class": "G1", "patches": [0, 2**31 - 1]}] * 1000})
    cases["header-huge-ids"] = ([(picture(), {"junctions": huge})], "huge ids")
    cases["header-nan-number"] = ([(picture(), {"x": float("nan"), "y": -1e308})], "nan")
    for only in (["A"], ["R"], ["P.X"], ["N.X", "N.Y"], ["__proto__", "length"]):
        cases["only-" + "-".join(only)] = ([({n: values(k) for k, n in enumerate(only)}, {})], "")
    return cases


CASES = _cases()


@pytest.fixture(scope="module")
def pages(tmp_path_factory) -> dict[str, Path]:
    """The pages, written once; one also from an EXR file whose channels carry the names
    (written and read by OpenEXR, which keeps names up to 255 bytes)."""
    folder = tmp_path_factory.mktemp("fuzz")
    out = {}
    for name, (images, title) in CASES.items():
        out[name] = folder / f"{name}.html"
        out[name].write_text(view_page(images, title=title), encoding="utf-8")
    channels = picture()
    channels.update({name[:200]: values(k) for k, name in enumerate(NAMES)})
    exr = write_exr(folder / f"{MARKUP[0]}.exr", channels)
    out["exr"] = folder / "exr.html"
    out["exr"].write_text(view_page([exr]), encoding="utf-8")
    return out


def load(browser, path: Path):
    """The page mounted: no page error, no console error, nothing injected ran."""
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(f"page error: {e}"))
    page.on("console", lambda m: errors.append(f"console: {m.text}") if m.type == "error" else None)
    page.goto(path.as_uri())
    page.wait_for_selector("[data-gshade-view][data-state]", timeout=20_000)
    state = page.get_attribute("[data-gshade-view]", "data-state")
    assert state == "ready", page.inner_text("[data-gshade-view]")
    return page, errors


def assert_clean(page, errors: list[str]) -> None:
    assert errors == []
    assert page.evaluate("() => window.__pwned") is None
    made = page.evaluate(
        """() => [...document.querySelectorAll('img, svg, iframe, script, a, [onerror], [onload]')]
        .filter((e) => !(e.tagName === 'SCRIPT' && !e.src && !e.hasAttribute('onload')))
        .map((e) => e.outerHTML.slice(0, 80))"""
    )
    assert made == []
    scripts = page.evaluate("() => document.scripts.length")
    assert scripts == 2  # the page's data and its code


def readout(page) -> dict[str, list[str]]:
    """The readout's rows: channel name -> the cells' texts."""
    rows = page.evaluate(  # as pairs: "__proto__" must stay a key
        """() => [...document.querySelectorAll('tr[data-channel]')].map((tr) => [
        tr.getAttribute('data-channel'),
        [...tr.querySelectorAll('td')].map((td) => td.textContent)])"""
    )
    return dict(rows)


def hover(page, x: int, y: int, image: int = 0) -> None:
    at = page.evaluate(f"gshadeView.clientOf({image}, {x}, {y})")
    page.mouse.move(at["clientX"], at["clientY"])


@pytest.mark.parametrize("case", [*CASES, "exr"])
def test_a_hostile_page_mounts_reads_out_and_runs_nothing(browser, pages, case):
    page, errors = load(browser, pages[case])
    images = CASES[case][0] if case != "exr" else None
    expected = images[0][0] if images else None
    for x, y in ((0, 0), (W - 1, H - 1), (2, 1)):
        hover(page, x, y)
        rows = readout(page)
        assert page.inner_text('td[data-role="pixel"][data-image="0"]') == f"{x}, {y}"
        if expected is not None:
            assert set(rows) == set(expected)
            for name, plane in expected.items():
                assert np.float32(float(rows[name][0])) == plane[y, x], (name, rows[name])
        else:
            assert len(rows) == 6 + len(NAMES)
            assert all(cells[0] not in ("", "—") for cells in rows.values())
    # every view paints (each channel's false colours, the picture, N, patches)
    for view in page.evaluate("gshadeView.views()"):
        page.select_option("[data-role=channel]", view)
        hover(page, 1, 1)
    assert_clean(page, errors)
    page.close()


def test_screenshots_of_a_hostile_and_a_plain_page(browser, pages, tmp_path):
    folder = Path(os.environ.get("GSHADE_SCREENSHOTS") or tmp_path)
    folder.mkdir(parents=True, exist_ok=True)
    shown = (
        ("markup-0", "fuzz-markup"),
        ("channel-names-pair", "fuzz-names"),
        ("header-junctions-colours-list", "fuzz-note"),
    )
    for case, name in shown:
        page, errors = load(browser, pages[case])
        hover(page, 2, 1)
        page.screenshot(path=str(folder / f"{name}.png"))
        legend = page.inner_text("[data-role=legend]")
        if case == "markup-0":
            assert MARKUP[0] in legend  # shown as text
            assert MARKUP[0] in page.inner_text("[data-role=junction]")
        notes = page.inner_text("[data-role=notes]")
        assert ("header junctions: expected colours" in notes) == (name == "fuzz-note")
        assert_clean(page, errors)
        page.close()
