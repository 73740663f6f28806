"""A Sphinx extension that writes gshade's references from its registries at build time:
``reference/generated/keys.rst`` (every scene table and key: what it accepts, its default
and meaning, as ``gshade keys``), ``reference/generated/shape_functions.rst`` (every
shape function: order, eye dependence, parameters, as ``gshade shapes``) and
``reference/generated/cli.rst`` (every command's ``--help``, from the argument parser).  Nothing is
written by hand: a key or function added to a registry appears at the next build."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from sphinx.application import Sphinx


def _cell(text: str) -> str:
    """Text for a list-table cell: one line, reST's special characters escaped."""
    text = " ".join(str(text).split())
    for special in ("\\", "*", "|", "`", "_"):
        text = text.replace(special, "\\" + special)
    return text or " "


def _table(rows: list[tuple[str, ...]], header: tuple[str, ...], widths: str) -> list[str]:
    out = [".. list-table::", "   :header-rows: 1", f"   :widths: {widths}", ""]
    for row in [header, *rows]:
        first, *rest = row
        out.append(f"   * - {first}")
        out += [f"     - {cell}" for cell in rest]
    return [*out, ""]


def keys_page() -> str:
    """The scene-key reference as reStructuredText."""
    from gshade.scene.keys import key_tables

    lines = [
        ".. _scene-keys:",
        "",
        "Scene keys",
        "==========",
        "",
        "Every table and key a scene file may hold, generated from the declarations the",
        "scene parser checks files against (``gshade keys`` prints the same).  A key not",
        "listed is refused with the nearest listed name.",
        "",
    ]
    for table in key_tables():
        title = table.heading
        lines += [title, "-" * len(title), ""]
        if table.description:
            lines += [_cell(table.description[0].upper() + table.description[1:]) + ".", ""]
        if table.keys:
            rows = [
                (f"``{k.name}``", _cell(k.accepts), _cell(k.default_text), _cell(k.description))
                for k in table.keys.values()
            ]
            lines += _table(rows, ("key", "accepts", "default", "meaning"), "18 30 18 34")
        if table.note:
            lines += ["Also: " + _cell(table.note) + ".", ""]
    return "\n".join(lines)


def shape_functions_page() -> str:
    """The shape-function reference as reStructuredText."""
    from gshade.shape import SHAPE_FUNCTIONS

    lines = [
        ".. _shape-functions:",
        "",
        "Shape functions",
        "===============",
        "",
        "Every shape function ``shape.function`` names, with its order (the derivatives it",
        "uses: its level lines are G(n − k) on a Gn surface) and parameters, generated from",
        "gshade's registry (``gshade shapes`` prints the same).",
        "",
    ]
    for fn in SHAPE_FUNCTIONS.values():
        title = fn.name
        lines += [title, "-" * len(title), ""]
        eye = ", depends on the eye" if fn.eye_dependent else ""
        lines += [f"Order {fn.order}{eye}. " + _cell(fn.summary), ""]
        if fn.parameters:
            rows = []
            for name, p in fn.parameters.items():
                default = str(p.default)
                if p.kind == "choice":
                    default += " (" + " | ".join(p.choices) + ")"
                rows.append((f"``{name}``", _cell(default), _cell(p.help)))
            lines += _table(rows, ("parameter", "default", "meaning"), "20 30 50")
    return "\n".join(lines)


def commands_page() -> str:
    """The command-line reference as reStructuredText: each command's help as the terminal
    shows it (``gshade COMMAND --help``), from gshade's own parser."""
    import argparse

    from gshade.app.cli import build_parser

    parser = build_parser()
    lines = [
        ".. _cli:",
        "",
        "Command line",
        "============",
        "",
        "Generated from gshade's argument parser: ``gshade --help`` and every command's",
        "``--help``, as the terminal shows them.  The exit statuses are listed in",
        ":ref:`exit-statuses`.",
        "",
        "::",
        "",
    ]
    lines += ["   " + line for line in parser.format_help().splitlines()]
    lines.append("")
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, command in commands.choices.items():
        title = f"gshade {name}"
        lines += [f".. _cli-{name}:", "", title, "-" * len(title), "", "::", ""]
        lines += ["   " + line for line in command.format_help().splitlines()]
        lines.append("")
    return "\n".join(line.rstrip() for line in lines)


def _write(app: Sphinx) -> None:
    folder = Path(app.srcdir) / "reference" / "generated"
    folder.mkdir(parents=True, exist_ok=True)
    pages = (
        ("keys", keys_page()),
        ("shape_functions", shape_functions_page()),
        ("cli", commands_page()),
    )
    for name, page in pages:
        path = folder / f"{name}.rst"
        if not path.exists() or path.read_text(encoding="utf-8") != page:
            path.write_text(page, encoding="utf-8")


def setup(app: Sphinx) -> dict[str, Any]:
    app.connect("builder-inited", _write)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
