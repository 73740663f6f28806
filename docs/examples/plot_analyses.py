"""
Analyses beyond stripes: draft, radius limits, parabolic lines and umbilics
===========================================================================

Besides the shape functions that show continuity, gshade has the analyses CAD users
know, drawn as flat bands with sharp, anti-aliased edges (``shape.display = "bands"``):

* **Draft angle** (order 1: it uses the normal), here on ``scenes/drafted-block-draft.toml``,
  a block whose sides lean by 3, 1, 0 and −2 degrees from the pull direction +z, against a
  least draft of 2 degrees: enough draft green, too little yellow, an undercut red, the
  parting line (draft 0) as a line.
* **Radius limits** (order 2: curvature), the filleted bracket ``scenes/data/bracket.step``
  against a tool of radius 9 mm: red where the surface curves convexly tighter than 9 mm, blue
  where concavely, grey within the limit.
* **Parabolic lines and umbilics** (order 2) on the Utah teapot: the sign of the Gaussian
  curvature K in two tones (saddle-shaped points blue, elliptic orange), the parabolic
  lines K = 0 between them in magenta (``render.parabolic``, ``--parabolic``), and the
  umbilics (k1 = k2) ringed.

A shape function of order k has level lines of class G(n−k) on a Gn surface (Kiciak,
*Geometric Continuity of Curves and Surfaces*, 2016), and so do these bands' edges: the
draft's band edges follow the normals (order 1), the radius and parabolic lines the
curvatures (order 2), which jump at the bracket's G1 fillet edges, so the bands there end
at the edges.
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
# Three renders: the draft scene as it is, the bracket with the radius analysis chosen by
# overrides, the teapot's Gaussian-curvature bands with the parabolic overlay.

draft = gshade.render(SCENES / "drafted-block-draft.toml", **SIZE)
radius = gshade.render(
    SCENES / "bracket-mean.toml",
    **SIZE,
    junctions=False,
    set={"shape.function": "min_radius", "shape.limit": 9.0, "shape.display": "bands"},
)
parabolic = gshade.render(SCENES / "teapot-parabolic.toml", **SIZE, parabolic=True)

fig, axes = plt.subplots(1, 3, figsize=(10, 2.9), layout="compressed")
panels = (
    (draft, "draft angle, 2° minimum (order 1)"),
    (radius, "radius limits, 9 mm (order 2)"),
    (parabolic, "sign of K, parabolic lines, umbilics"),
)
for ax, (image, title) in zip(axes, panels, strict=True):
    ax.imshow(image.srgba)
    ax.set_title(title, fontsize=10)
    ax.axis("off")
plt.show()

# %%
# Each render's legend says what the bands mean, and its header's ``statistics`` gives
# the numbers: the extremes over the whole surface with where they are, the smallest
# radius of curvature, and every umbilic point.

for image in (draft, radius, parabolic):
    print(image.legend.text())
surface = json.loads(draft.metadata["statistics"])["surface"]
print(f"draft: from {surface['min']['value']:.3g} to {surface['max']['value']:.3g} degrees")
smallest = json.loads(radius.metadata["statistics"])["min_radius"]
print(
    f"smallest radius {smallest['value']:.4g} mm ({smallest['side']}) on face "
    f"{smallest['patch']} at {[round(x, 2) for x in smallest['point']]}"
)
umbilics = json.loads(parabolic.metadata["statistics"])["umbilics"]
print(
    f"{len(umbilics)} umbilics; the first: {[round(x, 4) for x in umbilics[0]['point']]}, "
    f"k1 = k2 = {umbilics[0]['curvature']:.4g}"
)
