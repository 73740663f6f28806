"""The evaluation interface shared by all curves and patches, and tensor-product evaluation.

Every patch answers ``patch.derivatives(u, v, order)`` with an array of shape
``(order + 1, order + 1, *broadcast(u, v).shape, 3)`` whose entry ``[i, j]`` (for
i + j <= order) is the partial derivative d^(i+j) p / du^i dv^j; entries with i + j > order
are zero.  Every curve answers ``curve.derivatives(t, order)`` with shape
``(order + 1, *t.shape, dim)``.

Internally results are computed component-major (coordinate axis before the point axes) so
that the contractions are plain matrix products and every output is written once; the
returned arrays are views with the coordinate axis moved last.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...errors import GshadeError
from .bernstein import bernstein_basis
from .blas_threads import single_threaded_blas
from .knots import basis_functions, basis_matrix, validate_parameters
from .rational import project_curve_derivatives, project_patch_derivatives

__all__ = ["EXTENT_GRID", "Curve", "Patch", "TensorProductPatch", "unit_to_domain"]

Domain = tuple[tuple[float, float], tuple[float, float]]

#: Samples per side of a patch's parameter grid standing for the whole patch: its extent
#: (bounding boxes, framing) and, in ``gshade info``, its collapsed edges.
EXTENT_GRID = 17
#: Points are evaluated in chunks of this many, to bound temporary memory.
_CHUNK = 1 << 15


def unit_to_domain(
    domain: Domain | ArrayLike, s: ArrayLike, t: ArrayLike, index: ArrayLike | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Normalised parameters into a domain: u = u0 + (u1 - u0) s, v = v0 + (v1 - v0) t.

    ``domain`` is ((u0, u1), (v0, v1)), or an array of them of shape (..., 2, 2) that
    broadcasts with ``s`` and ``t`` (each point into its own patch's domain); with
    ``index``, an array (n, 2, 2) of which point k takes the domain ``index[k]``.
    """
    d = np.asarray(domain, dtype=np.float64)
    u0, u1, v0, v1 = d[..., 0, 0], d[..., 0, 1], d[..., 1, 0], d[..., 1, 1]
    if index is not None:  # gathered per component: contiguous, not (n, 2, 2) strided
        k = np.asarray(index, dtype=np.intp)
        u0, u1, v0, v1 = (c[k] for c in (u0, u1, v0, v1))
    return u0 + (u1 - u0) * np.asarray(s), v0 + (v1 - v0) * np.asarray(t)


def validate_order(order: int) -> int:
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or order < 0:
        raise GshadeError(f"order: expected an integer >= 0, got {order!r}")
    return int(order)


def _grid_axes(u: NDArray, v: NDArray) -> tuple[NDArray, NDArray] | None:
    """If (u, v) broadcast as an outer product (u down the rows, v along the columns),
    return the 1-D parameter vectors; otherwise None."""
    if u.ndim > 2 or v.ndim > 2 or max(u.ndim, v.ndim) < 2:
        return None
    u2, v2 = np.atleast_2d(u), np.atleast_2d(v)  # (1, n) from (n,): a leading axis
    if u2.shape[1] == 1 and v2.shape[0] == 1:
        return u2[:, 0], v2[0, :]
    return None


class Curve(ABC):
    """A parametric curve c(t) with derivatives; ``dim`` coordinates."""

    dim: int
    domain: tuple[float, float]

    def derivatives(self, t: ArrayLike, order: int = 0) -> NDArray[np.float64]:
        """Derivatives of order 0..order at t: shape (order + 1, *t.shape, dim)."""
        order = validate_order(order)
        lo, hi = self.domain
        t = validate_parameters(t, lo, hi, "t")
        flat = t.ravel()
        out = np.empty((order + 1, self.dim, flat.size))
        for start in range(0, flat.size, _CHUNK):
            sl = slice(start, start + _CHUNK)
            out[:, :, sl] = self._derivatives(flat[sl], order)
        return np.moveaxis(out, 1, -1).reshape((order + 1, *t.shape, self.dim))

    def __call__(self, t: ArrayLike) -> NDArray[np.float64]:
        """Points c(t), shape ``(*t.shape, dim)``."""
        return self.derivatives(t, 0)[0]

    @abstractmethod
    def _derivatives(self, t: NDArray, order: int) -> NDArray:
        """Component-major derivatives (order + 1, dim, N) at a flat array of parameters."""


class Patch(ABC):
    """A parametric surface patch p(u, v) with exact partial derivatives."""

    domain: Domain

    @single_threaded_blas
    def derivatives(
        self, u: ArrayLike, v: ArrayLike, order: int = 0, *, out: NDArray | None = None
    ) -> NDArray[np.float64]:
        """Partial derivatives up to total order ``order`` at (u, v).

        Parameters
        ----------
        u, v : array_like
            Parameters inside the domain; any shapes that broadcast together.  When they
            form an outer product (``u[:, None]``, ``v[None, :]``) a faster grid algorithm
            is used.
        order : int
            Highest total derivative order.
        out : ndarray, optional
            An array returned by an earlier call with the same shapes and order, to be
            overwritten (no new memory: the fastest way to evaluate repeatedly).  Entries
            with i + j > order are then left as they are.

        Returns
        -------
        ndarray, shape (order + 1, order + 1, *broadcast(u, v).shape, 3)
            Entry ``[i, j]`` is d^(i+j)p / du^i dv^j for i + j <= order, zero otherwise.

        Notes
        -----
        The matrix products run with one BLAS thread during the call, whatever the
        process's pool (restored on return; see :mod:`gshade.geometry.core.blas_threads`).
        """
        order = validate_order(order)
        (u0, u1), (v0, v1) = self.domain
        u = validate_parameters(u, u0, u1, "u")
        v = validate_parameters(v, v0, v1, "v")
        axes = _grid_axes(u, v)
        if axes is not None:
            shape = (axes[0].size, axes[1].size)
        else:
            try:
                shape = np.broadcast_shapes(u.shape, v.shape)
            except ValueError:
                raise GshadeError(
                    f"u, v: expected shapes that broadcast together, got {u.shape} and {v.shape}"
                ) from None
        buf = _component_major(out, order, shape)
        if axes is not None:
            self._derivatives_grid(axes[0], axes[1], order, buf)
        else:
            uf = np.broadcast_to(u, shape).ravel()
            vf = np.broadcast_to(v, shape).ravel()
            flat = buf.reshape(order + 1, order + 1, 3, -1)
            for start in range(0, uf.size, _CHUNK):
                sl = slice(start, start + _CHUNK)
                flat[:, :, :, sl] = self._derivatives_points(uf[sl], vf[sl], order)
        if out is None:
            return np.moveaxis(buf, 2, -1)
        if not np.shares_memory(buf, out):  # ``out`` had another layout: copy once
            out[...] = np.moveaxis(buf, 2, -1)
        return out

    def derivatives_grid(self, u: ArrayLike, v: ArrayLike, order: int = 0) -> NDArray:
        """Derivatives on the grid u x v (1-D arrays): shape (order+1, order+1, Nu, Nv, 3)."""
        u = np.asarray(u, dtype=np.float64).reshape(-1, 1)
        v = np.asarray(v, dtype=np.float64).reshape(1, -1)
        return self.derivatives(u, v, order)

    def __call__(self, u: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
        """Points p(u, v), shape ``(*broadcast(u, v).shape, 3)``."""
        return self.derivatives(u, v, 0)[0, 0]

    def parameter_grid(self, n_u: int, n_v: int) -> tuple[NDArray, NDArray]:
        """Evenly spaced parameters over the domain, shaped for the grid algorithm."""
        (u0, u1), (v0, v1) = self.domain
        return np.linspace(u0, u1, n_u)[:, None], np.linspace(v0, v1, n_v)[None, :]

    @abstractmethod
    def _derivatives_points(self, u: NDArray, v: NDArray, order: int) -> NDArray:
        """Component-major derivatives (order+1, order+1, 3, N) at flat parameter arrays."""

    def _derivatives_grid(self, u: NDArray, v: NDArray, order: int, buf: NDArray) -> None:
        """Write component-major derivatives on the grid u x v into buf (o+1, o+1, 3, Nu, Nv)."""
        uu, vv = np.meshgrid(u, v, indexing="ij")
        flat = buf.reshape(order + 1, order + 1, 3, -1)
        flat[...] = self._derivatives_points(uu.ravel(), vv.ravel(), order)


def _component_major(out: NDArray | None, order: int, shape: tuple[int, ...]) -> NDArray:
    """A (order+1, order+1, 3, *shape) buffer: ``out`` seen component-major if that is
    contiguous, else a fresh zeroed one (np.zeros costs nothing for untouched pages)."""
    full = (order + 1, order + 1, 3, *shape)
    if out is not None:
        expected = (order + 1, order + 1, *shape, 3)
        if out.shape != expected or out.dtype != np.float64:
            raise GshadeError(
                f"out: expected a float64 array of shape {expected}, got {out.dtype} {out.shape}"
            )
        view = np.moveaxis(out, -1, 2)
        if view.flags.c_contiguous:
            return view
    return np.zeros(full)


# --------------------------------------------------------------------------- bases


@dataclass(frozen=True)
class BernsteinBasis:
    """The Bernstein basis of a degree over an interval [a, b]."""

    degree: int
    interval: tuple[float, float]

    @property
    def n_points(self) -> int:
        return self.degree + 1

    def dense(self, t: NDArray, order: int) -> NDArray:
        a, b = self.interval
        out = bernstein_basis(self.degree, (t - a) / (b - a), order)
        for k in range(1, order + 1):
            out[k] *= (b - a) ** -k
        return out

    def local(self, t: NDArray, order: int) -> tuple[NDArray, NDArray]:
        return np.zeros(t.shape, dtype=np.intp), self.dense(t, order)


@dataclass(frozen=True)
class BSplineBasis:
    """The B-spline basis of a degree over a (validated) knot vector."""

    degree: int
    knots: NDArray

    @property
    def n_points(self) -> int:
        return len(self.knots) - self.degree - 1

    def dense(self, t: NDArray, order: int) -> NDArray:
        return basis_matrix(self.knots, self.degree, t, order)

    def local(self, t: NDArray, order: int) -> tuple[NDArray, NDArray]:
        spans, ders = basis_functions(self.knots, self.degree, t, order)
        return spans - self.degree, ders


# --------------------------------------------------------------------------- evaluation


def show_value(value: object, limit: int = 60) -> str:
    """A value on one line for a message, shortened (numbers as a plain list)."""
    try:
        text = str(np.asarray(value, dtype=np.float64).tolist())
    except (TypeError, ValueError):
        text = repr(value)
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 1] + "…"


def value_pair(value: object, name: str) -> tuple[Any, Any]:
    """A (u, v) pair from one value for both directions or a pair."""
    if isinstance(value, np.ndarray) and value.ndim > 0:
        value = list(value)
    if isinstance(value, str) or not isinstance(value, Sequence):
        return value, value
    if len(value) != 2:
        raise GshadeError(f"{name}: expected one value or a (u, v) pair, got {show_value(value)}")
    return value[0], value[1]


def validate_points(points: ArrayLike, ndim: int, what: str, min_count: int = 2) -> NDArray:
    """Validate a control net: shape (..., 3) with ``ndim`` index axes, finite values."""
    try:
        P = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise GshadeError(f"points: expected an array of numbers for the {what}") from None
    expected = "(n+1, 3)" if ndim == 1 else "(m+1, n+1, 3)"
    if P.ndim != ndim + 1 or P.shape[-1] not in ((3,) if ndim == 2 else (2, 3)):
        raise GshadeError(f"points: expected shape {expected} for the {what}, got {P.shape}")
    if any(s < min_count for s in P.shape[:-1]):
        raise GshadeError(
            f"points: expected at least {min_count} control points per direction for the "
            f"{what}, got shape {P.shape}"
        )
    if not np.all(np.isfinite(P)):
        raise GshadeError(f"points: expected finite coordinates for the {what}")
    return P


def validate_weights(
    weights: ArrayLike | None, shape: tuple[int, ...], what: str
) -> NDArray | None:
    """Validate weights: None, or positive finite numbers of the given shape."""
    if weights is None:
        return None
    try:
        w = np.asarray(weights, dtype=np.float64)
    except (TypeError, ValueError):
        raise GshadeError(f"weights: expected an array of numbers for the {what}") from None
    if w.shape != shape:
        raise GshadeError(f"weights: expected shape {shape} for the {what}, got {w.shape}")
    if not np.all(np.isfinite(w) & (w > 0)):
        bad = float(w[~(np.isfinite(w) & (w > 0))].flat[0])
        raise GshadeError(f"weights: expected positive finite numbers, got {bad!r}")
    return w


def homogeneous(points: NDArray, weights: NDArray | None) -> NDArray:
    """Control points in homogeneous form (w P, w), or the points themselves if polynomial."""
    if weights is None:
        return points
    return np.concatenate([points * weights[..., None], weights[..., None]], axis=-1)


class Basis(Protocol):
    """What a curve or tensor-product patch needs of its basis functions (Bernstein,
    B-spline, the geometric splines' piecewise cubics)."""

    def local(self, t: NDArray, order: int) -> tuple[NDArray, NDArray]:
        """The first nonzero function's index at each t, and the derivatives 0..order of
        the nonzero functions there (shape (order + 1, len(t), k))."""
        ...

    def dense(self, t: NDArray, order: int) -> NDArray:
        """The derivatives 0..order of every function at each t (shape (order + 1, len(t),
        n))."""
        ...


class BasisCurve(Curve):
    """A curve sum_i B_i(t) P_i over a basis (Bernstein or B-spline), rational if weighted."""

    def __init__(
        self,
        basis: Basis,
        points: NDArray,
        weights: NDArray | None,
    ) -> None:
        self._basis = basis
        self.points = points
        self.weights = weights
        self.dim = points.shape[-1]
        self._net = homogeneous(points, weights)

    @property
    def rational(self) -> bool:
        return self.weights is not None

    def _derivatives(self, t: NDArray, order: int) -> NDArray:
        first, ders = self._basis.local(t, order)
        idx = first[:, None] + np.arange(ders.shape[-1])
        local = self._net[idx]  # (N, k, c)
        h = np.einsum("onk,nkc->ocn", ders, local)
        if self.weights is None:
            return h
        return project_curve_derivatives(h, order)


class TensorProductPatch(Patch):
    """A patch sum_ij B_i(u) B_j(v) P_ij over two bases, rational if weighted."""

    def __init__(
        self,
        basis_u: Basis,
        basis_v: Basis,
        points: NDArray,
        weights: NDArray | None,
    ) -> None:
        self._bu = basis_u
        self._bv = basis_v
        self.points = points
        self.weights = weights
        self._net = homogeneous(points, weights)

    @property
    def rational(self) -> bool:
        return self.weights is not None

    def _derivatives_grid(self, u: NDArray, v: NDArray, order: int, buf: NDArray) -> None:
        Bu = self._bu.dense(u, order)  # (o+1, Nu, mu)
        Bv = self._bv.dense(v, order)  # (o+1, Nv, mv)
        mu, mv, c = self._net.shape
        net = self._net.reshape(mu, mv * c)
        w = np.empty((order + 1, order + 1, u.size, v.size)) if self.rational else None
        for i in range(order + 1):
            rows = (Bu[i] @ net).reshape(u.size, mv, c).transpose(2, 0, 1)  # (c, Nu, mv)
            for j in range(order + 1 - i):
                # dense products beat per-span ones here (measured): BLAS at full speed,
                # one thread (``derivatives`` limits the pool; more only wait on each other)
                np.matmul(rows[:3], Bv[j].T, out=buf[i, j])
                if w is not None:
                    np.matmul(rows[3], Bv[j].T, out=w[i, j])
        if w is not None:
            project_patch_derivatives(buf, w, order)

    def _derivatives_points(self, u: NDArray, v: NDArray, order: int) -> NDArray:
        fu, Bu = self._bu.local(u, order)  # (N,), (o+1, N, ku)
        fv, Bv = self._bv.local(v, order)
        ku, kv = Bu.shape[-1], Bv.shape[-1]
        c = self._net.shape[-1]
        if ku == self._net.shape[0] and kv == self._net.shape[1]:
            # the whole net is every point's local net (Bézier): no gather, plain products
            net = self._net.reshape(ku, kv * c)
            local = None
        else:
            iu = fu[:, None, None] + np.arange(ku)[None, :, None]
            iv = fv[:, None, None] + np.arange(kv)[None, None, :]
            local = self._net[iu, iv]  # (N, ku, kv, c)
        buf = np.zeros((order + 1, order + 1, c, u.size))
        BvT = Bv.transpose(0, 2, 1)  # (o+1, kv, N)
        for i in range(order + 1):
            # rows[b] = sum_a Bu[i][:, a] P[a, b]: (kv, c, N), point axis last and contiguous
            if local is None:
                rows = (net.T @ Bu[i].T).reshape(kv, c, u.size)
            else:
                rows = np.einsum("na,nabc->bcn", Bu[i], local)
            for j in range(order + 1 - i):
                out = buf[i, j]
                for b in range(kv):  # a few fused sweeps: twice as fast as one einsum
                    out += rows[b] * BvT[j, b]
        if self.weights is None:
            return buf
        return project_patch_derivatives(buf[:, :, :3], buf[:, :, 3], order)
