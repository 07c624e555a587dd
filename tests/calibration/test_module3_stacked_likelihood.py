"""The stacked module-3 likelihood equals the dense Eq. 4.30, at many theta."""

import numpy as np
import pytest

from skmba._core.linalg import FactorizationError
from skmba.calibration._module3_likelihood import (
    STACK_BYTES,
    schur_log_likelihoods,
    stack_chunks,
)

THETAS = np.array([[-0.7], [0.1], [0.9], [0.35]])


@pytest.mark.parametrize("data", ["problem", "gapped_problem"])
def test_many_theta_at_once_equal_the_dense_formula(request, dense_global, data):
    problem = request.getfixturevalue(data)
    gm = problem[1]
    values = gm.log_likelihoods(THETAS)
    expected = [dense_global(problem, t[0]) for t in THETAS]
    np.testing.assert_allclose(values, expected, rtol=1e-8, atol=1e-8)
    # One theta at a time gives the same values.
    np.testing.assert_allclose(
        values, [gm.log_likelihood(t) for t in THETAS], rtol=1e-12
    )


def _stack(gm, thetas):
    cond, terms = gm.conditionals(thetas)
    return gm.S_fixed + terms, gm.field_rows(cond)


def _args(gm):
    return gm.top, gm.rss_top_perp, gm.log_det_A, gm.N * gm.q + gm.n_observed


def test_a_schur_complement_that_does_not_factor_gives_minus_inf(problem):
    gm = problem[1]
    S, Z = _stack(gm, THETAS)
    expected = schur_log_likelihoods(S, Z, gm.noise_floor, *_args(gm))
    S[1] = -np.eye(len(S[1]))  # not positive definite: the stack fails
    values = schur_log_likelihoods(S, Z, gm.noise_floor, *_args(gm))
    assert values[1] == -np.inf
    keep = np.arange(len(THETAS)) != 1
    np.testing.assert_allclose(values[keep], expected[keep], rtol=1e-12)
    S[:] = -np.eye(S.shape[1])
    assert np.all(schur_log_likelihoods(S, Z, gm.noise_floor, *_args(gm)) == -np.inf)


def test_a_rank_deficient_regression_is_an_error(problem):
    gm = problem[1]
    S, Z = _stack(gm, THETAS)
    Z = Z.copy()
    Z[:, :, 1] = 0.0  # a regression column without field rows...
    top = gm.top.copy()
    top[:, 1] = 0.0  # ...nor simulation rows
    with pytest.raises(FactorizationError, match="rank deficient"):
        schur_log_likelihoods(S, Z, gm.noise_floor, top, *_args(gm)[1:])


def test_stack_chunks_cover_every_value_within_the_budget():
    for n_values, per_value, m in [(1, 1, 10), (37, 3, 140), (5, 16, 1200)]:
        chunks = stack_chunks(n_values, per_value, m, 7)
        covered = np.concatenate([np.arange(n_values)[c] for c in chunks])
        np.testing.assert_array_equal(covered, np.arange(n_values))
        size = chunks[0].stop - chunks[0].start
        assert size == 1 or size * per_value * (m + 7) ** 2 * 8 <= STACK_BYTES
