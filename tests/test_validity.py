"""The validity suite ``benchmarks/validity.py``: its helpers and a pinned subset.

The fast tests check the summary helpers on known numbers (the Wilson
interval against Newcombe 1998 and its formula, the rank histogram and its
tests, the thinning of posterior draws). The slow test runs a small
fixed-seed subset of the suite (a1 and freq, 4 seeds each) and pins
today's behaviour of the calibrator's defaults with tolerances that catch a
regression: see ``docs/validity.rst`` for the full study.
"""

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCHMARKS))

import _validity_cases  # noqa: E402
import validity  # noqa: E402


def wilson_by_formula(k, n, level=0.95):
    """Wilson (1927) score interval, as written in Newcombe (1998), eq. 3:
    (2 n p + z^2 -+ z sqrt(z^2 + 4 n p q)) / (2 (n + z^2))."""
    z = stats.norm.ppf(0.5 + level / 2)
    p = k / n
    centre = 2 * n * p + z**2
    half = z * math.sqrt(z**2 + 4 * n * p * (1 - p))
    return (centre - half) / (2 * (n + z**2)), (centre + half) / (2 * (n + z**2))


# Newcombe, R. G. (1998), Two-sided confidence intervals for the single
# proportion: comparison of seven methods, Statistics in Medicine 17, 857-872,
# Table I, method 3 (score interval without continuity correction).
NEWCOMBE_TABLE_I = [
    ((81, 263), (0.2553, 0.3662)),
    ((15, 148), (0.0624, 0.1605)),
    ((0, 20), (0.0, 0.1611)),
    ((1, 29), (0.0061, 0.1718)),
]


@pytest.mark.parametrize(("kn", "expected"), NEWCOMBE_TABLE_I)
def test_wilson_interval_matches_newcombe(kn, expected):
    low, high = validity.wilson_interval(*kn)
    assert (round(low, 4), round(high, 4)) == expected
    np.testing.assert_allclose((low, high), wilson_by_formula(*kn), atol=1e-12)


def test_wilson_interval_against_statsmodels_if_installed():
    proportion = pytest.importorskip("statsmodels.stats.proportion")
    for k, n in [(19, 20), (20, 20), (48, 50), (3, 7)]:
        expected = proportion.proportion_confint(k, n, method="wilson")
        np.testing.assert_allclose(validity.wilson_interval(k, n), expected)


def test_wilson_interval_edges():
    low, high = validity.wilson_interval(20, 20)
    assert high == pytest.approx(1.0) and low == pytest.approx(0.8389, abs=1e-4)
    assert all(np.isnan(validity.wilson_interval(0, 0)))


def test_mean_interval_is_the_t_interval_over_seeds():
    values = np.array([0.96, 0.9, 0.98, 0.82, 0.94, 1.0])
    expected = stats.t.interval(
        0.95, len(values) - 1, loc=values.mean(), scale=stats.sem(values)
    )
    np.testing.assert_allclose(validity.mean_interval(values), expected, rtol=1e-12)
    assert validity.mean_interval([0.9]) == (0.9, 0.9)


def test_rms_and_bins():
    assert validity.rms([3.0, -4.0]) == pytest.approx(math.sqrt(12.5))
    np.testing.assert_allclose(validity.rms([[1.0, 2.0], [-1.0, 0.0]]), [1, 2**0.5])
    assert [validity.n_rank_bins(n) for n in (3, 20, 49, 200)] == [2, 4, 9, 10]


def test_rank_histogram_shares_and_counts():
    counts, share = validity.rank_histogram([0, 25, 26, 50, 100], n_rank=100, n_bins=4)
    # 101 possible ranks in 4 bins: 0-25, 26-50, 51-75, 76-100
    np.testing.assert_array_equal(counts, [2, 2, 0, 1])
    np.testing.assert_allclose(share, np.array([26, 25, 25, 25]) / 101)
    assert share.sum() == pytest.approx(1.0)


def test_rank_tests_on_uniform_and_on_a_hump():
    uniform = np.arange(101)  # every rank once: a perfectly flat histogram
    chi2, ks = validity.rank_tests(uniform, n_rank=100)
    assert chi2 > 0.99 and ks > 0.99
    hump = np.full(40, 50)  # theta* always at the posterior median
    chi2, ks = validity.rank_tests(hump, n_rank=100)
    assert chi2 < 1e-6 and ks < 1e-6
    assert all(np.isnan(validity.rank_tests([3], n_rank=100)))


def test_thinned_quantiles_give_uniform_ranks():
    # sorted stratified draws of U(0, 1), like the quadrature posterior
    samples = ((np.arange(5000) + 0.5) / 5000)[:, None]
    draws = validity.thinned(samples, 100)
    assert draws.shape == (100, 1)
    truths = (np.arange(101) + 0.5) / 101  # one theta* per rank cell
    ranks = [int(np.sum(draws[:, 0] < t)) for t in truths]
    assert ranks == list(range(101))


def test_summarise_and_tables_on_synthetic_records():
    def record(seed, covered, z, rank, ok=True):
        r = {"case": "a1", "seed": seed, "ok": ok, "error": "", "seconds": 1.0}
        r["warning_categories"] = ["UserWarning"] if seed == 0 else []
        r["warning_messages"] = ["something"] if seed == 0 else []
        if not ok:
            r["error"] = "LinAlgError: singular"
            return r
        one = np.array
        r.update(
            theta_true=one([1.0]), theta_mean=one([1.0 + z]), theta_sd=one([1.0]),
            prior_sd=one([1.0 if seed else 2.0]),
            lo=one([0.0]), hi=one([2.0]), covered=one([covered]), z=one([z]),
            rank=one([rank]), cover_reality=0.9, cover_obs=1.0, cover_obs_draw=0.98,
            noise_ratio=one([1.0, 0.5]), identifiability=one([np.nan]),
            covered_robust=one([True]), robust_width=one([3.0 + seed]),
            fit_seconds=1.0,
        )  # fmt: skip
        return r

    records = [record(0, True, 1.0, 10), record(1, False, -3.0, 90)]
    records.append(record(2, True, 0.0, 0, ok=False))
    s = validity.summarise(records, n_rank=100)["a1"]
    assert (s["n"], s["n_ok"], s["n_failed"]) == (3, 2, 1)
    assert s["covered"].tolist() == [1]
    assert s["covered_robust"].tolist() == [2]
    np.testing.assert_allclose(s["robust_width"], [3.5])
    np.testing.assert_allclose(s["rms_z"], [math.sqrt(5.0)])
    assert s["warnings"] == {"UserWarning": 1}
    assert s["cover_reality"] == pytest.approx(0.9)
    assert s["cover_obs_draw"] == pytest.approx(0.98)
    np.testing.assert_allclose(s["noise_ratio"], [1.0, 0.5])
    assert s["prior_like"].tolist() == [1]  # seed 1: posterior sd = prior sd
    table = validity.format_tables({"a1": s})
    assert "1/2" in table and "2.24" in table and "UserWarning 1" in table
    assert "+1 failed" in table and "LinAlgError" in table


def test_observation_coverage_is_the_chance_of_a_fresh_draw():
    # An interval of the right centre and width holds 95 % of fresh draws.
    np.testing.assert_allclose(
        validity.observation_coverage(2.0, 0.3, 2.0, 0.3), 0.95, atol=1e-12
    )
    # Off centre, too wide or too narrow: against the share of many fresh
    # draws (the estimate it replaces), per input and response.
    rng = np.random.default_rng(0)
    truth = rng.normal(size=(5, 2))
    noise_sd = np.array([0.5, 2.0])
    mean = truth + rng.normal(size=(5, 2)) * noise_sd
    std = rng.uniform(0.3, 1.5, size=(5, 2)) * noise_sd
    exact = validity.observation_coverage(mean, std, truth, noise_sd)
    draws = truth + rng.normal(size=(200_000, 5, 2)) * noise_sd
    share = np.mean(np.abs(draws - mean) <= validity.Z_LEVEL * std, axis=0)
    se = np.sqrt(exact * (1 - exact) / 200_000)
    assert np.all(np.abs(share - exact) <= 4 * se + 1e-12)
    assert exact.shape == (5, 2) and np.all((exact > 0) & (exact < 1))
    # the one-draw estimate is one of those draws, seeded by the replicate
    one = validity.fresh_observations(truth, noise_sd, seed=3)
    again = validity.fresh_observations(truth, noise_sd, seed=3)
    np.testing.assert_array_equal(one, again)


def test_cases_build_the_documented_problems():
    a2 = _validity_cases.case_a2(0)
    X, y, X_sim, theta_sim, y_sim, prior, theta_true, reality_fn, noise_sd = a2
    assert X.shape == (20, 1) and y.shape == (20, 2) and y_sim.shape == (60, 2)
    np.testing.assert_allclose(theta_true, [2.0, 1.6])
    assert [d.support() for d in prior] == [(1.0, 3.0), (1.0, 3.0)]
    np.testing.assert_allclose(_validity_cases.quadratic_model(X_sim, theta_sim), y_sim)
    # 30 dB: noise variance = variance of the noise-free response / 1000
    np.testing.assert_allclose(noise_sd**2, reality_fn(X).var(axis=0) / 1e3)
    b2 = _validity_cases.case_b2(0)
    diff = b2.reality_fn(X) - reality_fn(X)
    np.testing.assert_allclose(diff[:, 0], 0.2 * np.sin(2 * np.pi * X[:, 0]))
    np.testing.assert_allclose(diff[:, 1], 0.0)
    a1, b1 = _validity_cases.case_a1(0), _validity_cases.case_b1(0)
    bump = b1.reality_fn(a1.X) - a1.reality_fn(a1.X)
    assert 0.0 < bump[:, 0].max() <= 0.1 and np.all(bump[:, 1] == 0.0)
    model = make_model_of_a1()
    np.testing.assert_allclose(a1.reality_fn(a1.X), model(a1.X, [[70e3]] * 25))
    for name in ("sbc_a1", "sbc_a2"):
        thetas = [_validity_cases.CASES[name].build(s).theta_true for s in range(3)]
        assert len({tuple(t) for t in thetas}) == 3  # drawn per seed


def test_sbc_cases_draw_everything_from_the_default_priors():
    registry = validity.cases()
    assert {"sbc_a1", "sbc_a2", "sbc0_a1", "sbc0_a2"} <= set(registry)
    for name, model in (("sbc_a1", make_model_of_a1()), ("sbc_a2", None)):
        spec = registry[name]
        one, again = spec.build(3), spec.build(3)
        np.testing.assert_array_equal(one.y, again.y)  # a function of the seed
        model = model or _validity_cases.quadratic_model
        theta = np.tile(one.theta_true, (len(one.X), 1))
        delta = one.reality_fn(one.X) - model(one.X, theta)
        assert np.all(np.abs(delta) > 0)  # a discrepancy is drawn
        # ... of the size its prior gives, in units of the simulations' spread
        assert np.all(delta.std(axis=0) < 5 * one.y_sim.std(axis=0))
        resid = one.y - one.reality_fn(one.X)
        assert np.all(resid.std(axis=0) < 4 * one.noise_sd)
        thetas = [spec.build(s).theta_true for s in range(3)]
        assert len({tuple(t) for t in thetas}) == 3


def make_model_of_a1():
    from skmba.datasets import make_cantilever

    return make_cantilever(random_state=0).simulator


@pytest.mark.slow
def test_validity_subset_pins_todays_defaults():
    """a1 and freq, 4 seeds each, on 2 processes (about 30 s on 2 idle cores)."""
    records = validity.run(
        ["a1", "freq"], {"a1": 4, "freq": 4}, n_jobs=2, progress=False
    )
    summary = validity.summarise(records)
    a1, freq = summary["a1"], summary["freq"]
    assert a1["n_failed"] == 0 and freq["n_failed"] == 0
    # a1 is confounded by design: the warning fires in every seed, with
    # identifiability_ far below the threshold, and the prior-set intervals
    # cover (rms z below 1.25, the bound for confounded designs).
    assert a1["warnings"].get("NonIdentifiabilityWarning", 0) == 4
    assert a1["covered"].tolist() == [4] and a1["rms_z"][0] < 1.25
    ident = [r["identifiability"][0] for r in records if r["case"] == "a1"]
    assert max(ident) < 0.05
    # ...and the robust interval, across plausible model errors, is many
    # times wider and covers too.
    assert a1["covered_robust"].tolist() == [4] and a1["robust_width"][0] > 5
    # freq is identifiable: no warning, every seed sharp (the data, not the
    # prior, set the width: sd ~0.002 of a prior sd of 0.58) and covered.
    assert freq["warnings"].get("NonIdentifiabilityWarning", 0) == 0
    assert freq["covered"].tolist() == [4] and 0.3 < freq["rms_z"][0] < 2.0
    sd = np.array([r["theta_sd"][0] for r in records if r["case"] == "freq"])
    assert np.all(sd < 0.01)
    ident = [r["identifiability"][0] for r in records if r["case"] == "freq"]
    assert min(ident) > 0.5
    # Identified whatever the model error: the robust interval is about the
    # posterior's.
    assert freq["covered_robust"].tolist() == [4]
    assert 0.5 < freq["robust_width"][0] < 2.0
    # the reality is well predicted; new observations are covered near
    # their level: the exact probability over these 4 seeds is 0.930 (a1)
    # and 0.959 (freq), the share of one fresh draw per input 0.95, 0.97
    assert a1["cover_reality"] > 0.85 and freq["cover_reality"] > 0.85
    assert a1["cover_obs"] > 0.9 and freq["cover_obs"] > 0.9
    assert a1["cover_obs_draw"] > 0.85 and freq["cover_obs_draw"] > 0.85
