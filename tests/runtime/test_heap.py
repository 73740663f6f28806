"""The command line's C heap settings (gshade.runtime.heap) take on glibc."""

import platform
import subprocess
import sys

import pytest

CHECK = """
import ctypes, sys
import gshade, gshade.rendering  # importing changes nothing
from gshade.runtime.heap import keep_freed_memory
print(keep_freed_memory())
"""


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="mallopt is glibc's")
def test_the_heap_settings_take_on_glibc():
    out = subprocess.run([sys.executable, "-c", CHECK], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "True"
