"""Shape optimisation of hole fillings (gshade.geometry.holes.fairing), against independent checks.

Oracles: gshade's shape-function registry (H and grad_M H from the patches' own exact
derivatives) under Gauss–Legendre quadrature of another order and under a midpoint rule;
H and |grad_M H| from finite differences of surface points only; the invariance of the
surface integral under degree elevation (another parametrisation, the same surface);
central differences of the residuals for the Jacobian; the junction conditions C x = r and
the normals across the inner edges sampled on the optimised patches.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import threading
import time
from collections import OrderedDict
from dataclasses import asdict
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import scipy.optimize

from gshade.errors import GshadeError
from gshade.geometry.core.bernstein import bernstein_basis
from gshade.geometry.holes import fairing_cache
from gshade.geometry.holes.fairing import (
    FAIRING_FUNCTIONALS,
    FairingProblem,
    default_quadrature,
    fairing_value,
    optimise_fairing,
)
from gshade.geometry.holes.fairing_cache import optimise_filling
from gshade.geometry.holes.fill import fill_hole, hole_system
from gshade.geometry.holes.ring import find_holes
from gshade.geometry.patches.bezier import BezierPatch
from gshade.shape.registry import evaluate

from ...support.meshes import wavy_fan

MEASURES = tuple(FAIRING_FUNCTIONALS)
T = np.linspace(0.0, 1.0, 21)[1:]  # 20 points per inner edge, the centre apart


def start(n, continuity="G1"):
    """The quadratic filling of the wavy n-hole: (x0, Z, degree, C, r)."""
    (hole,) = find_holes(*wavy_fan(n, 3))
    system = hole_system(hole, continuity)
    x0 = np.concatenate([p.points.reshape(-1, 3) for p in fill_hole(hole, continuity).patches])
    _, s, Vt = np.linalg.svd(system.C)
    Z = Vt[int(np.sum(s > 1e-10 * s[0])) :].T
    return x0, Z, system.degree, system.C, system.r


@pytest.fixture(scope="module", params=[3, 5, 6], ids=lambda n: f"n{n}")
def g1(request):
    n = request.param
    x0, Z, degree, C, r = start(n)
    runs = {m: optimise_fairing(x0, Z, n, degree, m) for m in MEASURES}
    return n, x0, Z, degree, C, r, runs


@pytest.fixture(scope="module")
def g2():
    n = 6
    x0, Z, degree, C, r = start(n, "G2")
    runs = {m: optimise_fairing(x0, Z, n, degree, m) for m in MEASURES}
    return n, x0, Z, degree, C, r, runs


def patches(x, n, degree):
    return [BezierPatch(net) for net in np.reshape(x, (n, degree + 1, degree + 1, 3))]


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def integrand(patch, u, v, measure):
    """|f|^2 W at (u, v) from the registry's H and grad_M H on the exact derivatives."""
    d = patch.derivatives(u, v, 3)
    values = evaluate("mean", d, gradient=True, backend="numpy")
    W = np.linalg.norm(np.cross(d[1, 0], d[0, 1]), axis=-1)
    f2 = values.f**2 if measure == "mean" else np.sum(values.gradient**2, axis=-1)
    return f2 * W


def gauss_measure(x, n, degree, measure, points=24):
    t, w = np.polynomial.legendre.leggauss(points)
    t, w = (t + 1) / 2, w / 2
    u, v = np.meshgrid(t, t, indexing="ij")
    return sum(
        float(np.sum(np.outer(w, w) * integrand(p, u, v, measure))) for p in patches(x, n, degree)
    )


def midpoint_measure(x, n, degree, measure, points=160):
    t = (np.arange(points) + 0.5) / points
    u, v = np.meshgrid(t, t, indexing="ij")
    return sum(float(np.mean(integrand(p, u, v, measure))) for p in patches(x, n, degree))


# --------------------------------------------------------------------------- the measure


@pytest.mark.parametrize("measure", MEASURES)
def test_the_measure_is_the_surface_integral(g1, measure):
    n, x0, _, degree, _, _, runs = g1
    x, info = runs[measure]
    for y, value in ((x0, info.initial), (x, info.final)):
        exact = gauss_measure(y, n, degree, measure)
        # the same quadrature order: the same sum, computed independently
        assert fairing_value(y, n, degree, measure, quadrature=24) == pytest.approx(
            exact, rel=1e-11
        )
        # the working quadrature (default order) is close to converged, also at the result
        assert value == pytest.approx(exact, rel=2e-3)
    assert info.final_check == pytest.approx(gauss_measure(x, n, degree, measure), rel=1e-3)


def test_the_measure_by_a_midpoint_rule():
    n = 5
    x0, _, degree, _, _ = start(n)
    for measure in MEASURES:
        value = fairing_value(x0, n, degree, measure, quadrature=20)
        assert midpoint_measure(x0, n, degree, measure) == pytest.approx(value, rel=2e-4)


def test_the_measure_does_not_depend_on_the_parametrisation():
    """Q_i(s, t) = P_i(phi(s), phi(t)), phi(s) = s (1 + s) / 2: the same surface, another
    parametrisation (nonlinear, degree (2d, 2d)), its net interpolated exactly."""
    n, d = 5, 5
    x0, _, degree, _, _ = start(n)
    assert degree == d
    s = 0.5 - 0.5 * np.cos(np.pi * (np.arange(2 * d + 1) + 0.5) / (2 * d + 1))
    B = bernstein_basis(2 * d, s)[0]  # (2d + 1, 2d + 1)
    phi = s * (1 + s) / 2
    u, v = np.meshgrid(phi, phi, indexing="ij")
    nets = [
        np.einsum("ia,jb,abc->ijc", *[np.linalg.inv(B)] * 2, p(u, v)) for p in patches(x0, n, d)
    ]
    xq = np.concatenate([net.reshape(-1, 3) for net in nets])
    for measure in MEASURES:
        a = fairing_value(x0, n, d, measure, quadrature=30)
        b = fairing_value(xq, n, 2 * d, measure, quadrature=30)
        assert b == pytest.approx(a, rel=1e-8)


def test_the_integrand_by_finite_differences_of_points():
    """H, W and |grad_M H| at the quadrature points from surface points only."""
    n, q = 5, 6
    x0, Z, degree, _, _ = start(n)
    P = patches(x0, n, degree)[2]
    net = np.asarray(P.points).reshape(-1, 3)
    x = np.concatenate([net] * n)  # five copies: patch 2 among them
    out = {}
    for measure in MEASURES:
        problem = FairingProblem(x, Z[:, :0], n, degree, FAIRING_FUNCTIONALS[measure], q)
        rho = problem.residuals(np.zeros(0)).reshape(n, q, q, -1)[2]
        out[measure] = np.sum(rho**2, axis=-1) / problem.weight[: q * q].reshape(q, q)
    t = (np.polynomial.legendre.leggauss(q)[0] + 1) / 2
    u, v = np.meshgrid(t, t, indexing="ij")
    h = 1e-3

    def forms(u, v):
        p = lambda a, b: P(u + a * h, v + b * h)  # noqa: E731
        pu, pv = (p(1, 0) - p(-1, 0)) / (2 * h), (p(0, 1) - p(0, -1)) / (2 * h)
        puu = (p(1, 0) - 2 * p(0, 0) + p(-1, 0)) / h**2
        pvv = (p(0, 1) - 2 * p(0, 0) + p(0, -1)) / h**2
        puv = (p(1, 1) - p(1, -1) - p(-1, 1) + p(-1, -1)) / (4 * h**2)
        nrm = unit(np.cross(pu, pv))
        E, F, G = (np.sum(a * b, -1) for a, b in ((pu, pu), (pu, pv), (pv, pv)))
        L, M, N = (np.sum(a * nrm, -1) for a in (puu, puv, pvv))
        H = (E * N - 2 * F * M + G * L) / (2 * (E * G - F * F))
        return H, E, F, G

    H, E, F, G = forms(u, v)
    W = np.sqrt(E * G - F * F)
    np.testing.assert_allclose(out["mean"], H**2 * W, rtol=1e-5)
    k = 1e-2  # H_u, H_v by fourth-order differences of those H (errors smooth in u, v)
    c = {2: -1 / 12, 1: 8 / 12, -1: -8 / 12, -2: 1 / 12}
    Hu = sum(w * forms(u + j * k, v)[0] for j, w in c.items()) / k
    Hv = sum(w * forms(u, v + j * k)[0] for j, w in c.items()) / k
    grad2 = (G * Hu * Hu - 2 * F * Hu * Hv + E * Hv * Hv) / (E * G - F * F)
    np.testing.assert_allclose(out["mean-gradient"], grad2 * W, rtol=1e-5)


# --------------------------------------------------------------------------- the Jacobian


@pytest.mark.parametrize("measure", MEASURES)
@pytest.mark.parametrize("continuity", ["G1", "G2"])
def test_the_jacobian_is_the_derivative(measure, continuity):
    n = 5
    x0, Z, degree, _, _ = start(n, continuity)
    problem = FairingProblem(x0, Z, n, degree, FAIRING_FUNCTIONALS[measure], 8)
    rng = np.random.default_rng(7)
    y = 0.02 * rng.normal(size=3 * problem.k)  # away from the start
    J = problem.jacobian(y)
    assert J.shape == (problem.residuals(y).size, 3 * problem.k)
    h = 1e-6
    for e in [*rng.normal(size=(3, 3 * problem.k)), *np.eye(3 * problem.k)[[0, 4, -1]]]:
        fd = (problem.residuals(y + h * e) - problem.residuals(y - h * e)) / (2 * h)
        assert np.abs(J @ e - fd).max() < 1e-7 * np.abs(fd).max()


# --------------------------------------------------------------------------- optimisation


@pytest.mark.parametrize("measure", MEASURES)
def test_the_optimisation_lowers_the_measure(g1, measure):
    _, _, Z, _, _, _, runs = g1
    _, info = runs[measure]
    assert info.measure == measure and info.parameters == 3 * Z.shape[1]
    assert info.final < 0.99 * info.initial  # the wavy holes all improve by > 1 %
    assert 0 < info.iterations <= 10 and info.jacobians >= 1


@pytest.mark.parametrize("measure", MEASURES)
def test_the_junction_conditions_still_hold(g1, measure):
    n, x0, _, degree, C, r, runs = g1
    x, _ = runs[measure]
    before = np.abs(C @ x0 - r).max()
    assert np.abs(C @ x - r).max() < before + 1e-12
    P = patches(x, n, degree)
    for i, p in enumerate(P):
        q = P[i - 1]
        np.testing.assert_allclose(p(T, 0 * T), q(0 * T, T), atol=1e-12)
        a = unit(np.cross(*p.derivatives(T, 0 * T, 1)[[1, 0], [0, 1]]))
        b = unit(np.cross(*q.derivatives(0 * T, T, 1)[[1, 0], [0, 1]]))
        assert np.abs(a - b).max() < 1e-11


def test_g2_filling_optimised(g2):
    n, x0, _, degree, C, r, runs = g2
    assert degree == 9
    for measure in MEASURES:
        x, info = runs[measure]
        assert info.final < 0.98 * info.initial
        assert info.final_check == pytest.approx(info.final, rel=1e-3)
        assert np.abs(C @ x - r).max() < np.abs(C @ x0 - r).max() + 1e-12
        P = patches(x, n, degree)
        for i, p in enumerate(P):
            a = unit(np.cross(*p.derivatives(T, 0 * T, 1)[[1, 0], [0, 1]]))
            b = unit(np.cross(*P[i - 1].derivatives(0 * T, T, 1)[[1, 0], [0, 1]]))
            assert np.abs(a - b).max() < 1e-11
    assert runs["mean-gradient"][1].seconds < 300.0  # a hang guard (~0.8 s on 2 cores)


@pytest.mark.parametrize("measure", MEASURES)
def test_moving_along_the_normal_only(measure):
    n = 5
    x0, Z, degree, C, r = start(n)
    x, info = optimise_fairing(x0, Z, n, degree, measure, free="normal")
    assert info.parameters == Z.shape[1]
    assert info.final < 0.995 * info.initial
    assert np.abs(C @ x - r).max() < np.abs(C @ x0 - r).max() + 1e-12
    # every control point moved along one direction (the mean normal)
    moves = x - x0
    _, s, _ = np.linalg.svd(moves)
    assert s[1] < 1e-12 * s[0]
    problem = FairingProblem(x0, Z, n, degree, FAIRING_FUNCTIONALS[measure], 8, unit(moves[:1]))
    y = 0.02 * np.random.default_rng(3).normal(size=problem.size)
    J = problem.jacobian(y)
    e = np.random.default_rng(4).normal(size=problem.size)
    fd = (problem.residuals(y + 1e-6 * e) - problem.residuals(y - 1e-6 * e)) / 2e-6
    assert np.abs(J @ e - fd).max() < 1e-7 * np.abs(fd).max()


def test_a_coarse_quadrature_cannot_make_it_worse():
    """With too few points the optimiser may lower the sum, not the integral: then the
    start is kept (checked with twice the points)."""
    n = 5
    x0, Z, degree, _, _ = start(n, "G2")
    x, info = optimise_fairing(x0, Z, n, degree, "mean", quadrature=10, iterations=20)
    fine = fairing_value(x0, n, degree, "mean", quadrature=20)
    assert info.final_check <= fine
    assert fairing_value(x, n, degree, "mean", quadrature=30) <= fairing_value(
        x0, n, degree, "mean", quadrature=30
    ) * (1 + 1e-9)


def test_more_steps_lower_it_further():
    n = 5
    x0, Z, degree, _, _ = start(n)
    values = [optimise_fairing(x0, Z, n, degree, "mean", iterations=k)[1].final for k in (2, 8)]
    assert values[1] <= values[0] < fairing_value(x0, n, degree, "mean")


def test_no_steps_return_the_start():
    n = 3
    x0, Z, degree, _, _ = start(n)
    x, info = optimise_fairing(x0, Z, n, degree, "mean", iterations=0)
    np.testing.assert_array_equal(x, x0)
    assert info.final == info.initial and info.iterations == 0
    assert info.quadrature == default_quadrature(degree, "mean")


def test_a_folded_result_is_discarded(monkeypatch):
    """The guard against a fold: a 'result' whose normals turned over is not taken."""
    n = 3
    x0, Z, degree, _, _ = start(n)
    fake = SimpleNamespace(
        x=np.full(3 * Z.shape[1], 0.1), fun=np.zeros(1), nfev=3, njev=2, status=1, message="ok"
    )
    monkeypatch.setattr(scipy.optimize, "least_squares", lambda *a, **k: fake)
    flip = FairingProblem.normals
    monkeypatch.setattr(
        FairingProblem, "normals", lambda self, y: flip(self, y) * (-1.0 if np.any(y) else 1.0)
    )
    x, info = optimise_fairing(x0, Z, n, degree, "mean")
    np.testing.assert_array_equal(x, x0)
    assert info.final == info.initial and not info.converged
    assert "folds" in info.message


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("change", "name"),
    [
        ({"measure": "mena"}, "measure"),
        ({"measure": 3}, "measure"),
        ({"iterations": -1}, "iterations"),
        ({"iterations": 2.5}, "iterations"),
        ({"iterations": True}, "iterations"),
        ({"quadrature": 0}, "quadrature"),
        ({"free": "tangent"}, "free"),
        ({"n": 2}, "n"),
        ({"degree": 4}, "x0"),
        ({"degree": 2, "measure": "mean-gradient"}, "degree"),
        ({"x0": "zeros"}, "x0"),
        ({"x0": "nan"}, "x0"),
        ({"Z": "short"}, "Z"),
        ({"x0": "flat"}, "x0"),
        ({"x0": [["a", "b", "c"]]}, "x0"),
        ({"Z": {"not": "numbers"}}, "Z"),
    ],
)
def test_bad_arguments(change, name):
    n = 3
    x0, Z, degree, _, _ = start(n)
    args = {"x0": x0, "Z": Z, "n": n, "degree": degree, "measure": "mean"}
    args.update(change)
    if isinstance(args["x0"], str):
        kind = args["x0"]
        args["x0"] = {"zeros": np.zeros((5, 3)), "nan": np.full_like(x0, np.nan)}.get(
            kind,
            np.zeros_like(x0),  # "flat": every point the same, irregular everywhere
        )
    if isinstance(args["Z"], str):
        args["Z"] = Z[:-1]
    kw = {k: args.pop(k) for k in ("iterations", "quadrature", "free") if k in args}
    with pytest.raises(GshadeError, match=f"^{name}:"):
        optimise_fairing(args["x0"], args["Z"], args["n"], args["degree"], args["measure"], **kw)


def test_a_misspelt_measure_is_suggested():
    with pytest.raises(GshadeError, match='did you mean "mean-gradient"'):
        fairing_value(np.zeros((108, 3)), 3, 5, "mean-gradiant")


# --------------------------------------------------------------------------- the cache


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """An empty cache: its folder under tmp_path, nothing in memory."""
    monkeypatch.setenv("GSHADE_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(fairing_cache, "_memory", OrderedDict())
    return tmp_path / "cache" / "hole-shape"


@pytest.fixture(scope="module")
def small():
    """A G1 filling of the wavy 3-hole (optimised in ~0.1 s with 3 steps)."""
    (hole,) = find_holes(*wavy_fan(3, 3))
    return fill_hole(hole, "G1")


def _same(a, b):
    """The same optimised filling: points bitwise, the report but for time and origin."""
    assert np.array_equal(a.nets, b.nets)
    strip = ("seconds", "cached")
    assert {k: v for k, v in asdict(a.fairing).items() if k not in strip} == {
        k: v for k, v in asdict(b.fairing).items() if k not in strip
    }


def test_optimised_fillings_are_cached_by_content(cache, small, monkeypatch):
    calls = []
    real = fairing_cache.optimise_fairing
    monkeypatch.setattr(
        fairing_cache, "optimise_fairing", lambda *a, **k: calls.append(1) or real(*a, **k)
    )
    fresh = optimise_filling(small, "mean", iterations=3)
    assert not fresh.fairing.cached and len(calls) == 1
    assert [p.name for p in cache.iterdir()] == [f"{_key(small, 3)}.bin"]
    again = optimise_filling(small, "mean", iterations=3)  # from memory
    assert again.fairing.cached and len(calls) == 1
    _same(again, fresh)
    fairing_cache._memory.clear()  # another process: from the file
    disk = optimise_filling(small, "mean", iterations=3)
    assert disk.fairing.cached and len(calls) == 1
    _same(disk, fresh)
    # another computation is another entry
    for other in ({"iterations": 2}, {"iterations": 3, "free": "normal"}):
        assert not optimise_filling(small, "mean", **other).fairing.cached
    assert not optimise_filling(small, "mean-gradient", iterations=1).fairing.cached
    assert len(calls) == 4 and len(list(cache.iterdir())) == 4


def _key(filling, iterations, measure="mean", free="all"):
    n = len(filling.patches)
    x0, Z = filling.nets, filling.free_basis
    return fairing_cache._cache_key(x0, Z, n, filling.degree, measure, iterations, free)


def _rewrite(path, change):
    """The cache file with its header (a dict) and points changed, the checksum kept right."""
    data = path.read_bytes()
    magic = fairing_cache._MAGIC
    end = data.index(b"\n", len(magic))
    header = json.loads(data[len(magic) : end])
    x = np.frombuffer(data[end + 1 :], dtype="<f8").copy()
    change(header, x)
    payload = x.astype("<f8").tobytes()
    header["sha256"] = hashlib.sha256(payload).hexdigest()
    path.write_bytes(magic + json.dumps(header).encode() + b"\n" + payload)


def _off_the_conditions(header, x):
    x[0] += 1e-3  # a control point moved out of the admissible space


def _wrong_check(header, x):
    header["info"]["final_check"] *= 0.5


def _nan(header, x):
    x[5] = np.nan


def _other_key(header, x):
    header["key"] = "0" * 64


def _bad_report(header, x):
    header["info"]["iterations"] = "ten"


CORRUPTIONS = {
    "garbage": lambda p: p.write_bytes(b"\x00garbage" * 100),
    "empty": lambda p: p.write_bytes(b""),
    "truncated": lambda p: p.write_bytes(p.read_bytes()[:-7]),
    "a flipped byte": lambda p: p.write_bytes(p.read_bytes()[:-9] + b"\x01" + p.read_bytes()[-8:]),
    "too large": lambda p: p.write_bytes(p.read_bytes() + b"\x00" * (5 * 2**20)),
    "json bomb": lambda p: p.write_bytes(fairing_cache._MAGIC + b"[" * 100_000 + b"\n"),
    "off the conditions": lambda p: _rewrite(p, _off_the_conditions),
    "a wrong final_check": lambda p: _rewrite(p, _wrong_check),
    "NaN": lambda p: _rewrite(p, _nan),
    "another key": lambda p: _rewrite(p, _other_key),
    "a bad report": lambda p: _rewrite(p, _bad_report),
}


@pytest.mark.parametrize("corruption", list(CORRUPTIONS))
def test_a_corrupt_or_hostile_cache_file_is_recomputed(cache, small, corruption):
    fresh = optimise_filling(small, "mean", iterations=3)
    path = cache / f"{_key(small, 3)}.bin"
    CORRUPTIONS[corruption](path)
    fairing_cache._memory.clear()
    again = optimise_filling(small, "mean", iterations=3)
    assert not again.fairing.cached
    _same(again, fresh)
    fairing_cache._memory.clear()  # and the file was written anew, whole
    assert optimise_filling(small, "mean", iterations=3).fairing.cached


@pytest.mark.parametrize("kind", ["symlink", "fifo", "folder"])
def test_a_cache_entry_that_is_not_a_regular_file_is_not_read(cache, small, tmp_path, kind):
    fresh = optimise_filling(small, "mean", iterations=3)
    path = cache / f"{_key(small, 3)}.bin"
    elsewhere = tmp_path / "elsewhere.bin"
    path.rename(elsewhere)
    if kind == "symlink":  # a whole entry, but through a link: not followed
        path.symlink_to(elsewhere)
    elif kind == "fifo":
        os.mkfifo(path)
    else:
        path.mkdir()
    fairing_cache._memory.clear()
    again = optimise_filling(small, "mean", iterations=3)  # neither blocks nor fails
    assert not again.fairing.cached
    _same(again, fresh)
    assert not [p for p in cache.iterdir() if p.name.endswith(".tmp")]


def test_the_cache_can_be_off_or_unwritable(small, tmp_path, monkeypatch):
    monkeypatch.setattr(fairing_cache, "_memory", OrderedDict())
    monkeypatch.setenv("GSHADE_CACHE_DIR", "off")
    assert fairing_cache.cache_folder() is None
    fresh = optimise_filling(small, "mean", iterations=3)
    assert optimise_filling(small, "mean", iterations=3).fairing.cached  # in memory
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("GSHADE_CACHE_DIR", str(blocker))
    fairing_cache._memory.clear()
    _same(optimise_filling(small, "mean", iterations=3), fresh)
    assert blocker.read_text() == "not a folder"
    monkeypatch.delenv("GSHADE_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert fairing_cache.cache_folder() == tmp_path / "xdg" / "gshade" / "hole-shape"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/path")  # ignored, as the spec says
    assert fairing_cache.cache_folder() == Path.home() / ".cache" / "gshade" / "hole-shape"


def test_concurrent_writers_leave_a_whole_entry(cache, small):
    """Writers of one entry each rename a whole file into place: a reader at any moment
    finds a whole one (the entry is there from the start), never a part; no writer fails;
    no temporary is left."""
    fresh = optimise_filling(small, "mean", iterations=3)
    key = _key(small, 3)
    path = cache / f"{key}.bin"
    stop = threading.Event()
    bad = []

    def write():
        try:
            while not stop.is_set():
                fairing_cache._store(key, fresh.nets, fresh.fairing)
        except Exception as error:  # a writer that fails writes nothing: the test must see it
            bad.append(error)

    def read():
        while not stop.is_set():
            found = fairing_cache._read_entry(path, key, fresh.nets.shape)
            if found is None or not np.array_equal(found[0], fresh.nets):
                bad.append(found)

    threads = [threading.Thread(target=write) for _ in range(4)]
    threads += [threading.Thread(target=read) for _ in range(2)]
    for t in threads:
        t.start()
    time.sleep(1.0)  # as many interleavings as a second gives (no result depends on it)
    stop.set()
    for t in threads:
        t.join()
    assert not bad
    assert [p.name for p in cache.iterdir()] == [path.name]
    fairing_cache._memory.clear()
    assert optimise_filling(small, "mean", iterations=3).fairing.cached


def test_a_hole_scene_loads_its_optimised_fillings_from_the_cache(cache, tmp_path, monkeypatch):
    """The second load of an ``optimise`` scene (and a load in another process) runs no
    optimisation: the fuzz and CLI tests load hole-valence-mean-g2-optimised.toml (>10 s of
    optimisation) many times."""
    from gshade.scene import load_scene

    from ...support.meshes import obj_of

    (tmp_path / "fan.obj").write_text(obj_of(*wavy_fan(3, 3)))
    scene = tmp_path / "s.toml"
    scene.write_text(
        '[[surface]]\ntype = "hole"\nfile = "fan.obj"\ncontinuity = "G1"\n'
        'optimise = "mean"\niterations = 3\n'
    )
    calls = []
    real = fairing_cache.optimise_fairing
    monkeypatch.setattr(
        fairing_cache, "optimise_fairing", lambda *a, **k: calls.append(1) or real(*a, **k)
    )
    first = load_scene(scene).patches
    assert len(calls) == 1
    fairing_cache._memory.clear()
    second = load_scene(scene).patches
    assert len(calls) == 1
    for a, b in zip(first, second, strict=True):
        assert np.array_equal(a.points, b.points)
    code = (
        "import gshade.geometry.holes.fairing_cache as h; from gshade.scene import load_scene; "
        "real = h.optimise_fairing; h.optimise_fairing = lambda *a, **k: 1 / 0; "
        f"print(len(load_scene({str(scene)!r}).patches))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert int(out.stdout) == len(first)
