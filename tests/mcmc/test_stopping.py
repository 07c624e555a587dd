"""Tests of the target-ESS stopping rule (skmba.mcmc._stopping) and of
run_chains(stopping=...)."""

import numpy as np
import pytest

from skmba.mcmc._diagnostics import ess_bulk, ess_tail, split_rhat
from skmba.mcmc._run import run_chains
from skmba.mcmc._stopping import STOP_GRID, EssTarget
from tests.mcmc.test_run_chains import _Batched, _GaussianMixture

SCALES = np.array([10.0, 0.1])


def gaussian(theta):
    return -0.5 * float(np.sum((theta / SCALES) ** 2))


STARTS = np.random.default_rng(0).normal(size=(4, 2)) * SCALES


def run(**kwargs):
    kwargs = {"n_samples": 3000, "burn_in": 500, "random_state": 0, **kwargs}
    return run_chains(gaussian, STARTS, independence=0.9, **kwargs)


@pytest.fixture(scope="module")
def full():
    return run()


@pytest.mark.parametrize("n_jobs, verbose", [(None, 0), (2, 0), (None, 1)])
def test_stopped_draws_are_the_first_draws_of_the_full_run(full, n_jobs, verbose):
    stopped = run(stopping=EssTarget(2000), n_jobs=n_jobs, verbose=verbose)
    m = stopped.samples.shape[1]
    assert m < full.samples.shape[1]
    np.testing.assert_array_equal(stopped.samples, full.samples[:, :m])
    np.testing.assert_array_equal(stopped.log_density, full.log_density[:, :m])


@pytest.mark.parametrize("target", [500, 2000, 5000])
def test_the_chains_stop_at_the_first_checkpoint_that_meets_the_target(full, target):
    """The regular checkpoints, and between two of them the one the rule
    predicts from the last (on its grid): the first judged met stops."""
    rule = EssTarget(target)
    stopped = run(stopping=rule)
    m = stopped.samples.shape[1]
    assert m % rule.grid == 0
    bulk, tail, rhat = rule.diagnostics(stopped.samples)
    assert np.all(bulk >= target) and np.all(tail >= target)
    assert np.all(rhat <= 1.01)
    # The last regular checkpoint before the stop fell short; a stop off the
    # regular ones is where it predicted, or a point of the grid after it.
    regular = (m - 1) // rule.every * rule.every
    if regular:
        met, predicted = rule.judge(full.samples[:, :regular])
        assert not met
        if m % rule.every:  # a predicted checkpoint
            assert predicted is not None and regular < predicted <= m


def test_a_predicted_checkpoint_stops_the_chains_between_regular_ones(full):
    """Judged at 2250 draws, the ESS predicts the target at 2350: the chains
    stop there, with the draws of the full run, rather than at 2500."""
    rule = EssTarget(5000)
    assert rule.judge(full.samples[:, :2250]) == (False, 2350)
    stopped = run(stopping=rule)
    assert stopped.samples.shape[1] == 2350
    np.testing.assert_array_equal(stopped.samples, full.samples[:, :2350])
    np.testing.assert_array_equal(stopped.log_density, full.log_density[:, :2350])


def test_the_prediction_scales_the_smallest_ess_to_the_target():
    rule = EssTarget(1000, grid=50)
    ones = np.ones(2)
    # 400 draws worth 700 (tail) of the 1000: 400 / 0.7 = 571.4 -> 600
    assert rule.predicted(400, np.array([900.0, 800.0]), np.array([700.0, 950.0]),
                          ones) == 600  # fmt: skip
    assert rule.predicted(400, np.full(2, 800.0), np.full(2, 800.0), ones) == 500
    # no prediction where R-hat is too high or an ESS is not finite
    assert (
        rule.predicted(400, np.full(2, 800.0), np.full(2, 800.0), ones * 1.05) is None
    )
    assert (
        rule.predicted(400, np.array([800.0, np.nan]), np.full(2, 800.0), ones) is None
    )


def test_a_target_out_of_reach_runs_to_n_samples(full):
    stopped = run(stopping=EssTarget(1e6))
    np.testing.assert_array_equal(stopped.samples, full.samples)
    np.testing.assert_array_equal(stopped.acceptance_rate, full.acceptance_rate)


def test_acceptance_rate_counts_the_draws_kept(full):
    stopped = run(stopping=EssTarget(1000))
    assert stopped.samples.shape[1] < 3000
    # Every kept draw is the previous one (rejected) or a new point.
    moved = np.any(np.diff(stopped.samples, axis=1) != 0, axis=2)
    accepted = (moved.sum(axis=1) + 1) / stopped.samples.shape[1]
    # (the first draw counts as a move: off by at most one draw)
    m = stopped.samples.shape[1]
    assert np.all(np.abs(stopped.acceptance_rate - accepted) <= 1.5 / m)


def test_unmixed_chains_do_not_stop():
    """Two chains, each in one of two separated modes: R-hat stays high at
    every checkpoint, so they run on to n_samples although each chain alone
    is worth more than the target."""
    far = np.array([[-10.0], [10.0]])

    def bimodal(theta):
        return float(np.logaddexp(-0.5 * ((theta[0] - 10) / 0.1) ** 2,
                                  -0.5 * ((theta[0] + 10) / 0.1) ** 2))  # fmt: skip

    result = run_chains(bimodal, far, n_samples=1000, burn_in=200,
                        random_state=0, stopping=EssTarget(100))  # fmt: skip
    assert result.samples.shape[1] == 1000
    assert result.rhat[0] > 1.5
    assert all(ess_bulk(result.samples[c, :, 0]) > 100 for c in range(2))


def test_labelled_chains_stopped_keep_the_mixture_log_density():
    """A labelled chain evaluates the mixture at its draws at the end; a
    stopped one does it at its stop."""
    target = _GaussianMixture()
    starts = np.random.default_rng(0).normal(size=(4, 2))
    kwargs = {"n_samples": 3000, "burn_in": 1000, "independence": 0.9}
    full = run_chains(_GaussianMixture(), starts, random_state=1, **kwargs)
    assert full.labels is not None  # the chains stayed joint (labelled)
    stopped = run_chains(target, starts, random_state=1, stopping=EssTarget(250),
                         **kwargs)  # fmt: skip
    m = stopped.samples.shape[1]
    assert m < 3000
    np.testing.assert_array_equal(stopped.samples, full.samples[:, :m])
    np.testing.assert_array_equal(stopped.labels, full.labels[:, :m])
    np.testing.assert_allclose(
        stopped.log_density.ravel(), target.batch(stopped.pooled), rtol=1e-12
    )


def test_diagnostics_are_those_of_the_diagnostics_module():
    draws = np.random.default_rng(3).normal(size=(4, 400, 2))
    bulk, tail, rhat = EssTarget(100).diagnostics(draws)
    for j in range(2):
        assert bulk[j] == ess_bulk(draws[:, :, j])
        assert tail[j] == ess_tail(draws[:, :, j])
        assert rhat[j] == split_rhat(draws[:, :, j])


def test_a_parameter_that_never_moved_does_not_meet_the_target():
    draws = np.random.default_rng(4).normal(size=(4, 500, 2))
    draws[:, :, 1] = 1.0
    assert not EssTarget(10).met(draws)


def test_chains_stopped_at_a_checkpoint_evaluated_no_proposal_beyond_it():
    """The independence proposals are evaluated in groups of the stops'
    grid as the chains reach them: a stop wastes no evaluated proposal
    (blocks of 1,024 steps evaluated at once had evaluated about 900 per
    chain when a run stopped at 500 draws)."""
    batched = _Batched()
    stopped = run_chains(batched, np.zeros((2, 2)), n_samples=3000, burn_in=500,
                         independence=0.9, random_state=0, n_jobs=1,
                         stopping=EssTarget(1000))  # fmt: skip
    m = stopped.samples.shape[1]
    assert m < 3000 and m % STOP_GRID == 0
    # The burn-in's: 5 blocks of 50 steps per chain, from halfway through.
    after = batched.calls[2 * 5 :]
    assert len(after) == 2 * (m // STOP_GRID)
    assert all(c <= STOP_GRID for c in after)
    # the proposals evaluated after burn-in are those of the draws kept:
    # about 9 in 10 of their steps, none beyond them
    assert 0.85 * 2 * m <= sum(after) <= 0.95 * 2 * m
