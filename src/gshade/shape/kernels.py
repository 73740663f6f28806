"""The shape functions' formulas on whole arrays of points (see ``functions.py``'s docs).

Each formula reads the jets of the surface derivatives (:mod:`gshade.shape.jets`) and returns
the jet of f with a mask of the points where f is defined.  :func:`run` evaluates one of them
on a derivatives array and turns (f, f_u, f_v) into the surface gradient.

Two backends run the same formulas: Dr.Jit's LLVM backend, which traces a formula into one
vectorised, multithreaded kernel (compiled once, then loaded from Dr.Jit's disk cache), and
numpy, used where no usable libLLVM is found (see :mod:`gshade.llvm`).  Parameters enter the
Dr.Jit kernels as opaque values, so new parameter values reuse the compiled kernel.
"""

from __future__ import annotations

import os
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from ..llvm import drjit_llvm_ready
from .jets import NUMPY, Backend, Jet, arccos, arctan2, cross, dot, jabs, sqrt

__all__ = ["BACKENDS", "backend", "run"]

PLANAR, ISOPHOTES, REFLECTION, HIGHLIGHT, PARAMETRISATION = 0, 1, 2, 3, 4
GAUSSIAN, MEAN, MAX_PRINCIPAL, MIN_PRINCIPAL, ABSOLUTE, RMS = 5, 6, 7, 8, 9, 10

#: index in the parameter vector of the |p_u x p_v| at or below which a point is irregular
IRREGULAR = 23
#: the backends :func:`run` accepts ("auto": Dr.Jit where its LLVM works, else numpy)
BACKENDS = ("auto", "drjit", "numpy")


def _planar_sections(vec, prm, option, xp):
    return dot(vec(0, 0), prm[0:3]), None, None


def _isophotes(vec, prm, angle, xp):
    N = cross(vec(1, 0), vec(0, 1))
    length = sqrt(dot(N, N), xp)
    f = dot(N, prm[0:3]) / length
    return (arccos(f, xp) if angle else f), length.f > prm[IRREGULAR], None


def _reflection_lines(vec, prm, at_infinity, xp):
    """r = w - 2 <w, N> N / <N, N> with w = p - e; plane: s = <(p - p0) x a2, r> / <c, r>."""
    p = vec(0, 0)
    N = cross(vec(1, 0), vec(0, 1))
    NN = dot(N, N)
    w = tuple(p[i] - prm[i] for i in range(3))
    eye = dot(w, w).f == 0.0
    valid = NN.f > prm[IRREGULAR] * prm[IRREGULAR]
    t = 2.0 * (dot(w, N) / NN)
    r = tuple(w[i] - t * N[i] for i in range(3))
    if at_infinity:
        return arctan2(dot(r, prm[12:15]), dot(r, prm[15:18]), xp), valid, eye
    c = prm[18:21]
    q = tuple(p[i] - prm[3 + i] for i in range(3))
    cr = dot(r, c)
    mu_sign = -dot(q, c).f * cr.f  # the sign of the ray parameter at the light plane
    valid = valid & (cr.f != 0.0) & (mu_sign > 0.0)
    return dot(cross(q, prm[9:12]), r) / cr, valid, eye


def _highlight_lines(vec, prm, distance, xp):
    """plane: s = <(p - p0) x a2, N> / <c, N>;  distance: <E x N, p - A> / |E x N|."""
    p = vec(0, 0)
    N = cross(vec(1, 0), vec(0, 1))
    length = xp.sqrt(xp.maximum(dot(N, N).f, 0.0))
    valid = length > prm[IRREGULAR]
    q = tuple(p[i] - prm[i] for i in range(3))
    if distance:
        EN = cross(N, prm[6:9])  # N x E = -(E x N)
        norm = sqrt(dot(EN, EN), xp)
        return -(dot(EN, q) / norm), valid & (norm.f > 1e-12 * length), None
    cn = dot(N, prm[9:12])
    valid = valid & (xp.abs(cn.f) > 1e-12 * length * prm[12])
    return dot(cross(q, prm[6:9]), N) / cn, valid, None


def _parametrisation_quality(vec, prm, option, xp):
    pu, pv = vec(1, 0), vec(0, 1)
    E, F, G = dot(pu, pu), dot(pu, pv), dot(pv, pv)
    s = E + G
    dEG = E - G
    return (dEG * dEG + 4.0 * (F * F)) / (s * s), s.f > 0.0, None


def _curvature(which):
    def formula(vec, prm, option, xp):
        """K = (L'N' - M'^2)/W^4, H = (E N' - 2F M' + G L')/(2 W^3), W = |N|, L' = <p_uu, N>,
        ...; ((k1 - k2)/2)^2 = ((G L' - E N')^2 / 4 + (G M' - F N')(E M' - F L')) / W^6."""
        pu, pv = vec(1, 0), vec(0, 1)
        N = cross(pu, pv)
        W2 = dot(N, N)
        valid = W2.f > prm[IRREGULAR] * prm[IRREGULAR]
        E, F, G = dot(pu, pu), dot(pu, pv), dot(pv, pv)
        L, M, Nn = dot(vec(2, 0), N), dot(vec(1, 1), N), dot(vec(0, 2), N)
        inv2 = 1.0 / W2
        inv4 = inv2 * inv2
        K = (L * Nn - M * M) * inv4
        if which == GAUSSIAN:
            return K, valid, None
        H = (E * Nn - 2.0 * (F * M) + G * L) / (2.0 * (W2 * sqrt(W2, xp)))
        if which == MEAN:
            return H, valid, None
        if which == RMS:
            return sqrt(2.0 * (H * H) - K, xp), valid, None
        gap = G * L - E * Nn
        disc = 0.25 * (gap * gap) + (G * M - F * Nn) * (E * M - F * L)
        root = sqrt(disc * (inv4 * inv2), xp)
        if which == MAX_PRINCIPAL:
            return H + root, valid, None
        if which == MIN_PRINCIPAL:
            return H - root, valid, None
        return jabs(H + root, xp) + jabs(H - root, xp), valid, None  # ABSOLUTE

    return formula


_FORMULAS = {
    PLANAR: _planar_sections,
    ISOPHOTES: _isophotes,
    REFLECTION: _reflection_lines,
    HIGHLIGHT: _highlight_lines,
    PARAMETRISATION: _parametrisation_quality,
    **{c: _curvature(c) for c in (GAUSSIAN, MEAN, MAX_PRINCIPAL, MIN_PRINCIPAL, ABSOLUTE, RMS)},
}


@cache
def _drjit() -> Backend:
    import drjit as dr

    return Backend("drjit", dr.sqrt, dr.acos, dr.atan2, dr.abs, dr.isfinite, dr.select)


def backend(name: str = "auto") -> str:
    """The backend that ``name`` means here: "drjit" where Dr.Jit's LLVM backend works
    (and ``GSHADE_SHAPE_BACKEND`` does not say "numpy"), else "numpy"."""
    if name not in BACKENDS:
        raise GshadeError(f"backend: expected one of {', '.join(BACKENDS)}, got {name!r}")
    if name == "auto":
        name = os.environ.get("GSHADE_SHAPE_BACKEND", "auto")
        if name not in BACKENDS:
            raise GshadeError(
                f"GSHADE_SHAPE_BACKEND: expected one of {', '.join(BACKENDS)}, got {name!r}"
            )
    if name == "auto":
        return "drjit" if drjit_llvm_ready() else "numpy"
    if name == "drjit" and not drjit_llvm_ready():
        raise GshadeError("backend: drjit needs Dr.Jit's LLVM backend with libLLVM >= 17")
    return name


def run(
    code: int,
    option: int,
    prm: NDArray,
    d: NDArray,
    with_gradient: bool,
    backend_name: str = "auto",
    with_partials: bool = False,
) -> tuple[NDArray, NDArray | None, NDArray, NDArray, NDArray | None]:
    """Evaluate shape function ``code`` at every point of ``d`` (shape (o+1, o+1, n, 3)).

    Returns f (n,), the gradient (3, n) or None, valid (n,), eye (n,): points where the
    eye lies on the surface (reflection lines), and the partials (f_u, f_v) (2, n) or None.
    The gradient is ((G f_u - F f_v) p_u + (E f_v - F f_u) p_v) / (EG - F^2); f, the gradient
    and the partials are 0 where f is undefined (or not finite).  Derivatives beyond d's
    order are taken as zero.
    """
    name = backend(backend_name)
    n, order = d.shape[2], d.shape[0] - 1
    params: list[Any]  # Dr.Jit or numpy numbers, as the backend's formulas take them
    zero: Any
    if name == "drjit":
        import drjit as dr
        from drjit.llvm import Float64

        xp = _drjit()
        params = [dr.opaque(Float64, float(x)) for x in prm]
        zero = dr.zeros(Float64, n)

        def array(i, j, c):
            return Float64(np.ascontiguousarray(d[i, j, :, c]))
    else:
        xp = NUMPY
        params = [float(x) for x in prm]
        zero = np.zeros(n)

        def array(i, j, c):
            return d[i, j, :, c]

    cache: dict[tuple[int, int, int], object] = {}

    def component(i, j, c):
        if i + j > order:
            return zero
        if (i, j, c) not in cache:
            cache[i, j, c] = array(i, j, c)
        return cache[i, j, c]

    def vec(i, j):
        return tuple(
            Jet(component(i, j, c), component(i + 1, j, c), component(i, j + 1, c))
            for c in range(3)
        )

    with np.errstate(all="ignore"):
        jet, valid, eye = _FORMULAS[code](vec, params, option, xp)
        finite = xp.isfinite(jet.f) & xp.isfinite(jet.u) & xp.isfinite(jet.v)
        valid = finite if valid is None else valid & finite
        if eye is not None:
            valid = valid & ~eye
        outputs = {"f": [xp.select(valid, jet.f, 0.0)], "valid": [valid]}
        if eye is not None:
            outputs["eye"] = [eye]
        if with_gradient:
            pu = [component(1, 0, c) for c in range(3)]
            pv = [component(0, 1, c) for c in range(3)]
            E = pu[0] * pu[0] + pu[1] * pu[1] + pu[2] * pu[2]
            F = pu[0] * pv[0] + pu[1] * pv[1] + pu[2] * pv[2]
            G = pv[0] * pv[0] + pv[1] * pv[1] + pv[2] * pv[2]
            det = E * G - F * F
            ok = valid & (det > 0.0)
            a = xp.select(ok, (G * jet.u - F * jet.v) / det, 0.0)
            b = xp.select(ok, (E * jet.v - F * jet.u) / det, 0.0)
            outputs["gradient"] = [a * pu[c] + b * pv[c] for c in range(3)]
        if with_partials:
            outputs["partials"] = [xp.select(valid, jet.u, 0.0), xp.select(valid, jet.v, 0.0)]
        if name == "drjit":
            dr.eval(*(x for arrays in outputs.values() for x in arrays))
    # numpy arrays of n values (formulas may leave a constant as a scalar)
    out = {k: np.stack([np.broadcast_to(np.asarray(x), n) for x in v]) for k, v in outputs.items()}
    f = np.ascontiguousarray(out["f"][0], dtype=np.float64)
    valid = out["valid"][0].astype(bool)
    eye = out["eye"][0].astype(bool) if "eye" in out else np.zeros(n, bool)
    return f, out.get("gradient"), valid, eye, out.get("partials")
