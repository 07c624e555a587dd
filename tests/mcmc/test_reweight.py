"""An earlier run's draws reweighted to a posterior that moved: known
answers (a Gaussian posterior updated by one more observation), the error
the reported ESS promises over seeded replicates, the refusal below the
Kish share, systematic resampling's counts, and the thinning of chains."""

import numpy as np
import pytest
from scipy import stats

from skmba.mcmc._diagnostics import MIN_ESS
from skmba.mcmc._posterior import PosteriorResult
from skmba.mcmc._reweight import REWEIGHT_SHARE, Anchor, reweighted, systematic_indices
from skmba.mcmc._run import run_chains


def _gaussian_update(n_old, n_new, seed, M=2000):
    """Draws of the posterior of a normal mean (unit noise, flat prior)
    after ``n_old`` observations, and the exact posterior after ``n_new``
    more: (anchor, new log density at its draws, new mean, new sd)."""
    rng = np.random.default_rng(seed)
    y = rng.normal(0.3, 1.0, n_old + n_new)
    old = stats.norm(y[:n_old].mean(), 1 / np.sqrt(n_old))
    new = stats.norm(y.mean(), 1 / np.sqrt(n_old + n_new))
    x = old.rvs(size=(M, 1), random_state=rng)
    anchor = Anchor(x, old.logpdf(x[:, 0]) + 7.0, np.array([float(M)]))
    return anchor, new.logpdf(x[:, 0]) - 3.0, new.mean(), new.std()


def test_the_reweighted_moments_are_the_new_posteriors():
    # 100 readings, then 5 more: the posterior moves by about a third of its sd
    anchor, log_new, mean, sd = _gaussian_update(100, 5, seed=0, M=20000)
    posterior, share = reweighted(anchor, log_new, random_state=0)
    assert posterior.method == "reweighted"
    assert 0.9 < share < 1.0  # the new sd is 2.4 % smaller, the mean moved
    se = sd / np.sqrt(posterior.ess[0])
    assert abs(posterior.mean[0] - mean) < 4 * se
    assert abs(np.sqrt(posterior.cov[0, 0]) / sd - 1) < 4 / np.sqrt(
        2 * posterior.ess[0]
    )
    # the resampled draws are the nodes, in proportion to their weights
    assert posterior.samples.shape == anchor.thetas.shape
    assert np.isin(posterior.samples, anchor.thetas).all()
    assert posterior.anchor is anchor and posterior.nodes is anchor.thetas
    np.testing.assert_allclose(posterior.weights.sum(), 1.0, rtol=1e-12)
    np.testing.assert_allclose(posterior.ess, anchor.ess * share)


def test_the_reported_ess_gives_the_error_of_the_mean_over_replicates():
    # z of the weighted mean against the exact one, with the standard error
    # sd / sqrt(ess): rms z is one when the ESS is what it claims (Kish's
    # approximation; 200 replicates give rms z to about +-0.05; measured
    # 1.04, Kish shares 0.61-1).
    z = []
    for seed in range(200):
        anchor, log_new, mean, sd = _gaussian_update(100, 10, seed, M=800)
        posterior, share = reweighted(anchor, log_new, random_state=seed)
        assert posterior is not None, share
        z.append((posterior.mean[0] - mean) / (sd / np.sqrt(posterior.ess[0])))
    rms = float(np.sqrt(np.mean(np.square(z))))
    assert 0.85 < rms < 1.15, rms


def test_too_uneven_weights_or_too_few_draws_are_refused():
    # 20 readings, then 200 more: the old draws hardly cover the new posterior
    anchor, log_new, _, _ = _gaussian_update(20, 200, seed=1)
    posterior, share = reweighted(anchor, log_new, random_state=0)
    assert posterior is None and share < REWEIGHT_SHARE
    # an even share of too few effective draws
    anchor, log_new, _, _ = _gaussian_update(100, 5, seed=1, M=1000)
    few = Anchor(anchor.thetas, anchor.log_density, np.array([MIN_ESS - 1.0]))
    assert reweighted(anchor, log_new)[0] is not None
    posterior, share = reweighted(few, log_new)
    assert posterior is None and share > REWEIGHT_SHARE
    nowhere = np.full(len(log_new), -np.inf)
    assert reweighted(anchor, nowhere) == (None, 0.0)


def test_nodes_outside_the_new_support_get_no_weight():
    anchor, log_new, _, _ = _gaussian_update(100, 5, seed=2, M=1000)
    log_new = np.where(anchor.thetas[:, 0] > 0.6, -np.inf, log_new)
    posterior, _ = reweighted(anchor, log_new, random_state=0)
    assert np.all(posterior.weights[anchor.thetas[:, 0] > 0.6] == 0.0)
    assert posterior.samples.max() <= 0.6


@pytest.mark.parametrize("seed", range(5))
def test_systematic_resampling_counts_are_floor_or_ceiling(seed):
    rng = np.random.default_rng(seed)
    w = rng.dirichlet(np.full(50, 0.5))
    n = 997
    counts = np.bincount(systematic_indices(w, n, rng), minlength=len(w))
    assert counts.sum() == n
    assert np.all(np.abs(counts - n * w) < 1.0 + 1e-9)


def _mcmc(chains, log_density, ess, rhat=(1.0, 1.0)):
    pooled = chains.reshape(-1, chains.shape[-1])
    return PosteriorResult.from_draws(
        "mcmc",
        pooled,
        chains=chains,
        log_density=log_density,
        ess=ess,
        rhat=np.asarray(rhat),
    )


def test_an_anchor_thins_each_chain_to_about_its_effective_draws():
    scale = np.array([1.0, 3.0])

    def log_density(theta):
        return -0.5 * float(np.sum((theta / scale) ** 2))

    starts = np.random.default_rng(0).normal(size=(4, 2))
    run = run_chains(log_density, starts, n_samples=1500, burn_in=500, random_state=0)
    log_p = -0.5 * np.sum((run.samples / scale) ** 2, axis=-1)
    # bulk ESS of 500 (the chains' own tail, mean and sd ESS are above it)
    ess = np.array([500.0, 900.0])
    anchor = Anchor.of(_mcmc(run.samples, log_p, ess))
    # 125 per chain: every 12th draw of each chain, with its log density
    assert anchor.thetas.shape == (500, 2)
    np.testing.assert_array_equal(anchor.thetas[:125], run.samples[0, ::12])
    np.testing.assert_array_equal(anchor.log_density[125:250], log_p[1, ::12])
    np.testing.assert_array_equal(anchor.ess, [500.0, 500.0])  # at most M
    # a reweighted posterior keeps its anchor; a run without its log
    # density, a quadrature or unusable diagnostics give none
    posterior, _ = reweighted(anchor, anchor.log_density, random_state=0)
    assert Anchor.of(posterior) is anchor
    assert Anchor.of(_mcmc(run.samples, None, ess)) is None
    # nor a run whose diagnostics were warned about
    assert Anchor.of(_mcmc(run.samples, log_p, np.array([np.nan, 900.0]))) is None
    assert Anchor.of(_mcmc(run.samples, log_p, np.array([399.0, 900.0]))) is None
    assert Anchor.of(_mcmc(run.samples, log_p, ess, rhat=(1.0, 1.02))) is None
    grid = PosteriorResult.from_rule(
        run.samples[0], run.samples[0], np.full(1500, 1 / 1500), (-3, 3)
    )
    assert Anchor.of(grid) is None
    # the same target: equal weights, a share of one
    assert reweighted(anchor, anchor.log_density + 2.0)[1] == pytest.approx(1.0)
