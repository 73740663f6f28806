"""Exact parametric curves and patches with derivatives, and their differential geometry.

The modules come in families, one subpackage each, every one importing only from those
before it:

- :mod:`~gshade.geometry.core`: the patch protocol, Bernstein bases, knots, rational
  derivatives, differential geometry, first-order jets;
- :mod:`~gshade.geometry.patches`: Bézier, B-spline (NURBS), Coons and revolved patches;
- :mod:`~gshade.geometry.evaluation`: many patches at once (grouped grids, scattered
  points), and the limits where a patch is irregular;
- :mod:`~gshade.geometry.splines`: the geometric splines (β, γ, ν) and G^k junctions;
- :mod:`~gshade.geometry.subdivision`: Catmull–Clark meshes and Stam's exact patches;
- :mod:`~gshade.geometry.holes`: n-sided holes, their G1 / G2 fillings and fairing.

The names below are the public ones; the modules' paths may change between versions.
"""

from .core.bernstein import bernstein_basis, de_casteljau, elevate_degree
from .core.differential import (
    first_fundamental_form,
    gaussian_and_mean_curvature,
    gaussian_curvature,
    irregular_mask,
    mean_curvature,
    principal_curvatures,
    second_fundamental_form,
    unit_normal,
)
from .core.patch import Curve, Patch
from .evaluation.regularity import patch_normals, regularised_derivatives, toward_interior
from .patches.bezier import BezierCurve, BezierPatch
from .patches.bspline import BSplineCurve, BSplinePatch
from .patches.coons import CoonsPatch
from .patches.revolution import circle, cylinder, revolve, sphere, torus
from .splines.betaspline import BetaSplineCurve, BetaSplinePatch
from .splines.gammaspline import GammaSplineCurve, GammaSplinePatch
from .splines.nuspline import NuSplinePatch, nu_spline
from .subdivision.stam import StamPatch, subdivision_patches

__all__ = [
    "BSplineCurve",
    "BSplinePatch",
    "BetaSplineCurve",
    "BetaSplinePatch",
    "BezierCurve",
    "BezierPatch",
    "CoonsPatch",
    "Curve",
    "GammaSplineCurve",
    "GammaSplinePatch",
    "NuSplinePatch",
    "Patch",
    "StamPatch",
    "bernstein_basis",
    "circle",
    "cylinder",
    "de_casteljau",
    "elevate_degree",
    "first_fundamental_form",
    "gaussian_and_mean_curvature",
    "gaussian_curvature",
    "irregular_mask",
    "mean_curvature",
    "nu_spline",
    "patch_normals",
    "principal_curvatures",
    "regularised_derivatives",
    "revolve",
    "second_fundamental_form",
    "sphere",
    "subdivision_patches",
    "torus",
    "toward_interior",
    "unit_normal",
]
