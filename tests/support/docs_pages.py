"""The code blocks the documentation shows, read from its reST sources, for the tests that
run or check them."""

from __future__ import annotations

import textwrap


def code_block(text: str, directive: str, page: str) -> str:
    """The body of the first ``directive`` (e.g. ``".. code-block:: toml\\n"``) in ``text``,
    the source of ``page``: the directive's options and the blank line after it skipped,
    the indented lines up to the first unindented one, unindented."""
    assert directive in text, f"{page}: no ``{directive.strip()}``"
    lines = text.split(directive, 1)[1].splitlines()
    while lines and (not lines[0].strip() or lines[0].lstrip().startswith(":")):
        lines.pop(0)  # the blank line and any options of the directive
    body = []
    for line in lines:
        if line.strip() and not line[0].isspace():
            break  # the block ends at the first unindented line
        body.append(line)
    return textwrap.dedent("\n".join(body)).strip("\n") + "\n"
