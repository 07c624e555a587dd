"""Module 3: the Schur-complement global model equals the dense Eq. 4.30,
with every field entry measured and with gaps (NaN entries left out)."""

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
