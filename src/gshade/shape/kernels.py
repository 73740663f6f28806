"""Compiled per-point kernels of the shape functions (formulas in ``functions.py``'s docs).

Each kernel reads the jets of the surface derivatives at one point and returns the jet of
f and a status (1 valid, 0 undefined there, 2 eye point on the surface).  ``run`` loops
over the points in parallel and turns (f, f_u, f_v) into the surface gradient.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .jets import (
    add,
    arccos,
    arctan2,
    cross,
    cross_const,
    div,
    dot,
    dot_const,
    jabs,
    mul,
    scale,
    sqrt,
    sub,
    vec,
    vsub_const,
)

PLANAR, ISOPHOTES, REFLECTION, HIGHLIGHT, PARAMETRISATION = 0, 1, 2, 3, 4
GAUSSIAN, MEAN, MAX_PRINCIPAL, MIN_PRINCIPAL, ABSOLUTE, RMS = 5, 6, 7, 8, 9, 10

VALID, UNDEFINED, EYE_ON_SURFACE = 1, 0, 2
#: index in the parameter vector of the |p_u x p_v| at or below which a point is irregular
IRREGULAR = 23


@njit(cache=True)
def _planar_sections(d, k, prm):
    return dot_const(vec(d, 0, 0, k), prm[0:3]), VALID


@njit(cache=True)
def _isophotes(d, k, prm, angle):
    N = cross(vec(d, 1, 0, k), vec(d, 0, 1, k))
    length = sqrt(dot(N, N))
    if length[0] <= prm[IRREGULAR]:
        return (0.0, 0.0, 0.0), UNDEFINED
    f = div(dot_const(N, prm[0:3]), length)
    if angle:
        f = arccos(f)
    return f, VALID


@njit(cache=True)
def _reflection_lines(d, k, prm, at_infinity):
    """r = w - 2 <w, N> N / <N, N> with w = p - e; plane: s = <(p - p0) x a2, r> / <c, r>."""
    p = vec(d, 0, 0, k)
    N = cross(vec(d, 1, 0, k), vec(d, 0, 1, k))
    NN = dot(N, N)
    w = vsub_const(p, prm[0:3])
    if dot(w, w)[0] == 0.0:
        return (0.0, 0.0, 0.0), EYE_ON_SURFACE
    if NN[0] <= prm[IRREGULAR] * prm[IRREGULAR]:
        return (0.0, 0.0, 0.0), UNDEFINED
    t = scale(div(dot(w, N), NN), 2.0)
    r = (sub(w[0], mul(t, N[0])), sub(w[1], mul(t, N[1])), sub(w[2], mul(t, N[2])))
    if at_infinity:
        b = prm[12:15]
        ref = prm[15:18]
        return arctan2(dot_const(r, b), dot_const(r, ref)), VALID
    a2 = prm[9:12]
    c = prm[18:21]
    q = vsub_const(p, prm[3:6])
    cr = dot_const(r, c)
    mu_sign = -dot_const(q, c)[0] * cr[0]
    if cr[0] == 0.0 or mu_sign <= 0.0:
        return (0.0, 0.0, 0.0), UNDEFINED
    return div(dot(cross_const(q, a2), r), cr), VALID


@njit(cache=True)
def _highlight_lines(d, k, prm, distance):
    """plane: s = <(p - p0) x a2, N> / <c, N>;  distance: <E x N, p - A> / |E x N|."""
    p = vec(d, 0, 0, k)
    N = cross(vec(d, 1, 0, k), vec(d, 0, 1, k))
    length = math.sqrt(max(dot(N, N)[0], 0.0))
    if length <= prm[IRREGULAR]:
        return (0.0, 0.0, 0.0), UNDEFINED
    q = vsub_const(p, prm[0:3])
    if distance:
        EN = cross_const(N, prm[6:9])  # N x E = -(E x N)
        norm = sqrt(dot(EN, EN))
        if not norm[0] > 1e-12 * length:
            return (0.0, 0.0, 0.0), UNDEFINED
        return scale(div(dot(EN, q), norm), -1.0), VALID
    c = prm[9:12]
    cn = dot_const(N, c)
    if not abs(cn[0]) > 1e-12 * length * prm[12]:
        return (0.0, 0.0, 0.0), UNDEFINED
    return div(dot(cross_const(q, prm[6:9]), N), cn), VALID


@njit(cache=True)
def _parametrisation_quality(d, k):
    pu, pv = vec(d, 1, 0, k), vec(d, 0, 1, k)
    E, F, G = dot(pu, pu), dot(pu, pv), dot(pv, pv)
    s = add(E, G)
    if s[0] <= 0.0:
        return (0.0, 0.0, 0.0), UNDEFINED
    dEG = sub(E, G)
    return div(add(mul(dEG, dEG), scale(mul(F, F), 4.0)), mul(s, s)), VALID


@njit(cache=True)
def _curvature(d, k, which, prm):
    """K = (L'N' - M'^2)/W^4, H = (E N' - 2F M' + G L')/(2 W^3), W = |N|, L' = <p_uu, N>, ...;
    ((k1 - k2)/2)^2 = ((G L' - E N')^2 / 4 + (G M' - F N')(E M' - F L')) / W^6."""
    pu, pv = vec(d, 1, 0, k), vec(d, 0, 1, k)
    N = cross(pu, pv)
    W2 = dot(N, N)
    if W2[0] <= prm[IRREGULAR] * prm[IRREGULAR]:
        return (0.0, 0.0, 0.0), UNDEFINED
    E, F, G = dot(pu, pu), dot(pu, pv), dot(pv, pv)
    L, M, Nn = dot(vec(d, 2, 0, k), N), dot(vec(d, 1, 1, k), N), dot(vec(d, 0, 2, k), N)
    inv2 = div((1.0, 0.0, 0.0), W2)
    inv4 = mul(inv2, inv2)
    K = mul(sub(mul(L, Nn), mul(M, M)), inv4)
    if which == GAUSSIAN:
        return K, VALID
    W3 = mul(W2, sqrt(W2))
    H = div(add(sub(mul(E, Nn), scale(mul(F, M), 2.0)), mul(G, L)), scale(W3, 2.0))
    if which == MEAN:
        return H, VALID
    if which == RMS:
        return sqrt(sub(scale(mul(H, H), 2.0), K)), VALID
    gap = sub(mul(G, L), mul(E, Nn))
    disc = add(
        scale(mul(gap, gap), 0.25), mul(sub(mul(G, M), mul(F, Nn)), sub(mul(E, M), mul(F, L)))
    )
    root = sqrt(mul(disc, mul(inv4, inv2)))
    if which == MAX_PRINCIPAL:
        return add(H, root), VALID
    if which == MIN_PRINCIPAL:
        return sub(H, root), VALID
    return add(jabs(add(H, root)), jabs(sub(H, root))), VALID  # ABSOLUTE


@njit(cache=True)
def _point(code, option, prm, d, k):
    if code == PLANAR:
        return _planar_sections(d, k, prm)
    if code == ISOPHOTES:
        return _isophotes(d, k, prm, option)
    if code == REFLECTION:
        return _reflection_lines(d, k, prm, option)
    if code == HIGHLIGHT:
        return _highlight_lines(d, k, prm, option)
    if code == PARAMETRISATION:
        return _parametrisation_quality(d, k)
    return _curvature(d, k, code, prm)


@njit(cache=True, parallel=True)
def run(code, option, prm, d, f, grad, status, with_gradient):
    """Evaluate shape function ``code`` at every point of ``d`` (shape (.., .., n, 3)).

    Writes f (n,), status (n,) and, if ``with_gradient``, grad (3, n) =
    ((G f_u - F f_v) p_u + (E f_v - F f_u) p_v) / (EG - F^2).
    """
    n = d.shape[2]
    for k in prange(n):
        jf, st = _point(code, option, prm, d, k)
        if st == VALID and not (
            math.isfinite(jf[0]) and math.isfinite(jf[1]) and math.isfinite(jf[2])
        ):
            st = UNDEFINED
        status[k] = st
        f[k] = jf[0] if st == VALID else 0.0
        if with_gradient:
            pux, puy, puz = d[1, 0, k, 0], d[1, 0, k, 1], d[1, 0, k, 2]
            pvx, pvy, pvz = d[0, 1, k, 0], d[0, 1, k, 1], d[0, 1, k, 2]
            E = pux * pux + puy * puy + puz * puz
            F = pux * pvx + puy * pvy + puz * pvz
            G = pvx * pvx + pvy * pvy + pvz * pvz
            det = E * G - F * F
            if st == VALID and det > 0.0:
                a = (G * jf[1] - F * jf[2]) / det
                b = (E * jf[2] - F * jf[1]) / det
            else:
                a = 0.0
                b = 0.0
            grad[0, k] = a * pux + b * pvx
            grad[1, k] = a * puy + b * pvy
            grad[2, k] = a * puz + b * pvz


def warm_up() -> None:
    """Compile (or load from the cache) every kernel once."""
    d = np.zeros((4, 4, 1, 3))
    d[1, 0, 0, 0] = d[0, 1, 0, 1] = 1.0
    prm = np.zeros(24)
    for code in range(RMS + 1):
        run(code, 0, prm, d, np.empty(1), np.empty((3, 1)), np.empty(1, np.int8), True)
