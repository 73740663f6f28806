"""Every docstring example in the package runs and prints what it says (doctest)."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import gshade


def _modules() -> list[str]:
    names = [
        info.name
        for info in pkgutil.walk_packages(gshade.__path__, prefix="gshade.")
        if not info.name.endswith("__main__")
    ]
    return sorted(names)


def _with_examples() -> list[str]:
    found = []
    for name in _modules():
        try:
            module = importlib.import_module(name)
        except ImportError:  # an optional dependency (the kernel, rhino3dm) is missing
            continue
        if any(test.examples for test in doctest.DocTestFinder().find(module)):
            found.append(name)
    return found


def test_the_package_has_examples() -> None:
    assert len(_with_examples()) >= 8


@pytest.mark.parametrize("name", _with_examples())
def test_the_examples_run(name: str) -> None:
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} examples failed"
