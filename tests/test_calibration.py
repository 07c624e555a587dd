"""ModularBayesCalibrator on the thesis' cantilever problems (section 4.7).

Physics note, measured here: with the physically correct beam formulas the
spring's effect on the tip displacement and on the energy are both the
fraction 3EI/(K L) of the model's value for a tip load, so a discrepancy
proportional to the model response is confounded with E. The MBA then
returns the E that makes the discrepancy smallest, E*/(1 + 3E*I/(K* L)) =
67.9 GPa (-3.1 %), with a narrow posterior: E is recovered within the
thesis' "few percent", but E* itself is outside the 95 % credible interval.
"""

import pickle
import warnings

import numpy as np
import pytest
from scipy import stats
from sklearn.base import clone

from skmba import ModularBayesCalibrator
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


def relative_error(cal, data, k=0):
    return cal.theta_mean_[k] / data.theta_true[k] - 1


def coverage(cal, data, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.uniform(*data.X_bounds[0], size=(60, 1))
    mean, std = cal.predict(X, return_std=True)
    return (np.abs(mean - data.reality(X)) <= 1.96 * std).mean(axis=0)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_471_single_parameter(seed):
    data = make_cantilever(n_simulations=70, n_observations=25, random_state=seed)
    cal = fit(data)
    assert abs(relative_error(cal, data)) < 0.05
    assert np.all(coverage(cal, data, seed) >= 0.85)
    assert cal.theta_nodes_.shape[1] == 1 and cal.theta_weights_.sum() == (
        pytest.approx(1.0)
    )
    assert not hasattr(cal, "rhat_")  # quadrature, no chains


def test_471_predictions_decompose():
    data = make_cantilever(random_state=3)
    cal = fit(data)
    X = np.linspace(*data.X_bounds[0], 7)[:, None]
    model = cal.predict_model(X)
    delta = cal.predict_discrepancy(X)
    reality, std_reality = cal.predict_reality(X, return_std=True)
    observed, std_observed = cal.predict(X, return_std=True)
    np.testing.assert_allclose(model + delta, reality, rtol=1e-8)
    np.testing.assert_allclose(observed, reality, rtol=1e-10)
    assert np.all(std_observed >= std_reality)  # the noise adds variance
    np.testing.assert_allclose(reality, data.reality(X), rtol=0.01)


def test_module2_total_variance_is_the_better_default():
    # With tip displacement and rotation, the printed Eq. 4.15 (emulator
    # variance only) lets the discrepancy absorb what theta explains and
    # ends far from E*; the law of total variance does not.
    data = make_cantilever(
        responses=("tip_displacement", "tip_rotation"), random_state=0
    )
    total = fit(data, module2_variance="total")
    conditional = fit(data, module2_variance="conditional")
    assert abs(relative_error(total, data)) < 0.05
    assert abs(relative_error(conditional, data)) > 2 * abs(relative_error(total, data))


def test_472_two_design_variables():
    data = make_cantilever(
        n_simulations=100,
        n_observations=40,
        design_variables=("force", "moment"),
        random_state=0,
    )
    cal = fit(data)
    assert abs(relative_error(cal, data)) < 0.05
    assert cal.predict(data.X_obs[:3]).shape == (3, 2)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_474_noisy_data(seed):
    data = make_cantilever(
        n_simulations=100, n_observations=35, snr_db=18.0, random_state=seed
    )
    cal = fit(data)
    assert abs(relative_error(cal, data)) < 0.10
    ratio = cal.noise_ / data.noise_variance
    assert np.all((ratio > 1 / 3) & (ratio < 3)), ratio  # the right order
    assert np.all(coverage(cal, data, seed) >= 0.85)


def test_476_outliers_fall_outside_the_predictive_interval():
    # Judged over three seeds: in two the outliers inflate the noise estimate
    # yet stay beyond 3 standard deviations; in the third the discrepancy GP
    # interpolates them (they are close to other data), which the note of
    # this issue records.
    detected = 0
    for seed in range(3):
        data = make_cantilever(
            n_simulations=100,
            n_observations=40,
            snr_db=[4.38, 71.6],
            n_outliers=2,
            random_state=seed,
        )
        cal = fit(data)
        idx = data.outlier_indices
        mean, std = cal.predict(data.X_obs[idx], return_std=True)
        z = np.abs(data.y_obs[idx] - mean) / std
        detected += bool(np.all(z.max(axis=1) > 1.96))
    assert detected >= 2


def test_477_gaussian_prior_one_parameter():
    data = make_cantilever(prior="gaussian", random_state=0)
    assert isinstance(data.prior[0].dist, type(stats.norm))
    cal = fit(data)
    assert abs(relative_error(cal, data)) < 0.05


@pytest.mark.parametrize("prior", ["uniform", "gaussian"])
def test_473_477_E_and_I_by_mcmc(prior):
    data = make_cantilever(
        n_simulations=170,
        n_observations=70,
        parameters=("E", "I"),
        prior=prior,
        random_state=0,
    )
    cal = fit(data, n_samples=1000, burn_in=1000, n_chains=4)
    EI = np.prod(cal.theta_samples_, axis=1).mean()
    assert abs(EI / np.prod(data.theta_true) - 1) < 0.05
    assert np.all(np.abs(cal.theta_mean_ / data.theta_true - 1) < 0.10)
    corr = cal.theta_cov_[0, 1] / np.sqrt(np.prod(np.diag(cal.theta_cov_)))
    assert corr < -0.5  # only E I is identified: a negative ridge
    assert np.all(cal.rhat_ < 1.05)
    assert cal.theta_samples_.shape == (4000, 2)
    assert np.all((cal.acceptance_rate_ > 0.1) & (cal.acceptance_rate_ < 0.6))


def test_log_posterior_is_prior_plus_schur_likelihood():
    data = make_cantilever(random_state=4)
    cal = fit(data)
    theta = np.array([[60e3], [70e3], [150e3]])
    values = cal.log_posterior(theta)
    assert values[2] == -np.inf  # outside the uniform prior
    expected = cal.prior_.logpdf(theta[:1]) + cal._global.log_likelihood(
        cal._std_theta(theta[0])
    )
    assert values[0] == pytest.approx(float(expected[0]), rel=1e-12)
    assert cal.log_posterior(theta[1]) == pytest.approx(values[1])
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
def test_bad_input_raises_clear_errors():
    data = make_cantilever(random_state=0)
    sims = dict(X_sim=data.X_sim, theta_sim=data.theta_sim, y_sim=data.y_sim)
    cal = ModularBayesCalibrator(prior=data.prior)
    with pytest.raises(ValueError, match="responses must be the same"):
        cal.fit(data.X_obs, data.y_obs[:, :1], **sims)
    with pytest.raises(ValueError, match="prior"):
        ModularBayesCalibrator(prior=[stats.uniform(0, 1), stats.uniform(0, 1)]).fit(
            data.X_obs, data.y_obs, **sims
        )
    with pytest.raises(ValueError, match="No simulations"):
        cal.fit(data.X_obs, data.y_obs)
    with pytest.raises(ValueError, match="together"):
        cal.fit(data.X_obs, data.y_obs, X_sim=data.X_sim)
    with pytest.raises(ValueError, match="sampler"):
        ModularBayesCalibrator(prior=data.prior, sampler="nuts").fit(
            data.X_obs, data.y_obs, **sims
        )
    with pytest.raises(ValueError, match="module2_variance"):
        ModularBayesCalibrator(prior=data.prior, module2_variance="x").fit(
            data.X_obs, data.y_obs, **sims
        )
    with pytest.raises(ValueError, match="n_chains"):
        ModularBayesCalibrator(prior=data.prior, n_chains=0).fit(
            data.X_obs, data.y_obs, **sims
        )
    with pytest.warns(UserWarning, match="outside the range"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", category=RuntimeWarning)
            cal.fit(data.X_obs * [2.0], data.y_obs, **sims)


def failing_simulator(X, theta):
    out = X * theta
    if np.any(X > 5000):
        raise ZeroDivisionError("mesh collapsed")
    return np.hstack([out, out**2])


def wrong_shape_simulator(X, theta):
    return X * theta


def nan_simulator(X, theta):
    out = np.hstack([X * theta, X])
    out[0, 0] = np.nan
    return out


@pytest.mark.parametrize(
    ("simulator", "exception", "match"),
    [
        (failing_simulator, RuntimeError, "at run .* mesh collapsed"),
        (wrong_shape_simulator, ValueError, "must return"),
        (nan_simulator, ValueError, "non-finite"),
        ("model", TypeError, "callable"),
    ],
)
def test_bad_simulators_are_reported_with_context(simulator, exception, match):
    data = make_cantilever(random_state=0)
    cal = ModularBayesCalibrator(simulator, data.prior, n_simulations=20)
    with pytest.raises(exception, match=match):
        cal.fit(data.X_obs, data.y_obs)


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
