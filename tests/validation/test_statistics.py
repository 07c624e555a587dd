"""The statistics of the validity suite (``validation/statistics.py``).

Checked on known numbers: the Wilson interval against Newcombe 1998 and its
formula, the t-interval of a mean coverage, the rank histogram and its
tests, the thinning of posterior draws, and the exact coverage of new
observations against many fresh draws; and the module's docstring examples
(``validation/`` is outside the doctest paths of ``pyproject.toml``).
"""

import doctest
import math

import numpy as np
import pytest
from scipy import stats

from validation import statistics
from validation.statistics import (
    Z_LEVEL,
    fresh_observations,
    mean_interval,
    n_rank_bins,
    observation_coverage,
    rank_histogram,
    rank_tests,
    rms,
    rms_band,
    spread_ratio,
    thinned,
    wilson_interval,
)


def test_docstring_examples():
    failed, attempted = doctest.testmod(
        statistics, optionflags=doctest.NORMALIZE_WHITESPACE
    )
    assert attempted >= 2 and failed == 0


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
    low, high = wilson_interval(*kn)
    assert (round(low, 4), round(high, 4)) == expected
    np.testing.assert_allclose((low, high), wilson_by_formula(*kn), atol=1e-12)


def test_wilson_interval_against_statsmodels_if_installed():
    proportion = pytest.importorskip("statsmodels.stats.proportion")
    for k, n in [(19, 20), (20, 20), (48, 50), (3, 7)]:
        expected = proportion.proportion_confint(k, n, method="wilson")
        np.testing.assert_allclose(wilson_interval(k, n), expected)


def test_wilson_interval_edges():
    low, high = wilson_interval(20, 20)
    assert high == pytest.approx(1.0) and low == pytest.approx(0.8389, abs=1e-4)
    assert all(np.isnan(wilson_interval(0, 0)))


def test_mean_interval_is_the_t_interval_over_seeds():
    values = np.array([0.96, 0.9, 0.98, 0.82, 0.94, 1.0])
    expected = stats.t.interval(
        0.95, len(values) - 1, loc=values.mean(), scale=stats.sem(values)
    )
    np.testing.assert_allclose(mean_interval(values), expected, rtol=1e-12)
    assert mean_interval([0.9]) == (0.9, 0.9)


def test_rms_and_bins():
    assert rms([3.0, -4.0]) == pytest.approx(math.sqrt(12.5))
    np.testing.assert_allclose(rms([[1.0, 2.0], [-1.0, 0.0]]), [1, 2**0.5])
    assert [n_rank_bins(n) for n in (3, 20, 49, 200)] == [2, 4, 9, 10]


def test_rms_band_is_the_chi_square_range_and_holds_its_level():
    # The ranges quoted in docs/internals.rst for 80 and 24 values.
    np.testing.assert_allclose(rms_band(80), [0.85, 1.15], atol=0.005)
    np.testing.assert_allclose(rms_band(24), [0.72, 1.28], atol=0.005)
    # One value: |z| within [Phi^-1(0.4875), Phi^-1(0.9875)].
    np.testing.assert_allclose(
        rms_band(1), np.abs(stats.norm.ppf([0.4875, 0.9875])), rtol=1e-9
    )
    # Honest z fall inside it at its level (20,000 sets of 24; Monte Carlo
    # error of the share 0.0015).
    z = np.random.default_rng(0).standard_normal((20_000, 24))
    lo, hi = rms_band(24)
    inside = np.mean((rms(z.T) >= lo) & (rms(z.T) <= hi))
    assert abs(inside - 0.95) < 4 * math.sqrt(0.95 * 0.05 / 20_000)


def test_spread_ratio_is_one_for_honest_errors_and_scales_with_them():
    # 8 problems of different means, 30 runs each, normal estimates of sd 2.
    rng = np.random.default_rng(1)
    x = 2.0 * rng.standard_normal((8, 30, 3)) + 50.0 * rng.standard_normal((8, 1, 3))
    honest = np.full_like(x, 2.0)
    ratio, lower, upper = spread_ratio(x, honest)
    assert np.all((lower < 1.0) & (1.0 < upper))
    # Errors reported half as large: the ratio doubles, the interval too.
    half = spread_ratio(x, honest / 2.0)
    for got, want in zip(half, (ratio, lower, upper), strict=True):
        np.testing.assert_allclose(got, 2.0 * want, rtol=1e-12)
    # The formula by hand on one problem of three runs.
    one = np.array([[1.0, 2.0, 6.0]])
    by_hand = math.sqrt(((1 - 3) ** 2 + (2 - 3) ** 2 / 4 + (6 - 3) ** 2) / 2)
    r1, _, _ = spread_ratio(one, np.array([[1.0, 2.0, 1.0]]))
    assert r1 == pytest.approx(by_hand)
    # The interval holds its level: 4,000 sets of 4 x 10 honest estimates
    # (Monte Carlo error of the share 0.0034).
    z = rng.standard_normal((4, 10, 4000))
    lo, hi = spread_ratio(z, np.ones_like(z))[1:]
    inside = np.mean((lo < 1.0) & (1.0 < hi))
    assert abs(inside - 0.95) < 4 * math.sqrt(0.95 * 0.05 / 4000)
    with pytest.raises(ValueError, match="K >= 2"):
        spread_ratio(np.ones((3, 1)), np.ones((3, 1)))


def test_rank_histogram_shares_and_counts():
    counts, share = rank_histogram([0, 25, 26, 50, 100], n_rank=100, n_bins=4)
    # 101 possible ranks in 4 bins: 0-25, 26-50, 51-75, 76-100
    np.testing.assert_array_equal(counts, [2, 2, 0, 1])
    np.testing.assert_allclose(share, np.array([26, 25, 25, 25]) / 101)
    assert share.sum() == pytest.approx(1.0)


def test_rank_tests_on_uniform_and_on_a_hump():
    uniform = np.arange(101)  # every rank once: a perfectly flat histogram
    chi2, ks = rank_tests(uniform, n_rank=100)
    assert chi2 > 0.99 and ks > 0.99
    hump = np.full(40, 50)  # theta* always at the posterior median
    chi2, ks = rank_tests(hump, n_rank=100)
    assert chi2 < 1e-6 and ks < 1e-6
    assert all(np.isnan(rank_tests([3], n_rank=100)))


def test_thinned_quantiles_give_uniform_ranks():
    # sorted stratified draws of U(0, 1), like the quadrature posterior
    samples = ((np.arange(5000) + 0.5) / 5000)[:, None]
    draws = thinned(samples, 100)
    assert draws.shape == (100, 1)
    truths = (np.arange(101) + 0.5) / 101  # one theta* per rank cell
    ranks = [int(np.sum(draws[:, 0] < t)) for t in truths]
    assert ranks == list(range(101))


def test_observation_coverage_is_the_chance_of_a_fresh_draw():
    # An interval of the right centre and width holds 95 % of fresh draws.
    np.testing.assert_allclose(
        observation_coverage(2.0, 0.3, 2.0, 0.3), 0.95, atol=1e-12
    )
    # Off centre, too wide or too narrow: against the share of many fresh
    # draws (the estimate it replaces), per input and response.
    rng = np.random.default_rng(0)
    truth = rng.normal(size=(5, 2))
    noise_sd = np.array([0.5, 2.0])
    mean = truth + rng.normal(size=(5, 2)) * noise_sd
    std = rng.uniform(0.3, 1.5, size=(5, 2)) * noise_sd
    exact = observation_coverage(mean, std, truth, noise_sd)
    draws = truth + rng.normal(size=(200_000, 5, 2)) * noise_sd
    share = np.mean(np.abs(draws - mean) <= Z_LEVEL * std, axis=0)
    se = np.sqrt(exact * (1 - exact) / 200_000)
    assert np.all(np.abs(share - exact) <= 4 * se + 1e-12)
    assert exact.shape == (5, 2) and np.all((exact > 0) & (exact < 1))
    # the one-draw estimate is one of those draws, seeded by the replicate
    one = fresh_observations(truth, noise_sd, seed=3)
    again = fresh_observations(truth, noise_sd, seed=3)
    np.testing.assert_array_equal(one, again)


def test_rank_ecdf_band_known_answers():
    from validation.statistics import rank_ecdf_band

    pytest.importorskip("arviz")
    # Every rank equally often: the ECDF is the uniform's, inside.
    assert rank_ecdf_band(np.repeat(np.arange(101), 2)) == (True, 0.0)
    # Every rank 0 (theta* below every draw): the ECDF is 1 from the start.
    inside, excess = rank_ecdf_band(np.zeros(200, dtype=int))
    assert not inside and excess > 0.9


def test_rank_ecdf_band_holds_its_level():
    # Calibrated ranks fall inside the simultaneous 95 % band at that rate:
    # 400 sets of 200 uniform ranks, the Wilson interval contains 0.95.
    from validation.statistics import rank_ecdf_band, wilson_interval

    pytest.importorskip("arviz")
    rng = np.random.default_rng(0)
    inside = sum(rank_ecdf_band(rng.integers(0, 101, 200))[0] for _ in range(400))
    lo, hi = wilson_interval(inside, 400)
    assert lo <= 0.95 <= hi
