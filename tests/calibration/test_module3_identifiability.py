"""identifiability_ and NonIdentifiabilityWarning
(skmba.calibration._module3_identifiability)."""

import warnings

import numpy as np
import pytest

from skmba.calibration._module3_identifiability import (
    IDENTIFIABILITY_THRESHOLD,
    data_share,
    linearised_sds,
    warn_if_confounded,
)
from skmba.exceptions import NonIdentifiabilityWarning


def _gauss(x, roughness):
    return np.exp(-roughness * (x[:, None] - x[None, :]) ** 2)


def information_ratio(J, V0, K_d, X_d):
    """The probe's ratio: linearised sd without over with the discrepancy."""
    sd0, sd1 = linearised_sds(J, V0, K_d, X_d)
    return sd0 / sd1


def test_information_ratio_known_answers():
    n = 30
    x = np.linspace(-1.5, 1.5, n)
    V0 = 0.01 * np.eye(n)
    X_d = np.ones((n, 1))
    # A sensitivity that is a constant shift: the discrepancy mean absorbs
    # it entirely, whatever the discrepancy variance.
    assert information_ratio(np.ones((n, 1)), V0, 0 * V0, X_d)[0] < 1e-6
    # No discrepancy variance and a sensitivity orthogonal to the constant:
    # only the mean's degree of freedom is lost, which costs nothing here.
    J = (x - x.mean())[:, None]
    assert information_ratio(J, V0, 0 * V0, X_d)[0] == pytest.approx(1.0)
    # A smooth discrepancy absorbs a smooth (linear) sensitivity...
    smooth = information_ratio(J, V0, 1.0 * _gauss(x, 0.5), X_d)[0]
    # ...but not a fast oscillation.
    J_fast = np.sin(12 * x)[:, None]
    fast = information_ratio(J_fast, V0, 1.0 * _gauss(x, 0.5), X_d)[0]
    assert smooth < 0.1 < 0.9 < fast <= 1.0


def test_information_ratio_equals_dense_posterior_sds():
    rng = np.random.default_rng(0)
    n, r = 12, 2
    J = rng.normal(size=(n, r))
    A = rng.normal(size=(n, n))
    V0 = A @ A.T / n + 0.1 * np.eye(n)
    x = np.linspace(0, 1, n)
    K = 0.3 * _gauss(x, 4.0)
    X_d = np.column_stack([np.ones(n), x])
    var0 = np.diag(np.linalg.inv(J.T @ np.linalg.inv(V0) @ J))
    Vi = np.linalg.inv(V0 + K)
    Pi = Vi - Vi @ X_d @ np.linalg.inv(X_d.T @ Vi @ X_d) @ X_d.T @ Vi
    var1 = np.diag(np.linalg.inv(J.T @ Pi @ J))
    np.testing.assert_allclose(
        information_ratio(J, V0, K, X_d), np.sqrt(var0 / var1), rtol=1e-8
    )
    np.testing.assert_allclose(
        linearised_sds(J, V0, K, X_d), np.sqrt([var0, var1]), rtol=1e-8
    )


def test_warning_names_the_parameter_and_the_remedies():
    with pytest.warns(
        NonIdentifiabilityWarning, match=r"E \(0\.05\).*PreposteriorDesigner"
    ):
        warn_if_confounded(np.array([0.05, 0.9]), ["E", "I"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_if_confounded(np.array([IDENTIFIABILITY_THRESHOLD + 0.01]), ["E"])
    assert issubclass(NonIdentifiabilityWarning, UserWarning)


def test_data_share_is_the_conditional_sd_ratio_at_most_one():
    # One parameter: the data's linearised sd over the posterior's.
    assert data_share(np.array([[4.0]]), np.array([[1.0]]))[0] == 0.5
    # Against the dense formula: sqrt(inv(cov)_jj / info_jj), capped at 1.
    rng = np.random.default_rng(1)
    A, B = rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    info, cov = A @ A.T + np.eye(3), 0.05 * (B @ B.T + np.eye(3))
    dense = np.sqrt(np.diag(np.linalg.inv(cov)) / np.diag(info))
    np.testing.assert_allclose(data_share(info, cov), np.minimum(dense, 1.0))
    # No information on the second parameter: its interval is the prior's
    # whatever the discrepancy (1). A parameter tied to another along a
    # ridge (E and I of a beam): wide marginals, but given the other the
    # posterior is 10 times the data's width, which the share shows.
    out = data_share(np.diag([100.0, 0.0]), np.eye(2))
    np.testing.assert_array_equal(out, [0.1, 1.0])
    # (log E, log I: the data pin their sum down, not their difference).
    ridge = 100.0 * np.array([[1.0, -0.99995], [-0.99995, 1.0]])
    info = np.array([[1.0e4, 1.0e4 - 1.0], [1.0e4 - 1.0, 1.0e4]])
    assert np.all(data_share(info, ridge) < 0.2)
