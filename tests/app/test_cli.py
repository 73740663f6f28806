"""The command line: the installed `gshade` script."""

import subprocess
import sys

from gshade.app.cli import main


def test_shapes_lists_every_function_with_its_order(capsys):
    assert main(["shapes"]) == 0
    out = capsys.readouterr().out
    assert "isophotes  (order 1)" in out
    assert "mean  (order 2)" in out
    assert "reflection_lines  (order 1, eye-dependent)" in out
    assert "light = (0.0, 0.0, 1.0)" in out


def test_the_console_script_runs():
    result = subprocess.run(
        [sys.executable, "-m", "gshade", "--version"], capture_output=True, text=True
    )
    assert result.returncode == 0 and result.stdout.startswith("gshade ")
