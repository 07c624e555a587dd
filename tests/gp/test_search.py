"""The default likelihood search: how many evaluations, and what it finds."""

import numpy as np
import pytest
from scipy.optimize import minimize

import skmba.gp._search
from skmba import MultiResponseGP
from skmba.gp._lbfgsb import GAIN_TOL
from skmba.gp._likelihood import NoiseFreeLikelihood


def smooth_responses(n, seed):
    """Four smooth responses of four inputs, as benchmarks/bench_gp.py (to
    the last bit: the old search's count moves with them)."""
    X = np.random.default_rng(seed).uniform(size=(n, 4))
    base = [
        np.sin(2 * X[:, 0]) + X[:, 1] ** 2,
        np.cos(1.5 * X[:, 1]) * X[:, 2],
        np.exp(-X[:, 3]) + 0.5 * X[:, 0] * X[:, 2],
        np.sin(X[:, 2] + X[:, 3]),
    ]
    return X, np.column_stack([base[k] + 0.1 * k * X[:, k] for k in range(4)])


def scipy_to_its_end(objective, start, bounds):
    """The search before the stopping rule: L-BFGS-B on ``-loglik`` with
    scipy's defaults, run until its own tests (or failed line searches)
    end it."""
    res = minimize(objective, start, jac=True, method="L-BFGS-B", bounds=bounds)
    return res.x, res.fun


def test_default_fit_needs_few_likelihood_evaluations(monkeypatch):
    # Regression guard. N = 1000, d = 4, q = 4 with the defaults: 75
    # evaluations before (scipy's relative reduction test, below the
    # likelihood's round-off, never fired and two failed line searches of 20
    # evaluations ended the search), 10 with the per-observation objective
    # and the predicted-gain rule.
    X, Y = smooth_responses(1000, seed=0)
    count = {"evaluations": 0}

    class Counting(NoiseFreeLikelihood):
        def __init__(self, *args, **kwargs):
            count["evaluations"] += 1
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(skmba.gp._search, "NoiseFreeLikelihood", Counting)
    MultiResponseGP().fit(X, Y)
    assert count["evaluations"] <= 15


def rounding_spread(gp, seed=0):
    """Range of the log-likelihood over 20 points within 1e-8 of the fitted
    hyperparameters: its round-off at this nugget."""
    rng = np.random.default_rng(seed)
    theta = gp.kernel_.theta
    values = [
        gp.log_marginal_likelihood(theta + 1e-8 * rng.normal(size=theta.shape))
        for _ in range(20)
    ]
    return np.ptp(values)


@pytest.mark.parametrize("seed", [1, 2])
def test_default_fit_reaches_the_likelihood_of_a_fit_run_to_its_end(seed):
    # Identity: stopping at a predicted gain of GAIN_TOL loses at most about
    # GAIN_TOL nats against scipy's search run until it cannot go on (which
    # only adds the round-off of the likelihood, measured here: 6e-4 to
    # 1.4e-3 at N = 500 with the default nugget).
    X, Y = smooth_responses(500, seed)
    gp = MultiResponseGP().fit(X, Y)
    reference = MultiResponseGP(optimizer=scipy_to_its_end).fit(X, Y)
    tolerance = GAIN_TOL + rounding_spread(reference)
    assert gp.log_marginal_likelihood_value_ >= (
        reference.log_marginal_likelihood_value_ - tolerance
    )
    np.testing.assert_allclose(gp.kernel_.theta, reference.kernel_.theta, atol=0.01)
    X_test, _ = smooth_responses(200, seed=10 + seed)
    np.testing.assert_allclose(
        gp.predict(X_test), reference.predict(X_test), rtol=0, atol=1e-5
    )


@pytest.mark.parametrize("seed", [0, 1, 5])
def test_a_well_conditioned_fit_loses_at_most_the_gain_tolerance(seed):
    # An emulator of sin(2 pi t x) over x in [0, 1] and t in [2, 4]: 60
    # points leave the likelihood smooth (no round-off to speak of), so
    # the loss against the fit run to its end is GAIN_TOL at most.
    rng = np.random.default_rng(seed)
    Z = np.column_stack([rng.uniform(0, 1, 60), rng.uniform(2, 4, 60)])
    y = np.sin(2 * np.pi * Z[:, 1] * Z[:, 0])
    gp = MultiResponseGP().fit(Z, y)
    reference = MultiResponseGP(optimizer=scipy_to_its_end).fit(Z, y)
    loss = reference.log_marginal_likelihood_value_ - gp.log_marginal_likelihood_value_
    assert loss <= GAIN_TOL
