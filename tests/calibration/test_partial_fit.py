"""``partial_fit``: batches of readings of one structure, module 1 kept and
modules 2-3 started where the last update ended, agree with one ``fit`` on
all of them; ``theta_history_`` records each update; bad batches are
refused with a message naming the fix."""

import pickle
import warnings

import numpy as np
import pytest

import skmba.calibration._pipeline as pipeline
from skmba import ModularBayesCalibrator
from tests.calibration.bridge_year import (
    DATA,
    FAST,
    FRAME,
    LONG,
    SIMS,
    X,
    Y,
    quiet,
    sd_error,
)

pd = pytest.importorskip("pandas")


def _calibrator(**params):
    return ModularBayesCalibrator(prior=DATA.prior, **{**FAST, **params})


def _in_batches(cal, labels):
    for k, label in enumerate(np.unique(labels)):
        rows = labels == label
        quiet(cal.partial_fit, X[rows], Y[rows], **(SIMS if k == 0 else {}))
    return cal


@pytest.mark.slow
@pytest.mark.parametrize(
    ("uncertainty", "batches", "mean_tol", "sd_tol"),
    [
        # Propagated, one fit on all the readings is itself no closer to
        # another with another random_state: its 16 module-2 draws move the
        # means by 0.12 and 0.13 posterior sds and the sds by 3 % (E) and
        # 11 % (k_bearing) (sd over random_state 0-4, this set-up, all the
        # readings, measured; issue 30's Monte Carlo error). The bounds are
        # three sds of the difference of two such fits (sqrt(2) times one).
        # Module 2's update starts over the last posterior, not a first pass.
        ("propagate", FRAME.index.quarter, 0.55, (0.15, 0.5)),
    ],
)
def test_batches_agree_with_one_fit_on_all_of_them(
    uncertainty, batches, mean_tol, sd_tol
):
    # The data are the same (means and counts of all the readings so far);
    # the difference is Monte Carlo error (module 3's chains, module 2's
    # draws).
    labels = np.asarray(batches)
    updated = _in_batches(_calibrator(discrepancy_uncertainty=uncertainty), labels)
    full = quiet(_calibrator(discrepancy_uncertainty=uncertainty).fit, X, Y, **SIMS)
    sd = np.sqrt(np.diag(full.theta_cov_))
    assert np.all(np.abs(updated.theta_mean_ - full.theta_mean_) <= mean_tol * sd)
    ratio = np.sqrt(np.diag(updated.theta_cov_)) / sd
    assert np.all(np.abs(ratio - 1.0) <= sd_tol), ratio
    # the readings and the emulator are those of the one fit
    np.testing.assert_array_equal(updated.y_obs_, full.y_obs_)
    np.testing.assert_array_equal(updated.y_sim_, full.y_sim_)
    history = updated.theta_history_
    assert len(history) == len(np.unique(labels))
    assert history.index[-1] == FRAME.index[-1]
    assert history["n_readings"].iloc[-1] == len(full.y_obs_)


@pytest.mark.slow
def test_monthly_batches_agree_with_one_fit_to_a_tenth_of_a_posterior_sd():
    """The issue's bound, plug-in module 2: 12 monthly batches against one fit
    on all of them, means within 0.1 posterior sd, sds within 10 %.

    With FAST's chains the last update's ESS is 440-640 and the bearing
    stiffness's mean moved by -0.21 to +0.01 sds over random_state 0-4: its
    Monte Carlo error, not the updates'. With LONG's, -0.03 to -0.01 over
    0-2 (means 0.02 and -0.03 sds here, sds 1.00 and 1.05 times). Its heavy
    tail leaves the ratio of its sds a Monte Carlo error of 5.3 % here (from
    the kurtosis and the ESS of both): it is held to three of those."""
    labels = np.asarray(FRAME.index.month)
    params = dict(discrepancy_uncertainty="plug-in", **LONG)
    updated = _in_batches(_calibrator(**params), labels)
    full = quiet(_calibrator(**params).fit, X, Y, **SIMS)
    sd = np.sqrt(np.diag(full.theta_cov_))
    assert np.all(np.abs(updated.theta_mean_ - full.theta_mean_) <= 0.1 * sd)
    ratio = np.sqrt(np.diag(updated.theta_cov_)) / sd
    assert abs(ratio[0] - 1.0) <= 0.1, ratio
    se = np.hypot(
        sd_error(updated.theta_samples_[:, 1], updated.ess_[1]),
        sd_error(full.theta_samples_[:, 1], full.ess_[1]),
    )
    assert abs(ratio[1] - 1.0) <= max(0.1, 3.0 * se), (ratio, se)


def _spied(monkeypatch):
    """The ``n_restarts`` of each search of module 2's mode, as they run."""
    restarts, search = [], pipeline.fit_hyperposterior

    def spy(*args, **kwargs):
        restarts.append(kwargs["n_restarts"])
        return search(*args, **kwargs)

    monkeypatch.setattr(pipeline, "fit_hyperposterior", spy)
    return restarts


def test_an_update_searches_module_2_from_the_last_mode_until_the_data_grow(
    monkeypatch,
):
    """A day added to a fortnight starts module 2's search at the last mode
    alone (a fifteenth more values); its restarts run again once the data
    hold a tenth more values than when they last ran (the rest of January:
    more than as many again)."""
    restarts = _spied(monkeypatch)
    month, day = FRAME.index.month, FRAME.index.day
    fortnight = (month == 1) & (day <= 14)
    two = quiet(_calibrator().partial_fit, X[fortnight], Y[fortnight], **SIMS)
    assert restarts == [2, 2]  # the fit's two passes
    searched = two._modules.searched
    assert searched == int(np.isfinite(Y[fortnight].to_numpy()).sum())
    first = (month == 1) & (day == 15)
    quiet(two.partial_fit, X[first], Y[first])
    assert restarts[2:] == [0] and two._modules.searched == searched
    rest = (month == 1) & (day > 15)
    quiet(two.partial_fit, X[rest], Y[rest])
    assert restarts[3:] == [2]
    assert two._modules.searched == int(np.isfinite(Y[month == 1].to_numpy()).sum())


@pytest.mark.slow
def test_a_day_s_restarts_would_move_theta_by_little(monkeypatch):
    """A day added to half a year, searched from the last mode alone or with
    the restarts: they end on the same ridge (here 0.1 nats higher), theta's
    means within 0.04 posterior sd and its sds within 4.2 % (measured; held
    to the issue's monthly bound)."""
    restarts = _spied(monkeypatch)
    month, day = FRAME.index.month, FRAME.index.day
    half = quiet(_calibrator().partial_fit, X[month <= 6], Y[month <= 6], **SIMS)
    blob = pickle.dumps(half)
    first = (month == 7) & (day == 1)
    quiet(half.partial_fit, X[first], Y[first])
    monkeypatch.setattr(pipeline, "RESTART_GROWTH", -1.0)  # restarts always
    again = quiet(pickle.loads(blob).partial_fit, X[first], Y[first])
    assert restarts == [2, 2, 0, 2]
    sd = np.sqrt(np.diag(half.theta_cov_))
    assert np.all(np.abs(again.theta_mean_ - half.theta_mean_) <= 0.1 * sd)
    ratio = np.sqrt(np.diag(again.theta_cov_)) / sd
    assert np.all(np.abs(ratio - 1.0) <= 0.1), ratio


def test_first_call_is_fit_and_history_labels_each_update():
    days = FRAME.index.day
    january = (FRAME.index.month == 1) & (days <= 7)  # its first week
    first = quiet(_calibrator().partial_fit, X[january], Y[january], **SIMS)
    fitted = quiet(_calibrator().fit, X[january], Y[january], **SIMS)
    np.testing.assert_array_equal(first.theta_samples_, fitted.theta_samples_)
    week = (FRAME.index.month == 2) & (days <= 7)
    quiet(first.partial_fit, X[week], Y[week])
    history = first.theta_history_
    assert list(history.index) == [FRAME.index[january][-1], FRAME.index[week][-1]]
    assert history.index.name == "until"
    assert list(history.columns[:4]) == ["n_readings", "n_means", "E_mean", "E_sd"]
    np.testing.assert_array_equal(history["n_readings"], [168, 168 + 168])
    row = history.iloc[-1]
    assert row["E_2.5%"] < row["E_mean"] < row["E_97.5%"]
    assert row["E_mean"] == first.theta_mean_[0]
    # a fit that fails leaves the record as it was; one that runs starts it
    with pytest.raises(ValueError, match="sample"):
        first.fit(X[:1], Y[:1], **SIMS)
    assert len(first.theta_history_) == 2 and len(first._history) == 2
    quiet(first.fit, X[week], Y[week], **SIMS)
    assert len(first.theta_history_) == 1


def test_repeated_inputs_count_once_in_the_cost():
    days = slice(0, 72)
    cal = _calibrator(bin_width=None, discrepancy_uncertainty="plug-in")
    quiet(cal.fit, X[days], Y[days], **SIMS)
    n_means = cal.theta_history_["n_means"].iloc[-1]
    # Three days' temperatures to 0.1 degC: 56, fewer than their 72 hours
    assert n_means == len(np.unique(X[days].to_numpy())) == 56
    assert cal.global_model_.base.n == n_means


def test_bad_batches_are_refused():
    cal = quiet(_calibrator().partial_fit, X[:200], Y[:200], **SIMS)
    with pytest.raises(ValueError, match="pass simulations to the first call"):
        cal.partial_fit(X[200:300], Y[200:300], **SIMS)
    with pytest.raises(ValueError, match=r"has columns \['f1', 'f2', 'f3', 'g'\]"):
        cal.partial_fit(X[200:300], Y[200:300].rename(columns={"f4": "g"}))
    with pytest.raises(ValueError, match="feature names"):
        cal.partial_fit(X[200:300].rename(columns={"temperature": "T"}), Y[200:300])
    with pytest.raises(ValueError, match="not a table"):
        cal.partial_fit(X[200:300], Y[200:300].to_numpy())
    with pytest.raises(ValueError, match="row labels"):
        cal.partial_fit(X[200:300], Y[201:301])
    # a batch whose columns come in another order is matched by name; its
    # hours without any reading are reported, by their row in the record
    reordered = Y[200:300][["f4", "f2", "f3", "f1"]].copy()
    reordered.iloc[[5, 6]] = np.nan
    message = r"2 row\(s\) of y have no measured response .* rows \[205, 206\]"
    with pytest.warns(UserWarning, match=message):
        quiet(cal.partial_fit, X[200:300], reordered)
    expected = Y[200:300].to_numpy()
    np.testing.assert_array_equal(cal.y_obs_[-98:], np.delete(expected, [5, 6], 0))
    # and not again by the next update
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cal.partial_fit(X[300:400], Y[300:400])
    assert not [w for w in caught if "no measured response" in str(w.message)]
