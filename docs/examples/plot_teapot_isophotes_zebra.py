"""
Isophotes and zebra stripes on the Utah teapot
==============================================

The Utah teapot's 32 bicubic Bézier patches under two first-order shape functions:
isophotes (curves of constant ⟨n, l⟩, the normal against a light direction) and zebra
stripes (reflections of light lines at infinity, seen from the eye).  A shape function of
order k has level lines of class G(n−k) on a Gn surface (Kiciak, *Geometric Continuity of
Curves and Surfaces*, 2016): both functions here are of order 1, so where two patches meet
only G1 the stripes are merely G0, and they **kink** at the junction: they change
direction abruptly, without a gap.  The teapot's G1 junctions are the rings of its profile
(rim to body, upper to lower body, body to bottom, the lid's knob) and the middle seams of
the handle and the spout; look where the zebra stripes cross the rim and the knob.  Across
the seams between the quarters of the body, which are G2, the stripes run through
smoothly.
"""

from pathlib import Path

import matplotlib.pyplot as plt

import gshade
from gshade.analysis.scene_junctions import scene_continuity

# the checkout: sphinx-gallery runs the script in its own folder, without __file__
HERE = Path(__file__).parent if "__file__" in globals() else Path.cwd()
ROOT = HERE.resolve().parents[1]
SCENE = ROOT / "scenes" / "teapot-isophotes.toml"
SIZE = {"width": 400, "height": 300, "spp": 4}


# %%
# The scene file renders the isophotes; the zebra stripes are the same scene with the
# shape function replaced by dotted overrides (as ``gshade render --set`` takes them):
# reflection lines of light lines at infinity parallel to z, seen from the eye.

isophotes = gshade.render(SCENE, **SIZE)
ZEBRA = {
    "shape.function": "reflection_lines",
    "shape.form": "infinity",
    "shape.axis": [0, 0, 1],
    "shape.eye_point": [6.0, -8.5, 5.5],
    "shape.period": 0.2618,
}
zebra = gshade.render(SCENE, **SIZE, set=ZEBRA)

fig, axes = plt.subplots(1, 2, figsize=(8, 3.2), layout="compressed")
for ax, image, title in zip(
    axes, (isophotes, zebra), ("isophotes (order 1)", "zebra stripes (order 1)"), strict=True
):
    ax.imshow(image.srgba)
    ax.set_title(title, fontsize=10)
    ax.axis("off")
plt.show()

# %%
# Where the kinks are: left, the junctions drawn over the isophotes, coloured by their
# measured continuity class (orange G1, green G2); right, a close-up of the zebra stripes
# where the body meets the rim along a G1 (orange) ring: the vertical stripes of the body
# turn abruptly into the rim there, a kink without a gap.  The same classes come as
# numbers from the continuity report.

seams = gshade.render(SCENE, **SIZE, junctions=True)
close_up = gshade.render(
    SCENE,
    **SIZE,
    set={
        **ZEBRA,
        "camera.origin": [7.0, -9.3, 6.9],
        "camera.target": [0.86, -1.23, 2.4],  # a point of the rim's G1 seam, z = 2.4
        "camera.fov": 5,
    },
)
fig, axes = plt.subplots(1, 2, figsize=(8, 3.2), layout="compressed")
for ax, image, title in zip(
    axes,
    (seams, close_up),
    ("junctions: G1 orange, G2 green", "zebra at the rim's G1 seam, close up"),
    strict=True,
):
    ax.imshow(image.srgba)
    ax.set_title(title, fontsize=10)
    ax.axis("off")
plt.show()

junctions, _ = scene_continuity(gshade.load_scene(SCENE))
classes = sorted({j.cls for j in junctions})
print(f"{len(junctions)} junctions:", {c: sum(j.cls == c for j in junctions) for c in classes})
rim = next(j for j in junctions if j.patches == (0, 4))
print(
    f"rim to body (patches 0 and 4): {rim.cls}, normal angle {rim.normal_angle_deg:.2g} "
    f"degrees, curvature jump {rim.curvature_jump:.4g}"
)
