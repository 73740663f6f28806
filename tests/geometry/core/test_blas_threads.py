"""Evaluation is independent of the BLAS thread pool, and leaves the caller's pool alone."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from gshade.errors import GshadeError
from gshade.geometry import BezierPatch, BSplinePatch
from gshade.geometry.core.blas_threads import BlasSingleThread, blas_single_thread
from gshade.geometry.evaluation.patch_groups import grid_derivatives


def blas_pools() -> list[tuple[str, int]]:
    """(library path, threads) of every BLAS library loaded."""
    return sorted(
        (lib["filepath"], lib["num_threads"])
        for lib in threadpool_info()
        if lib.get("user_api") == "blas"
    )


@pytest.fixture(scope="module")
def numpy_blas() -> set[str]:
    """The BLAS libraries that numpy loads (a fresh interpreter, numpy alone): gshade's
    products run in these; others loaded later (scipy's) are left to their users."""
    code = (
        "import json, numpy\nfrom threadpoolctl import threadpool_info\n"
        "print(json.dumps([l['filepath'] for l in threadpool_info() if l['user_api'] == 'blas']))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    paths = {os.path.realpath(p) for p in json.loads(out.stdout)}
    if not paths:
        pytest.skip("numpy loads no BLAS library that threadpoolctl knows")
    return paths


def numpy_pools(pools: list[tuple[str, int]], paths: set[str]) -> list[int]:
    found = [n for p, n in pools if os.path.realpath(p) in paths]
    assert found, (pools, paths)
    return found


def caller_pool_of_two() -> list[tuple[str, int]]:
    """The pools inside ``threadpool_limits(2, "blas")``: at least one of 2 threads, else the
    test would check nothing."""
    pools = blas_pools()
    if not any(n == 2 for _, n in pools):
        pytest.skip(f"no BLAS pool could be set to 2 threads: {pools}")
    return pools


def surface(rational: bool) -> BSplinePatch:
    """The benchmark's kind of patch: bicubic, 20 x 20, clamped uniform knots."""
    rng = np.random.default_rng(7)
    g = np.linspace(0.0, 1.0, 20)
    P = np.stack(np.broadcast_arrays(g[:, None], g[None, :], rng.uniform(-0.2, 0.2, (20, 20))))
    U = np.concatenate([np.zeros(3), np.linspace(0.0, 1.0, 18), np.ones(3)])
    w = rng.uniform(0.5, 2.0, (20, 20)) if rational else None
    return BSplinePatch(np.moveaxis(P, 0, -1), (3, 3), (U, U), weights=w)


def assert_close(a: np.ndarray, b: np.ndarray, rel: float = 1e-13) -> None:
    """Equal up to ``rel`` times each derivative's largest magnitude (summation order)."""
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            scale = max(1.0, float(np.abs(b[i, j]).max()))
            assert float(np.abs(a[i, j] - b[i, j]).max()) <= rel * scale, (i, j)


class PoolProbe(BSplinePatch):
    """Records the BLAS pools seen while the grid products run."""

    seen: list[list[tuple[str, int]]]

    def _derivatives_grid(self, u, v, order, buf):
        self.seen.append(blas_pools())
        super()._derivatives_grid(u, v, order, buf)


@pytest.mark.parametrize("rational", [False, True], ids=["bspline", "nurbs"])
def test_bspline_grid_same_with_one_blas_thread_and_default_pool(rational):
    patch = surface(rational)
    u = np.linspace(0.0, 1.0, 150)[:, None]  # 150 x 20 x 150: OpenBLAS would use its pool
    v = np.linspace(0.0, 1.0, 140)[None, :]
    default = patch.derivatives(u, v, 2)
    with threadpool_limits(1, "blas"):
        one = patch.derivatives(u, v, 2)
    assert_close(default, one)
    # and the per-point path, which multiplies without BLAS for B-splines
    uu, vv = np.broadcast_arrays(u, v)
    assert_close(default, patch.derivatives(uu.copy(), vv.copy(), 2))


def test_bspline_evaluation_runs_on_one_blas_thread_and_restores_the_pool(numpy_blas):
    patch = PoolProbe(surface(False).points, (3, 3), surface(False).knots)
    patch.seen = []
    u, v = np.linspace(0.0, 1.0, 50)[:, None], np.linspace(0.0, 1.0, 60)[None, :]
    env = os.environ.get("OPENBLAS_NUM_THREADS")
    with threadpool_limits(2, "blas"):  # the caller's choice, whatever the machine's default
        before = caller_pool_of_two()
        patch.derivatives(u, v, 2)
        assert blas_pools() == before
        assert patch.seen and numpy_pools(patch.seen[-1], numpy_blas) == [1] * len(numpy_blas)
        with pytest.raises(GshadeError):
            patch.derivatives(np.array([[2.0]]), np.array([[0.5]]), 1)  # outside the domain
        assert blas_pools() == before
        grid_derivatives([BezierPatch(np.zeros((4, 4, 3))), patch], np.linspace(0, 1, 9), 1)
        assert blas_pools() == before
    assert os.environ.get("OPENBLAS_NUM_THREADS") == env  # no environment variable set


def test_nurbs_evaluation_from_many_threads_restores_the_pool():
    patch = surface(True)
    u, v = np.linspace(0.0, 1.0, 40)[:, None], np.linspace(0.0, 1.0, 30)[None, :]
    ref = patch.derivatives(u, v, 2)
    with threadpool_limits(2, "blas"):
        before = caller_pool_of_two()
        with ThreadPoolExecutor(4) as pool:
            results = list(pool.map(lambda _: patch.derivatives(u, v, 2), range(24)))
        assert blas_pools() == before
    for r in results:
        assert_close(r, ref)


def test_bezier_limiter_nests_and_restores(numpy_blas):
    limiter = BlasSingleThread()
    with threadpool_limits(2, "blas"):
        before = caller_pool_of_two()
        with limiter:
            with limiter, blas_single_thread:
                assert set(numpy_pools(blas_pools(), numpy_blas)) == {1}
            assert set(numpy_pools(blas_pools(), numpy_blas)) == {1}
        assert blas_pools() == before
