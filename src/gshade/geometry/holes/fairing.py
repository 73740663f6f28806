"""Fairing of a hole filling on the surface itself (Kiciak 2016, §5.4: shape optimisation).

A filling of an n-sided hole (:mod:`~gshade.geometry.holes.fill`) is n Bézier patches
P_0, ..., P_(n-1) of degree (d, d) whose control points x (shape (N, 3), N = n (d + 1)^2, row
(d + 1)^2 i + (d + 1) a + b holding P_i[a, b]) satisfy linear junction conditions C x = r,
the same for x, y and z.  The quadratic construction gives one solution x0 and a basis Z
(shape (N, k), C Z = 0) of the directions that keep every condition, so the admissible
fillings are

    x(Y) = x0 + Z Y,        Y of shape (k, 3).

The quadratic functionals (thin-plate energies) depend on the parametrisation.  Here one of
Kiciak's *shape* functionals (fairing functionals: they depend only on the surface M) is
lowered over Y:

    "mean"           F_b = int_M H^2 dA                (order 2; for G1 fillings)
    "mean-gradient"  F_d = int_M |grad_M H|^2 dA       (order 3; for G2 fillings)

(the names of BSTools' eghole manual, ``doc/English/eghole.tex``), H the mean curvature and
grad_M H its gradient on the surface.  With N = p_u x p_v, W = |N|, E, F, G the first
fundamental form and L', M', N' the second w.r.t. N (:mod:`~gshade.geometry.core.differential`),

    H = (E N' - 2 F M' + G L') / (2 W^3),          dA = W du dv,
    grad_M H = a p_u + b p_v  with  [E F; F G] (a, b) = (H_u, H_v),
    |grad_M H|^2 = g1^2 + g2^2,  g1 = H_u / sqrt(E),  g2 = (E H_v - F H_u) / (sqrt(E) W),

(g1, g2) being grad_M H in the orthonormal tangent frame e1 = p_u / |p_u|, e2 = n x e1 (the
Cholesky factor of the first form).  The surface integral is the sum of the patches'
integrals over [0, 1]^2, each in its own parameters (it does not depend on the
parametrisation).  With Gauss–Legendre nodes and weights w_q on each patch

    F(Y) ~ sum_q |rho_q(Y)|^2,   rho_q = sqrt(w_q W_q) f_q,   f = H or (g1, g2),

a nonlinear least-squares problem, solved by scipy's trust-region Gauss–Newton /
Levenberg–Marquardt method (:func:`scipy.optimize.least_squares`, "trf", subproblems by
LSMR) from the quadratic solution Y = 0, for at most ``iterations`` steps.

Jacobian.  The derivatives p_(ij) of every patch at the quadrature points are *linear* in
Y: p_(ij)(q) = B_ij(q) x0_i + B_ij(q) Z_i Y (B_ij the tensor-product Bernstein derivative
rows, Z_i the rows of Z of patch i); the matrices A_ij = B_ij Z_i are computed once.  The
residual at a point depends on 15 numbers (p_u, p_v, p_uu, p_uv, p_vv; for
"mean-gradient" 27: the third derivatives too), so d rho / d p_(ij) is taken at every point
by the complex step, rho(p + i h e) = rho(p) + i h rho'(p) e + O(h^2) (exact to round-off:
no difference is taken), all 15 or 27 directions in one vectorised evaluation; the chain
rule gives d rho / d Y = sum_ij (d rho / d p_(ij)) A_ij.

The conditions C x = r hold for every Y to round-off (C Z = 0): the optimised filling is as
G1 (or G2) as the quadratic one.

Free directions.  ``free="all"`` lets every control point move in space (Y free, 3 k
parameters: the largest decrease, but the points may also slide along the surface);
``free="normal"`` moves them along one direction only, the start's area-weighted mean
normal nu (Y = y nu^T, k parameters), as Kiciak does for F_d (the surface changed as a
graph over a plane): cheaper, converging in fewer steps, a smaller decrease.

Warning.  Like Kiciak's minimisation of F_b and F_d ("more troublesome and time consuming";
it may fail for some surfaces), this may fail when the surface is not flat enough: the
functionals are not convex, a step may fold a patch (W -> 0, where H is undefined), and the
minimum found is local.  Safeguards: steps with undefined residuals are rejected by the
trust region, so the quadrature sum never rises; a result whose normals turned over against
the start's (a fold) is discarded; and the result is taken only if the measure with twice
the quadrature points per direction (``final_check``) is lower than the start's too, since
with too few points the optimiser lowers the sum by exploiting the quadrature's error
rather than the integral.  A discarded result returns x0 and says why in the report.

Cache.  :func:`gshade.geometry.holes.fairing_cache.optimise_filling` (what a scene's ``optimise``
key runs) keeps the results by content (:mod:`gshade.geometry.holes.fairing_cache`).

References
----------
P. Kiciak, *Geometric Continuity of Curves and Surfaces* (2016), §5.4 (shape optimisation of
hole fillings).  P. Kiciak, BSTools (LGPL), https://github.com/radek-p/BSTools,
``doc/English/eghole.tex`` (the functionals F_b and F_d; no text or code taken).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...errors import GshadeError, one_of, show, suggest
from ..core.bernstein import bernstein_basis
from ..core.blas_threads import single_threaded_blas
from ..core.differential import fundamental_forms, mean_from_forms
from ..core.jets import Jet

__all__ = [
    "FAIRING_FUNCTIONALS",
    "FREE",
    "ITERATIONS",
    "FairingFunctional",
    "FairingProblem",
    "FairingReport",
    "default_quadrature",
    "fairing_value",
    "optimise_fairing",
]

#: How the control points may move (:func:`optimise_fairing`'s ``free``).
FREE = ("all", "normal")
#: Default number of trust-region steps of :func:`optimise_fairing`.
ITERATIONS = 10
#: The complex step, relative to the first derivatives' size.
_STEP = 1e-20

Slot = tuple[int, int]


@dataclass(frozen=True)
class FairingFunctional:
    """A shape functional int_M |f|^2 dA.

    Attributes
    ----------
    name : str
        Its key in :data:`FAIRING_FUNCTIONALS`.
    order : int
        The highest derivative of the surface it uses.
    components : int
        The numbers f has at a point (1 for H, 2 for grad_M H in a tangent frame).
    kiciak : str
        Kiciak's name for it (BSTools, eghole).
    summary : str
        The formula.
    """

    name: str
    order: int
    components: int
    kiciak: str
    summary: str


#: The shape functionals by name (module docstring).
FAIRING_FUNCTIONALS: dict[str, FairingFunctional] = {
    "mean": FairingFunctional("mean", 2, 1, "F_b", "int_M H^2 dA (mean curvature; G1 fillings)"),
    "mean-gradient": FairingFunctional(
        "mean-gradient",
        3,
        2,
        "F_d",
        "int_M |grad_M H|^2 dA (surface gradient of the mean curvature; G2 fillings)",
    ),
}


@dataclass(frozen=True)
class FairingReport:
    """What :func:`optimise_fairing` did.

    Attributes
    ----------
    measure : str
        The functional (a key of :data:`FAIRING_FUNCTIONALS`).
    initial, final : float
        Its value by the quadrature at the start and at the result; final <= initial.
    final_check : float
        The result's value with twice the quadrature points per direction (close to
        ``final`` when the quadrature is fine enough).
    iterations : int
        Trust-region steps tried (accepted or not).
    jacobians : int
        Jacobians evaluated (the start's and one per accepted step).
    converged : bool
        Whether a convergence test stopped it (False: ``iterations`` did, or it failed).
    message : str
        Why it stopped (scipy's reason, or why the result was discarded).
    seconds : float
        Wall time of the whole optimisation (set-up included).
    quadrature : int
        Gauss–Legendre points per direction and patch.
    parameters : int
        Free parameters, 3 k.
    cached : bool
        Whether :func:`optimise_filling` found the result in its cache (``seconds`` is then
        the look-up's time).
    """

    measure: str
    initial: float
    final: float
    final_check: float
    iterations: int
    jacobians: int
    converged: bool
    message: str
    seconds: float
    quadrature: int
    parameters: int
    cached: bool = False


# --------------------------------------------------------------------------- the integrand


def _sqrt(a: Jet) -> Jet:
    """sqrt of a jet (analytic: complex values pass through, for the complex step)."""
    r = np.sqrt(a.f)
    s = 0.5 / r
    return Jet(r, s * a.u, s * a.v)


def _residuals(d: dict[Slot, Any], weight: Any, order: int) -> Any:
    """rho = sqrt(w W) f at every point, shape (..., components): ``d[i, j]`` holds the
    derivatives p_(ij) (shape (..., 3), real or complex), ``weight`` the quadrature weights.
    Only +, -, *, / and sqrt: analytic, so the complex step differentiates it exactly."""
    if order == 2:

        def comp(i: int, j: int) -> tuple[Any, Any, Any]:
            a = d[i, j]
            return a[..., 0], a[..., 1], a[..., 2]

        f = fundamental_forms(comp(1, 0), comp(0, 1), comp(2, 0), comp(1, 1), comp(0, 2))
        W = np.sqrt(f.W2)
        return (np.sqrt(weight * W) * mean_from_forms(f, W))[..., None]

    def vec(i: int, j: int) -> tuple[Jet, Jet, Jet]:
        a, b, c = d[i, j], d[i + 1, j], d[i, j + 1]
        x, y, z = (Jet(a[..., m], b[..., m], c[..., m]) for m in range(3))
        return x, y, z

    f = fundamental_forms(vec(1, 0), vec(0, 1), vec(2, 0), vec(1, 1), vec(0, 2))
    W = _sqrt(f.W2)
    H = mean_from_forms(f, W)
    # grad_M H in the orthonormal frame (p_u / sqrt(E), n x p_u / sqrt(E))
    E, F, root = f.E.f, f.F.f, np.sqrt(f.E.f)
    s = np.sqrt(weight * W.f)
    return np.stack([s * H.u / root, s * (E * H.v - F * H.u) / (root * W.f)], axis=-1)


# --------------------------------------------------------------------------- the problem


class FairingProblem:
    """The least-squares problem rho(Y) of a shape functional over x0 + Z Y.

    The maps Y -> p_(ij) at the quadrature points are precomputed (module docstring);
    :meth:`residuals` and :meth:`jacobian` take Y flattened row-major (entry 3 l + c is
    Y[l, c]), as :func:`scipy.optimize.least_squares` does.

    Parameters
    ----------
    x0 : ndarray, shape (N, 3)
    Z : ndarray, shape (N, k)
    n, degree : int
    measure : FairingFunctional
    quadrature : int
        Gauss–Legendre points per direction and patch.
    directions : ndarray, shape (m, 3), optional
        Orthonormal directions D the control points may move in: Y = y D with y of shape
        (k, m) (default the identity: Y = y, every direction).
    """

    def __init__(
        self,
        x0: NDArray[np.float64],
        Z: NDArray[np.float64],
        n: int,
        degree: int,
        measure: FairingFunctional,
        quadrature: int,
        directions: NDArray[np.float64] | None = None,
    ) -> None:
        self.k = Z.shape[1]
        self.D = np.eye(3) if directions is None else np.asarray(directions, dtype=np.float64)
        self.size = self.k * self.D.shape[0]
        self.order = measure.order
        self.components = measure.components
        t, w = np.polynomial.legendre.leggauss(quadrature)
        t, w = 0.5 * (t + 1.0), 0.5 * w
        B = bernstein_basis(degree, t, measure.order)  # (order + 1, q, d + 1)
        self.slots: list[Slot] = [
            (i, j) for i in range(self.order + 1) for j in range(self.order + 1 - i) if i + j
        ]
        size = (degree + 1) ** 2
        xs, Zs = x0.reshape(n, size, 3), Z.reshape(n, size, self.k)
        points = n * quadrature**2
        self.A: dict[Slot, NDArray[np.float64]] = {}
        self.D0: dict[Slot, NDArray[np.float64]] = {}
        for i, j in self.slots:
            M = np.kron(B[i], B[j])  # (q^2, size): row q_u q + q_v, column a (d + 1) + b
            self.A[i, j] = np.einsum("qs,psk->pqk", M, Zs).reshape(points, self.k)
            self.D0[i, j] = np.einsum("qs,psc->pqc", M, xs).reshape(points, 3)
        self.weight = np.tile(np.outer(w, w).ravel(), n)
        scale = max(float(np.abs(self.D0[1, 0]).max()), float(np.abs(self.D0[0, 1]).max()))
        self.h = _STEP * (scale if scale > 0 else 1.0)

    def derivatives(self, y: NDArray[np.float64]) -> dict[Slot, NDArray[np.float64]]:
        """p_(ij) at the quadrature points (shape (points, 3) each) for Y = y."""
        Y = np.reshape(y, (self.k, self.D.shape[0])) @ self.D
        return {s: self.D0[s] + self.A[s] @ Y for s in self.slots}

    def residuals(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        """rho (points x components, flattened); sum rho^2 is the measure."""
        with np.errstate(all="ignore"):
            rho = _residuals(self.derivatives(y), self.weight, self.order)
        return np.asarray(rho, dtype=np.float64).reshape(-1)

    def jacobian(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        """d rho / d y, shape (points x components, k m)."""
        d = self.derivatives(y)
        S, P = len(self.slots), self.weight.size
        # the 3 S input directions (slot m, coordinate c), each perturbed by i h
        batch = {}
        for m, s in enumerate(self.slots):
            z = np.broadcast_to(d[s].astype(np.complex128), (3 * S, P, 3)).copy()
            for c in range(3):
                z[3 * m + c, :, c] += 1j * self.h
            batch[s] = z
        with np.errstate(all="ignore"):
            g = np.imag(_residuals(batch, self.weight, self.order)) / self.h  # (3S, P, R)
        g = np.einsum("scpr,jc->sjpr", g.reshape(S, 3, P, self.components), self.D)
        A = np.stack([self.A[s] for s in self.slots])  # (S, P, k)
        J = np.einsum("sjpr,spl->prlj", g, A, optimize=True)
        return J.reshape(P * self.components, self.size)

    def normals(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        """p_u x p_v at the quadrature points (points, 3)."""
        d = self.derivatives(y)
        return np.cross(d[1, 0], d[0, 1])


# --------------------------------------------------------------------------- public API


def _measure(measure: Any) -> FairingFunctional:
    if not (isinstance(measure, str) and measure in FAIRING_FUNCTIONALS):
        hint = suggest(measure, tuple(FAIRING_FUNCTIONALS)) if isinstance(measure, str) else ""
        known = one_of(tuple(FAIRING_FUNCTIONALS))
        raise GshadeError(f"measure: expected one of {known}, got {show(measure)}{hint}")
    return FAIRING_FUNCTIONALS[measure]


def _count(name: str, value: Any, least: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
        raise GshadeError(f"{name}: expected an integer >= {least}, got {show(value)}")
    return int(value)


def default_quadrature(degree: int, measure: str) -> int:
    """Gauss–Legendre points per direction used unless asked otherwise: degree + 7 (12 at
    degree 5, 16 at degree 9), for both measures.  Measured on the wavy holes (n = 3, 5, 6,
    20 steps): the optimised measures agree with 40 x 40 points to <= 1e-3 relative; with
    degree + 4 points the "mean" optimisation of a degree-9 filling exploited the
    quadrature's error (a 20 % lower sum, a higher integral)."""
    _measure(measure)
    return int(degree) + 7


def _array(name: str, value: Any) -> NDArray[np.float64]:
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise GshadeError(f"{name}: expected an array of numbers, got {show(value)}") from None


def _inputs(
    x0: ArrayLike, Z: ArrayLike, n: Any, degree: Any, measure: Any, quadrature: Any
) -> tuple[NDArray[np.float64], NDArray[np.float64], int, int, FairingFunctional, int]:
    m = _measure(measure)
    n = _count("n", n, 3)
    degree = _count("degree", degree, m.order)
    q = (
        default_quadrature(degree, m.name)
        if quadrature is None
        else _count("quadrature", quadrature, 1)
    )
    size = n * (degree + 1) ** 2
    x = _array("x0", x0)
    if x.shape != (size, 3) or not np.all(np.isfinite(x)):
        raise GshadeError(
            f"x0: expected {size} x 3 finite numbers (n = {n} nets of degree ({degree}, "
            f"{degree})), got shape {x.shape}"
        )
    B = _array("Z", Z)
    if B.ndim != 2 or B.shape[0] != size or not np.all(np.isfinite(B)):
        raise GshadeError(f"Z: expected a finite {size} x k matrix, got shape {B.shape}")
    return x, B, n, degree, m, q


@single_threaded_blas
def fairing_value(
    x: ArrayLike, n: int, degree: int, measure: str, *, quadrature: int | None = None
) -> float:
    """The fairing functional ``measure`` of the filling with control points ``x``.

    Parameters
    ----------
    x : array_like, shape (n (degree + 1)^2, 3)
        The nets of P_0, ..., P_(n-1), row (d + 1)^2 i + (d + 1) a + b holding P_i[a, b].
    n, degree : int
        Patches and their degree (d, d).
    measure : {"mean", "mean-gradient"}
        See :data:`FAIRING_FUNCTIONALS`.
    quadrature : int, optional
        Gauss–Legendre points per direction and patch (default :func:`default_quadrature`).

    Returns
    -------
    float
        The sum over the patches of the Gauss–Legendre sums of |f|^2 W (NaN where a
        quadrature point is irregular).

    Raises
    ------
    GshadeError
        Naming the bad argument.
    """
    x0 = _array("x0", x)
    Z = np.zeros((x0.shape[0] if x0.ndim else 0, 0))
    xv, Z, n, degree, m, q = _inputs(x0, Z, n, degree, measure, quadrature)
    rho = FairingProblem(xv, Z, n, degree, m, q).residuals(np.zeros(0))
    return float(rho @ rho)


@single_threaded_blas
def optimise_fairing(
    x0: ArrayLike,
    Z: ArrayLike,
    n: int,
    degree: int,
    measure: str,
    *,
    iterations: int = ITERATIONS,
    quadrature: int | None = None,
    free: str = "all",
) -> tuple[NDArray[np.float64], FairingReport]:
    """Lower a fairing functional over the fillings x0 + Z Y (module docstring).

    Parameters
    ----------
    x0 : array_like, shape (N, 3)
        The quadratic solution (the start), N = n (degree + 1)^2, row
        (d + 1)^2 i + (d + 1) a + b holding P_i[a, b].
    Z : array_like, shape (N, k)
        A basis of the null space of the conditions (C Z = 0), e.g. from
        :func:`gshade.geometry.holes.fill.solve_qp`.
    n : int
        Sides of the hole (>= 3).
    degree : int
        The patches' degree d in each direction (>= the measure's order).
    measure : {"mean", "mean-gradient"}
        F_b = int H^2 dA or F_d = int |grad_M H|^2 dA (:data:`FAIRING_FUNCTIONALS`).
    iterations : int
        The most trust-region steps (>= 0; 0 returns x0).
    quadrature : int, optional
        Gauss–Legendre points per direction and patch (default :func:`default_quadrature`).
    free : {"all", "normal"}
        "all": Y free (3 k parameters); "normal": Y = y nu^T with nu the start's
        area-weighted mean normal (k parameters), Kiciak's choice for F_d (the surface
        moved as a graph over its tangent plane: no tangential sliding of the
        parametrisation; cheaper, usually a smaller decrease).

    Returns
    -------
    x : ndarray, shape (N, 3)
        x0 + Z Y at the Y found (x0 itself if no step lowered the measure).
    info : FairingReport
        The measure before and after, the steps, the time.

    Raises
    ------
    GshadeError
        Naming the bad argument: an unknown measure, iterations or quadrature not an
        integer >= 0 (>= 1), shapes that do not fit, a degree below the measure's order,
        or a start that is irregular at a quadrature point (p_u x p_v = 0: H undefined).
    """
    start = time.perf_counter()
    x, B, n, degree, m, q = _inputs(x0, Z, n, degree, measure, quadrature)
    iterations = _count("iterations", iterations, 0)
    if free not in FREE:
        raise GshadeError(f"free: expected one of {one_of(FREE)}, got {show(free)}")
    problem = FairingProblem(x, B, n, degree, m, q)
    rho0 = problem.residuals(np.zeros(problem.size))
    if not np.all(np.isfinite(rho0)):
        raise GshadeError(
            f"x0: the start is irregular (p_u x p_v = 0 at a quadrature point), {m.name} is "
            "undefined there"
        )
    normal0 = problem.normals(np.zeros(problem.size))
    if free == "normal":  # the area-weighted mean normal nu: Y = y nu^T
        nu = problem.weight @ normal0
        problem = FairingProblem(x, B, n, degree, m, q, (nu / np.linalg.norm(nu))[None, :])
    y = np.zeros(problem.size)
    initial = final = float(rho0 @ rho0)
    steps = jacobians = 0
    converged, message = False, "no steps"
    if iterations > 0 and problem.size > 0:
        from scipy.optimize import least_squares  # 0.4 s to import: only when optimising

        res = least_squares(
            problem.residuals,
            y,
            jac=problem.jacobian,
            method="trf",
            tr_solver="lsmr",
            max_nfev=iterations + 1,
        )
        steps, jacobians = int(res.nfev) - 1, int(res.njev or 0)
        converged, message = bool(res.status > 0), str(res.message)
        value = float(res.fun @ res.fun)
        if not (np.all(np.isfinite(res.fun)) and value <= initial):
            pass  # no step was accepted
        elif not np.all(np.einsum("pc,pc->p", problem.normals(res.x), normal0) > 0.0):
            converged = False
            message = "discarded: the result folds (a normal turned over); x0 returned"
        else:
            y, final = res.x, value
    Y = y.reshape(problem.k, -1) @ problem.D
    out = x + B @ Y
    check = fairing_value(out, n, degree, m.name, quadrature=2 * q)
    if final < initial and not check < fairing_value(x, n, degree, m.name, quadrature=2 * q):
        out, final, converged = x, initial, False
        check = fairing_value(x, n, degree, m.name, quadrature=2 * q)
        message = (
            "discarded: no better with 2 x quadrature points (the quadrature's error was "
            "exploited; raise quadrature); x0 returned"
        )
    info = FairingReport(
        measure=m.name,
        initial=initial,
        final=final,
        final_check=check,
        iterations=steps,
        jacobians=jacobians,
        converged=converged,
        message=message,
        seconds=time.perf_counter() - start,
        quadrature=q,
        parameters=problem.size,
    )
    return out, info
