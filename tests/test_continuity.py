"""Junction measures and classes on constructed G0, G1, G2 and G3 pairs."""

import json
import subprocess
import sys

import numpy as np
import pytest

from gshade.continuity import continuity_report
from gshade.geometry import BezierPatch, BSplinePatch
from gshade.io import read_newell

from .conftest import ROOT, TEAPOT


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
    from gshade.continuity import Tolerances

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
            "gshade.cli",
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
        ("0:u1,2:u0", "gshade: error: pair 0:u1,2:u0: the boundaries do not match"),
        ("0-u1", "gshade: error: --pair: expected I:SIDE,J:SIDE"),
    ]:
        result = subprocess.run(
            [sys.executable, "-m", "gshade.cli", "continuity", scene, "--pair", pair],
            capture_output=True,
            text=True,
        )
        assert result.returncode == 2
        assert result.stderr.startswith(message) and result.stderr.count("\n") == 1
    result = subprocess.run(
        [sys.executable, "-m", "gshade.cli", "continuity", scene, "--pair", "0:u1,1:u0"],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0 and "1 junctions: 1 G1" in result.stdout
