"""Shape functions (Kiciak, Chapter 6): a registry of functions of a surface's exact
derivatives, evaluated with Dr.Jit or numpy.  How their values become colours is
:mod:`gshade.display`."""

from .functions import (
    SHAPE_FUNCTIONS,
    Bands,
    Parameter,
    ShapeFunction,
    ShapeValues,
    checked_parameters,
    evaluate,
    function_bands,
    function_period,
    get_shape_function,
    validate_parameter,
    validate_parameters,
)

__all__ = [
    "SHAPE_FUNCTIONS",
    "Bands",
    "Parameter",
    "ShapeFunction",
    "ShapeValues",
    "checked_parameters",
    "evaluate",
    "function_bands",
    "function_period",
    "get_shape_function",
    "validate_parameter",
    "validate_parameters",
]
