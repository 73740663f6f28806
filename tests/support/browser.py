"""A headless Chromium (Playwright) for the tests of `gshade view` pages."""

from __future__ import annotations

import os
import shutil

import pytest


def _unavailable(reason: str):
    if os.environ.get("CI"):
        pytest.fail(f"browser tests need {reason} (CI is set)")
    pytest.skip(f"browser tests need {reason}")


@pytest.fixture(scope="module")
def browser():
    """A Chromium browser (Playwright); the test is skipped without one, and fails under CI."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        _unavailable('Playwright (pip install -e ".[test]")')
    chromium = shutil.which("chromium")
    if chromium is None:
        _unavailable("Chromium (apt-get install chromium)")
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
        yield b
        b.close()


def open_page(browser, path):
    """The gshade view page at ``path`` in a new browser page, once it says it is ready."""
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(path.as_uri())
    page.wait_for_selector("[data-gshade-view][data-state]", timeout=20_000)
    state = page.get_attribute("[data-gshade-view]", "data-state")
    assert state == "ready", page.inner_text("[data-gshade-view]") + " ".join(errors)
    return page
