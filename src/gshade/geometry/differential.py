"""Differential geometry of a patch from its exact derivatives (Kiciak, Appendix A.10).

All functions take a derivatives array ``d`` as returned by ``Patch.derivatives`` (shape
``(order + 1, order + 1, ..., 3)``) and work on any number of points at once.

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

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import GshadeError

__all__ = [
    "PrincipalCurvatures",
    "first_fundamental_form",
    "gaussian_curvature",
    "irregular_mask",
    "mean_curvature",
    "principal_curvatures",
    "second_fundamental_form",
    "unit_normal",
]

#: |p_u x p_v| below this times the squared derivative scale marks an irregular point.
IRREGULAR_TOL = 1e-8
#: Points per chunk in the curvature formulas (temporaries stay in cache).
_CHUNK = 1 << 14


def _order_of(d: NDArray, needed: int, what: str) -> None:
    if d.ndim < 3 or d.shape[0] != d.shape[1] or d.shape[-1] != 3:
        raise GshadeError(f"derivatives: expected shape (order+1, order+1, ..., 3), got {d.shape}")
    if d.shape[0] - 1 < needed:
        raise GshadeError(
            f"derivatives: {what} needs derivatives of order {needed}, got order {d.shape[0] - 1}"
        )


def _cross(a: NDArray, b: NDArray) -> NDArray:
    """Cross product over the last axis, written component-wise (fast on strided views)."""
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


def _dot(a: NDArray, b: NDArray) -> NDArray:
    out = a[..., 0] * b[..., 0]
    out += a[..., 1] * b[..., 1]
    out += a[..., 2] * b[..., 2]
    return out


def derivative_scale(d: NDArray) -> float:
    """A length scale of the first derivatives: the largest |component| of p_u or p_v."""
    s = 0.0
    for x in (d[1, 0], d[0, 1]):
        if x.size:
            s = max(s, float(np.max(x)), -float(np.min(x)))
    return s if s > 0 else 1.0


def irregular_mask(d: ArrayLike, tol: float = IRREGULAR_TOL) -> NDArray[np.bool_]:
    """True where the parametrisation is irregular: |p_u x p_v| <= tol * scale^2.

    The scale is the largest first-derivative component in ``d``, so that a collapsed
    edge (where p_u or p_v vanishes up to round-off) is recognised in any units.
    """
    d = np.asarray(d)
    _order_of(d, 1, "the regularity test")
    N = _cross(d[1, 0], d[0, 1])
    return np.sqrt(_dot(N, N)) <= tol * derivative_scale(d) ** 2


class Normal(NamedTuple):
    """Unit normals and where they are regular."""

    n: NDArray[np.float64]
    regular: NDArray[np.bool_]


def unit_normal(
    d: ArrayLike, toward: ArrayLike | None = None, tol: float = IRREGULAR_TOL
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
        :func:`gshade.geometry.patch_normals`, which supplies it.

    Returns
    -------
    Normal
        ``n`` (shape (..., 3), unit length everywhere, never NaN) and ``regular`` (bool).
    """
    d = np.asarray(d)
    _order_of(d, 1, "the normal")
    pu, pv = d[1, 0], d[0, 1]
    N = _cross(pu, pv)
    length = np.sqrt(_dot(N, N))
    scale2 = derivative_scale(d) ** 2
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
        order = d.shape[0] - 1
        take = lambda i, j: d[i, j][irr]  # noqa: E731
        terms = []
        if order >= 2:
            Nu = _cross(take(2, 0), take(0, 1)) + _cross(take(1, 0), take(1, 1))
            Nv = _cross(take(1, 1), take(0, 1)) + _cross(take(1, 0), take(0, 2))
            terms.append(a[:, None] * Nu + b[:, None] * Nv)
        if order >= 3:
            Nuu = (
                _cross(take(3, 0), take(0, 1))
                + 2 * _cross(take(2, 0), take(1, 1))
                + _cross(take(1, 0), take(2, 1))
            )
            Nuv = (
                _cross(take(2, 1), take(0, 1))
                + _cross(take(2, 0), take(0, 2))
                + _cross(take(1, 0), take(1, 2))
            )
            Nvv = (
                _cross(take(1, 2), take(0, 1))
                + 2 * _cross(take(1, 1), take(0, 2))
                + _cross(take(1, 0), take(0, 3))
            )
            terms.append(
                (a * a)[:, None] * Nuu + (2 * a * b)[:, None] * Nuv + (b * b)[:, None] * Nvv
            )
        for term in terms:
            tl = np.sqrt(_dot(term, term))
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
    """E = <p_u, p_u>, F = <p_u, p_v>, G = <p_v, p_v>."""
    d = np.asarray(d)
    _order_of(d, 1, "the first fundamental form")
    pu, pv = d[1, 0], d[0, 1]
    return _dot(pu, pu), _dot(pu, pv), _dot(pv, pv)


def second_fundamental_form(
    d: ArrayLike, n: ArrayLike | None = None
) -> tuple[NDArray, NDArray, NDArray]:
    """L = <p_uu, n>, M = <p_uv, n>, N = <p_vv, n> (n from :func:`unit_normal` if not given)."""
    d = np.asarray(d)
    _order_of(d, 2, "the second fundamental form")
    normal = unit_normal(d).n if n is None else np.asarray(n)
    return _dot(d[2, 0], normal), _dot(d[1, 1], normal), _dot(d[0, 2], normal)


def _curvature_terms(d: NDArray):
    """E, F, G, the unnormalised L', M', N' and |N|^2 (guarded against zero)."""
    pu, pv = d[1, 0], d[0, 1]
    N = _cross(pu, pv)
    E, F, G = _dot(pu, pu), _dot(pu, pv), _dot(pv, pv)
    L_, M_, N_ = _dot(d[2, 0], N), _dot(d[1, 1], N), _dot(d[0, 2], N)
    W2 = _dot(N, N)
    tiny = np.finfo(np.float64).tiny ** 0.25
    np.maximum(W2, tiny, out=W2)
    return E, F, G, L_, M_, N_, W2


def _finite(x: NDArray) -> NDArray:
    return np.nan_to_num(x, copy=False, nan=0.0, posinf=0.0, neginf=0.0)


def gaussian_curvature(d: ArrayLike) -> NDArray[np.float64]:
    """Gaussian curvature K = (LN - M^2) / (EG - F^2)."""
    d = np.asarray(d)
    _order_of(d, 2, "Gaussian curvature")
    _, _, _, L_, M_, N_, W2 = _curvature_terms(d)
    L_ *= N_
    M_ *= M_
    L_ -= M_
    W2 *= W2
    L_ /= W2
    return _finite(L_)


def mean_curvature(d: ArrayLike) -> NDArray[np.float64]:
    """Mean curvature H = (EN - 2FM + GL) / (2 (EG - F^2)), signed w.r.t. n = p_u x p_v."""
    d = np.asarray(d)
    _order_of(d, 2, "mean curvature")
    E, F, G, L_, M_, N_, W2 = _curvature_terms(d)
    return _mean_from_terms(E, F, G, L_, M_, N_, W2)


def _mean_from_terms(E, F, G, L_, M_, N_, W2):
    E *= N_
    F *= M_
    F *= 2.0
    E -= F
    G *= L_
    E += G
    W2 = np.sqrt(W2) * W2
    W2 *= 2.0
    E /= W2
    return _finite(E)


def gaussian_and_mean_curvature(d: ArrayLike) -> tuple[NDArray, NDArray]:
    """K and H together, sharing the common terms (faster than two calls).

    Works through the points in cache-sized chunks, so that the temporaries of the
    formula stay in cache and are reused.
    """
    d = np.asarray(d)
    _order_of(d, 2, "curvature")
    shape = d.shape[2:-1]
    flat = d[:3, :3].reshape(3, 3, -1, 3)
    n = flat.shape[2]
    K, H = np.empty(n), np.empty(n)
    for start in range(0, n, _CHUNK):
        sl = slice(start, start + _CHUNK)
        E, F, G, L_, M_, N_, W2 = _curvature_terms(flat[:, :, sl])
        k = L_ * N_
        k -= M_ * M_
        k /= W2 * W2
        K[sl] = k
        H[sl] = _mean_from_terms(E, F, G, L_, M_, N_, W2)
    return _finite(K).reshape(shape), _finite(H).reshape(shape)


class PrincipalCurvatures(NamedTuple):
    """Principal curvatures k1 >= k2 and their unit directions (tangent vectors in R^3)."""

    k1: NDArray[np.float64]
    k2: NDArray[np.float64]
    e1: NDArray[np.float64]
    e2: NDArray[np.float64]


def principal_curvatures(d: ArrayLike) -> PrincipalCurvatures:
    """Principal curvatures k1,2 = H ± sqrt(H^2 - K) and principal directions.

    The directions are eigenvectors of the shape operator I^-1 II mapped to R^3 by
    (du, dv) -> du p_u + dv p_v; e2 = n x e1, so (e1, e2, n) is right-handed.  At umbilics
    every direction is principal and e1 is along p_u.
    """
    d = np.asarray(d)
    _order_of(d, 2, "principal curvatures")
    pu, pv = d[1, 0], d[0, 1]
    n = unit_normal(d).n
    E, F, G = first_fundamental_form(d)
    L, M, N = second_fundamental_form(d, n)
    W2 = np.maximum(E * G - F * F, np.finfo(np.float64).tiny ** 0.25)
    H = _finite((E * N - 2 * F * M + G * L) / (2 * W2))
    # ((k1 - k2) / 2)^2 from the shape operator S = I^-1 II as ((S11 - S22) / 2)^2 + S12 S21
    # rather than H^2 - K, which loses half the digits near umbilics.
    half_gap = (G * L - E * N) / (2 * W2)
    disc = _finite(half_gap * half_gap + (G * M - F * N) * (E * M - F * L) / (W2 * W2))
    root = np.sqrt(np.maximum(disc, 0.0))
    k1, k2 = H + root, H - root
    # (II - k1 I) x = 0: two candidate null vectors; take the better conditioned one.
    a1, b1 = M - k1 * F, -(L - k1 * E)
    a2, b2 = N - k1 * G, -(M - k1 * F)
    first = a1 * a1 + b1 * b1 >= a2 * a2 + b2 * b2
    du = np.where(first, a1, a2)
    dv = np.where(first, b1, b2)
    e1 = du[..., None] * pu + dv[..., None] * pv
    length = np.sqrt(_dot(e1, e1))
    scale = np.sqrt(E) * (np.abs(k1) + np.abs(k2) + 1e-300) * np.sqrt(E + G)
    umbilic = ~(length > 1e-10 * scale)
    e1 = np.where(umbilic[..., None], pu, e1)
    length = np.sqrt(_dot(e1, e1))
    e1 = e1 / np.where(length > 0, length, 1.0)[..., None]
    e2 = _cross(n, e1)
    return PrincipalCurvatures(k1, k2, e1, e2)
