"""Text shown to a person, made printable: names and messages from files, escaped.

Names and messages shown (printed, or written into XML, HTML and JSON) go through
:func:`printable`: control characters, format characters and bytes of a file name that are not
UTF-8 become visible escapes (``\\x1b``, ``\\u202e``, ``\\xff``).
"""

from __future__ import annotations

import re
import unicodedata
from functools import lru_cache

__all__ = ["printable"]

#: Unicode categories shown escaped: controls (C0, DEL, C1), format characters (bidi
#: overrides, zero-width), surrogates (bytes that are not UTF-8), line and paragraph
#: separators.
_ESCAPED_CATEGORIES = frozenset({"Cc", "Cf", "Cs", "Zl", "Zp"})
#: Characters outside ASCII's printable range: the only ones that can need escaping.
_CANDIDATES = re.compile(r"[^\x20-\x7e]")


@lru_cache(maxsize=4096)
def _escape(char: str, keep_lines: bool) -> str:
    code = ord(char)
    if keep_lines and char in "\n\t":
        return char
    if 0xDC80 <= code <= 0xDCFF:  # a byte that is not UTF-8, as surrogateescape keeps it
        return f"\\x{code - 0xDC00:02x}"
    if code in (0xFFFE, 0xFFFF) or unicodedata.category(char) in _ESCAPED_CATEGORIES:
        return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"
    return char


def printable(text: object, *, keep_lines: bool = False) -> str:
    """``str(text)`` with its control characters written as escapes.

    Parameters
    ----------
    text : object
        A name, a path or a message (made a str).
    keep_lines : bool
        Keep newlines and tabs (a log, a traceback); by default they are escaped too, so
        that the result is one line.

    Returns
    -------
    str
        The text with C0 and C1 controls, DEL, format characters (``U+202E`` ...), line
        separators and surrogates written as ``\\xNN`` / ``\\uNNNN`` (a surrogate-escaped
        byte as the byte, ``\\xff``).  Printable text is returned unchanged, and the result
        is printable: ``printable(printable(t)) == printable(t)``.
    """
    text = str(text)
    return _CANDIDATES.sub(lambda m: _escape(m.group(), keep_lines), text)
