"""``python -m gshade``: the ``gshade`` command."""

from .app.cli import console

console()
