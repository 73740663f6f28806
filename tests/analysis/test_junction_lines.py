"""Junction lines drawn over the picture: where, how wide, which colour, and nothing else."""

import json

import numpy as np
import pytest

import gshade
from gshade.analysis.continuity import Junction
from gshade.analysis.junction_lines import CLASS_COLOURS, draw_junctions

from ..support.paths import ROOT


def junction(cls, a=0, b=1, sides=("u1", "u0")):
    return Junction((a, b), sides, False, cls, 0.0, 0.0, 0.0, 0.0, 8)


def two_patches(width=64, height=32, split=32.0):
    """A flat picture of two patches side by side: patch 0 has u = x / split on the left
    (its edge u = 1 at x = split), patch 1 has u = (x - split) / split on the right."""
    x = np.arange(width) + 0.5
    X = np.broadcast_to(x, (height, width))
    left = X < split
    u = np.where(left, X / split, (X - split) / split)
    v = np.broadcast_to(((np.arange(height) + 0.5) / height)[:, None], (height, width))
    channels = {
        "R": np.full((height, width), 0.5, np.float32),
        "G": np.full((height, width), 0.5, np.float32),
        "B": np.full((height, width), 0.5, np.float32),
        "A": np.ones((height, width), np.float32),
        "f": np.random.default_rng(0).random((height, width)).astype(np.float32),
        "u": u.astype(np.float32),
        "v": v.astype(np.float32),
        "patch": np.where(left, 0.0, 1.0).astype(np.float32),
    }
    return channels, [((0.0, 1.0), (0.0, 1.0))] * 2


@pytest.mark.parametrize("cls", ["G0", "G1", "G2", "G3"])
def test_line_lies_on_the_edge_with_its_width_and_class_colour(cls):
    channels, domains = two_patches()
    out = draw_junctions(channels, [junction(cls)], domains, width=2.0)
    rgb = np.stack([out[c] for c in "RGB"], -1)
    row = rgb[10]
    # the two pixels next to the edge (x = 31.5 and 32.5: half a pixel away) are fully
    # covered, the next ones (1.5 px away) not at all: a line 2 px wide
    np.testing.assert_allclose(row[31], CLASS_COLOURS[cls], atol=1e-6)
    np.testing.assert_allclose(row[32], CLASS_COLOURS[cls], atol=1e-6)
    np.testing.assert_allclose(row[:31], 0.5)
    np.testing.assert_allclose(row[33:], 0.5)
    for name in ("A", "f", "u", "v", "patch"):  # the data stay exact
        np.testing.assert_array_equal(out[name], channels[name])


def test_line_width_is_anti_aliased_in_between():
    channels, domains = two_patches()
    out = draw_junctions(channels, [junction("G1")], domains, width=1.0)
    # half a pixel per side: the pixel centres, half a pixel from the edge, are half covered
    expected = 0.5 * 0.5 + 0.5 * np.asarray(CLASS_COLOURS["G1"])
    np.testing.assert_allclose([out[c][5, 31] for c in "RGB"], expected, atol=1e-6)


def test_hidden_side_and_uninvolved_edges_draw_nothing():
    channels, domains = two_patches()
    channels["patch"][:, 20:40] = -1.0  # something else in front of the junction
    channels["A"][:, 20:40] = 0.0
    out = draw_junctions(channels, [junction("G0")], domains)
    for c in "RGB":
        np.testing.assert_array_equal(out[c], channels[c])
    # a junction along the v edges of these patches is not in the picture's columns
    channels, domains = two_patches()
    out = draw_junctions(channels, [junction("G2", sides=("v1", "v0"))], domains)
    assert np.abs(out["R"][2:-2] - 0.5).max() == 0.0


def test_render_with_junctions_marks_only_the_junction(tmp_path):
    scene = ROOT / "scenes" / "junctions-isophotes.toml"
    size = {"width": 160, "height": 100, "spp": 1, "lighting": "flat"}
    plain = gshade.render(scene, **size)
    drawn = gshade.render(scene, **size, junctions=True)
    for name in ("A", "f", "P.X", "N.Z", "u", "v", "patch"):
        np.testing.assert_array_equal(drawn[name], plain[name])
    meta = json.loads(drawn.metadata["junctions"])
    classes = sorted(j["class"] for j in meta["junctions"])
    assert classes == ["G1", "G2"]  # the G1 pair and the G2 pair
    changed = np.abs(drawn.rgb - plain.rgb).max(-1) > 1e-6
    assert 0 < changed.sum() < 0.05 * changed.size
    # every changed pixel is within 2 px of where the picture passes from one patch of a
    # pair to the other
    patch = plain["patch"]
    seam = np.zeros_like(changed)
    for a, b in ((0, 1), (2, 3)):
        right = (patch[:, :-1] == a) & (patch[:, 1:] == b) | (patch[:, :-1] == b) & (
            patch[:, 1:] == a
        )
        seam[:, :-1] |= right
        seam[:, 1:] |= right
    near = seam.copy()
    for dy in range(-2, 3):
        for dx in range(-2, 3):
            near |= np.roll(seam, (dy, dx), axis=(0, 1))
    assert not (changed & ~near).any()


def test_junctions_key_must_be_a_boolean(tmp_path):
    text = (ROOT / "scenes" / "junction-g1.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("[render]", '[render]\njunctions = "yes"'))
    with pytest.raises(gshade.GshadeError, match=r"\[render\] junctions: expected true or false"):
        gshade.load_scene(bad)


def _polyline_distance(uv, inverse, curve):
    """Brute force: each pixel's (uv (n, 2)) least pixel distance J^-1 (c - uv) to any
    segment of ``curve``."""
    A = (curve[None, :-1] - uv[:, None]) @ inverse.T  # (n, segments, 2)
    AB = (curve[1:] - curve[:-1]) @ inverse.T
    t = np.clip(-np.einsum("nsk,sk->ns", A, AB) / np.sum(AB * AB, -1), 0.0, 1.0)
    return np.linalg.norm(A + t[..., None] * AB, axis=-1).min(axis=1)


@pytest.mark.parametrize("seed, points", [(0, 6), (1, 6), (2, 6), (0, 200)])
def test_a_brep_edge_covers_the_pixels_within_half_its_width_of_its_curve(seed, points):
    """A B-rep edge's line over a sheared, stretched face, its curve a polyline of few
    points (segments of several pixels) or many: every pixel's coverage is what its brute-force
    pixel distance to the polyline gives (clip(width / 2 + 1/2 - d, 0, 1)), also midway
    along the long segments, where no curve point is near."""
    from gshade.analysis.edge_continuity import EdgeLine

    rng = np.random.default_rng(seed)
    H, W = 40, 56
    rows, cols = np.mgrid[0:H, 0:W] + 0.5
    J = np.array([[0.02, 0.006], [-0.004, 0.03]]) * (1 + 0.3 * rng.random((2, 2)))
    u = 0.1 + J[0, 0] * cols + J[0, 1] * rows
    v = 0.2 + J[1, 0] * cols + J[1, 1] * rows
    channels, _ = two_patches(W, H)
    channels.update(u=u.astype(np.float32), v=v.astype(np.float32))
    channels["patch"] = np.zeros((H, W), np.float32)
    t = np.linspace(0.0, 1.0, points)
    curve = np.stack([0.35 + 0.5 * t, 0.6 + 0.3 * np.sin(2 * t + seed)], -1)
    out = draw_junctions(
        channels, [], [((0.0, 2.0), (0.0, 2.0))], edges=[EdgeLine("G2", [(0, curve)])]
    )
    # the line's colour mixed into grey 0.5: coverage from the green channel
    coverage = (out["G"] - 0.5) / (CLASS_COLOURS["G2"][1] - 0.5)
    inverse = np.linalg.inv(J)
    uv = np.stack([u.ravel(), v.ravel()], -1)
    expected = _polyline_distance(uv, inverse, curve).reshape(H, W)
    expected = np.clip(1.5 - expected, 0.0, 1.0)
    assert (expected > 0).sum() > 60  # the line crosses the face
    np.testing.assert_allclose(coverage, expected, atol=2e-3)
