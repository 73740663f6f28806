"""The `gshade view` page tests' command and the data a page embeds."""

from __future__ import annotations

import json
import re
import subprocess
import sys

from .paths import ROOT

#: The scene the page tests render, and their size.
VIEW_SCENE = ROOT / "scenes" / "teapot-isophotes.toml"
W, H = 160, 120


def gshade(*args):
    """``python -m gshade`` with these arguments, its output captured."""
    return subprocess.run(
        [sys.executable, "-m", "gshade", *map(str, args)], capture_output=True, text=True
    )


def page_data(page: str) -> dict:
    """The JSON data a `gshade view` page embeds."""
    found = re.findall(r'<script type="application/json" class="gshade-view-data">(.*?)</', page)
    assert len(found) == 1
    return json.loads(found[0])
