"""Patches joined with prescribed continuity are classified as constructed."""

import numpy as np
import pytest

from gshade import GshadeError
from gshade.analysis.continuity import continuity_report
from gshade.geometry import BezierPatch
from gshade.geometry.splines.junctions import junction_patch

CONNECTIONS = [
    {},
    {"alpha": 0.2, "beta": 1.5, "gamma": 0.1, "delta": -0.3, "epsilon": 0.05, "zeta": 0.2},
]


def base(seed=2, degree=(3, 3)):
    m, n = degree
    P = np.zeros((m + 1, n + 1, 3))
    P[..., 0] = np.linspace(0, 3, m + 1)[:, None]
    P[..., 1] = np.linspace(0, 3, n + 1)[None, :]
    P[..., 2] = np.random.default_rng(seed).normal(scale=0.3, size=(m + 1, n + 1))
    return BezierPatch(P)


@pytest.mark.parametrize("continuity", ["G0", "G1", "G2", "G3"])
@pytest.mark.parametrize("connection", CONNECTIONS)
def test_constructed_junctions_have_their_class(continuity, connection):
    p = base()
    q = junction_patch(p, continuity, **connection)
    (junction,) = continuity_report([p, q])
    assert junction.cls == continuity and junction.sides == ("v1", "v0")
    # also with the new patch reversed and degree-elevated
    flipped = BezierPatch(q.points[::-1, ::-1])
    (junction,) = continuity_report([flipped.elevated((4, 5)), p])
    assert junction.cls == continuity


def test_bad_junction_input():
    with pytest.raises(GshadeError, match="continuity: expected one of G0, G1, G2, G3"):
        junction_patch(base(), "C2")
    with pytest.raises(GshadeError, match="beta: expected a number > 0"):
        junction_patch(base(), "G1", beta=0.0)
    with pytest.raises(GshadeError, match="degree in v to be at least 3"):
        junction_patch(base(degree=(3, 2)), "G2")


@pytest.mark.parametrize("continuity", ["G0", "G1", "G2", "G3"])
def test_junction_scenes_show_their_class(continuity):
    from gshade.scene import load_scene

    from ...support.paths import ROOT

    scene = load_scene(ROOT / "scenes" / f"junction-{continuity.lower()}.toml")
    (junction,) = continuity_report(list(scene.patches))
    assert junction.cls == continuity
