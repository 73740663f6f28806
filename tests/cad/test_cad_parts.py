"""Kernel-built parts rendered against exact figures: a sphere cut by a plane (closed, |H| =
1/R and 0, the cut circle within half a pixel), a curved B-spline face with a circular hole
(open exactly over the hole), a loft through B-spline sections (f = the kernel's own mean
curvature), the same part as STEP, IGES and BREP (the same pictures), and one B-spline
surface split into two faces (no crack, f continuous across the split).

The parts are built with Open CASCADE at test time (:mod:`tests.support.cad_parts`) and written once
per module; images are small (160 x 120) and flat-lit, with the mean curvature as f.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("OCP")

from OCP.BRepAdaptor import BRepAdaptor_Surface
from OCP.BRepLProp import BRepLProp_SLProps
from scipy import ndimage

from gshade.cad import read_cad
from gshade.cad.kernel import shape_faces
from gshade.geometry import gaussian_and_mean_curvature
from gshade.rendering import render
from gshade.scene import load_scene

from ..support.cad_parts import (
    CAP_PLANE,
    HOLE_CENTRE,
    HOLE_RADIUS,
    SHEET,
    SPHERE_RADIUS,
    SPLIT_AT,
    bspline_sheet,
    holed_bspline_face,
    loft,
    sphere_cap,
    split_bspline_face,
    write_shape,
)
from ..support.pictures import silhouette_of

SETTINGS = """
[shape]
function = "mean"
display = "colormap"
[render]
width = 160
height = 120
spp = {spp}
lighting = "flat"
{extra}
"""


@pytest.fixture(scope="module")
def parts(tmp_path_factory) -> Path:
    """A folder with the parts written once: cap.brep, holed.step, loft.{brep,step,igs},
    loft-reversed.brep, split.brep, sheet.brep."""
    folder = tmp_path_factory.mktemp("cad_parts")
    write_shape(sphere_cap(), folder / "cap.brep")
    write_shape(holed_bspline_face(), folder / "holed.step")
    shape = loft()
    for name in ("loft.brep", "loft.step", "loft.igs"):
        write_shape(shape, folder / name)
    write_shape(shape.Reversed(), folder / "loft-reversed.brep")
    write_shape(split_bspline_face(), folder / "split.brep")
    write_shape(bspline_sheet(), folder / "sheet.brep")
    return folder


def _scene(folder: Path, file: str, camera: str, name: str, spp: int = 4, extra: str = ""):
    """A scene of one cad surface (the file in ``folder``), mean curvature, flat."""
    path = folder / name
    settings = SETTINGS.format(spp=spp, extra=extra)
    path.write_text(f'[[surface]]\ntype = "cad"\nfile = "{file}"\n{settings}\n[camera]\n{camera}\n')
    return load_scene(path)


def _kinds(scene) -> np.ndarray:
    """The kernel's surface kind of each of the scene's patches."""
    cad = scene.surfaces[0].cad
    return np.array([cad.model.faces[i].kind for i in cad.faces])


def _one_face_core(image) -> np.ndarray:
    """Fully covered pixels whose 3 x 3 neighbourhood shows one face only."""
    patch = image["patch"]
    same = ndimage.minimum_filter(patch, 3) == ndimage.maximum_filter(patch, 3)
    return same & (image["A"] == 1) & (patch >= 0)


def _pixel_to_xy(image) -> tuple[np.ndarray, float]:
    """For an orthographic view along z: each pixel centre's world (x, y) (an affine map of
    the pixel, fitted to P on the hit pixels) and the pixel's size in world units."""
    A = image["A"]
    rows, cols = np.indices(A.shape)
    X = np.stack([cols + 0.5, rows + 0.5, np.ones(A.shape)], -1)
    hit = image["patch"] >= 0
    P = np.stack([image["P.X"], image["P.Y"]], -1).astype(float)
    coef, *_ = np.linalg.lstsq(X[hit], P[hit], rcond=None)
    assert np.abs(X[hit] @ coef - P[hit]).max() < 1e-4  # an orthographic view along z
    return X @ coef, float(np.linalg.norm(coef[0]))


# -- a sphere cut by a plane --------------------------------------------------------------

CAP_VIEWS = {
    "above": "origin = [30, -40, 35]\ntarget = [0, 0, 2.5]\nup = [0, 0, 1]\nfov = 20",
    "below": "origin = [-25, 30, -30]\ntarget = [0, 0, 2.5]\nup = [0, 0, 1]\nfov = 20",
    "side": "origin = [45, 10, -12]\ntarget = [0, 0, 2.5]\nup = [0, 0, 1]\nfov = 18",
    "ortho": 'type = "orthographic"\norigin = [-20, -20, -30]\ntarget = [0, 0, 2]\n'
    "up = [0, 0, 1]\nwidth = 14",
}


@pytest.mark.parametrize("view", sorted(CAP_VIEWS))
def test_sphere_cap_is_closed_with_exact_curvatures(parts, view):
    """The cap z >= h of a sphere of radius R, from four views: no uncovered pixel inside
    the silhouette (none partly covered, none without a patch, away from its rim), and on
    pixels well inside one face |H| = 1/R on the sphere, H = 0 on the flat disc."""
    scene = _scene(parts, "cap.brep", CAP_VIEWS[view], f"cap-{view}.toml")
    image = render(scene)
    A, patch, f = image["A"], image["patch"], image["f"]
    silhouette = silhouette_of(A)
    assert (A > 0).sum() > 1500
    assert not ((A == 0) & silhouette).any()
    inside = ndimage.binary_erosion(silhouette)
    assert not ((A < 1) & inside).any()
    assert not ((patch < 0) & inside).any()
    core = inside & _one_face_core(image)
    kinds = _kinds(scene)
    sphere = core & np.isin(patch, np.flatnonzero(kinds == "sphere"))
    plane = core & np.isin(patch, np.flatnonzero(kinds == "plane"))
    assert sphere.sum() + plane.sum() > 1000
    if sphere.any():
        assert np.abs(np.abs(f[sphere]) - 1 / SPHERE_RADIUS).max() < 1e-6
    if plane.any():
        assert np.abs(f[plane]).max() < 1e-6
    if view != "above":
        assert plane.sum() > 100  # the disc is seen from below and from the side
    if view != "below":
        assert sphere.sum() > 100


@pytest.mark.parametrize("side", ["above", "below"])
def test_the_cut_circle_is_within_half_a_pixel(parts, side):
    """Straight along z (orthographic, one sample per pixel: at its centre), the covered
    pixels are the disc of radius sqrt(R² - h²) that the cut leaves: from above its edge is
    the sphere face's trimming circle, from below the flat face's. No pixel whose centre lies
    more than half a pixel inside the exact circle is uncovered, none more than half a pixel
    outside it is covered."""
    z = -30 if side == "below" else 30
    camera = (
        f'type = "orthographic"\norigin = [0, 0, {z}]\ntarget = [0, 0, {CAP_PLANE}]\n'
        "up = [0, 1, 0]\nwidth = 14"
    )
    scene = _scene(parts, "cap.brep", camera, f"circle-{side}.toml", spp=1)
    image = render(scene)
    A, patch = image["A"], image["patch"]
    kind = "plane" if side == "below" else "sphere"
    assert set(_kinds(scene)[np.unique(patch[patch >= 0]).astype(int)]) == {kind}
    xy, pixel = _pixel_to_xy(image)
    rho = math.sqrt(SPHERE_RADIUS**2 - CAP_PLANE**2)
    d = (np.hypot(xy[..., 0], xy[..., 1]) - rho) / pixel  # signed, in pixels
    inside, outside = d < -0.5, d > 0.5
    assert inside.sum() > 8000
    assert int((inside & (A < 1)).sum()) == 0
    assert int((outside & (A > 0)).sum()) == 0


# -- a B-spline face with a circular hole -------------------------------------------------


def test_the_hole_in_a_bspline_face_is_open_exactly(parts):
    """A curved B-spline face with the vertical cylinder of radius r cut out, seen straight
    along z (orthographic, samples at the pixel centres): the hole's outline is the circle of
    radius r around its centre.  Pixels more than half a pixel inside it are uncovered
    (A = 0); pixels more than half a pixel outside it, and inside the sheet, are covered."""
    cx, cy = HOLE_CENTRE
    camera = (
        f'type = "orthographic"\norigin = [{cx}, {cy}, 50]\ntarget = [{cx}, {cy}, 2]\n'
        "up = [0, 1, 0]\nwidth = 14"
    )
    scene = _scene(parts, "holed.step", camera, "holed.toml", spp=1)
    (face,) = scene.surfaces[0].cad.model.faces
    assert face.kind == "bspline" and face.inner_loops == 1
    image = render(scene)
    A = image["A"]
    xy, pixel = _pixel_to_xy(image)
    d = (np.hypot(xy[..., 0] - cx, xy[..., 1] - cy) - HOLE_RADIUS) / pixel
    in_sheet = (np.minimum(xy, SHEET - xy) > 0.5 * pixel).all(axis=-1)
    hole, sheet = d < -0.5, (d > 0.5) & in_sheet
    assert hole.sum() > 3000 and sheet.sum() > 8000
    assert int((hole & (A > 0)).sum()) == 0
    assert int((sheet & (A < 1)).sum()) == 0


# -- a loft: f against the kernel's own curvature -----------------------------------------

LOFT_VIEW = "origin = [40, -30, 25]\ntarget = [0, 0, 6]\nup = [0, 0, 1]\nfov = 30"


def _kernel_mean_curvature(face, us: np.ndarray, vs: np.ndarray) -> np.ndarray:
    """The kernel's mean curvature of a face's surface at the (u, v) (with the sign of the
    surface's normal, whatever the face's orientation)."""
    adaptor = BRepAdaptor_Surface(face)
    props = BRepLProp_SLProps(adaptor, 2, 1e-9)
    out = np.empty(len(us))
    for i, (u, v) in enumerate(zip(us, vs, strict=True)):
        props.SetParameters(float(u), float(v))
        # IsCurvatureDefined() computes the curvatures: MeanCurvature() alone returns 0
        assert props.IsCurvatureDefined()
        out[i] = props.MeanCurvature()
    return out


@pytest.mark.parametrize("file", ["loft.brep", "loft-reversed.brep"])
def test_loft_mean_curvature_is_the_kernels(parts, file):
    """A closed loft through two circles and a periodic B-spline section: no background
    inside its silhouette, and at the pixel centres (one sample per pixel, the finest
    texture) gshade's mean curvature equals the kernel's (BRepLProp_SLProps on the same face
    at the same parameters; the EXR's (u, v) are (v, u) of the face on a reversed face, whose
    outward normal is minus the surface's, so H changes sign there).

    The exact evaluation at the hit parameters agrees to 1e-6 relative; the f channel is
    interpolated (bicubic Hermite) from texels of the exact values, and the side face's
    knots of multiplicity 12 at degree 14 (C2: H has kinks there) cost up to ~2e-3 of max |H|
    in the pixels next to a knot line."""
    scene = _scene(parts, file, LOFT_VIEW, f"{file}.toml", spp=1, extra="texture_resolution = 512")
    image = render(scene)
    A, patch, f = image["A"], image["patch"], image["f"]
    assert (A > 0).sum() > 3000
    assert not ((A == 0) & silhouette_of(A)).any()
    cad = scene.surfaces[0].cad
    kernel_faces = shape_faces(read_cad(cad.model.path, isolated=False).brep)
    rows, cols = (a[::2] for a in np.nonzero(_one_face_core(image)))  # every other pixel
    k = patch[rows, cols].astype(int)
    u, v = image["u"][rows, cols].astype(float), image["v"][rows, cols].astype(float)
    exact_H, kernel_H = np.empty(len(k)), np.empty(len(k))
    for i in np.unique(k):
        at = k == i
        _, exact_H[at] = gaussian_and_mean_curvature(scene.patches[i].derivatives(u[at], v[at], 2))
        face = cad.model.faces[cad.faces[i]]
        face_u, face_v = (v[at], u[at]) if cad.swapped[i] else (u[at], v[at])
        H = _kernel_mean_curvature(kernel_faces[cad.faces[i]], face_u, face_v)
        kernel_H[at] = -H if face.reversed else H
    f_H = f[rows, cols].astype(float)
    kinds = _kinds(scene)[k]
    side, caps = kinds == "bspline", kinds == "plane"
    assert side.sum() > 1000 and caps.sum() > 100
    assert np.abs(exact_H[caps]).max() < 1e-9 and np.abs(f_H[caps]).max() < 1e-9
    assert np.abs(kernel_H[caps]).max() < 1e-9
    scale = np.abs(kernel_H[side]).max()
    assert scale > 0.1
    # relative to |H|, and to 1e-3 max |H| where H crosses 0
    size = np.maximum(np.abs(kernel_H[side]), 1e-3 * scale)
    assert (np.abs(exact_H - kernel_H)[side] / size).max() < 1e-6
    relative = np.abs(f_H - kernel_H)[side] / size
    assert np.median(relative) < 1e-5
    assert np.abs(f_H - kernel_H)[side].max() < 5e-3 * scale


# -- the same part as STEP, IGES and BREP -------------------------------------------------


@pytest.fixture(scope="module")
def loft_images(parts):
    """The loft rendered from the same view from its BREP, STEP and IGES files."""
    out = {}
    for name in ("loft.brep", "loft.step", "loft.igs"):
        scene = _scene(parts, name, LOFT_VIEW, f"formats-{name}.toml")
        out[name] = (scene, render(scene))
    return out


def test_step_iges_and_brep_give_the_same_pictures(loft_images):
    """The loft written as STEP, IGES and BREP renders to the same picture: coverage equal
    except on a handful of silhouette pixels (the kernel meshes each file's faces anew, and
    STEP and IGES store the geometry in decimal text), and where all three are fully covered
    f and P agree closely (IGES may reparametrise the faces, so u, v are not compared)."""
    scene, brep = loft_images["loft.brep"]
    assert (brep["A"] > 0).sum() > 3000
    for name in ("loft.step", "loft.igs"):
        other_scene, other = loft_images[name]
        assert len(other_scene.patches) == len(scene.patches), name
        differ = brep["A"] != other["A"]
        assert differ.sum() <= 6, (name, int(differ.sum()))
        both = (brep["A"] == 1) & (other["A"] == 1)
        both &= _one_face_core(brep) & _one_face_core(other)
        assert both.sum() > 3000
        P = np.stack([brep[f"P.{c}"] - other[f"P.{c}"] for c in "XYZ"], -1)
        assert np.linalg.norm(P[both], axis=-1).max() < 1e-4, name
        scale = np.abs(brep["f"][both]).max()
        assert np.abs(brep["f"][both] - other["f"][both]).max() < 1e-4 * scale, name


# -- one B-spline surface split into two faces --------------------------------------------


def test_a_split_bspline_surface_renders_without_a_crack(parts):
    """One curved B-spline surface as two sewn faces (u <= 0.5, u >= 0.5), seen from above:
    no uncovered pixel inside the silhouette (no crack along the split), both faces seen, and
    the same picture as the surface made one face: coverage equal but for a few rim pixels,
    f equal where both are covered (so continuous across the split), and the jump of f
    between neighbouring pixels across the split no larger than between neighbours
    elsewhere (the finest texels: see below)."""
    camera = "origin = [10, -12, 30]\ntarget = [10, 10, 2]\nup = [0, 0, 1]\nfov = 50"
    fine = "texture_resolution = 512"
    scene = _scene(parts, "split.brep", camera, "split.toml", extra=fine)
    faces = scene.surfaces[0].cad.model.faces
    assert [f.kind for f in faces] == ["bspline", "bspline"]
    assert faces[0].box[0][1] == pytest.approx(SPLIT_AT) == faces[1].box[0][0]
    image = render(scene)
    A, patch, f = image["A"], image["patch"], image["f"]
    silhouette = silhouette_of(A)
    assert (A > 0).sum() > 5000
    assert not ((A == 0) & silhouette).any()
    inside = ndimage.binary_erosion(silhouette, iterations=2)
    assert not ((A < 1) & inside).any()
    assert set(np.unique(patch[inside])) == {0.0, 1.0}
    # the same as one face
    whole = render(_scene(parts, "sheet.brep", camera, "sheet.toml", extra=fine))
    assert (A != whole["A"]).sum() <= 6
    both = (A == 1) & (whole["A"] == 1)
    scale = np.abs(whole["f"][both]).max()
    # f is interpolated from each face's texels: near the surface's knot lines (H has kinks
    # there) the two tilings differ by up to ~4e-4 max |f| (~2.5% at the default texels)
    assert np.abs(f[both] - whole["f"][both]).max() < 1e-3 * scale
    # horizontal neighbours inside the silhouette: across the split, and within one face
    left, right = np.s_[:, :-1], np.s_[:, 1:]
    pair = inside[left] & inside[right]
    jump = np.abs(f[left] - f[right])
    across = pair & (patch[left] != patch[right])
    within = pair & (patch[left] == patch[right])
    assert across.sum() > 30
    assert jump[across].max() <= 1.5 * np.quantile(jump[within], 0.999)
