"""B-spline knot vectors: validation, spans, basis functions with derivatives, knot insertion.

Conventions follow Piegl & Tiller, *The NURBS Book* (and Kiciak, Appendix A.3): a curve of
degree p with control points P_0..P_n has a knot vector U_0 <= ... <= U_{n+p+1}; its
parameter domain is [U_p, U_{n+1}].  Knot vectors may be clamped or not and nonuniform,
with interior multiplicities up to p + 1.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...errors import GshadeError, ParameterDomainError

__all__ = [
    "basis_functions",
    "basis_functions_in_spans",
    "basis_matrix",
    "domain",
    "find_spans",
    "insert_knot",
    "one_clamped_span",
    "refine_to_bezier",
    "validate_knots",
]


def validate_knots(knots: ArrayLike, degree: int, n_points: int, name: str = "knots") -> NDArray:
    """Validate a knot vector for ``n_points`` control points of the given degree.

    Raises
    ------
    GshadeError
        If the degree is < 1, the knot vector has the wrong length, decreases, contains
        non-finite values, a knot has multiplicity > degree + 1, or the domain is empty.
    """
    if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) or degree < 1:
        raise GshadeError(f"degree: expected an integer >= 1, got {degree!r}")
    U = np.asarray(knots, dtype=np.float64)
    if U.ndim != 1:
        raise GshadeError(f"{name}: expected a 1-D sequence of numbers, got shape {U.shape}")
    expected = n_points + degree + 1
    if U.shape[0] != expected:
        raise GshadeError(
            f"{name}: expected {expected} knots for {n_points} control points of degree "
            f"{degree} (points + degree + 1), got {U.shape[0]}"
        )
    if n_points < degree + 1:
        raise GshadeError(
            f"{name}: degree {degree} needs at least {degree + 1} control points, got {n_points}"
        )
    if not np.all(np.isfinite(U)):
        raise GshadeError(f"{name}: expected finite numbers, got {U.tolist()}")
    dec = np.nonzero(np.diff(U) < 0)[0]
    if dec.size:
        i = int(dec[0])
        raise GshadeError(
            f"{name}: expected a non-decreasing sequence, but knot {i + 1} ({float(U[i + 1])!r}) "
            f"< knot {i} ({float(U[i])!r})"
        )
    values, counts = np.unique(U, return_counts=True)
    if counts.max() > degree + 1:
        raise GshadeError(
            f"{name}: expected knot multiplicities <= degree + 1 = {degree + 1}, got "
            f"{int(counts.max())} for the knot {float(values[counts.argmax()])!r}"
        )
    if not U[degree] < U[n_points]:
        raise GshadeError(
            f"{name}: the parameter domain [knot {degree}, knot {n_points}] = "
            f"[{float(U[degree])!r}, {float(U[n_points])!r}] is empty"
        )
    return U


def domain(knots: NDArray, degree: int) -> tuple[float, float]:
    """Parameter domain [U_p, U_{n+1}] of a B-spline with the given knots and degree."""
    return float(knots[degree]), float(knots[len(knots) - degree - 1])


def one_clamped_span(knots: NDArray, degree: int) -> bool:
    """Whether ``knots`` are one clamped span, [a] * (p + 1) + [b] * (p + 1) with a < b: the
    B-spline basis is then the Bernstein basis on [a, b], its net one Bézier cell.

    Examples
    --------
    >>> one_clamped_span([0, 0, 0, 2, 2, 2], 2), one_clamped_span([0, 0, 1, 2, 2], 1)
    (True, False)
    """
    p = degree
    return len(knots) == 2 * (p + 1) and knots[0] == knots[p] < knots[p + 1] == knots[-1]


def validate_parameters(t: ArrayLike, lo: float, hi: float, name: str = "t") -> NDArray:
    """Return ``t`` as float array; raise if any value is outside [lo, hi] (beyond round-off).

    Values within 1e-12 of the domain's size outside it are clamped onto it.
    """
    t = np.asarray(t, dtype=np.float64)
    tol = 1e-12 * max(1.0, hi - lo)
    bad = ~((t >= lo - tol) & (t <= hi + tol))  # also catches NaN
    if np.any(bad):
        example = float(t[bad].flat[0])
        raise ParameterDomainError(
            f"{name}: expected values in the parameter domain [{lo!r}, {hi!r}], got "
            f"{example!r} ({int(bad.sum())} value(s) outside)"
        )
    return np.clip(t, lo, hi)


def find_spans(knots: NDArray, degree: int, t: NDArray) -> NDArray[np.intp]:
    """Index k of the knot span [U_k, U_{k+1}) containing each t, with p <= k <= n.

    The right end of the domain belongs to the last non-empty span.
    """
    n = len(knots) - degree - 2
    k = np.searchsorted(knots, t, side="right") - 1
    k = np.clip(k, degree, n)
    # At the right end of the domain (and inside a run of equal knots at it) step back to
    # the last non-empty span.
    last = int(np.nonzero(knots[: n + 1] < knots[n + 1])[0][-1])
    return np.minimum(k, last)


def basis_functions(
    knots: NDArray, degree: int, t: NDArray, order: int = 0
) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """Nonzero B-spline basis functions and their derivatives (vectorised Cox–de Boor).

    Parameters
    ----------
    knots : ndarray
        Validated knot vector.
    degree : int
        Degree p.
    t : ndarray, shape (N,)
        Parameters inside the domain.
    order : int
        Highest derivative order.

    Returns
    -------
    spans : ndarray of int, shape (N,)
        Span index k of each parameter: the nonzero functions are N_{k-p}..N_k.
    ders : ndarray, shape (order + 1, N, p + 1)
        ``ders[j, :, r]`` is the j-th derivative of N_{k-p+r}.  Derivative orders above p
        are zero.  (Piegl & Tiller, algorithm A2.3.)
    """
    t = np.asarray(t, dtype=np.float64).ravel()
    spans = find_spans(knots, degree, t)
    return spans, basis_functions_in_spans(knots, degree, t, spans, order)


def basis_functions_in_spans(
    knots: NDArray, degree: int, t: NDArray, spans: NDArray, order: int = 0
) -> NDArray[np.float64]:
    """:func:`basis_functions`' ``ders`` for parameters ``t`` in given knot ``spans``
    (indices into ``knots``: the span [U_k, U_{k+1}) of each t).  ``knots`` may be several
    knot vectors end to end, each point's span an index into its own (many splines' bases
    at once)."""
    p = degree
    N = t.shape[0]
    # points last: every step below is one contiguous sweep over the N points
    left = np.empty((p + 1, N))
    right = np.empty((p + 1, N))
    ndu = np.empty((p + 1, p + 1, N))
    ndu[0, 0] = 1.0
    saved = np.empty(N)
    temp = np.empty(N)
    for j in range(1, p + 1):
        np.subtract(t, knots[spans + 1 - j], out=left[j])
        np.subtract(knots[spans + j], t, out=right[j])
        saved[:] = 0.0
        for r in range(j):
            # lower triangle: knot differences
            np.add(right[r + 1], left[j - r], out=ndu[j, r])
            np.divide(ndu[r, j - 1], ndu[j, r], out=temp)
            # upper triangle: basis functions
            np.multiply(right[r + 1], temp, out=ndu[r, j])
            ndu[r, j] += saved
            np.multiply(left[j - r], temp, out=saved)
        ndu[j, j] = saved
    # points last here too; handed out as (order + 1, N, p + 1) (a view: its N axis stays
    # the contiguous one, as products along it want)
    ders = np.zeros((order + 1, p + 1, N))
    ders[0] = ndu[:, p]
    if order == 0:
        return ders.transpose(0, 2, 1)
    a = np.empty((2, p + 1, N))
    d = np.empty(N)
    for r in range(p + 1):
        s1, s2 = 0, 1
        a[0, 0] = 1.0
        for k in range(1, min(order, p) + 1):
            d[:] = 0.0
            rk, pk = r - k, p - k
            if r >= k:
                np.divide(a[s1, 0], ndu[pk + 1, rk], out=a[s2, 0])
                np.multiply(a[s2, 0], ndu[rk, pk], out=d)
            j1 = 1 if rk >= -1 else -rk
            j2 = k - 1 if r - 1 <= pk else p - r
            for j in range(j1, j2 + 1):
                a[s2, j] = (a[s1, j] - a[s1, j - 1]) / ndu[pk + 1, rk + j]
                d += a[s2, j] * ndu[rk + j, pk]
            if r <= pk:
                a[s2, k] = -a[s1, k - 1] / ndu[pk + 1, r]
                d += a[s2, k] * ndu[r, pk]
            ders[k, r] = d
            s1, s2 = s2, s1
    factor = float(p)
    for k in range(1, min(order, p) + 1):
        ders[k] *= factor
        factor *= p - k
    return ders.transpose(0, 2, 1)


def basis_matrix(knots: NDArray, degree: int, t: NDArray, order: int = 0) -> NDArray:
    """Dense basis matrices: ``out[j, a, i]`` = j-th derivative of N_i at t_a.

    Shape (order + 1, len(t), number of control points).  Used for evaluation on grids,
    where a dense (small) matrix product beats gathering local control points.
    """
    n_pts = len(knots) - degree - 1
    spans, ders = basis_functions(knots, degree, t, order)
    out = np.zeros((order + 1, len(spans), n_pts))
    rows = np.arange(len(spans))[:, None]
    cols = spans[:, None] - degree + np.arange(degree + 1)[None, :]
    out[:, rows, cols] = ders
    return out


def insert_knot(
    knots: NDArray, degree: int, points: NDArray, t: float, times: int = 1
) -> tuple[NDArray, NDArray]:
    """Insert the knot ``t`` ``times`` times (Boehm's algorithm), leaving the spline unchanged.

    ``points`` has shape (n_points, ...): any trailing dimensions (coordinates, homogeneous
    coordinates, or a second parametric direction) are carried along.
    """
    U = np.asarray(knots, dtype=np.float64)
    P = np.asarray(points, dtype=np.float64)
    p = degree
    lo, hi = domain(U, p)
    if not lo <= t <= hi:
        raise ParameterDomainError(f"knot: expected a value in [{lo!r}, {hi!r}], got {t!r}")
    for _ in range(times):
        if np.count_nonzero(U == t) >= p + 1:
            raise GshadeError(
                f"knot: {t!r} already has multiplicity {p + 1} = degree + 1; cannot insert more"
            )
        # any k with U_k <= t <= U_{k+1} works (Boehm); find_spans gives one, also at the
        # right end of the domain
        k = int(find_spans(U, p, np.array([t]))[0])
        newP = np.empty((P.shape[0] + 1, *P.shape[1:]))
        newP[: k - p + 1] = P[: k - p + 1]
        newP[k + 1 :] = P[k:]
        for i in range(k - p + 1, k + 1):
            denom = U[i + p] - U[i]
            alpha = (t - U[i]) / denom if denom > 0 else 0.0
            newP[i] = alpha * P[i] + (1.0 - alpha) * P[i - 1]
        U = np.insert(U, k + 1, t)
        P = newP
    return U, P


def refine_to_bezier(knots: NDArray, degree: int, points: NDArray) -> tuple[NDArray, list]:
    """Bézier extraction: control points of the polynomial pieces of a B-spline.

    Every distinct knot value in the domain (its ends included) is inserted until its
    multiplicity is at least the degree; then the Bézier points of the span [U_k, U_{k+1})
    are P_{k-p}..P_k.  Works for clamped and unclamped knots.

    Returns
    -------
    breaks : ndarray
        The distinct knot values bounding the pieces (length = pieces + 1).
    pieces : list of ndarray
        Each of shape (p + 1, ...) with the trailing dimensions of ``points``.
    """
    U = np.asarray(knots, dtype=np.float64)
    P = np.asarray(points, dtype=np.float64)
    p = degree
    lo, hi = domain(U, p)
    for value in np.unique(U[(U >= lo) & (U <= hi)]):
        mult = int(np.count_nonzero(U == value))
        if mult < p:
            U, P = insert_knot(U, p, P, float(value), p - mult)
    n = len(U) - p - 2
    pieces = []
    breaks = [lo]
    for k in range(p, n + 1):
        if U[k] < U[k + 1]:
            pieces.append(P[k - p : k + 1].copy())
            breaks.append(float(U[k + 1]))
    return np.array(breaks), pieces
