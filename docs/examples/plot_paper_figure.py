"""
A figure for a paper: the order ladder
======================================

``gshade figure SPEC -o OUT.pdf`` lays out a grid of gshade renders with matplotlib for a
report or a paper: one row per scene, one column per set of overrides, with panel titles,
the stripe period under striped panels and a colour bar under colour-mapped ones, every
panel of a row seen through one camera so that the panels compare point for point.  Here
the project's own spec ``scenes/figures/order-ladder.toml`` is rendered through the
command's Python entry point (``gshade.app.figure.make_figure``) at a small panel size.
It is the book's central claim in one picture: a shape function of order k has level lines
of class G(n−k) on a Gn surface (Kiciak, *Geometric Continuity of Curves and Surfaces*,
2016).  Each panel shows two pairs of patches, meeting only G1 on the left (orange seam) and
G2 on the right (green seam): planar sections (order 0) cross both seams smoothly,
isophotes and reflection lines (order 1) kink at the G1 seam only, and the mean curvature
(order 2) jumps at the G1 seam and is continuous at the G2 seam.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

from gshade.app.figure import load_figure_spec, make_figure

# the checkout: sphinx-gallery runs the script in its own folder, without __file__
HERE = Path(__file__).parent if "__file__" in globals() else Path.cwd()
ROOT = HERE.resolve().parents[1]
SPEC = ROOT / "scenes" / "figures" / "order-ladder.toml"

# %%
# The spec is read and checked as the command reads it; its panel size (640 × 280) is made
# smaller here for the documentation.  ``make_figure`` writes PNG (300 dpi), PDF or SVG by
# the file's suffix, with gshade's version, every panel's scene hash and every row's camera
# in the file's metadata.

spec = load_figure_spec(SPEC)
spec.width, spec.height, spec.spp = 320, 140, 4
with tempfile.TemporaryDirectory() as tmp:
    output = make_figure(spec, Path(tmp) / "order-ladder.png")
    figure = plt.imread(output)
print(f"{spec.title!r}: {len(spec.rows)} row(s) x {len(spec.columns)} columns")
for label, camera in spec.cameras.items():
    print(f"camera of row {label!r}: {camera}")

fig, ax = plt.subplots(figsize=(12, 12 * figure.shape[0] / figure.shape[1]), layout="compressed")
ax.imshow(figure)
ax.axis("off")
plt.show()
