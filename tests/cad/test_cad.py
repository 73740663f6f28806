"""The CAD reader's dispatch: extensions, and the libraries missing."""

from __future__ import annotations

import sys

import pytest

from gshade import GshadeError
from gshade.cad import INSTALL, read_cad


@pytest.mark.parametrize(
    ("name", "module", "library"),
    [("part.step", "gshade.cad.occt", "OCP"), ("part.3dm", "gshade.cad.rhino", "rhino3dm")],
)
def test_missing_libraries_name_the_install_command(tmp_path, monkeypatch, name, module, library):
    path = tmp_path / name
    path.write_text("anything")
    import gshade.io

    monkeypatch.delitem(sys.modules, module, raising=False)
    monkeypatch.delattr(gshade.io, module.rsplit(".", 1)[1], raising=False)
    for loaded in [m for m in sys.modules if m == library or m.startswith(library + ".")]:
        monkeypatch.setitem(sys.modules, loaded, None)  # importing it now fails
    monkeypatch.setitem(sys.modules, library, None)
    with pytest.raises(GshadeError) as info:
        read_cad(path)
    message = str(info.value)
    assert message.startswith(str(path)) and INSTALL in message and "\n" not in message


def test_unknown_extension_is_one_line(tmp_path):
    with pytest.raises(GshadeError, match=r"x\.stl: expected a CAD file \(\.step, .*got the"):
        read_cad(tmp_path / "x.stl")


def test_a_mesh_file_given_as_a_scene_is_named_not_parsed(tmp_path):
    """``gshade render part.stl``: one line naming what was expected, not a TOML error."""
    from gshade.scene import load_scene

    part = tmp_path / "part.stl"
    part.write_bytes(b"solid x\nendsolid x\n")
    with pytest.raises(GshadeError, match=r"part\.stl: expected a scene file \(TOML\) or a CAD"):
        load_scene(part)
