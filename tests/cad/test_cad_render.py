"""Rendering the trimmed faces of CAD models (scene type ``cad``): hole-free silhouettes,
exact curvatures on fillets and corners, holes left open, one-line errors."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("OCP")

from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder
from OCP.BRepTools import BRepTools
from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt
from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
from scipy import ndimage

from gshade.errors import GshadeError
from gshade.io import read_exr
from gshade.rendering import render
from gshade.scene import load_scene
from gshade.scene.load import CAD_LIGHT

from ..support.cad_parts import filleted_box
from ..support.pictures import silhouette_of

R = 2.0  # the fillet radius

SHAPE = """
[shape]
function = "mean"
display = "colormap"
[render]
width = 160
height = 120
spp = 4
lighting = "flat"
"""


def _plate_with_hole():
    plate = BRepPrimAPI_MakeBox(20.0, 20.0, 2.0).Shape()
    axis = gp_Ax2(gp_Pnt(10.0, 10.0, -1.0), gp_Dir(0.0, 0.0, 1.0))
    return BRepAlgoAPI_Cut(plate, BRepPrimAPI_MakeCylinder(axis, 4.0, 4.0).Shape()).Shape()


def _scene(folder: Path, surface: str, camera: str, name: str = "scene.toml") -> Path:
    path = folder / name
    path.write_text(f'[[surface]]\ntype = "cad"\n{surface}\n{SHAPE}\n[camera]\n{camera}\n')
    return path


@pytest.fixture(scope="module")
def box_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("cad_render") / "box.brep"
    BRepTools.Write_s(filleted_box(r=R), str(path))
    return path


@pytest.fixture(scope="module")
def plate_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("cad_render") / "plate.step"
    writer = STEPControl_Writer()
    writer.Transfer(_plate_with_hole(), STEPControl_AsIs)
    writer.Write(str(path))
    return path


VIEWS = {
    "front": "origin = [40, -50, 45]\ntarget = [5, 10, 15]\nup = [0, 0, 1]\nfov = 40",
    "below": "origin = [-30, 60, -40]\ntarget = [5, 10, 15]\nup = [0, 0, 1]\nfov = 40",
    "ortho": 'type = "orthographic"\norigin = [60, 40, 30]\ntarget = [5, 10, 15]\n'
    "up = [0, 0, 1]\nwidth = 50",
}


@pytest.mark.parametrize("view", sorted(VIEWS))
def test_filleted_box_is_closed_with_exact_curvatures(box_file, view):
    scene = load_scene(_scene(box_file.parent, 'file = "box.brep"', VIEWS[view], f"{view}.toml"))
    image = render(scene)
    A, patch, f = image["A"], image["patch"], image["f"]
    silhouette = silhouette_of(A)
    assert (A > 0).sum() > 1000
    # no holes: every uncovered pixel is connected to the border
    assert not ((A == 0) & silhouette).any()
    inside = ndimage.binary_erosion(silhouette)
    assert not ((A < 1) & inside).any()
    assert not ((patch < 0) & inside).any()
    # f on pixels well inside one face: |H| = 1/(2r) on the fillets, 1/r at the corners
    cad = scene.surfaces[0].cad
    assert cad is not None
    kinds = np.array([cad.model.faces[i].kind for i in cad.faces])
    same = ndimage.minimum_filter(patch, 3) == ndimage.maximum_filter(patch, 3)
    core = inside & same & (A == 1)
    seen = set()
    for kind, value in (("cylinder", 1 / (2 * R)), ("sphere", 1 / R), ("plane", 0.0)):
        on = core & np.isin(patch, np.flatnonzero(kinds == kind))
        if on.any():
            seen.add(kind)
            assert np.abs(np.abs(f[on]) - value).max() < 1e-6, kind
    assert {"cylinder", "plane"} <= seen
    # P lies on the patch at (u, v): the exact channels use the cad surface's patches
    hit = np.argwhere(core)[:: max(1, int(core.sum()) // 50)]
    P = np.stack([image["P.X"], image["P.Y"], image["P.Z"]], -1)
    for r, c in hit:
        p = scene.patches[int(patch[r, c])]
        q = p(np.array([image["u"][r, c]], float), np.array([image["v"][r, c]], float))
        assert np.linalg.norm(np.ravel(q) - P[r, c]) < 1e-4


def test_the_sphere_corners_are_seen(box_file):
    camera = "origin = [60, -60, 70]\ntarget = [10, 20, 30]\nup = [0, 0, 1]\nfov = 8"
    scene = load_scene(_scene(box_file.parent, 'file = "box.brep"', camera, "corner.toml"))
    image = render(scene)
    A, patch, f = image["A"], image["patch"], image["f"]
    cad = scene.surfaces[0].cad
    assert cad is not None
    kinds = np.array([cad.model.faces[i].kind for i in cad.faces])
    inside = ndimage.binary_erosion(silhouette_of(A))
    same = ndimage.minimum_filter(patch, 3) == ndimage.maximum_filter(patch, 3)
    on = inside & same & (A == 1) & np.isin(patch, np.flatnonzero(kinds == "sphere"))
    assert on.sum() > 20
    assert np.abs(np.abs(f[on]) - 1 / R).max() < 1e-6


def test_a_hole_stays_open(plate_file):
    camera = (
        'type = "orthographic"\norigin = [10, 10, 50]\ntarget = [10, 10, 1]\nup = [0, 1, 0]\n'
        "width = 24"
    )
    image = render(load_scene(_scene(plate_file.parent, 'file = "plate.step"', camera)))
    A, patch = image["A"], image["patch"]
    P = np.stack([image["P.X"], image["P.Y"]], -1)
    rows, cols = np.indices(A.shape)
    hit = patch >= 0
    # the pixel centres' (x, y) from P on the plate (an affine map of the pixel)
    X = np.stack([cols + 0.5, rows + 0.5, np.ones(A.shape)], -1)
    coef, *_ = np.linalg.lstsq(X[hit], P[hit], rcond=None)
    assert np.abs(X[hit] @ coef - P[hit]).max() < 1e-4
    xy = X @ coef
    pixel = float(np.linalg.norm(coef[0]))
    d = np.hypot(xy[..., 0] - 10, xy[..., 1] - 10)
    in_hole = d < 4 - pixel
    assert in_hole.sum() > 1000
    assert not (A[in_hole] > 0).any()
    plate = (d > 4 + pixel) & (np.abs(xy - 10) < 10 - pixel).all(axis=-1)
    assert plate.sum() > 5000
    assert (A[plate] == 1).all()


#: A cad surface's bad keys: (the surface's lines, the key named, words of the message); the
#: .3dm case needs rhino3dm (without it the message says to install it, as another test checks)
BAD_SURFACES = [
    pytest.param(
        'file = "model.3dm"',
        "",
        "model.3dm: expected a Rhino .3dm file, got no 3dm header",
        marks=pytest.mark.skipif(
            importlib.util.find_spec("rhino3dm") is None, reason="rhino3dm is not installed"
        ),
        id="3dm",
    ),
    pytest.param('file = "missing.step"', "file", "no such file", id="missing"),
    pytest.param('file = "box.brep"\nfaces = [0, 999]', "faces", "got 999", id="face-999"),
    pytest.param(
        'file = "box.brep"\nfaces = [-1]', "faces", "expected a list of face numbers", id="face-1"
    ),
    pytest.param(
        'file = "box.brep"\ntolerance = 0', "tolerance", "expected a positive number", id="tol"
    ),
    pytest.param('file = "box.brep"\nsew = 1', "sew", "expected true or false", id="sew"),
    pytest.param('file = "data.txt"', "file", "expected a CAD file", id="not-cad"),
]


@pytest.mark.parametrize(("surface", "key", "words"), BAD_SURFACES)
def test_bad_inputs_are_one_line(tmp_path, box_file, surface, key, words):
    camera = "origin = [40, -50, 45]\ntarget = [5, 10, 15]\nup = [0, 0, 1]"
    (tmp_path / "box.brep").write_bytes(box_file.read_bytes())
    (tmp_path / "model.3dm").write_bytes(b"")
    path = _scene(tmp_path, surface, camera)
    with pytest.raises(GshadeError) as err:
        load_scene(path)
    message = str(err.value)
    assert "\n" not in message
    assert str(path) in message and words in message
    assert f"(cad): {key}: " in message if key else "(cad): " in message


def test_some_faces(box_file):
    camera = "origin = [40, -50, 45]\ntarget = [5, 10, 15]\nup = [0, 0, 1]"
    path = _scene(box_file.parent, 'file = "box.brep"\nfaces = [0, 2]', camera, "some.toml")
    scene = load_scene(path)
    assert len(scene.patches) == 2
    image = render(scene)
    # the faces' own numbers (as info and the warnings give them), not their places
    assert set(np.unique(image["patch"])) <= {-1, 0, 2}
    assert 2 in np.unique(image["patch"])
    assert (image["A"] > 0).any()


def test_a_cad_file_is_a_scene_of_its_one_surface(tmp_path):
    part = tmp_path / "bracket.brep"
    BRepTools.Write_s(filleted_box(r=R), str(part))
    scene = load_scene(part, {"shape.function": "mean"})
    assert scene.name == "bracket" and len(scene.patches) == 26
    assert scene.shape.function == "mean" and "light" not in scene.shape.params
    # isophotes lit along the automatic view: walls parallel to z are off the stripe edges
    lit = load_scene(part).shape
    assert lit.function == "isophotes"
    assert np.allclose(lit.params["light"], CAD_LIGHT)
    out = tmp_path / "out"
    out.mkdir()
    args = [sys.executable, "-m", "gshade"]
    small = ["--width", "64", "--height", "48", "--spp", "1"]
    run = subprocess.run(
        [*args, "render", str(part), "-o", str(out / "b.exr"), *small],
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stderr
    channels, _ = read_exr(out / "b.exr")
    assert channels["A"].max() == 1.0
    info = subprocess.run([*args, "info", str(part)], capture_output=True, text=True)
    assert info.returncode == 0 and "26" in info.stdout
    edges = subprocess.run([*args, "continuity", str(part)], capture_output=True, text=True)
    assert edges.returncode == 0 and edges.stdout.strip().endswith("48 junctions: 48 G1")


def test_ranges_come_from_the_trimmed_region_only():
    """A trimmed face's tile covers its whole parameter box; the stripes' period and the
    colour range come from the texels the trimmed region's mesh reaches, so wild values of
    the surface outside the trim (untrimmed corners of the box) do not set them."""
    from gshade.rendering.atlas import Atlas
    from gshade.rendering.style import display_style, trimmed_region
    from gshade.rendering.textures import ShapeTextures
    from gshade.scene import parse_scene

    atlas = Atlas.for_patches(2, 9)  # patch 0 untrimmed, patch 1 a trimmed face
    values = np.zeros((atlas.height, atlas.width, 3), np.float32)
    rows0, cols0 = atlas.tile_slices(0)
    values[rows0, cols0, 0] = np.linspace(0.0, 1.0, 9)[None, :]  # f in [0, 1] on patch 0
    rows1, cols1 = atlas.tile_slices(1)
    values[rows1, cols1, 0] = 1e6  # patch 1: wild outside its trim...
    values[rows1.start + 3 : rows1.start + 6, cols1.start + 3 : cols1.start + 6, 0] = 0.5
    values[rows1.start + 4, cols1.start + 4, 0] = 0.53  # (not constant: the period unmoved)
    valid = np.ones((atlas.height, atlas.width), np.float32)
    image = np.zeros((atlas.height, atlas.width, 3), np.float32)
    tex = ShapeTextures(atlas, [values], [valid], [valid], image, image, image, image)
    # ...and its mesh's vertices only in the middle of its box
    params = np.array([[0.4, 0.4], [0.6, 0.4], [0.5, 0.6], [0.0, 0.0], [1.0, 1.0]])
    patch = np.array([1, 1, 1, 0, 0])
    region = trimmed_region(atlas, patch, params, np.array([False, True]))
    assert region[rows0, cols0].all()
    assert region[rows1, cols1].sum() == 7 and region[rows1.start + 4, cols1.start + 4]
    shape = parse_scene('[[surface]]\ntype = "sphere"\n[shape]\nstripes = 10\n').shape
    style = display_style(shape, shape.function, tex, region)
    assert style.period == pytest.approx(0.1)  # (1 - 0) / 10 stripes
    assert display_style(shape, shape.function, tex).period == pytest.approx(1e5)


def test_a_cad_file_through_a_symbolic_link_is_a_scene(tmp_path, box_file):
    """The link is what the user named: the model is read where the link points."""
    link = tmp_path / "linked.brep"
    link.symlink_to(box_file)
    scene = load_scene(link)
    assert scene.name == "linked" and len(scene.patches) == 26
