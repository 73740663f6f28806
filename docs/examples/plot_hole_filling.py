"""
Hole filling: G1 against G2
===========================

Around an extraordinary vertex (valence n ≠ 4) of a Catmull–Clark mesh, gshade cuts out
the n faces and fills the hole with n tensor-product Bézier patches that meet the
surroundings and each other with guaranteed continuity (Kiciak, *Geometric Continuity of
Curves and Surfaces*, 2016, ch. 4–5): G1 with patches of degree (5, 5), G2 with degree
(9, 9).  The pictures show the mean curvature H, a shape function of order 2, of both
fillings of the same meshes (``scenes/hole-*-mean-g1.toml`` and ``-g2.toml``).  A shape
function of order k has level lines of class G(n−k) on a Gn surface, so on the G1
fillings H **jumps** across the inner edges between the filling's patches (a star of
colour steps around each cap's centre, and around the hole's rim), while on the G2
fillings H is continuous everywhere and the colour flows smoothly through the centre.
"""

from pathlib import Path

import matplotlib.pyplot as plt
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize

import gshade

# the checkout: sphinx-gallery runs the script in its own folder, without __file__
HERE = Path(__file__).parent if "__file__" in globals() else Path.cwd()
ROOT = HERE.resolve().parents[1]
SCENES = ROOT / "scenes"
SIZE = {"width": 280, "height": 210, "spp": 4, "lighting": "flat"}
#: Mean curvature alone, on the scenes' own fixed range (so that the panels compare), seen
#: from the scenes' own eye with a narrower field of view.
MEAN = {
    "shape.function": "mean",
    "shape.display": "colormap",
    "shape.range": [-3.2, -0.2],
    "camera.fov": 19,
}
MESHES = {"pentadrum (valence 3 and 5)": "valence", "hexadrum (valence 3 and 6)": "hexadrum"}


# %%
# Four renders: each mesh filled G1 and G2, mean curvature on one colour scale.

fig, axes = plt.subplots(2, 2, figsize=(6.6, 5.4), layout="compressed")
for row, (label, mesh) in enumerate(MESHES.items()):
    for col, continuity in enumerate(("g1", "g2")):
        image = gshade.render(SCENES / f"hole-{mesh}-mean-{continuity}.toml", **SIZE, set=MEAN)
        ax = axes[row, col]
        ax.imshow(image.srgba)
        ax.set_title(f"{label}, {continuity.upper()} filling", fontsize=9)
        ax.axis("off")
legend = image.legend
fig.colorbar(
    ScalarMappable(Normalize(*legend.value_range), legend.colormap),
    ax=axes,
    shrink=0.6,
    label="mean curvature H",
)
plt.show()
