"""
A failing ``gshade check``: test, reference and difference
==========================================================

``gshade check`` renders each scene small (160 × 120 pixels, 4 samples per pixel, unless
the scene's ``[check]`` table says otherwise), compares it with its reference EXR channel
by channel with ``idiff``'s thresholds, and reports PASS, WARNING or FAILURE.  Here a
reference of ``scenes/junctions-isophotes.toml`` (two pairs of Bézier patches under
isophotes, with a ``[check]`` table added for a larger check picture) is made in a
temporary folder, then one control point of one patch is raised by 0.15, and the check is
run again through the Python API (``gshade.regression.check.check_scene``, what the
command and the pytest plugin run per scene).  The pictures show the new render (test), the
reference and the per-pixel difference (each pixel's largest absolute difference over the
compared channels R, G, B, A and f, as the HTML report's heat map shows it).  The
difference lies on the one patch whose point moved (the third from the left, nearest its
left edge) and fades away from the point: the isophotes follow the surface normals, which
the point moves most near itself.  The scene fixes its camera and stripe period; a scene
that left them automatic would see a local change move the whole picture, as gshade would
frame it and choose its period anew.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from gshade.io import read_exr
from gshade.io.image import srgb8, straight_rgb
from gshade.regression.check import check_scene
from gshade.regression.comparison import heat_map

# the checkout: sphinx-gallery runs the script in its own folder, without __file__
HERE = Path(__file__).parent if "__file__" in globals() else Path.cwd()
ROOT = HERE.resolve().parents[1]
SCENE = ROOT / "scenes" / "junctions-isophotes.toml"
#: The check's own render size (default 160 x 120), added to the copied scene.
CHECK = """
[check]
width = 320
height = 180
"""


def picture(channels):
    """The picture as gshade's PNG writer encodes it: 8-bit sRGB with alpha."""
    return srgb8(straight_rgb(channels), channels["A"])


# %%
# The reference first: ``update=True`` writes the references of new or failing scenes
# (``gshade check --update``).  Then the scene file is edited and checked again.

with tempfile.TemporaryDirectory() as tmp:
    folder = Path(tmp)
    scene = folder / "junctions-isophotes.toml"
    scene.write_text(SCENE.read_text() + CHECK)
    references = folder / "references"
    references.mkdir()

    first = check_scene(scene, references, update=True)
    print(first.line())

    text = scene.read_text()
    # the G2 pair's first patch: its control point (4.8, 1, z) raised by 0.15
    moved = text.replace("[4.8, 1, 0.147021918275928]", "[4.8, 1, 0.297021918275928]")
    assert moved != text
    scene.write_text(moved)

    result = check_scene(scene, references)
    print(result.line())
    reference, _ = read_exr(result.reference)

comparison = result.comparison
overall = comparison.overall
print(f"verdict {comparison.verdict} (exit status {comparison.exit_status})")
print(
    f"{comparison.failing} of {comparison.pixels} pixels over fail = "
    f"{comparison.thresholds.fail} ({comparison.failing_percent:.3g} %, allowed "
    f"{comparison.thresholds.failpercent} %)"
)
print(
    f"largest difference {overall.max_error:.4g} at pixel {overall.max_at} in "
    f"{overall.max_channel}; mean {overall.mean_error:.3g}, PSNR {overall.psnr:.3g} dB"
)
for name, metrics in comparison.per_channel.items():
    print(f"  {name}: max {metrics.max_error:.4g}, mean {metrics.mean_error:.3g}")

# %%
# The three pictures one above the other, as ``gshade check --report`` shows a failing
# scene, cut to the rows the surfaces cover.

covered = (result.image.channels["A"] > 0) | (reference["A"] > 0)
rows = np.flatnonzero(covered.any(axis=1))
band = slice(max(rows[0] - 4, 0), rows[-1] + 5)
fig, axes = plt.subplots(3, 1, figsize=(6, 5.6), layout="compressed")
panels = (
    (picture(result.image.channels), "test (one control point raised)"),
    (picture(reference), "reference"),
    (heat_map(comparison), f"difference (black 0, yellow {comparison.heat_scale:.2g})"),
)
for ax, (pixels, title) in zip(axes, panels, strict=True):
    ax.imshow(pixels[band])
    ax.set_title(title, fontsize=10)
    ax.axis("off")
plt.show()
