"""Covered pixels always carry their surface: a centre ray that slips through the crack
between two separately tessellated surfaces (which no sample of the pixel saw) gets its
exact hit from a neighbour's patch (issue 14, point 1)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from gshade.geometry.patches.revolution import sphere
from gshade.rendering import render
from gshade.scene import parse_scene


def _separate_sphere_patches() -> str:
    """The unit NURBS sphere as eight separate rational biquadratic Bezier surfaces (one a
    knot span), each evaluated on its own, so neighbours share boundary control points only
    up to round-off."""
    whole = sphere(1.0)
    ku, kv = (np.unique(k) for k in whole.knots)
    tables = []
    for u0, u1 in itertools.pairwise(ku):
        for v0, v1 in itertools.pairwise(kv):
            piece = whole.restricted(((u0, u1), (v0, v1)))
            rows = ", ".join(
                "["
                + ", ".join(f"[{float(x)!r}, {float(y)!r}, {float(z)!r}]" for x, y, z in row)
                + "]"
                for row in piece.points
            )
            weights = ", ".join(
                "[" + ", ".join(repr(float(w)) for w in row) + "]" for row in piece.weights
            )
            tables.append(
                f'[[surface]]\ntype = "bezier"\npoints = [{rows}]\nweights = [{weights}]\n'
            )
    return "\n".join(tables)


@pytest.mark.parametrize(
    ("origin", "up"), [("[0, 0, 5]", "[0, 1, 0]"), ("[3.5, 3.5, 0.3]", "[0, 0, 1]")]
)
def test_no_covered_pixel_without_its_surface(origin, up):
    """Seams seen from above (the 45 degree seams) and from the side: no pixel with A = 1
    and patch = -1; every covered pixel's P is on the unit sphere."""
    text = _separate_sphere_patches() + (
        '\n[shape]\nfunction = "isophotes"\n[render]\nwidth = 320\nheight = 320\nspp = 4\n'
        'lighting = "flat"\n'
        f'[camera]\ntype = "orthographic"\norigin = {origin}\ntarget = [0, 0, 0]\n'
        f"up = {up}\nwidth = 2.2\n"
    )
    image = render(parse_scene(text))
    A, patch = image["A"], image["patch"]
    assert int(((A >= 1) & (patch < 0)).sum()) == 0
    on = patch >= 0
    P = np.stack([image["P.X"], image["P.Y"], image["P.Z"]], -1)[on]
    assert np.abs(np.linalg.norm(P, axis=1) - 1.0).max() < 1e-6
