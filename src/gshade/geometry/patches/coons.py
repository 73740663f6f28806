"""Coons patches: bilinearly and bicubically blended (Kiciak, Appendix A.9).

A Coons patch interpolates four boundary curves (and, bicubically blended, four
cross-boundary derivative curves):

    p(u, v) = sum_k a_k(v) C_k(u) + sum_k a_k(u) D_k(v) - sum_k sum_l a_k(u) a_l(v) Q_kl

with blending functions a = (1 - t, t) (bilinear) or the cubic Hermite basis
(H0, H1, H2, H3) = (1 - 3t^2 + 2t^3, 3t^2 - 2t^3, t - 2t^2 + t^3, -t^2 + t^3) (bicubic),
C = (p(., 0), p(., 1) [, p_v(., 0), p_v(., 1)]), D = (p(0, .), p(1, .) [, p_u(0, .), p_u(1, .)])
and Q the corner data (points, and for bicubic blending the corner derivatives and twists).
The domain is the unit square; each curve's own parameter interval is mapped onto [0, 1].
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ...errors import GshadeError
from ..core.bernstein import elevate_degree
from ..core.patch import Curve, Patch
from .bezier import BezierCurve, BezierPatch

__all__ = ["CoonsPatch"]

# Blending functions as polynomial coefficients (ascending powers) and in Bernstein form.
_LINEAR = np.array([[1.0, -1.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
_HERMITE = np.array(
    [[1.0, 0.0, -3.0, 2.0], [0.0, 0.0, 3.0, -2.0], [0.0, 1.0, -2.0, 1.0], [0.0, 0.0, -1.0, 1.0]]
)
_LINEAR_BERNSTEIN = np.array([[1.0, 0.0], [0.0, 1.0]])
_HERMITE_BERNSTEIN = np.array(
    [[1.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 1.0], [0.0, 1 / 3, 0.0, 0.0], [0.0, 0.0, -1 / 3, 0.0]]
)


def _blend(coeffs: NDArray, t: NDArray, order: int) -> NDArray:
    """Blending functions and their derivatives: shape (order + 1, K, N)."""
    out = np.zeros((order + 1, coeffs.shape[0], t.size))
    c = coeffs.copy()
    for k in range(order + 1):
        out[k] = np.polynomial.polynomial.polyval(t, c.T)
        c = np.concatenate([c[:, 1:] * np.arange(1, c.shape[1]), np.zeros((c.shape[0], 1))], 1)
    return out


def _curve_on_unit(curve: Curve, t: NDArray, order: int) -> NDArray:
    """Derivatives of a curve reparametrised onto [0, 1]: shape (order + 1, N, 3)."""
    a, b = curve.domain
    d = curve.derivatives(a + (b - a) * t, order)
    for k in range(1, order + 1):
        d[k] *= (b - a) ** k
    return d


class CoonsPatch(Patch):
    """Bilinearly or bicubically blended Coons patch over the unit square.

    Parameters
    ----------
    v0, v1 : Curve
        Boundary curves p(u, 0) and p(u, 1).
    u0, u1 : Curve
        Boundary curves p(0, v) and p(1, v).
    cross_v0, cross_v1, cross_u0, cross_u1 : Curve, optional
        Cross-boundary derivatives p_v(u, 0), p_v(u, 1), p_u(0, v), p_u(1, v), as functions
        of the patch parameter.  Give all four for bicubic blending, none for bilinear.
    tol : float
        Corner compatibility tolerance, relative to the size of the data.

    Raises
    ------
    GshadeError
        If the curves are not 3-D curves, only some cross derivatives are given, or the data
        disagree at a corner (points, and for bicubic blending tangents and twists).

    Examples
    --------
    Four parabolic arcs, each rising to z = 1/2 at its middle, blended bilinearly: the two
    ruled surfaces added, the bilinear patch of the corners taken away.

    >>> from gshade.geometry import BezierCurve, CoonsPatch
    >>> v0 = BezierCurve([[0, 0, 0], [0.5, 0, 1], [1, 0, 0]])
    >>> v1 = BezierCurve([[0, 1, 0], [0.5, 1, 1], [1, 1, 0]])
    >>> u0 = BezierCurve([[0, 0, 0], [0, 0.5, 1], [0, 1, 0]])
    >>> u1 = BezierCurve([[1, 0, 0], [1, 0.5, 1], [1, 1, 0]])
    >>> patch = CoonsPatch(v0, v1, u0, u1)
    >>> patch(0.5, 0.0).tolist(), patch(0.5, 0.5).tolist()
    ([0.5, 0.0, 0.5], [0.5, 0.5, 1.0])
    >>> bezier = patch.to_bezier()
    >>> bezier.degree, bezier(0.5, 0.5).tolist()
    ((2, 2), [0.5, 0.5, 1.0])
    """

    domain = ((0.0, 1.0), (0.0, 1.0))

    def __init__(
        self,
        v0: Curve,
        v1: Curve,
        u0: Curve,
        u1: Curve,
        *,
        cross_v0: Curve | None = None,
        cross_v1: Curve | None = None,
        cross_u0: Curve | None = None,
        cross_u1: Curve | None = None,
        tol: float = 1e-9,
    ) -> None:
        named: dict[str, Curve | None] = {
            "v0": v0,
            "v1": v1,
            "u0": u0,
            "u1": u1,
            "cross_v0": cross_v0,
            "cross_v1": cross_v1,
            "cross_u0": cross_u0,
            "cross_u1": cross_u1,
        }
        given = [
            k for k in ("cross_v0", "cross_v1", "cross_u0", "cross_u1") if named[k] is not None
        ]
        if given and len(given) != 4:
            missing = sorted(set(("cross_v0", "cross_v1", "cross_u0", "cross_u1")) - set(given))
            raise GshadeError(
                f"Coons patch: bicubic blending needs all four cross-boundary derivative "
                f"curves; missing {', '.join(missing)}"
            )
        for key, c in named.items():
            if c is None:
                continue
            if not isinstance(c, Curve) or c.dim != 3:
                raise GshadeError(f"Coons patch: {key}: expected a 3-D curve, got {c!r}")
        self.bicubic = bool(given)
        # the cross derivatives: all four (bicubic) or none
        self.curves_u = [v0, v1] + [c for c in (cross_v0, cross_v1) if c is not None]
        self.curves_v = [u0, u1] + [c for c in (cross_u0, cross_u1) if c is not None]
        self._coeffs = _HERMITE if self.bicubic else _LINEAR
        self._corners = self._corner_data(named, tol)

    def _corner_data(self, c: dict[str, Curve | None], tol: float) -> NDArray:
        """Corner matrix Q (K x K x 3) after checking that all curves agree at the corners."""
        ends = {
            k: _curve_on_unit(cv, np.array([0.0, 1.0]), 2) for k, cv in c.items() if cv is not None
        }
        scale = 1.0 + max(float(np.abs(e).max()) for e in ends.values())

        def agree(what: str, corner: str, a: NDArray, b: NDArray, na: str, nb: str) -> None:
            if np.linalg.norm(a - b) > tol * scale:
                raise GshadeError(
                    f"Coons patch: incompatible corner {corner}: {what} from {na} is "
                    f"{np.round(a, 12).tolist()} but from {nb} is {np.round(b, 12).tolist()}; "
                    f"expected equal within {tol:g} (relative)"
                )

        K = 4 if self.bicubic else 2
        Q = np.zeros((K, K, 3))
        for k in (0, 1):  # u = k
            for l in (0, 1):  # v = l
                corner = f"(u={k}, v={l})"
                from_v = ends[f"v{l}"][0, k]
                agree("the point", corner, from_v, ends[f"u{k}"][0, l], f"v{l}", f"u{k}")
                Q[k, l] = from_v
                if self.bicubic:
                    pv = ends[f"cross_v{l}"][0, k]
                    pu = ends[f"cross_u{k}"][0, l]
                    agree("p_v", corner, pv, ends[f"u{k}"][1, l], f"cross_v{l}", f"u{k}'")
                    agree("p_u", corner, pu, ends[f"v{l}"][1, k], f"cross_u{k}", f"v{l}'")
                    twist = ends[f"cross_v{l}"][1, k]
                    agree(
                        "the twist p_uv",
                        corner,
                        twist,
                        ends[f"cross_u{k}"][1, l],
                        f"cross_v{l}'",
                        f"cross_u{k}'",
                    )
                    Q[k, 2 + l] = pv
                    Q[2 + k, l] = pu
                    Q[2 + k, 2 + l] = twist
        return Q

    def _derivatives_points(self, u: NDArray, v: NDArray, order: int) -> NDArray:
        Au = _blend(self._coeffs, u, order)  # (o+1, K, N)
        Av = _blend(self._coeffs, v, order)
        Cu = np.stack([_curve_on_unit(c, u, order) for c in self.curves_u], 1)  # (o+1, K, N, 3)
        Dv = np.stack([_curve_on_unit(c, v, order) for c in self.curves_v], 1)
        out = np.zeros((order + 1, order + 1, 3, u.size))
        for i in range(order + 1):
            for j in range(order + 1 - i):
                s = np.einsum("kn,knc->cn", Av[j], Cu[i])
                s += np.einsum("kn,knc->cn", Au[i], Dv[j])
                s -= np.einsum("kn,ln,klc->cn", Au[i], Av[j], self._corners)
                out[i, j] = s
        return out

    def to_bezier(self) -> BezierPatch:
        """The same surface as a Bézier patch, when every curve is a polynomial Bézier curve.

        Each term a_k(v) C_k(u) is a tensor product of Bernstein polynomials; after degree
        elevation to common degrees the three sums add up control point by control point.
        """
        bezier_u = [c for c in self.curves_u if isinstance(c, BezierCurve) and not c.rational]
        bezier_v = [c for c in self.curves_v if isinstance(c, BezierCurve) and not c.rational]
        if len(bezier_u) < len(self.curves_u) or len(bezier_v) < len(self.curves_v):
            raise GshadeError(
                "Coons patch: conversion to a Bézier patch needs polynomial Bézier curves "
                "(no B-spline or rational curves)"
            )
        blend = _HERMITE_BERNSTEIN if self.bicubic else _LINEAR_BERNSTEIN
        bdeg = blend.shape[1] - 1
        m = max([bdeg] + [c.degree for c in bezier_u])
        n = max([bdeg] + [c.degree for c in bezier_v])
        blend_u = elevate_degree(blend, m - bdeg, axis=1)  # (K, m+1)
        blend_v = elevate_degree(blend, n - bdeg, axis=1)  # (K, n+1)
        Cu = np.stack([c.elevated(m).points for c in bezier_u])  # (K, m+1, 3)
        Dv = np.stack([c.elevated(n).points for c in bezier_v])  # (K, n+1, 3)
        net = np.einsum("kj,kic->ijc", blend_v, Cu)
        net += np.einsum("ki,kjc->ijc", blend_u, Dv)
        net -= np.einsum("ki,lj,klc->ijc", blend_u, blend_v, self._corners)
        return BezierPatch(net)
