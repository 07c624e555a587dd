"""ModularBayesCalibrator: API, input validation, persistence, memory checks.

The replications of the thesis' section 4.7 are in tests/thesis/.
"""

import io
import pickle
import re
import sys
import types
import warnings

import joblib
import numpy as np
import pytest
from scipy import stats
from sklearn.base import clone
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process.kernels import RBF, ConstantKernel
from sklearn.metrics import r2_score
from thesis._helpers import fit, relative_error

import skmba._core.linalg as linalg_module
import skmba.calibration._module2_plug_in as discrepancy_module
import skmba.calibration._module2_prior_integral as integration_module
import skmba.calibration._module3_fit as module3_module
import skmba.calibration._module3_likelihood as global_model_module
import skmba.calibration._module3_posterior as posterior_module
import skmba.calibration._module3_quadrature as quadrature_module
import skmba.calibration._module4_prediction as prediction_module
from skmba import ModularBayesCalibrator
from skmba.calibration._module3_identifiability import IDENTIFIABILITY_THRESHOLD
from skmba.datasets import make_cantilever
from skmba.exceptions import FieldDataWarning, NonIdentifiabilityWarning
from skmba.mcmc._stopping import EssTarget


@pytest.mark.parametrize("treatment", ["plug-in", "propagate"])
def test_unevaluable_likelihood_names_the_cause(monkeypatch, treatment):
    def fail(self, theta, conditional=None):
        raise posterior_module.FactorizationError("S(theta) is not positive definite.")

    def singular(self, S, Z, noise_floor=None):
        return np.full(len(S), -np.inf)  # no Schur complement factors

    # Every theta and every draw of the mixture fails; the single model's
    # factorisation says why.
    monkeypatch.setattr(global_model_module.GlobalModel, "whiten", fail)
    monkeypatch.setattr(
        global_model_module.GlobalModel, "stacked_log_likelihoods", singular
    )
    with pytest.raises(
        posterior_module.FactorizationError,
        match=r"could not be evaluated at any quadrature node \(at theta=.*S\(theta\) "
        r"is not positive definite.*raise emulator_alpha, or remove responses",
    ) as info:
        fit(make_cantilever(30, 10, random_state=0), discrepancy_uncertainty=treatment)
    assert isinstance(info.value.__cause__, posterior_module.FactorizationError)


def test_log_posterior_is_prior_plus_schur_likelihood():
    data = make_cantilever(random_state=4)
    cal = fit(data)
    theta = np.array([[60e3], [70e3], [150e3]])
    values = cal.log_posterior(theta)
    assert values[2] == -np.inf  # outside the uniform prior
    expected = cal.prior_.logpdf(theta[:1]) + cal.global_model_.log_likelihood(
        (theta[0] - cal.theta_offset_) / cal.theta_scale_
    )
    assert values[0] == pytest.approx(float(expected[0]), rel=1e-12)
    assert cal.log_posterior(theta[1]) == pytest.approx(values[1])
    # a list prior names no parameters: a table's columns are taken in order
    pd = pytest.importorskip("pandas")
    table = pd.DataFrame(theta, columns=["Young's modulus"])
    np.testing.assert_array_equal(cal.log_posterior(table), values)
    with pytest.raises(ValueError, match="theta has 2 values"):
        cal.log_posterior([1.0, 2.0])


def test_simulator_runs_on_a_latin_hypercube_and_fit_is_reproducible():
    data = make_cantilever(random_state=0)
    params = dict(
        simulator=data.simulator, prior=data.prior, n_simulations=40, random_state=3
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = ModularBayesCalibrator(**params).fit(data.X_obs, data.y_obs)
        b = ModularBayesCalibrator(**params).fit(data.X_obs, data.y_obs)
    assert a.X_sim_.shape == (40, 1) and a.y_sim_.shape == (40, 2)
    lo, hi = data.prior[0].support()
    assert np.all((a.theta_sim_ >= lo) & (a.theta_sim_ <= hi))
    np.testing.assert_array_equal(a.theta_samples_, b.theta_samples_)
    assert abs(relative_error(a, data)) < 0.05


def test_clone_pickle_and_units():
    data = make_cantilever(random_state=1)
    cal = fit(data)
    twin = clone(cal)
    assert twin.get_params()["prior"] is not None and not hasattr(twin, "theta_mean_")
    back = pickle.loads(pickle.dumps(cal))
    X = data.X_obs[:4]
    np.testing.assert_array_equal(back.predict(X), cal.predict(X))
    # user units: sigma2 in squared response units, noise too
    assert cal.discrepancy_sigma2_.shape == (2, 2)
    assert cal.noise_.shape == (2,)
    assert cal.theta_mean_.shape == (1,) and cal.theta_cov_.shape == (1, 1)
    assert 20e3 < cal.theta_mean_[0] < 100e3


# ------------------------------------------------------------------ bad input
BAD = make_cantilever(n_simulations=30, n_observations=10, random_state=0)
SIMS = dict(X_sim=BAD.X_sim, theta_sim=BAD.theta_sim, y_sim=BAD.y_sim)


def with_value(array, index, value):
    out = np.array(array, dtype=float)
    out[index] = value
    return out


def failing_simulator(X, theta):
    out = X * theta
    if np.any(X > 5000):
        raise ZeroDivisionError("mesh collapsed")
    return np.hstack([out, out**2])


def broken_simulator(X, theta):
    raise ZeroDivisionError("mesh collapsed")


def mostly_nan_simulator(X, theta):
    out = np.hstack([X * theta, X])
    out[2:] = np.nan
    return out


def batch_only_simulator(X, theta):
    if len(X) > 1:
        raise MemoryError("the solver cannot hold the batch")
    return np.hstack([X * theta, X])


def wrong_shape_simulator(X, theta):
    return X * theta


def nan_simulator(X, theta):
    out = np.hstack([X * theta, X])
    out[0, 0] = np.nan
    return out


def text_simulator(X, theta):
    return [["converged", "ok"]] * len(X)


def case(case_id, exception, match, *, params=None, X=None, y=None, sims=SIMS):
    return pytest.param(params or {}, X, y, sims, exception, match, id=case_id)


def sims_with(**changes):
    return {**SIMS, **changes}


def first_rows(n):
    return {name: value[:n] for name, value in SIMS.items()}


UNIFORM = stats.uniform(20e3, 80e3)
TWO_PARAMETERS = dict(prior=None)
THETA_2 = np.hstack([BAD.theta_sim, BAD.theta_sim[::-1]])

PLUG_IN = "plug-in"

BAD_INPUT = [
    # NaN and inf, with the rows to drop
    case(
        "X-nan",
        ValueError,
        r"Input X contains NaN or inf in rows \[0\]: the inputs of every "
        r"observation must be known; remove these rows of X and y",
        X=with_value(BAD.X_obs, (0, 0), np.nan),
    ),
    case(
        "X-inf",
        ValueError,
        r"Input X contains NaN or inf in rows \[4\]",
        X=with_value(BAD.X_obs, (4, 0), np.inf),
    ),
    case(
        "y-minus-inf",
        ValueError,
        r"Input y contains inf in rows \[0\]: an infinite reading is not a "
        r"measurement. Set it to NaN \(not measured",
        y=with_value(BAD.y_obs, (0, 0), -np.inf),
    ),
    case(
        "y-row-without-any-reading",
        UserWarning,
        r"1 row\(s\) of y have no measured response \(all NaN\), rows \[3\]: "
        r"they are left out, with their rows of X",
        y=with_value(BAD.y_obs, (3, slice(None)), np.nan),
    ),
    case(
        "y-response-never-measured",
        ValueError,
        r"response 1 \(column 1\) of y is measured 0 time\(s\): module 2 needs "
        r"more measurements of each response than the 1 term\(s\) of "
        r"discrepancy_regression='constant'. Remove the response",
        y=with_value(BAD.y_obs, (slice(None), 1), np.nan),
    ),
    case(
        "y-response-measured-too-rarely-for-the-regression",
        ValueError,
        r"response 0 \(column 0\) of y is measured 2 time\(s\): .* than the 2 "
        r"term\(s\) of discrepancy_regression='linear'",
        params=dict(discrepancy_regression="linear"),
        y=with_value(BAD.y_obs, (slice(2, None), 0), np.nan),
    ),
    case(
        "X_sim-nan",
        ValueError,
        r"X_sim contains NaN or inf in rows \[2\]: the inputs of every run must "
        r"be known; drop these rows from X_sim, theta_sim and y_sim alike \(a "
        r"failed run is a NaN row of y_sim only\)",
        sims=sims_with(X_sim=with_value(BAD.X_sim, (2, 0), np.nan)),
    ),
    case(
        "y_sim-nan-row-left-out",
        UserWarning,
        r"1 row\(s\) of y_sim hold NaN or inf \(1x non-finite output \[nan, .*\]\): "
        r"the 29 successful runs are used and the failed ones are listed in "
        r"simulation_failures_",
        sims=sims_with(y_sim=with_value(BAD.y_sim, (7, 0), np.nan)),
    ),
    case(
        "theta_sim-inf",
        ValueError,
        r"theta_sim contains NaN or inf in rows \[5\]",
        sims=sims_with(theta_sim=with_value(BAD.theta_sim, (5, 0), np.inf)),
    ),
    case(
        "theta_sim-nan-without-prior",
        ValueError,
        r"theta_sim contains NaN or inf in rows \[5\]",
        params=dict(prior=None),
        sims=sims_with(theta_sim=with_value(BAD.theta_sim, (5, 0), np.nan)),
    ),
    case(
        "y_sim-all-nan-without-prior",
        ValueError,
        r"0 simulations after 30 row\(s\) of y_sim hold NaN or inf \(30x "
        r"non-finite output \[nan, nan\]\) are too few to fit an emulator: "
        r"regression='constant' on d \+ r = 2 inputs needs at least 3",
        params=dict(prior=None),
        sims=sims_with(y_sim=np.full_like(BAD.y_sim, np.nan)),
    ),
    # shapes and dimensions
    case(
        "X-1d",
        ValueError,
        r"X must be a 2-D array of shape \(n_samples, n_features\), got 1-D .* "
        r"use X.reshape\(-1, 1\)",
        X=BAD.X_obs[:, 0],
    ),
    case(
        "X-3d",
        ValueError,
        r"X must be a 2-D array .* got 3-D",
        X=BAD.X_obs[:, :, None],
    ),
    case(
        "y-3d",
        ValueError,
        r"y must be an array of shape \(n_samples,\) or \(n_samples, q\)",
        y=BAD.y_obs[:, :, None],
    ),
    case(
        "X-y-rows",
        ValueError,
        r"X and y have 5 and 10 rows: y must hold one row",
        X=BAD.X_obs[:5],
    ),
    case(
        "X_sim-1d",
        ValueError,
        r"X_sim must be a 2-D array .* use X_sim.reshape\(-1, 1\)",
        sims=sims_with(X_sim=BAD.X_sim[:, 0]),
    ),
    case(
        "theta_sim-1d",
        ValueError,
        r"theta_sim must be a 2-D array of shape \(n_simulations, r\), got 1-D "
        r".* use theta_sim.reshape\(-1, 1\)",
        sims=sims_with(theta_sim=BAD.theta_sim[:, 0]),
    ),
    case(
        "y_sim-3d",
        ValueError,
        r"y_sim must be an array of shape \(n_simulations, q\)",
        sims=sims_with(y_sim=BAD.y_sim[:, :, None]),
    ),
    case(
        "simulation-rows",
        ValueError,
        r"X_sim, theta_sim and y_sim must have the same number of rows, got 30, "
        r"30 and 29",
        sims=sims_with(y_sim=BAD.y_sim[:-1]),
    ),
    case(
        "X_sim-columns",
        ValueError,
        r"X_sim has 2 columns but X has 1: the simulations must use the same",
        sims=sims_with(X_sim=np.hstack([BAD.X_sim, BAD.X_sim])),
    ),
    case(
        "y_sim-responses",
        ValueError,
        r"y_sim has 2 responses but y has 1: the simulated and observed",
        y=BAD.y_obs[:, :1],
    ),
    case(
        "theta_sim-columns",
        ValueError,
        r"prior has 1 distribution\(s\) but there are 2 calibration parameters; "
        r"give one distribution per parameter",
        sims=sims_with(theta_sim=THETA_2),
    ),
    case(
        "X_sim-alone",
        ValueError,
        r"Pass X_sim, theta_sim and y_sim together",
        sims={"X_sim": BAD.X_sim},
    ),
    case("no-simulations", ValueError, r"No simulations: pass a simulator", sims={}),
    # empty and single-sample data
    case(
        "empty-field-data",
        ValueError,
        r"X has 0 sample\(s\) \(n_samples=0\): module 2 needs more field",
        X=BAD.X_obs[:0],
        y=BAD.y_obs[:0],
    ),
    case(
        "one-observation",
        ValueError,
        r"X has 1 sample\(s\) \(n_samples=1\).* Add observations",
        X=BAD.X_obs[:1],
        y=BAD.y_obs[:1],
    ),
    case(
        "two-observations-linear-discrepancy",
        ValueError,
        r"n_samples=2\): .* 2 term\(s\) of discrepancy_regression='linear'",
        params=dict(discrepancy_regression="linear"),
        X=BAD.X_obs[:2],
        y=BAD.y_obs[:2],
    ),
    case(
        "empty-simulations",
        ValueError,
        r"X_sim, theta_sim and y_sim are empty \(0 simulations\)",
        sims=first_rows(0),
    ),
    case(
        "one-simulation",
        ValueError,
        r"1 simulations are too few to fit an emulator: .* at least 3; provide "
        r"about 10 per input \(20\)",
        sims=first_rows(1),
    ),
    case(
        "too-few-simulations-for-quadratic-regression",
        ValueError,
        r"6 simulations are too few .* regression='quadratic' on d \+ r = 2 "
        r"inputs needs at least 7",
        params=dict(regression="quadratic"),
        sims=first_rows(6),
    ),
    # constant inputs or responses
    case(
        "constant-theta_sim",
        ValueError,
        r"theta_sim column\(s\) \[0\] are constant .* Vary each parameter",
        sims=sims_with(theta_sim=np.full_like(BAD.theta_sim, 50e3)),
    ),
    case(
        "constant-simulated-response",
        ValueError,
        r"y_sim column\(s\) \[1\] are constant over the simulations: .* Remove "
        r"these responses from y and y_sim",
        sims=sims_with(y_sim=with_value(BAD.y_sim, (slice(None), 1), 3.0)),
    ),
    case(
        "constant-X_sim",
        UserWarning,
        r"observation input\(s\) lie outside the range of the simulations \(widened",
        sims=sims_with(X_sim=np.full_like(BAD.X_sim, 5000.0)),
    ),
    # unknown option strings
    *(
        case(
            f"unknown-{name}",
            ValueError,
            rf"{name}='bogus' is not supported; use one of",
            params={name: "bogus"},
        )
        for name in (
            "integration",
            "sampler",
            "module2_variance",
            "discrepancy_optimizer",
            "regression",
            "discrepancy_regression",
        )
    ),
    # discrepancy_prior: the prior (propagate) or the ranges (plug-in) of module 2
    case(
        "hyperprior-not-a-dict",
        TypeError,
        r"discrepancy_prior must be None or a dict with keys among "
        r"\['correlation_eta', 'noise', 'roughness', 'sd_scale'\], got list",
        params=dict(discrepancy_prior=[0.5]),
    ),
    case(
        "hyperprior-plug-in-key",
        ValueError,
        r"discrepancy_prior has unknown keys \['variance'\] for "
        r"discrepancy_uncertainty='propagate'.*belong to "
        r"discrepancy_uncertainty='plug-in'",
        params=dict(discrepancy_prior={"variance": (0.01, 20.0)}),
    ),
    case(
        "hyperprior-negative-sd-scale",
        ValueError,
        r"discrepancy_prior\['sd_scale'\] must be a positive number",
        params=dict(discrepancy_prior={"sd_scale": -0.5}),
    ),
    case(
        "hyperprior-sd-scale-per-response",
        ValueError,
        r"discrepancy_prior\['sd_scale'\] has 3 values for 2 responses",
        params=dict(discrepancy_prior={"sd_scale": [0.5, 0.5, 0.1]}),
    ),
    case(
        "hyperprior-noise-reversed",
        ValueError,
        r"discrepancy_prior\['noise'\] must be a range \(low, high\) with "
        r"0 < low < high",
        params=dict(discrepancy_prior={"noise": (1.0, 1e-6)}),
    ),
    case(
        "discrepancy-uncertainty-unknown",
        ValueError,
        r"discrepancy_uncertainty",
        params=dict(discrepancy_uncertainty="marginal"),
    ),
    case(
        "discrepancy_prior-not-a-dict",
        TypeError,
        r"discrepancy_prior must be None or a dict with keys among \['roughness', "
        r"'variance'\], got list",
        params=dict(discrepancy_uncertainty=PLUG_IN, discrepancy_prior=[0.01, 20]),
    ),
    case(
        "discrepancy_prior-unknown-key",
        ValueError,
        r"discrepancy_prior has unknown keys \['mean'\]; the calibrator bounds only",
        params=dict(
            discrepancy_uncertainty=PLUG_IN, discrepancy_prior={"mean": (-5, 5)}
        ),
    ),
    case(
        "discrepancy_prior-variance-reversed",
        ValueError,
        r"discrepancy_prior\['variance'\] needs low <= high",
        params=dict(
            discrepancy_uncertainty=PLUG_IN, discrepancy_prior={"variance": (1.0, 0.1)}
        ),
    ),
    case(
        "discrepancy_prior-variance-negative",
        ValueError,
        r"discrepancy_prior\['variance'\] must be >= 0.0",
        params=dict(
            discrepancy_uncertainty=PLUG_IN, discrepancy_prior={"variance": (-1.0, 1.0)}
        ),
    ),
    case(
        "discrepancy_prior-variance-wrong-length",
        ValueError,
        r"discrepancy_prior\['variance'\] must be a pair \(low, high\) of numbers "
        r"or of arrays of length 2",
        params=dict(
            discrepancy_uncertainty=PLUG_IN,
            discrepancy_prior={"variance": (0.01, [1.0, 2.0, 3.0])},
        ),
    ),
    case(
        "discrepancy_prior-roughness-zero",
        ValueError,
        r"discrepancy_prior\['roughness'\] must be > 0, .* use None to keep the "
        r"kernel's own roughness_bounds",
        params=dict(
            discrepancy_uncertainty=PLUG_IN, discrepancy_prior={"roughness": (0.0, 9.0)}
        ),
    ),
    case(
        "discrepancy_prior-roughness-on-a-kernel-without-it",
        TypeError,
        r"discrepancy_prior\['roughness'\] needs a discrepancy kernel with a "
        r"'roughness' hyperparameter",
        params=dict(
            discrepancy_uncertainty=PLUG_IN,
            discrepancy_kernel=RBF(),
            discrepancy_prior={"roughness": (0.1, 9.0)},  # explicit: needs one
        ),
    ),
    case(
        "quadrature-integration-two-parameters",
        ValueError,
        r"integration='quadrature' needs one parameter, the prior has 2; use "
        r"integration='qmc'",
        params=dict(prior=None, integration="quadrature"),
        sims=sims_with(theta_sim=THETA_2),
    ),
    case(
        "quadrature-sampler-two-parameters",
        ValueError,
        r"sampler='quadrature' needs one parameter, the prior has 2; use "
        r"sampler='mcmc'",
        params=dict(prior=None, sampler="quadrature"),
        sims=sims_with(theta_sim=THETA_2),
    ),
    # negative, zero or non-integer sizes
    *(
        case(
            f"{name}={value!r}",
            exception,
            match,
            params={name: value},
        )
        for name, value, exception, match in (
            ("n_chains", 0, ValueError, r"n_chains must be a positive integer, got 0"),
            ("n_chains", True, ValueError, r"n_chains must be a positive integer"),
            ("n_samples", -5, ValueError, r"n_samples must be a positive integer"),
            ("burn_in", -1, ValueError, r"burn_in must be a non-negative integer"),
            ("n_integration_nodes", 0, ValueError, r"n_integration_nodes must be "),
            ("n_integration_nodes", 1, ValueError, r"an integer >= 2 or None, got 1"),
            ("n_jobs", 0, ValueError, r"n_jobs must be None, a positive integer"),
            ("n_jobs", 1.5, ValueError, r"n_jobs must be None, .* got 1.5"),
            ("n_restarts_optimizer", -1, ValueError, r"n_restarts_optimizer must "),
            ("verbose", -1, ValueError, r"verbose must be a non-negative integer"),
            ("emulator_alpha", -1.0, ValueError, r"emulator_alpha must be a finite"),
            ("emulator_alpha", "x", ValueError, r"emulator_alpha must be .* got 'x'"),
            ("noise", "yes", TypeError, r"noise must be True or False"),
            ("model_kernel", "Gauss", TypeError, r"model_kernel must be an sklearn"),
        )
    ),
    case(
        "n_simulations=0",
        ValueError,
        r"n_simulations must be an integer >= 2 or None, got 0",
        params=dict(simulator=failing_simulator, n_simulations=0),
        sims={},
    ),
    case(
        "n_simulations-too-few-checked-before-running",
        ValueError,
        r"2 simulations are too few to fit an emulator",
        params=dict(simulator=failing_simulator, n_simulations=2),
        sims={},
    ),
    # priors
    case(
        "prior-two-parameters",
        ValueError,
        r"prior has 2 distribution\(s\) but there are 1 calibration parameters",
        params=dict(prior=[UNIFORM, UNIFORM]),
    ),
    case(
        "prior-multivariate-wrong-dimension",
        ValueError,
        r"prior is over 2 parameter\(s\) but there are 1 calibration parameters; "
        r"give a prior of dimension 1",
        params=dict(prior=stats.multivariate_normal([5e4, 1.0], np.eye(2))),
    ),
    case(
        "prior-zero-width",
        ValueError,
        r"prior\[0\], uniform\(loc=1, scale=0\), has zero width .* give its prior "
        r"a positive width",
        params=dict(prior=[stats.uniform(1, 0)]),
    ),
    case(
        "prior-normal-zero-width",
        ValueError,
        r"prior, norm\(loc=50000, scale=0\), has zero width",
        params=dict(prior=stats.norm(50e3, 0.0)),
    ),
    case(
        "prior-string",
        TypeError,
        r"prior of type str has no logpdf method; prior must be a list of frozen",
        params=dict(prior="uniform"),
    ),
    case(
        "prior-unfrozen",
        TypeError,
        r"prior\[0\] is the unfrozen distribution scipy.stats.norm; freeze it",
        params=dict(prior=[stats.norm]),
    ),
    case(
        "prior-misses-the-simulations",
        ValueError,
        r"The prior puts 0.00% of its mass on the simulated range of theta_sim "
        r"\(theta\[0\] in \[2.096e\+04, 9.83e\+04\]\): .* correct the prior",
        params=dict(prior=[stats.uniform(200e3, 100e3)]),
    ),
    case(
        "prior-wider-than-the-simulations",
        UserWarning,
        r"4\d\.\d% of the prior mass lies outside the simulated range of "
        r"theta_sim .* Extend the simulations to cover the prior, or narrow",
        params=dict(prior=[stats.norm(50e3, 50e3)]),
    ),
    case(
        "observations-outside-the-simulations",
        UserWarning,
        r"5 observation input\(s\) lie outside the range of the simulations "
        r"\(widened by one mean spacing of the runs\), in the design variable\(s\) "
        r"column 0: 5 at \[.*\] against simulations over \[.*\]: the emulator "
        r"extrapolates there. Extend the simulation design",
        X=BAD.X_obs * 2.0,
    ),
    case(
        "units-mix-up",
        FieldDataWarning,
        r"The observations of response 1 \(column 1 of y\) are typically \d+ "
        r"times the size of its simulations over the same inputs .*: other "
        r"units \(m against mm, strain against microstrain, kN against N\)\?",
        y=BAD.y_obs * [1.0, 1000.0],
    ),
    case(
        "small-design",
        UserWarning,
        r"15 simulations for d \+ r = 2 emulator inputs are fewer than the rule "
        r"of thumb of 10 per input \(20; Loeppky, Sacks and Welch 2009\)",
        sims=first_rows(15),
    ),
    *(
        case(
            f"scaled-discrepancy-kernel-{treatment}",
            ValueError,
            r"The discrepancy_kernel must be a correlation with unit diagonal .* "
            r"in \[2, 2\]. Remove ConstantKernel",
            params=dict(
                discrepancy_kernel=ConstantKernel(2.0) * RBF(),
                discrepancy_uncertainty=treatment,
            ),
        )
        for treatment in ("propagate", PLUG_IN)
    ),
    case(
        "no-prior-with-a-simulator",
        ValueError,
        r"prior is required when the simulations are run by the simulator",
        params=dict(prior=None, simulator=BAD.simulator),
        sims={},
    ),
    # simulators
    case(
        "simulator-fails-on-every-run",
        RuntimeError,
        r"simulator failed on all 20 runs, e.g. run 0 with X=\[.*\], theta=\[.*\]: "
        r"ZeroDivisionError: mesh collapsed. Fix the simulator",
        params=dict(simulator=broken_simulator, n_simulations=20),
        sims={},
    ),
    case(
        "simulator-fails-on-some-runs",
        UserWarning,
        r"\d+ of 20 simulator runs failed \(\d+x ZeroDivisionError: mesh "
        r"collapsed\): the \d+ successful runs are used",
        params=dict(simulator=failing_simulator, n_simulations=20),
        sims={},
    ),
    case(
        "simulator-leaves-too-few-runs",
        ValueError,
        r"2 simulations after 18 of 20 simulator runs failed \(18x non-finite "
        r"output .*\) are too few to fit an emulator: .* needs at least 3",
        params=dict(simulator=mostly_nan_simulator, n_simulations=20),
        sims={},
    ),
    case(
        "simulator-raises-on-the-batch-only",
        UserWarning,
        r"simulator raised MemoryError: the solver cannot hold the batch on the "
        r"batch of 20 runs but not on smaller blocks; it was called 39 times",
        params=dict(simulator=batch_only_simulator, n_simulations=20),
        sims={},
    ),
    case(
        "simulator-wrong-shape",
        ValueError,
        r"simulator returned an array of shape \(20, 1\) for runs 0..19; it must "
        r"return \(20, 2\)",
        params=dict(simulator=wrong_shape_simulator, n_simulations=20),
        sims={},
    ),
    case(
        "simulator-non-finite",
        UserWarning,
        r"1 of 20 simulator runs failed \(1x non-finite output \[nan, .*\]\): the "
        r"19 successful runs are used and the failed ones are listed in "
        r"simulation_failures_ \(inputs and error\)",
        params=dict(simulator=nan_simulator, n_simulations=20),
        sims={},
    ),
    case(
        "simulator-returns-text",
        TypeError,
        r"simulator returned a list that is not an array of numbers",
        params=dict(simulator=text_simulator, n_simulations=20),
        sims={},
    ),
    case(
        "simulator-not-callable",
        TypeError,
        r"simulator must be a callable simulator\(X, theta\) -> Y or None, got str",
        params=dict(simulator="model.exe"),
        sims={},
    ),
]


@pytest.mark.parametrize(("params", "X", "y", "sims", "exception", "match"), BAD_INPUT)
def test_bad_input_table(params, X, y, sims, exception, match):
    params = {
        "prior": BAD.prior,
        "n_restarts_optimizer": 0,
        "random_state": 0,
        **params,
    }
    cal = ModularBayesCalibrator(**params)
    X = BAD.X_obs if X is None else X
    y = BAD.y_obs if y is None else y
    if issubclass(exception, Warning):
        # Documented warnings: the fit goes on and gives a finite posterior,
        # and the warning points at the caller of fit, not into skmba.
        with pytest.warns(exception, match=match) as record:
            cal.fit(X, y, **sims)
        assert np.all(np.isfinite(cal.theta_mean_))
        ours = [w for w in record if re.search(match, str(w.message))]
        assert {w.filename for w in ours} == {__file__}
    else:
        with pytest.raises(exception, match=match):
            cal.fit(X, y, **sims)


def test_simulator_error_chains_the_original_exception():
    cal = ModularBayesCalibrator(broken_simulator, BAD.prior, n_simulations=20)
    with pytest.raises(RuntimeError, match="on all 20 runs") as info:
        cal.fit(BAD.X_obs, BAD.y_obs)
    assert isinstance(info.value.__cause__, ZeroDivisionError)
    assert str(info.value.__cause__) == "mesh collapsed"


class StuckGaugeCantilever:
    """The cantilever model whose energy output is stuck at one value (a
    post-processing bug): the fit fails after the runs, at the check of
    the simulated responses."""

    def __init__(self, model):
        self.model = model

    def __call__(self, X, theta):
        Y = self.model(X, theta)
        Y[:, 1] = 1.0
        return Y


def test_simulator_runs_survive_a_failed_fit():
    # A week of simulations must not be lost when a later step fails: the
    # runs stay in X_sim_, theta_sim_, y_sim_, the error says so, and they
    # can be passed back without running the simulator again.
    cal = ModularBayesCalibrator(
        StuckGaugeCantilever(BAD.simulator),
        BAD.prior,
        n_simulations=30,
        n_restarts_optimizer=0,
        random_state=0,
    )
    with pytest.raises(
        ValueError, match=r"y_sim column\(s\) \[1\] are constant"
    ) as info:
        cal.fit(BAD.X_obs, BAD.y_obs)
    if sys.version_info >= (3, 11):
        assert any("kept in X_sim_" in note for note in info.value.__notes__)
    assert cal.X_sim_.shape == (30, 1) and cal.y_sim_.shape == (30, 2)
    sims = dict(X_sim=cal.X_sim_, theta_sim=cal.theta_sim_, y_sim=cal.y_sim_[:, :1])
    cal.set_params(simulator=None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # observations beyond the largest load
        cal.fit(BAD.X_obs, BAD.y_obs[:, :1], **sims)
    assert abs(relative_error(cal, BAD)) < 0.05


def test_constant_field_data():
    # Repeated measurements at one load are valid data, but the unknown
    # constant mean of the discrepancy absorbs any offset there: the field
    # data carry no information on theta, which the calibrator says, and
    # the posterior is the prior (uniform on [20, 100] GPa, mean 60 GPa).
    X = np.full((10, 1), 6000.0)
    rng = np.random.default_rng(0)
    y = BAD.reality(X) * (1 + 1e-3 * rng.standard_normal((10, 2)))
    cal = ModularBayesCalibrator(prior=BAD.prior, n_restarts_optimizer=0)
    with pytest.warns(UserWarning, match=r"X has 1 distinct row\(s\): .* prior"):
        cal.fit(X, y, **SIMS)
    assert cal.theta_mean_[0] == pytest.approx(60e3, rel=1e-6)
    # A response observed as constant is no error either, but a stuck gauge
    # is named.
    # (16 draws of module 2: with a response stuck at 0.5 the integral to
    # discrepancy_tol="auto" stops at 4096 draws short of its tolerance, in
    # 6 of 6 seeds measured, and says so too; the 16 draws say it below.)
    y_constant = np.column_stack([BAD.y_obs[:, 0], np.full(10, 0.5)])
    cal = ModularBayesCalibrator(
        prior=BAD.prior, n_restarts_optimizer=0, discrepancy_tol=None, random_state=0
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.simplefilter("ignore", ConvergenceWarning)
        # E and the discrepancy are confounded on this design (the thesis
        # cantilever), which is said whatever the data.
        warnings.simplefilter("ignore", NonIdentifiabilityWarning)
        cal.fit(BAD.X_obs, y_constant, **SIMS)
    # and the 16 draws disagree about E there, which is said as well
    assert [str(w.message)[:60] for w in caught] == [
        "The observations of response 1 (column 1 of y) are all 0.5: ",
        "Theta's posterior mixes 16 fixed draws of the discrepancy an",
    ]
    assert caught[0].category is FieldDataWarning
    assert np.all(np.isfinite(cal.theta_mean_)) and np.all(cal.noise_ > 0)


def test_bad_input_at_prediction_time():
    cal = fit(BAD, n_restarts_optimizer=0)
    with pytest.raises(ValueError, match="X has 2 features, but"):
        cal.predict(np.ones((3, 2)))
    with pytest.raises(ValueError, match="Input X contains NaN"):
        cal.predict_model(with_value(BAD.X_obs[:3], (1, 0), np.nan))
    with pytest.raises(ValueError, match="theta has 2 values per row; the prior"):
        cal.log_posterior([[1.0, 2.0]])


def test_inside_a_pipeline_with_routed_simulations():
    from sklearn.pipeline import Pipeline

    data = make_cantilever(random_state=2)
    pipe = Pipeline([("calibrate", ModularBayesCalibrator(prior=data.prior))])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pipe.fit(
            data.X_obs,
            data.y_obs,
            calibrate__X_sim=data.X_sim,
            calibrate__theta_sim=data.theta_sim,
            calibrate__y_sim=data.y_sim,
        )
    assert pipe.predict(data.X_obs[:2]).shape == (2, 2)
    assert pipe.score(data.X_obs, data.y_obs) > 0.99


# ---------------------------------------------------------------- persistence
TWO = make_cantilever(
    n_simulations=40, n_observations=12, parameters=("E", "I"), random_state=0
)
SMALL_MCMC = dict(n_chains=2, n_samples=100, burn_in=100, n_restarts_optimizer=0)


@pytest.fixture(scope="module", params=["quadrature", "mcmc"])
def fitted(request):
    if request.param == "quadrature":
        return fit(BAD, n_restarts_optimizer=0), BAD
    return fit(TWO, **SMALL_MCMC), TWO


def everything(cal, data):
    """All module-4 outputs (with std) and log posteriors, to compare."""
    X = data.X_obs[:5]
    out = {
        name: np.stack(getattr(cal, name)(X, return_std=True))
        for name in ("predict", "predict_model", "predict_discrepancy")
    }
    thetas = np.vstack([cal.theta_mean_, 0.98 * cal.theta_mean_])
    out["log_posterior"] = cal.log_posterior(thetas)
    return out


def unpicklable_function(obj):
    """A lambda, a local function (closure) or a method of one."""
    func = getattr(obj, "__func__", obj)
    if not isinstance(func, types.FunctionType):
        return False
    return func.__name__ == "<lambda>" or "<locals>" in func.__qualname__


def functions_and_handles(obj, seen=None):
    """Lambdas, closures and open files reachable from a fitted state.

    scipy's frozen distributions (the prior) are leaves: scipy pickles them.
    """
    seen = set() if seen is None else seen
    if id(obj) in seen or isinstance(obj, (np.ndarray, str, bytes, int, float)):
        return []
    seen.add(id(obj))
    if unpicklable_function(obj) or isinstance(obj, io.IOBase):
        return [obj]
    if type(obj).__module__.startswith("scipy."):
        return []
    if isinstance(obj, dict):
        children = list(obj.values())
    elif isinstance(obj, (list, tuple, set)):
        children = list(obj)
    elif hasattr(obj, "__dict__") and not isinstance(obj, type):
        children = list(vars(obj).values())
    else:
        children = []
    return [f for child in children for f in functions_and_handles(child, seen)]


def test_fitted_state_holds_no_functions_or_handles(fitted):
    cal, _ = fitted
    fitted_state = {k: v for k, v in vars(cal).items() if k.endswith("_")}
    fitted_state.update({k: v for k, v in vars(cal).items() if k.startswith("_")})
    assert "global_model_" in fitted_state
    assert functions_and_handles(fitted_state) == []
    # the walk does find them
    with io.StringIO() as handle:
        planted = {"model": [lambda x: x, handle], "prior": fitted_state["prior_"]}
        assert len(functions_and_handles(planted)) == 2


@pytest.mark.parametrize("how", ["pickle", "joblib"])
def test_persistence_gives_identical_results(fitted, how, tmp_path):
    cal, data = fitted
    expected = everything(cal, data)
    if how == "pickle":
        back = pickle.loads(pickle.dumps(cal))
    else:
        joblib.dump(cal, tmp_path / "calibrator.joblib")
        back = joblib.load(tmp_path / "calibrator.joblib")
    got = everything(back, data)
    for name, value in expected.items():
        np.testing.assert_array_equal(got[name], value, err_msg=name)
    # Predicting does not change the fitted state: a second round trip of
    # the loaded copy still gives the same.
    again = everything(pickle.loads(pickle.dumps(back)), data)
    for name, value in expected.items():
        np.testing.assert_array_equal(again[name], value, err_msg=name)


def test_simulator_is_not_needed_after_fit():
    cal = ModularBayesCalibrator(
        lambda X, theta: BAD.simulator(X, theta),  # cannot be pickled
        BAD.prior,
        n_simulations=30,
        n_restarts_optimizer=0,
        random_state=0,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal.fit(BAD.X_obs, BAD.y_obs)
    expected = everything(cal, BAD)
    with pytest.raises((pickle.PicklingError, AttributeError, TypeError)):
        pickle.dumps(cal)
    cal.set_params(simulator=None)
    got = everything(cal, BAD)
    back = pickle.loads(pickle.dumps(cal))
    loaded = everything(back, BAD)
    for name, value in expected.items():
        np.testing.assert_array_equal(got[name], value, err_msg=name)
        np.testing.assert_array_equal(loaded[name], value, err_msg=name)
    assert back.get_params()["simulator"] is None


# ------------------------------------------------------- progress and chains
def test_verbose_zero_prints_nothing(capsys):
    fit(BAD, n_restarts_optimizer=0)
    fit(TWO, **SMALL_MCMC)
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == ""


def test_verbose_reports_each_module(capsys):
    # Everything on standard error: the lines and bars of skmba._core.progress.
    fit(BAD, n_restarts_optimizer=0, verbose=1)
    captured = capsys.readouterr()
    assert captured.out == ""
    out = captured.err
    lines = [line.split("\r")[-1] for line in out.split("\n") if line]
    assert all(line.startswith("[ModularBayesCalibrator] ") for line in lines)
    assert re.search(r"module 1 done in [\d.]+ s: emulator of 30 simulations", out)
    assert re.search(r"module 2 done in [\d.]+ s: noise variances \[", out)
    assert "module 3: quadrature pass 1 (201 nodes on [" in out
    assert re.search(r"quadrature pass 2 \(201 nodes on .* \d+ carry the mass\)", out)
    assert re.search(r"module 3 done in [\d.]+ s \(quadrature\): posterior mean", out)
    assert "[ModularBayesCalibrator] emulator of 30 simulations: 100%" in out
    fit(TWO, verbose=2, n_jobs=1, **SMALL_MCMC)
    captured = capsys.readouterr()
    assert captured.out == ""
    out = captured.err
    assert "running 2 chain(s) of 100 burn-in + 100 steps" in out
    assert "MCMC: 2 chain(s): 100%" in out
    for c in range(2):
        assert re.search(rf"chain {c} done: acceptance 0\.\d\d", out)
        # verbose=2: detail lines of each chain, from the parent process
        assert f"chain {c}: burn-in of 100 steps done in" in out
        assert f"chain {c}: 100 draws done in" in out
    assert re.search(r"module 3 done .* \(mcmc\): .* R-hat \[", out)


def test_theta_chains_hold_the_mcmc_draws_and_go_with_quadrature():
    cal = fit(BAD, sampler="mcmc", random_state=1, **SMALL_MCMC)
    assert cal.theta_chains_.shape == (2, 100, 1)
    np.testing.assert_array_equal(cal.theta_samples_, cal.theta_chains_.reshape(-1, 1))
    # user units: moduli in MPa inside the prior's support
    assert np.all((cal.theta_chains_ > 20e3) & (cal.theta_chains_ < 100e3))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal.set_params(sampler="auto").fit(BAD.X_obs, BAD.y_obs, **SIMS)
    for name in ("theta_chains_", "acceptance_rate_", "rhat_", "ess_"):
        assert not hasattr(cal, name), name
    assert cal.theta_nodes_.shape[1] == 1


def test_target_ess_ends_the_chains_early_on_the_full_run_s_first_draws():
    """The default ``target_ess`` stops the chains once every parameter's
    bulk and tail ESS reach it (R-hat <= 1.01); the draws are those of the
    run at full length, cut."""
    kwargs = dict(SMALL_MCMC, n_samples=3000, burn_in=200)
    kwargs.update(sampler="mcmc", discrepancy_uncertainty="plug-in", random_state=1)
    stopped = fit(BAD, target_ess=400, **kwargs)
    full = fit(BAD, target_ess=None, **kwargs)
    m = stopped.theta_chains_.shape[1]
    rule = EssTarget(400)
    assert m < 3000 and m % rule.grid == 0
    assert full.theta_chains_.shape == (2, 3000, 1)
    np.testing.assert_array_equal(stopped.theta_chains_, full.theta_chains_[:, :m])
    np.testing.assert_array_equal(
        stopped.theta_log_posterior_, full.theta_log_posterior_[:, :m]
    )
    assert stopped.ess_[0] >= 400 and stopped.rhat_[0] <= 1.01
    assert rule.met(stopped.theta_chains_)
    # The regular checkpoint before the stop fell short; the stop is there
    # or at the checkpoint the rule predicted from it (every 250, grid 50).
    regular = (m - 1) // rule.every * rule.every
    met, predicted = rule.judge(full.theta_chains_[:, :regular])
    assert not met
    if m % rule.every:  # a predicted checkpoint
        assert predicted is not None and regular < predicted <= m
    with pytest.raises(ValueError, match="target_ess"):
        fit(BAD, target_ess=0, **kwargs)


def test_the_second_pass_burns_in_a_quarter_and_an_update_all(monkeypatch):
    """The propagated module 2's first pass burns in at most 500 steps from
    the mode; the second pass starts from its draws and burns in
    ``WARM_BURN_IN_SHARE`` of ``burn_in``, at least the 100 steps that adapt
    (docs/internals.rst, skmba.mcmc._chain); an update's chains, started
    from the last posterior's draws, burn in ``burn_in``."""
    calls, run_chains = [], posterior_module.run_chains

    def recorded(*args, **kwargs):
        calls.append((kwargs["burn_in"], kwargs["moments"] is not None))
        return run_chains(*args, **kwargs)

    monkeypatch.setattr(posterior_module, "run_chains", recorded)
    # As if the short runs mixed (R-hat at most 1.01; the next test takes
    # the other branch).
    monkeypatch.setattr(posterior_module, "_mixed", lambda *args: True)
    data = make_cantilever(30, 12, parameters=("E", "I"), random_state=0)
    assert module3_module.WARM_BURN_IN_SHARE == 0.25
    for burn_in, first, second in ((1000, 500, 250), (400, 400, 100), (60, 60, 60)):
        calls.clear()
        fit(data, n_restarts_optimizer=0, n_samples=250, burn_in=burn_in)
        assert calls == [(first, False), (second, True)]
    calls.clear()
    cal = ModularBayesCalibrator(
        prior=data.prior,
        n_restarts_optimizer=0,
        n_samples=250,
        burn_in=400,
        random_state=0,
    )
    sims = dict(X_sim=data.X_sim, theta_sim=data.theta_sim, y_sim=data.y_sim)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal.partial_fit(data.X_obs[:3], data.y_obs[:3], **sims)
        # Nine readings after three: the reweighted draws do not do.
        cal.partial_fit(data.X_obs[3:], data.y_obs[3:])
    assert calls == [(400, False), (100, True), (400, True)]


def test_a_second_pass_that_would_warn_runs_again_after_the_full_burn_in(
    monkeypatch,
):
    """Chains of the second pass whose draws fail the R-hat check after the
    quarter burn-in run again after ``burn_in``: the fit is then the one
    whose second pass burns in ``burn_in`` from the start."""
    calls, run_chains = [], posterior_module.run_chains

    def recorded(*args, **kwargs):
        calls.append(kwargs["burn_in"])
        return run_chains(*args, **kwargs)

    monkeypatch.setattr(posterior_module, "run_chains", recorded)
    # As if the short run's R-hat were above 1.01 (judged once, after it).
    monkeypatch.setattr(posterior_module, "_mixed", lambda *args: False)
    data = make_cantilever(30, 12, parameters=("E", "I"), random_state=0)
    params = dict(n_restarts_optimizer=0, n_samples=250, burn_in=400)
    again = fit(data, **params)
    assert calls == [400, 100, 400]
    monkeypatch.setattr(module3_module, "WARM_BURN_IN_SHARE", 1.0)
    calls.clear()
    full = fit(data, **params)
    assert calls == [400, 400]
    np.testing.assert_array_equal(again.theta_chains_, full.theta_chains_)


# --------------------------------------------------------------------- memory
def patch_memory_check(monkeypatch, check):
    """Replace check_memory in every module that budgets memory."""
    for module in (
        module3_module,
        integration_module,
        discrepancy_module,
        prediction_module,
    ):
        monkeypatch.setattr(module, "check_memory", check)


def recorder(fail_on=None):
    """A check_memory that records its calls and can refuse one of them."""
    calls = []

    def check(n_bytes, what, remedy):
        calls.append((what, n_bytes, remedy))
        if fail_on is not None and what.startswith(fail_on):
            raise MemoryError(f"{what} needs {n_bytes} bytes. {remedy}")

    return check, calls


def test_memory_is_checked_before_the_large_allocations(monkeypatch):
    check, calls = recorder()
    patch_memory_check(monkeypatch, check)
    cal = fit(BAD, n_restarts_optimizer=0)
    cal.predict(BAD.X_obs[:7], return_std=True)
    whats = [what for what, _, _ in calls]
    # Module 2b and module 3 run twice (the second pass of the propagated
    # module 2); the second integration has no more nodes than the first.
    assert [w.split(" (")[0] for w in whats] == [
        "Module 2",
        "The module-2 likelihood",
        "The module-3 global model",
        "The module-2 likelihood",
        "The module-3 global model",
        "The prediction at 7 points",
    ]
    sizes = dict(zip((w.split(" (")[0] for w in whats), calls, strict=True))
    nq = 10 * 2
    # at least the nq x nq matrices each step is known to hold
    assert sizes["Module 2"][1] >= 4 * 8 * nq**2
    assert sizes["The module-2 likelihood"][1] >= 8 * 8 * nq**2
    assert sizes["The module-3 global model"][1] >= 6 * 8 * nq**2
    N = len(BAD.X_sim)
    assert sizes["The prediction at 7 points"][1] >= 8 * (N * 2) * (7 * 2)


@pytest.mark.parametrize(
    ("fail_on", "match"),
    [
        ("Module 2", r"Module 2 \(the emulator integrated .* Use fewer field"),
        ("The module-2 likelihood", r"module-2 likelihood .* Use fewer field"),
        ("The module-3 global model", r"global model .* Use fewer field"),
    ],
)
def test_fit_refuses_what_does_not_fit_in_memory(monkeypatch, fail_on, match):
    check, _ = recorder(fail_on)
    patch_memory_check(monkeypatch, check)
    with pytest.raises(MemoryError, match=match):
        ModularBayesCalibrator(prior=BAD.prior, n_restarts_optimizer=0).fit(
            BAD.X_obs, BAD.y_obs, **SIMS
        )


def test_prediction_refuses_what_does_not_fit_in_memory(monkeypatch):
    cal = fit(BAD, n_restarts_optimizer=0)
    check, _ = recorder("The prediction")
    patch_memory_check(monkeypatch, check)
    with pytest.raises(MemoryError, match=r"Predict at fewer points per call"):
        cal.predict(BAD.X_obs)


def test_memory_check_uses_the_real_available_memory(monkeypatch):
    # With the real check_memory and 200 kB "available", module 1 (58 kB)
    # runs and module 2 (about 0.5 MB) refuses before allocating.
    monkeypatch.setattr(linalg_module, "_available_memory", lambda: 200_000)
    with pytest.raises(MemoryError, match=r"^Module 2 \(the .* GiB is available"):
        ModularBayesCalibrator(prior=BAD.prior, n_restarts_optimizer=0).fit(
            BAD.X_obs, BAD.y_obs, **SIMS
        )


def test_unresolved_quadrature_posterior_is_reported(monkeypatch, capsys):
    # Make the resolution criterion unreachable: all eight passes run and
    # the calibrator says that theta_cov_ is then underestimated.
    monkeypatch.setattr(quadrature_module, "_RESOLVED_NODES", 202)
    cal = ModularBayesCalibrator(prior=BAD.prior, n_restarts_optimizer=0, verbose=1)
    with pytest.warns(
        UserWarning, match=r"narrower than the quadrature resolved "
    ) as record:
        cal.fit(BAD.X_obs, BAD.y_obs, **SIMS)
    assert np.isfinite(cal.theta_mean_[0])
    ours = [w for w in record if "narrower than the quadrature" in str(w.message)]
    assert {w.filename for w in ours} == {__file__}
    out = capsys.readouterr().err
    assert "quadrature pass 8 (201 nodes" in out and "pass 9" not in out


def test_a_numpy_generator_seeds_the_fit_reproducibly():
    def run():
        cal = ModularBayesCalibrator(
            prior=BAD.prior,
            n_restarts_optimizer=0,
            n_samples=200,
            random_state=np.random.default_rng(5),
        )
        return cal.fit(BAD.X_obs, BAD.y_obs, **SIMS).theta_samples_

    np.testing.assert_array_equal(run(), run())


def test_module2_treatments():
    # "propagate" (default) integrates the module-2 hyperparameters out over
    # draws (one parameter: blocks of 128 to discrepancy_tol="auto"); "plug-in"
    # is the thesis' MBA: one global model, a mixture of one draw of weight
    # one, whose likelihood is its global model's.
    from skmba.calibration._module2_converged import N_BLOCK
    from skmba.calibration._module3_mixture import ModelMixture

    data = make_cantilever(30, 10, random_state=0)
    default = fit(data, n_restarts_optimizer=0)
    plug_in = fit(data, n_restarts_optimizer=0, discrepancy_uncertainty="plug-in")
    assert isinstance(default.global_model_, ModelMixture)
    n_draws = len(default.global_model_.models)
    assert n_draws == default.discrepancy_draws_ and n_draws % N_BLOCK == 0
    assert np.all(np.isfinite(default.theta_mcse_))
    assert isinstance(plug_in.global_model_, ModelMixture)
    assert len(plug_in.global_model_.models) == 1
    t_std = (np.array([65e3]) - plug_in.theta_offset_) / plug_in.theta_scale_
    base = plug_in.global_model_.base
    assert plug_in.global_model_.log_likelihood(t_std) == base.log_likelihood(t_std)
    for cal in (default, plug_in):
        assert cal.identifiability_.shape == (1,)
        # E is confounded with the discrepancy on the cantilever (a spring
        # or a softer beam change both responses alike): the data account
        # for under a third of its posterior sd.
        assert 0 < cal.identifiability_[0] < IDENTIFIABILITY_THRESHOLD
    # The mixture's log posterior is that of its draws, mixed.
    theta = np.array([65e3])
    expected = default.prior_.logpdf(theta[None])[
        0
    ] + default.global_model_.log_likelihood(
        (theta - default.theta_offset_) / default.theta_scale_
    )
    assert default.log_posterior(theta) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("treatment", ["propagate", PLUG_IN])
def test_sklearn_kernel_as_discrepancy_kernel_needs_no_extra_settings(treatment):
    """A scikit-learn correlation keeps its own bounds under either
    treatment (Table 6.2's roughness range is for the kernels of
    skmba.kernels), and is fitted: its length scale moves from the start."""
    cal = ModularBayesCalibrator(
        prior=BAD.prior,
        discrepancy_kernel=RBF(1.0),
        discrepancy_uncertainty=treatment,
        n_restarts_optimizer=0,
        random_state=0,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NonIdentifiabilityWarning)
        cal.fit(BAD.X_obs, BAD.y_obs, **SIMS)
    assert isinstance(cal.discrepancy_kernel_, RBF)
    assert cal.discrepancy_kernel_.length_scale != 1.0
    assert np.all(np.isfinite(cal.theta_mean_))


# ------------------------------------------------------------ named tables
def _named_cantilever():
    pd = pytest.importorskip("pandas")
    data = make_cantilever(
        36,
        12,
        design_variables=("force", "moment"),
        parameters=("E", "I"),
        snr_db=30,
        random_state=0,
    )
    inputs, responses, parameters = ["F", "M"], ["tip", "energy"], ["E", "I"]
    tables = dict(
        X=pd.DataFrame(data.X_obs, columns=inputs),
        y=pd.DataFrame(data.y_obs, columns=responses),
        X_sim=pd.DataFrame(data.X_sim, columns=inputs),
        theta_sim=pd.DataFrame(data.theta_sim, columns=parameters),
        y_sim=pd.DataFrame(data.y_sim, columns=responses),
    )
    prior = dict(zip(parameters, data.prior, strict=True))
    return data, tables, prior


def _fit_tables(prior, X, y, **sims):
    cal = ModularBayesCalibrator(
        prior=prior,
        n_chains=2,
        n_samples=200,
        burn_in=100,
        n_restarts_optimizer=0,
        random_state=0,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return cal.fit(X, y, **sims)


def test_simulation_tables_are_matched_by_column_name():
    data, t, prior = _named_cantilever()
    sims = {k: t[k] for k in ("X_sim", "theta_sim", "y_sim")}
    ordered = _fit_tables(prior, t["X"], t["y"], **sims)
    reversed_columns = {k: v.iloc[:, ::-1] for k, v in sims.items()}
    shuffled = _fit_tables(prior, t["X"], t["y"], **reversed_columns)
    arrays = _fit_tables(
        list(data.prior),
        data.X_obs,
        data.y_obs,
        X_sim=data.X_sim,
        theta_sim=data.theta_sim,
        y_sim=data.y_sim,
    )
    # The same fit bit for bit: reordered tables and arrays alike.
    for other in (shuffled, arrays):
        np.testing.assert_array_equal(other.theta_samples_, ordered.theta_samples_)
        X_new = t["X"][:3] if other is shuffled else data.X_obs[:3]
        np.testing.assert_array_equal(other.predict(X_new), ordered.predict(t["X"][:3]))
    assert list(ordered.feature_names_in_) == ["F", "M"]
    assert ordered.response_names_ == ["tip", "energy"]
    assert ordered.parameter_names_ == ["E", "I"]
    assert arrays.response_names_ is None and not hasattr(arrays, "feature_names_in_")
    # scikit-learn's rule at prediction: the fitted names, in their order.
    with pytest.raises(ValueError, match="feature names should match"):
        ordered.predict(t["X"][["M", "F"]])
    # log_posterior matches a table's columns to the parameter names
    theta = t["theta_sim"].iloc[:3]
    np.testing.assert_array_equal(
        ordered.log_posterior(theta[["I", "E"]]),
        ordered.log_posterior(theta.to_numpy()),
    )
    # without a prior, the columns of theta_sim name the parameters
    unnamed = _fit_tables(None, t["X"], t["y"], **reversed_columns)
    assert unnamed.parameter_names_ == ["I", "E"]


@pytest.mark.parametrize(
    ("table", "columns", "match"),
    [
        (
            "X_sim",
            ["F", "moment"],
            r"The columns of X_sim do not match the columns of X: X_sim lacks "
            r"\['M'\] and has \['moment'\] besides",
        ),
        (
            "theta_sim",
            ["E", "J"],
            r"The columns of theta_sim do not match the keys of prior: theta_sim "
            r"lacks \['I'\] and has \['J'\] besides",
        ),
        (
            "y_sim",
            ["tip", "strain"],
            r"The columns of y_sim do not match the columns of y: y_sim lacks "
            r"\['energy'\] and has \['strain'\] besides \(the columns of y: \['tip', "
            r"'energy'\]; y_sim: \['tip', 'strain'\]\)",
        ),
    ],
)
def test_simulation_tables_with_other_names_are_an_error(table, columns, match):
    _, t, prior = _named_cantilever()
    sims = {k: t[k] for k in ("X_sim", "theta_sim", "y_sim")}
    sims[table] = sims[table].set_axis(columns, axis=1)
    with pytest.raises(ValueError, match=match):
        ModularBayesCalibrator(prior=prior).fit(t["X"], t["y"], **sims)


# ------------------------------------------------------------ missing readings
def test_a_row_without_readings_is_left_out_and_gaps_use_the_rest():
    data = make_cantilever(30, 12, snr_db=30, random_state=2)
    y = data.y_obs.copy()
    y[4] = np.nan  # every sensor out
    y[[1, 7], [0, 1]] = np.nan  # one sensor out at a time
    params = dict(prior=data.prior, n_restarts_optimizer=0, random_state=0)
    sims = dict(X_sim=data.X_sim, theta_sim=data.theta_sim, y_sim=data.y_sim)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NonIdentifiabilityWarning)
        with pytest.warns(UserWarning, match=r"rows \[4\]: they are left out"):
            gapped = ModularBayesCalibrator(**params).fit(data.X_obs, y, **sims)
        keep = np.arange(12) != 4
        dropped = ModularBayesCalibrator(**params).fit(
            data.X_obs[keep], y[keep], **sims
        )
        full = ModularBayesCalibrator(**params).fit(data.X_obs, data.y_obs, **sims)
    # Leaving the empty row out is what the calibrator does itself.
    np.testing.assert_array_equal(gapped.theta_samples_, dropped.theta_samples_)
    assert gapped.X_obs_.shape == (11, 1) and np.isnan(gapped.y_obs_).sum() == 2
    # The two single gaps cost a little information, and move theta little.
    sd, sd_full = np.sqrt(gapped.theta_cov_[0, 0]), np.sqrt(full.theta_cov_[0, 0])
    assert abs(gapped.theta_mean_[0] - full.theta_mean_[0]) < sd_full
    assert 0.95 * sd_full < sd < 2 * sd_full
    mean, std = gapped.predict(data.X_obs[[1, 7]], return_std=True)
    assert np.all(np.isfinite(mean)) and np.all(std > 0)
    # score: scikit-learn's R2 without gaps, per measured entries with them
    pred = full.predict(data.X_obs)
    assert full.score(data.X_obs, data.y_obs) == pytest.approx(
        r2_score(data.y_obs, pred), rel=1e-12
    )
    m0, m1 = np.isfinite(y[:, 0]), np.isfinite(y[:, 1])
    expected = 0.5 * (r2_score(y[m0, 0], pred[m0, 0]) + r2_score(y[m1, 1], pred[m1, 1]))
    assert full.score(data.X_obs, y) == pytest.approx(expected, rel=1e-12)


def test_observations_outside_the_simulations_name_the_design_variable():
    pd = pytest.importorskip("pandas")
    X = pd.DataFrame({"F": BAD.X_obs[:, 0] * 2.0})
    cal = ModularBayesCalibrator(
        prior=BAD.prior, n_restarts_optimizer=0, random_state=0
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NonIdentifiabilityWarning)
        with pytest.warns(UserWarning, match=r"in the design variable\(s\) 'F': 5 at"):
            cal.fit(X, BAD.y_obs, **SIMS)
