"""
Isophotes, reflection lines and highlight lines
===============================================

Three shape functions of order 1 on the same Utah teapot, each from its own scene file
(``scenes/teapot-isophotes.toml``, ``teapot-reflection.toml``, ``teapot-highlight.toml``).
All three are computed from the unit normal, so all three show a G1 junction the same way:
a shape function of order k has level lines of class G(n−k) on a Gn surface (Kiciak,
*Geometric Continuity of Curves and Surfaces*, 2016), and on the teapot's G1 profile seams
(rim to body, body to bottom) every kind of stripe **kinks**.  They differ in what they
model, and so in what they are for:

* **Isophotes** ⟨n, l⟩ = const: the surface lit by a distant light l, independent of the
  eye.  The quickest overview; the stripes crowd where the normal turns fast.
* **Reflection lines**: the mirror images of a family of straight light lines in a plane
  (here above the teapot), seen from the eye point: what a designer sees on a glossy car
  body in a light tunnel.  They depend on the eye, so they move as the view does, and they
  magnify small undulations.
* **Highlight lines** (Beier and Chen): the light lines met by the surface normal lines,
  independent of the eye, a cheaper and view-stable stand-in for reflection lines.
"""

from pathlib import Path

import matplotlib.pyplot as plt

import gshade

# the checkout: sphinx-gallery runs the script in its own folder, without __file__
HERE = Path(__file__).parent if "__file__" in globals() else Path.cwd()
ROOT = HERE.resolve().parents[1]
SCENES = ROOT / "scenes"
SIZE = {"width": 320, "height": 240, "spp": 4}
#: Each scene, and its stripe period widened for these small pictures (None: the scene's).
FUNCTIONS = {
    "isophotes": ("teapot-isophotes.toml", None),
    "reflection lines": ("teapot-reflection.toml", 10.0),
    "highlight lines": ("teapot-highlight.toml", 5.0),
}


# %%
# One render per scene, at one size; the legend says the function and its stripe period.
# Purple is where a function is undefined: there the reflected ray misses the light plane.

fig, axes = plt.subplots(1, 3, figsize=(10, 2.9), layout="compressed")
for ax, (label, (scene, period)) in zip(axes, FUNCTIONS.items(), strict=True):
    image = gshade.render(SCENES / scene, **SIZE, set={"shape.period": period} if period else None)
    ax.imshow(image.srgba)
    ax.set_title(f"{label} (order 1)", fontsize=10)
    ax.axis("off")
    print(f"{label}: {image.legend.text()}")
plt.show()
