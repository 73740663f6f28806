"""The shape functions' parameter layouts: named fields, one declaration each."""

import numpy as np
import pytest

from gshade.geometry import regularised_derivatives, torus
from gshade.shape import SHAPE_FUNCTIONS, evaluate, validate_parameters
from gshade.shape.kernels import Layout, backend


def test_layout_packs_and_reads_fields_by_name():
    layout = Layout(("eye", 3), ("scale", 1))
    assert [name for name, _ in layout.fields] == ["eye", "scale", "irregular"]
    assert layout.size == 5
    prm = layout.pack(eye=[1.0, 2.0, 3.0], scale=4.0)
    np.testing.assert_array_equal(prm, [1, 2, 3, 4, 0])
    p = layout.read(list(prm))
    assert p.eye == [1.0, 2.0, 3.0] and p.scale == 4.0 and p.irregular == 0.0
    assert layout.read(list(layout.pack(eye=[0, 0, 0], scale=0, irregular=7.0))).irregular == 7


@pytest.mark.parametrize(
    ("fields", "values", "message"),
    [
        ((("a", 3),), {}, "missing"),
        ((("a", 3),), {"a": [1, 2, 3], "b": 1}, "unknown"),
        ((("a", 3),), {"a": [1, 2]}, "expected 3 numbers"),
    ],
)
def test_layout_rejects_wrong_values(fields, values, message):
    with pytest.raises(ValueError, match=message):
        Layout(*fields).pack(**values)


def test_layout_rejects_duplicate_fields():
    with pytest.raises(ValueError, match="duplicate"):
        Layout(("a", 3), ("a", 1))
    with pytest.raises(ValueError, match="duplicate"):
        Layout(("irregular", 1))


@pytest.mark.parametrize("name", sorted(SHAPE_FUNCTIONS))
def test_every_form_packs_into_its_layout(name):
    fn = SHAPE_FUNCTIONS[name]
    forms = fn.parameters.get("form")
    for form in forms.choices if forms else (None,):
        kw = validate_parameters(fn, {"form": form} if form else {})
        got, layout, values = fn.pack(fn.name, kw)
        assert got == (form or "")
        assert layout.pack(**values).shape == (layout.size,)


def test_new_parameter_values_reuse_the_compiled_kernel():
    """Parameters enter the Dr.Jit kernel as opaque values: a new light direction runs the
    kernel already compiled (no new trace is compiled)."""
    pytest.importorskip("drjit")
    if backend() != "drjit":
        pytest.skip("no usable libLLVM here: only the numpy backend runs")
    s = torus(2.0, 0.7)
    d = regularised_derivatives(s, *s.parameter_grid(20, 20), 2).d
    evaluate("isophotes", d, light=(0, 0, 1), backend="drjit")
    import drjit as dr

    dr.set_flag(dr.JitFlag.KernelHistory, True)
    try:
        dr.kernel_history()
        evaluate("isophotes", d, light=(0.3, -0.2, 0.9), backend="drjit")
        jit = [k for k in dr.kernel_history() if k.get("type") == dr.KernelType.JIT]
    finally:
        dr.set_flag(dr.JitFlag.KernelHistory, False)
    assert jit and all(k["cache_hit"] for k in jit)
