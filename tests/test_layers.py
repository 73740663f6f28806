"""The packages' layering: data flows one way, so a package imports only from the layers below
it (docs/concepts/layout.rst).  Read from the source with :mod:`ast`, lazy imports inside functions
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
    ("cad",),
    ("shape",),
    ("display",),
    ("scene",),
    ("analysis",),
    ("rendering",),
    ("regression",),
    ("app",),
]
RANK = {name: rank for rank, names in enumerate(LAYERS) for name in names}

#: Modules allowed to import from a higher layer: re-exports kept for one version.
RE_EXPORTS = {"io/cad.py": {"cad"}}  # gshade.io.cad, the names of gshade.cad (0.9 only)


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
    allowed = RE_EXPORTS.get(path.relative_to(SOURCE).as_posix(), set())
    upward = sorted(p for p in imported_packages(path) if RANK[p] > RANK[own] and p not in allowed)
    assert not upward, f"{path.relative_to(SOURCE)} ({own}) imports from {upward}"


#: The geometry's subpackages, lowest first: each imports only from its own and earlier ones.
GEOMETRY_LAYERS = [
    ("core",),
    ("patches",),
    ("evaluation",),
    ("splines", "subdivision"),
    ("holes",),
]
GEOMETRY_RANK = {name: rank for rank, names in enumerate(GEOMETRY_LAYERS) for name in names}
GEOMETRY = SOURCE / "geometry"


def test_every_geometry_module_is_in_a_family():
    loose = sorted(p.name for p in GEOMETRY.glob("*.py") if p.name != "__init__.py")
    families = {p.name for p in GEOMETRY.iterdir() if p.is_dir() and p.name != "__pycache__"}
    assert not loose, loose
    assert families == set(GEOMETRY_RANK), sorted(families ^ set(GEOMETRY_RANK))


@pytest.mark.parametrize(
    "path",
    sorted(p for p in GEOMETRY.rglob("*.py") if p.parent != GEOMETRY),
    ids=lambda p: str(p.relative_to(SOURCE)),
)
def test_geometry_families_import_only_from_lower_ones(path):
    own = path.relative_to(GEOMETRY).parts[0]
    found = set()
    for module, _ in _imports(path, top_level_only=False):
        parts = module.split(".")
        if parts[:2] != ["gshade", "geometry"]:
            continue
        if len(parts) == 2:  # from gshade.geometry import x: the package's re-exports
            found.add("(the package)")
        else:
            found.add(parts[2])
    upward = sorted(
        f for f in found if f not in GEOMETRY_RANK or GEOMETRY_RANK[f] > GEOMETRY_RANK[own]
    )
    assert not upward, f"{path.relative_to(SOURCE)} ({own}) imports from {upward}"


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SOURCE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path, top_level_only: bool) -> list[tuple[str, list[str]]]:
    """(module imported, names imported from it) for each gshade import of a module; with
    ``top_level_only``, the imports run when it is imported (not those inside functions)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    nodes = tree.body if top_level_only else list(ast.walk(tree))
    package = _module_name(path).split(".")
    if path.name != "__init__.py":
        package = package[:-1]
    out = []
    for node in nodes:
        if isinstance(node, ast.ImportFrom):
            base = package[: len(package) - (node.level - 1)] if node.level else []
            module = ".".join(base + (node.module.split(".") if node.module else []))
            if module.split(".")[0] == "gshade":
                out.append((module, [a.name for a in node.names]))
        elif isinstance(node, ast.Import):
            out.extend((a.name, []) for a in node.names if a.name.split(".")[0] == "gshade")
    return out


ALL_MODULES = sorted(SOURCE.rglob("*.py"))


def test_no_private_names_across_modules():
    """A module's private names (``_name``) are its own: none is imported elsewhere."""
    found = []
    for path in ALL_MODULES:
        for module, names in _imports(path, top_level_only=False):
            private = [n for n in names if n.startswith("_") and not n.startswith("__")]
            if private:
                found.append(f"{path.relative_to(SOURCE)}: {module} {private}")
    assert not found, found


def test_the_cad_package_imports_without_a_cycle():
    """The modules of gshade.cad import each other (when imported) in one direction only."""
    modules = {_module_name(p): p for p in (SOURCE / "cad").glob("*.py")}
    graph = {
        name: {m for m, names in _imports(path, top_level_only=True) for m in _targets(m, names)}
        & set(modules)
        for name, path in modules.items()
    }
    graph["gshade.cad"] -= set(modules)  # the package's re-exports: what it is made of
    done: set[str] = set()

    def visit(name: str, trail: tuple[str, ...]) -> None:
        assert name not in trail, " -> ".join((*trail, name))
        if name in done:
            return
        for other in sorted(graph[name]):
            visit(other, (*trail, name))
        done.add(name)

    for name in sorted(graph):
        visit(name, ())


def _targets(module: str, names: list[str]) -> list[str]:
    """The modules an import names: ``from package import module`` names the module."""
    return [module, *(f"{module}.{n}" for n in names)]


TESTS = Path(__file__).resolve().parent


def test_tests_mirror_the_package_and_share_helpers_through_support():
    """Every test module sits in the folder of what it tests (a package of gshade, or
    hostile/ for the whole program under hostile input; the layering checks at the top) and
    imports no other test module: shared helpers live in tests/support/."""
    folders = {p.relative_to(TESTS).parts[0] for p in TESTS.rglob("test_*.py")}
    assert folders <= set(RANK) | {
        "hostile",
        "test_layers.py",
        "test_errors.py",
        "test_docstring_examples.py",
        "test_python_api.py",  # gshade's top level: src/gshade/__init__.py
    }, sorted(folders)
    found = []
    for path in TESTS.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                names = [node.module or "", *(a.name for a in node.names)]
                if any(n.split(".")[-1].startswith("test_") for n in names):
                    found.append(f"{path.relative_to(TESTS)}:{node.lineno}")
    assert not found, found
