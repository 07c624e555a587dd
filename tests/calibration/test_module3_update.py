"""Module 3 of an update: a day added to months of readings reweights the
last run's draws and agrees with chains run on the same update within
their Monte Carlo errors; the next day reweights the same draws; a last
run that did not converge is not reused; the fitted attributes, summary
and ArviZ export say which."""

import pickle
import warnings

import numpy as np
import pytest

import skmba.calibration._module3_fit as module3_fit
import skmba.mcmc._reweight as reweight_module
from skmba import ModularBayesCalibrator
from skmba.calibration._module3_mixture import IDLE_WEIGHT, ModelMixture
from skmba.mcmc._diagnostics import ess_bulk, ess_mean, ess_sd, ess_tail
from tests.calibration.bridge_year import (
    DATA,
    FAST,
    FRAME,
    SIMS,
    X,
    Y,
    quiet,
    sd_error,
)

pd = pytest.importorskip("pandas")

MONTH, DAY = FRAME.index.month, FRAME.index.day


@pytest.fixture(scope="module")
def eleven_months():
    """A calibrator fitted on January to November (pickled: each test
    updates its own copy)."""
    cal = ModularBayesCalibrator(prior=DATA.prior, **FAST)
    rows = MONTH <= 11
    return pickle.dumps(quiet(cal.partial_fit, X[rows], Y[rows], **SIMS))


def _update(blob, rows):
    cal = pickle.loads(blob)
    return quiet(cal.partial_fit, X[rows], Y[rows])


def test_a_day_reweights_the_last_draws_as_chains_would(eleven_months, monkeypatch):
    day = (MONTH == 12) & (DAY == 1)
    cal = _update(eleven_months, day)
    assert not hasattr(cal, "theta_chains_") and not hasattr(cal, "rhat_")
    # about one node per effective draw of the last run's chains: the
    # smallest of their bulk, tail, mean and sd ESS
    chains = pickle.loads(eleven_months).theta_chains_
    worth = np.array(
        [
            [f(chains[:, :, j]) for f in (ess_bulk, ess_tail, ess_mean, ess_sd)]
            for j in range(chains.shape[-1])
        ]
    ).min(axis=1)
    # every chain thinned by a whole step to at most ESS / chains draws, so
    # at least ESS * draws / (draws + ESS / chains) nodes: on an AMD EPYC
    # an ESS of 1,256 (314 per chain of 1,000) gave a step of 4 and 1,000
    # nodes, 0.80 ESS, above that bound's 0.76
    n_chains, n_draws = chains.shape[:2]
    per_chain = np.ceil(worth.min() / n_chains)
    lowest = worth.min() * n_draws / (n_draws + per_chain)
    assert lowest <= len(cal.theta_nodes_) <= worth.min()
    assert cal.theta_weights_.sum() == pytest.approx(1.0)
    # ESS: the run's (at most the nodes) times the Kish share
    share = 1.0 / np.sum(cal.theta_weights_**2) / len(cal.theta_weights_)
    assert share >= reweight_module.REWEIGHT_SHARE
    np.testing.assert_allclose(
        cal.ess_, np.minimum(worth, len(cal.theta_nodes_)) * share, rtol=1e-6
    )
    assert "the last MCMC draws reweighted" in cal.summary(kind="text")
    assert "ESS" in cal.summary(kind="text")
    table = cal.summary()
    np.testing.assert_allclose(table["ess_bulk"], cal.ess_)
    assert table["r_hat"].isna().all()
    # the same update by chains (the reweighting refused at any share)
    monkeypatch.setattr(reweight_module, "REWEIGHT_SHARE", 2.0)
    chains = _update(eleven_months, day)
    assert hasattr(chains, "theta_chains_")
    sd = np.sqrt(np.diag(chains.theta_cov_))
    se_mean = sd * np.sqrt(1 / cal.ess_ + 1 / chains.ess_)
    assert np.all(np.abs(cal.theta_mean_ - chains.theta_mean_) < 4 * se_mean)
    se_sd = np.hypot(
        sd_error(cal.theta_samples_, cal.ess_),
        sd_error(chains.theta_samples_, chains.ess_),
    )
    ratio = np.sqrt(np.diag(cal.theta_cov_)) / sd
    assert np.all(np.abs(ratio - 1.0) < 4 * se_sd), (ratio, se_sd)


def test_the_reweighting_leaves_out_idle_draws_and_loses_nothing(
    eleven_months, monkeypatch
):
    """The update's likelihoods at the nodes are over the module-2 draws
    with weight at 100 thinned nodes: the weights are those over every
    draw, to the idle draws' share."""
    day = (MONTH == 12) & (DAY == 1)
    counts, original = [], ModelMixture.spread_restricted

    def spy(self, thetas, n_jobs=None, tol=IDLE_WEIGHT):
        used, kept, values = original(self, thetas, n_jobs, tol)
        counts.append((len(kept), len(self.models), len(thetas)))
        return used, kept, values

    monkeypatch.setattr(ModelMixture, "spread_restricted", spy)
    fast = _update(eleven_months, day)
    [(kept, every, probes)] = counts
    assert kept < every and 100 <= probes < 200  # some draws left out
    monkeypatch.setattr(
        ModelMixture,
        "spread_restricted",
        lambda self, thetas, n_jobs=None, tol=0.0: (
            self,
            np.arange(len(self.models)),
            self.spread_component_log_likelihoods(thetas, n_jobs),
        ),
    )
    full = _update(eleven_months, day)
    np.testing.assert_array_equal(fast.theta_nodes_, full.theta_nodes_)
    np.testing.assert_allclose(fast.theta_weights_, full.theta_weights_, rtol=1e-7)
    np.testing.assert_allclose(fast.theta_mean_, full.theta_mean_, rtol=1e-9)


def test_module_4_reads_the_weights_the_reweighting_computed(
    eleven_months, monkeypatch
):
    """Each node is evaluated once (the probes with every draw, the others
    with the draws kept), and module 4's rule reads its draws' weights
    there: the predictions are those of weights recomputed at the rule's
    thetas."""
    day = (MONTH == 12) & (DAY == 1)
    evaluated, original = [], ModelMixture.spread_component_log_likelihoods

    def counting(self, thetas, n_jobs=None):
        evaluated.append(len(thetas))
        return original(self, thetas, n_jobs)

    monkeypatch.setattr(ModelMixture, "spread_component_log_likelihoods", counting)
    read = _update(eleven_months, day)
    assert sum(evaluated) == len(read.theta_nodes_)  # none for module 4
    monkeypatch.undo()
    own = module3_fit.reweighted_posterior
    monkeypatch.setattr(
        module3_fit,
        "reweighted_posterior",
        lambda *args, **kwargs: (own(*args, **kwargs)[0], None, None),
    )
    recomputed = _update(eleven_months, day)
    X_new = X[day].iloc[::3]
    for method in ("predict", "predict_reality", "predict_discrepancy"):
        mean, sd = getattr(read, method)(X_new, return_std=True)
        mean_again, sd_again = getattr(recomputed, method)(X_new, return_std=True)
        np.testing.assert_allclose(mean, mean_again, rtol=1e-9)
        np.testing.assert_allclose(sd, sd_again, rtol=1e-9)


def test_the_next_day_reweights_the_same_draws_and_the_export_says_so(
    eleven_months,
):
    cal = _update(eleven_months, (MONTH == 12) & (DAY == 1))
    nodes, weights = cal.theta_nodes_, cal.theta_weights_
    second = (MONTH == 12) & (DAY == 2)
    quiet(cal.partial_fit, X[second], Y[second])
    np.testing.assert_array_equal(cal.theta_nodes_, nodes)
    assert not np.allclose(cal.theta_weights_, weights, rtol=1e-3)
    assert len(cal.theta_history_) == 3
    history = cal.theta_history_
    np.testing.assert_array_equal(history["E_mean"].iloc[-1], cal.theta_mean_[0])
    pytest.importorskip("arviz")
    idata = cal.to_inference_data()
    assert idata.posterior.attrs["sampler"] == "reweighted draws (skmba)"
    assert "Kish share" in idata.posterior.attrs["note"]


def test_a_last_run_that_did_not_converge_is_not_reweighted():
    # A week of readings with chains of 40 draws: R-hat above 1.01 and an
    # ESS below 400 (warned); its draws must not stand for the next posterior.
    cal = ModularBayesCalibrator(prior=DATA.prior, **{**FAST, "n_samples": 40})
    week = (MONTH == 1) & (DAY <= 7)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal.partial_fit(X[week], Y[week], **SIMS)
    assert np.max(cal.rhat_) > 1.01 and np.min(cal.ess_) < 400
    day = (MONTH == 1) & (DAY == 8)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal.partial_fit(X[day], Y[day])
    assert hasattr(cal, "theta_chains_") and not hasattr(cal, "theta_nodes_")


def _chains_arguments(monkeypatch):
    """The keyword arguments of the update's chains (posterior_by_mcmc)."""
    calls, original = [], module3_fit.posterior_by_mcmc

    def spy(log_posterior, **kwargs):
        calls.append(kwargs)
        return original(log_posterior, **kwargs)

    monkeypatch.setattr(module3_fit, "posterior_by_mcmc", spy)
    return calls


def test_chains_start_from_a_refused_reweighting_with_enough_effective_draws(
    eleven_months, monkeypatch
):
    """A refused reweighting whose draws are worth MIN_ESS effective draws
    places the chains: they start from its draws, which also fit their
    proposal, and burn in as a second pass (the full burn-in if they do
    not mix); with fewer, from the last posterior's after the full one."""
    day = (MONTH == 12) & (DAY == 1)
    last = pickle.loads(eleven_months)
    monkeypatch.setattr(reweight_module, "REWEIGHT_SHARE", 2.0)
    calls = _chains_arguments(monkeypatch)
    cal = _update(eleven_months, day)
    [kwargs] = calls
    assert kwargs["earlier_fits_proposal"]
    assert (kwargs["burn_in"], kwargs["fallback_burn_in"]) == (
        module3_fit.warm_burn_in(FAST["burn_in"]),
        FAST["burn_in"],
    )
    # systematic resampling of the anchor's nodes (thinned chains)
    nodes = {tuple(row) for row in last.theta_chains_.reshape(-1, 2)}
    assert all(tuple(row) in nodes for row in kwargs["earlier"])
    assert hasattr(cal, "theta_chains_") and np.all(cal.rhat_ <= 1.01)
    # Below MIN_ESS effective draws: the last posterior's draws, full burn-in.
    calls.clear()
    monkeypatch.setattr(reweight_module, "MIN_ESS", 10**9)
    _update(eleven_months, day)
    [kwargs] = calls
    assert not kwargs["earlier_fits_proposal"]
    assert (kwargs["burn_in"], kwargs["fallback_burn_in"]) == (FAST["burn_in"], None)
    np.testing.assert_array_equal(kwargs["earlier"], last.theta_samples_)
