"""
Curvature combs (porcupines)
============================

A curvature comb draws, at samples along a curve, a spine from the curve away from its
centre of curvature, as long as the curvature times a scale, and the envelope through the
tips; where the curvature vector reverses (an inflection) the comb changes side, and gshade
rings the point in white.  ``render.combs`` (``--combs``) draws combs along the patch
boundaries and B-rep edges, with ``render.comb_lines`` also along the knot lines
(``"knots"``) and along planar sections (``"sections"``).  A curve's curvature is of order
2, like the surface's: a shape function of order k has level lines of class G(n−k) on a Gn
surface (Kiciak, *Geometric Continuity of Curves and Surfaces*, 2016), and a section across
a G1 junction is a G1 curve, whose comb **steps** there.

Left, ``scenes/bracket-combs.toml``: the filleted bracket's B-rep edges and eight sections
x = const across its bend, over its mean curvature.  The sections' combs are zero on the
flat plates and 1/10 on the inner fillet of the bend (r = 10), 1/18 on the outer one, with a
step at each fillet edge; the holes' circles and the free corners' arcs carry the tallest
combs.  Right, the NURBS surface of ``scenes/nurbs-gaussian.toml`` with combs along its
boundaries and its interior knot lines, over its isophotes: the combs of the wavy knot lines
change side at their inflections.
"""

import json
from pathlib import Path

import matplotlib.pyplot as plt

import gshade

# the checkout: sphinx-gallery runs the script in its own folder, without __file__
HERE = Path(__file__).parent if "__file__" in globals() else Path.cwd()
ROOT = HERE.resolve().parents[1]
SCENES = ROOT / "scenes"
SIZE = {"width": 320, "height": 240, "spp": 4}


# %%
# The bracket's scene asks for the combs itself; the NURBS surface gets them by keyword,
# with a spine scale (length per unit of curvature) below the automatic one, which makes
# the median spine 5 % of the scene's diagonal.

bracket = gshade.render(SCENES / "bracket-combs.toml", **SIZE)
nurbs = gshade.render(
    SCENES / "nurbs-gaussian.toml",
    **SIZE,
    combs=True,
    comb_lines=["edges", "knots"],
    comb_scale=0.6,
    set={"shape.function": "isophotes", "shape.display": "stripes", "shape.stripes": 12},
)

fig, axes = plt.subplots(1, 2, figsize=(9, 3.4), layout="compressed")
for ax, image, title in zip(
    axes,
    (bracket, nurbs),
    ("bracket: edges and sections, mean curvature", "NURBS: boundaries and knot lines"),
    strict=True,
):
    ax.imshow(image.srgba)
    ax.set_title(title, fontsize=10)
    ax.axis("off")
plt.show()

# %%
# The header's ``combs`` gives the curvature shown, the scale (the spine's length per unit
# of curvature), the largest value with its curve and point, and every inflection.

for name, image in (("bracket", bracket), ("NURBS", nurbs)):
    combs = json.loads(image.metadata["combs"])
    largest = combs["max"]
    print(f"{name}: {combs['curvature']} curvature, spine = {combs['scale']:.4g} x curvature")
    print(
        f"  largest curvature {largest['value']:.4g} on {largest['curve']} at "
        f"{[round(x, 3) for x in largest['point']]}"
    )
    print(f"  {len(combs['inflections'])} inflections")
    for inflection in combs["inflections"][:3]:
        print(
            f"    {inflection['curve']}, t = {inflection['t']:.6g}, "
            f"point {[round(x, 3) for x in inflection['point']]}"
        )
