"""Module 2 with its uncertainty (skmba.calibration._module2_posterior) and REML."""

import numpy as np
import pytest
from scipy import special

from skmba.calibration._module2_plug_in import DiscrepancyFit
from skmba.calibration._module2_posterior import _Coordinates, fit_hyperposterior
from skmba.kernels import Gauss
from skmba.priors._hyperprior import Hyperprior


def _data(seed=0, n=14):
    rng = np.random.default_rng(seed)
    X = np.linspace(-1.7, 1.7, n)[:, None]
    Y = np.column_stack([np.sin(2 * X[:, 0]), 0.1 * X[:, 0]])
    Y = Y + 0.05 * rng.normal(size=Y.shape)
    V = 0.01 * np.kron(np.ones((2, 2)) + np.eye(2), np.exp(-((X - X.T) ** 2)))
    return X, Y, V


def _fit(X, Y, V):
    fit = DiscrepancyFit(
        Gauss([1.0], roughness_bounds=[(0.1, 9.0)]),
        X,
        Y,
        np.column_stack([np.ones(len(X)), X[:, 0]]),
        V,
        None,
        regression="linear",
        restricted=True,
        unit_scale=True,
        free_sd=True,
    )
    return fit


def test_restricted_likelihood_equals_dense_formula():
    X, Y, V = _data()
    fit = _fit(X, Y, V)
    p = np.array([np.log(1.3), np.log(0.002), np.log(0.004), -0.2, 0.8, 0.4])
    theta, lam, L = fit.unpack(p)
    n = len(X)
    R = fit.kernel.clone_with_theta(theta)(X)
    Vt = V + np.kron(L @ L.T, R) + np.kron(np.diag(lam), np.eye(n))
    Xr = np.kron(np.eye(2), fit.H)
    y = Y.T.ravel()
    Vi = np.linalg.inv(Vt)
    A = Xr.T @ Vi @ Xr
    r = y - Xr @ np.linalg.solve(A, Xr.T @ Vi @ y)
    reml = -0.5 * (
        (2 * n - 4) * np.log(2 * np.pi)
        + np.linalg.slogdet(Vt)[1]
        + np.linalg.slogdet(A)[1]
        + r @ Vi @ r
    )
    assert fit.evaluate(p, eval_gradient=False) == pytest.approx(reml, rel=1e-10)


def test_posterior_gradient_matches_finite_differences():
    X, Y, V = _data(1)
    coords = _Coordinates(_fit(X, Y, V), Hyperprior())
    v = np.random.default_rng(2).normal(size=coords.free.sum()) * 0.5
    _, grad = coords.log_posterior(v)
    h = 1e-6
    num = [
        (coords.log_posterior(v + e, False) - coords.log_posterior(v - e, False))
        / (2 * h)
        for e in np.eye(len(v)) * h
    ]
    np.testing.assert_allclose(grad, num, rtol=1e-4, atol=1e-5)


def test_draws_and_weights():
    X, Y, V = _data(3)
    draws = fit_hyperposterior(X, Y, V, prior=Hyperprior(), n_draws=16, random_state=0)
    assert len(draws.components) == 16
    assert special.logsumexp(draws.log_weights) == pytest.approx(0.0, abs=1e-12)
    for comp in draws.components:
        assert np.all(np.linalg.eigvalsh(comp.sigma2) >= 0)
        assert np.all((comp.noise >= 1e-6 * (1 - 1e-9)) & (comp.noise <= 1.0))
        assert 0.1 * (1 - 1e-9) <= comp.kernel_.roughness <= 9.0 * (1 + 1e-9)
    again = fit_hyperposterior(X, Y, V, prior=Hyperprior(), n_draws=16, random_state=0)
    np.testing.assert_array_equal(again.log_weights, draws.log_weights)


def test_the_noise_posterior_mean_is_the_same_for_any_n_jobs():
    """Its 512 evaluations run in joblib tasks, each draw on its own: the
    same importance weights, so the same mean and ESS, bit for bit."""
    X, Y, V = _data(3)
    kwargs = dict(prior=Hyperprior(), n_draws=16, random_state=0)
    one = fit_hyperposterior(X, Y, V, **kwargs)
    two = fit_hyperposterior(X, Y, V, n_jobs=2, **kwargs)
    assert one.noise_mean is not None and one.noise_ess > 1.0
    np.testing.assert_array_equal(two.noise_mean, one.noise_mean)
    assert two.noise_ess == one.noise_ess


@pytest.mark.slow
def test_restricted_noise_is_not_biased_low():
    # Pure noise around a linear trend, no discrepancy and no emulator
    # variance: the REML noise estimate averages near the truth, where plain
    # maximum likelihood is low by the factor (n - p) / n.
    ratios = []
    for seed in range(20):
        rng = np.random.default_rng(seed)
        X = np.linspace(-1.7, 1.7, 10)[:, None]
        Y = np.column_stack([0.5 * X[:, 0], -0.2 * X[:, 0]])
        Y = Y + 0.1 * rng.normal(size=Y.shape)
        draws = fit_hyperposterior(
            X,
            Y,
            np.zeros((20, 20)),
            prior=Hyperprior(sd_scale=1e-3),
            regression="linear",
            n_draws=2,
            random_state=seed,
        )
        ratios.append(draws.mode.noise / 0.01)
    assert 0.8 < np.mean(ratios) < 1.2


@pytest.mark.parametrize("seed", [0, 1])
def test_noise_posterior_mean_is_the_inverse_gamma_mean(seed):
    # Pure noise around a linear trend (p = 2 terms), a negligible
    # discrepancy and no emulator variance: under the log-uniform noise prior
    # and the restricted likelihood, each noise variance's posterior is
    # inverse-gamma((n - p) / 2, SS / 2), SS the least-squares residual sum of
    # squares, of mean SS / (n - p - 2). (The mode module 2 reports is that of
    # its unbounded coordinates, a logit of the log variance: lower still.)
    n, p = 20, 2
    rng = np.random.default_rng(seed)
    X = np.linspace(-1.7, 1.7, n)[:, None]
    Y = np.column_stack([0.5 * X[:, 0], -0.2 * X[:, 0]])
    Y = Y + np.array([0.1, 0.2]) * rng.normal(size=Y.shape)
    H = np.column_stack([np.ones(n), X[:, 0]])
    ss = np.sum((Y - H @ np.linalg.lstsq(H, Y, rcond=None)[0]) ** 2, axis=0)
    draws = fit_hyperposterior(
        X,
        Y,
        np.zeros((2 * n, 2 * n)),
        prior=Hyperprior(sd_scale=1e-3),
        regression="linear",
        n_draws=2,
        random_state=seed,
    )
    mean = ss / (n - p - 2)
    # Importance-sampling error: the posterior's coefficient of variation,
    # sqrt(2 / (n - p - 4)), over the square root of the effective size.
    se = mean * np.sqrt(2 / (n - p - 4)) / np.sqrt(draws.noise_ess)
    assert draws.noise_ess > 30
    assert np.all(np.abs(draws.noise_mean - mean) < 4 * se)
    assert np.all(draws.noise_mean > draws.mode.noise)


def test_normalised_prior_integrates_to_one():
    # E over the Student-t proposal of p / t is the integral of p: 1 when
    # the prior density in the unbounded coordinates is normalised.
    from scipy import stats

    X, Y, V = _data(4)
    fit = _fit(X, Y, V)
    coords = _Coordinates(fit, Hyperprior())
    m = int(coords.free.sum())
    mode = coords.to_v(fit.start())
    cov = np.diag(np.full(m, 2.0))
    t = stats.multivariate_t(mode, cov, df=5)
    v = t.rvs(40000, random_state=0)
    ratio = np.exp([coords.log_prior_normalised(x) for x in v] - t.logpdf(v))
    assert ratio.mean() == pytest.approx(1.0, abs=4 * ratio.std() / 200)


def test_prior_draws_follow_the_normalised_density():
    X, Y, V = _data(5)
    coords = _Coordinates(_fit(X, Y, V), Hyperprior())
    rng = np.random.default_rng(0)
    v = np.array([coords.prior_draw(rng) for _ in range(3000)])
    # The correlation entry (last coordinate, q = 2): rho = z / sqrt(1 + z^2)
    # is 2 Beta(eta, eta) - 1 with eta = 2.
    from scipy import stats

    rho = v[:, -1] / np.sqrt(1 + v[:, -1] ** 2)
    assert stats.kstest(0.5 * (rho + 1), stats.beta(2, 2).cdf).pvalue > 1e-3
