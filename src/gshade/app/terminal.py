"""What gshade prints: one line at a time, its names and messages shown escaped.

File names come from untrusted folders (a pull request's ``scenes/``) and may hold terminal
escape sequences (set the window title, colours, BEL), line breaks, bidirectional overrides
or bytes that are not UTF-8 (surrogate-escaped by Python: ``'\\udcff'``).  Every line the
command line prints, on stdout and stderr, goes through :func:`say` (or
:func:`printable`, :func:`gshade.io.printable.printable` itself: the one function, in the io
layer so that the report and the JUnit file use it too), which writes those characters as
Python escapes (``\\x1b``, ``\\u202e``; a byte that is not UTF-8 as ``\\xff``): the text
stays one line, readable, and encodable in UTF-8.
"""

from __future__ import annotations

import sys
from typing import TextIO

__all__ = ["printable", "say"]


def printable(text: object, *, keep_lines: bool = False) -> str:
    """:func:`gshade.io.printable.printable` (imported when first needed: ``gshade --help``
    does not load the io package)."""
    from ..io.printable import printable as shown

    return shown(text, keep_lines=keep_lines)


def say(*parts: object, file: TextIO | None = None, flush: bool = False) -> None:
    """``print`` of :func:`printable` text: ``parts`` joined by spaces, one line, to
    ``file`` (default stdout)."""
    line = " ".join(printable(p) for p in parts)
    print(line, file=sys.stdout if file is None else file, flush=flush)
