"""
A sweep over a shape parameter: γ-spline tension
================================================

``scenes/gammaspline-mean.toml`` is a bicubic γ-spline surface (Boehm's G2 splines in
B-spline form; Kiciak, *Geometric Continuity of Curves and Surfaces*, 2016, §2.3.3): one
shape parameter γ > 0 per interior knot line, γ = 1 the C2 bicubic B-spline.  Across a knot
line with γ < 1 the surface is only C1, its second derivative jumping by ν p_u with
ν = 2 (h_l + h_r)(1 − γ) / (γ h_l h_r), yet geometrically G2.  The sweep lowers γ on the
middle knot line in u from 1 to 0.15 and shows the mean curvature H (order 2) in colour
with isophote stripes (order 1) over it.  A shape function of order k has level lines of
class G(n−k) on a Gn surface, so whatever γ, the isophotes stay smooth and H stays
continuous (no colour step) across the knot line; what the sweep shows is the shape: as γ
falls the surface is drawn toward its control net there, and a ridge of high curvature
gathers along the line, as a tension would make it.
"""

from pathlib import Path

import matplotlib.pyplot as plt

import gshade

# the checkout: sphinx-gallery runs the script in its own folder, without __file__
HERE = Path(__file__).parent if "__file__" in globals() else Path.cwd()
ROOT = HERE.resolve().parents[1]
SCENE = ROOT / "scenes" / "gammaspline-mean.toml"
SIZE = {"width": 240, "height": 180, "spp": 4}
GAMMAS = (1.0, 0.6, 0.3, 0.15)


# %%
# One render per value of the dotted key ``surface.1.gamma_u`` (surfaces count from 1: the
# scene's only surface, its γ per knot line in u), with one colour range for all, so that
# the panels compare.  The same sweep as files on disk, in parallel worker processes::
#
#     gshade batch scenes/gammaspline-mean.toml -o sweep \
#         --sweep "surface.1.gamma_u=[1,1,1],[1,0.6,1],[1,0.3,1],[1,0.15,1]"
#
# or, in the scene file, a ``[sweep]`` table with ``"surface.1.gamma_u" = [[1, 1, 1], …]``.

fig, axes = plt.subplots(1, len(GAMMAS), figsize=(10, 2.4), layout="compressed")
for ax, gamma in zip(axes, GAMMAS, strict=True):
    image = gshade.render(
        SCENE,
        **SIZE,
        set={"surface.1.gamma_u": [1.0, gamma, 1.0], "shape.range": [-1.5, 1.5]},
    )
    ax.imshow(image.srgba)
    ax.set_title(f"γ = {gamma:g} on the middle knot line", fontsize=9)
    ax.axis("off")
fig.suptitle(
    "mean curvature (colour, coolwarm on [-1.5, 1.5]) and isophotes (stripes)", fontsize=10
)
plt.show()
