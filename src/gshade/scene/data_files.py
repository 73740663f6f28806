"""Where the data files a surface's ``file`` key names may lie: within the scene file's
folder, or a folder in ``GSHADE_DATA_PATH``, once symbolic links are resolved."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from ..errors import show
from .tables import Table

__all__ = ["DATA_PATH_VARIABLE", "DataFiles", "data_roots"]

#: Environment variable: further folders (separated by os.pathsep) that surface data files
#: may lie in besides the scene file's own folder.
DATA_PATH_VARIABLE = "GSHADE_DATA_PATH"


def data_roots(base: Path, data_path: Sequence[str | os.PathLike] | None) -> list[Path]:
    """The folders data files may lie in: the scene's own and ``data_path`` (default: the
    environment's ``GSHADE_DATA_PATH``)."""
    if data_path is None:
        data_path = [p for p in os.environ.get(DATA_PATH_VARIABLE, "").split(os.pathsep) if p]
    roots = []
    for folder in [base, *data_path]:
        try:
            roots.append(Path(folder).resolve())
        except (OSError, ValueError, RuntimeError):
            continue
    return roots


@dataclass
class DataFiles:
    """Where one surface's data file may lie: relative to ``base`` (the scene file's
    folder), within one of ``roots``.  ``used``: the file it read, once found."""

    base: Path
    roots: Sequence[Path]
    used: Path | None = None

    def find(self, t: Table, name: str, key: str = "file") -> Path:
        """The data file a table's ``key`` (a surface's ``file``) names (relative to the
        scene file), checked to lie within one of the roots once symbolic links are
        resolved."""
        from ..io.files import file_kind  # here: gshade.io loads OpenEXR

        data_file = self.base / name
        try:
            resolved = data_file.resolve()
            exists = resolved.exists()
            kind = file_kind(resolved) if exists else None
        except (OSError, ValueError, RuntimeError) as exc:
            raise t.error(
                key,
                f"expected a path to an existing file, got {show(name)} "
                f"({getattr(exc, 'strerror', None) or 'not a usable path'})",
            ) from None
        if not any(resolved.is_relative_to(root) for root in self.roots):
            raise t.error(
                key,
                f"expected a file within the scene's folder {self.roots[0]} (or a folder in "
                f"{DATA_PATH_VARIABLE}), got {show(name)}",
            )
        if not exists:
            raise t.error(
                key,
                f"expected an existing file (relative to the scene file), got {show(name)} "
                f"(no such file: {data_file})",
            )
        if kind is not None:  # a folder, a FIFO, a device: said so, not "no such file"
            raise t.error(
                key,
                f"expected a regular file (relative to the scene file), got {show(name)}, "
                f"which is {kind}",
            )
        self.used = data_file
        return data_file
