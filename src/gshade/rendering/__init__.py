"""Rendering: tessellation, shape textures, cameras and Mitsuba on the CPU."""

from __future__ import annotations

from typing import Any

__all__ = ["render"]


def __getattr__(name: str) -> Any:
    # lazy, so that ``gshade.runtime.variant`` can be imported without Mitsuba
    if name == "render":
        from .pipeline import render

        return render
    raise AttributeError(f"module 'gshade.rendering' has no attribute {name!r}")
