"""
The continuity ladder: G0 to G3 under shape functions of order 0, 1 and 2
=========================================================================

Four pairs of Bézier patches (``scenes/junction-g0.toml`` … ``junction-g3.toml``), each
second patch built from the first one's derivatives along their common edge so that the
two meet exactly G0, G1, G2 or G3 (Kiciak, *Geometric Continuity of Curves and Surfaces*,
2016, ch. 3).  Each pair is shown under a shape function of order 0 (planar sections), of
order 1 (isophotes) and of order 2 (mean curvature H, in colour with its level lines as
stripes), seen from straight above: the seam is the vertical line through the middle of
every picture.  A shape function of order k has level lines of class G(n−k) on a Gn
surface, so read the grid along its diagonal:

* **G0 row**: the planar sections already kink at the seam; isophotes and H jump.
* **G1 row**: planar sections cross smoothly; the isophotes kink; H jumps (a colour step).
* **G2 row**: planar sections and isophotes are smooth; H is continuous (no colour step)
  but its level lines kink.
* **G3 row**: every column is smooth across the seam.

A defect therefore shows first in the column whose order equals the junction's class.
"""

from pathlib import Path

import matplotlib.pyplot as plt

import gshade

# the checkout: sphinx-gallery runs the script in its own folder, without __file__
HERE = Path(__file__).parent if "__file__" in globals() else Path.cwd()
ROOT = HERE.resolve().parents[1]
SCENES = ROOT / "scenes"
SIZE = {"width": 240, "height": 180, "spp": 4}
#: Every pair seen from straight above, the seam (y = 3) a vertical line in the middle: the
#: first patch on the left, the second (which bends down steeply) on the right.
CAMERA = {
    "camera.type": "orthographic",
    "camera.origin": [1.5, 3.2, 12.0],
    "camera.target": [1.5, 3.2, 0.0],
    "camera.up": [-1, 0, 0],
    "camera.width": 4.4,
}

#: The columns: a label and the dotted scene keys that choose the shape function.
COLUMNS = {
    "planar sections (order 0)": {
        "shape.function": "planar_sections",
        "shape.direction": [1, 1, 2],
        "shape.display": "stripes",
        "shape.stripes": 24,
    },
    "isophotes (order 1)": {
        "shape.function": "isophotes",
        "shape.light": [0.3, -0.4, 1.0],
        "shape.display": "stripes",
        "shape.stripes": 20,
    },
    "mean curvature (order 2)": {
        "shape.function": "mean",
        "shape.display": "both",
        "shape.colour_function": "mean",
        "shape.stripes": 24,
    },
}


# %%
# Twelve small renders: one scene per row, the shape function per column given as
# overrides of the scene file.

fig, axes = plt.subplots(4, 3, figsize=(7.5, 8.2), layout="compressed")
for row, continuity in enumerate(("G0", "G1", "G2", "G3")):
    scene = SCENES / f"junction-{continuity.lower()}.toml"
    for col, (label, overrides) in enumerate(COLUMNS.items()):
        image = gshade.render(scene, **SIZE, set={**CAMERA, **overrides})
        ax = axes[row, col]
        ax.imshow(image.srgba)
        ax.set_xticks([])
        ax.set_yticks([])
        for side in ax.spines.values():
            side.set_visible(False)
        if row == 0:
            ax.set_title(label, fontsize=10)
        if col == 0:
            ax.set_ylabel(f"{continuity} junction", fontsize=11)
fig.suptitle("order k shows a G(k) defect: kinks and jumps along the seam", fontsize=11)
plt.show()
