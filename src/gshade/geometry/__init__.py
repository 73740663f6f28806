"""Exact parametric curves and patches with derivatives, and their differential geometry."""

from .bernstein import bernstein_basis, de_casteljau, elevate_degree
from .betaspline import BetaSplineCurve, BetaSplinePatch
from .bezier import BezierCurve, BezierPatch
from .bspline import BSplineCurve, BSplinePatch
from .coons import CoonsPatch
from .differential import (
    first_fundamental_form,
    gaussian_and_mean_curvature,
    gaussian_curvature,
    irregular_mask,
    mean_curvature,
    principal_curvatures,
    second_fundamental_form,
    unit_normal,
)
from .gammaspline import GammaSplineCurve, GammaSplinePatch
from .nuspline import NuSplinePatch, nu_spline
from .patch import Curve, Patch
from .regularity import patch_normals, regularised_derivatives, toward_interior
from .revolution import circle, cylinder, revolve, sphere, torus
from .subdivision import StamPatch, subdivision_patches

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
