"""
Studio reflections: the teapot under the light box
===================================================

The shape function ``environment`` shows a surface as a designer's studio does: a chrome
mirror reflecting strip lights overhead and a soft floor (``map = "lightbox"``), or any
latitude–longitude map (an EXR or HDR file). It is computed from the exact unit normal at
every sample, so a G1 junction shows as a kink in the reflected strips — Kiciak's reflection
lines (form ``infinity``) are the special case of an environment of stripes at infinity.

This example renders ``scenes/teapot-studio.toml`` as a mirror, the same teapot as a glossy
conductor (``roughness = 0.05``: Mitsuba's ``roughconductor`` samples the lobe until two
seeds agree within 1 % in sRGB, as the legend says), and the teapot's zebra
(``scenes/teapot-zebra.toml``) beside them; then it reads the reflection direction out of
the mirror's EXR channels and checks it against the exact normal.
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import gshade

# the checkout: sphinx-gallery runs the script in its own folder, without __file__
HERE = Path(__file__).parent if "__file__" in globals() else Path.cwd()
SCENES = HERE.resolve().parents[1] / "scenes"
SIZE = {"width": 320, "height": 240, "spp": 16}

# %%
# The mirror, the glossy conductor and the zebra. The strips' reflections cross the lid's
# rim and kink there (a G1 junction), as the zebra's stripes do.

mirror = gshade.render(SCENES / "teapot-studio.toml", **SIZE)
glossy = gshade.render(SCENES / "teapot-studio.toml", **SIZE, set={"shape.roughness": 0.05})
zebra = gshade.render(SCENES / "teapot-zebra.toml", **SIZE, lighting="flat")

fig, axes = plt.subplots(1, 3, figsize=(10, 2.9), layout="compressed")
for ax, (label, image) in zip(
    axes, {"mirror": mirror, "glossy (roughness 0.05)": glossy, "zebra": zebra}.items(), strict=True
):
    ax.imshow(image.srgba)
    ax.set_title(label, fontsize=10)
    ax.set_axis_off()
print(glossy.metadata["legend"])

# %%
# The EXR's ``refl.X``, ``refl.Y``, ``refl.Z``: the exact unit reflection direction where the
# ray through each pixel centre meets the exact surface. It is ``v - 2 <v, N> N`` of the
# direction ``v`` from the eye to the point ``P`` and the exact normal ``N`` there, and ``f``
# is the map's luminance in that direction.

hit = mirror["patch"] >= 0
r = np.stack([mirror[f"refl.{a}"] for a in "XYZ"], -1)[hit].astype(float)
P = np.stack([mirror[f"P.{a}"] for a in "XYZ"], -1)[hit].astype(float)
N = np.stack([mirror[f"N.{a}"] for a in "XYZ"], -1)[hit].astype(float)
eye = np.array([6.0, -8.5, 5.5])  # the scene's camera origin
v = (P - eye) / np.linalg.norm(P - eye, axis=1, keepdims=True)
expected = v - 2 * np.sum(v * N, axis=1, keepdims=True) * N
print(f"{hit.sum()} pixels: |r - (v - 2 <v, N> N)| <= {np.abs(r - expected).max():.1e}")
assert np.abs(r - expected).max() < 1e-5

fig, axes = plt.subplots(1, 2, figsize=(7, 2.6), layout="compressed")
axes[0].imshow(
    np.where(hit[..., None], (np.stack([mirror[f"refl.{a}"] for a in "XYZ"], -1) + 1) / 2, 1)
)
axes[0].set_title("refl as RGB", fontsize=10)
shown = axes[1].imshow(np.where(hit, mirror["f"], np.nan), cmap="gray")
axes[1].set_title("f: the luminance reflected", fontsize=10)
fig.colorbar(shown, ax=axes[1], shrink=0.8)
for ax in axes:
    ax.set_axis_off()
