"""Exact rational surfaces of revolution: circles as NURBS, spheres, cylinders, tori.

A circle is a rational quadratic B-spline (four quarter arcs with weights 1, sqrt(2)/2, 1;
Piegl & Tiller, section 7.5).  Revolving a profile curve (rho(t), z(t)) about the z axis
gives the tensor-product NURBS with P_ij = (rho_i c_j^x, rho_i c_j^y, z_i) and weights
w_i w_j (Kiciak, A.4), exact to round-off.
"""

from __future__ import annotations

import numpy as np

from ..errors import GshadeError
from .bspline import BSplineCurve, BSplinePatch

__all__ = ["circle", "cylinder", "revolve", "sphere", "torus"]

_S = np.sqrt(0.5)
#: The unit circle's weights (:func:`circle`).
_CIRCLE_WEIGHTS = np.array([1, _S, 1, _S, 1, _S, 1, _S, 1])


def circle(radius: float = 1.0, centre=(0.0, 0.0)) -> BSplineCurve:
    """A full circle as a planar rational quadratic B-spline over [0, 1], counter-clockwise
    from (centre + (radius, 0))."""
    c = np.array(
        [[1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1], [1, 0]], dtype=float
    )
    knots = [0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1]
    return BSplineCurve(np.asarray(centre, float) + radius * c, 2, knots, _CIRCLE_WEIGHTS)


def revolve(profile: BSplineCurve) -> BSplinePatch:
    """Revolve a planar profile (rho, z) once about the z axis.

    u runs along the profile, v around the axis (v = 0 in the xz plane, counter-clockwise
    seen from +z).  The profile may be rational; rho = 0 gives a collapsed edge (a pole).
    """
    if profile.dim != 2:
        raise GshadeError(f"profile: expected a planar curve (rho, z), got dimension {profile.dim}")
    ring = circle()
    rho, z = profile.points[:, 0], profile.points[:, 1]
    wp = profile.weights if profile.weights is not None else np.ones(len(rho))
    P = np.empty((len(rho), len(ring.points), 3))
    P[..., 0] = rho[:, None] * ring.points[None, :, 0]
    P[..., 1] = rho[:, None] * ring.points[None, :, 1]
    P[..., 2] = z[:, None]
    W = wp[:, None] * _CIRCLE_WEIGHTS[None, :]
    return BSplinePatch(P, (profile.degree, 2), (profile.knots, ring.knots), W)


def sphere(radius: float = 1.0) -> BSplinePatch:
    """The sphere of the given radius about the origin; u from the south to the north pole."""
    profile = BSplineCurve(
        radius * np.array([[0, -1], [1, -1], [1, 0], [1, 1], [0, 1]], dtype=float),
        2,
        [0, 0, 0, 0.5, 0.5, 1, 1, 1],
        [1, _S, 1, _S, 1],
    )
    return revolve(profile)


def cylinder(radius: float = 1.0, height: float = 1.0) -> BSplinePatch:
    """The cylinder rho = radius, 0 <= z <= height (without caps)."""
    profile = BSplineCurve([[radius, 0.0], [radius, height]], 1, [0, 0, 1, 1])
    return revolve(profile)


def torus(major: float = 2.0, minor: float = 0.5) -> BSplinePatch:
    """The torus with tube radius ``minor`` about the circle of radius ``major`` in z = 0."""
    if not 0 < minor < major:
        raise GshadeError(f"torus: expected 0 < minor < major, got minor={minor}, major={major}")
    return revolve(circle(minor, centre=(major, 0.0)))
