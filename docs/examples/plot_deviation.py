"""
Geometric deviation between two surfaces
========================================

``gshade deviation A B`` tells how far surface A lies from surface B (a part before and
after a change, a model and its rebuild): A is rendered from its view, and every covered
pixel's exact point P on A gets its signed distance to B's exact surfaces,
d = sign(⟨c − P, n⟩) ‖c − P‖, with c the closest point of B (found by Newton's method on
B's patches) and n A's normal.  Within a tolerance ±T the picture is neutral grey; beyond
it, a diverging colour map, red on the side A's normal points to, blue on the other.
Distance is of order 0, unlike the shape functions of order k, whose level lines are of
class G(n−k) on a Gn surface (Kiciak, *Geometric Continuity of Curves and Surfaces*,
2016): it shows where the geometry moved, not how smooth it is.

Two cases: a bicubic Bézier patch against a copy with its inner control point (1, 2) raised
by 0.2, which moves the surface by 0.2 B₁(u) B₂(v) along z: a red bump of at most
0.2 (4/9)² ≈ 0.0395 around that point, fading to zero at the patch's edges, which the point
does not move; and the exact sphere of radius 2 against the sphere of radius 2.003, where
the deviation is −0.003 at every pixel, blue: the sphere's normal p_u × p_v points inward,
and the larger sphere lies outside, against it.
"""

import matplotlib.pyplot as plt

from gshade.rendering.deviation_image import deviation_image
from gshade.rendering.deviation_references import SurfaceReference
from gshade.scene import parse_scene


def bezier(raised: float) -> str:
    """A bicubic Bézier patch over [0, 3]², its control point (1, 2) raised by ``raised``."""
    rows = []
    for i in range(4):
        points = []
        for j in range(4):
            z = 0.3 * (i - 1.5) ** 2 / 2.25 - 0.2 * (j - 1.5) ** 2 / 2.25
            z += raised if (i, j) == (1, 2) else 0.0
            points.append(f"[{i}, {j}, {z:.6f}]")
        rows.append("[" + ", ".join(points) + "]")
    return (
        '[[surface]]\ntype = "bezier"\npoints = [\n  ' + ",\n  ".join(rows) + "\n]\n"
        "[camera]\norigin = [8, -6, 7]\ntarget = [1.5, 1.5, 0]\nfov = 28\n"
    )


def sphere(radius: float) -> str:
    return f'[[surface]]\ntype = "sphere"\nradius = {radius}\n'


# %%
# Scenes given as text (``parse_scene``), B wrapped as a reference surface;
# :func:`~gshade.rendering.deviation_image.deviation_image` renders A and measures it, and
# returns the picture and the numbers (the EXR's ``deviation`` header), writing nothing.

cases = {
    "patch, one control point raised by 0.2": (bezier(0.0), bezier(0.2), 0.01),
    "sphere r = 2 against r = 2.003": (sphere(2.0), sphere(2.003), 0.001),
}
results = {}
for label, (a, b, tolerance) in cases.items():
    reference = SurfaceReference(parse_scene(b))
    image, summary = deviation_image(
        parse_scene(a), reference, tolerance, width=320, height=240, spp=4
    )
    results[label] = image, summary, tolerance

for label, (_, s, tolerance) in results.items():
    x, y, z = s["point"]
    print(f"{label} (tolerance {tolerance:g}):")
    print(
        f"  max |d| = {s['max_abs']:.9g} at ({x:.4g}, {y:.4g}, {z:.4g}), pixel {s['pixel']}; "
        f"d from {s['min']:.6g} to {s['max']:.6g}"
    )
    print(
        f"  mean {s['mean']:.6g}, RMS {s['rms']:.6g}, 95 % of |d| below {s['p95']:.6g}, "
        f"{100 * s['within']:.1f} % within ±{tolerance:g}; {s['count']} pixels measured"
    )

spheres = results["sphere r = 2 against r = 2.003"][1]
error = max(abs(spheres["min"] + 0.003), abs(spheres["max"] + 0.003))
print(f"spheres: every d within {error:.2g} of -0.003 (double precision)")

fig, axes = plt.subplots(1, 2, figsize=(8, 3.2), layout="compressed")
for ax, (label, (image, _, _)) in zip(axes, results.items(), strict=True):
    ax.imshow(image.srgba)
    ax.set_title(label, fontsize=10)
    ax.axis("off")
plt.show()
