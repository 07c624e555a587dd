"""Refits under a stated class of discrepancy priors (prior_sensitivity)."""

import warnings

import numpy as np
import pytest

from skmba import ModularBayesCalibrator
from skmba.calibration._sensitivity import prior_variants
from validation.cases import case_a1, case_freq


def test_prior_variants_scale_the_users_prior():
    got = dict(prior_variants({"sd_scale": 0.2}, "propagate", 10.0, 4.0))
    assert list(got) == [
        "default", "roughness/10", "roughness*10", "sd_scale/4", "sd_scale*4"
    ]  # fmt: skip
    assert got["default"] == {"sd_scale": 0.2}
    np.testing.assert_allclose(got["roughness/10"]["roughness"], (0.01, 0.9))
    np.testing.assert_allclose(got["roughness*10"]["roughness"], (1.0, 90.0))
    assert got["sd_scale/4"] == {"sd_scale": pytest.approx(0.05)}
    assert got["sd_scale*4"]["sd_scale"] == pytest.approx(0.8)
    # plug-in: the variance range by the factor's square; no roughness range,
    # no roughness variants
    plug = dict(prior_variants({"roughness": None}, "plug-in", 10.0, 2.0))
    assert list(plug) == ["default", "variance/2", "variance*2"]
    np.testing.assert_allclose(plug["variance*2"]["variance"], (4e-2, 80.0))
    # one sd_scale per response is scaled as a whole
    per = dict(prior_variants({"sd_scale": [0.5, 0.1]}, "propagate", 10.0, 4.0))
    np.testing.assert_allclose(per["sd_scale*4"]["sd_scale"], [2.0, 0.4])


def _fit(case, **params):
    cal = ModularBayesCalibrator(prior=case.prior, random_state=0, **params)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return cal.fit(case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim,
                       y_sim=case.y_sim)  # fmt: skip


@pytest.fixture(scope="module")
def a1():
    case = case_a1(0)
    cal = _fit(case)
    return case, cal, cal.prior_sensitivity()


def test_rows_are_the_fit_and_refits_with_the_stated_priors(a1):
    # The default row is the fit's own posterior; a variant's row is a fit
    # with that discrepancy_prior from scratch (same settings and seed).
    case, cal, tab = a1
    assert list(tab.columns) == [
        "mean", "sd", "2.5%", "97.5%", "sd_ratio", "shift", "r_hat", "prior_share"
    ]  # fmt: skip
    row = tab.loc["default[theta0]"]
    samples = cal.theta_samples_[:, 0]
    assert row["mean"] == pytest.approx(np.mean(samples), rel=1e-12)
    assert row["sd"] == pytest.approx(np.std(samples, ddof=1), rel=1e-12)
    assert row["sd_ratio"] == 1.0 and row["shift"] == 0.0
    assert np.isnan(row["r_hat"])  # quadrature
    other = _fit(case, discrepancy_prior={"roughness": (1.0, 90.0)}).theta_samples_
    row = tab.loc["roughness*10[theta0]"]
    assert row["mean"] == pytest.approx(np.mean(other), rel=1e-12)
    assert row["97.5%"] == pytest.approx(np.quantile(other, 0.975), rel=1e-12)
    ratio = np.std(other, ddof=1) / np.std(samples, ddof=1)
    assert row["sd_ratio"] == pytest.approx(ratio, rel=1e-12)
    ((lo, hi),) = cal.prior_.bounds(0.95)
    width = np.subtract(*np.quantile(other, [0.975, 0.025]))
    assert row["prior_share"] == pytest.approx(width / (hi - lo), rel=1e-12)


def test_union_is_the_range_over_the_class(a1):
    # The last row: the union of the five intervals (robust Bayes over the
    # stated class), its width against the prior's central 95 %.
    _, cal, tab = a1
    assert list(tab.index)[-1] == "union[theta0]"
    variants = tab.iloc[:-1]
    union = tab.loc["union[theta0]"]
    assert union["2.5%"] == variants["2.5%"].min()
    assert union["97.5%"] == variants["97.5%"].max()
    ((lo, hi),) = cal.prior_.bounds(0.95)
    width = union["97.5%"] - union["2.5%"]
    assert union["prior_share"] == pytest.approx(width / (hi - lo), rel=1e-12)
    assert np.isnan(union[["mean", "sd", "sd_ratio", "shift", "r_hat"]]).all()
    # wider than the fit's own, narrower than the prior on a1 seed 0
    assert (
        union["97.5%"] - union["2.5%"]
        > tab.loc["default[theta0]", "97.5%"] - (tab.loc["default[theta0]", "2.5%"])
    )
    assert 0 < union["prior_share"] < 1


def test_a_confounded_interval_moves_with_the_roughness_prior(a1):
    # a1 (E confounded with a discrepancy proportional to the response): the
    # interval is set by the roughness range (measured, seed 0: sd ratios
    # 1.85 and 0.29 at roughness /10 and *10; 16-draw Monte Carlo spread of
    # the sd about 20 %).
    _, _, tab = a1
    assert tab.loc["roughness/10[theta0]", "sd_ratio"] > 1.4
    assert tab.loc["roughness*10[theta0]", "sd_ratio"] < 0.5


def test_an_identified_interval_barely_moves():
    # freq (theta sets a frequency): the data set the width (measured, seed 0:
    # sd ratios 0.94-1.34 over the four priors, shifts within 0.4 sd).
    tab = _fit(case_freq(0)).prior_sensitivity()
    variants = tab.drop(index="union[theta0]")
    ratios = variants["sd_ratio"].to_numpy()
    assert np.all((ratios > 0.75) & (ratios < 1.5))
    assert np.all(np.abs(variants["shift"].to_numpy()) < 0.6)
    # the range over the class: about the fit's own interval
    own = variants.loc["default[theta0]"]
    union = tab.loc["union[theta0]"]
    assert union["prior_share"] < 2 * own["prior_share"]


@pytest.mark.parametrize("bad", [1.0, 0.5, np.nan, "10"])
def test_factors_must_exceed_one(a1, bad):
    _, cal, _ = a1
    with pytest.raises(ValueError, match="roughness_factor must be a number > 1"):
        cal.prior_sensitivity(roughness_factor=bad)
