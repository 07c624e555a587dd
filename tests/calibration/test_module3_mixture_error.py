"""The Monte Carlo error of module 3's mixture over module 2's fixed draws
(skmba.calibration._module3_mixture_error)."""

import warnings

import numpy as np
import pytest
from scipy import stats

from skmba import ModularBayesCalibrator
from skmba.calibration._module3_mixture_error import (
    MIXTURE_TOL,
    mixture_error,
    mixture_errors,
)

GRID = np.linspace(-9.0, 9.0, 4001)


def _mixture_on_grid(means, sds, shares):
    """A mixture of normal conditionals on :data:`GRID`: the nodes' weights
    and each draw's weight ``p(k | theta)`` there."""
    parts = zip(means, sds, shares, strict=True)
    dens = np.array([p * stats.norm.pdf(GRID, m, s) for m, s, p in parts]).T
    total = dens.sum(axis=1)
    return total / total.sum(), dens / total[:, None]


def test_on_a_grid_it_is_the_delta_method_of_the_conditionals():
    """Three normal conditionals with shares: the delta method over the
    draws written with their exact moments and CDFs (mean: ``sqrt(sum s_k^2
    (m_k - m)^2)``; sd: the conditional mean squares; ends: the CDFs at the
    end over the density there, the density as the nodes path reads it: the
    quantile spacing over a quarter of the tail's mass either side)."""
    means, sds = np.array([-0.5, 0.2, 1.0]), np.array([0.8, 1.0, 0.6])
    shares = np.array([0.2, 0.5, 0.3])
    weights, given = _mixture_on_grid(means, sds, shares)
    summaries, se = mixture_errors(GRID[:, None], weights, given)
    m = shares @ means
    second = sds**2 + (means - m) ** 2
    var = shares @ second
    np.testing.assert_allclose(summaries[0, 0], m, atol=1e-6)
    np.testing.assert_allclose(summaries[1, 0], np.sqrt(var), rtol=1e-5)
    expected = [
        np.sqrt(np.sum(shares**2 * (means - m) ** 2)),
        np.sqrt(np.sum(shares**2 * (second - var) ** 2)) / (2 * np.sqrt(var)),
    ]
    cdf_grid = np.cumsum(weights) - 0.5 * weights  # mass midpoints
    for p, q in zip((0.025, 0.975), summaries[2:, 0], strict=True):
        cdf = stats.norm.cdf(q, means, sds)
        h = min(p, 1 - p) / 2
        spacing = np.diff(np.interp([p - h, p + h], cdf_grid, GRID))[0] / (2 * h)
        expected.append(np.sqrt(np.sum(shares**2 * (cdf - p) ** 2)) * spacing)
    np.testing.assert_allclose(se[:2, 0], expected[:2], rtol=1e-4)
    # the grid's CDF at an end is exact to half a cell's mass (about 1e-4,
    # against the draws' CDF differences of 0.01-0.1 there)
    np.testing.assert_allclose(se[2:, 0], expected[2:], rtol=0.02)


def test_the_errors_are_the_spread_of_other_draws_when_they_share_the_weight():
    """16 draws ``phi_k ~ N(0, 1)`` with conditionals ``N(phi_k / 2, 1)``,
    equally likely: over 400 sets of draws, each set's estimate of the
    posterior mean, sd and ends against the exact posterior (``N(0,
    1.25)``). Where no few draws carry the weight the delta method is right
    on average: the root mean square of the reported errors is 0.87-1.02 of
    the estimates' root mean square error (two runs of 400; reading low by
    a factor 2 would put it near 0.5). Each error read from 16 draws is
    itself noisy (the sd's influences are squares), so the rms of each
    estimate's deviation over its own error is larger, 1.1-2.1."""
    rng = np.random.default_rng(3)
    truth_sd = np.sqrt(1.25)
    truth = np.array([0.0, truth_sd, *stats.norm.ppf([0.025, 0.975], 0, truth_sd)])
    deviations, errors = [], []
    for _ in range(400):
        phi = rng.standard_normal(16)
        weights, given = _mixture_on_grid(phi / 2, np.ones(16), np.full(16, 1 / 16))
        summaries, se = mixture_errors(GRID[:, None], weights, given)
        deviations.append(summaries[:, 0] - truth)
        errors.append(se[:, 0])
    rmse = np.sqrt(np.mean(np.square(deviations), axis=0))
    reported = np.sqrt(np.mean(np.square(errors), axis=0))
    assert np.all((reported / rmse > 0.8) & (reported / rmse < 1.25)), reported / rmse


def test_the_warning_names_only_the_parameter_the_draws_disagree_about():
    """Two parameters on independent draws' conditionals: theta0's two
    draws sit 2 sds apart, theta1's agree. The warning names theta0 only;
    with both agreeing nothing is said and the errors vanish."""
    rng = np.random.default_rng(0)
    n = 20000
    labels = rng.integers(0, 2, n)
    theta = np.column_stack(
        [rng.normal(np.where(labels == 0, -1.0, 1.0), 1.0), rng.normal(0.0, 1.0, n)]
    )
    given = np.column_stack(
        [stats.norm.pdf(theta[:, 0], -1.0, 1.0), stats.norm.pdf(theta[:, 0], 1.0, 1.0)]
    )
    given /= given.sum(axis=1, keepdims=True)
    weights = np.full(n, 1.0 / n)
    with pytest.warns(UserWarning, match=r"disagree about E \(") as caught:
        error = mixture_error(theta, weights, given, names=["E", "k"])
    assert "k (" not in str(caught[0].message)
    assert not error.converged and error.n_draws == 2
    assert error.mean[0] > MIXTURE_TOL * np.std(theta[:, 0])
    assert error.mean[1] < 0.02 and error.ess == pytest.approx(2.0, rel=0.01)
    same = np.full((n, 2), 0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        error = mixture_error(theta, weights, same, names=["E", "k"])
    assert error.converged and np.allclose(error.mean, 0.0) and np.allclose(error.sd, 0)


def test_two_parameter_default_reports_and_warns_on_a_confounded_design():
    """The suite's a2 seed 0 (both parameters confounded with the
    discrepancy), the default (16 draws, MCMC): refits with random_state 0-4
    spread its sds by 0.33 posterior sds (docs/validity.rst, "Module 2's 16
    draws"); the fit says so, and its errors of the sd lie between a tenth
    and twice that."""
    from validation.cases import case_a2

    case = case_a2(0)
    cal = ModularBayesCalibrator(prior=case.prior, random_state=0)
    with pytest.warns(UserWarning, match="16 fixed draws"):
        cal.fit(
            case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim, y_sim=case.y_sim
        )
    relative = cal.theta_mcse_ / np.sqrt(np.diag(cal.theta_cov_))
    assert np.all(np.isfinite(relative))
    assert np.all((relative[1] > 0.1 * 0.33) & (relative[1] < 2 * 0.33)), relative
    assert cal.summary()["mcse_sd"].to_numpy() == pytest.approx(cal.theta_mcse_[1])
