"""Helpers of the thesis replications, tests/calibration/test_estimator_calibration.py
and sensor design.

Physics note, measured here: with the physically correct beam formulas the
spring's effect on the tip displacement and on the energy are both the
fraction 3EI/(K L) of the model's value for a tip load, so a discrepancy
proportional to the model response is confounded with E: the fixed-support
model at E_eff = E*/(1 + 3E*I/(K* L)) = 67.9 GPa reproduces the data
exactly. The data identify E_eff (with I: the product E_eff I), not E*.

With the default module 2 (the discrepancy hyperparameters integrated out
under their documented prior) the posterior sits at E_eff, a few tenths of
a GPa wide at the thesis' noise, and ``fit`` raises a
NonIdentifiabilityWarning: E* lies outside the interval, as no method can
avoid on these data. The thesis' plug-in MBA (``discrepancy_uncertainty=
"plug-in"``) with the Table 6.2 floor on the discrepancy variance covered
E* only because the floor made the interval a few GPa wide. The
replications check the error of E against E* (a few percent, as the
thesis) and the interval against E_eff, the quantity the data identify.
"""

import warnings

import numpy as np

from skmba import ModularBayesCalibrator, PreposteriorDesigner
from skmba.datasets import make_cantilever


def fit(data, **params):
    params.setdefault("random_state", 0)
    cal = ModularBayesCalibrator(prior=data.prior, **params)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", category=Warning)
        return cal.fit(
            data.X_obs,
            data.y_obs,
            X_sim=data.X_sim,
            theta_sim=data.theta_sim,
            y_sim=data.y_sim,
        )


def effective_modulus(data):
    """E_eff of the beam with a spring: the fixed-support model's E that
    reproduces the real beam (tip load)."""
    beam = data.reality
    return beam.E / (1 + 3 * beam.E * beam.I / (beam.spring_stiffness * beam.length))


def relative_error(cal, data, k=0):
    return cal.theta_mean_[k] / data.theta_true[k] - 1


def credible_interval(cal, k=0):
    return np.quantile(cal.theta_samples_[:, k], [0.025, 0.975])


def inside(value, interval):
    return interval[0] < value < interval[1]


def coverage(cal, data, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.uniform(*data.X_bounds[0], size=(60, 1))
    mean, std = cal.predict(X, return_std=True)
    return (np.abs(mean - data.reality(X)) <= 1.96 * std).mean(axis=0)


def fit_E_and_I(seed, prior="uniform"):
    data = make_cantilever(
        n_simulations=170,
        n_observations=70,
        parameters=("E", "I"),
        prior=prior,
        random_state=seed,
    )
    return data, fit(data, n_samples=1000, burn_in=1000, n_chains=4, n_jobs=2)


def check_E_and_I_posterior(cal, data):
    """What every 4.7.3/4.7.7 posterior must show."""
    EI_draws = np.prod(cal.theta_samples_, axis=1)
    for k in range(2):  # along the ridge E I = c the prior decides
        assert inside(data.theta_true[k], credible_interval(cal, k))
    # The data identify E_eff I (the spring's 3 %), not E* I*.
    EI_eff = effective_modulus(data) * data.theta_true[1]
    assert inside(EI_eff, np.quantile(EI_draws, [0.025, 0.975]))
    corr = cal.theta_cov_[0, 1] / np.sqrt(np.prod(np.diag(cal.theta_cov_)))
    assert corr < -0.5  # only E I is identified: a negative ridge
    assert np.all(cal.rhat_ < 1.05)
    assert cal.theta_samples_.shape == (4000, 2)
    # Nine steps in ten are independence moves, accepted the more often the
    # closer their Student-t is to the posterior: no upper bound (a random
    # walk's 0.6 would fail a well-fitted proposal), but the chains must
    # move and give effective draws (measured on 4.7.3 seeds 0-3:
    # acceptance 0.36-0.61, bulk ESS 1004-1460 of 4000 draws).
    assert np.all(cal.acceptance_rate_ > 0.1)
    assert np.all(cal.ess_ > 400)
    return EI_draws.mean() / np.prod(data.theta_true) - 1


#: A calibrator without optimizer restarts, for the sensor designs.
FAST_CAL = ModularBayesCalibrator(n_restarts_optimizer=0)


def designer(prior, **params):
    params = {"calibrator": FAST_CAL, "n_design": 8, "n_mc": 6, **params}
    params.setdefault("random_state", 0)
    return PreposteriorDesigner(prior, **params)


def table_6_2_on_a_common_scale(data, informative=False):
    """Table 6.2 on the scale of the tip displacement, shared by all sensors.

    The thesis' ranking (tip displacement more informative than the mid- and
    quarter-span ones) needs the discrepancy prior on one scale for all
    responses: in the model every displacement is F/(EI) times a constant,
    so with priors relative to each response's own spread the three are
    equivalent. The informative prior of section 6.3 lowers the largest
    discrepancy variance of the rotation (C) to 0.1 of its own variance.
    """
    sd = data.y_sim.std(axis=0)
    high = np.full(5, 20.0 * sd[0] ** 2)
    if informative:
        high[2] = 0.1 * sd[2] ** 2
    return {
        "discrepancy_prior": {
            "variance": (0.01 * np.minimum(sd[0] ** 2, high), high),
            "mean": (-5.0 * sd[0], 5.0 * sd[0]),
        },
        "noise_prior": (0.0, 1e-4 * sd[0] ** 2),
        "prior_units": "user",
    }
