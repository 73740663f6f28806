"""Reading input files with one-line errors that name the file and what went wrong."""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import GshadeError

__all__ = ["read_bytes"]


def read_bytes(
    path: str | os.PathLike,
    expected: str,
    error: type[GshadeError] = GshadeError,
    size: int = -1,
) -> bytes:
    """The bytes of a file (its first ``size`` if given).

    Raises ``error`` naming the file when it does not exist, is a directory (where
    ``expected``, e.g. "an OBJ file", was wanted) or cannot be read.
    """
    path = Path(path)
    try:
        with open(path, "rb") as f:
            return f.read(size)
    except FileNotFoundError:
        raise error(f"{path}: no such file") from None
    except IsADirectoryError:
        raise error(f"{path}: expected {expected}, got a directory") from None
    except OSError as exc:
        raise error(f"{path}: cannot read the file ({exc.strerror or exc})") from None
