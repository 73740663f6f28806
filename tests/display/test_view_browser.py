"""The `gshade view` page in a real browser (Playwright driving Debian's Chromium): the
readout under the mouse shows the EXR's values, zoom keeps the pixel under the cursor, the
channel switch and the difference view change the picture.

Without Chromium (``/usr/bin/chromium``) or Playwright the tests are skipped, except where
the environment variable CI is set: there they fail.  ``GSHADE_SCREENSHOTS=DIR`` saves
screenshots of the page into DIR (default: the test's temporary folder).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from gshade.display.view_data import junction_seams
from gshade.io.image import read_exr, read_exr_planes, write_exr

from ..support.browser import open_page
from ..support.view_pages import VIEW_SCENE, H, W, gshade

pytestmark = pytest.mark.slow  # a real browser

HALVES = {"R", "G", "B", "A", "N.X", "N.Y", "N.Z"}


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    """Image A: the teapot rendered at 160x120, 1 spp, junctions drawn, with its page
    (render --html).  Image B: A with f raised by 0.25 on the surface, R G B A N stored as
    halves.  The page of A and B (gshade view)."""
    folder = tmp_path_factory.mktemp("browser")
    a, b = folder / "a.exr", folder / "b.exr"
    result = gshade(
        "render",
        VIEW_SCENE,
        "-o",
        a,
        "--html",
        folder / "a.html",
        "--width",
        W,
        "--height",
        H,
        "--spp",
        1,
        "--junctions",
    )
    assert result.returncode == 0, result.stderr
    channels, header = read_exr(a)
    channels["f"] = np.where(channels["patch"] >= 0, channels["f"] + 0.25, 0).astype(np.float32)
    write_exr(b, channels, header, half=HALVES)
    result = gshade("view", a, b, "-o", folder / "ab.html")
    assert result.returncode == 0, result.stderr
    return {"a": a, "b": b, "one": folder / "a.html", "two": folder / "ab.html"}


@pytest.fixture(scope="module")
def shots(tmp_path_factory):
    folder = Path(os.environ.get("GSHADE_SCREENSHOTS") or tmp_path_factory.mktemp("shots"))
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def hover(page, x, y, image=0):
    """Move the mouse (a real event) to the centre of pixel (x, y) of an image."""
    at = page.evaluate(f"gshadeView.clientOf({image}, {x}, {y})")
    page.mouse.move(at["clientX"], at["clientY"])


def cell(page, channel, image=0):
    return page.inner_text(f'tr[data-channel="{channel}"] td[data-image="{image}"]')


def readout(page):
    return page.inner_text("[data-role=readout]")


def canvas_digest(page):
    return page.evaluate(
        """() => { const c = document.querySelector('[data-role=canvas]');
        const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
        let h = 0; for (let i = 0; i < d.length; i += 7) h = (h * 31 + d[i]) >>> 0; return h; }"""
    )


def sample_pixels(patch):
    """A few surface pixels spread over the image, and one of the background."""
    ys, xs = np.nonzero(patch >= 0)
    picks = [(int(xs[i]), int(ys[i])) for i in np.linspace(0, len(xs) - 1, 6).astype(int)]
    by, bx = np.nonzero(patch < 0)
    return [*picks, (int(bx[0]), int(by[0]))]


CHANNELS = ["f", "f.mean", "P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z", "u", "v", "patch", "R", "A"]


def test_readout_shows_the_exr_values(browser, pages):
    channels, _ = read_exr(pages["a"])
    page = open_page(browser, pages["one"])
    for x, y in sample_pixels(channels["patch"]):
        hover(page, x, y)
        assert page.inner_text('td[data-role="pixel"][data-image="0"]') == f"{x}, {y}"
        for name in CHANNELS:
            text = cell(page, name)
            assert np.float32(float(text)) == channels[name][y, x], (name, x, y, text)
            assert len(text.lstrip("-").replace(".", "").split("e")[0].lstrip("0")) <= 9
    # the patch row; the teapot is no CAD model
    assert page.inner_text('tr[data-channel="patch"] th') == "patch"
    page.close()


def test_both_images_and_their_difference(browser, pages):
    a, _ = read_exr(pages["a"])
    b, _, _, _ = read_exr_planes(pages["b"])
    page = open_page(browser, pages["two"])
    for x, y in sample_pixels(a["patch"])[:4]:
        hover(page, x, y)
        for name in ("f", "N.X", "N.Z", "u", "R"):
            ta, tb = cell(page, name, 0), cell(page, name, 1)
            assert np.float32(float(ta)) == a[name][y, x], (name, ta)
            if name in HALVES:  # a half prints with at most 5 digits and reads back to it
                assert np.float16(float(tb)) == b[name][y, x], (name, tb)
            else:
                assert np.float32(float(tb)) == b[name][y, x], (name, tb)
        difference = float(page.inner_text('tr[data-channel="f"] td[data-role="diff"]'))
        assert difference == pytest.approx(float(a["f"][y, x]) - float(b["f"][y, x]), rel=1e-5)
    page.close()


def test_zoom_keeps_the_pixel_under_the_cursor(browser, pages):
    page = open_page(browser, pages["one"])
    hover(page, 97, 41)
    before = readout(page)
    scale = page.evaluate("gshadeView.state().scale")
    for _ in range(4):
        page.mouse.wheel(0, -240)
    assert page.evaluate("gshadeView.state().scale") > 4 * scale
    assert readout(page) == before
    assert page.inner_text('td[data-role="pixel"][data-image="0"]') == "97, 41"
    # dragging pans: the pixel under the mouse changes by the drag over the scale
    s = page.evaluate("gshadeView.state().scale")
    at = page.evaluate("gshadeView.clientOf(0, 97, 41)")
    page.mouse.down()
    page.mouse.move(at["clientX"] + 3 * s, at["clientY"], steps=4)
    page.mouse.up()
    assert page.inner_text('td[data-role="pixel"][data-image="0"]') == "97, 41"
    page.mouse.move(at["clientX"] + 3 * s, at["clientY"])
    assert page.evaluate(f"gshadeView.pixelAt({at['clientX']}, {at['clientY']}).x") == 94
    page.close()


def test_channel_switch_changes_the_canvas(browser, pages, shots):
    page = open_page(browser, pages["one"])
    views = page.evaluate("gshadeView.views()")
    assert views[:2] == ["picture", "f"] and {"N", "patch", "u", "v"} <= set(views)
    seen = {canvas_digest(page)}
    hover(page, 80, 60)
    page.screenshot(path=str(shots / "view-teapot.png"))
    for view in ("f", "N", "patch"):
        page.select_option("[data-role=channel]", view)
        seen.add(canvas_digest(page))
        if view == "f":
            bar = page.inner_text("[data-role=colourbar]")
            assert "viridis" in bar and "automatic range" in bar
            hover(page, 80, 60)
            page.screenshot(path=str(shots / "view-f-false-colour.png"))
    assert len(seen) == 4
    page.close()


def test_junction_nearest_the_cursor(browser, pages):
    channels, header = read_exr(pages["a"])
    junctions = json.loads(header["junctions"])["junctions"]
    seams = junction_seams(channels["patch"], junctions)[:, 0, :].astype(float)
    page = open_page(browser, pages["one"])
    for x, y in sample_pixels(channels["patch"])[:4]:
        hover(page, x, y)
        d = np.hypot(seams[0] - (2 * x + 1), seams[1] - (2 * y + 1))
        index = int(seams[2, np.argmin(d)])
        shown = page.get_attribute("[data-role=junction] dl", "data-junction")
        assert int(shown) == index
        text = page.inner_text("[data-role=junction]")
        assert junctions[index]["class"] in text and "curvature jump" in text
    page.close()


def test_flip_side_by_side_and_difference(browser, pages, shots):
    page = open_page(browser, pages["two"])
    hover(page, 80, 60)
    a_view = canvas_digest(page)
    page.click('button[data-mode="flip"]')
    assert page.evaluate("gshadeView.state().current") == 1
    assert page.inner_text("[data-role=shown]").startswith("B:")
    page.click('button[data-mode="side"]')
    hover(page, 30, 50, image=1)
    assert page.inner_text('td[data-role="pixel"][data-image="1"]') == "30, 50"
    page.select_option("[data-role=channel]", "f")
    page.click('button[data-mode="diff"]')
    diff_view = canvas_digest(page)
    assert diff_view != a_view
    bar = page.inner_text("[data-role=colourbar]")
    assert "|A − B| (f)" in bar and "0.25" in bar  # the scale runs to the largest difference
    hover(page, 80, 60)
    assert page.inner_text('tr[data-channel="f"] td[data-role="diff"]') != ""
    for _ in range(2):
        page.mouse.wheel(0, -200)
    page.screenshot(path=str(shots / "view-difference.png"))
    page.close()


def test_zoomed_screenshot(browser, pages, shots):
    page = open_page(browser, pages["one"])
    hover(page, 60, 40)
    for _ in range(3):
        page.mouse.wheel(0, -300)
    assert page.inner_text('td[data-role="pixel"][data-image="0"]') == "60, 40"
    page.screenshot(path=str(shots / "view-zoomed.png"))
    page.close()


def test_an_environment_render_shows_the_reflection_direction(browser, tmp_path, shots):
    """An environment render's page: refl.X/Y/Z under the cursor, as the EXR holds them,
    after N; a "refl as RGB" view of its own (no false-colour view of each component)."""
    exr = tmp_path / "mirror.exr"
    result = gshade(
        "render",
        VIEW_SCENE,
        "-o",
        exr,
        "--html",
        tmp_path / "mirror.html",
        "--width",
        W,
        "--height",
        H,
        "--spp",
        1,
        "--set",
        "shape.function=environment",
    )
    assert result.returncode == 0, result.stderr
    channels, _ = read_exr(exr)
    page = open_page(browser, tmp_path / "mirror.html")
    views = page.evaluate("gshadeView.views()")
    assert "refl" in views and not {"refl.X", "refl.Y", "refl.Z"} & set(views)
    rows = page.eval_on_selector_all("tr[data-channel]", "rs => rs.map(r => r.dataset.channel)")
    assert rows.index("N.Z") + 1 == rows.index("refl.X") < rows.index("refl.Z")
    for x, y in sample_pixels(channels["patch"]):
        hover(page, x, y)
        for name in ("refl.X", "refl.Y", "refl.Z", "f"):
            text = cell(page, name)
            assert np.float32(float(text)) == channels[name][y, x], (name, x, y, text)
    before = canvas_digest(page)
    page.select_option("[data-role=channel]", "refl")
    assert canvas_digest(page) != before
    hover(page, 80, 60)
    page.screenshot(path=str(shots / "view-refl-as-rgb.png"))
    page.close()
