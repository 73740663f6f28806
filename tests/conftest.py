"""The test session's settings: Dr.Jit pointed at gshade's libLLVM (the tests import drjit
and mitsuba themselves), hypothesis's profile under CI, gshade's caches in a folder of the
session's, and the fixtures of tests/support/browser.py.  The ``slow`` marker is pyproject's
(``-m "not slow"``: the quick loop; the test command of README.md and
docs/getting_started.rst runs everything)."""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile

from hypothesis import settings

import gshade.runtime

# the test modules import drjit and mitsuba themselves: the libLLVM gshade would choose first
gshade.runtime.setup()

# CI runs the same examples every time (a red CI must mean a change, not a new draw);
# locally each run explores new ones.
settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")

# gshade's content-keyed caches (the optimised hole fillings) go to a folder of this test
# session's, which its subprocesses inherit, never to the user's ~/.cache
if "GSHADE_CACHE_DIR" not in os.environ:
    os.environ["GSHADE_CACHE_DIR"] = tempfile.mkdtemp(prefix="gshade-tests-cache-")
    atexit.register(shutil.rmtree, os.environ["GSHADE_CACHE_DIR"], True)


pytest_plugins = ["tests.support.browser"]
