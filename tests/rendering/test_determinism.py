"""Determinism: the same scene renders bit-identically across runs, processes and threads."""

import subprocess
import sys

import numpy as np
import pytest

from ..support.paths import ROOT

RENDER = """
import sys
import numpy as np
import gshade  # first: it points Dr.Jit at a usable LLVM
import drjit as dr
threads = int(sys.argv[1])
dr.set_thread_count(threads)
image = gshade.render(sys.argv[2], width=96, height=72, spp=4)
np.savez(sys.argv[3], **image.channels)
"""


@pytest.mark.parametrize("scene", ["teapot-mean.toml", "junctions-isophotes.toml"])
def test_bit_identical_in_two_processes_and_with_one_or_two_threads(tmp_path, scene):
    outputs = []
    for k, threads in enumerate((2, 2, 1)):
        out = tmp_path / f"run{k}.npz"
        result = subprocess.run(
            [sys.executable, "-c", RENDER, str(threads), str(ROOT / "scenes" / scene), str(out)],
            capture_output=True,
            text=True,
        )
        assert result.returncode == 0, result.stderr
        outputs.append(dict(np.load(out)))
    first = outputs[0]
    for other in outputs[1:]:
        assert set(other) == set(first)
        for name in first:
            assert np.array_equal(first[name], other[name], equal_nan=True), name
