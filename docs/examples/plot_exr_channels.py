"""
Exact values in the EXR channels
================================

A gshade render is more than a picture: its EXR file carries, per pixel, the shape
function's exact value ``f`` at the point where the ray through the pixel centre meets the
exact surface, that point ``P.X P.Y P.Z``, the exact unit normal ``N.X N.Y N.Z``, the patch
parameters ``u v`` and the ``patch`` number.  This example renders the mean curvature H of an
exact rational torus (tube radius r = 0.5 about a circle of radius R = 2), writes the EXR to
a temporary folder, reads it back with the ``OpenEXR`` package alone and checks the
numbers against the closed forms, pixel by pixel: the point's distance to the tube's centre
circle is r, the normal is ±(P − C) / r for the nearest point C of that circle, and with
cos θ = (ρ − R) / r (ρ the distance of P from the axis) the mean curvature is
H = ∓(R + 2 r cos θ) / (2 r (R + r cos θ)), the sign that of the normal.  Mean curvature is
a shape function of order 2 (it shows a G1 junction as a jump; Kiciak, *Geometric
Continuity of Curves and Surfaces*, 2016); the torus is one smooth surface, so f varies
smoothly from ∓1.2 on the outer equator to ∓2/3 on the inner one.  The pictures
show the ``f`` channel as read, its difference from the closed form at the pixel's own
``P``, and a histogram of f over the covered pixels.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import OpenEXR

import gshade
from gshade.scene import parse_scene

R, r = 2.0, 0.5
TORUS = f"""
[[surface]]
type = "torus"
major = {R}
minor = {r}

[shape]
function = "mean"
display = "colormap"
"""

# %%
# Render, write the EXR, and read every channel back as numpy arrays.

image = gshade.render(parse_scene(TORUS), width=320, height=240, spp=4)
with tempfile.TemporaryDirectory() as tmp:
    path = Path(tmp) / "torus-mean.exr"
    image.write_exr(path)
    with OpenEXR.File(str(path), separate_channels=True) as exr:
        channels = {name: ch.pixels.copy() for name, ch in exr.channels().items()}
        header = dict(exr.header())
print("channels:", ", ".join(sorted(channels)))
print("scene:", header["scene_name"], "| legend:", header["legend"])

on = channels["patch"] >= 0  # pixels whose centre ray meets the surface
f = channels["f"]
P = np.stack([channels[f"P.{c}"] for c in "XYZ"], axis=-1).astype(np.float64)
N = np.stack([channels[f"N.{c}"] for c in "XYZ"], axis=-1).astype(np.float64)

# the closed forms at each pixel's own P
rho = np.hypot(P[..., 0], P[..., 1])
C = P * np.where(rho > 0, R / np.maximum(rho, 1e-300), 0)[..., None]
C[..., 2] = 0.0  # the nearest point of the tube's centre circle
outward = (P - C) / r
side = np.sign(np.sum(N * outward, axis=-1))  # +1 where N points out of the tube
cos = np.where(on, (rho - R) / r, 0.0)  # 0 off the surface, where P is 0
H = -side * (R + 2 * r * cos) / (2 * r * (R + r * cos))

# %%
# The numbers at one pixel, and over every covered pixel against the closed forms.

row, col = np.unravel_index(np.argmax(np.where(on, np.abs(f), 0)), f.shape)  # largest |H|
print(
    f"pixel (x={col}, y={row}): patch {channels['patch'][row, col]:g}, "
    f"u = {channels['u'][row, col]:.9g}, v = {channels['v'][row, col]:.9g}"
)
print(f"  P = {P[row, col].round(9).tolist()}")
print(f"  N = {N[row, col].round(9).tolist()}")
print(f"  f = {f[row, col]:.9g}; closed form at P: H = {H[row, col]:.9g}")
print(f"{on.sum()} covered pixels:")
print(f"  max ||P - C| - r|       = {np.abs(np.linalg.norm(P - C, axis=-1) - r)[on].max():.3g}")
print(f"  max |N - side (P - C)/r| = {np.abs(N - side[..., None] * outward)[on].max():.3g}")
print(f"  max |f - H|              = {np.abs(f - H)[on].max():.3g}")
print(f"  f from {f[on].min():.6g} to {f[on].max():.6g}")

# %%
# The f channel, its difference from the closed form, and the histogram of f.

fig, axes = plt.subplots(1, 3, figsize=(10, 2.9), layout="constrained")
shown = axes[0].imshow(np.where(on, f, np.nan), cmap="viridis")
fig.colorbar(shown, ax=axes[0], shrink=0.8)
axes[0].set_title("channel f: mean curvature H", fontsize=10)
shown = axes[1].imshow(np.where(on, f - H, np.nan), cmap="coolwarm")
fig.colorbar(shown, ax=axes[1], shrink=0.8, format="%.0e")
axes[1].set_title("f − H(P), the closed form", fontsize=10)
for ax in axes[:2]:
    ax.axis("off")
axes[2].hist(f[on], bins=50)
axes[2].set_title("histogram of f (covered pixels)", fontsize=10)
axes[2].set_xlabel("f")
plt.show()
