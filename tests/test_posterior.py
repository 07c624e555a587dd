"""Module 3: the Schur-complement global model equals the dense Eq. 4.30."""

import numpy as np
import pytest


@pytest.mark.parametrize("theta", [-0.7, 0.1, 0.9])
def test_schur_log_likelihood_equals_dense_eq_4_30(problem, dense_global, theta):
    gm = problem[1]
    assert gm.log_likelihood(np.array([theta])) == pytest.approx(
        dense_global(problem, theta), rel=1e-8, abs=1e-8
    )
