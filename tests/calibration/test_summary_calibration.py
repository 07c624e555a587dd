"""Summaries and the ArviZ export: summary(), to_inference_data(), names."""

import sys
import warnings

import numpy as np
import pytest
from scipy import stats
from sklearn.utils import Bunch
from thesis._helpers import fit

from skmba import ModularBayesCalibrator, PreposteriorDesigner
from skmba.calibration._summary import CALIBRATION_COLUMNS, QUADRATURE_NOTE
from skmba.datasets import make_cantilever
from skmba.sensor_design._scoring import jackknife_mcse

with warnings.catch_warnings():
    warnings.simplefilter("ignore", FutureWarning)  # ArviZ 0.x announces 1.0
    az = pytest.importorskip("arviz")
pd = pytest.importorskip("pandas")

N_CHAINS, N_SAMPLES = 2, 300
TWO = make_cantilever(
    n_simulations=40, n_observations=12, parameters=("E", "I"), random_state=0
)
ONE = make_cantilever(30, 10, random_state=0)


@pytest.fixture(scope="module")
def mcmc():
    """E and I by MCMC, with a dict prior that names them."""
    data = Bunch(**TWO)
    data.prior = dict(zip(TWO.parameter_names, TWO.prior, strict=True))
    return fit(
        data,
        n_chains=N_CHAINS,
        n_samples=N_SAMPLES,
        burn_in=200,
        n_restarts_optimizer=0,
    )


@pytest.fixture(scope="module")
def quadrature():
    """E alone by quadrature, with a list prior (unnamed)."""
    return fit(ONE, n_samples=N_SAMPLES, n_restarts_optimizer=0)


@pytest.fixture(params=["mcmc", "quadrature"])
def cal(request, mcmc, quadrature):
    return mcmc if request.param == "mcmc" else quadrature


@pytest.fixture
def no_pandas(monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)  # import pandas fails


# --------------------------------------------------------------- names
def test_parameter_names_come_from_a_dict_prior_or_are_numbered(mcmc, quadrature):
    assert mcmc.parameter_names_ == ["E", "I"]
    assert quadrature.parameter_names_ == ["theta0"]


def test_field_data_are_kept(mcmc):
    np.testing.assert_array_equal(mcmc.X_obs_, TWO.X_obs)
    np.testing.assert_array_equal(mcmc.y_obs_, TWO.y_obs)


def test_log_posterior_of_the_draws_is_kept(mcmc):
    assert mcmc.theta_log_posterior_.shape == (N_CHAINS, N_SAMPLES)
    draws = mcmc.theta_chains_[1, ::60]
    np.testing.assert_allclose(
        mcmc.theta_log_posterior_[1, ::60], mcmc.log_posterior(draws), rtol=1e-10
    )


# ------------------------------------------------------------- summary
def expected_columns(cal):
    r = cal.theta_mean_.size
    samples = cal.theta_samples_
    prior_sd = np.sqrt(np.diag(cal.prior_.cov()))
    sd = np.sqrt(np.diag(cal.theta_cov_))
    return {
        "mean": cal.theta_mean_,
        "sd": sd,
        "2.5%": np.quantile(samples, 0.025, axis=0),
        "97.5%": np.quantile(samples, 0.975, axis=0),
        "prior_mean": cal.prior_.mean(),
        "prior_sd": prior_sd,
        "sd_ratio": sd / prior_sd,
        "r_hat": getattr(cal, "rhat_", np.full(r, np.nan)),
        "ess_bulk": getattr(cal, "ess_", np.full(r, np.nan)),
        "identifiability": cal.identifiability_,
    }


def test_summary_is_a_dataframe_of_the_fitted_attributes(cal):
    table = cal.summary()
    assert isinstance(table, pd.DataFrame)
    assert list(table.index) == cal.parameter_names_
    assert table.index.name == "parameter"
    assert tuple(table.columns) == CALIBRATION_COLUMNS
    for column, values in expected_columns(cal).items():
        np.testing.assert_array_equal(table[column].to_numpy(), values, err_msg=column)
    if not hasattr(cal, "rhat_"):  # quadrature: no chains
        assert table["r_hat"].isna().all() and table["ess_bulk"].isna().all()


def test_summary_without_pandas_is_a_structured_array(cal, no_pandas):
    table = cal.summary()
    assert isinstance(table, np.ndarray)
    assert table.dtype.names == ("parameter", *CALIBRATION_COLUMNS)
    assert list(table["parameter"]) == cal.parameter_names_
    for column, values in expected_columns(cal).items():
        np.testing.assert_array_equal(table[column], values, err_msg=column)


def test_summary_text_is_one_line(mcmc, quadrature):
    text = mcmc.summary(kind="text")
    assert "\n" not in text
    assert text.startswith("ModularBayesCalibrator (MCMC): E = ")
    assert "; I = " in text and "R-hat" in text and "ESS" in text
    text = quadrature.summary(kind="text")
    assert "quadrature" in text and "theta0 = " in text and "R-hat" not in text
    with pytest.raises(ValueError, match="kind"):
        mcmc.summary(kind="html")


def test_summary_shows_identifiability(mcmc, monkeypatch):
    monkeypatch.setattr(mcmc, "identifiability_", np.array([0.2, 0.9]))
    table = mcmc.summary()
    np.testing.assert_array_equal(table["identifiability"], [0.2, 0.9])
    assert "identifiability 0.2" in mcmc.summary(kind="text")


def test_summary_needs_a_fitted_calibrator():
    from sklearn.exceptions import NotFittedError

    with pytest.raises(NotFittedError):
        ModularBayesCalibrator().summary()
    with pytest.raises(NotFittedError):
        ModularBayesCalibrator().to_inference_data()


# --------------------------------------------------------------- ArviZ
@pytest.fixture(scope="module")
def idata(mcmc):
    return mcmc.to_inference_data()


def test_posterior_group(mcmc, idata):
    assert isinstance(idata, az.InferenceData)
    posterior = idata.posterior
    assert list(posterior.data_vars) == ["E", "I"]
    for j, name in enumerate(mcmc.parameter_names_):
        assert posterior[name].dims == ("chain", "draw")
        assert posterior[name].shape == (N_CHAINS, N_SAMPLES)
        np.testing.assert_array_equal(posterior[name], mcmc.theta_chains_[:, :, j])
    assert posterior.attrs["inference_library"] == "skmba"


def test_sample_stats_group(mcmc, idata):
    stats_ = idata.sample_stats
    np.testing.assert_array_equal(stats_["lp"], mcmc.theta_log_posterior_)
    assert stats_["acceptance_rate"].shape == (N_CHAINS, N_SAMPLES)
    np.testing.assert_array_equal(
        stats_["acceptance_rate"][:, 0], mcmc.acceptance_rate_
    )
    assert np.all(stats_["acceptance_rate"] == stats_["acceptance_rate"][:, :1])


def test_prior_group(mcmc, idata):
    prior = idata.prior
    assert list(prior.data_vars) == ["E", "I"]
    assert prior["E"].shape == (1, N_CHAINS * N_SAMPLES)
    bounds = mcmc.prior_.bounds()
    for j, name in enumerate(mcmc.parameter_names_):
        draws = prior[name].to_numpy()
        assert np.all((draws >= bounds[j, 0]) & (draws <= bounds[j, 1]))
    again = mcmc.to_inference_data(n_prior_draws=50, random_state=3).prior
    assert again["I"].shape == (1, 50)


def test_observed_and_constant_data_groups(idata):
    observed = idata.observed_data
    assert list(observed.data_vars) == ["y0", "y1"]
    for k in range(2):
        assert observed[f"y{k}"].dims == ("observation",)
        np.testing.assert_array_equal(observed[f"y{k}"], TWO.y_obs[:, k])
    np.testing.assert_array_equal(idata.constant_data["x0"], TWO.X_obs[:, 0])


def test_arviz_summary_runs_and_agrees(mcmc, idata):
    table = az.summary(idata, round_to="none")
    assert list(table.index) == ["E", "I"]
    np.testing.assert_allclose(table["mean"], mcmc.theta_mean_, rtol=1e-12)
    np.testing.assert_allclose(table["r_hat"], mcmc.rhat_, rtol=1e-6)
    np.testing.assert_allclose(table["ess_bulk"], mcmc.ess_, rtol=1e-6)


def test_rhat_and_ess_equal_arviz_on_the_calibrators_chains(mcmc):
    for j in range(2):
        chains = mcmc.theta_chains_[:, :, j]
        assert mcmc.rhat_[j] == pytest.approx(az.rhat(chains, method="rank"), abs=1e-6)
        assert mcmc.ess_[j] == pytest.approx(az.ess(chains, method="bulk"), abs=1e-6)


def test_quadrature_posterior_is_one_pseudo_chain(quadrature):
    idata = quadrature.to_inference_data()
    draws = idata.posterior["theta0"]
    assert draws.shape == (1, N_SAMPLES)
    np.testing.assert_array_equal(
        np.sort(draws.to_numpy()[0]), np.sort(quadrature.theta_samples_[:, 0])
    )
    assert idata.posterior.attrs["note"] == QUADRATURE_NOTE
    assert "not a Markov chain" in QUADRATURE_NOTE
    assert "sample_stats" not in idata.groups()
    assert idata.prior["theta0"].shape == (1, N_SAMPLES)
    az.summary(idata, kind="stats")


def test_without_arviz_the_error_names_the_extra(mcmc, monkeypatch):
    monkeypatch.setitem(sys.modules, "arviz", None)
    with pytest.raises(ImportError, match=r'pip install "skmba\[arviz\]"'):
        mcmc.to_inference_data()


# ------------------------------------------------------------ designer
@pytest.fixture(scope="module")
def designer():
    sims = make_cantilever(
        30, responses=("tip_displacement", "energy", "tip_rotation"), random_state=0
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return PreposteriorDesigner(
            sims.prior,
            calibrator=ModularBayesCalibrator(n_restarts_optimizer=0),
            n_design=8,
            n_mc=4,
            random_state=0,
        ).fit(np.hstack([sims.X_sim, sims.theta_sim]), sims.y_sim)


def test_designer_summary_ranks_the_subsets(designer):
    table = designer.summary()
    assert isinstance(table, pd.DataFrame)
    assert list(table.index) == list(range(1, 8)) and table.index.name == "rank"
    assert list(table.columns) == [
        "subset",
        "n_responses",
        "score",
        "mcse",
        "warning_rate[theta0]",
        "warning_rate_mcse[theta0]",
    ]
    assert table["score"].is_monotonic_increasing
    order = np.argsort(designer.scores_, kind="stable")
    np.testing.assert_array_equal(table["score"], designer.scores_[order])
    np.testing.assert_array_equal(table["mcse"], designer.scores_mcse_[order])
    np.testing.assert_array_equal(
        table["warning_rate[theta0]"], designer.warning_rate_[order, 0]
    )
    np.testing.assert_array_equal(
        table["warning_rate_mcse[theta0]"], designer.warning_rate_mcse_[order, 0]
    )
    best = ", ".join(f"y{k}" for k in designer.best_subset_)
    assert table["subset"].iloc[0] == best
    assert np.all(designer.scores_mcse_ > 0)


def test_designer_summary_names_and_no_pandas(designer, no_pandas):
    names = ("tip", "energy", "rotation")
    table = designer.summary(response_names=names)
    assert isinstance(table, np.ndarray)
    assert table.dtype.names == (
        "rank",
        "subset",
        "n_responses",
        "score",
        "mcse",
        "warning_rate[theta0]",
        "warning_rate_mcse[theta0]",
    )
    assert "tip, energy, rotation" in list(table["subset"])
    assert list(table["rank"]) == list(range(1, 8))
    with pytest.raises(ValueError, match="one name per response"):
        designer.summary(response_names=names[:2])


def test_jackknife_of_the_trace_is_the_standard_error_of_the_mean():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(3, 20, 2, 2))
    covs = a @ np.swapaxes(a, -1, -2)  # (subsets, replicates, r, r)
    traces = np.trace(covs, axis1=-2, axis2=-1)
    expected = traces.std(axis=1, ddof=1) / np.sqrt(20)

    def trace(stack):
        return np.trace(stack, axis1=1, axis2=2)

    np.testing.assert_allclose(jackknife_mcse(covs, trace), expected, rtol=1e-12)


def test_jackknife_of_a_nonlinear_score_matches_the_definition():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(1, 6, 2, 2))
    covs = a @ np.swapaxes(a, -1, -2)

    def score(stack):  # a stack (m, r, r) -> (m,)
        return np.sqrt(np.linalg.det(stack))

    loo = np.array(
        [
            float(np.sqrt(np.linalg.det(np.delete(covs[0], i, axis=0).mean(axis=0))))
            for i in range(6)
        ]
    )
    expected = np.sqrt(5 / 6 * np.sum((loo - loo.mean()) ** 2))
    assert jackknife_mcse(covs, score)[0] == pytest.approx(expected, rel=1e-12)
    assert np.isnan(jackknife_mcse(covs[:, :1], score)[0])


def test_unknown_prior_forms_are_still_numbered():
    prior = stats.multivariate_normal([1.0, 2.0], np.eye(2))
    from skmba.calibration._summary import parameter_names
    from skmba.priors._theta import check_prior

    assert parameter_names(check_prior(prior)) == ["theta0", "theta1"]


@pytest.fixture(scope="module")
def freq_fit():
    from validation.cases import case_freq

    case = case_freq(0)
    cal = ModularBayesCalibrator(prior=case.prior, random_state=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal.fit(case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim,
                y_sim=case.y_sim)  # fmt: skip
    return cal


def test_discrepancy_prior_in_user_units(freq_fit):
    # Known answers from the documented default prior (roughness log-uniform
    # on (0.1, 9), sd half-normal of scale 0.5, noise variance log-uniform on
    # (1e-6, 1)), stated with the inputs scaled by their sd over the distinct
    # field inputs and the responses by the model's spread over those and
    # the prior of theta, both computed here from the data and the model.
    from validation.cases import case_freq, frequency_model
    from validation.sbc_cases import field_units

    cal = freq_fit
    tab = cal.discrepancy_prior_summary()
    assert tuple(tab.columns) == (
        "prior_2.5%", "prior_97.5%", "fitted", "field_spread", "prior_unit"
    )  # fmt: skip
    _, unit_x, unit_y = field_units(frequency_model, cal.X_obs_, case_freq(0).prior)
    assert unit_x[0] == pytest.approx(np.unique(cal.X_obs_).std(), rel=1e-12)
    assert tab.loc["length_scale[x0]", "prior_unit"] == pytest.approx(unit_x[0])
    # The model's spread on the emulator against the model itself.
    assert tab.loc["sd[y0]", "prior_unit"] == pytest.approx(unit_y[0], rel=1e-3)
    unit_y = tab.loc["sd[y0]", "prior_unit"]
    rough = stats.loguniform(0.1, 9.0).ppf([0.975, 0.025])
    np.testing.assert_allclose(
        tab.loc["length_scale[x0]", ["prior_2.5%", "prior_97.5%"]],
        unit_x[0] / np.sqrt(2.0 * rough),
        rtol=1e-12,
    )
    np.testing.assert_allclose(
        tab.loc["sd[y0]", ["prior_2.5%", "prior_97.5%"]],
        stats.halfnorm(scale=0.5 * unit_y).ppf([0.025, 0.975]),
        rtol=1e-12,
    )
    np.testing.assert_allclose(
        tab.loc["noise_sd[y0]", ["prior_2.5%", "prior_97.5%"]],
        np.sqrt(stats.loguniform(1e-6, 1.0).ppf([0.025, 0.975])) * unit_y,
        rtol=1e-12,
    )
    roughness = cal.discrepancy_kernel_.roughness
    assert tab.loc["length_scale[x0]", "fitted"] == pytest.approx(
        cal.X_scale_[0] / np.sqrt(2.0 * roughness)
    )
    assert tab.loc["sd[y0]", "fitted"] == pytest.approx(
        np.sqrt(cal.discrepancy_sigma2_[0, 0])
    )
    assert tab.loc["noise_sd[y0]", "fitted"] == pytest.approx(np.sqrt(cal.noise_[0]))
    assert tab.loc["length_scale[x0]", "field_spread"] == pytest.approx(
        np.ptp(cal.X_obs_)
    )


def _wider_simulations(data, factor):
    """``data``'s simulations with the load axis stretched ``factor`` times."""
    lo, hi = data.X_sim.min(), data.X_sim.max()
    X_wide = lo + (data.X_sim - lo) * (factor * hi - lo) / (hi - lo)
    return Bunch(
        X_sim=X_wide,
        theta_sim=data.theta_sim,
        y_sim=data.simulator(X_wide, data.theta_sim),
    )


@pytest.mark.parametrize("treatment", ["plug-in", "propagate"])
def test_discrepancy_prior_does_not_move_with_the_simulation_design(treatment):
    # The prior is stated in the field data's terms: the same field data
    # with simulations over twice the load range give the same prior in the
    # user's units (before issue 30 its length scales doubled), up to the
    # two emulators' difference in the model's spread; the standardised
    # units themselves do move.
    data = make_cantilever(40, 10, random_state=0)
    tables = []
    for sims in (data, _wider_simulations(data, 2.0)):
        cal = ModularBayesCalibrator(prior=data.prior, random_state=0,
                                     discrepancy_uncertainty=treatment)  # fmt: skip
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cal.fit(data.X_obs, data.y_obs, X_sim=sims.X_sim,
                    theta_sim=sims.theta_sim, y_sim=sims.y_sim)  # fmt: skip
        tables.append((cal.discrepancy_prior_summary(), cal.X_scale_[0]))
    (narrow, s0), (broad, s1) = tables
    assert 1.7 < s1 / s0 < 2.3
    prior = ["prior_2.5%", "prior_97.5%", "prior_unit"]
    np.testing.assert_allclose(
        broad.loc["length_scale[x0]", prior], narrow.loc["length_scale[x0]", prior],
        rtol=1e-12,
    )  # fmt: skip
    # The responses' unit is the model's spread at the field inputs, which
    # each emulator reproduces to its accuracy there (the wide design's 40
    # runs cover the field range half as densely: 0.12 % off, measured).
    from validation.sbc_cases import field_units

    _, _, spread = field_units(data.simulator, data.X_obs, data.prior)
    for table in (narrow, broad):
        np.testing.assert_allclose(
            table.loc[["sd[y0]", "sd[y1]"], "prior_unit"], spread, rtol=5e-3
        )
    rows = ["sd[y0]", "sd[y1]", "noise_sd[y0]", "noise_sd[y1]"]
    np.testing.assert_allclose(broad.loc[rows, prior], narrow.loc[rows, prior],
                               rtol=5e-3)  # fmt: skip
    noise = broad.loc["noise_sd[y1]", "prior_2.5%"]
    assert np.isnan(noise) == (treatment == "plug-in")  # plug-in: no noise range
