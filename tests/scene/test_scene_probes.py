"""The fuzz test's named probes (tests/support/fuzz_scenes.py, ``P01``...``P27``) with the
outcome each must have, written out: refused with one line naming the file and the key or limit,
or accepted and rendered.  The fuzz test itself only asks "a clean error or a finite image";
this table turns each probe into a must-reject or must-accept case, so that a check that stops
refusing (or starts refusing a valid scene) turns a row red.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import gshade
from gshade import GshadeError

from ..support.fuzz_scenes import probes, write_variant

REJECT, ACCEPT = "reject", "accept"

#: probe number -> (outcome, for REJECT a pattern the message must contain)
EXPECTED: dict[int, tuple[str, str]] = {
    1: (REJECT, r"\[render\] width: expected an integer from 1 to 16384, got 100000000"),
    2: (REJECT, r"\[render\] height: expected an integer from 1 to 16384, got 2147483648"),
    3: (REJECT, r"\[render\] spp: expected an integer from 1 to 4096"),
    4: (REJECT, r"\[render\] tessellation: expected an integer from 2 to 1024, got 1000000"),
    5: (REJECT, r"\[render\] tessellation: expected a finite number within ±1e\+15"),
    6: (REJECT, r"\[render\] width: expected an integer from 1 to 16384, got 65536"),
    7: (REJECT, r"\[render\] texture_resolution: expected a finite number within ±1e\+15"),
    8: (REJECT, r"\[render\] seed: expected a finite number within ±1e\+15"),
    9: (REJECT, r"\[render\] chord_tolerance: expected a number in \[1e-09, 1\], got 5e-324"),
    10: (REJECT, r"\[camera\] fov: expected a number in \(0\.001, 180\), got 1e-300"),
    11: (REJECT, r"invalid TOML: .*4300 digits"),
    12: (REJECT, r"invalid TOML: arrays or tables nested too deeply \(at most 8\)"),
    13: (REJECT, r"invalid TOML: arrays or tables nested too deeply \(at most 8\)"),
    14: (REJECT, r"\[\[surface\]\] 1 \(bezier\): points: expected at most 21 points .*degree 40"),
    15: (REJECT, r"\[\[surface\]\] 1 \(sphere\): degenerate: it has no regular point"),
    16: (REJECT, r"\[\[surface\]\] 1 \(sphere\): radius: expected a positive number, got 0"),
    17: (REJECT, r"\[\[surface\]\] 1 \(junction\): patch 0 degenerate: it has no regular point"),
    18: (REJECT, r"\[\[surface\]\] 1 \(bezier\): points: .*got rows of 4, 3, 4, 4 points"),
    19: (REJECT, r"name: expected a name of at most 200 bytes \(UTF-8\), got one of 300 bytes"),
    20: (REJECT, r"name: expected a name usable as a file name .*control character"),
    21: (REJECT, r"name: expected a name usable as a file name .*path separator"),
    22: (ACCEPT, ""),  # the teapot 40 times over: 1,280 patches, within every limit
    23: (REJECT, r"colour: unknown key \(expected one of: name, surface, shape"),
    24: (REJECT, r"\[\[surface\]\] 1: type: missing; expected one of \"newell\""),
    25: (ACCEPT, ""),  # subdivision levels = 4: the stated maximum
    26: (ACCEPT, ""),  # a camera at the origin only: framing still finds a view
    27: (REJECT, r"\[camera\] fov: expected a number in \(0\.001, 180\), got 1e-300"),
}

PROBES = {int(case.label[1:3]): case for case in probes()}


def test_every_probe_has_its_outcome_written_down():
    assert sorted(PROBES) == sorted(EXPECTED)


@pytest.mark.parametrize("number", sorted(EXPECTED), ids=lambda n: PROBES[n].label[:40])
def test_probe_outcome(number, tmp_path):
    case = PROBES[number]
    outcome, pattern = EXPECTED[number]
    path = write_variant(tmp_path, case)
    before = sorted(p.name for p in tmp_path.iterdir())
    try:
        scene = gshade.load_scene(path)
        # a size probe keeps its own settings: the render must refuse it before working
        image = gshade.render(scene, **({} if case.size else {"width": 16, "height": 12, "spp": 1}))
    except GshadeError as exc:
        message = str(exc)
        assert outcome == REJECT, f"{case.label}: refused, must be accepted: {message}"
        assert "\n" not in message
        assert message.startswith(str(path)), message
        assert re.search(pattern, message), message
        assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written
        return
    assert outcome == ACCEPT, f"{case.label}: accepted, must be refused ({pattern})"
    for name, channel in image.channels.items():
        assert channel.shape == (12, 16), name
        assert np.all(np.isfinite(channel)), name
