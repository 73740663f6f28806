"""Patches joined with prescribed geometric continuity (Kiciak, ch. 3).

Given a polynomial Bézier patch p of degree (m, n), ``junction_patch`` builds p* of the same
degree with p*(u, 0) = p(u, 1) and cross-boundary derivatives from constant connection
functions (α, β > 0, γ, δ, ε, ζ):

- G1: p*_v = α p_u + β p_v;
- G2: p*_vv = α² p_uu + 2αβ p_uv + β² p_vv + γ p_u + δ p_v;
- G3: p*_vvv = α³ p_uuu + 3α²β p_uuv + 3αβ² p_uvv + β³ p_vvv
  + 3(αγ p_uu + (αδ + βγ) p_uv + βδ p_vv) + ε p_u + ζ p_v,

all of p at v = 1.  These fix the first k + 1 rows of p*'s control net for a G^k junction;
the others continue p beyond v = 1 (p(u, 1 + βv), exactly, by the Bézier extension of p),
and the row after the fixed ones is lifted along the edge's normal by ``kick`` times the
patch size, so that the junction is G^k and not more.
"""

from __future__ import annotations

from math import comb

import numpy as np
from numpy.typing import NDArray

from ...errors import GshadeError
from ..core.bernstein import bernstein_basis, elevate_degree
from ..patches.bezier import BezierPatch

__all__ = ["CLASSES", "junction_patch"]

CLASSES = ("G0", "G1", "G2", "G3")


def _du(rows: NDArray, m: int, times: int) -> NDArray:
    """The ``times``-th u-derivative of Bernstein rows (axis 0 = u coefficients, degree m),
    elevated back to degree m."""
    out = rows
    for k in range(times):
        out = (m - k) * (out[1:] - out[:-1])
    return elevate_degree(out, times, axis=0) if times else out


def _extension(points: NDArray, length: float) -> NDArray:
    """Control rows of p(u, 1 + length * t), t in [0, 1]: the polynomial continued past v = 1."""
    n = points.shape[1] - 1
    t = np.linspace(0.0, 1.0, n + 1)
    B = bernstein_basis(n, 1.0 + length * t)[0]  # (n+1 samples, n+1 basis)
    values = np.einsum("sj,ijc->isc", B, points)  # the continued curves at the samples
    A = bernstein_basis(n, t)[0]
    return np.einsum("js,isc->ijc", np.linalg.inv(A), values)


def junction_patch(
    patch: BezierPatch,
    continuity: str,
    *,
    alpha: float = 0.0,
    beta: float = 1.0,
    gamma: float = 0.0,
    delta: float = 0.0,
    epsilon: float = 0.0,
    zeta: float = 0.0,
    kick: float = 0.15,
) -> BezierPatch:
    """The patch p* meeting ``patch`` along its v = 1 edge with a G0, G1, G2 or G3 junction."""
    if continuity not in CLASSES:
        raise GshadeError(f"continuity: expected one of {', '.join(CLASSES)}, got {continuity!r}")
    if not isinstance(patch, BezierPatch) or patch.rational:
        raise GshadeError("junction: expected a polynomial Bézier patch to continue")
    if not beta > 0:
        raise GshadeError(f"beta: expected a number > 0, got {beta!r}")
    k = CLASSES.index(continuity)
    P = patch.points
    m, n = patch.degree
    needed = min(k + 1, 3)  # the rows 0..k, and one more to break G(k+1) below G3
    if n < needed:
        raise GshadeError(
            f"junction: a {continuity} junction needs the patch's degree in v to be at least "
            f"{needed}, got {n}"
        )
    # v-derivatives of p at v = 1 as rows of Bernstein coefficients in u (degree m)
    dv = [
        sum((-1) ** j * comb(r, j) * P[:, n - j] for j in range(r + 1)) * _falling(n, r)
        for r in range(4 if n >= 3 else n + 1)
    ]
    a, b, g, d, e, z = alpha, beta, gamma, delta, epsilon, zeta
    rows = [dv[0]]
    if k >= 1:
        rows.append(a * _du(dv[0], m, 1) + b * dv[1])
    if k >= 2:
        rows.append(
            a * a * _du(dv[0], m, 2)
            + 2 * a * b * _du(dv[1], m, 1)
            + b * b * dv[2]
            + g * _du(dv[0], m, 1)
            + d * dv[1]
        )
    if k >= 3:
        rows.append(
            a**3 * _du(dv[0], m, 3)
            + 3 * a * a * b * _du(dv[1], m, 2)
            + 3 * a * b * b * _du(dv[2], m, 1)
            + b**3 * dv[3]
            + 3 * (a * g * _du(dv[0], m, 2) + (a * d + b * g) * _du(dv[1], m, 1) + b * d * dv[2])
            + e * _du(dv[0], m, 1)
            + z * dv[1]
        )
    # the net: the continuation, then rows 0..k from the derivatives (Bézier derivative rule
    # p*^(r)(u, 0) = n!/(n-r)! sum_j (-1)^(r-j) C(r, j) Q_j)
    Q = _extension(P, beta)
    for r, target in enumerate(rows):
        lower = sum((-1) ** (r - j) * comb(r, j) * Q[:, j] for j in range(r))
        Q[:, r] = target / _falling(n, r) - lower if r else target
    if k < 3 and k + 1 <= n:
        normal = np.cross(_du(dv[0], m, 1).mean(axis=0), dv[1].mean(axis=0))
        normal /= np.linalg.norm(normal) or 1.0
        size = float(np.linalg.norm(np.ptp(P.reshape(-1, 3), axis=0)))
        Q[:, k + 1] += kick * size * normal * np.sin(np.linspace(0.3, 2.8, m + 1))[:, None]
    return BezierPatch(Q)


def _falling(n: int, r: int) -> float:
    out = 1.0
    for j in range(r):
        out *= n - j
    return out
