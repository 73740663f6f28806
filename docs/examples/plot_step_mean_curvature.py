"""
Mean curvature of a STEP part, with its B-rep edges
===================================================

A CAD file is a scene by itself: here the filleted L bracket ``scenes/data/bracket.step``
(17 trimmed faces, built with Open CASCADE by ``scenes/make_cad_scenes.py``), its exact
faces coloured by their mean curvature H, a shape function of order 2, with the B-rep
edges drawn in the colour of their measured continuity class.  A shape function of order
k has level lines of class G(n−k) on a Gn surface (Kiciak, *Geometric Continuity of Curves
and Surfaces*, 2016), so an order-2 function shows a G1 junction as a **jump of colour**.
Look at the fillets: H is 0 on the flat plates (grey) and ±1/(2r) on a fillet of radius r,
so the colour jumps across every orange (G1) edge between a fillet and a plate; the red
edges are sharp (G0) edges, where the faces meet at an angle.  The continuity report below
gives the same classes as numbers: the normal angle across each edge and the jump of the
normal curvature (1/r at a fillet's G1 edge).
"""

from collections import Counter
from pathlib import Path

import matplotlib.pyplot as plt
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize

import gshade
from gshade.analysis.scene_junctions import scene_continuity

# the checkout: sphinx-gallery runs the script in its own folder, without __file__
HERE = Path(__file__).parent if "__file__" in globals() else Path.cwd()
ROOT = HERE.resolve().parents[1]
PART = ROOT / "scenes" / "data" / "bracket.step"


# %%
# The STEP file loads as a scene of one ``cad`` surface with the default camera; the
# overrides choose the shape function and a colour map, ``junctions=True`` draws the edges.

scene = gshade.load_scene(
    PART,
    {"shape.function": "mean", "shape.display": "colormap", "shape.range": [-0.125, 0.125]},
)
image = gshade.render(scene, width=400, height=300, spp=4, junctions=True)

legend = image.legend
fig, ax = plt.subplots(figsize=(5, 3.6), layout="compressed")
ax.imshow(image.srgba)
ax.set_title("mean curvature; edges G0 red, G1 orange", fontsize=10)
ax.axis("off")
fig.colorbar(
    ScalarMappable(Normalize(*legend.value_range), legend.colormap),
    ax=ax,
    shrink=0.7,
    label=f"H ({legend.units})",
)
plt.show()

# %%
# The continuity report of the B-rep edges (what ``gshade continuity`` prints): every edge
# shared by two faces, measured on both faces' exact surfaces along the edge.

junctions, _ = scene_continuity(scene)
print(f"{len(junctions)} edges:", dict(sorted(Counter(j.cls for j in junctions).items())))
print(f"{'edge':>4} {'faces':>8} {'class':>5} {'gap':>9} {'angle (deg)':>11} {'k jump':>9}")
for j in sorted(junctions, key=lambda j: j.edge)[:12]:
    print(
        f"{j.edge:>4} {j.patches[0]:>3}-{j.patches[1]:<4} {j.cls:>5} {j.gap:9.2g} "
        f"{j.normal_angle_deg:11.4g} {j.curvature_jump:9.4g}"
    )
print("...")
fillet = [j for j in junctions if j.cls == "G1"]
radii = sorted({round(1 / j.curvature_jump, 6) for j in fillet})
print("fillet radii from the G1 edges' curvature jumps (1/jump):", radii)
