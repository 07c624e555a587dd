"""ChangeDetector on the monitored bridge: quiet on other weeks of the same
bridge, alarmed by a stiffness loss that it puts on the deck; reusing a
fitted calibrator's simulations; bad batches refused with the fix named."""

import copy
import warnings

import numpy as np
import pytest
from scipy import optimize, stats
from sklearn.exceptions import NotFittedError

from skmba import ChangeDetector, ModularBayesCalibrator
from skmba.datasets import make_bridge_monitoring

WEEK = 168
REFERENCE = make_bridge_monitoring(n_hours=24 * 60, random_state=0)
SIMS = dict(X_sim=REFERENCE.X_sim, theta_sim=REFERENCE.theta_sim, y_sim=REFERENCE.y_sim)


def _calibrator():
    return ModularBayesCalibrator(
        prior=REFERENCE.prior,
        discrepancy_uncertainty="plug-in",
        bin_width=1.0,
        n_samples=1000,
        burn_in=300,
        random_state=0,
    )


def _quiet(call, *args, **kwargs):
    # E and the bearings are confounded with the discrepancy on a
    # temperature-only design (the identifiability warning says so).
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return call(*args, **kwargs)


@pytest.fixture(scope="module")
def detector():
    det = ChangeDetector(_calibrator(), bin_width=0.5)
    return _quiet(det.fit, REFERENCE.X_obs, REFERENCE.y_obs, **SIMS)


def _weeks(data, n):
    return [
        (data.X_obs[k * WEEK : (k + 1) * WEEK], data.y_obs[k * WEEK : (k + 1) * WEEK])
        for k in range(n)
    ]


def test_fitted_attributes(detector):
    assert detector.parameter_names_ == ["E", "k_bearing"]
    np.testing.assert_array_equal(
        detector.theta_reference_,
        np.median(detector.calibrator_.theta_samples_, axis=0),
    )
    assert detector.n_features_in_ == 1


def test_weeks_of_the_unchanged_bridge_look_like_the_reference(detector):
    # The same months of another year (other weather and noise): the score
    # statistics of 8 weeks sum to a chi-squared with 16 degrees of freedom.
    other = make_bridge_monitoring(n_hours=24 * 56, random_state=1)
    evidence = [detector.evidence(X, y) for X, y in _weeks(other, 8)]
    total = sum(ev.statistic for ev in evidence)
    degrees = sum(ev.degrees for ev in evidence)
    assert degrees == 16
    assert stats.chi2.ppf(0.001, degrees) < total < stats.chi2.ppf(0.999, degrees)
    # Not tested here: residual_statistic and misfit_statistic run about
    # 14 % above their chi-squared means on these weeks (6 % without batch
    # bins): the reference's covariance of reality is too small by that
    # much, measured and documented in docs/change_detection.rst.


def _effective_change(data):
    """Relative change of (E, k_bearing) that the exact model reads between
    the healthy and the damaged bridge at ``data``'s temperatures."""
    X, sd, theta = data.X_obs, data.noise_sd, np.asarray(data.theta_true)

    def fitted(target):
        def residuals(log_ratio):
            rows = np.tile(theta * np.exp(log_ratio), (len(X), 1))
            return ((data.simulator(X, rows) - target) / sd).ravel()

        return np.exp(optimize.least_squares(residuals, [0.0, 0.0]).x)

    healthy = fitted(data.reality(X))
    return fitted(data.damage["reality"](X)) / healthy - 1.0


def test_a_stiffness_loss_is_detected_and_put_on_the_deck(detector):
    damaged = make_bridge_monitoring(
        n_hours=WEEK, damage_size=0.1, damage_start=0, random_state=2
    )
    X, y = damaged.X_obs, damaged.y_obs
    assert detector.predict(X, y) == -1
    assert detector.decision_function(X, y) < 0
    report = detector.report(X, y)
    assert list(report.columns) == [
        "mean",
        "sd",
        "2.5%",
        "97.5%",
        "p_exceeds",
        "log10_bf",
    ]
    e = report.loc["E"]
    # The deck softened: one element of 20 lost 10 % of its stiffness, which
    # the model, with one modulus for the whole deck, reads as a loss of
    # well under 2 % of the deck's effective E.
    assert e["97.5%"] < 0 and e["2.5%"] > -0.02
    assert report["log10_bf"].idxmax() == "E"
    # The change the model itself reads: its (E, k_bearing) fitted by least
    # squares to the noise-free damaged and healthy frequencies of the week.
    effective = _effective_change(damaged)
    assert -0.0085 < effective[0] < -0.007
    # The detector reads it through the emulator of 60 simulations, whose
    # error (not in the report's sd) moves the reading by up to 0.2 % of E:
    # -0.71 % and -0.90 % with emulators of log-likelihood 292.2 and 295.8
    # (theta_0 the posterior mean). From the posterior median (theta_0 now)
    # -0.90 % with the second; from the mean, which follows the chains'
    # draws of k_bearing's tail, it was -1.39 % on another processor.
    assert abs(e["mean"] - effective[0]) < 0.002
    # Below the default 1 % threshold with posterior probability above 99 %,
    # surely above 0.1 % (the normal tails, against the dense formula).
    assert e["p_exceeds"] < 0.01
    lowered = copy.deepcopy(detector).set_params(threshold=0.001)
    e_low = lowered.report(X, y).loc["E"]
    z = (0.001 + e_low["mean"]) / e_low["sd"]
    assert e_low["p_exceeds"] == pytest.approx(stats.norm.sf(z), abs=1e-12)
    assert e_low["p_exceeds"] > 0.999


def test_a_refitted_discrepancy_absorbs_much_of_a_change(detector):
    # With a discrepancy of its own the current state can explain a
    # change by it: weaker evidence than with the reference's carried over.
    # The reference is the same: set_params after fit, no new calibration.
    damaged = make_bridge_monitoring(
        n_hours=WEEK, damage_size=0.1, damage_start=0, random_state=2
    )
    refit = copy.deepcopy(detector).set_params(discrepancy="refit")
    carry_T = detector.evidence(damaged.X_obs, damaged.y_obs).statistic
    refit_T = refit.evidence(damaged.X_obs, damaged.y_obs).statistic
    assert refit_T < 0.5 * carry_T


def test_a_fitted_calibrator_lends_its_simulations(detector):
    # The simulations of the fitted calibrator, not a run of a simulator;
    # the same settings and data: the same reference.
    det = ChangeDetector(detector.calibrator_, bin_width=0.5)
    _quiet(det.fit, REFERENCE.X_obs, REFERENCE.y_obs)
    np.testing.assert_array_equal(det.calibrator_.X_sim_, REFERENCE.X_sim)
    np.testing.assert_allclose(
        det.theta_reference_, detector.theta_reference_, rtol=1e-12
    )


def test_bad_use_is_refused_with_the_fix(detector):
    pytest.importorskip("pandas")
    X, y = REFERENCE.X_obs[:WEEK], REFERENCE.y_obs[:WEEK]
    with pytest.raises(NotFittedError):
        ChangeDetector(_calibrator()).predict(X, y)
    with pytest.raises(ValueError, match="no finite reading"):
        detector.predict(X, np.full_like(y, np.nan))
    with pytest.raises(ValueError, match="responses"):
        detector.predict(X, y[:, :3])
    with pytest.raises(ValueError, match="alpha"):
        ChangeDetector(_calibrator(), alpha=1.5).fit(REFERENCE.X_obs, REFERENCE.y_obs)
    with pytest.raises(TypeError, match="calibrator"):
        ChangeDetector("calibrator").fit(REFERENCE.X_obs, REFERENCE.y_obs)
    with pytest.raises(ValueError, match="discrepancy"):
        ChangeDetector(_calibrator(), discrepancy="new").fit(X, y)
    with pytest.raises(ValueError, match="alpha"):  # checked per batch too
        copy.deepcopy(detector).set_params(alpha=0.0).predict(X, y)
    framed = ChangeDetector(_calibrator(), bin_width=0.5)
    frame = REFERENCE.frame
    _quiet(framed.fit, frame[["temperature"]], frame[["f1", "f2", "f3", "f4"]], **SIMS)
    week = frame.iloc[:WEEK]
    responses = week[["f1", "f2", "f3", "f4"]]
    with pytest.raises(ValueError, match="lacks"):
        framed.predict(week[["temperature"]], responses.rename(columns={"f4": "g4"}))
    with pytest.raises(ValueError, match="feature names"):
        framed.predict(
            week[["temperature"]].rename(columns={"temperature": "T"}), responses
        )
    # columns in another order are matched by name
    assert framed.predict(
        week[["temperature"]], week[["f4", "f3", "f2", "f1"]]
    ) == framed.predict(week[["temperature"]], week[["f1", "f2", "f3", "f4"]])


def test_scan_is_one_evidence_per_batch_and_skips_a_dead_logger(detector):
    pd = pytest.importorskip("pandas")
    other = make_bridge_monitoring(n_hours=4 * WEEK, random_state=3)
    frame = other.frame.copy()
    frame.iloc[WEEK : 2 * WEEK, 1:] = np.nan  # the second week lost
    X, y = frame[["temperature"]], frame[["f1", "f2", "f3", "f4"]]
    scan = detector.scan(X.to_numpy(), y.to_numpy(), batch_size=WEEK)
    assert len(scan) == 3
    assert list(scan.index) == [0, 2 * WEEK, 3 * WEEK]
    last = detector.evidence(other.X_obs[3 * WEEK :], other.y_obs[3 * WEEK :])
    assert scan["p_value"].iloc[-1] == pytest.approx(last.p_value, rel=1e-12)
    assert scan["E_mean"].iloc[-1] == pytest.approx(last.change_mean[0], rel=1e-12)
    assert list(scan["changed"]) == list(scan["p_value"] < detector.alpha)
    assert scan["n_readings"].iloc[0] == np.isfinite(other.y_obs[:WEEK]).any(1).sum()
    assert isinstance(scan, pd.DataFrame)
    with pytest.raises(ValueError, match="batch_size"):
        detector.scan(X.to_numpy(), y.to_numpy(), batch_size=0)


def test_a_confounded_design_still_sees_a_change_of_the_effective_parameter():
    # The cantilever on its unmodelled spring: the data cannot tell E from
    # the spring (the reference's interval of E is several per cent wide),
    # yet a 5 % loss of E, the spring unchanged, moves the readings along
    # E's direction, which the batch sees to well under a per cent.
    from skmba.datasets import make_cantilever

    ref = make_cantilever(snr_db=30, random_state=0)
    cal = ModularBayesCalibrator(prior=ref.prior, random_state=0)
    det = ChangeDetector(cal, simulator=ref.simulator)
    _quiet(
        det.fit,
        ref.X_obs,
        ref.y_obs,
        X_sim=ref.X_sim,
        theta_sim=ref.theta_sim,
        y_sim=ref.y_sim,
    )
    reference_sd = np.sqrt(det.calibrator_.theta_cov_[0, 0]) / det.theta_reference_[0]
    assert reference_sd > 0.015
    damaged = make_cantilever(snr_db=30, E_true=0.95 * 70e3, random_state=4)
    e = det.report(damaged.X_obs, damaged.y_obs).iloc[0]  # the one parameter, E
    assert det.predict(damaged.X_obs, damaged.y_obs) == -1
    assert e["sd"] < 0.5 * reference_sd
    # E_eff = 1 / (1 / E + c): a 5 % loss of E is a 4.8 % loss of E_eff here.
    assert e["2.5%"] < -0.048 < e["97.5%"]


def test_clone_and_pickle(detector):
    import pickle

    from sklearn.base import clone

    fresh = clone(detector)
    assert fresh.get_params()["bin_width"] == 0.5 and not hasattr(fresh, "calibrator_")
    again = pickle.loads(pickle.dumps(detector))
    X, y = REFERENCE.X_obs[-WEEK:], REFERENCE.y_obs[-WEEK:]
    assert again.evidence(X, y).statistic == detector.evidence(X, y).statistic
