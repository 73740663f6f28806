"""Shape optimisation of a hole filling on the surface itself (Kiciak 2016, §5.4).

A filling of an n-sided hole (:mod:`~gshade.geometry.hole_fill`) is n Bézier patches
P_0, ..., P_(n-1) of degree (d, d) whose control points x (shape (N, 3), N = n (d + 1)^2, row
(d + 1)^2 i + (d + 1) a + b holding P_i[a, b]) satisfy linear junction conditions C x = r,
the same for x, y and z.  The quadratic construction gives one solution x0 and a basis Z
(shape (N, k), C Z = 0) of the directions that keep every condition, so the admissible
fillings are

    x(Y) = x0 + Z Y,        Y of shape (k, 3).

The quadratic functionals (thin-plate energies) depend on the parametrisation.  Here one of
Kiciak's *shape* functionals, which depend only on the surface M, is lowered over Y:

    "mean"           F_b = int_M H^2 dA                (order 2; for G1 fillings)
    "mean-gradient"  F_d = int_M |grad_M H|^2 dA       (order 3; for G2 fillings)

(the names of BSTools' eghole manual, ``doc/English/eghole.tex``), H the mean curvature and
grad_M H its gradient on the surface.  With N = p_u x p_v, W = |N|, E, F, G the first
fundamental form and L', M', N' the second w.r.t. N (:mod:`~gshade.geometry.differential`),

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

Cache.  :func:`optimise_filling` (what a scene's ``optimise`` key runs: seconds per hole)
keeps its results by content: the key is a SHA-256 of the start x0, the basis Z, n, the
degree, the measure, the steps, ``free``, the versions of gshade, numpy and scipy and the
source of the modules the result depends on, so an entry is found only for the same
computation.  Entries live in memory (:data:`CACHE_ENTRIES` per process) and on disk,
one small file per filling in :func:`cache_folder` (``$GSHADE_CACHE_DIR``, else
``$XDG_CACHE_HOME/gshade`` or ``~/.cache/gshade``, subfolder ``hole-shape``;
``GSHADE_CACHE_DIR=off``: memory only).  A file is written to a temporary beside it and
renamed (concurrent writers each put a whole file there), and one read back is trusted only
if it is a regular file (not a link) of bounded size, its header names the same key, its
checksum and shape fit, its points are finite, its move x - x0 lies in the span of Z (so
the junction conditions hold as for a fresh result) and its ``final_check`` is what the
points give; otherwise it is ignored and recomputed (and overwritten).  Deleting the folder
is always safe.

References
----------
P. Kiciak, *Geometric Continuity of Curves and Surfaces* (2016), §5.4 (shape optimisation of
hole fillings).  P. Kiciak, BSTools (LGPL), https://github.com/radek-p/BSTools,
``doc/English/eghole.tex`` (the functionals F_b and F_d; no text or code taken).
"""

from __future__ import annotations

import hashlib
import json
import os
import stat
import threading
import time
from collections import OrderedDict
from dataclasses import asdict, dataclass, fields, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import GshadeError, one_of, show, suggest
from ..geometry.bernstein import bernstein_basis
from ..geometry.blas_threads import single_threaded_blas
from ..geometry.differential import fundamental_forms, mean_from_forms
from ..geometry.hole_fill import HoleFilling, filling_patches
from .jets import Jet

__all__ = [
    "CACHE_ENTRIES",
    "CACHE_VARIABLE",
    "FREE",
    "ITERATIONS",
    "SHAPE_MEASURES",
    "ShapeMeasure",
    "ShapeOptimisation",
    "ShapeProblem",
    "cache_folder",
    "default_quadrature",
    "optimise_filling",
    "optimise_shape",
    "shape_measure",
]

#: How the control points may move (:func:`optimise_shape`'s ``free``).
FREE = ("all", "normal")
#: Default number of trust-region steps of :func:`optimise_shape`.
ITERATIONS = 10
#: The complex step, relative to the first derivatives' size.
_STEP = 1e-20

Slot = tuple[int, int]


@dataclass(frozen=True)
class ShapeMeasure:
    """A shape functional int_M |f|^2 dA.

    Attributes
    ----------
    name : str
        Its key in :data:`SHAPE_MEASURES`.
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
SHAPE_MEASURES: dict[str, ShapeMeasure] = {
    "mean": ShapeMeasure("mean", 2, 1, "F_b", "int_M H^2 dA (mean curvature; G1 fillings)"),
    "mean-gradient": ShapeMeasure(
        "mean-gradient",
        3,
        2,
        "F_d",
        "int_M |grad_M H|^2 dA (surface gradient of the mean curvature; G2 fillings)",
    ),
}


@dataclass(frozen=True)
class ShapeOptimisation:
    """What :func:`optimise_shape` did.

    Attributes
    ----------
    measure : str
        The functional (a key of :data:`SHAPE_MEASURES`).
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


class ShapeProblem:
    """The least-squares problem rho(Y) of a shape functional over x0 + Z Y.

    The maps Y -> p_(ij) at the quadrature points are precomputed (module docstring);
    :meth:`residuals` and :meth:`jacobian` take Y flattened row-major (entry 3 l + c is
    Y[l, c]), as :func:`scipy.optimize.least_squares` does.

    Parameters
    ----------
    x0 : ndarray, shape (N, 3)
    Z : ndarray, shape (N, k)
    n, degree : int
    measure : ShapeMeasure
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
        measure: ShapeMeasure,
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


def _measure(measure: Any) -> ShapeMeasure:
    if not (isinstance(measure, str) and measure in SHAPE_MEASURES):
        hint = suggest(measure, tuple(SHAPE_MEASURES)) if isinstance(measure, str) else ""
        raise GshadeError(
            f"measure: expected one of {one_of(tuple(SHAPE_MEASURES))}, got {show(measure)}{hint}"
        )
    return SHAPE_MEASURES[measure]


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
) -> tuple[NDArray[np.float64], NDArray[np.float64], int, int, ShapeMeasure, int]:
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
def shape_measure(
    x: ArrayLike, n: int, degree: int, measure: str, *, quadrature: int | None = None
) -> float:
    """The shape functional ``measure`` of the filling with control points ``x``.

    Parameters
    ----------
    x : array_like, shape (n (degree + 1)^2, 3)
        The nets of P_0, ..., P_(n-1), row (d + 1)^2 i + (d + 1) a + b holding P_i[a, b].
    n, degree : int
        Patches and their degree (d, d).
    measure : {"mean", "mean-gradient"}
        See :data:`SHAPE_MEASURES`.
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
    rho = ShapeProblem(xv, Z, n, degree, m, q).residuals(np.zeros(0))
    return float(rho @ rho)


@single_threaded_blas
def optimise_shape(
    x0: ArrayLike,
    Z: ArrayLike,
    n: int,
    degree: int,
    measure: str,
    *,
    iterations: int = ITERATIONS,
    quadrature: int | None = None,
    free: str = "all",
) -> tuple[NDArray[np.float64], ShapeOptimisation]:
    """Lower a shape functional over the fillings x0 + Z Y (module docstring).

    Parameters
    ----------
    x0 : array_like, shape (N, 3)
        The quadratic solution (the start), N = n (degree + 1)^2, row
        (d + 1)^2 i + (d + 1) a + b holding P_i[a, b].
    Z : array_like, shape (N, k)
        A basis of the null space of the conditions (C Z = 0), e.g. from
        :func:`gshade.geometry.hole_fill.solve_qp`.
    n : int
        Sides of the hole (>= 3).
    degree : int
        The patches' degree d in each direction (>= the measure's order).
    measure : {"mean", "mean-gradient"}
        F_b = int H^2 dA or F_d = int |grad_M H|^2 dA (:data:`SHAPE_MEASURES`).
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
    info : ShapeOptimisation
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
    problem = ShapeProblem(x, B, n, degree, m, q)
    rho0 = problem.residuals(np.zeros(problem.size))
    if not np.all(np.isfinite(rho0)):
        raise GshadeError(
            f"x0: the start is irregular (p_u x p_v = 0 at a quadrature point), {m.name} is "
            "undefined there"
        )
    normal0 = problem.normals(np.zeros(problem.size))
    if free == "normal":  # the area-weighted mean normal nu: Y = y nu^T
        nu = problem.weight @ normal0
        problem = ShapeProblem(x, B, n, degree, m, q, (nu / np.linalg.norm(nu))[None, :])
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
    check = shape_measure(out, n, degree, m.name, quadrature=2 * q)
    if final < initial and not check < shape_measure(x, n, degree, m.name, quadrature=2 * q):
        out, final, converged = x, initial, False
        check = shape_measure(x, n, degree, m.name, quadrature=2 * q)
        message = (
            "discarded: no better with 2 x quadrature points (the quadrature's error was "
            "exploited; raise quadrature); x0 returned"
        )
    info = ShapeOptimisation(
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


@single_threaded_blas
def optimise_filling(
    filling: HoleFilling, measure: str, *, iterations: int = ITERATIONS, free: str = "all"
) -> HoleFilling:
    """The hole filling with ``measure`` lowered by :func:`optimise_shape` within the space
    of fillings meeting the same conditions (``filling.free_basis``); ``shape`` holds the
    report, ``energy`` stays the quadratic solution's.

    The result is cached by content, in memory and on disk (module docstring, *Cache*): the
    same filling, measure, steps and ``free`` give the same points without the optimisation.
    """
    start = time.perf_counter()
    n = len(filling.patches)
    x0, Z = np.asarray(filling.nets, dtype=np.float64), np.asarray(filling.free_basis)
    key = None
    if isinstance(measure, str) and measure in SHAPE_MEASURES and free in FREE:
        key = _cache_key(x0, Z, n, filling.degree, measure, iterations, free)
    found = None if key is None else _cached(key, x0, Z, n, filling.degree, measure)
    if found is not None:
        x, info = found
        info = replace(info, seconds=time.perf_counter() - start, cached=True)
    else:
        x, info = optimise_shape(
            x0, Z, n, filling.degree, measure, iterations=iterations, free=free
        )
        if key is not None:
            _store(key, x, info)
    patches = filling_patches(x, n, filling.degree)
    return replace(filling, patches=patches, nets=x, shape=info)


# --------------------------------------------------------------------------- the cache

#: Environment variable: the folder of gshade's caches (``off``: none on disk).
CACHE_VARIABLE = "GSHADE_CACHE_DIR"
#: Optimised fillings kept in memory per process (the least recently used go first).
CACHE_ENTRIES = 512
#: The first line of a cache file, and the largest file read (n = 100 patches of degree 9:
#: 240 kB of points).
_MAGIC = b"gshade hole-shape cache 1\n"
_MAX_CACHE_FILE = 4 * 2**20
#: A cached move x - x0 must lie in the span of Z to this (relative to the points' size).
_SPAN_TOL = 1e-9
_memory: OrderedDict[str, tuple[NDArray[np.float64], ShapeOptimisation]] = OrderedDict()
_lock = threading.Lock()


def cache_folder() -> Path | None:
    """The folder of the cached optimised fillings: ``$GSHADE_CACHE_DIR/hole-shape``, else
    ``$XDG_CACHE_HOME/gshade/hole-shape`` (an absolute path) or
    ``~/.cache/gshade/hole-shape``; None with ``GSHADE_CACHE_DIR=off`` (or no home)."""
    given = os.environ.get(CACHE_VARIABLE, "").strip()
    if given.lower() == "off":
        return None
    if given:
        return Path(given) / "hole-shape"
    xdg = os.environ.get("XDG_CACHE_HOME", "").strip()
    if xdg and os.path.isabs(xdg):
        return Path(xdg) / "gshade" / "hole-shape"
    try:
        return Path.home() / ".cache" / "gshade" / "hole-shape"
    except (RuntimeError, KeyError, OSError):
        return None


@lru_cache(maxsize=1)
def _fingerprint() -> bytes:
    """What a result depends on besides its inputs: the versions and the source of the
    modules of the optimisation (an edit to them is another computation)."""
    import scipy

    from .. import __version__
    from ..geometry import bernstein, differential, hole_fill
    from . import jets

    h = hashlib.sha256(f"{__version__} {np.__version__} {scipy.__version__}".encode())
    modules = (__file__, jets.__file__, differential.__file__, bernstein.__file__)
    for module in (*modules, hole_fill.__file__):
        try:
            h.update(Path(str(module)).read_bytes())
        except OSError:
            h.update(str(module).encode())
    return h.digest()


def _cache_key(
    x0: NDArray[np.float64],
    Z: NDArray[np.float64],
    n: int,
    degree: int,
    measure: str,
    iterations: Any,
    free: str,
) -> str | None:
    """The SHA-256 (hex) naming one optimisation; None for inputs that are not arrays of
    numbers (the optimisation says what is wrong with them)."""
    if Z.dtype.kind not in "fiu" or isinstance(iterations, bool):
        return None
    if not isinstance(iterations, (int, np.integer)):
        return None
    h = hashlib.sha256(_MAGIC + _fingerprint())
    head = [int(n), int(degree), measure, int(iterations), free, x0.shape, Z.shape]
    h.update(json.dumps(head).encode())
    h.update(np.ascontiguousarray(x0, dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(Z, dtype="<f8").tobytes())
    return h.hexdigest()


def _cached(
    key: str,
    x0: NDArray[np.float64],
    Z: NDArray[np.float64],
    n: int,
    degree: int,
    measure: str,
) -> tuple[NDArray[np.float64], ShapeOptimisation] | None:
    """The cached result of ``key``: from memory, else from a file checked to be sound."""
    with _lock:
        if key in _memory:
            _memory.move_to_end(key)
            x, info = _memory[key]
            return x.copy(), info
    folder = cache_folder()
    if folder is None:
        return None
    found = _read_entry(folder / f"{key}.bin", key, x0.shape)
    if found is None:
        return None
    x, info = found
    if not _sound(x, info, x0, Z, n, degree, measure):
        return None
    _remember(key, x, info)
    return x, info


def _read_entry(
    path: Path, key: str, shape: tuple[int, ...]
) -> tuple[NDArray[np.float64], ShapeOptimisation] | None:
    """A cache file's points and report, or None for any file that is not a whole entry of
    this key (missing, a link, not a regular file, too large, truncated, another format)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOFOLLOW", 0))
    except (OSError, ValueError):
        return None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode) or info.st_size > _MAX_CACHE_FILE:
            return None
        with os.fdopen(os.dup(fd), "rb") as f:
            data = f.read(_MAX_CACHE_FILE + 1)
    except OSError:
        return None
    finally:
        os.close(fd)
    try:
        if not data.startswith(_MAGIC) or len(data) > _MAX_CACHE_FILE:
            return None
        end = data.index(b"\n", len(_MAGIC))
        header = json.loads(data[len(_MAGIC) : end].decode("utf-8"))
        payload = data[end + 1 :]
        if not isinstance(header, dict) or header.get("key") != key:
            return None
        if header.get("sha256") != hashlib.sha256(payload).hexdigest():
            return None
        if len(payload) != 8 * int(np.prod(shape)):
            return None
        x = np.frombuffer(payload, dtype="<f8").astype(np.float64).reshape(shape)
        report = _report(header.get("info"))
    except (ValueError, TypeError, KeyError, UnicodeDecodeError, RecursionError):
        return None
    if report is None or not np.all(np.isfinite(x)):
        return None
    return x, report


def _report(raw: Any) -> ShapeOptimisation | None:
    """A :class:`ShapeOptimisation` from a cache file's JSON, each field of its type."""
    if not isinstance(raw, dict):
        return None
    kinds: dict[str, type] = {"float": float, "int": int, "bool": bool, "str": str}
    values: dict[str, Any] = {}
    for f in fields(ShapeOptimisation):
        if f.name in ("cached", "seconds"):
            continue
        value: Any = raw.get(f.name)
        kind = kinds[str(f.type)]
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if type(value) is not kind:
            return None
        if isinstance(value, str) and len(value) > 1000:
            return None
        values[f.name] = value
    if values["measure"] not in SHAPE_MEASURES:
        return None
    return ShapeOptimisation(seconds=0.0, **values)


def _sound(
    x: NDArray[np.float64],
    info: ShapeOptimisation,
    x0: NDArray[np.float64],
    Z: NDArray[np.float64],
    n: int,
    degree: int,
    measure: str,
) -> bool:
    """Whether cached points are a filling this optimisation could give: x - x0 in the span
    of Z (the junction conditions hold) and the report's ``final_check`` theirs."""
    if info.measure != measure:
        return False
    move = x - x0
    scale = max(1.0, float(np.abs(x0).max()))
    if Z.shape[1]:
        Y = np.linalg.lstsq(Z, move, rcond=None)[0]
        move = move - Z @ Y
    if not float(np.abs(move).max()) <= _SPAN_TOL * scale:
        return False
    check = shape_measure(x, n, degree, measure, quadrature=2 * info.quadrature)
    return bool(abs(check - info.final_check) <= 1e-9 * max(abs(check), 1e-300))


def _remember(key: str, x: NDArray[np.float64], info: ShapeOptimisation) -> None:
    with _lock:
        _memory[key] = (x.copy(), replace(info, cached=False))
        _memory.move_to_end(key)
        while len(_memory) > CACHE_ENTRIES:
            _memory.popitem(last=False)


def _store(key: str, x: NDArray[np.float64], info: ShapeOptimisation) -> None:
    """Keep a result in memory and, best effort, on disk (an unwritable folder: memory)."""
    import tempfile  # here, not on the import path of every command

    _remember(key, x, info)
    folder = cache_folder()
    if folder is None:
        return
    payload = np.ascontiguousarray(x, dtype="<f8").tobytes()
    report = {k: v for k, v in asdict(info).items() if k not in ("cached", "seconds")}
    header = {"key": key, "sha256": hashlib.sha256(payload).hexdigest(), "info": report}
    data = _MAGIC + json.dumps(header).encode() + b"\n" + payload
    try:
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{key[:16]}.", suffix=".tmp", dir=folder)
    except OSError:
        return
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, folder / f"{key}.bin")  # atomic: readers see a whole file
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if not isinstance(exc, OSError):
            raise
