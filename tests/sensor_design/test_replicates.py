"""Pieces of the fast preposterior analysis (skmba.sensor_design._replicates) on their
own.

The designer end to end is tested in
``tests/sensor_design/test_estimator_sensor_design.py``.
"""

import warnings
from types import SimpleNamespace

import numpy as np
import pytest
from sklearn.exceptions import ConvergenceWarning

from skmba.priors._hyperprior import Hyperprior
from skmba.sensor_design._replicates import warn_replicate_problems
from skmba.sensor_design._scoring import criterion_value


def test_replicate_problems_are_counted_in_their_warnings():
    reps = [SimpleNamespace(n_unconverged=u, n_repaired=r) for u, r in [(2, 0), (1, 3)]]
    with pytest.warns(ConvergenceWarning, match="3 module-2 likelihood.* of the 2 "):
        with pytest.warns(UserWarning, match="3 posterior-integrated emulator"):
            warn_replicate_problems(reps)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_replicate_problems([SimpleNamespace(n_unconverged=0, n_repaired=0)])


@pytest.mark.parametrize("criterion", ["trace", "det", "max_eig"])
def test_a_stack_of_covariances_is_scored_as_each_one_alone(criterion):
    rng = np.random.default_rng(3)
    a = rng.normal(size=(4, 5, 3, 3))
    covs = a @ np.swapaxes(a, -1, -2)  # (4, 5) covariances of r = 3
    b = rng.normal(size=(3, 3))
    prior_cov = b @ b.T + np.eye(3)
    stacked = criterion_value(covs, prior_cov, criterion)
    assert stacked.shape == (4, 5)
    one_by_one = [
        [criterion_value(c, prior_cov, criterion) for c in row] for row in covs
    ]
    np.testing.assert_allclose(stacked, one_by_one, rtol=1e-12)
    assert isinstance(criterion_value(covs[0, 0], prior_cov, criterion), float)


@pytest.mark.parametrize("treatment", ["propagate", "plug-in"])
def test_the_designer_states_the_prior_in_the_calibrators_terms(treatment):
    # The designer draws and fits its synthetic data with the discrepancy
    # prior in the same terms as the calibrator that will fit the field data
    # at the planned inputs: the same PriorUnits and, for the plug-in, the
    # ranges carried to module 2's units with them. The response unit is
    # measured on each one's emulator, two fits whose searches stop within
    # GAIN_TOL (1e-3 nats) of the likelihood's maximum: they agree to 2e-6
    # to 1e-5 relative (the simulations' units differ by 5e-3 and 3e-2 here).
    from skmba import ModularBayesCalibrator
    from skmba.calibration._module1_emulator import Standardizer, fit_emulator
    from skmba.calibration._settings import CalibrationSettings
    from skmba.datasets import make_cantilever
    from skmba.priors._theta import check_prior
    from skmba.sensor_design._inputs import check_design_priors
    from skmba.sensor_design._replicates import MonteCarloContext

    data = make_cantilever(40, 12, random_state=0)
    template = ModularBayesCalibrator(
        prior=data.prior, random_state=0, discrepancy_uncertainty=treatment
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = template.fit(data.X_obs, data.y_obs, X_sim=data.X_sim,
                           theta_sim=data.theta_sim, y_sim=data.y_sim)  # fmt: skip
    settings = CalibrationSettings.from_params(template.get_params())
    scaler = Standardizer.from_simulations(data.X_sim, data.theta_sim, data.y_sim)
    emulator = fit_emulator(scaler, data.X_sim, data.theta_sim, data.y_sim,
                            **settings.emulator.kwargs(), random_state=0)  # fmt: skip
    if treatment == "propagate":
        priors = Hyperprior()
    else:
        priors = check_design_priors(None, None, "standardised", 1, 2, scaler.y_scale)
    ctx = MonteCarloContext.build(
        settings, emulator, scaler, data.X_obs, check_prior(data.prior), priors,
        (0, 1), fast=True, module2_max_iter=50,
    )  # fmt: skip
    units = cal.discrepancy_prior_units_
    if treatment == "propagate":
        got = ctx.hyperprior.units
        np.testing.assert_allclose(got.input_ratio, units.input_ratio, rtol=1e-12)
        np.testing.assert_allclose(got.response_ratio, units.response_ratio, rtol=1e-4)
    else:
        np.testing.assert_allclose(
            ctx.priors["roughness"][0], 0.1 * np.asarray(units.input_ratio) ** 2,
            rtol=1e-12,
        )  # fmt: skip
        np.testing.assert_allclose(
            ctx.priors["variance"][0], 1e-2 * np.asarray(units.response_ratio) ** 2,
            rtol=1e-4,
        )  # fmt: skip
