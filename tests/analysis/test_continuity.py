"""Junction measures and classes on constructed G0, G1, G2 and G3 pairs."""

import json
import subprocess
import sys

import numpy as np
import pytest

from gshade.analysis.continuity import continuity_report
from gshade.geometry import BezierPatch, BSplineCurve, BSplinePatch
from gshade.io import read_newell

from ..support.paths import ROOT, TEAPOT


def sheet(degree: int) -> tuple[BezierPatch, BezierPatch]:
    """Two Bézier patches split from one B-spline sheet of the given degree in u: a
    C^(degree-1) junction at u = 1/2 (G2 for cubics, G3 for quartics)."""
    nu = degree + 2
    x = np.linspace(0.0, 4.0, nu)
    y = np.linspace(0.0, 3.0, 4)
    P = np.zeros((nu, 4, 3))
    P[..., 0] = x[:, None]
    P[..., 1] = y[None, :]
    P[..., 2] = 0.5 * np.sin(0.9 * x[:, None] + 0.3) * np.cos(0.7 * y[None, :] - 0.8)
    U = [0.0] * (degree + 1) + [0.5] + [1.0] * (degree + 1)
    spline = BSplinePatch(P, (degree, 3), (U, [0, 0, 0, 0, 1, 1, 1, 1]))
    (a,), (b,) = spline.bezier_patches()
    return a, b


def moved(patch: BezierPatch, row: int, dz: float) -> BezierPatch:
    P = patch.points.copy()
    P[row, :, 2] += dz
    return BezierPatch(P, domain=patch.domain)


def pairs():
    a, b = sheet(3)
    a4, b4 = sheet(4)
    return {
        "G0": (a, moved(b, 1, 0.4)),  # the first row off the edge: tangents change
        "G1": (a, moved(b, 2, 0.6)),  # the second row: C1, curvature jumps
        "G2": (a, b),  # C2 cubics
        "G3": (a4, b4),  # C3 quartics
    }


@pytest.mark.parametrize("expected", ["G0", "G1", "G2", "G3"])
def test_constructed_pairs_are_classified_as_constructed(expected):
    a, b = pairs()[expected]
    (junction,) = continuity_report([a, b])
    assert junction.cls == expected
    assert junction.patches == (0, 1) and junction.sides == ("u1", "u0")
    assert junction.gap < 1e-12


@pytest.mark.parametrize("expected", ["G0", "G1", "G2", "G3"])
def test_classes_survive_reversal_and_degree_elevation(expected):
    a, b = pairs()[expected]
    reversed_b = BezierPatch(b.points[::-1, ::-1], domain=b.domain)  # both directions flipped
    (junction,) = continuity_report([a, reversed_b])
    assert junction.cls == expected and junction.sides == ("u1", "u1")
    m, n = b.degree
    elevated = b.elevated((m + 1, n + 2))
    (junction,) = continuity_report([elevated, a])
    assert junction.cls == expected


def test_the_g0_tolerance_decides_what_is_a_junction():
    from gshade.analysis.continuity import Tolerances

    a, b = pairs()["G2"]
    lifted = BezierPatch(b.points + np.array([0, 0, 1e-4]), domain=b.domain)
    assert continuity_report([a, lifted]) == []  # a 1e-4 gap is no junction by default
    loose = Tolerances.for_size(5.0, g0=1e-3)
    (junction,) = continuity_report([a, lifted], tolerances=loose)
    assert junction.gap == pytest.approx(1e-4) and junction.cls in ("G2", "G3")


def test_teapot_report_and_cli_json():
    report = continuity_report(read_newell(TEAPOT))
    assert len(report) == 52
    assert {j.cls for j in report} <= {"G1", "G2"}
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "gshade.app.cli",
            "continuity",
            str(ROOT / "scenes" / "junctions-mean.toml"),
            "--json",
        ],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    classes = [j["class"] for j in data["junctions"]]
    assert classes == ["G1", "G2"]
    assert set(data["junctions"][0]) >= {
        "patches",
        "class",
        "gap",
        "normal_angle_deg",
        "curvature_jump",
        "curvature_gradient_jump",
        "samples",
    }


def test_explicit_pairs_are_measured_and_mismatched_ones_named():
    from gshade import GshadeError

    a, b = pairs()["G1"]
    c = BezierPatch(b.points + np.array([0.0, 0.0, 0.3]), domain=b.domain)  # lifted off
    (junction,) = continuity_report([a, b, c], pairs=[(1, "u0", 0, "u1")])
    assert junction.cls == "G1" and junction.patches == (1, 0) and not junction.reversed
    reversed_b = BezierPatch(b.points[::-1, ::-1], domain=b.domain)
    (junction,) = continuity_report([a, reversed_b], pairs=[(0, "u1", 1, "u1")])
    assert junction.cls == "G1" and junction.reversed
    for pair, message in [
        ((0, "u1", 2, "u0"), r"pair 0:u1,2:u0: the boundaries do not match: they are 0.3 apart"),
        ((0, "u1", 1, "v0"), "the boundaries do not match"),
        ((0, "u1", 5, "u0"), "patch 5: expected a patch index from 0 to 2"),
        ((0, "w1", 1, "u0"), "side 'w1': expected one of u0, u1, v0, v1"),
        ((1, "u0", 1, "u1"), "expected two different patches"),
    ]:
        with pytest.raises(GshadeError, match=message):
            continuity_report([a, b, c], pairs=[pair])


def test_cli_pair_errors_exit_2_with_one_line():
    scene = str(ROOT / "scenes" / "junctions-mean.toml")
    for pair, message in [
        ("0:u1,2:u0", f"gshade: error: {scene}: pair 0:u1,2:u0: the boundaries do not match"),
        ("0-u1", "gshade: error: --pair: expected I:SIDE,J:SIDE"),
    ]:
        result = subprocess.run(
            [sys.executable, "-m", "gshade", "continuity", scene, "--pair", pair],
            capture_output=True,
            text=True,
        )
        assert result.returncode == 2
        assert result.stderr.startswith(message) and result.stderr.count("\n") == 1
    result = subprocess.run(
        [sys.executable, "-m", "gshade", "continuity", scene, "--pair", "0:u1,1:u0"],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0 and "1 junctions: 1 G1" in result.stdout


def brute_force_junctions(patches, tolerance, probes=5):
    """The former O(S^2) search, kept as the oracle for the k-d tree search."""
    from gshade.analysis.continuity import SIDES, _side_points

    t = np.linspace(0.0, 1.0, probes)
    sides = []
    for i, patch in enumerate(patches):
        for side in SIDES:
            pts = _side_points(patch, side, t)
            if np.ptp(pts, axis=0).max() > tolerance:
                sides.append((i, side, pts))
    found = []
    for a, (i, si, pa) in enumerate(sides):
        for j, sj, pb in sides[a + 1 :]:
            if i == j:
                continue
            if np.abs(pa - pb).max() <= tolerance:
                found.append((i, si, j, sj, False))
            elif np.abs(pa - pb[::-1]).max() <= tolerance:
                found.append((i, si, j, sj, True))
    return found


def scene_patch_sets():
    from gshade.scene import load_scene

    seen = {}
    for path in sorted((ROOT / "scenes").glob("*.toml")):
        scene = load_scene(path)
        patches = list(scene.patches)
        key = tuple(s.source for s in scene.surfaces)
        seen.setdefault(key, (path.stem, patches))
    return list(seen.values())


@pytest.mark.slow
def test_the_kd_tree_search_finds_what_the_brute_force_search_finds():
    from gshade.analysis.continuity import find_junctions

    cases = [("teapot", read_newell(TEAPOT)), *scene_patch_sets()]
    a, b = pairs()["G2"]
    cases.append(("pair", [a, BezierPatch(b.points[::-1, ::-1], domain=b.domain)]))
    for name, patches in cases:
        pts = np.concatenate([p(*p.parameter_grid(9, 9)).reshape(-1, 3) for p in patches])
        for tol in (1e-7 * np.linalg.norm(np.ptp(pts, axis=0)), 1e-3):
            assert find_junctions(patches, tol) == brute_force_junctions(patches, tol), name
    assert len(find_junctions(read_newell(TEAPOT), 1e-9)) == 52


def fan(count: int) -> list[BezierPatch]:
    """Bilinear patches whose u0 sides all cross at their middle (the origin) but do not
    coincide: more boundaries meet at a middle point than the k-d tree query returns."""
    out, up = [], np.array([0.0, 0.0, 1.0])
    for angle in np.linspace(0.0, np.pi, count, endpoint=False):
        d = np.array([np.cos(angle), np.sin(angle), 0.0])
        out.append(BezierPatch(np.array([[-d, d], [up - d, up + d]])))
    return out


def test_boundaries_crossing_at_their_middle_are_not_junctions():
    from gshade.analysis.continuity import find_junctions

    patches = fan(12)
    u0 = patches[3].points[0]
    patches.append(BezierPatch(np.stack([u0, u0 - [0, 0, 1]])))  # shares patch 3's u0 side
    expected = brute_force_junctions(patches, 1e-9)
    assert expected == [(3, "u0", 12, "u0", False)]
    assert find_junctions(patches, 1e-9) == expected
    assert find_junctions(fan(40), 1e-9) == []


def test_duplicated_surfaces_are_refused_with_one_line(tmp_path):
    from gshade import GshadeError
    from gshade.analysis.continuity import find_junctions

    a, _ = pairs()["G2"]
    assert len(find_junctions([a] * 9, 1e-9)) == 4 * 36  # each side: 8 partners
    with pytest.raises(GshadeError, match=r"^patch 0 side u0: .* with 9 other boundaries"):
        find_junctions([a] * 10, 1e-9)
    scene = tmp_path / "spheres.toml"
    scene.write_text('[[surface]]\ntype = "sphere"\n' * 300)
    result = subprocess.run(
        [sys.executable, "-m", "gshade", "continuity", str(scene)],
        capture_output=True,
        text=True,
        timeout=300,  # a hang guard
    )
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert result.stderr.startswith(
        f"gshade: error: {scene}: patch 0 side v0: its boundary coincides with 598 other"
    )


def test_samples_and_pairs_are_bounded():
    from gshade import GshadeError

    a, b = pairs()["G2"]
    (junction,) = continuity_report([a, b], samples=4096)
    assert junction.samples == 4096
    with pytest.raises(GshadeError, match="samples: expected 1 to 4096, got 4097"):
        continuity_report([a, b], samples=4097)
    with pytest.raises(GshadeError, match="pairs: expected at most 10000 pairs, got 10001"):
        continuity_report([a, b], pairs=[(0, "u1", 1, "u0")] * 10001)


@pytest.mark.slow
def test_batched_measures_equal_the_per_junction_oracle():
    """measure_all (each patch evaluated once for all its sides) against measure, junction
    by junction: the teapot, the scenes' surfaces, the subdivision cube, and a pair at two
    scales (its small patches take the per-side path: below the batch's irregular limit)."""
    from gshade.analysis.continuity import (
        Tolerances,
        classify,
        find_junctions,
        measure,
        measure_all,
    )
    from gshade.analysis.junction_measures import MEASURES
    from gshade.geometry.subdivision.stam import subdivision_patches
    from gshade.io.obj import read_obj_mesh

    mesh = read_obj_mesh(ROOT / "scenes" / "data" / "cube.obj")
    a, b = pairs()["G1"]
    scaled = [BezierPatch(p.points * s, domain=p.domain) for s in (1e-6, 1e3) for p in (a, b)]
    cases = [
        ("teapot", read_newell(TEAPOT)),
        *scene_patch_sets(),
        ("cube", subdivision_patches(mesh.vertices, mesh.faces, levels=2)),
        ("scaled", scaled),
    ]
    total = 0
    for name, patches in cases:
        pts = np.concatenate([p(*p.parameter_grid(9, 9)).reshape(-1, 3) for p in patches])
        diag = float(np.linalg.norm(np.ptp(pts, axis=0)))
        tol = Tolerances.for_size(diag)
        junctions = find_junctions(patches, max(tol.g0, 1e-12 * diag))
        batched = measure_all(patches, junctions, samples=16)
        for junction, got in zip(junctions, batched, strict=True):
            expected = measure(patches, junction, samples=16)
            for key in MEASURES:  # the four measures (round_off and max_at beside them)
                assert got[key] == pytest.approx(expected[key], rel=1e-12, abs=0.0), (
                    name,
                    junction,
                    key,
                )
            assert classify(got, tol) == classify(expected, tol), (name, junction)
        total += len(junctions)
    assert total > 1000


@pytest.mark.parametrize(("major", "minor"), [(3.0, 1.0), (3.0, 0.5), (5.0, 4.0)])
def test_measures_of_a_torus_meeting_its_tangent_plane_match_closed_forms(major, minor):
    """The torus's top circle (tube angle phi = pi/2) joins the plane z = r tangentially: G1.
    There k = 1/r across the junction and 0 along it on the torus, 0 on the plane, so the
    curvature jump is 1/r; |grad K| = 1/(r^2 R) and |grad H| = 1/(2 r R) on the torus
    (K = cos phi / (r (R + r cos phi)), do Carmo §3-3), 0 on the plane: the gradient jump
    is the larger one (grad K for r < 2, grad H for r = 4, R = 5)."""
    from gshade.geometry import revolve

    s = np.sqrt(0.5)
    R, r = major, minor
    quarter = BSplineCurve([[R + r, 0.0], [R + r, r], [R, r]], 2, [0, 0, 0, 1, 1, 1], [1, s, 1])
    annulus = BSplineCurve([[R, r], [R - 0.8 * r, r]], 1, [0, 0, 1, 1])
    report = continuity_report([revolve(quarter), revolve(annulus)], pairs=[(0, "u1", 1, "u0")])
    (junction,) = report
    assert junction.gap < 1e-12 and junction.normal_angle_deg < 1e-9
    assert junction.curvature_jump == pytest.approx(1 / r, rel=1e-12)
    expected = max(1 / (r * r * R), 1 / (2 * r * R))
    assert junction.curvature_gradient_jump == pytest.approx(expected, rel=1e-12)
    assert junction.cls == "G1"
