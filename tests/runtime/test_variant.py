"""Mitsuba variants: finding a usable LLVM, and the scalar fallback with one warning."""

import os
import subprocess
import sys

import pytest

from gshade import GshadeError
from gshade.runtime.llvm import find_llvm
from gshade.runtime.variant import llvm_version, resolve_variant


@pytest.mark.parametrize(
    ("name", "version"),
    [
        ("libLLVM.so.23.1", 23),
        ("libLLVM-19.so", 19),
        ("libLLVM-14.0.6.so.1", 14),
        ("libLLVM-15.so.1", 15),
        ("libLLVM.so", None),
        ("libc.so.6", None),
    ],
)
def test_llvm_version_from_the_file_name(name, version):
    assert llvm_version(f"/usr/lib/{name}") == version


def test_unknown_variant_is_named():
    with pytest.raises(GshadeError, match="variant: expected one of auto, llvm_ad_rgb"):
        resolve_variant("gpu")


FALLBACK = """
import warnings
import numpy as np
import gshade.runtime.variant as v
v.find_llvm = lambda: None          # as on a machine without libLLVM >= 17
from gshade import GshadeError
try:
    v.resolve_variant("llvm_ad_rgb")
except GshadeError as exc:
    print("explicit:", exc)
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    import gshade
    from gshade.scene import parse_scene
    scene = parse_scene('''
[[surface]]
type = "sphere"
[shape]
function = "isophotes"
[render]
width = 12
height = 9
spp = 1
lighting = "flat"
''')
    image = gshade.render(scene)
print("variant:", image.metadata["variant"])
print("warnings:", sum("scalar_rgb" in str(w.message) for w in caught))
print("covered:", int((image["A"] > 0).sum()))
"""


def test_without_llvm_auto_falls_back_to_scalar_with_one_warning():
    result = subprocess.run([sys.executable, "-c", FALLBACK], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    out = result.stdout
    assert "explicit: variant: llvm_ad_rgb needs libLLVM >= 17" in out
    assert "variant: scalar_rgb" in out
    assert "warnings: 1" in out
    assert int(out.split("covered:")[1]) > 20


EARLY_DRJIT = """
import warnings
import drjit as dr
loaded = dr.detail.llvm_version()[0]  # Dr.Jit picks its LLVM before gshade can help
import gshade
from gshade.scene import parse_scene
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    image = gshade.render(parse_scene('[[surface]]\\ntype = "sphere"\\n'), width=8, height=6,
                          spp=1)
warned = any("gshade.runtime.setup() before importing drjit" in str(w.message) for w in caught)
print("loaded:", loaded, "variant:", image.metadata["variant"], "warned:", warned)
"""


def test_drjit_imported_first_never_aborts():
    result = subprocess.run(
        [sys.executable, "-c", EARLY_DRJIT],
        capture_output=True,
        text=True,
        env={k: v for k, v in __import__("os").environ.items() if k != "DRJIT_LIBLLVM_PATH"},
    )
    assert result.returncode == 0, result.stderr
    loaded = int(result.stdout.split("loaded:")[1].split()[0])
    if loaded < 17:
        assert "variant: scalar_rgb" in result.stdout and "warned: True" in result.stdout
    else:
        assert "variant: llvm_ad_rgb" in result.stdout


OWN_PROCESS = """
import hashlib, sys
import gshade.runtime.variant as v
from gshade.io.image import read_exr
SCENE = sys.argv[2]
if sys.argv[1] == "cli":  # the command line's process: gshade's own
    from gshade.app.cli import main
    assert main(["render", SCENE, "-o", sys.argv[3]]) == 0
    picture = read_exr(sys.argv[3])[0]["R"]
else:  # a program's process
    import gshade
    picture = gshade.render(SCENE)["R"]
mi = v.mitsuba()
try:
    mi.load_dict({"type": "prb"})
    print("prb: yes")
except Exception:
    print("prb: no")
print("variant:", mi.variant(), "R:", hashlib.sha256(picture.tobytes()).hexdigest())
"""


def test_the_command_line_sets_variants_without_mitsubas_python_integrators(tmp_path):
    scene = tmp_path / "sphere.toml"
    scene.write_text('[[surface]]\ntype = "sphere"\n[render]\nwidth = 16\nheight = 12\nspp = 4\n')
    said = {}
    for mode in ("cli", "library"):
        out = subprocess.run(
            [sys.executable, "-c", OWN_PROCESS, mode, str(scene), str(tmp_path / "s.exr")],
            capture_output=True,
            text=True,
        )
        assert out.returncode == 0, out.stderr
        said[mode] = out.stdout
    if "variant: llvm_ad_rgb" not in said["library"]:
        pytest.skip("Mitsuba loads its Python integrators with llvm_ and cuda_ variants only")
    assert "prb: yes" in said["library"]  # a program's process: as Mitsuba sets variants
    assert "prb: no" in said["cli"]
    picture = [said[m].split("R:")[1].strip() for m in ("cli", "library")]
    assert picture[0] == picture[1]  # the same picture either way


IMPORTS = """
import os, sys
import gshade, gshade.scene, gshade.rendering, gshade.cad, gshade.analysis, gshade.app.cli
import gshade.geometry, gshade.shape, gshade.display, gshade.regression
print("set:", os.environ.get("DRJIT_LIBLLVM_PATH"), "drjit:", "drjit" in sys.modules)
gshade.runtime.setup()
print("after setup:", os.environ.get("DRJIT_LIBLLVM_PATH") is not None)
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
import drjit as dr
print("llvm:", dr.detail.llvm_version()[0])
"""


def test_importing_gshade_changes_nothing_and_setup_points_drjit_at_its_llvm():
    """Importing gshade's packages sets no variable and imports no Dr.Jit; a program that
    imports Mitsuba itself calls gshade.runtime.setup() first and gets a libLLVM >= 17."""
    if find_llvm() is None:
        pytest.skip("no libLLVM >= 17 here")
    env = {k: v for k, v in os.environ.items() if k != "DRJIT_LIBLLVM_PATH"}
    result = subprocess.run(
        [sys.executable, "-c", IMPORTS], capture_output=True, text=True, env=env
    )
    assert result.returncode == 0, result.stderr
    assert "set: None drjit: False" in result.stdout
    assert "after setup: True" in result.stdout
    assert int(result.stdout.split("llvm:")[1]) >= 17
