"""Interior knot lines of B-spline patches and CAD faces as junctions
(:mod:`gshade.analysis.knot_lines`): classes and measures against closed forms, on patches
built here and on CAD faces the kernel builds at test time."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gshade.analysis.continuity import Tolerances, continuity_report
from gshade.analysis.junction_lines import CLASS_COLOURS
from gshade.analysis.knot_lines import KnotLine, interior_knots, one_sided_pieces
from gshade.geometry import BSplinePatch

#: A planar control polygon (x, z) of a cubic B-spline with the double knot 1 in
#: [0, 0, 0, 0, 1, 1, 2, 2, 2, 2]: C1 there, its curvature jumps.
PROFILE = np.array([(0.0, 0.0), (1.0, 0.6), (2.0, 1.0), (3.0, 1.0), (4.0, 0.2), (5.0, 0.0)])
#: The extrusion's extent in y.
WIDTH = 3.0
#: The profile's knots in u, and the extrusion's (one cubic Bézier span) in v.
DOUBLE_KNOT_U = [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 2.0, 2.0, 2.0, 2.0]
BEZIER_V = [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0]


def profile_net(scale: float = 1.0) -> np.ndarray:
    """The control net (6, 4, 3) of the general cylinder (x(u), y, z(u)) over PROFILE, with
    y = WIDTH v (equally spaced Bézier points: linear in v)."""
    return scale * np.array([[(x, WIDTH * j / 3, z) for j in range(4)] for x, z in PROFILE])


def profile_cylinder() -> BSplinePatch:
    return BSplinePatch(profile_net(), (3, 3), (DOUBLE_KNOT_U, BEZIER_V))


def _cross(a, b) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def profile_curvatures(c: np.ndarray = PROFILE) -> tuple[float, float]:
    """The signed curvatures of the profile on the left and the right of its double knot,
    by hand from its two cubic Bézier pieces (no gshade geometry).

    A third copy of the knot (Boehm; both spans have length 1, so alpha = 1/2) adds the
    point Q = (c2 + c3) / 2; the pieces are c0 c1 c2 Q and Q c3 c4 c5.  At the ends of a
    Bézier curve of degree n (Kiciak, ch. 2; Farin):
    kappa(1) = (n-1)/n (b3 - b2) x (b1 - b2) / |b3 - b2|^3 and
    kappa(0) = (n-1)/n (b1 - b0) x (b2 - b1) / |b1 - b0|^3.
    """
    q = 0.5 * (c[2] + c[3])
    left = 2 / 3 * _cross(q - c[2], c[1] - c[2]) / np.linalg.norm(q - c[2]) ** 3
    right = 2 / 3 * _cross(c[3] - q, c[4] - c[3]) / np.linalg.norm(c[3] - q) ** 3
    return left, right


def test_a_double_knot_is_c1_and_g1_with_the_bezier_pieces_curvature_jump():
    """(a) Two bicubic pieces joined C1 (a double knot): on a general cylinder the normal
    curvature across the line is the profile's, along it 0, so the largest jump of the
    normal curvature over directions is |kappa_left - kappa_right|."""
    (junction,) = continuity_report([profile_cylinder()])
    assert junction.knot == KnotLine("u", 1.0, 2, 3, "patch")
    assert junction.knot.parametric_continuity == 1
    assert junction.patches == (0, 0) and junction.sides is None
    left, right = profile_curvatures()
    assert abs(left - right) > 1.0  # a real jump: -1.067 on the left, -2.133 on the right
    assert junction.cls == "G1"
    assert junction.curvature_jump == pytest.approx(abs(left - right), rel=1e-9)
    assert junction.gap < 1e-12 and junction.normal_angle_deg < 1e-9


def test_the_one_sided_pieces_are_the_limits_from_each_side():
    """The pieces' derivatives at the knot against finite differences of the whole patch
    from each side (second derivative in u by three points at h, 2h away)."""
    patch = profile_cylinder()
    left, right = one_sided_pieces(patch, "u", 1.0)
    assert left.domain[0] == (0.0, 1.0) and right.domain[0] == (1.0, 2.0)
    v = np.array([0.3])
    h = 1e-4
    for piece, sign in ((left, -1.0), (right, 1.0)):
        d = piece.derivatives(np.array([1.0]), v, 2)
        p0, p1, p2 = (patch(np.array([1.0 + sign * k * h]), v)[0] for k in (0, 1, 2))
        np.testing.assert_allclose(d[2, 0][0], (p2 - 2 * p1 + p0) / h**2, atol=1e-3)
    d_left = left.derivatives(np.array([1.0]), v, 2)[2, 0]
    d_right = right.derivatives(np.array([1.0]), v, 2)[2, 0]
    assert np.abs(d_left - d_right).max() > 1.0  # the second derivative jumps


def _random_net(nu: int, nv: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.arange(nu, dtype=float), np.arange(nv, dtype=float), indexing="ij")
    return np.stack([x, y, rng.uniform(-0.5, 0.5, (nu, nv))], -1)


def test_a_simple_knot_is_c2_and_g2():
    """(b) Simple knots of a bicubic: C2, so G2; the third derivative jumps (generic
    heights), so not G3."""
    U = [0, 0, 0, 0, 0.4, 1, 1, 1, 1]
    V = [0, 0, 0, 0, 0.6, 1, 1, 1, 1]
    report = continuity_report([BSplinePatch(_random_net(5, 5, 1), (3, 3), (U, V))])
    assert [(j.knot.direction, j.knot.knot, j.knot.multiplicity) for j in report] == [
        ("u", 0.4, 1),
        ("v", 0.6, 1),
    ]
    for j in report:
        assert j.cls == "G2"
        assert j.curvature_jump < 1e-10 and j.normal_angle_deg < 1e-9


def test_a_knot_doubled_by_insertion_is_geometrically_smooth():
    """(c) One bicubic Bézier patch with 0.5 inserted twice in u and 0.3 three times in v:
    parametrically C1 and C0 there, but one polynomial: G2 or better (G3: no jump at all)."""
    bezier = BSplinePatch(_random_net(4, 4, 2), (3, 3), (BEZIER_V, BEZIER_V))
    patch = bezier.insert_knot("u", 0.5, 2).insert_knot("v", 0.3, 3)
    report = continuity_report([patch])
    assert [(j.knot.direction, j.knot.knot, j.knot.multiplicity) for j in report] == [
        ("u", 0.5, 2),
        ("v", 0.3, 3),
    ]
    for j in report:
        assert j.cls in ("G2", "G3")
        assert j.curvature_jump < 1e-9 and j.curvature_gradient_jump < 1e-7


def test_which_knots_make_knot_lines():
    """C^(p - m) below C3: every interior knot of a cubic, double knots of a quartic; none
    at the ends of the range."""
    U = np.array([0, 0, 0, 0, 0, 0.2, 0.5, 0.5, 0.8, 0.8, 0.8, 1, 1, 1, 1, 1], float)
    assert interior_knots(U, 4, 0.0, 1.0) == [(0.5, 2), (0.8, 3)]
    assert interior_knots(U, 3, 0.0, 1.0) == [(0.2, 1), (0.5, 2), (0.8, 3)]
    assert interior_knots(U, 3, 0.2, 0.8) == [(0.5, 2)]


def test_knot_lines_are_in_the_continuity_json_and_table(tmp_path, capsys):
    """A scene's bspline patch through ``gshade continuity``: its knot line listed with the
    patch, direction, knot, multiplicity and degree; the table says u=1."""
    from gshade.app.cli import main

    scene = _profile_scene(tmp_path)
    assert main(["continuity", str(scene), "--json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)["junctions"]
    assert {k: row[k] for k in ("patch", "direction", "knot", "multiplicity", "degree")} == {
        "patch": 0,
        "direction": "u",
        "knot": 1.0,
        "multiplicity": 2,
        "degree": 3,
    }
    assert row["patches"] == [0, 0] and row["class"] == "G1"
    assert "sides" not in row and "edge" not in row
    assert main(["continuity", str(scene)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[1].split()[:4] == ["0", "0", "u=1", "G1"]
    assert out[-1] == "1 junctions: 1 G1"


def _profile_scene(folder: Path, surface: str | None = None) -> Path:
    """A scene of the profile cylinder (or of ``surface``'s TOML), seen straight from
    above, orthographic, 0.05 units a pixel."""
    if surface is None:
        points = json.dumps(profile_net().tolist())
        surface = (
            f'type = "bspline"\ndegree = [3, 3]\nknots_u = {DOUBLE_KNOT_U}\n'
            f"knots_v = {BEZIER_V}\npoints = {points}\n"
        )
    path = folder / "profile.toml"
    path.write_text(
        f"[[surface]]\n{surface}"
        '[shape]\nfunction = "mean"\ndisplay = "colormap"\n'
        '[render]\nwidth = 120\nheight = 80\nspp = 1\nlighting = "flat"\n'
        '[camera]\ntype = "orthographic"\norigin = [2.5, 1.5, 20]\ntarget = [2.5, 1.5, 0]\n'
        "up = [0, 1, 0]\nwidth = 6\n"
    )
    return path


def _drawn_on_the_knot_line(scene: Path) -> dict:
    """Rendered with and without junctions: the G1 (orange) pixels are those within the
    line's half width of x = 2.5 (the knot line: Q's x, where Q = (c2 + c3) / 2), the
    others unchanged; returns the header's junction entry."""
    from gshade.rendering import render
    from gshade.scene import load_scene

    image = render(load_scene(scene), junctions=True)
    plain = render(load_scene(scene))
    rgb = np.stack([image[c] for c in "RGB"], -1)
    changed = np.abs(rgb - np.stack([plain[c] for c in "RGB"], -1)).max(-1) > 1e-6
    orange = np.abs(rgb - np.asarray(CLASS_COLOURS["G1"])).max(-1) < 0.05
    pixel = 6 / 120
    distance = np.abs(image["P.X"] - 2.5)
    covered = image["A"] > 0
    assert orange[covered & (distance < 0.45 * pixel)].all()
    assert not changed[covered & (distance > 1.6 * pixel)].any()
    assert orange.sum() >= 2 * 50  # 2 px wide along the patch's 60 px in y
    (entry,) = json.loads(image.metadata["junctions"])["junctions"]
    return entry


def test_junctions_draw_a_patch_knot_line(tmp_path):
    entry = _drawn_on_the_knot_line(_profile_scene(tmp_path))
    assert entry["patch"] == 0 and entry["knot"] == 1.0 and entry["class"] == "G1"


# --------------------------------------------------------------------------- CAD faces


def _ocp():
    pytest.importorskip("OCP")
    from ..support import cad_parts

    return cad_parts


def _surface(poles: np.ndarray, knots_u, mults_u, knots_v=(0.0, 1.0), mults_v=(4, 4)):
    """A polynomial bicubic Geom_BSplineSurface of the poles (nu, nv, 3)."""
    _ocp()
    from OCP.collections import Array1_double, Array1_int, Array2_gp_Pnt
    from OCP.Geom import Geom_BSplineSurface
    from OCP.gp import gp_Pnt

    nu, nv, _ = poles.shape
    grid = Array2_gp_Pnt(1, nu, 1, nv)
    for i in range(nu):
        for j in range(nv):
            grid.SetValue(i + 1, j + 1, gp_Pnt(*map(float, poles[i, j])))
    arrays = []
    for values, mults in ((knots_u, mults_u), (knots_v, mults_v)):
        a, m = Array1_double(1, len(values)), Array1_int(1, len(values))
        for k, (t, n) in enumerate(zip(values, mults, strict=True)):
            a.SetValue(k + 1, float(t))
            m.SetValue(k + 1, int(n))
        arrays.append((a, m))
    (U, MU), (V, MV) = arrays
    return Geom_BSplineSurface(grid, U, V, MU, MV, 3, 3, False, False)


def _face(surface, box=None):
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace

    if box is None:
        return BRepBuilderAPI_MakeFace(surface, 1e-7).Face()
    (u0, u1), (v0, v1) = box
    return BRepBuilderAPI_MakeFace(surface, u0, u1, v0, v1, 1e-7).Face()


#: The CAD profile face's scale (mm): curvatures scale by 1 / SCALE.
SCALE = 10.0


def test_a_cad_face_with_a_double_knot_through_the_continuity_command(tmp_path, capsys):
    """(d) A one-face STEP file of the profile cylinder (knots 0, 0.5, 1 with the middle one
    double), built by the kernel: ``gshade continuity`` lists the knot line with the face,
    direction and knot, classed G1 with the Bézier pieces' curvature jump."""
    from gshade.app.cli import main

    cad_parts = _ocp()
    surface = _surface(profile_net(SCALE), (0.0, 0.5, 1.0), (4, 2, 4))
    path = cad_parts.write_shape(_face(surface), tmp_path / "double-knot.step")
    assert main(["continuity", str(path), "--json"]) == 0
    rows = [r for r in json.loads(capsys.readouterr().out)["junctions"] if "knot" in r]
    assert len(rows) == 1
    (row,) = rows
    assert {k: row[k] for k in ("face", "direction", "knot", "multiplicity", "degree")} == {
        "face": 0,
        "direction": "u",
        "knot": 0.5,
        "multiplicity": 2,
        "degree": 3,
    }
    left, right = profile_curvatures()
    assert row["class"] == "G1" and row["patches"] == [0, 0]
    assert row["curvature_jump"] == pytest.approx(abs(left - right) / SCALE, rel=1e-6)
    assert main(["continuity", str(path)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[1].split()[:4] == ["0", "0", "u=0.5", "G1"]
    assert out[-1] == "1 junctions: 1 G1"


def test_junctions_draw_a_cad_face_knot_line(tmp_path):
    """The same face (scale 1) rendered with ``--junctions``: drawn along its knot line."""
    cad_parts = _ocp()
    surface = _surface(profile_net(), (0.0, 0.5, 1.0), (4, 2, 4))
    cad_parts.write_shape(_face(surface), tmp_path / "face.brep")
    entry = _drawn_on_the_knot_line(_profile_scene(tmp_path, 'type = "cad"\nfile = "face.brep"\n'))
    assert entry["face"] == 0 and entry["knot"] == 0.5 and entry["class"] == "G1"


#: :func:`_sheet`: knots in u, the simple one at 0.35 and the double one at 0.7.
SHEET_KNOTS = ((0.0, 0.35, 0.7, 1.0), (4, 1, 2, 4))
#: :func:`_sheet`: heights of its 7 pole columns (a bumpy profile in u).
SHEET_HEIGHTS = (0.0, 1.0, 2.5, 1.5, 3.0, 0.5, 1.0)
#: :func:`_sheet`: the heights' factors along its 4 pole rows in v.
SHEET_WEIGHTS = (0.1, 0.3, 0.6, 1.0)


def _sheet():
    """A bicubic sheet over [0, 20]² in (x, y): pole columns at x = 20 i / 6 (x depends on
    u only, y = 20 v on v only), z = h_i w_j: the curvature jump at the double knot grows
    with y (from 0.14 at y = 0 to 1.05 at y = 20)."""
    poles = np.array(
        [
            [(20 * i / 6, 20 * j / 3, h * w) for j, w in enumerate(SHEET_WEIGHTS)]
            for i, h in enumerate(SHEET_HEIGHTS)
        ]
    )
    return _surface(poles, *SHEET_KNOTS)


def _knot_lines(path: Path) -> dict[float, object]:
    from gshade.analysis.scene_junctions import scene_continuity
    from gshade.scene import load_scene

    report, _ = scene_continuity(load_scene(path))
    return {j.knot.knot: j for j in report if j.knot is not None}


def test_a_knot_line_outside_a_trimmed_face_is_not_listed(tmp_path):
    """(e) The sheet's face u <= 0.5 has the knot 0.35 inside, not 0.7: only u = 0.35 is
    listed."""
    cad_parts = _ocp()
    half = cad_parts.write_shape(_face(_sheet(), ((0.0, 0.5), (0.0, 1.0))), tmp_path / "h.brep")
    whole = cad_parts.write_shape(_face(_sheet()), tmp_path / "whole.brep")
    assert sorted(_knot_lines(whole)) == [0.35, 0.7]
    lines = _knot_lines(half)
    assert sorted(lines) == [0.35]
    assert lines[0.35].knot == KnotLine("u", 0.35, 1, 3, "face")


def _triangle_cut(face):
    """The face with the part x + y > 20 cut away (a prism over a triangle beyond that line):
    the trimmed region is the triangle x + y <= 20 of the sheet."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace, BRepBuilderAPI_MakePolygon
    from OCP.BRepPrimAPI import BRepPrimAPI_MakePrism
    from OCP.gp import gp_Pnt, gp_Vec

    polygon = BRepBuilderAPI_MakePolygon(
        gp_Pnt(-1.0, 21.0, -30.0), gp_Pnt(21.0, -1.0, -30.0), gp_Pnt(30.0, 30.0, -30.0), True
    )
    base = BRepBuilderAPI_MakeFace(polygon.Wire()).Face()
    prism = BRepPrimAPI_MakePrism(base, gp_Vec(0.0, 0.0, 60.0)).Shape()
    return BRepAlgoAPI_Cut(face, prism).Shape()


def test_only_the_part_inside_the_trim_is_measured(tmp_path):
    """The sheet cut to the triangle x + y <= 20: the knot line u = 0.7 (at x = X) is
    sampled on its part y <= 20 - X only (the points, checked in space against the cut,
    reach it), and its curvature jump, growing with y, is below the whole face's."""
    from gshade.analysis.knot_lines import trimmed_along
    from gshade.cad import read_cad

    cad_parts = _ocp()
    cut = cad_parts.write_shape(_triangle_cut(_face(_sheet())), tmp_path / "cut.brep")
    whole = cad_parts.write_shape(_face(_sheet()), tmp_path / "whole.brep")
    (face,) = read_cad(cut).faces
    assert face.trimmed
    t = trimmed_along(face, "u", 0.7, *face.box[1], 32)
    points = face.patch(np.full(32, 0.7), t)
    x_plus_y = points[:, 0] + points[:, 1]
    assert x_plus_y.max() <= 20.0 + 1e-6
    assert x_plus_y.max() > 20.0 - 0.2  # up to the trim (1/512 of the line a cell)
    assert np.all(np.diff(t) > 0)
    trimmed, full = _knot_lines(cut)[0.7], _knot_lines(whole)[0.7]
    assert trimmed.cls == full.cls == "G1"
    # the line is inside for y <= 20 - 11.8 (v <= 0.41): about half the whole line's jump
    assert trimmed.curvature_jump < 0.6 * full.curvature_jump


def test_tolerances_class_knot_lines_like_junctions():
    """The class follows the tolerances as for patch boundaries: a G2 tolerance above the
    jump makes the C1 line G2."""
    left, right = profile_curvatures()
    loose = Tolerances(g0=1e-9, g2=2 * abs(left - right), g3=1e9)
    (junction,) = continuity_report([profile_cylinder()], tolerances=loose)
    assert junction.cls == "G3"
    strict_g3 = Tolerances(g0=1e-9, g2=2 * abs(left - right))
    (junction,) = continuity_report([profile_cylinder()], tolerances=strict_g3)
    assert junction.cls == "G2"
