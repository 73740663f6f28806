"""Shape functions (Kiciak, Chapter 6) and how they become colours."""

from .colour import (
    ColourMapped,
    Legend,
    auto_range,
    colour_map,
    combine,
    stripe_coverage,
    stripe_period,
    stripes,
)
from .functions import (
    SHAPE_FUNCTIONS,
    Parameter,
    ShapeFunction,
    ShapeValues,
    evaluate,
    get_shape_function,
)

__all__ = [
    "SHAPE_FUNCTIONS",
    "ColourMapped",
    "Legend",
    "Parameter",
    "ShapeFunction",
    "ShapeValues",
    "auto_range",
    "colour_map",
    "combine",
    "evaluate",
    "get_shape_function",
    "stripe_coverage",
    "stripe_period",
    "stripes",
]
