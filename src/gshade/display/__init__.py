"""How shape-function values become colours: anti-aliased stripes, colour maps, their
combination and the legend (Kiciak §6: level lines and colour maps)."""

from .colour import (
    ColourMapped,
    Legend,
    auto_range,
    colour_map,
    combine,
    stripe_coverage,
    stripe_period,
    stripes,
    validate_colormap,
    validate_range,
)

__all__ = [
    "ColourMapped",
    "Legend",
    "auto_range",
    "colour_map",
    "combine",
    "stripe_coverage",
    "stripe_period",
    "stripes",
    "validate_colormap",
    "validate_range",
]
