"""Planes, cylinders, cones, spheres, tori, and surfaces of revolution and extrusion of lines
and B-spline curves of a CAD model as exact NURBS, built by gshade from the kernel's data (no
NURBS conversion of the model).

The kernel parametrises these surfaces by lengths and angles (its ``ElSLib``):

- plane:    S(u, v) = O + u X + v Y
- cylinder: S(u, v) = O + r (cos u X + sin u Y) + v Z
- cone:     S(u, v) = O + (r + v sin a)(cos u X + sin u Y) + v cos a Z
- sphere:   S(u, v) = O + r cos v (cos u X + sin u Y) + r sin v Z
- torus:    S(u, v) = O + (R + r cos v)(cos u X + sin u Y) + r sin v Z
- extrusion:  S(u, v) = C(u) + v D
- revolution: S(u, v) = A + a(v) Z + cos u r(v) + sin u (Z x r(v)), C(v) = A + a(v) Z + r(v)

with the surface's frame O, X, Y, Z (X, Y, Z its X, Y and main directions), the basis curve
C (a line, or a B-spline or Bezier curve: its own poles, weights and knots, the same
parameter), the extrusion's direction D and the revolution's axis (A, Z) (a right-handed turn
by u of the curve's poles, which is exact for a rational curve too).  Over the
face's parameter box, each angle runs along the exact rational arc
:func:`gshade.geometry.patches.revolution.arc` and each length along a line (degree 1); the
surface is their tensor product (P_ij from the arcs' points, weights w_i w_j; Piegl &
Tiller, 8.5), exact to round-off.  The patch's parameter equals the kernel's along lengths
and at the arcs' knots; :meth:`gshade.cad.CadFace.to_patch` maps the rest exactly.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..geometry.patches.bspline import BSplinePatch
from ..geometry.patches.revolution import arc

__all__ = ["ANALYTIC_KINDS", "analytic_patch", "builds"]

#: The surface kinds built here (extrusions and revolutions of some basis curves: see
#: :func:`builds`).
ANALYTIC_KINDS = ("plane", "cylinder", "cone", "sphere", "torus", "extrusion", "revolution")
_SWEPT = ("extrusion", "revolution")

Box = tuple[tuple[float, float], tuple[float, float]]
Arcs = tuple[tuple[float, float] | None, tuple[float, float] | None]


def _xyz(v: Any) -> NDArray[np.float64]:
    return np.array([v.X(), v.Y(), v.Z()], dtype=np.float64)


def _frame(position: Any) -> tuple[NDArray[np.float64], ...]:
    """A gp_Ax3's origin, X, Y and main directions."""
    return (
        _xyz(position.Location()),
        _xyz(position.XDirection()),
        _xyz(position.YDirection()),
        _xyz(position.Direction()),
    )


def _line(a: float, b: float) -> tuple[NDArray, NDArray, NDArray]:
    """A parameter that is a length: points (2,) a, b, weights 1, knots of degree 1."""
    return np.array([a, b]), np.ones(2), np.array([a, a, b, b])


def builds(kind: str, adaptor: Any) -> bool:
    """Whether :func:`analytic_patch` builds this face's surface (a swept surface only when
    its basis curve is a line, a B-spline or a Bezier curve)."""
    if kind not in ANALYTIC_KINDS:
        return False
    if kind not in _SWEPT:
        return True
    from OCP.GeomAbs import GeomAbs_CurveType as T

    curve_type = adaptor.BasisCurve().GetType()
    return curve_type in (T.GeomAbs_Line, T.GeomAbs_BSplineCurve, T.GeomAbs_BezierCurve)


def _basis_curve(adaptor: Any, lo: float, hi: float) -> tuple[NDArray, NDArray, NDArray, int]:
    """The swept surface's basis curve as (poles (n, 3), weights (n,), knots, degree), in
    the kernel's parameter: a line over [lo, hi], or the B-spline (Bezier) curve itself
    (periodic ones unrolled)."""
    from OCP.GeomAbs import GeomAbs_CurveType as T
    from OCP.GeomConvert import GeomConvert

    curve = adaptor.BasisCurve()
    if curve.GetType() == T.GeomAbs_Line:
        line = curve.Line()
        origin, direction = _xyz(line.Location()), _xyz(line.Direction())
        t, w, k = _line(lo, hi)
        return origin + t[:, None] * direction, w, k, 1
    geom = curve.BSpline() if curve.GetType() == T.GeomAbs_BSplineCurve else curve.Bezier()
    if type(geom).__name__ != "Geom_BSplineCurve":
        geom = GeomConvert.CurveToBSplineCurve_s(geom)
    if geom.IsPeriodic():
        geom = geom.Copy()
        geom.SetNotPeriodic()
    n = geom.NbPoles()
    poles = np.array([_xyz(geom.Pole(i)) for i in range(1, n + 1)])
    weights = np.array([geom.Weight(i) for i in range(1, n + 1)], dtype=np.float64)
    sequence = geom.KnotSequence()
    knots = np.array([sequence.Value(i) for i in range(sequence.Lower(), sequence.Upper() + 1)])
    return poles, weights, knots, int(geom.Degree())


def _swept(kind: str, adaptor: Any, box: Box) -> tuple[BSplinePatch, Arcs]:
    """An extrusion (u along the curve, v along D) or a revolution (u the angle, v along
    the curve) as the tensor product of its basis curve with a line or an arc."""
    (u0, u1), (v0, v1) = box
    if kind == "extrusion":
        C, wc, kc, p = _basis_curve(adaptor, u0, u1)
        D = _xyz(adaptor.Direction())
        v, wl, kv = _line(v0, v1)
        P = C[:, None, :] + v[None, :, None] * D
        W = wc[:, None] * wl[None, :]
        return BSplinePatch(P, (p, 1), (kc, kv), W), (None, None)
    axis = adaptor.AxeOfRevolution()
    A, Z = _xyz(axis.Location()), _xyz(axis.Direction())
    C, wc, kc, p = _basis_curve(adaptor, v0, v1)
    axial = (C - A) @ Z
    R = C - A - axial[:, None] * Z  # from the axis to each pole, across it
    ring = arc(u0, u1)
    c, wu = ring.points, np.asarray(ring.weights)
    P = (
        A
        + axial[None, :, None] * Z
        + c[:, 0, None, None] * R[None, :, :]
        + c[:, 1, None, None] * np.cross(Z, R)[None, :, :]
    )
    W = wu[:, None] * wc[None, :]
    return BSplinePatch(P, (2, p), (ring.knots, kc), W), ((u0, u1), None)


def analytic_patch(kind: str, adaptor: Any, box: Box) -> tuple[BSplinePatch, Arcs]:
    """The exact NURBS of a plane, cylinder, cone, sphere, torus (over the face's parameter
    box) or swept surface (:func:`builds`; over its basis curve's domain along the curve),
    and which of its parameters are angles (their ranges).

    Parameters
    ----------
    kind : str
        One of :data:`ANALYTIC_KINDS`.
    adaptor : BRepAdaptor_Surface
        The face's surface (in the model's coordinates: the face's location applied).
    box : ((u0, u1), (v0, v1))
        The face's parameter box in the kernel's parameters.
    """
    (u0, u1), (v0, v1) = box
    if kind in _SWEPT:
        return _swept(kind, adaptor, box)
    if kind == "plane":
        O, X, Y, _ = _frame(adaptor.Plane().Position())
        u, _, ku = _line(u0, u1)
        v, _, kv = _line(v0, v1)
        P = O + u[:, None, None] * X + v[None, :, None] * Y
        return BSplinePatch(P, (1, 1), (ku, kv)), (None, None)
    ring = arc(u0, u1)  # every other kind turns about its axis with u
    c, ku = ring.points, ring.knots
    wu = np.asarray(ring.weights)  # an arc is rational
    cu, su = c[:, 0, None, None], c[:, 1, None, None]
    if kind in ("cylinder", "cone"):
        surface = adaptor.Cylinder() if kind == "cylinder" else adaptor.Cone()
        O, X, Y, Z = _frame(surface.Position())
        v, wl, kv = _line(v0, v1)
        if kind == "cylinder":
            rho, height = np.full(2, surface.Radius()), v
        else:
            a = surface.SemiAngle()
            rho, height = surface.RefRadius() + v * np.sin(a), v * np.cos(a)
        P = O + rho[None, :, None] * (cu * X + su * Y) + height[None, :, None] * Z
        W = wu[:, None] * wl[None, :]
        return BSplinePatch(P, (2, 1), (ku, kv), W), ((u0, u1), None)
    # sphere and torus: v turns too, about a circle in the (rho, z) half-plane
    tube = arc(v0, v1)
    d, kv = tube.points, tube.knots
    wv = np.asarray(tube.weights)
    if kind == "sphere":
        surface = adaptor.Sphere()
        O, X, Y, Z = _frame(surface.Position())
        rho, height = surface.Radius() * d[:, 0], surface.Radius() * d[:, 1]
    else:
        surface = adaptor.Torus()
        O, X, Y, Z = _frame(surface.Position())
        rho = surface.MajorRadius() + surface.MinorRadius() * d[:, 0]
        height = surface.MinorRadius() * d[:, 1]
    P = O + rho[None, :, None] * (cu * X + su * Y) + height[None, :, None] * Z
    W = wu[:, None] * wv[None, :]
    return BSplinePatch(P, (2, 2), (ku, kv), W), ((u0, u1), (v0, v1))
