"""Bad input raises a GshadeError (a ValueError) that says what was expected and given."""

import numpy as np
import pytest

from gshade import GshadeError
from gshade.errors import ParameterDomainError
from gshade.geometry import BezierCurve, BezierPatch, BSplineCurve, BSplinePatch, unit_normal

from .support.paths import ROOT

NET = np.zeros((4, 4, 3))
U4 = [0, 0, 0, 0, 1, 1, 1, 1]


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: BezierPatch(np.zeros((4, 4))), r"expected shape \(m\+1, n\+1, 3\).*got \(4, 4\)"),
        (lambda: BezierPatch(np.zeros((1, 4, 3))), "at least 2 control points"),
        (lambda: BezierPatch([[["a"]]]), "expected an array of numbers"),
        (lambda: BezierPatch(np.full((2, 2, 3), np.nan)), "finite"),
        (lambda: BezierPatch(NET, weights=np.ones((4, 3))), r"weights: expected shape \(4, 4\)"),
        (lambda: BezierPatch(NET, weights=-np.ones((4, 4))), "positive finite numbers, got -1.0"),
        (lambda: BezierPatch(NET, weights=np.zeros((4, 4))), "positive"),
        (lambda: BezierPatch(NET, domain=((1, 0), (0, 1))), "start < end"),
        (lambda: BSplinePatch(NET, (3, 3), (U4[:-1], U4)), "expected 8 knots .* got 7"),
        (
            lambda: BSplinePatch(NET, (3, 3), (U4, [0, 0, 0, 1, 0.5, 1, 1, 1])),
            r"knots_v: expected a non-decreasing sequence, but knot 4 \(0.5\) < knot 3 \(1.0\)",
        ),
        (
            lambda: BSplinePatch(NET, (0, 3), ([0, 0, 1, 1, 1], U4)),
            "degree: expected an integer >= 1, got 0",
        ),
        (lambda: BSplinePatch(NET, (3, 3), ([0, 0, 0, 0, 0, 1, 1, 1], U4)), "multiplicities"),
        (lambda: BSplinePatch(NET, (3, 3), ([0, 0, 0, 1, 1, 1, 1, 2], U4)), "domain .* is empty"),
        (lambda: BSplinePatch(NET, 3, U4), "pairs"),
        (
            lambda: BSplineCurve(np.zeros((3, 3)), 3, [0] * 4 + [1] * 3),
            "needs at least 4 control points",
        ),
        (lambda: BezierCurve(np.zeros((3, 4))), "expected shape"),
    ],
)
def test_construction_errors(make, message):
    with pytest.raises(GshadeError, match=message) as info:
        make()
    assert isinstance(info.value, ValueError)


def test_parameters_outside_the_domain():
    patch = BSplinePatch(NET, (3, 3), (U4, U4))
    with pytest.raises(
        ParameterDomainError,
        match=r"u: expected values in the parameter domain \[0.0, 1.0\], got 1.5",
    ):
        patch.derivatives([0.5, 1.5], 0.5)
    with pytest.raises(ParameterDomainError, match="v:"):
        patch(0.5, np.nan)
    with pytest.raises(ParameterDomainError):
        BezierCurve(np.zeros((3, 2)))(-0.1)
    # round-off outside the domain is clamped, not an error
    assert np.all(np.isfinite(patch(1 + 1e-15, -1e-15)))


def test_bad_order_and_shapes():
    patch = BezierPatch(NET)
    with pytest.raises(GshadeError, match="order: expected an integer >= 0, got -1"):
        patch.derivatives(0.5, 0.5, -1)
    with pytest.raises(GshadeError, match="broadcast"):
        patch.derivatives(np.zeros(3), np.zeros(4))
    with pytest.raises(GshadeError, match="needs derivatives of order 1"):
        unit_normal(patch.derivatives(0.5, 0.5, 0))


def test_knot_insertion_errors():
    patch = BSplinePatch(NET, (3, 3), (U4, U4))
    with pytest.raises(GshadeError, match="direction"):
        patch.insert_knot("w", 0.5)
    with pytest.raises(ParameterDomainError, match="knot"):
        patch.insert_knot("u", 2.0)
    with pytest.raises(GshadeError, match="multiplicity 4"):
        patch.insert_knot("u", 0.0)


def test_library_errors_name_parameters_and_the_cli_its_flags(capsys):
    """The library speaks of its parameters (samples, workers, scheduler); only the command
    line turns them into its flags (--samples, -j, --scheduler)."""
    from gshade.analysis.continuity import continuity_report
    from gshade.app.batch import parse_sweeps, validate_batch_options
    from gshade.app.cli import main
    from gshade.geometry import sphere
    from gshade.regression.comparison import Thresholds
    from gshade.scene import load_scene, parse_overrides

    teapot = str(ROOT / "scenes" / "teapot-isophotes.toml")
    for call, library in [
        (lambda: continuity_report([sphere(1.0)], samples=0), "samples: expected 1 to"),
        (lambda: validate_batch_options(0, 10.0), "workers: expected at least 1"),
        (lambda: validate_batch_options(1, 10.0, "ftp://x"), "scheduler: expected a tcp://"),
        (lambda: parse_overrides(["shape.period"]), "override shape.period: expected key="),
        (lambda: load_scene(teapot, {"shape.x": 1}), f"{teapot}: override shape.x: unknown"),
        (lambda: parse_sweeps(["shape.function"]), "sweep 'shape.function': expected key="),
        (lambda: Thresholds(fail=-1.0), "fail: expected a finite number >= 0"),
    ]:
        with pytest.raises(GshadeError) as info:
            call()
        assert str(info.value).startswith(library) and "--" not in str(info.value)
    for argv, flag, status in [
        (["continuity", teapot, "--samples", "0"], "--samples: expected 1 to", 2),
        (["batch", teapot, "-o", "/tmp/never-made", "-j", "0"], "-j: expected", 2),
        (["info", teapot, "--set", "shape.period"], "--set shape.period: expected key=", 2),
        (["info", teapot, "--set", "shape.x=1"], f"{teapot}: --set shape.x: unknown", 2),
        (["batch", teapot, "-o", "/tmp/never-made", "--sweep", "x"], "--sweep 'x': expected", 2),
        (["compare", teapot, teapot, "--fail", "-1"], "--fail: expected a finite number", 5),
    ]:
        assert main(argv) == status
        assert capsys.readouterr().err.startswith(f"gshade: error: {flag}")
