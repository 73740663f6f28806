"""One protocol of array operations for numpy and Dr.Jit (gshade.runtime.backend), used by
the shape kernels' jets, the stripe filter, the atlas lookups and the Newton step."""

import numpy as np
import pytest

from gshade.display import stripe_coverage
from gshade.display.colour import coverage_formula
from gshade.geometry.core import jets
from gshade.runtime.backend import NUMPY, NUMPY_NAN, ArrayOps, cross3, dot3, drjit_ops
from gshade.shape.kernels import backend


def test_the_jets_backend_is_the_protocol():
    assert jets.Backend is ArrayOps and jets.NUMPY is NUMPY


def test_minimum_and_maximum_select_or_propagate_nan():
    a, b = np.array([1.0, np.nan, 3.0]), np.array([2.0, 5.0, np.nan])
    # compare-and-select (as Dr.Jit's, whose fminimum some LLVM versions cannot compile)
    np.testing.assert_array_equal(NUMPY.minimum(a, b), [1.0, 5.0, np.nan])
    np.testing.assert_array_equal(NUMPY.maximum(a, b), [2.0, 5.0, np.nan])
    np.testing.assert_array_equal(NUMPY.clip(np.array([-1.0, 0.5, 9.0]), 0.0, 1.0), [0, 0.5, 1])
    np.testing.assert_array_equal(NUMPY_NAN.minimum(a, b), [1.0, np.nan, np.nan])
    # the public numpy stripe filter keeps an undefined value visible
    assert np.isnan(stripe_coverage(np.nan, 0.3))


def test_row_vectors_and_written_out_products():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(2, 50, 3))
    np.testing.assert_allclose(NUMPY.dot(a, b), (a * b).sum(axis=1), rtol=1e-14)
    np.testing.assert_array_equal(NUMPY.cross(a, b), np.cross(a, b))
    np.testing.assert_array_equal(NUMPY.scale(np.arange(50.0), a), np.arange(50.0)[:, None] * a)
    columns_a, columns_b = list(a.T), list(b.T)
    np.testing.assert_allclose(dot3(columns_a, columns_b), NUMPY.dot(a, b), rtol=1e-14)
    np.testing.assert_array_equal(np.stack(cross3(columns_a, columns_b), -1), np.cross(a, b))


def test_defaults_come_from_the_named_library():
    ops = ArrayOps("numpy", np.sqrt, np.arccos, np.arctan2, np.abs, np.isfinite, np.where)
    assert ops.floor is np.floor and ops.logical_not is np.logical_not
    with pytest.raises(ValueError, match="no default operations for 'cupy'"):
        ArrayOps("cupy", np.sqrt, np.arccos, np.arctan2, np.abs, np.isfinite, np.where)


def test_the_stripe_filter_is_the_same_formula_on_drjit():
    if backend() != "drjit":
        pytest.skip("no usable libLLVM here")
    import drjit as dr
    from drjit.llvm import Float64

    # built as gshade.shape.kernels builds its backend: the rest filled in from Dr.Jit
    ops = jets.Backend("drjit", dr.sqrt, dr.acos, dr.atan2, dr.abs, dr.isfinite, dr.select)
    assert ops.floor is dr.floor and ops.dot is dr.dot
    rng = np.random.default_rng(1)
    s, a, b = rng.normal(scale=3, size=(3, 5000))
    a[:1000] = 0.0
    b[1000:2000] = 1e-7
    expected = coverage_formula(s, a, b, 0.4)
    for dr_ops in (ops, drjit_ops()):
        got = coverage_formula(Float64(s), Float64(a), Float64(b), 0.4, dr_ops)
        np.testing.assert_allclose(np.array(got), expected, rtol=0, atol=1e-12)
