"""The joint-posterior reference (``validation/joint_posterior.py``,
``validation/studies/joint_reference.py``).

Fast: the joint log density is the sum of its parts computed independently
(the priors by hand, the likelihood by the global model), the public
coordinates of module 2 reproduce ``fit_hyperposterior``'s draws, and the
chains and the conditional quadrature recover known answers. Slow: the
study on a1 seed 0 with short chains converges.
"""

import numpy as np
import pytest
from scipy import special, stats

from skmba.calibration._module2_posterior import (
    HyperparameterCoordinates,
    fit_hyperposterior,
)
from skmba.kernels import Gauss
from skmba.mcmc import ess_bulk
from skmba.priors._hyperprior import Hyperprior
from validation.joint_posterior import (
    Component,
    JointTarget,
    calibrator_log_posterior,
    conditional_posterior,
    fit_default,
    hyperparameter_space,
    rao_blackwell,
    sample_joint,
    sd_mcse,
)
from validation.studies import joint_reference
from validation.suite import registry


def _hand_log_prior(v, prior, response_ratio):
    """``log p(phi)`` in ``v`` for one design variable and two responses,
    from the hyperprior's definition: log-uniform roughness and noise
    (logits of their logs), half-normal sds (in logs) whose scale is
    ``sd_scale`` in the field data's terms, ``response_ratio`` times that in
    module 2's units, LKJ correlation."""
    rough, noise, log_sd, z = v[0], v[1:3], v[3:5], v[5]
    # a uniform variable's logit has the density s (1 - s), s = expit(v)
    s = special.expit(np.r_[rough, noise])
    value = np.sum(np.log(s * (1 - s)))
    sd = np.exp(log_sd)
    scale = prior.sd_scale * np.asarray(response_ratio)
    value += np.sum(stats.halfnorm(scale=scale).logpdf(sd) + log_sd)
    rho = z / np.sqrt(1 + z**2)  # the unit-row factor [[1, 0], [z, 1]]
    eta = prior.correlation_eta
    value += stats.beta(eta, eta).logpdf((1 + rho) / 2) - np.log(2)
    return value - 1.5 * np.log1p(z**2)  # d rho / d z


@pytest.fixture(scope="module")
def a1_fit():
    cal = fit_default(registry()["a1"].build(0), 0)
    log_post = calibrator_log_posterior(cal)
    space = hyperparameter_space(cal)
    return cal, log_post, space, JointTarget(log_post, space)


def test_joint_density_is_the_sum_of_its_parts(a1_fit):
    cal, log_post, space, target = a1_fit
    assert space.size == 6 and target.size == 7
    theta = cal.theta_mean_ * 1.02
    v = space.coordinates_of(Component(cal.global_model_.models[3])) + 0.1
    x = np.r_[log_post.to_u(theta), v]
    # log p(theta) in u: the prior of E times d E / d u, by central
    # differences (the constant log u_scale dropped, as by the calibrator's
    # own log density)
    u, h = log_post.to_u(theta), 1e-6
    slope = (log_post.from_u(u + h) - log_post.from_u(u - h))[0] / (2 * h)
    log_prior_u = float(cal.prior_.logpdf(theta[None, :])[0]) + np.log(
        slope / log_post.coordinates.u_scale[0]
    )
    theta_std = (theta - cal.theta_offset_) / cal.theta_scale_
    model = cal.global_model_.base.with_discrepancy(space.component(v))
    expected = log_prior_u + space.log_prior(v) + model.log_likelihood(theta_std)
    assert target(x) == pytest.approx(expected, rel=1e-10)
    # and log p(phi) in v is the hyperprior's, normalised
    ratio = cal.discrepancy_prior_units_.response_ratio
    assert space.log_prior(v) == pytest.approx(_hand_log_prior(v, Hyperprior(), ratio))
    # outside the prior of theta, the density is zero
    assert target(np.r_[log_post.to_u(np.array([1e6])), v]) == -np.inf


def test_coordinates_reproduce_the_draws_of_fit_hyperposterior():
    rng = np.random.default_rng(3)
    X = np.linspace(-1.7, 1.7, 14)[:, None]
    Y = np.column_stack([np.sin(2 * X[:, 0]), 0.1 * X[:, 0]])
    Y = Y + 0.05 * rng.normal(size=Y.shape)
    V = 0.01 * np.kron(np.ones((2, 2)) + np.eye(2), np.exp(-((X - X.T) ** 2)))
    kwargs = {"prior": Hyperprior(), "kernel": Gauss([1.0]), "regression": "linear"}
    draws = fit_hyperposterior(
        X, Y, V, n_draws=8, random_state=0, noise_mean=False, **kwargs
    )
    space = HyperparameterCoordinates.from_field_data(X, Y, V, **kwargs)
    assert draws.draw_coordinates.shape == (8, space.size)
    for v, comp in zip(draws.draw_coordinates, draws.components, strict=True):
        again = space.component(v)
        np.testing.assert_allclose(again.sigma2, comp.sigma2, rtol=1e-12)
        np.testing.assert_allclose(again.noise, comp.noise, rtol=1e-12)
        np.testing.assert_allclose(again.kernel_.theta, comp.kernel_.theta)
        assert again.regression == comp.regression == "linear"
        np.testing.assert_allclose(space.coordinates_of(comp), v, atol=1e-8)


def test_chains_recover_a_gaussian():
    mean = np.array([1.0, -2.0])
    sd = np.array([0.5, 3.0])
    cov = np.outer(sd, sd) * np.array([[1.0, 0.6], [0.6, 1.0]])
    prec = np.linalg.inv(cov)

    def log_density(x):
        d = x - mean
        return -0.5 * float(d @ prec @ d)

    starts = mean + np.random.default_rng(0).normal(size=(4, 2)) * 2 * sd
    out = sample_joint(
        log_density,
        starts,
        np.eye(2),
        n_samples=500,
        burn_in=1000,
        target_ess=2000,
        random_state=1,
    )
    assert out["runs"] >= 2 and np.all(out["ess"] >= 2000)
    assert np.all(out["rhat"] <= 1.01)
    samples = out["samples"]
    for j in range(2):
        x = samples[:, :, j]
        assert abs(x.mean() - mean[j]) < 4 * x.std() / np.sqrt(ess_bulk(x))
        assert abs(x.std() - sd[j]) < 4 * sd_mcse(x)


def test_sd_mcse_of_independent_draws():
    x = np.random.default_rng(0).normal(size=(4, 5000))
    # the sd of n normal draws has standard error sd / sqrt(2 n)
    assert sd_mcse(x) == pytest.approx(1 / np.sqrt(2 * x.size), rel=0.3)


class _Prior:
    def bounds(self, coverage):
        return np.array([[-10.0, 10.0]])

    def logpdf(self, t):
        return np.where(np.abs(t[:, 0]) <= 10, -np.log(20.0), -np.inf)


class _Scaler:
    def theta(self, t):
        return t


class _LogPosterior:
    prior, scaler = _Prior(), _Scaler()


class _Gaussian:
    """A likelihood of theta: N(center, 0.2^2)."""

    def __init__(self, center):
        self.center = center

    def log_likelihoods(self, t):
        return -0.5 * ((t[:, 0] - self.center) / 0.2) ** 2


class _Target:
    def model(self, v):
        return _Gaussian(v[0])


def test_conditional_quadrature_and_its_mixture():
    mean, var, draws = conditional_posterior(_LogPosterior(), _Gaussian(1.3), 400)
    assert mean == pytest.approx(1.3, abs=1e-10)
    assert var == pytest.approx(0.04, rel=1e-8)
    z = stats.norm.ppf((np.arange(400) + 0.5) / 400)
    np.testing.assert_allclose(draws, 1.3 + 0.2 * z, atol=2e-3)
    # theta given v ~ N(v, 0.04): the mixture over the draws of v has the
    # mean of v and the variance 0.04 + var(v)
    v = np.random.default_rng(0).normal(0.5, 1.0, size=(4, 50, 1))
    ref = rao_blackwell(_LogPosterior(), _Target(), v, n_draws=8, rng=0)
    assert ref["mean"][0] == pytest.approx(v.mean(), abs=1e-10)
    assert ref["sd"][0] == pytest.approx(np.sqrt(0.04 + v.var()), rel=1e-8)
    assert ref["lo"][0] < v.mean() < ref["hi"][0]
    assert 0 < ref["sd_mcse"][0] < 0.2 * ref["sd"][0]


@pytest.mark.slow
def test_study_on_a1_converges(record_property):
    record = joint_reference.run_case(
        "a1",
        0,
        n_refits=0,
        # Runs of 3000 draws, extended until ESS 400 and R-hat 1.01 (the
        # study's own rule): fixed lengths of 3000-6000 draws left R-hat at
        # 1.010-1.022 with today's emulator (ESS 470-530); this one stops
        # after 17300 draws per chain at R-hat 1.005, ESS 1124 (75 s).
        target_ess=400,
        n_samples=3000,
        max_samples=20000,
        burn_in=2000,
        n_conditionals=100,
    )
    assert record["n_samples"] < 20000, "the chains did not reach their target"
    assert np.all(record["rhat"] <= 1.01), record["rhat"]
    assert np.all(record["ess"] >= 400), record["ess"]
    row = next(joint_reference.rows([record]))
    record_property("sd_ratio", row["sd_ratio"])
    record_property("ratio_mcse", row["ratio_mcse"])
    record_property("mean_diff", row["mean_diff"])
    print(joint_reference.format_table([record]))
    # Convergence only: these short chains gave a reference sd of 1397 MPa
    # (sd ratio 1.15 +- 0.05) where the stored run's long ones give 1606
    # +- 40 (ratio 1.00), so no band on the ratio is justified here.
    assert np.isfinite(row["sd_ratio"]) and row["ratio_mcse"] > 0
