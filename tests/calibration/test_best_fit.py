"""The best-fit estimand (skmba/calibration/_best_fit.py).

Known answers: on the cantilever with an unmodelled support spring, reality
is the fixed-support model at the effective modulus E*/(1 + 3E*I/(K L))
(both responses), so the best fit is that modulus; identities: the
projection recovers the theta that made its target, the emulator's kriging
mean without the triangular solve equals the conditional one, and the
reality draws have module 4's moments. Coverage over seeds:
validation/studies/best_fit.py (docs/validity.rst).
"""

import re
import warnings
from dataclasses import replace

import numpy as np
import pytest

from skmba import ModularBayesCalibrator
from skmba.calibration._best_fit import (
    N_BATCHES,
    N_BEST_FIT_DRAWS,
    best_fit_draws,
    project,
    reality_draws,
)
from skmba.calibration._module4_prediction import conditional_moments
from skmba.datasets import make_cantilever
from skmba.exceptions import NonIdentifiabilityWarning


@pytest.fixture(scope="module")
def beam():
    return make_cantilever(random_state=0)


def _fit(data, **params):
    cal = ModularBayesCalibrator(prior=data.prior, random_state=0, **params)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cal.fit(
            data.X_obs,
            data.y_obs,
            X_sim=data.X_sim,
            theta_sim=data.theta_sim,
            y_sim=data.y_sim,
        )
    return cal, caught


@pytest.fixture(scope="module")
def fits(beam):
    return {
        estimand: _fit(beam, estimand=estimand) for estimand in ("physical", "best_fit")
    }


def _effective_modulus(data):
    b = data.reality
    return b.E / (1 + 3 * b.E * b.I / (b.spring_stiffness * b.length))


def _standardised(cal):
    """The fitted modules and the field inputs in standardised units."""
    modules = cal._modules
    Xs = modules.scaler.x(np.asarray(cal.X_obs_, dtype=float))
    return modules, Xs


def test_the_best_fit_is_the_effective_modulus(beam, fits):
    cal, caught = fits["best_fit"]
    physical, physical_caught = fits["physical"]
    target = _effective_modulus(beam)
    low, high = np.quantile(cal.theta_samples_[:, 0], [0.025, 0.975])
    assert low < target < high
    sd = np.sqrt(cal.theta_cov_[0, 0])
    assert abs(cal.theta_mean_[0] - target) < 3 * sd
    # What the data tell is sharper than what they cannot tell apart: the
    # physical E is confounded with the discrepancy (and fit says so).
    assert sd < 0.5 * np.sqrt(physical.theta_cov_[0, 0])
    assert any(
        issubclass(w.category, NonIdentifiabilityWarning) for w in physical_caught
    )
    assert not any(issubclass(w.category, NonIdentifiabilityWarning) for w in caught)
    # E* itself is far outside the best fit's interval: another estimand.
    assert beam.theta_true[0] > high + 10 * sd


def test_reality_and_module_3_are_the_physical_fits(fits):
    cal, _ = fits["best_fit"]
    physical, _ = fits["physical"]
    X = np.linspace(1.0, 10.0, 7)[:, None] * 1e3
    np.testing.assert_array_equal(cal.predict(X), physical.predict(X))
    np.testing.assert_array_equal(cal.theta_nodes_, physical.theta_nodes_)


def test_summary_history_and_errors_are_the_best_fits(fits):
    cal, _ = fits["best_fit"]
    summary = cal.summary()
    assert summary["mean"].iloc[0] == pytest.approx(cal.theta_mean_[0], rel=1e-12)
    row = cal.theta_history_.iloc[-1]
    assert row["theta0_mean"] == pytest.approx(cal.theta_mean_[0], rel=1e-12)
    # The draws are independent: the batch error of the mean is sd / sqrt(m)
    # up to the batches' own error (20 batches: a relative sd of about 16 %).
    sd = np.sqrt(cal.theta_cov_[0, 0])
    ratio = cal.theta_mcse_[0, 0] / (sd / np.sqrt(N_BEST_FIT_DRAWS))
    assert 0.5 < ratio < 1.5
    assert cal.theta_samples_.shape == (N_BEST_FIT_DRAWS, 1)


def test_partial_fit_records_the_best_fit(beam):
    cal = ModularBayesCalibrator(
        prior=beam.prior,
        estimand="best_fit",
        discrepancy_uncertainty="plug-in",
        random_state=0,
    )
    halves = np.array_split(np.arange(len(beam.X_obs)), 2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal.partial_fit(
            beam.X_obs[halves[0]],
            beam.y_obs[halves[0]],
            X_sim=beam.X_sim,
            theta_sim=beam.theta_sim,
            y_sim=beam.y_sim,
        )
        first_sd = np.sqrt(cal.theta_cov_[0, 0])
        cal.partial_fit(beam.X_obs[halves[1]], beam.y_obs[halves[1]])
    history = cal.theta_history_
    assert list(history["n_readings"]) == [len(halves[0]), len(beam.X_obs)]
    assert history["theta0_mean"].iloc[-1] == pytest.approx(cal.theta_mean_[0])
    assert history["theta0_sd"].iloc[0] == pytest.approx(first_sd)
    assert cal.estimand_ == "best_fit"


def test_same_seed_same_best_fit(beam, fits):
    cal, _ = fits["best_fit"]
    again, _ = _fit(beam, estimand="best_fit")
    np.testing.assert_array_equal(again.theta_samples_, cal.theta_samples_)


def test_projection_recovers_the_theta_of_its_target(fits):
    cal, _ = fits["best_fit"]
    modules, Xs = _standardised(cal)
    emulator = modules.emulator
    truth = np.array([[-0.8], [-0.1], [0.0], [0.3], [0.9]])
    targets = emulator.kriging_mean(Xs, truth)
    bounds = np.array([[-1.7, 1.7]])
    weights = np.full(len(Xs), 1.0 / len(Xs))
    start = np.full_like(truth, 1.5)
    found, converged = project(emulator, Xs, weights, targets, start, bounds)
    np.testing.assert_allclose(found, truth, atol=1e-6)
    assert np.all(converged)
    # A target beyond the range: the fit stops at its end.
    beyond = emulator.kriging_mean(Xs, np.array([[0.9]]))
    found, _ = project(emulator, Xs, weights, beyond, np.zeros((1, 1)), bounds * 0.5)
    assert found[0, 0] == pytest.approx(0.85)


def test_kriging_mean_is_the_conditional_mean(fits):
    cal, _ = fits["best_fit"]
    modules, Xs = _standardised(cal)
    thetas = np.array([[-0.4], [0.2], [1.1]])
    fast = modules.emulator.kriging_mean(Xs, thetas)
    dense = modules.emulator.conditional(Xs, thetas).mean()
    # The two orders of the triangular solves round differently: measured
    # 1e-10 of the standardised responses here (the correlation's condition
    # number is 3.9e9, a worst case of 9e-7); 1e-8 leaves two decades.
    np.testing.assert_allclose(fast, dense, rtol=0, atol=1e-8)


def testreality_draws_have_module_4_moments(fits):
    cal, _ = fits["best_fit"]
    modules, Xs = _standardised(cal)
    scaler, rule = modules.scaler, modules.module3.rule
    entry = int(np.argmax(rule.weights))
    one = replace(
        rule,
        thetas=scaler.theta(rule.thetas[[entry]]),
        weights=np.ones(1),
        draws=None if rule.draws is None else rule.draws[[entry]],
    )
    mixture = modules.module3.log_post.model
    model = mixture.base if one.draws is None else mixture.models[one.draws[0]]
    mean, var = conditional_moments(model, one.thetas[0], Xs, "reality")
    draws, picked = reality_draws(mixture, one, Xs, 4000, np.random.default_rng(0))
    assert np.all(picked == 0)
    se = np.sqrt(var / len(draws))
    assert np.max(np.abs(draws.mean(axis=0) - mean) / se) < 4.5
    ratio = draws.var(axis=0) / var
    assert np.all((ratio > 0.85) & (ratio < 1.15))


def test_best_fit_draws_batches(fits):
    cal, _ = fits["best_fit"]
    modules, Xs = _standardised(cal)
    scaler, rule = modules.scaler, modules.module3.rule
    theta_sim = scaler.theta(cal.theta_sim_)
    bounds = np.column_stack([theta_sim.min(axis=0), theta_sim.max(axis=0)])
    best = best_fit_draws(
        modules.module3.log_post.model,
        replace(rule, thetas=scaler.theta(rule.thetas)),
        modules.emulator,
        Xs,
        np.ones(len(Xs)),
        bounds,
        random_state=0,
    )
    assert best.batch_estimates.shape == (N_BATCHES, 4, 1)
    assert np.all(best.at_bound == 0.0)
    # Another seed than the fit's: the same posterior within the errors.
    user = best.samples * scaler.theta_scale + scaler.theta_offset
    error = np.hypot(cal.theta_mcse_[0, 0], best.mcse[0, 0] * scaler.theta_scale[0])
    assert abs(user.mean() - cal.theta_mean_[0]) < 4 * error


def test_a_best_fit_that_is_not_unique_warns():
    # Section 4.7.3: the tip displacement and energy depend on E I only.
    data = make_cantilever(
        n_simulations=170, n_observations=70, parameters=("E", "I"), random_state=0
    )
    short = dict(n_samples=300, burn_in=200, target_ess=None)
    _, caught = _fit(
        data, estimand="best_fit", discrepancy_uncertainty="plug-in", **short
    )
    said = [str(w.message) for w in caught if "not unique" in str(w.message)]
    assert len(said) == 1
    assert re.search(r"\(theta0 [+-]0\.\d+, theta1 [+-]0\.\d+\)", said[0])


def test_kriging_mean_of_a_kernel_that_is_not_a_product():
    from sklearn.gaussian_process.kernels import Matern

    data = make_cantilever(random_state=0)
    cal, _ = _fit(
        data,
        model_kernel=Matern(length_scale=[1.0, 1.0], nu=2.5),
        discrepancy_uncertainty="plug-in",
    )
    modules, Xs = _standardised(cal)
    thetas = np.array([[-0.4], [0.7]])
    fast = modules.emulator.kriging_mean(Xs, thetas)
    dense = modules.emulator.conditional(Xs, thetas).mean()
    np.testing.assert_allclose(fast, dense, rtol=0, atol=1e-8)


@pytest.mark.slow
def test_the_best_fit_hardly_depends_on_the_discrepancy_prior(fits):
    # The user guide's claim: on this beam prior_sensitivity() moves the best
    # fit's sd by about 2 % (9.44-9.62 MPa) and its mean by 0.4 MPa, where
    # the physical interval's width moves several-fold with the roughness.
    table = fits["best_fit"][0].prior_sensitivity()
    rows = [i for i in table.index if not str(i).startswith("union")]
    sd = table.loc[rows, "sd"].to_numpy()
    assert sd.max() / sd.min() < 1.1
    mean = table.loc[rows, "mean"].to_numpy()
    assert np.ptp(mean) < 0.2 * sd.min()
    physical = fits["physical"][0].prior_sensitivity()
    width = physical.loc[[i for i in physical.index if "union" not in str(i)], "sd"]
    assert width.max() / width.min() > 2.0


def test_a_bad_estimand_is_refused(beam):
    cal = ModularBayesCalibrator(prior=beam.prior, estimand="best-fit")
    with pytest.raises(ValueError, match="estimand"):
        cal.fit(
            beam.X_obs,
            beam.y_obs,
            X_sim=beam.X_sim,
            theta_sim=beam.theta_sim,
            y_sim=beam.y_sim,
        )
