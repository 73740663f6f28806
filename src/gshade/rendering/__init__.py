"""Rendering: tessellation, shape textures, cameras and Mitsuba on the CPU."""

from .pipeline import render

__all__ = ["render"]
