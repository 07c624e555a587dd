"""Module 3: the Schur-complement global model equals the dense Eq. 4.30,
with every field entry measured and with gaps (NaN entries left out)."""

import copy
import dataclasses

import numpy as np
import pytest


@pytest.mark.parametrize("theta", [-0.7, 0.1, 0.9])
@pytest.mark.parametrize("data", ["problem", "gapped_problem"])
def test_schur_log_likelihood_equals_dense_eq_4_30(request, dense_global, theta, data):
    problem = request.getfixturevalue(data)
    gm = problem[1]
    assert gm.log_likelihood(np.array([theta])) == pytest.approx(
        dense_global(problem, theta), rel=1e-8, abs=1e-8
    )


def test_gaps_leave_out_their_entries(problem, gapped_problem):
    full, gapped = problem[1], gapped_problem[1]
    assert full.observed is None and full.n_observed == 12
    assert gapped.n_observed == 9
    # entries (2, 0), (5, 0) and (0, 1) are vec positions 2, 5 and 6 + 0
    np.testing.assert_array_equal(gapped.observed, [0, 1, 3, 4, 7, 8, 9, 10, 11])
    assert gapped.log_likelihood(np.array([0.2])) != pytest.approx(
        full.log_likelihood(np.array([0.2]))
    )


def test_field_correlation_is_the_correlation_at_every_theta(problem):
    # All field points share theta: with a stationary kernel the model
    # correlation among them does not depend on it, bit for bit.
    gm = problem[1]
    assert gm.R_ee is not None
    for theta in (-0.9, 0.2, 0.7):
        cond = gm.emulator.conditional(gm.X_e, np.array([[theta]]))
        np.testing.assert_array_equal(cond.prior_correlation()[0], gm.R_ee)
        np.testing.assert_array_equal(
            cond.correlation(gm.nugget, prior=gm.R_ee), cond.correlation(gm.nugget)
        )


def test_field_correlation_of_a_non_stationary_kernel_is_none(problem):
    from sklearn.gaussian_process.kernels import DotProduct

    emulator = problem[1].emulator
    gp = copy.copy(emulator.gp)
    gp.kernel_ = DotProduct()
    emulator = dataclasses.replace(emulator, gp=gp)
    assert emulator.field_correlation(problem[1].X_e) is None
