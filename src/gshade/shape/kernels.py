"""Running the shape functions' formulas on whole arrays of points.

The formulas live with their declarations in :mod:`gshade.shape.functions`.  Each reads the
jets of the surface derivatives (:mod:`gshade.geometry.core.jets`) and its parameters by name
through its :class:`Layout`, and returns the jet of f with a mask of the points where f is defined.
:func:`run` evaluates one on a derivatives array and turns (f, f_u, f_v) into the surface
gradient.

Two backends run the same formulas: Dr.Jit's LLVM backend, which traces a formula into one
vectorised, multithreaded kernel (compiled once, then loaded from Dr.Jit's disk cache), and
numpy, used where no usable libLLVM is found (see :mod:`gshade.runtime.llvm`).  Parameters enter the
Dr.Jit kernels as opaque values, so new parameter values reuse the compiled kernel.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from functools import cache
from types import SimpleNamespace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import GshadeError
from ..geometry.core.differential import first_form, first_form_det, solve_first_form
from ..geometry.core.jets import NUMPY, Backend, Jet
from ..runtime.drjit_arrays import drjit_array
from ..runtime.llvm import drjit_llvm_ready, import_drjit

__all__ = ["BACKENDS", "Formula", "Layout", "backend", "run"]

#: the backends :func:`run` accepts ("auto": Dr.Jit where its LLVM works, else numpy)
BACKENDS = ("auto", "drjit", "numpy")

#: a formula: (vec, parameters, form, xp) -> (jet of f, valid or None, eye or None); ``vec(i, j)``
#: is the jet vector of d^(i+j) p / du^i dv^j, ``parameters`` its :meth:`Layout.read` view
Formula = Callable[[Callable[[int, int], Any], Any, str, Backend], tuple[Jet, Any, Any]]


class Layout:
    """A shape function's packed parameters: ordered ``(name, size)`` fields, each a slice of
    one flat vector of numbers, followed by ``irregular`` (the |p_u x p_v| at or below which a
    point is irregular; set by ``evaluate``).

    ``pack(**values)`` builds the vector (where the values are computed);
    ``read(vector)`` gives the formula each field by name (a field of size 1 as its number,
    others as a list), so no offset is written anywhere else.
    """

    def __init__(self, *fields: tuple[str, int]):
        self.fields: tuple[tuple[str, int], ...] = (*fields, ("irregular", 1))
        self.slices: dict[str, slice] = {}
        at = 0
        for name, size in self.fields:
            if name in self.slices or size < 1:
                raise ValueError(f"Layout: duplicate or empty field {name!r}")
            self.slices[name] = slice(at, at + size)
            at += size
        self.size = at

    def pack(self, **values: ArrayLike) -> NDArray:
        """The parameter vector: every field's value (``irregular`` may be left out: 0)."""
        missing = set(self.slices) - set(values) - {"irregular"}
        unknown = set(values) - set(self.slices)
        if missing or unknown:
            raise ValueError(f"Layout.pack: missing {sorted(missing)}, unknown {sorted(unknown)}")
        prm = np.zeros(self.size)
        for name, value in values.items():
            s = self.slices[name]
            v = np.asarray(value, dtype=np.float64).reshape(-1)
            if v.size != s.stop - s.start:
                raise ValueError(f"Layout.pack: {name}: expected {s.stop - s.start} numbers")
            prm[s] = v
        return prm

    def read(self, prm: Sequence[Any]) -> SimpleNamespace:
        """The fields of ``prm`` (numbers, or Dr.Jit's opaque values) by name."""
        return SimpleNamespace(
            **{
                name: prm[s.start] if s.stop - s.start == 1 else list(prm[s])
                for name, s in self.slices.items()
            }
        )


@cache
def _drjit() -> Backend:
    from ..runtime.backend import drjit_ops

    return drjit_ops()


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
    formula: Formula,
    form: str,
    layout: Layout,
    prm: NDArray,
    d: NDArray,
    with_gradient: bool,
    backend_name: str = "auto",
    with_partials: bool = False,
) -> tuple[NDArray, NDArray | None, NDArray, NDArray, NDArray | None]:
    """Evaluate ``formula`` (its ``form``, parameters ``prm`` packed by ``layout``) at every
    point of ``d`` (shape (o+1, o+1, n, 3)).

    Returns f (n,), the gradient (3, n) or None, valid (n,), eye (n,): points where the
    eye lies on the surface (reflection lines), and the partials (f_u, f_v) (2, n) or None.
    The gradient is ((G f_u - F f_v) p_u + (E f_v - F f_u) p_v) / (EG - F^2)
    (:func:`~gshade.geometry.core.differential.solve_first_form`); f, the gradient
    and the partials are 0 where f is undefined (or not finite).  Derivatives beyond d's
    order are taken as zero.
    """
    name = backend(backend_name)
    n, order = d.shape[2], d.shape[0] - 1
    params: list[Any]  # Dr.Jit or numpy numbers, as the backend's formulas take them
    zero: Any
    if name == "drjit":
        dr = import_drjit()
        from drjit.llvm import Float64

        xp = _drjit()
        params = [dr.opaque(Float64, float(x)) for x in prm]
        zero = dr.zeros(Float64, n)

        def array(i: int, j: int, c: int) -> Any:
            return drjit_array(Float64, d[i, j, :, c])
    else:
        xp = NUMPY
        params = [float(x) for x in prm]
        zero = np.zeros(n)

        def array(i: int, j: int, c: int) -> Any:
            return d[i, j, :, c]

    cache: dict[tuple[int, int, int], object] = {}

    def component(i: int, j: int, c: int) -> Any:
        if i + j > order:
            return zero
        if (i, j, c) not in cache:
            cache[i, j, c] = array(i, j, c)
        return cache[i, j, c]

    def vec(i: int, j: int) -> tuple[Jet, ...]:
        return tuple(
            Jet(component(i, j, c), component(i + 1, j, c), component(i, j + 1, c))
            for c in range(3)
        )

    with np.errstate(all="ignore"):
        jet, valid, eye = formula(vec, layout.read(params), form, xp)
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
            E, F, G = first_form(pu, pv)
            det = first_form_det(E, F, G)
            ok = valid & (det > 0.0)
            a, b = solve_first_form(E, F, G, det, jet.u, jet.v)
            a, b = xp.select(ok, a, 0.0), xp.select(ok, b, 0.0)
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
