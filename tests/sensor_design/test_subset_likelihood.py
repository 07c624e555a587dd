"""The designer's batched module-3 likelihood equals the global model."""

import numpy as np
import pytest
from conftest import discrepancy, fixed_gp
from sklearn.base import clone

from skmba._core.regression import regression_basis
from skmba.calibration._module1_emulator import Emulator
from skmba.calibration._module3_likelihood import GlobalModel
from skmba.kernels import Gauss
from skmba.sensor_design._subset_likelihood import FieldDesignEmulator, SubsetLikelihood


def _three_response_problem():
    rng = np.random.default_rng(3)
    N, n, q = 16, 5, 3
    X_m = rng.uniform(-1, 1, size=(N, 2))
    Y_m = np.column_stack(
        [
            np.sin(2 * X_m[:, 0]) * X_m[:, 1],
            X_m[:, 0] + 0.5 * X_m[:, 1] ** 2,
            np.cos(X_m[:, 0] + X_m[:, 1]),
        ]
    )
    gp = fixed_gp(X_m, Y_m)
    X_e = rng.uniform(-1, 1, size=(n, 1))
    Y_e = rng.normal(size=(n, q))
    A = rng.normal(size=(q, q))
    sigma2_d = 0.1 * (A @ A.T + np.eye(q))
    noise = np.array([0.01, 0.02, 0.005])
    return gp, X_m, Y_m, X_e, Y_e, sigma2_d, noise


@pytest.mark.parametrize("subset", [(0,), (2,), (0, 2), (1, 2), (0, 1, 2)])
def test_subset_likelihood_equals_global_model_of_the_subset(subset):
    """The batched subset path equals GlobalModel on the restricted data.

    With the kernel fixed, the GLS and ``Sigma2`` of a subset of the
    responses are the restriction of those of all responses, so a GP fitted
    to the subset alone is the restricted emulator.
    """
    gp, X_m, Y_m, X_e, Y_e, sigma2_d, noise = _three_response_problem()
    idx = list(subset)
    design = FieldDesignEmulator(Emulator(gp, X_m, Y_m, "linear"), X_e)
    H_d = regression_basis(X_e, "constant")
    like = SubsetLikelihood(
        design, idx, Y_e, Gauss(roughness=2.0)(X_e), H_d, sigma2_d, noise
    )
    thetas = np.array([[-0.7], [0.1], [0.9]])
    batched = like.log_likelihood(design.pieces(thetas))
    gp_sub = clone(gp).fit(X_m, Y_m[:, idx])
    np.testing.assert_allclose(
        gp_sub.likelihood_.sigma2, gp.likelihood_.sigma2[np.ix_(idx, idx)]
    )
    gm = GlobalModel(
        Emulator(gp_sub, X_m, Y_m[:, idx], "linear"),
        X_e,
        Y_e[:, idx],
        discrepancy(sigma2_d[np.ix_(idx, idx)], noise[idx]),
    )
    reference = np.array([gm.log_likelihood(t) for t in thetas])
    np.testing.assert_allclose(batched, reference, rtol=1e-8, atol=1e-8)


def test_subset_likelihood_marks_non_positive_definite_theta():
    """A Schur complement that is not positive definite gives -inf there."""
    gp, X_m, Y_m, X_e, Y_e, sigma2_d, noise = _three_response_problem()
    design = FieldDesignEmulator(Emulator(gp, X_m, Y_m, "linear"), X_e)
    H_d = regression_basis(X_e, "constant")
    like = SubsetLikelihood(
        design, [0, 1], Y_e, Gauss(roughness=2.0)(X_e), H_d, sigma2_d, noise
    )
    pieces = list(design.pieces(np.array([[0.0], [0.5]])))
    pieces[0] = pieces[0].copy()
    pieces[0][1] -= 50.0 * np.eye(len(X_e))  # break the second theta only
    out = like.log_likelihood(tuple(pieces))
    assert np.isfinite(out[0]) and out[1] == -np.inf
