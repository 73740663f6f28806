"""Shared checks of the β- and ν-spline tests (tests/geometry/splines/test_betaspline.py,
tests/geometry/splines/test_nuspline.py): one-sided derivatives at junctions, the continuity
measure of a patch's Bézier pieces, and scene files with one spline surface.
"""

from __future__ import annotations

import numpy as np
import pytest

from gshade import GshadeError

from .paths import ROOT


def one_sided(curve, t):
    """Derivatives just left of t (from the arc ending there) and at t (the next arc)."""
    left = curve.derivatives(np.array([np.nextafter(t, -np.inf)]), 3)[:, 0]
    right = curve.derivatives(np.array([t]), 3)[:, 0]
    return left, right


def patch_one_sided(patch, direction, knot, other, order=2):
    """One-sided patch derivatives across the knot line ``direction`` = knot."""
    below = np.full_like(other, np.nextafter(knot, -np.inf))
    at = np.full_like(other, knot)
    if direction == "u":
        return patch.derivatives(below, other, order), patch.derivatives(at, other, order)
    return patch.derivatives(other, below, order), patch.derivatives(other, at, order)


def continuity_classes(patch):
    """Continuity classes of the junctions between a B-spline patch's Bézier pieces."""
    from gshade.analysis.continuity import continuity_report

    pieces = [piece for row in patch.bezier_patches() for piece in row]
    return [j.cls for j in continuity_report(pieces, samples=8)]


# --------------------------------------------------------------------------- scene files

NET_7x6 = [[[i, j, 0.1 * ((i * j) % 3)] for j in range(6)] for i in range(7)]


def load(tmp_path, body):
    from gshade.scene import load_scene

    path = tmp_path / "scene.toml"
    path.write_text(f'[[surface]]\ntype = "sphere"\n[[surface]]\n{body}', encoding="utf-8")
    return path, load_scene(path)


def check_one_line_error(make, message):
    """``make()`` raises a one-line GshadeError matching ``message``."""
    with pytest.raises(GshadeError, match=message) as info:
        make()
    assert "\n" not in str(info.value)


def check_bad_scene(tmp_path, body, message):
    """A scene whose second surface is ``body`` (``points`` NET_7x6 unless given) fails with
    a one-line message naming the file and the surface."""
    if "points" not in body:
        body += f"points = {NET_7x6}\n"
    with pytest.raises(GshadeError, match=message) as info:
        load(tmp_path, body)
    text = str(info.value)
    assert text.startswith(f"{tmp_path / 'scene.toml'}: [[surface]] 2 ("), text
    assert "\n" not in text


WRONG_VALUES = [
    "x",
    0,
    -1,
    True,
    [],
    [1],
    [1, 2, 3],
    [[1, 2, 3]],
    {"a": 1},
    ["closed"],
    [1e308] * 3,
]


def check_wrong_values(scene, key):
    """Every value of WRONG_VALUES for surface 1's ``key`` in ``scenes/<scene>.toml`` loads
    or fails with a one-line GshadeError naming the surface and the key."""
    from gshade.scene import load_scene

    path = ROOT / "scenes" / f"{scene}.toml"
    load_scene(path)
    for value in WRONG_VALUES:
        try:
            load_scene(path, {f"surface.1.{key}": value})
        except GshadeError as exc:
            text = str(exc)
            assert text.startswith(f"{path}: [[surface]] 1 ("), text
            assert "\n" not in text and key in text, text
