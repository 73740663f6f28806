"""The packages' layering: data flows one way, so a package imports only from the layers below
it (README, *Layout*).  Read from the source with :mod:`ast`, lazy imports inside functions
included; an import against the order turns this red."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import gshade

SOURCE = Path(gshade.__file__).parent

#: Lowest first; a module may import from its own package and from any earlier one.
LAYERS = [
    ("errors", "limits", "runtime"),
    ("geometry",),
    ("io",),
    ("shape",),
    ("display",),
    ("scene",),
    ("analysis",),
    ("rendering",),
    ("regression",),
    ("app",),
]
RANK = {name: rank for rank, names in enumerate(LAYERS) for name in names}


def imported_packages(path: Path) -> set[str]:
    """The top-level gshade packages (``gshade.<name>``) that a module imports from."""
    # the package that relative imports start from (for x/__init__.py that is x itself)
    package = list(path.relative_to(SOURCE.parent).with_suffix("").parts)[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - (node.level - 1)]
                target = base + (node.module.split(".") if node.module else [])
            else:
                target = (node.module or "").split(".")
            names = [target] if node.module else [[*target, a.name] for a in node.names]
        elif isinstance(node, ast.Import):
            names = [a.name.split(".") for a in node.names]
        else:
            continue
        for name in names:
            if name[0] == "gshade" and len(name) > 1 and name[1] in RANK:
                found.add(name[1])
    return found


PACKAGED = sorted(
    p for p in SOURCE.rglob("*.py") if p.relative_to(SOURCE).parts[0].removesuffix(".py") in RANK
)


def test_every_package_has_a_layer():
    top = {p.name.removesuffix(".py") for p in SOURCE.iterdir() if not p.name.startswith("_")}
    top -= {"py.typed"}
    assert top <= set(RANK), sorted(top - set(RANK))


@pytest.mark.parametrize("path", PACKAGED, ids=lambda p: str(p.relative_to(SOURCE)))
def test_imports_only_from_lower_layers(path):
    own = path.relative_to(SOURCE).parts[0].removesuffix(".py")
    upward = sorted(p for p in imported_packages(path) if RANK[p] > RANK[own])
    assert not upward, f"{path.relative_to(SOURCE)} ({own}) imports from {upward}"
