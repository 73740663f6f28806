"""Exact rational surfaces of revolution: circles as NURBS, spheres, cylinders, tori.

A circle is a rational quadratic B-spline (four quarter arcs with weights 1, sqrt(2)/2, 1;
Piegl & Tiller, section 7.5).  Revolving a profile curve (rho(t), z(t)) about the z axis
gives the tensor-product NURBS with P_ij = (rho_i c_j^x, rho_i c_j^y, z_i) and weights
w_i w_j (Kiciak, A.4), exact to round-off.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...errors import GshadeError
from .bspline import BSplineCurve, BSplinePatch

__all__ = ["arc", "arc_parameters", "circle", "cylinder", "revolve", "sphere", "torus"]

_S = np.sqrt(0.5)
#: The unit circle's weights (:func:`circle`).
_CIRCLE_WEIGHTS = np.array([1, _S, 1, _S, 1, _S, 1, _S, 1])


def circle(radius: float = 1.0, centre: ArrayLike = (0.0, 0.0)) -> BSplineCurve:
    """A full circle as a planar rational quadratic B-spline over [0, 1], counter-clockwise
    from (centre + (radius, 0))."""
    c = np.array(
        [[1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1], [1, 0]], dtype=float
    )
    knots = [0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1]
    return BSplineCurve(np.asarray(centre, float) + radius * c, 2, knots, _CIRCLE_WEIGHTS)


#: How far (relative) an arc may exceed a full turn (0.063 rad, 3.6 degrees): the parameter
#: box of a periodic CAD face, which its trimming curves bound, passes a full turn by up to
#: the file's tolerance (Fusion 360: -pi to pi + 6.7e-11 rad, -pi - 5.1e-5 to pi + 6e-6 rad
#: on a cylinder of a 800-face part; NX 10: 2 pi + 0.006 rad on four faces of a 1,040-face
#: part); the arc then covers its start twice over that sliver, which the trims cut off.
#: Far below a turn's last quarter.
TURN_OVERSHOOT = 1e-2


def _arc_segments(a0: float, a1: float) -> tuple[int, float]:
    """The number of equal segments of the arc from a0 to a1 (each at most a quarter turn)
    and their angle."""
    count = max(1, int(np.ceil((a1 - a0) / (0.5 * np.pi) - 1e-9)))
    return count, (a1 - a0) / count


def arc(a0: float, a1: float) -> BSplineCurve:
    """The unit circle's arc from angle a0 to a1 (a0 < a1 <= a0 + 2 pi), exact: rational
    quadratic segments of equal angle Delta <= pi/2 with weights 1, cos(Delta/2), 1 (Piegl &
    Tiller, section 7.5), the knots (double inside) at the segments' end angles, so that
    the parameter equals the angle at every knot; between knots see :func:`arc_parameters`.

    A full turn may overshoot 2 pi by :data:`TURN_OVERSHOOT` of it, as CAD faces' parameter
    boxes do (Fusion 360: -pi to pi + 6.7e-11); the arc then covers its start twice over
    that sliver.
    """
    if not (
        np.isfinite(a0) and np.isfinite(a1) and a0 < a1 <= a0 + 2 * np.pi * (1 + TURN_OVERSHOOT)
    ):
        raise GshadeError(f"arc: expected a0 < a1 <= a0 + 2 pi, got a0={a0!r}, a1={a1!r}")
    count, delta = _arc_segments(a0, a1)
    ends = a0 + delta * np.arange(count + 1)
    middle = ends[:-1] + 0.5 * delta
    points = np.empty((2 * count + 1, 2))
    points[0::2] = np.stack([np.cos(ends), np.sin(ends)], -1)
    points[1::2] = np.stack([np.cos(middle), np.sin(middle)], -1) / np.cos(0.5 * delta)
    weights = np.ones(2 * count + 1)
    weights[1::2] = np.cos(0.5 * delta)
    knots = np.concatenate([[a0] * 3, np.repeat(ends[1:-1], 2), [a1] * 3])
    knots[-3:] = a1
    return BSplineCurve(points, 2, knots, weights)


def arc_parameters(angle: ArrayLike, a0: float, a1: float) -> NDArray[np.float64]:
    """The parameters of :func:`arc` (a0, a1) at which it passes through the given angles.

    In a segment from angle b of angle Delta, the rational quadratic with middle weight
    c = cos(Delta/2) reaches angle b + phi at the local parameter
    tau = t / (s + t (1 - c)), t = tan(phi / 2), s = sin(Delta/2) (its angle obeys
    tan(phi/2) = tau s / ((1 - tau) + tau c)); the parameter is b + tau Delta.

    Examples
    --------
    >>> import numpy as np
    >>> t = arc_parameters(np.pi / 6, 0.0, np.pi / 2)  # where the quarter arc is at 30°
    >>> np.round(arc(0.0, np.pi / 2)(t), 12).tolist()
    [0.866025403784, 0.5]
    """
    angle = np.asarray(angle, dtype=np.float64)
    count, delta = _arc_segments(a0, a1)
    k = np.clip(np.floor((angle - a0) / delta), 0, count - 1)
    start = a0 + k * delta
    t = np.tan(0.5 * (angle - start))
    tau = t / (np.sin(0.5 * delta) + t * (1.0 - np.cos(0.5 * delta)))
    return start + tau * delta


def revolve(profile: BSplineCurve) -> BSplinePatch:
    """Revolve a planar profile (rho, z) once about the z axis.

    u runs along the profile, v around the axis (v = 0 in the xz plane, counter-clockwise
    seen from +z).  The profile may be rational; rho = 0 gives a collapsed edge (a pole).

    Examples
    --------
    A cone: the segment from (rho, z) = (1, 0) to (0, 1), revolved; halfway up, a circle of
    radius 1/2.

    >>> import numpy as np
    >>> from gshade.geometry import BSplineCurve, revolve
    >>> cone = revolve(BSplineCurve([[1, 0], [0, 1]], 1, [0, 0, 1, 1]))
    >>> ring = cone(0.5, [0.1, 0.2, 0.6, 0.9])
    >>> np.round(np.hypot(ring[:, 0], ring[:, 1]), 12).tolist()
    [0.5, 0.5, 0.5, 0.5]
    >>> np.round(ring[:, 2], 12).tolist()
    [0.5, 0.5, 0.5, 0.5]
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
    """The sphere of the given radius about the origin; u from the south to the north pole.

    Examples
    --------
    >>> import numpy as np
    >>> u, v = np.random.default_rng(0).random((2, 4))
    >>> np.round(np.linalg.norm(sphere(2.0)(u, v), axis=-1), 12).tolist()
    [2.0, 2.0, 2.0, 2.0]
    """
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
