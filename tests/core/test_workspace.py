"""Scratch buffers: reused per thread, never leaking one call into the next."""

import threading

import numpy as np
from scipy import linalg

from skmba._core import workspace
from skmba._core.linalg import stacked_whitening
from skmba._core.workspace import scratch
from skmba.kernels import Gauss


def _stack(rng, k=6, m=150, c=5):
    A = rng.normal(size=(k, m, m))
    return A @ np.swapaxes(A, 1, 2) + m * np.eye(m), rng.normal(size=(k, m, c))


def test_stacked_whitening_does_not_read_what_the_buffer_held():
    S, Z = _stack(np.random.default_rng(0))
    scratch((S.size * 2,))[:] = np.nan  # what an earlier use left behind
    L, W = stacked_whitening(S, Z, 1.0)
    for k in range(len(S)):
        L_k = linalg.cholesky(S[k], lower=True)
        np.testing.assert_allclose(L[k], L_k, rtol=1e-12, atol=1e-12)
        W_k = linalg.solve_triangular(L_k, Z[k], lower=True)
        np.testing.assert_allclose(W[k], W_k, rtol=1e-10, atol=1e-12)


def test_each_thread_has_its_own_buffer_and_large_requests_their_own_array():
    mine = scratch((4, 4)).base
    theirs = []
    thread = threading.Thread(target=lambda: theirs.append(scratch((4, 4)).base))
    thread.start()
    thread.join()
    assert theirs[0] is not mine
    assert scratch((2, 8)).base is mine
    large = scratch((workspace.SCRATCH_BYTES // 8 + 1,))
    assert large.base is not mine
    assert scratch((4, 4)).base is mine


def test_a_correlation_built_in_the_buffer_does_not_read_what_it_held():
    rng = np.random.default_rng(2)
    X, Y = rng.uniform(size=(40, 3)), rng.uniform(size=(30, 3))
    scratch((40 * 30 * 2,))[:] = np.nan
    roughness = np.array([0.5, 2.0, 8.0])
    expected = np.exp(-(((X[:, None, :] - Y[None, :, :]) ** 2) @ roughness))
    K = Gauss(roughness=roughness)(X, Y)
    np.testing.assert_allclose(K, expected, rtol=1e-13)
    assert K.base is not scratch((1,)).base  # what it returns is its own
