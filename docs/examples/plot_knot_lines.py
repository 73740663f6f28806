"""
Knot lines of a NURBS surface
=============================

A B-spline surface is a union of polynomial pieces, and its interior knot lines are
junctions between them: across a knot of multiplicity m in degree p the pieces meet
C^(p−m).  ``scenes/nurbs-gaussian.toml`` is a rational surface of degree (3, 2) with a
*double* knot at u = 0.6 (C1 there) and simple knots elsewhere.  The render's junction
overlay (``render.junctions``, ``--junctions``) draws every knot line in the colour of its
measured geometric class: G1 orange, G2 green.  A shape function of order k has level lines
of class G(n−k) on a Gn surface (Kiciak, *Geometric Continuity of Curves and Surfaces*,
2016).  Across the orange lines (the double knot in u, and both knots in v, where the
surface is only quadratic and a simple knot leaves it C1) the Gaussian curvature K (order
2) steps, and the isophotes (order 1) kink: they cross without a gap but change direction.
Across the green line u = 0.3 (a simple knot of the cubic direction, C2) K is continuous
and the isophotes run through smoothly.
"""

from pathlib import Path

import matplotlib.pyplot as plt

import gshade
from gshade.analysis.scene_junctions import scene_continuity

# the checkout: sphinx-gallery runs the script in its own folder, without __file__
HERE = Path(__file__).parent if "__file__" in globals() else Path.cwd()
ROOT = HERE.resolve().parents[1]
SCENE = ROOT / "scenes" / "nurbs-gaussian.toml"
SIZE = {"width": 320, "height": 240, "spp": 4}


# %%
# The scene's Gaussian curvature (its colour range narrowed to ±0.5, so that the steps
# show), and its isophotes, both with the knot lines drawn.

gaussian = gshade.render(SCENE, **SIZE, junctions=True, set={"shape.range": [-0.5, 0.5]})
isophotes = gshade.render(
    SCENE,
    **SIZE,
    junctions=True,
    set={
        "shape.function": "isophotes",
        "shape.light": [0.2, -0.4, 1.0],
        "shape.display": "stripes",
        "shape.stripes": 12,
    },
)
fig, axes = plt.subplots(1, 2, figsize=(8, 3.2), layout="compressed")
for ax, image, title in zip(
    axes,
    (gaussian, isophotes),
    ("Gaussian curvature K, knot lines", "isophotes, knot lines"),
    strict=True,
):
    ax.imshow(image.srgba)
    ax.set_title(title, fontsize=10)
    ax.axis("off")
plt.show()

# %%
# The knot lines in the continuity report: where each is, its multiplicity, the
# parametric continuity C^(p−m) and the geometric class measured on the exact pieces.

junctions, _ = scene_continuity(gshade.load_scene(SCENE))
print(f"{'line':>7} {'m':>2} {'p':>2} {'C^k':>4} {'class':>5} {'angle (deg)':>11} {'k jump':>9}")
for j in junctions:
    if j.knot is None:
        continue
    k = j.knot
    print(
        f"{k.direction}={k.knot:<5.3g} {k.multiplicity:>2} {k.degree:>2} "
        f"{'C' + str(k.parametric_continuity):>4} {j.cls:>5} {j.normal_angle_deg:11.2g} "
        f"{j.curvature_jump:9.4g}"
    )
