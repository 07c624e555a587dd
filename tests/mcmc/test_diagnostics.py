"""Tests of the convergence diagnostics: rank-normalised split-R-hat and ESS."""

import warnings

import numpy as np
import pytest
from scipy import signal, stats

from skmba.mcmc._diagnostics import (
    _autocovariance,
    _rhat_bulk,
    _rhat_folded,
    check_diagnostics,
    ess_bulk,
    ess_mean,
    ess_sd,
    ess_tail,
    rank_normalize,
    split_rhat,
)
from skmba.mcmc._run import run_chains


def test_rank_normalize_formula():
    x = np.array([[3.0, 1.0, 2.0], [2.0, 5.0, 4.0]])
    ranks = np.array([[4.0, 1.0, 2.5], [2.5, 6.0, 5.0]])  # ties averaged
    expected = stats.norm.ppf((ranks - 3 / 8) / (6 + 1 / 4))
    np.testing.assert_allclose(rank_normalize(x), expected)


def test_split_rhat_of_iid_chains_is_one():
    draws = np.random.default_rng(0).normal(size=(4, 1000))
    assert split_rhat(draws) == pytest.approx(1.0, abs=0.01)


def test_split_rhat_detects_a_shifted_chain():
    draws = np.random.default_rng(1).normal(size=(4, 1000))
    draws[2] += 2.0
    assert split_rhat(draws) > 1.1


def test_split_rhat_detects_a_trend_within_one_chain():
    draws = np.linspace(0.0, 10.0, 1000) + np.random.default_rng(2).normal(size=1000)
    assert split_rhat(draws) > 1.1


def test_folded_rhat_detects_different_variances():
    draws = np.random.default_rng(3).normal(size=(4, 1000))
    draws[2:] *= 3.0  # same mean, three times the spread
    assert _rhat_bulk(draws) < 1.01  # the location-based R-hat misses it
    assert _rhat_folded(draws) > 1.1
    assert split_rhat(draws) == max(_rhat_bulk(draws), _rhat_folded(draws))
    assert split_rhat(draws) > 1.1


def test_degenerate_chains():
    assert np.isnan(split_rhat(np.ones((2, 10))))
    assert np.isnan(ess_bulk(np.ones((2, 10))))
    assert np.isnan(split_rhat(np.zeros((2, 3))))
    # Each chain stuck at a different value.
    assert split_rhat(np.array([[0.0] * 10, [1.0] * 10])) == np.inf


def test_autocovariance_matches_direct_sum():
    x = np.random.default_rng(4).normal(size=(2, 50))
    centred = x - x.mean(axis=1, keepdims=True)
    direct = np.array([[c[: 50 - k] @ c[k:] / 50 for k in range(50)] for c in centred])
    np.testing.assert_allclose(_autocovariance(x), direct, atol=1e-12)


def test_ess_of_iid_draws_is_the_number_of_draws():
    draws = np.random.default_rng(5).normal(size=(4, 2500))
    assert ess_bulk(draws) == pytest.approx(draws.size, rel=0.1)


def test_ess_of_ar1_chains_matches_theory():
    rho, n_chains, n_draws = 0.9, 4, 10000
    rng = np.random.default_rng(6)
    innovations = rng.normal(size=(n_chains, n_draws)) * np.sqrt(1 - rho**2)
    first = rng.normal(size=n_chains)  # stationary start
    chains = signal.lfilter(
        [1.0], [1.0, -rho], innovations, axis=1, zi=rho * first[:, np.newaxis]
    )[0]
    theory = n_chains * n_draws * (1 - rho) / (1 + rho)
    assert ess_bulk(chains) == pytest.approx(theory, rel=0.2)


def test_check_diagnostics_warns_on_a_short_run():
    result = run_chains(
        lambda t: -0.5 * float(t @ t),
        np.array([[-3.0, 3.0], [3.0, -3.0]]),
        n_samples=60,
        burn_in=20,
        random_state=0,
    )
    with pytest.warns(UserWarning, match="n_samples") as record:
        messages = check_diagnostics(result, names=["E", "I"])
    assert len(messages) == len(record) >= 1
    assert any("E (" in message and "I (" in message for message in messages)


def test_check_diagnostics_warns_on_unmixed_chains():
    # Two well separated modes, one chain in each.
    def bimodal(theta):
        return float(
            np.logaddexp(-0.5 * (theta[0] - 10) ** 2, -0.5 * (theta[0] + 10) ** 2)
        )

    result = run_chains(
        bimodal,
        np.array([[-10.0], [10.0]]),
        n_samples=2000,
        burn_in=500,
        random_state=0,
    )
    assert result.rhat[0] > 1.5
    with pytest.warns(UserWarning) as record:
        messages = check_diagnostics(result, names=["stiffness"])
    assert any(m.startswith("R-hat above 1.01 for stiffness") for m in messages)
    assert any("more chains" in m and "burn_in" in m for m in messages)
    assert len(record) == len(messages)
    with pytest.raises(ValueError, match="names"):
        check_diagnostics(result, names=["a", "b"])


# --- agreement with ArviZ (rank-normalised split R-hat, bulk ESS) ------------


def arviz():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)  # ArviZ 0.x announces 1.0
        return pytest.importorskip("arviz")


def ar1_chains(rho, n_chains, n_draws, seed):
    """Stationary Gaussian AR(1) chains with unit marginal variance."""
    rng = np.random.default_rng(seed)
    innovations = rng.normal(size=(n_chains, n_draws)) * np.sqrt(1 - rho**2)
    first = rng.normal(size=n_chains)
    return signal.lfilter(
        [1.0], [1.0, -rho], innovations, axis=1, zi=rho * first[:, np.newaxis]
    )[0]


KNOWN_ANSWER_CHAINS = {
    "iid normal": (np.random.default_rng(7).normal(size=(4, 1000)), 4000),
    "AR(1) rho=0.5": (ar1_chains(0.5, 4, 2000, 8), 8000 * 0.5 / 1.5),
    "AR(1) rho=0.9": (ar1_chains(0.9, 4, 5000, 9), 20000 * 0.1 / 1.9),
    # agreement only: the middle draw dropped by the split; unmixed chains
    "odd length": (np.random.default_rng(10).normal(size=(3, 301)), None),
    "shifted chain": (np.random.default_rng(11).normal(size=(2, 400)) + 1.0, None),
}
KNOWN_ANSWER_CHAINS["shifted chain"][0][0] -= 1.0


@pytest.mark.parametrize("name", list(KNOWN_ANSWER_CHAINS))
def test_rhat_and_ess_equal_arviz(name):
    az = arviz()
    chains, theory = KNOWN_ANSWER_CHAINS[name]
    assert split_rhat(chains) == pytest.approx(az.rhat(chains, method="rank"), abs=1e-6)
    assert ess_bulk(chains) == pytest.approx(az.ess(chains, method="bulk"), abs=1e-6)
    assert ess_tail(chains) == pytest.approx(az.ess(chains, method="tail"), abs=1e-6)
    assert ess_mean(chains) == pytest.approx(az.ess(chains, method="mean"), abs=1e-6)
    assert ess_sd(chains) == pytest.approx(az.ess(chains, method="sd"), abs=1e-6)
    if theory is not None:  # ESS = N (1 - rho) / (1 + rho) for AR(1), N for iid draws
        assert ess_bulk(chains) == pytest.approx(theory, rel=0.15)


def test_one_chain_rhat_is_kept_where_arviz_gives_nan():
    az = arviz()
    chain = np.random.default_rng(12).normal(size=(1, 500))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert np.isnan(az.rhat(chain, method="rank"))
    assert split_rhat(chain) == pytest.approx(1.0, abs=0.02)
    assert ess_bulk(chain) == pytest.approx(az.ess(chain, method="bulk"), abs=1e-6)
