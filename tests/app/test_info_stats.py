"""``gshade info --stats``: the whole surface's numbers without rendering."""

import subprocess
import sys

SADDLE = """
name = "saddle"
[[surface]]
type = "bezier"
points = [[[-1, -1, 1], [-1, 1, -1]], [[1, -1, -1], [1, 1, 1]]]
[shape]
function = "min_radius"
limit = 2.0
"""


def test_info_stats_gives_the_smallest_radius_and_where_it_is(tmp_path):
    """z = xy: |k| is largest at the origin, where k1 = -k2 = 1: the smallest radius is 1
    there (the patch's middle, u = v = 1/2); nothing is written."""
    scene = tmp_path / "saddle.toml"
    scene.write_text(SADDLE)
    out = subprocess.run(
        [sys.executable, "-m", "gshade", "info", str(scene), "--stats"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert "  min_radius over the whole surface:" in out
    (radius,) = [line for line in out.splitlines() if "smallest radius" in line]
    value = float(radius.split("smallest radius ")[1].split()[0])
    assert abs(value - 1.0) < 1e-6
    assert "(concave, patch 0)" in radius  # H = 0 there: k = +1 (sign(0) = +1)
    extremes = [line for line in out.splitlines() if "u 0.5, v 0.5" in line]
    assert len(extremes) == 2, out  # the min (-1) and the max (+1), both at the origin
    for line in extremes:
        point = [float(x) for x in line.split("at [")[1].split("]")[0].split(",")]
        assert max(abs(x) for x in point) < 1e-12, line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["saddle.toml"]
