"""The GIL-free triangular solve: scipy's bits, and other threads run."""

import threading
import time

import numpy as np
import pytest
from scipy import linalg
from threadpoolctl import threadpool_limits

from skmba._core.triangular import lower_solve


def _factor(m, rng):
    A = rng.normal(size=(m, m))
    return np.linalg.cholesky(A @ A.T / m + np.eye(m))


@pytest.mark.parametrize("m, n", [(1, 1), (5, 3), (50, 777)])
@pytest.mark.parametrize("order_L", ["C", "F"])
@pytest.mark.parametrize("order_B", ["C", "F"])
def test_the_solution_is_scipys_to_the_bit(m, n, order_L, order_B):
    rng = np.random.default_rng(m)
    L = np.asarray(_factor(m, rng), order=order_L)
    B = np.asarray(rng.normal(size=(m, n)), order=order_B)
    X = lower_solve(L, B)
    np.testing.assert_array_equal(X, linalg.solve_triangular(L, B, lower=True))
    assert X.flags.f_contiguous
    np.testing.assert_allclose(L @ X, B, atol=1e-12 * m)


def test_the_upper_triangle_is_not_read_and_B_is_kept():
    rng = np.random.default_rng(0)
    L = _factor(6, rng)
    B = rng.normal(size=(6, 2))
    kept = B.copy()
    noisy = L + np.triu(rng.normal(size=(6, 6)), 1)
    np.testing.assert_array_equal(lower_solve(noisy, B), lower_solve(L, B))
    np.testing.assert_array_equal(B, kept)


def test_other_threads_run_during_the_solve():
    """A Python thread notes the time at every step while the main thread
    solves a system of order 1,000 with 4,000 right-hand sides on one BLAS
    thread (about 0.3 s): its longest pause stays below half the solve's
    time. A call that holds the GIL (scipy's solve) stops it for the whole
    solve."""
    rng = np.random.default_rng(1)
    L, B = _factor(1000, rng), rng.normal(size=(1000, 4000))
    last, longest, stop = [time.perf_counter()], [0.0], threading.Event()

    def note():
        while not stop.is_set():
            now = time.perf_counter()
            longest[0] = max(longest[0], now - last[0])
            last[0] = now

    worker = threading.Thread(target=note)
    with threadpool_limits(1, user_api="blas"):
        worker.start()
        try:
            time.sleep(0.01)  # the worker runs
            longest[0] = 0.0
            start = time.perf_counter()
            lower_solve(L, B)
            seconds = time.perf_counter() - start
        finally:
            stop.set()
            worker.join()
    assert longest[0] < 0.5 * seconds


@pytest.mark.parametrize(
    "L, B, match",
    [
        (np.eye(3), np.ones(3), "two-dimensional"),
        (np.ones((3, 2)), np.ones((3, 1)), "square"),
        (np.eye(3), np.ones((2, 1)), "right-hand sides as columns"),
    ],
)
def test_invalid_shapes_are_refused(L, B, match):
    with pytest.raises(ValueError, match=match):
        lower_solve(L, B)
