"""The STEP / IGES / BREP reader: exact faces, curvature on fillets, one-line errors."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("OCP")

from OCP.BRepAdaptor import BRepAdaptor_Surface
from OCP.BRepBuilderAPI import (
    BRepBuilderAPI_MakeEdge,
    BRepBuilderAPI_MakeFace,
    BRepBuilderAPI_NurbsConvert,
)
from OCP.collections import Array1_double, Array1_int, Array2_double, Array2_gp_Pnt
from OCP.Geom import Geom_BSplineSurface
from OCP.gp import gp_Pnt, gp_Vec

from gshade.cad import occt, read_cad
from gshade.cad.kernel import shape_faces
from gshade.errors import GshadeError
from gshade.geometry import gaussian_and_mean_curvature

from ..support.cad_parts import filleted_box, write_shape

R = 2.0
SIZE = (10.0, 20.0, 30.0)
DIAGONAL = float(np.linalg.norm(SIZE))


def make_rounded():
    """A 10 x 20 x 30 box with all 12 edges filleted at R."""
    return filleted_box(SIZE, R)


@pytest.fixture(scope="module")
def rounded():
    return make_rounded()


@pytest.fixture(scope="module")
def brep_model(rounded, tmp_path_factory):
    path = write_shape(rounded, tmp_path_factory.mktemp("cad") / "rounded.brep")
    return read_cad(path)


def _kernel_d2(adaptor, u, v):
    """Kernel derivatives as d[i, j] (i + j <= 2)."""
    p, du, dv, duu, dvv, duv = gp_Pnt(), gp_Vec(), gp_Vec(), gp_Vec(), gp_Vec(), gp_Vec()
    adaptor.D2(u, v, p, du, dv, duu, dvv, duv)
    d = np.zeros((3, 3, 3))
    d[0, 0] = p.X(), p.Y(), p.Z()
    for (i, j), w in {(1, 0): du, (0, 1): dv, (2, 0): duu, (0, 2): dvv, (1, 1): duv}.items():
        d[i, j] = w.X(), w.Y(), w.Z()
    return d


SAME_PARAMETERS = {"plane", "bspline", "bezier"}


def max_difference(model, shape, samples=6, seed=0):
    """Largest |patch - kernel| over D0..D2 at random (u, v), relative to the model size,
    against the converted faces (all) and the original faces (those parametrised alike)."""
    rng = np.random.default_rng(seed)
    converted = shape_faces(BRepBuilderAPI_NurbsConvert(shape, True).Shape())
    worst = 0.0
    for face, original, conv in zip(model.faces, shape_faces(shape), converted, strict=True):
        adaptors = [BRepAdaptor_Surface(conv)]
        if face.kind in SAME_PARAMETERS:
            adaptors.append(BRepAdaptor_Surface(original))
        (u0, u1), (v0, v1) = face.box
        for u, v in zip(rng.uniform(u0, u1, samples), rng.uniform(v0, v1, samples), strict=True):
            mine = face.patch.derivatives(u, v, 2)
            for adaptor in adaptors:
                kernel = _kernel_d2(adaptor, u, v)
                for i, j in ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)):
                    difference = float(np.max(np.abs(mine[i, j] - kernel[i, j])))
                    worst = max(worst, difference / DIAGONAL)
    return worst


def test_kinds_and_formats(rounded, tmp_path):
    counts = {}
    for name in ("rounded.step", "rounded.igs", "rounded.brep"):
        path = write_shape(rounded, tmp_path / name)
        model = read_cad(path)
        counts[name] = len(model.faces)
        kinds = [f.kind for f in model.faces]
        assert sorted(set(kinds)) == ["cylinder", "plane", "sphere"], name
        assert (kinds.count("plane"), kinds.count("cylinder"), kinds.count("sphere")) == (6, 12, 8)
        assert model.unit == ("unknown" if name.endswith(".brep") else "mm")
        assert np.allclose(model.bounds[0], 0, atol=1e-3) and np.allclose(
            model.bounds[1], SIZE, atol=1e-3
        )
        assert all(f.exact and f.error == 0 for f in model.faces)
    assert set(counts.values()) == {26}


def test_patches_match_the_kernel(rounded, brep_model):
    assert max_difference(brep_model, rounded) < 1e-9
    spheres = [f for f in brep_model.faces if f.kind == "sphere"]
    assert all(f.patch.rational for f in spheres)


def test_dropping_the_weights_is_caught(rounded, brep_model):
    from gshade.geometry.patches.bspline import BSplinePatch

    for face in brep_model.faces:
        p = face.patch
        if p.rational:
            face.patch = BSplinePatch(p.points, p.degree, p.knots)
    assert max_difference(brep_model, rounded) > 1e-3


def test_curvature_on_the_fillets(tmp_path, rounded):
    model = read_cad(write_shape(rounded, tmp_path / "r.step"))
    errors = {"cylinder": 0.0, "sphere": 0.0}
    rng = np.random.default_rng(1)
    for face in model.faces:
        if face.kind not in errors:
            continue
        (u0, u1), (v0, v1) = face.box
        for u, v in zip(rng.uniform(u0, u1, 5), rng.uniform(v0, v1, 5), strict=True):
            K, H = gaussian_and_mean_curvature(face.patch.derivatives(u, v, 2))
            if face.kind == "cylinder":
                err = max(abs(abs(H) - 1 / (2 * R)) * R, abs(K) * R * R)
            else:
                err = max(abs(abs(H) - 1 / R) * R, abs(K - 1 / R**2) * R * R)
            errors[face.kind] = max(errors[face.kind], float(err))
    assert errors["cylinder"] < 1e-9 and errors["sphere"] < 1e-9, errors


def test_bspline_face(tmp_path):
    """A rational bicubic face with interior knots is read with its own parametrisation."""
    nu, nv, p, q = 5, 4, 3, 2
    rng = np.random.default_rng(2)
    poles, weights = Array2_gp_Pnt(1, nu, 1, nv), Array2_double(1, nu, 1, nv)
    for i in range(nu):
        for j in range(nv):
            poles.SetValue(i + 1, j + 1, gp_Pnt(i * 2.0, j * 3.0, float(rng.uniform(-1, 1))))
            weights.SetValue(i + 1, j + 1, float(rng.uniform(0.5, 2.0)))
    uk, um = Array1_double(1, 3), Array1_int(1, 3)
    for k, (t, m) in enumerate(((0.0, 4), (0.4, 1), (1.0, 4))):
        uk.SetValue(k + 1, t)
        um.SetValue(k + 1, m)
    vk, vm = Array1_double(1, 3), Array1_int(1, 3)
    for k, (t, m) in enumerate(((0.0, 3), (0.5, 1), (2.0, 3))):
        vk.SetValue(k + 1, t)
        vm.SetValue(k + 1, m)
    surface = Geom_BSplineSurface(poles, weights, uk, vk, um, vm, p, q, False, False)
    face = BRepBuilderAPI_MakeFace(surface, 0.1, 0.9, 0.2, 1.8, 1e-7).Face()
    model = read_cad(write_shape(face, tmp_path / "f.step"))
    (f,) = model.faces
    assert f.kind == "bspline" and f.patch.rational and f.patch.degree == (p, q)
    assert np.allclose(f.box, ((0.1, 0.9), (0.2, 1.8)))
    assert not f.trimmed and len(f.loops) == 1
    adaptor = BRepAdaptor_Surface(face)  # the original: same parametrisation
    for u, v in ((0.3, 0.4), (0.45, 1.7), (0.85, 0.25)):
        assert (
            np.max(
                np.abs(f.patch.derivatives(u, v, 2) - _kernel_d2(adaptor, u, v))[
                    [0, 1, 0, 2, 1, 0], [0, 0, 1, 0, 1, 2]
                ]
            )
            < 1e-9 * 10
        )


def test_loops_on_the_rounded_box(brep_model):
    for face in brep_model.faces:
        assert len(face.loops) == 1 and face.inner_loops == 0
        loop = face.loops[0]
        assert np.allclose(loop[0], loop[-1])
        (u0, u1), (v0, v1) = face.box
        t = 1e-9 * max(u1 - u0, v1 - v0)
        assert np.all(loop[:, 0] >= u0 - t) and np.all(loop[:, 0] <= u1 + t)
        assert np.all(loop[:, 1] >= v0 - t) and np.all(loop[:, 1] <= v1 + t)


def _one_line(exc, path):
    message = str(exc.value)
    assert "\n" not in message and str(path) in message
    return message


def test_bad_files(tmp_path, rounded):
    good = write_shape(rounded, tmp_path / "good.step").read_bytes()
    text = tmp_path / "x.step"
    text.write_text("hello, not a STEP file\n")
    with pytest.raises(GshadeError) as exc:
        read_cad(text)
    assert "not a STEP file" in _one_line(exc, text)

    half = tmp_path / "half.step"
    half.write_bytes(good[: len(good) // 2])
    with pytest.raises(GshadeError) as exc:
        read_cad(half)
    assert "truncated" in _one_line(exc, half)

    obj = tmp_path / "x.obj"
    obj.write_text("v 0 0 0\n")
    with pytest.raises(GshadeError) as exc:
        read_cad(obj)
    _one_line(exc, obj)

    before = sorted(p.name for p in tmp_path.iterdir())
    edge = BRepBuilderAPI_MakeEdge(gp_Pnt(0, 0, 0), gp_Pnt(1, 0, 0)).Edge()
    for name in ("wire.igs", "wire.step", "wire.brep"):
        path = write_shape(edge, tmp_path / name)
        before.append(name)
        with pytest.raises(GshadeError) as exc:
            read_cad(path)
        assert "no surfaces" in _one_line(exc, path)

    missing = tmp_path / "missing.iges"
    with pytest.raises(GshadeError) as exc:
        read_cad(missing)
    _one_line(exc, missing)
    with pytest.raises(GshadeError) as exc:
        occt.read(tmp_path)
    assert "expected" in str(exc.value)
    assert sorted(before) == sorted(p.name for p in tmp_path.iterdir())


def test_step_faces_match_the_kernel_reading_the_same_file(rounded, tmp_path):
    path = write_shape(rounded, tmp_path / "r.step")
    shape, unit = occt._read_shape(path, ".step")
    assert unit == "mm"
    assert max_difference(read_cad(path), shape) < 1e-9


def test_a_step_files_declared_accuracy(rounded, tmp_path):
    """The global uncertainty a STEP file declares, in mm: the kernel's writer declares
    1e-7 mm; an inch file's 1e-5 is 2.54e-4 mm; a file without one declares nothing."""
    from gshade.cad.step_accuracy import step_uncertainty

    model = read_cad(write_shape(rounded, tmp_path / "r.step"))
    assert model.precision == pytest.approx(1e-7)
    assert read_cad(write_shape(rounded, tmp_path / "r.brep")).precision == 0.0
    inch = tmp_path / "inch.step"
    inch.write_text(
        "ISO-10303-21;\nDATA;\n#7 =( CONVERSION_BASED_UNIT ( 'INCH', #9 ) LENGTH_UNIT ( ) "
        "NAMED_UNIT ( #8 ) );\n#5 = UNCERTAINTY_MEASURE_WITH_UNIT (LENGTH_MEASURE(\n"
        "1.0E-005 ), #7, 'distance_accuracy_value', 'NONE');\nENDSEC;\n"
    )
    assert step_uncertainty(inch) == pytest.approx(2.54e-4)
    metre = tmp_path / "metre.step"
    metre.write_text(
        inch.read_text().replace("( CONVERSION_BASED_UNIT ( 'INCH', #9 )", "( SI_UNIT($,.METRE.)")
    )
    assert step_uncertainty(metre) == pytest.approx(1e-2)
    (tmp_path / "none.step").write_text("ISO-10303-21;\nDATA;\nENDSEC;\n")
    assert step_uncertainty(tmp_path / "none.step") == 0.0


def test_a_step_file_may_start_with_comments(tmp_path, rounded):
    # ISO 10303-21 allows comments outside strings; some writers put their banner first,
    # and the kernel reads such a file
    good = write_shape(rounded, tmp_path / "good.step").read_bytes()
    banner = tmp_path / "banner.step"
    banner.write_bytes(b"/* written by a tool\n * with a banner */\n\n/* two */ " + good)
    assert len(read_cad(banner).faces) == len(read_cad(tmp_path / "good.step").faces)
    other = tmp_path / "other.step"
    other.write_bytes(b"/* a comment */ hello, not a STEP file\n")
    with pytest.raises(GshadeError) as exc:
        read_cad(other)
    assert "not a STEP file" in _one_line(exc, other)
