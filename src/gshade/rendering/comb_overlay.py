"""The curvature combs of a render (``render.combs``): the scene's curves sampled every few
pixels of their images (:mod:`gshade.analysis.scene_combs`), drawn over the picture in one
scale (:mod:`gshade.rendering.comb_lines`), and their numbers for the header."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..analysis.scene_combs import LONGEST_SPINE, comb_scale, comb_summary, scene_combs
from ..analysis.scene_junctions import scene_diagonal
from .comb_lines import draw_combs

if TYPE_CHECKING:
    from ..scene.model import RenderSettings, Scene
    from .camera import View

__all__ = ["SAMPLE_PIXELS", "comb_note", "comb_overlay"]

#: A comb's samples are this many pixels apart along its curve's image (at least
#: MIN_SAMPLES, at most MAX_SAMPLES a curve)
SAMPLE_PIXELS, MIN_SAMPLES, MAX_SAMPLES = 3.0, 4, 1024


def _image_length(points: NDArray, view: View) -> float:
    """The length in pixels of a polyline's image, its part in the picture's reach (a
    curve behind the eye or far outside counts as short)."""
    col, row = view.image_positions(*view.camera_coordinates(points))
    reach = 2.0 * max(view.image_width, view.image_height)
    xy = np.clip(np.nan_to_num(np.stack([col, row], -1), nan=-reach), -reach, 2 * reach)
    return float(np.linalg.norm(np.diff(xy, axis=0), axis=-1).sum())


def comb_overlay(
    scene: Scene, settings: RenderSettings, view: View, channels: dict[str, NDArray]
) -> tuple[dict[str, NDArray], dict[str, Any]]:
    """The channels with the scene's combs drawn, and their summary
    (:func:`gshade.analysis.scene_combs.comb_summary`)."""

    def samples(points: NDArray) -> int:
        n = _image_length(points, view) / SAMPLE_PIXELS
        return int(np.clip(n, MIN_SAMPLES, MAX_SAMPLES))

    found = scene_combs(
        scene,
        lines=settings.comb_lines,
        curvature=settings.comb_curvature,
        samples=samples,
        sections=settings.comb_sections,
        section_direction=settings.comb_section_direction,
    )
    diagonal = scene_diagonal(scene)
    scale = settings.comb_scale or comb_scale(found, diagonal)
    drawn = draw_combs(channels, found, scale, view, LONGEST_SPINE * diagonal)
    return drawn, comb_summary(found, settings.comb_curvature, scale)


def comb_note(summary: dict[str, Any], length: str) -> str:
    """The legend's phrase of the combs: what they show and their scale."""
    n = len(summary["inflections"])
    return (
        f"combs: {summary['curvature']} curvature, spine = {summary['scale']:.4g} {length}² "
        f"x curvature, {n} inflection{'' if n == 1 else 's'} ringed"
    )
