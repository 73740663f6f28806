"""The four junction measures, their round-off, and where each is largest (Kiciak, ch. 2–3).

At paired points of a junction (a patch boundary, a B-rep edge, a knot line) the two sides'
exact derivatives give, per sample:

- ``gap`` = |p_i - p_j| (G0);
- ``normal_angle_deg`` = the angle between the two *oriented* unit normals,
  atan2(|n_i x n_j|, <n_i, n_j>), 0 to 180 degrees (G1: the same oriented tangent plane,
  Kiciak §2.2; a cusp or a fold, normals 180 degrees apart, is G0);
- ``curvature_jump`` = the largest |eigenvalue| of W_i - W_j, W the shape operator (the
  second fundamental form w.r.t. the oriented normal) written in an orthonormal frame
  (e1, n x e1) of each side's tangent plane, e1 the junction's tangent (G2, Kiciak §2.3).
  With D = W_i - W_j = [[a, b], [b, c]]:
  ``max_e |k_i(e) - k_j(e)| = |a + c| / 2 + sqrt(((a - c) / 2)^2 + b^2)`` exactly (no
  sampled directions); at a G1 junction D = diag(0, c) and this is the jump across the edge;
- ``curvature_gradient_jump`` = max(|grad H_i - grad H_j|, |grad K_i - grad K_j|), the surface
  gradients of the mean (oriented) and Gaussian curvatures (G3, Kiciak §2.4).

Each measure's round-off is estimated per side and sample from the magnitudes that its
evaluation sums (:func:`derivative_round_off`), carried to the measure to first order
(:func:`side_round_off`); a junction's class compares each measure with the larger of the
tolerance and ``ROUND_OFF_SAFETY`` x (side i's + side j's round-off), largest over the samples.

A B-spline side may be evaluated about its own centre (:func:`centred`): the round-off of
its derivatives, and its estimate, then scale with the size of its control net rather than
with its distance from the origin.

Each side is evaluated in its own parametrisation scaled by powers of two per direction
(:func:`derivative_scales`: |p_u|, |p_v| of order 1 over the face), so that the test for an
irregular point, |p_u x p_v| <= ``IRREGULAR_TOL`` s_u s_v, uses the face's own scale, and is
unchanged by the speed of its parametrisation, whatever else is measured with it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..geometry.core.differential import IRREGULAR_TOL, cross_arrays, dot_arrays, solve_first_form
from ..geometry.core.patch import Patch, TensorProductPatch
from ..geometry.evaluation.regularity import toward_interior
from ..geometry.patches.bspline import BSplinePatch
from ..shape import evaluate

__all__ = [
    "MEASURES",
    "ROUND_OFF_SAFETY",
    "Comparison",
    "SideGeometry",
    "centred",
    "compare_sides",
    "derivative_round_off",
    "derivative_scales",
    "junction_fields",
    "shape_operator_jump",
    "side_derivatives",
    "side_geometry",
    "side_round_off",
]

#: The measures, in the order of the classes they decide (G0, G1, G2, G3).
MEASURES = ("gap", "normal_angle_deg", "curvature_jump", "curvature_gradient_jump")
#: The measured round-off is this many times the first-order estimate, at most (see tests).
ROUND_OFF_SAFETY = 8.0
_EPS = float(np.finfo(np.float64).eps)
#: The step toward the domain's centre (relative to its size) at an irregular point.
_OFFSET = 1e-5
#: Grid points per direction for a face's derivative scale.
_SCALE_GRID = 9


def derivative_scales(patch: Patch) -> tuple[float, float]:
    """(s_u, s_v): the least powers of two at least max |p_u| and max |p_v| over a 9 x 9
    grid of the patch's domain (dividing by them is exact: p_u / s_u and p_v / s_v have
    lengths of order 1, on every face alike)."""
    grid = np.asarray(patch.derivatives(*patch.parameter_grid(_SCALE_GRID, _SCALE_GRID), 1))
    with np.errstate(all="ignore"):
        pu = np.linalg.norm(grid[1, 0], axis=-1).ravel()
        pv = np.linalg.norm(grid[0, 1], axis=-1).ravel()
    out = []
    for values in (pu, pv):
        top = float(np.max(values, initial=0.0, where=np.isfinite(values)))
        out.append(2.0 ** np.ceil(np.log2(top)) if top > 0 else 1.0)
    return out[0], out[1]


def centred(patch: Patch) -> tuple[Patch, NDArray | None]:
    """A B-spline patch moved by -c, c the centre of its control points' box, and c (other
    patches as they are, and None).

    The same surface up to the rounding of P - c (at most half an ulp of each difference):
    evaluated there, a derivative's rounding (and :func:`derivative_round_off`) is of order
    eps sum |B^(i)| |P - c|, not eps sum |B^(i)| |P|: on a face of size s far from the
    origin, s / |P| of it (:func:`side_derivatives` with ``origin`` puts positions back).
    A rational patch keeps its weights (sum w B (P - c) / sum w B = p - c)."""
    if not isinstance(patch, BSplinePatch):
        return patch, None
    points = np.asarray(patch.points, dtype=np.float64)
    centre = 0.5 * (points.min(axis=(0, 1)) + points.max(axis=(0, 1)))
    # the same knots, degrees and weights, validated once: a moved copy costs a tenth of a
    # new patch's checks
    return patch.translated(-centre), centre


def _evaluate(patch: Patch, u: NDArray, v: NDArray, order: int) -> NDArray:
    """Derivatives at (u, v); a B-spline beyond its domain continued (end pieces)."""
    if isinstance(patch, BSplinePatch):
        return patch.derivatives_beyond(u, v, order)
    (u0, u1), (v0, v1) = patch.domain
    return np.asarray(patch.derivatives(np.clip(u, u0, u1), np.clip(v, v0, v1), order))


def side_derivatives(
    patch: Patch,
    u: NDArray,
    v: NDArray,
    order: int = 3,
    scales: tuple[float, float] | None = None,
    origin: NDArray | None = None,
) -> tuple[NDArray, NDArray, tuple[float, float]]:
    """Derivatives of order ``order`` at (u, v) in the patch's scaled parametrisation
    (d[i, j] / (s_u^i s_v^j), :func:`derivative_scales`), regularised where irregular, their
    round-off (:func:`derivative_round_off`, scaled alike) and (s_u, s_v).

    A point is irregular where |p_u x p_v| <= IRREGULAR_TOL s_u s_v (the scaled
    |p_u x p_v| <= IRREGULAR_TOL): there the derivatives of order >= 1 are taken a step
    1e-5 x the domain's size toward its centre (their limits up to O(1e-5)); positions stay.
    A B-spline is evaluated beyond its domain where (u, v) lie there (its end pieces
    continued, as the kernel does; a CAD edge's pcurve may stray past its face's box).
    ``scales``: the patch's :func:`derivative_scales`, where known.  ``origin``: the patch
    is the surface moved by -origin (:func:`centred`); the positions are moved back, their
    rounding (eps |p|) added to their round-off.
    """
    u = np.asarray(u, dtype=np.float64).ravel()
    v = np.asarray(v, dtype=np.float64).ravel()
    su, sv = derivative_scales(patch) if scales is None else scales
    power = np.arange(order + 1)
    factor = (1.0 / su ** power[:, None]) * (1.0 / sv ** power[None, :])
    d = _evaluate(patch, u, v, order) * factor[:, :, None, None]
    su2, sv2 = _grow(d, su, sv)  # points beyond the grid's largest speed
    if (su2, sv2) != (su, sv):
        factor2 = (su / su2) ** power[:, None] * (sv / sv2) ** power[None, :]
        d *= factor2[:, :, None, None]
        factor, su, sv = factor * factor2, su2, sv2
    with np.errstate(all="ignore"):
        cross = np.sqrt(dot_arrays(*(2 * [cross_arrays(d[1, 0], d[0, 1])])))
    irregular = ~(cross > IRREGULAR_TOL)
    if irregular.any():
        step = toward_interior(patch, u[irregular], v[irregular]) * _OFFSET
        moved = _evaluate(patch, u[irregular] + step[:, 0], v[irregular] + step[:, 1], order)
        position = d[0, 0][irregular]
        d[:, :, irregular] = moved * factor[:, :, None, None]
        d[0, 0][irregular] = position
    error = derivative_round_off(patch, u, v, order) * factor[:, :, None]
    if origin is not None:
        d[0, 0] += origin
        error[0, 0] += _EPS * np.linalg.norm(d[0, 0], axis=-1)
    return d, error, (su, sv)


def _grow(d: NDArray, su: float, sv: float) -> tuple[float, float]:
    """The scales, doubled until the points' own |p_u|, |p_v| are at most 1 too."""
    with np.errstate(all="ignore"):
        for k, (i, j) in enumerate(((1, 0), (0, 1))):
            top = np.linalg.norm(d[i, j], axis=-1)
            top_value = float(np.max(top, initial=0.0, where=np.isfinite(top)))
            if top_value > 1.0:
                grow = 2.0 ** np.ceil(np.log2(top_value))
                su, sv = (su * grow, sv) if k == 0 else (su, sv * grow)
    return su, sv


def derivative_round_off(patch: Patch, u: NDArray, v: NDArray, order: int = 3) -> NDArray:
    """An estimate of the rounding error of each derivative d[i, j] at (u, v), shape
    (order + 1, order + 1, N), in the patch's own parametrisation.

    A tensor-product patch sums B_a^(i)(u) B_b^(j)(v) P_ab: the error of a sum of n terms,
    its data (the control points, themselves rounded) and its basis values each within a few
    ulps, is bounded by ~ n eps sum |B_a^(i)| |B_b^(j)| |P_ab| (Higham, *Accuracy and
    Stability of Numerical Algorithms*, §3.1), with n = (p + 1) + (q + 1) for the two nested
    sums.  A rational patch's quotient (w P)^(i,j) / w adds |p| sum |B^(i)| |B^(j)| w_ab,
    and 2^(i+j) for the lower derivatives it subtracts.  Other patches (Coons, subdivision):
    ~ 8 eps max|p| (3 / du)^i (3 / dv)^j over the domain's sizes du, dv.
    """
    u = np.asarray(u, dtype=np.float64).ravel()
    v = np.asarray(v, dtype=np.float64).ravel()
    n = len(u)
    out = np.zeros((order + 1, order + 1, n))
    if not isinstance(patch, TensorProductPatch):
        (u0, u1), (v0, v1) = patch.domain
        size = float(np.abs(np.asarray(patch(*patch.parameter_grid(5, 5)))).max())
        for i in range(order + 1):
            for j in range(order + 1 - i):
                out[i, j] = 8 * _EPS * size * (3.0 / (u1 - u0)) ** i * (3.0 / (v1 - v0)) ** j
        return out
    fu, bu = patch._bu.local(u, order)  # (N,), (order + 1, N, ku): the spans' basis values
    fv, bv = patch._bv.local(v, order)
    rows = fu[:, None, None] + np.arange(bu.shape[-1])[None, :, None]
    cols = fv[:, None, None] + np.arange(bv.shape[-1])[None, None, :]
    net = np.asarray(patch._net, dtype=np.float64)
    local = np.linalg.norm(net[..., :3], axis=-1)[rows, cols]  # |w P| (or |P|), (N, ku, kv)
    au, av = np.abs(bu), np.abs(bv)
    terms = (bu.shape[-1] + bv.shape[-1]) * _EPS
    rational = patch.weights is not None
    if rational:
        weights = net[..., 3][rows, cols]
        w = np.abs(np.einsum("na,nb,nab->n", bu[0], bv[0], weights))
        size = np.einsum("na,nb,nab->n", au[0], av[0], local) / w  # ~ |p|
    for i in range(order + 1):
        for j in range(order + 1 - i):
            m = np.einsum("na,nb,nab->n", au[i], av[j], local)
            if rational:
                m = (m + size * np.einsum("na,nb,nab->n", au[i], av[j], np.abs(weights))) / w
                m *= 2.0 ** (i + j)
            out[i, j] = terms * m
    return out


class SideGeometry(NamedTuple):
    """One side of many junctions at their samples: derivatives d (4, 4, ..., 3) (scaled
    parametrisation), oriented unit normals n, the oriented mean and the Gaussian
    curvature's surface gradients (..., 3), and the round-off of position, normal
    (radians), normal curvature and curvature gradient (each (..., 4))."""

    d: NDArray
    n: NDArray
    mean_gradient: NDArray
    gauss_gradient: NDArray
    round_off: NDArray


def side_geometry(d: NDArray, error: NDArray, orientation: NDArray | float = 1.0) -> SideGeometry:
    """Normals, curvature gradients and round-off from derivatives ``d`` (4, 4, ..., 3) and
    their round-off ``error`` (4, 4, ...) (:func:`side_derivatives`); ``orientation`` (+1
    or -1 per point, or one number) turns p_u x p_v into the oriented (outward) normal."""
    orient = np.asarray(orientation, dtype=np.float64)
    with np.errstate(all="ignore"):
        N = cross_arrays(d[1, 0], d[0, 1])
        length = np.sqrt(dot_arrays(N, N))
    length = np.where(length > 0, length, 1.0)
    n = N / length[..., None] * np.broadcast_to(orient, length.shape)[..., None]
    mean, gauss, H, K = _curvature_gradients(d)
    mean = mean * np.broadcast_to(orient, length.shape)[..., None]
    kappa = np.abs(H) + np.sqrt(np.maximum(H * H - K, 0.0))  # the larger |k1|, |k2|
    slope = np.linalg.norm(mean, axis=-1)
    return SideGeometry(d, n, mean, gauss, side_round_off(d, error, kappa, slope))


def _curvature_gradients(d: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """The surface gradients of H (w.r.t. p_u x p_v) and K, and H and K, at every point of
    ``d`` (scaled
    derivatives, :func:`side_derivatives`), by the shape functions ``mean`` and
    ``gaussian``.  One point with p_u = (1, 0, 0), p_v = (0, 1, 0) goes along: ``evaluate``
    takes its irregular-point threshold from the largest first-derivative component of what
    it is given, so with it the threshold is IRREGULAR_TOL exactly (the scaled components
    are at most 1), the rule of :func:`side_derivatives`, on every batch alike."""
    shape = d.shape[2:-1]
    count = int(np.prod(shape))
    # component-major (each coordinate's values contiguous, as Patch.derivatives gives
    # them): the shape kernels take those without a copy, and a copy costs a new kernel
    buf = np.zeros((d.shape[0], d.shape[1], 3, count + 1))
    buf[..., :count] = np.moveaxis(d.reshape(d.shape[0], d.shape[1], count, 3), -1, 2)
    buf[1, 0, 0, count] = buf[0, 1, 1, count] = 1.0
    flat = np.moveaxis(buf, 2, -1)
    mean = evaluate("mean", flat)
    gauss = evaluate("gaussian", flat)
    assert mean.gradient is not None and gauss.gradient is not None  # asked for by default
    return (
        mean.gradient[:-1].reshape(*shape, 3),
        gauss.gradient[:-1].reshape(*shape, 3),
        mean.f[:-1].reshape(shape),
        gauss.f[:-1].reshape(shape),
    )


def side_round_off(d: NDArray, error: NDArray, kappa: NDArray, slope: NDArray) -> NDArray:
    """First-order round-off of each measure's share on one side, (..., 4): position,
    normal (radians), normal curvature, curvature gradient (the larger of the mean's and
    the Gaussian's).

    With sigma the smallest singular value of [p_u p_v] (sigma^2 the smaller eigenvalue of
    the first fundamental form), e_k the largest round-off of the derivatives of order
    k = i + j (:func:`derivative_round_off`), ``kappa`` the larger |principal curvature| and
    ``slope`` |grad H| at the point: normal e_1 / sigma; curvature
    c = e_2 / sigma^2 + 2 kappa e_1 / sigma; mean-curvature gradient
    g = e_3 / sigma^3 + 3 kappa e_2 / sigma^2 + 3 (slope + kappa^2) e_1 / sigma; Gaussian
    curvature gradient 2 kappa g + 2 slope c (each a derivative's error over its scale,
    times the value it multiplies; the leading terms of the formulas' derivatives).
    """
    with np.errstate(all="ignore"):
        pu, pv = d[1, 0], d[0, 1]
        E, F, G = dot_arrays(pu, pu), dot_arrays(pu, pv), dot_arrays(pv, pv)
        s2 = 0.5 * (E + G) - np.sqrt(0.25 * (E - G) ** 2 + F * F)
        s = np.sqrt(np.maximum(s2, np.finfo(np.float64).tiny))
        e = [np.maximum.reduce([error[i, k - i] for i in range(k + 1)]) for k in range(4)]
        normal = e[1] / s
        curvature = e[2] / s**2 + 2 * kappa * normal
        mean = e[3] / s**3 + 3 * kappa * e[2] / s**2 + 3 * (slope + kappa**2) * normal
        gauss = 2 * kappa * mean + 2 * slope * curvature
        out = np.stack([e[0], normal, curvature, np.maximum(mean, gauss)], axis=-1)
    return np.where(np.isfinite(out), out, np.inf)


def shape_operator_jump(
    side_i: SideGeometry, side_j: SideGeometry, along: NDArray
) -> tuple[NDArray, NDArray]:
    """The curvature jump max_e |k_i(e) - k_j(e)| exactly, and the direction e (in side i's
    tangent plane) where it is reached.

    Each side's shape operator in the orthonormal frame (e1, n x e1), e1 the unit tangent
    ``along`` the junction projected into that side's tangent plane: W_kl = II(e_k, e_l), the
    frame's vectors written a p_u + b p_v by the first form (:func:`solve_first_form`) and II
    w.r.t. the oriented normal.  D = W_i - W_j = [[a, b], [b, c]]; its largest |eigenvalue|
    is |a + c| / 2 + sqrt(((a - c) / 2)^2 + b^2) (the frames are matched by turning side j's
    plane about e1 onto side i's: the same at a G1 point).
    """
    frames = []
    for side in (side_i, side_j):
        d, n = side.d, side.n
        e1 = along - dot_arrays(along, n)[..., None] * n
        length = np.sqrt(dot_arrays(e1, e1))
        e1 = e1 / np.where(length > 0, length, 1.0)[..., None]
        e2 = cross_arrays(n, e1)
        pu, pv = d[1, 0], d[0, 1]
        E, F, G = dot_arrays(pu, pu), dot_arrays(pu, pv), dot_arrays(pv, pv)
        det = E * G - F * F
        det = np.where(det > 0, det, 1.0)
        L, M, N = dot_arrays(d[2, 0], n), dot_arrays(d[1, 1], n), dot_arrays(d[0, 2], n)
        a1, b1 = solve_first_form(E, F, G, det, dot_arrays(pu, e1), dot_arrays(pv, e1))
        a2, b2 = solve_first_form(E, F, G, det, dot_arrays(pu, e2), dot_arrays(pv, e2))
        w11 = L * a1 * a1 + 2 * M * a1 * b1 + N * b1 * b1
        w22 = L * a2 * a2 + 2 * M * a2 * b2 + N * b2 * b2
        w12 = L * a1 * a2 + M * (a1 * b2 + a2 * b1) + N * b1 * b2
        frames.append((w11, w12, w22, e1, e2))
    a = frames[0][0] - frames[1][0]
    b = frames[0][1] - frames[1][1]
    c = frames[0][2] - frames[1][2]
    half = 0.5 * (a + c)
    root = np.hypot(0.5 * (a - c), b)
    jump = np.abs(half) + root
    top = half + np.where(half >= 0, root, -root)  # the eigenvalue of the larger |value|
    x1, y1 = b, top - a  # (D - top) x = 0: two candidate null vectors, the longer one
    x2, y2 = top - c, b
    first = x1 * x1 + y1 * y1 >= x2 * x2 + y2 * y2
    x, y = np.where(first, x1, x2), np.where(first, y1, y2)
    norm = np.hypot(x, y)
    x = np.where(norm > 0, x / np.where(norm > 0, norm, 1.0), 1.0)
    y = np.where(norm > 0, y / np.where(norm > 0, norm, 1.0), 0.0)
    e1, e2 = frames[0][3], frames[0][4]
    return jump, x[..., None] * e1 + y[..., None] * e2


class Comparison(NamedTuple):
    """Many junctions compared, (J, S) samples each: per measure (in :data:`MEASURES`'
    order) the largest value over the samples (J, 4), the sample where it is (J, 4), and
    the round-off (J, 4) (``ROUND_OFF_SAFETY`` x both sides', largest over the samples); the
    direction of the largest curvature jump (J, 3) at its sample."""

    values: NDArray
    where: NDArray
    round_off: NDArray
    jump_direction: NDArray


def compare_sides(side_i: SideGeometry, side_j: SideGeometry, along: NDArray) -> Comparison:
    """The four measures (see the module's docstring) of J junctions at S paired samples:
    sample s of junction m on side i (arrays (4, 4, J, S, 3), (J, S, 3), ...) with sample s
    on side j; ``along`` (J, S, 3) a tangent of the junction on side i (any length; where
    zero, p_u + p_v stands in)."""
    di, dj = side_i.d, side_j.d
    ni, nj = side_i.n, side_j.n
    gap = np.linalg.norm(di[0, 0] - dj[0, 0], axis=-1)
    # atan2 of |cross| and dot: accurate for tiny angles, and 0 to 180 degrees
    angle = np.degrees(
        np.arctan2(np.linalg.norm(cross_arrays(ni, nj), axis=-1), dot_arrays(ni, nj))
    )
    length = np.linalg.norm(along, axis=-1, keepdims=True)
    if not (length > 0).all():  # no tangent (a degenerate sample): any tangent-plane frame
        along = np.where(length > 0, along, di[1, 0] + di[0, 1])
    jump, direction = shape_operator_jump(side_i, side_j, along)
    grad_h = np.linalg.norm(side_i.mean_gradient - side_j.mean_gradient, axis=-1)
    grad_k = np.linalg.norm(side_i.gauss_gradient - side_j.gauss_gradient, axis=-1)
    per_sample = np.stack([gap, angle, jump, np.where(grad_k > grad_h, grad_k, grad_h)], -1)
    with np.errstate(invalid="ignore"):
        ranked = np.where(np.isnan(per_sample), -np.inf, per_sample)
    where = np.argmax(ranked, axis=1)  # (J, 4): the first sample of the largest value
    values = np.take_along_axis(per_sample, where[:, None, :], axis=1)[:, 0]
    noise = side_i.round_off + side_j.round_off
    noise[..., 1] = np.degrees(noise[..., 1])
    round_off = ROUND_OFF_SAFETY * noise.max(axis=1)
    at = where[:, 2][:, None, None]
    jump_direction = np.take_along_axis(direction, at, axis=1)[:, 0]
    return Comparison(values, where, round_off, jump_direction)


def junction_fields(
    cmp: Comparison, m: int, t: NDArray, points: NDArray, uv: NDArray
) -> tuple[dict, dict, dict]:
    """Junction ``m`` of a comparison as the report gives it: its four measures, their
    round-off, and ``max_at``: per measure the sample where it is largest, ``t`` (the
    fraction along the junction, ``t[s]``), ``point`` (side i's point there, ``points``
    (J, S, 3)) and ``uv`` (side i's parameters, ``uv`` (J, S, 2)); the curvature jump's also
    ``direction`` (the unit tangent of side i where the normal curvatures differ most)."""
    measures = {name: float(cmp.values[m, k]) for k, name in enumerate(MEASURES)}
    round_off = {name: float(cmp.round_off[m, k]) for k, name in enumerate(MEASURES)}
    where: dict = {}
    for k, name in enumerate(MEASURES):
        s = int(cmp.where[m, k])
        where[name] = {
            "t": float(t[s]),
            "point": [float(x) for x in points[m, s]],
            "uv": [float(x) for x in uv[m, s]],
        }
    where["curvature_jump"]["direction"] = [float(x) for x in cmp.jump_direction[m]]
    return measures, round_off, where
