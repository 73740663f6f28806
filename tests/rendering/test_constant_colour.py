"""A constant value is one colour: a plane under isophotes is one stripe colour, however
its value falls against the stripes (issue: planes that never speckle).

Two rules, tested on their own and on kernel-made boxes (axis-aligned, rotated, offset by
1000 units) rendered with the automatic period and with periods that put a face's value
exactly on a stripe edge:

- the renderer settles a stripe coordinate known only to single precision onto the edge it
  lies within noise of, with a zero footprint (gshade.display.colour.settled_on_edges);
- the automatic period keeps constant values away from the edges
  (gshade.rendering.style.period_off_edges).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gshade.app.cli import main
from gshade.display.colour import coverage_formula, settled_on_edges
from gshade.io.image import read_exr
from gshade.rendering.atlas import Atlas
from gshade.rendering.style import EDGE_MARGIN, PERIOD_NUDGE, constant_values, period_off_edges
from gshade.scene.load import CAD_LIGHT


def test_values_within_noise_of_an_edge_are_settled_on_it():
    s = np.array([10.0 - 3e-7, 10.0, 10.0 + 4e-7, 10.5 + 2e-6, 10.5 - 5e-7, 10.25, 10.001])
    a = np.array([1e-9, 0.0, 2e-10, 0.0, 1e-8, 0.0, 0.0])
    settled, a2, b2 = settled_on_edges(s, a, np.zeros_like(a), 0.5)
    assert settled.tolist() == [10.0, 10.0, 10.0, 10.5, 10.5, 10.25, 10.001]
    assert a2.tolist() == [0.0] * 5 + [0.0, 0.0] and not b2.any()
    cov = coverage_formula(settled, a2, b2, 0.5)
    assert len(set(cov[:3].tolist())) == 1 and len(set(cov[3:5].tolist())) == 1


def test_a_footprint_wider_than_the_noise_is_filtered_as_it_is():
    s = np.array([10.0 + 1e-7, 10.0 - 1e-7])
    a = np.full(2, 0.01)
    settled, a2, _ = settled_on_edges(s, a, np.zeros(2), 0.5)
    assert (settled == s).all() and (a2 == a).all()
    assert np.allclose(coverage_formula(settled, a2, 0.0 * a2, 0.5), 0.5, atol=1e-4)


@settings(max_examples=200, deadline=None)
@given(
    edge=st.integers(-1000, 1000),
    fall=st.booleans(),
    duty=st.sampled_from([0.25, 0.375, 0.5, 0.7]),
    noise=st.lists(st.floats(-1.0, 1.0), min_size=2, max_size=8),
)
def test_noise_at_an_edge_gives_one_colour(edge, fall, duty, noise):
    """Single-precision noise (a few ulps) around an edge: one colour for all."""
    centre = edge + (duty if fall else 0.0)
    ulp = max(abs(centre), 1.0) * 2.0**-23
    s = centre + np.array(noise) * 4 * ulp
    footprint = np.abs(np.array(noise)) * ulp
    settled, a, b = settled_on_edges(s, footprint, 0.0 * footprint, duty)
    assert len(set(coverage_formula(settled, a, b, duty).tolist())) == 1


def test_constant_values_are_those_of_whole_tiles():
    """A tile whose valid texels all hold one value (a plane) gives it; a tile constant
    along one parameter only (a cylinder's isophotes) does not; invalid texels (outside a
    trim) do not count."""
    f = np.zeros((8, 16), np.float32)
    f[:, :8] = 0.25  # tile 0: a plane
    f[:, 8:] = np.linspace(0.0, 1.0, 8)[None, :]  # tile 1: constant along columns only
    valid = np.ones(f.shape, bool)
    tiles = Atlas.for_patches(2, 8).all_tile_slices()
    assert constant_values(f, valid, tiles).tolist() == [0.25]
    f[0, 0] = 7.0  # a texel outside the trim of tile 0
    assert constant_values(f, valid, tiles).size == 0
    valid[0, 0] = False
    assert constant_values(f, valid, tiles).tolist() == [0.25]
    # tiles of two sizes: a constant 8 x 8 tile beside a varying 16 x 16 one
    atlas = Atlas.for_tiles([8, 16])
    g = np.zeros((atlas.height, atlas.width), np.float32)
    rows, cols = atlas.tile_slices(1)
    g[rows, cols] = np.linspace(0.0, 1.0, 16)[None, :]
    g[atlas.tile_slices(0)] = -3.0
    both = np.ones(g.shape, bool)
    assert constant_values(g, both, atlas.all_tile_slices()).tolist() == [-3.0]


@settings(max_examples=200, deadline=None)
@given(
    period=st.floats(1e-3, 10.0),
    stripes=st.lists(st.floats(0.01, 20.0), min_size=1, max_size=3),
    phase=st.floats(0.0, 1.0),
)
def test_the_automatic_period_keeps_constant_values_off_the_edges(period, stripes, phase):
    """Up to three constant regions, anywhere (but 0, which no period moves): a period
    within 20 % keeps them all at least a tenth of a period from every edge (one region of
    a period or more always; more, when such a period exists; else the best found)."""
    values = np.array(stripes) * period
    chosen = period_off_edges(period, values, phase, 0.5)
    assert abs(chosen / period - 1.0) <= PERIOD_NUDGE + 1e-12
    s = values / chosen + phase
    t = np.mod(s, 1.0)
    margin = np.minimum.reduce([t, np.abs(t - 0.5), 1.0 - t]).min()
    if len(stripes) == 1 and stripes[0] >= 1:  # (less than a period: it moves too little)
        assert margin >= EDGE_MARGIN - 1e-9
    unchanged = np.mod(values / period + phase, 1.0)
    if np.minimum.reduce([unchanged, np.abs(unchanged - 0.5), 1.0 - unchanged]).min() >= 0.1:
        assert chosen == period  # nothing to move: the picture is the same


@pytest.fixture(scope="module")
def boxes(tmp_path_factory):
    """A 30 x 20 x 10 box from the kernel: axis-aligned, rotated, and offset by 1000."""
    pytest.importorskip("OCP")
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.gp import gp_Ax1, gp_Dir, gp_Pnt, gp_Trsf, gp_Vec

    from ..support.cad_parts import write_shape

    folder = tmp_path_factory.mktemp("boxes")
    box = BRepPrimAPI_MakeBox(30.0, 20.0, 10.0).Shape()
    turn, shift = gp_Trsf(), gp_Trsf()
    turn.SetRotation(gp_Ax1(gp_Pnt(0, 0, 0), gp_Dir(1, 2, 3)), 0.7)
    shift.SetTranslation(gp_Vec(1000, 1000, 1000))
    return {
        "aligned": write_shape(box, folder / "aligned.step"),
        "rotated": write_shape(
            BRepBuilderAPI_Transform(box, turn, True).Shape(), folder / "r.step"
        ),
        "offset": write_shape(
            BRepBuilderAPI_Transform(box, shift, True).Shape(), folder / "o.step"
        ),
    }


def _face_colours(path) -> dict[int, int]:
    """For each face seen, the number of distinct colours among its interior pixels (those
    whose 8 neighbours are of the same face and fully covered)."""
    channels, _ = read_exr(path)
    patch, covered = channels["patch"].astype(int), channels["A"] == 1
    inner = np.zeros_like(covered)
    inner[1:-1, 1:-1] = covered[1:-1, 1:-1]
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            inner[1:-1, 1:-1] &= (
                patch[1 + dy : patch.shape[0] - 1 + dy, 1 + dx : patch.shape[1] - 1 + dx]
                == patch[1:-1, 1:-1]
            )
            inner[1:-1, 1:-1] &= covered[
                1 + dy : covered.shape[0] - 1 + dy, 1 + dx : covered.shape[1] - 1 + dx
            ]
    rgb = np.stack([channels[c] for c in "RGB"], -1)
    out = {}
    for face in np.unique(patch[inner]):
        colours = rgb[inner & (patch == face)]
        out[int(face)] = len(np.unique(colours, axis=0))
    return out


def _render(scene, out, *extra) -> None:
    argv = ["render", str(scene), "-o", str(out), "--width", "160", "--height", "120"]
    argv += ["--spp", "4", "--set", "render.lighting=flat", *extra]
    assert main(argv) == 0


@pytest.mark.parametrize("kind", ["aligned", "rotated", "offset"])
def test_each_face_of_a_box_is_one_colour_with_the_automatic_period(boxes, kind, tmp_path):
    _render(boxes[kind], tmp_path / "box.exr")
    colours = _face_colours(tmp_path / "box.exr")
    assert len(colours) >= 2 and all(n == 1 for n in colours.values()), colours


@pytest.mark.parametrize("kind", ["aligned", "offset"])
@pytest.mark.parametrize("stripes", [7, 10])
def test_a_face_exactly_on_a_stripe_edge_is_one_colour(boxes, kind, stripes, tmp_path):
    """The front face's isophote value <n, l> (n = -y, the CAD light) is made exactly a
    whole number of periods: on a stripe edge, still one colour."""
    light = np.array(CAD_LIGHT) / np.linalg.norm(CAD_LIGHT)
    period = float(-light[1]) / stripes
    _render(boxes[kind], tmp_path / "edge.exr", "--set", f"shape.period={period!r}")
    colours = _face_colours(tmp_path / "edge.exr")
    assert len(colours) >= 2 and all(n == 1 for n in colours.values()), colours


@pytest.mark.parametrize("kind", ["aligned", "rotated"])
def test_the_automatic_period_keeps_the_faces_off_the_edges(boxes, kind, tmp_path):
    """The automatic period (from the legend, 4 digits) puts every face's constant value
    (the exact channel f) a tenth of a period or more from the edges; unmoved, the face
    holding the span's end would be exactly on one."""
    import re

    _render(boxes[kind], tmp_path / "box.exr")
    channels, header = read_exr(tmp_path / "box.exr")
    period = float(re.search(r"stripes every ([0-9.e+-]+)", header["legend"]).group(1))
    patch = channels["patch"].astype(int)
    for face in np.unique(patch[patch >= 0]):
        values = channels["f"][patch == face].astype(np.float64)
        if np.ptp(values) > 1e-6:
            continue  # not a plane
        t = np.mod(values.mean() / period, 1.0)
        assert min(t, abs(t - 0.5), 1.0 - t) >= EDGE_MARGIN - 0.01, (face, values.mean())
