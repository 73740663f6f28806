"""The scene-key reference (``gshade keys``) and the documentation's annotated scene file
agree: every declared key is in the annotated scene file of docs/reference/scene_files.rst
(the ``.. code-block:: toml`` after the label ``annotated-scene-file``), and every key there
is declared."""

from __future__ import annotations

import json
import math
import re

from gshade.app.cli import main
from gshade.scene import SURFACE_TYPES, parse_scene
from gshade.scene.keys import key_tables, scene_keys
from gshade.scene.sections import CHECK_KEYS, SHAPE_KEYS
from gshade.shape import SHAPE_FUNCTIONS

from ..support.docs_pages import code_block
from ..support.paths import ROOT

HEADER = re.compile(r"^(\[\[?)(\w+)\]\]?")
KEY_AT_START = re.compile(r"^#?\s*([a-z]\w*)\s*=")
KEYS_IN_TEXT = re.compile(r"(?<![\w.])([a-z]\w*)\s*=(?!=)")
SURFACE_TYPE_LINE = re.compile(r"^#\s*(\w+):\s")


DOCS_PAGE = ROOT / "docs" / "reference" / "scene_files.rst"
LABEL = ".. _annotated-scene-file:"
DIRECTIVE = ".. code-block:: toml\n"


def docs_block() -> str:
    """The annotated scene file as the docs page shows it: the body of the first
    ``.. code-block:: toml`` after the label, unindented."""
    text = DOCS_PAGE.read_text(encoding="utf-8")
    assert LABEL in text, f"{DOCS_PAGE}: the label {LABEL!r} is gone"
    after = text.split(LABEL, 1)[1]
    block = code_block(after, DIRECTIVE, f"{DOCS_PAGE} after {LABEL!r}")
    assert block.strip(), f"{DOCS_PAGE}: the annotated scene file is empty"
    return block


def docs_keys() -> dict[str, set[str]]:
    """Table heading (as the reference writes it) -> the key names the docs block shows.

    A key is a name before ``=`` at a line's start, written or commented out (``# key =``);
    in ``[[surface]]``, a line ``# TYPE: …`` and the comment lines after it (starting in
    column 0) show that type's keys inline, and the keys written out are those of the
    ``type = "…"`` above them.  Comments after a value, and their indented continuation
    lines, are prose."""
    found: dict[str, set[str]] = {"(top level)": set()}
    table, kind = "(top level)", None
    for line in docs_block().splitlines():
        header = HEADER.match(line)
        if header:
            table = "[[surface]]" if header[1] == "[[" else f"[{header[2]}]"
            kind = None
            found.setdefault(table, set())
            continue
        if table != "[[surface]]":
            key = KEY_AT_START.match(line)
            if key:
                found[table].add(key[1])
            continue
        if not line.startswith("#"):
            key = KEY_AT_START.match(line)
            if key and key[1] == "type":
                kind = json.loads(line.split("=", 1)[1].split("#", 1)[0])
                found[table].add("type")
            elif key:
                found.setdefault(f'[[surface]] type = "{kind}"', set()).add(key[1])
            continue
        start = SURFACE_TYPE_LINE.match(line)
        if start:
            kind, line = start[1], line[start.end() :]
        found.setdefault(f'[[surface]] type = "{kind}"', set()).update(KEYS_IN_TEXT.findall(line))
    return found


def declared_keys() -> dict[str, set[str]]:
    return {table.heading: set(table.keys) for table in key_tables()}


def test_every_declared_key_is_in_the_docs_and_every_docs_key_is_declared():
    shown, declared = docs_keys(), declared_keys()
    # the top level's tables are the block's headers, not keys
    tables = {name for name in declared["(top level)"] if name != "name"}
    declared["(top level)"] -= tables
    assert {h.strip("[]") for h in shown if h.startswith("[") and " " not in h} == tables
    parameters = {p for fn in SHAPE_FUNCTIONS.values() for p in fn.parameters}
    shown["[shape]"] -= parameters - set(SHAPE_KEYS)  # "the function's parameters, by name"
    assert set(shown) == set(declared)
    for heading in declared:
        missing = declared[heading] - shown[heading]
        unknown = shown[heading] - declared[heading]
        page = DOCS_PAGE.relative_to(ROOT)
        assert not missing, f"{page}'s scene file lacks {heading} {sorted(missing)}"
        assert not unknown, f"{page}'s scene file shows undeclared {heading} {sorted(unknown)}"


def test_the_docs_block_is_a_valid_scene():
    scene = parse_scene(docs_block(), base=ROOT / "scenes")
    assert scene.name == "teapot-isophotes" and scene.check == {} and scene.sweep == {}


def test_every_surface_type_is_declared_with_its_keys():
    headings = [t.heading for t in key_tables()]
    assert [h.split('"')[1] for h in headings if "type =" in h] == list(SURFACE_TYPES)
    assert all(k.description and k.accepts for t in key_tables() for k in t.keys.values())


def test_the_check_defaults_listed_are_gshade_checks():
    from gshade.regression.check import CHECK_DEFAULTS, DEFAULT_THRESHOLDS

    for key, value in {**CHECK_DEFAULTS, **vars(DEFAULT_THRESHOLDS)}.items():
        default = CHECK_KEYS[key].default
        assert default == value or (math.isinf(value) and math.isinf(default)), key


def test_gshade_keys_prints_the_reference(capsys):
    assert main(["keys"]) == 0
    out = capsys.readouterr().out
    assert out == scene_keys() + "\n"
    for heading, keys in declared_keys().items():
        assert heading in out and all(f"  {k} " in out for k in keys)
