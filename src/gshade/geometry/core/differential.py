"""Differential geometry of a patch from its exact derivatives (Kiciak, Appendix A.10;
do Carmo, *Differential Geometry of Curves and Surfaces*, §3-2 and §3-3).

The formulas are written once, in the first section below, generic over the number type:
numpy or Dr.Jit arrays, or jets (:mod:`gshade.geometry.core.jets`, values carrying their u and v
derivatives through +, -, * and /).  The numpy functions of this module, the shape
functions' curvatures and surface gradients (:mod:`gshade.shape`) and the junction measures
(:mod:`gshade.analysis.continuity`) all call them.  The numpy functions take a derivatives
array ``d`` as returned by ``Patch.derivatives`` (shape ``(order + 1, order + 1, ..., 3)``)
and work on any number of points at once.

Conventions: N = p_u x p_v, n = N / |N|; E = <p_u, p_u>, F = <p_u, p_v>, G = <p_v, p_v>;
L = <p_uu, n>, M = <p_uv, n>, N = <p_vv, n>;
K = (LN - M^2) / (EG - F^2), H = (EN - 2FM + GL) / (2 (EG - F^2)); k1 >= k2.
Because EG - F^2 = |p_u x p_v|^2, K and H are computed from the unnormalised normal:
K = (L'N' - M'^2) / |N|^4 and H = (E N' - 2 F M' + G L') / (2 |N|^3) with L' = <p_uu, N> etc.

At irregular points (|p_u x p_v| = 0, e.g. a collapsed patch edge) the formulas divide by
zero.  :func:`unit_normal` then returns the limit normal from higher derivatives; the
curvature functions return finite numbers there (never NaN), which are limits only if the
derivatives were regularised first (:func:`gshade.geometry.regularised_derivatives`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...errors import GshadeError

__all__ = [
    "Forms",
    "PrincipalCurvatures",
    "cross",
    "derivative_scale",
    "derivative_scales",
    "dot",
    "first_form",
    "first_form_det",
    "first_fundamental_form",
    "form_at",
    "fundamental_forms",
    "gaussian_curvature",
    "gaussian_from_forms",
    "irregular_mask",
    "mean_curvature",
    "mean_from_forms",
    "normal_curvature",
    "principal_curvatures",
    "principal_half_gap",
    "principal_terms",
    "second_form",
    "second_fundamental_form",
    "solve_first_form",
    "unit_normal",
]

#: |p_u x p_v| below this times the squared derivative scale marks an irregular point.
IRREGULAR_TOL = 1e-8
#: Points per chunk in the curvature formulas (temporaries stay in cache).
_CHUNK = 1 << 14
#: The least |p_u x p_v|^2 the numpy curvatures divide by (finite, never NaN).
_TINY = np.finfo(np.float64).tiny ** 0.25

#: a number of the generic formulas: a numpy or Dr.Jit array, a float, or a jet
Num = Any

# --------------------------------------------------------------------------- the formulas
# Generic over the number type (only +, -, * and /, and a ``sqrt`` where one is passed);
# vectors are sequences of three components.  Jets divide by multiplying with 1 / b, numpy
# arrays divide exactly: the same formula rounds alike on each type, not across types.


def dot(a: Sequence[Num], b: Sequence[Num]) -> Num:
    """Scalar product <a, b> = a_x b_x + a_y b_y + a_z b_z."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a: Sequence[Num], b: Sequence[Num]) -> tuple[Num, Num, Num]:
    """Vector product a x b = (a_y b_z - a_z b_y, a_z b_x - a_x b_z, a_x b_y - a_y b_x)."""
    return (
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    )


def first_form(pu: Sequence[Num], pv: Sequence[Num]) -> tuple[Num, Num, Num]:
    """First fundamental form E = <p_u, p_u>, F = <p_u, p_v>, G = <p_v, p_v> (Kiciak A.10)."""
    return dot(pu, pu), dot(pu, pv), dot(pv, pv)


def first_form_det(E: Num, F: Num, G: Num) -> Num:
    """det I = EG - F^2, which equals |p_u x p_v|^2 (Lagrange's identity)."""
    return E * G - F * F


def second_form(
    puu: Sequence[Num], puv: Sequence[Num], pvv: Sequence[Num], n: Sequence[Num]
) -> tuple[Num, Num, Num]:
    """Second fundamental form L = <p_uu, n>, M = <p_uv, n>, N = <p_vv, n> w.r.t. the normal
    n, unit or not (Kiciak A.10; do Carmo §3-3)."""
    return dot(puu, n), dot(puv, n), dot(pvv, n)


class Forms(NamedTuple):
    """Both fundamental forms: E, F, G; L, M, N w.r.t. a normal of length w (1 or |N|);
    W2 = det I = EG - F^2."""

    E: Num
    F: Num
    G: Num
    L: Num
    M: Num
    N: Num
    W2: Num


def fundamental_forms(
    pu: Sequence[Num],
    pv: Sequence[Num],
    puu: Sequence[Num],
    puv: Sequence[Num],
    pvv: Sequence[Num],
) -> Forms:
    """Both forms, the second w.r.t. the unnormalised N = p_u x p_v (w = |N|), W2 = <N, N>."""
    normal = cross(pu, pv)
    W2 = dot(normal, normal)
    E, F, G = first_form(pu, pv)
    L, M, N = second_form(puu, puv, pvv, normal)
    return Forms(E, F, G, L, M, N, W2)


def gaussian_from_forms(f: Forms) -> Num:
    """Gaussian curvature K = (LN - M^2) / (EG - F^2) (do Carmo §3-3).

    ``f`` is w.r.t. N = p_u x p_v (:func:`fundamental_forms`), so K = (L'N' - M'^2) / W^4,
    computed as (L'N' - M'^2) (1 / W2)^2.
    """
    inv2 = 1.0 / f.W2
    return (f.L * f.N - f.M * f.M) * (inv2 * inv2)


def mean_from_forms(f: Forms, w: Num | None = None) -> Num:
    """Mean curvature H = (EN - 2FM + GL) / (2 (EG - F^2) w) (do Carmo §3-3).

    Signed w.r.t. the normal of L, M, N; ``w`` is that normal's length: |N| = sqrt(W2) for
    :func:`fundamental_forms`, None for a unit normal.
    """
    return (f.E * f.N - 2.0 * (f.F * f.M) + f.G * f.L) / (2.0 * (f.W2 if w is None else f.W2 * w))


def principal_terms(f: Forms) -> tuple[Num, Num]:
    """gap = GL - EN and twist = (GM - FN)(EM - FL), the shape operator's parts.

    S = I^-1 II has S11 - S22 = gap / (W2 w) and S12 S21 = twist / (W2 w)^2, and
    ((k1 - k2) / 2)^2 = ((S11 - S22) / 2)^2 + S12 S21: no cancellation near umbilics, unlike
    H^2 - K (do Carmo §3-3).
    """
    return f.G * f.L - f.E * f.N, (f.G * f.M - f.F * f.N) * (f.E * f.M - f.F * f.L)


def principal_half_gap(f: Forms, sqrt: Callable[[Num], Num]) -> Num:
    """(k1 - k2) / 2 = sqrt((gap^2 / 4 + twist) / W2^3) for forms w.r.t. N = p_u x p_v.

    The principal curvatures are k1,2 = H ± it (:func:`principal_terms`); ``sqrt`` is the
    number type's, taking negative round-off to 0.
    """
    gap, twist = principal_terms(f)
    inv2 = 1.0 / f.W2
    return sqrt((0.25 * (gap * gap) + twist) * ((inv2 * inv2) * inv2))


def solve_first_form(E: Num, F: Num, G: Num, det: Num, x: Num, y: Num) -> tuple[Num, Num]:
    """(a, b) with I (a, b) = (x, y): ((G x - F y) / det, (E y - F x) / det), det = EG - F^2.

    With (x, y) = (f_u, f_v), a p_u + b p_v is the surface gradient of f (Kiciak ch. 6); with
    (x, y) = (<p_u, e>, <p_v, e>), (a, b) are the parameters of the tangent vector e.
    """
    return (G * x - F * y) / det, (E * y - F * x) / det


def form_at(A: Num, B: Num, C: Num, a: Num, b: Num) -> Num:
    """A quadratic form at (a, b): A a^2 + 2 B a b + C b^2 (I(a, b) or II(a, b))."""
    return A * a * a + 2 * B * a * b + C * b * b


# --------------------------------------------------------------------------- numpy arrays


def _order_of(d: NDArray, needed: int, what: str) -> None:
    if d.ndim < 3 or d.shape[0] != d.shape[1] or d.shape[-1] != 3:
        raise GshadeError(f"derivatives: expected shape (order+1, order+1, ..., 3), got {d.shape}")
    if d.shape[0] - 1 < needed:
        raise GshadeError(
            f"derivatives: {what} needs derivatives of order {needed}, got order {d.shape[0] - 1}"
        )


def _xyz(a: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """The components of vectors along the last axis, as the formulas take them."""
    return a[..., 0], a[..., 1], a[..., 2]


def cross_arrays(a: NDArray, b: NDArray) -> NDArray:
    """:func:`cross` of (..., 3) arrays into one (..., 3) array, written in place: on large
    arrays the generic form's temporaries (one per product, then a stack) cost more."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    np.multiply(ay, bz, out=out[..., 0])
    out[..., 0] -= az * by
    np.multiply(az, bx, out=out[..., 1])
    out[..., 1] -= ax * bz
    np.multiply(ax, by, out=out[..., 2])
    out[..., 2] -= ay * bx
    return out


def dot_arrays(a: NDArray, b: NDArray) -> NDArray:
    """:func:`dot` of (..., 3) arrays."""
    return dot(_xyz(a), _xyz(b))


def derivative_scale(d: NDArray) -> float:
    """A length scale of the first derivatives: the largest |component| of p_u or p_v."""
    s = 0.0
    for x in (d[1, 0], d[0, 1]):
        if x.size:
            s = max(s, float(np.max(x)), -float(np.min(x)))
    return s if s > 0 else 1.0


def derivative_scales(d: NDArray, groups: ArrayLike) -> NDArray[np.float64]:
    """:func:`derivative_scale` of each group of points (``groups``: an integer per point,
    broadcast to the points' shape, e.g. each point's patch), given at every point: many
    patches' points at once, each on its own patch's scale."""
    both = np.maximum(np.abs(d[1, 0]), np.abs(d[0, 1]))  # (..., 3)
    shape = both.shape[:-1]
    groups = np.asarray(groups)
    groups = groups.reshape((1,) * (len(shape) - groups.ndim) + groups.shape)
    # the axes along which the groups do not change are reduced first, with the components
    # (a group per patch of a grid: one reduction over its trailing axes)
    alike = tuple(a for a in range(len(shape)) if groups.shape[a] == 1 < shape[a])
    if alike:
        largest = both.max(axis=(*alike, len(shape)), keepdims=True)[..., 0]
    else:  # the largest component, element-wise (a reduction over 3 is slow)
        largest = np.maximum(np.maximum(both[..., 0], both[..., 1]), both[..., 2])
    keys, place = np.unique(np.broadcast_to(groups, largest.shape), return_inverse=True)
    scale = np.zeros(keys.size)
    np.maximum.at(scale, place.ravel(), largest.ravel())
    kept = np.where(scale > 0, scale, 1.0)[place].reshape(largest.shape)
    return np.broadcast_to(kept, shape)


def irregular_mask(
    d: ArrayLike, tol: float = IRREGULAR_TOL, scale: ArrayLike | None = None
) -> NDArray[np.bool_]:
    """True where the parametrisation is irregular: |p_u x p_v| <= tol * scale^2.

    The scale is the largest first-derivative component in ``d`` (:func:`derivative_scale`),
    so that a collapsed edge (where p_u or p_v vanishes up to round-off) is recognised in
    any units; or ``scale``, per point (broadcast to the points' shape), such as
    :func:`derivative_scales`.
    """
    d = np.asarray(d)
    _order_of(d, 1, "the regularity test")
    N = cross_arrays(d[1, 0], d[0, 1])
    scale2 = derivative_scale(d) ** 2 if scale is None else np.asarray(scale, np.float64) ** 2
    return np.sqrt(dot_arrays(N, N)) <= tol * scale2


class Normal(NamedTuple):
    """Unit normals and where they are regular."""

    n: NDArray[np.float64]
    regular: NDArray[np.bool_]


def unit_normal(
    d: ArrayLike,
    toward: ArrayLike | None = None,
    tol: float = IRREGULAR_TOL,
    scale: ArrayLike | None = None,
) -> Normal:
    """Unit normal n = (p_u x p_v) / |p_u x p_v|, with limits at irregular points.

    Parameters
    ----------
    d : ndarray, shape (order + 1, order + 1, ..., 3)
        Derivatives; order >= 1 (>= 2 or 3 for limits at irregular points).
    toward : array_like, shape (..., 2), optional
        A parameter direction (du, dv) pointing from each point into the patch's domain.
        At an irregular point the normal is the limit of n(u + t du, v + t dv) as t -> 0+,
        from the Taylor expansion of p_u x p_v (first order needs d of order 2, second
        order needs order 3).  Without it, (1, 1) is used: right on the edges u = u0 and
        v = v0, opposite on u = u1 and v = v1.  ``Patch`` users should call
        :func:`gshade.geometry.core.patch_normals`, which supplies it.
    scale : array_like, shape (...), optional
        The length scale each point's regularity is judged on (default: one for all,
        :func:`derivative_scale` of ``d``; per patch: :func:`derivative_scales`).

    Returns
    -------
    Normal
        ``n`` (shape (..., 3), unit length everywhere, never NaN) and ``regular`` (bool).
    """
    d = np.asarray(d)
    _order_of(d, 1, "the normal")
    pu, pv = d[1, 0], d[0, 1]
    N = cross_arrays(pu, pv)
    length = np.sqrt(dot_arrays(N, N))
    scale2 = derivative_scale(d) ** 2 if scale is None else np.asarray(scale, np.float64) ** 2
    regular = length > tol * scale2
    if not regular.all():
        irr = ~regular
        a, b = np.ones(irr.shape), np.ones(irr.shape)
        if toward is not None:
            tw = np.broadcast_to(np.asarray(toward, dtype=np.float64), (*irr.shape, 2))
            a, b = tw[..., 0], tw[..., 1]
        a, b = a[irr], b[irr]
        fixed = N[irr]
        fixed_len = length[irr]
        scale2 = np.broadcast_to(scale2, irr.shape)[irr]
        order = d.shape[0] - 1
        take = lambda i, j: d[i, j][irr]  # noqa: E731
        terms = []
        if order >= 2:
            Nu = cross_arrays(take(2, 0), take(0, 1)) + cross_arrays(take(1, 0), take(1, 1))
            Nv = cross_arrays(take(1, 1), take(0, 1)) + cross_arrays(take(1, 0), take(0, 2))
            terms.append(a[:, None] * Nu + b[:, None] * Nv)
        if order >= 3:
            Nuu = (
                cross_arrays(take(3, 0), take(0, 1))
                + 2 * cross_arrays(take(2, 0), take(1, 1))
                + cross_arrays(take(1, 0), take(2, 1))
            )
            Nuv = (
                cross_arrays(take(2, 1), take(0, 1))
                + cross_arrays(take(2, 0), take(0, 2))
                + cross_arrays(take(1, 0), take(1, 2))
            )
            Nvv = (
                cross_arrays(take(1, 2), take(0, 1))
                + 2 * cross_arrays(take(1, 1), take(0, 2))
                + cross_arrays(take(1, 0), take(0, 3))
            )
            terms.append(
                (a * a)[:, None] * Nuu + (2 * a * b)[:, None] * Nuv + (b * b)[:, None] * Nvv
            )
        for term in terms:
            tl = np.sqrt(dot_arrays(term, term))
            use = (fixed_len <= tol * scale2) & (tl > tol * scale2)
            fixed[use] = term[use]
            fixed_len[use] = tl[use]
        N[irr] = fixed
        length[irr] = fixed_len
    # Wholly degenerate points (no usable derivative) get an arbitrary but finite normal.
    dead = ~(length > 0)
    if dead.any():
        N[dead] = (0.0, 0.0, 1.0)
        length[dead] = 1.0
    N /= length[..., None]
    return Normal(N, regular)


def first_fundamental_form(d: ArrayLike) -> tuple[NDArray, NDArray, NDArray]:
    """E = <p_u, p_u>, F = <p_u, p_v>, G = <p_v, p_v> (:func:`first_form`)."""
    d = np.asarray(d)
    _order_of(d, 1, "the first fundamental form")
    return first_form(_xyz(d[1, 0]), _xyz(d[0, 1]))


def second_fundamental_form(
    d: ArrayLike, n: ArrayLike | None = None
) -> tuple[NDArray, NDArray, NDArray]:
    """L = <p_uu, n>, M = <p_uv, n>, N = <p_vv, n> (n from :func:`unit_normal` if not given)."""
    d = np.asarray(d)
    _order_of(d, 2, "the second fundamental form")
    normal = unit_normal(d).n if n is None else np.asarray(n)
    return second_form(_xyz(d[2, 0]), _xyz(d[1, 1]), _xyz(d[0, 2]), _xyz(normal))


def _finite(x: NDArray) -> NDArray:
    return np.nan_to_num(x, copy=False, nan=0.0, posinf=0.0, neginf=0.0)


def _curvatures(d: ArrayLike, what: str, gaussian: bool, mean: bool) -> list[NDArray]:
    """K and/or H (:func:`gaussian_from_forms`, :func:`mean_from_forms`) of every point.

    Works through the points in cache-sized chunks, so that the temporaries of the
    formulas stay in cache and are reused; |N|^2 is at least ``_TINY`` (finite values).
    """
    d = np.asarray(d)
    _order_of(d, 2, what)
    shape = d.shape[2:-1]
    flat = d[:3, :3].reshape(3, 3, -1, 3)
    n = flat.shape[2]
    out = [np.empty(n) for _ in range(gaussian + mean)]
    for start in range(0, n, _CHUNK):
        part = flat[:, :, start : start + _CHUNK]
        f = fundamental_forms(
            *(_xyz(part[i, j]) for i, j in ((1, 0), (0, 1), (2, 0), (1, 1), (0, 2)))
        )
        f = f._replace(W2=np.maximum(f.W2, _TINY))
        values = [gaussian_from_forms(f)] if gaussian else []
        if mean:
            values.append(mean_from_forms(f, np.sqrt(f.W2)))
        for o, x in zip(out, values, strict=True):
            o[start : start + _CHUNK] = x
    return [_finite(o).reshape(shape) for o in out]


def gaussian_curvature(d: ArrayLike) -> NDArray[np.float64]:
    """Gaussian curvature K = (LN - M^2) / (EG - F^2)."""
    return _curvatures(d, "Gaussian curvature", True, False)[0]


def mean_curvature(d: ArrayLike) -> NDArray[np.float64]:
    """Mean curvature H = (EN - 2FM + GL) / (2 (EG - F^2)), signed w.r.t. n = p_u x p_v."""
    return _curvatures(d, "mean curvature", False, True)[0]


def gaussian_and_mean_curvature(d: ArrayLike) -> tuple[NDArray, NDArray]:
    """K and H together, sharing the fundamental forms (faster than two calls)."""
    K, H = _curvatures(d, "curvature", True, True)
    return K, H


class PrincipalCurvatures(NamedTuple):
    """Principal curvatures k1 >= k2 and their unit directions (tangent vectors in R^3)."""

    k1: NDArray[np.float64]
    k2: NDArray[np.float64]
    e1: NDArray[np.float64]
    e2: NDArray[np.float64]


def principal_curvatures(d: ArrayLike) -> PrincipalCurvatures:
    """Principal curvatures k1,2 = H ± sqrt(H^2 - K) and principal directions (do Carmo §3-2).

    The root comes from :func:`principal_terms` (exact near umbilics).  The directions are
    eigenvectors of the shape operator I^-1 II mapped to R^3 by (du, dv) -> du p_u + dv p_v;
    e2 = n x e1, so (e1, e2, n) is right-handed.  At umbilics every direction is principal
    and e1 is along p_u.
    """
    d = np.asarray(d)
    _order_of(d, 2, "principal curvatures")
    pu, pv = d[1, 0], d[0, 1]
    n = unit_normal(d).n
    E, F, G = first_fundamental_form(d)
    L, M, N = second_fundamental_form(d, n)
    f = Forms(E, F, G, L, M, N, np.maximum(first_form_det(E, F, G), _TINY))
    H = _finite(mean_from_forms(f))
    # ((k1 - k2) / 2)^2 from principal_terms, here divided before squaring (unlike
    # principal_half_gap): the directions near umbilics depend on this rounding, kept as it was
    gap, twist = principal_terms(f)
    half_gap = gap / (2 * f.W2)
    disc = _finite(half_gap * half_gap + twist / (f.W2 * f.W2))
    root = np.sqrt(np.maximum(disc, 0.0))
    k1, k2 = H + root, H - root
    # (II - k1 I) x = 0: two candidate null vectors; take the better conditioned one.
    a1, b1 = M - k1 * F, -(L - k1 * E)
    a2, b2 = N - k1 * G, -(M - k1 * F)
    first = a1 * a1 + b1 * b1 >= a2 * a2 + b2 * b2
    du = np.where(first, a1, a2)
    dv = np.where(first, b1, b2)
    e1 = du[..., None] * pu + dv[..., None] * pv
    length = np.sqrt(dot_arrays(e1, e1))
    scale = np.sqrt(E) * (np.abs(k1) + np.abs(k2) + 1e-300) * np.sqrt(E + G)
    umbilic = ~(length > 1e-10 * scale)
    e1 = np.where(umbilic[..., None], pu, e1)
    length = np.sqrt(dot_arrays(e1, e1))
    e1 = e1 / np.where(length > 0, length, 1.0)[..., None]
    e2 = cross_arrays(n, e1)
    return PrincipalCurvatures(k1, k2, e1, e2)


def normal_curvature(d: ArrayLike, n: ArrayLike, e: ArrayLike) -> NDArray[np.float64]:
    """Normal curvature k(e) = II(a) / I(a) in the tangent direction e (do Carmo §3-2).

    e = a_u p_u + a_v p_v by least squares (:func:`solve_first_form`); II w.r.t. the unit
    normal n.  Shapes: d (order + 1, order + 1, ..., 3) with order >= 2, n and e (..., 3).
    """
    d, e = np.asarray(d), np.asarray(e)
    _order_of(d, 2, "normal curvature")
    pu, pv = d[1, 0], d[0, 1]
    E, F, G = first_fundamental_form(d)
    L, M, N = second_fundamental_form(d, n)
    det = first_form_det(E, F, G)
    au, av = solve_first_form(
        E, F, G, np.where(det > 0, det, 1.0), np.sum(pu * e, -1), np.sum(pv * e, -1)
    )
    first = form_at(E, F, G, au, av)
    return form_at(L, M, N, au, av) / np.where(first > 0, first, 1.0)
