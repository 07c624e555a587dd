"""Tests of the adaptive Metropolis sampler."""

import re
import warnings

import joblib
import numpy as np
import pytest
from scipy import stats
from scipy.special import logsumexp

from skmba.mcmc import _proposals as proposals
from skmba.mcmc._chain import Chain
from skmba.mcmc._diagnostics import check_diagnostics, ess_bulk
from skmba.mcmc._proposals import T_VARIANCE_FACTOR, TProposal, label_proposal
from skmba.mcmc._run import ChainResult, run_chains
from skmba.mcmc._stopping import STOP_GRID, EssTarget

# A 2-D Gaussian whose scales differ by 1e5 and whose correlation is -0.9:
# far from the default proposal (2.38^2 / 2) I, so that only an adapted
# proposal samples it well.
SD = np.array([1e3, 1e-2])
RHO = -0.9
MEAN = np.array([2e3, 0.5])
COV = np.array([[SD[0] ** 2, RHO * SD[0] * SD[1]], [RHO * SD[0] * SD[1], SD[1] ** 2]])
PRECISION = np.linalg.inv(COV)


def correlated_gaussian(theta):
    d = theta - MEAN
    return -0.5 * float(d @ PRECISION @ d)


def standard_normal(theta):
    return -0.5 * float(theta @ theta)


def dispersed_starts(n_chains, seed):
    """Starts drawn from the target with doubled standard deviations."""
    z = np.random.default_rng(seed).normal(size=(n_chains, 2))
    return MEAN + 2.0 * z @ np.linalg.cholesky(COV).T


@pytest.fixture(scope="module")
def gaussian_result():
    return run_chains(
        correlated_gaussian,
        dispersed_starts(4, seed=0),
        n_samples=4000,
        burn_in=2000,
        random_state=0,
    )


def test_result_shapes(gaussian_result):
    result = gaussian_result
    assert isinstance(result, ChainResult)
    assert result.samples.shape == (4, 4000, 2)
    assert result.log_density.shape == (4, 4000)
    assert result.acceptance_rate.shape == (4,)
    assert result.proposal_cov.shape == (4, 2, 2)
    assert result.pooled.shape == (16000, 2)
    np.testing.assert_array_equal(result.pooled[4000:8000], result.samples[1])
    assert result.rhat.shape == (2,)
    assert result.ess.shape == (2,)


def test_stored_log_density_matches_samples(gaussian_result):
    result = gaussian_result
    recomputed = [correlated_gaussian(t) for t in result.samples[2, ::97]]
    np.testing.assert_allclose(result.log_density[2, ::97], recomputed)


def test_correlated_gaussian_with_very_different_scales(gaussian_result):
    result = gaussian_result
    pooled = result.pooled
    # Pooled mean within 0.1 standard deviation of the true mean.
    np.testing.assert_array_less(np.abs(pooled.mean(axis=0) - MEAN) / SD, 0.1)
    # Every entry of the covariance (variances and the covariance) within
    # 15% relative error.
    np.testing.assert_array_less(np.abs(np.cov(pooled.T) / COV - 1.0), 0.15)
    assert np.all(result.acceptance_rate >= 0.15)
    assert np.all(result.acceptance_rate <= 0.5)
    np.testing.assert_array_less(result.rhat, 1.01)
    np.testing.assert_array_less(400, result.ess)


def test_adapted_proposal_matches_target_shape(gaussian_result):
    # The frozen proposal covariance has the target's correlation and scales
    # (up to the global factor), not the identity it started from.
    for cov in gaussian_result.proposal_cov:
        sd = np.sqrt(np.diag(cov))
        assert cov[0, 1] / (sd[0] * sd[1]) == pytest.approx(RHO, abs=0.05)
        assert sd[0] / sd[1] == pytest.approx(SD[0] / SD[1], rel=0.3)


def test_bounded_support_is_respected():
    # Uniform prior on [0, 1] times a Gaussian likelihood centred near the
    # lower bound: the posterior is a truncated normal.
    loc, scale = 0.05, 0.1

    def log_density(theta):
        t = theta[0]
        if t < 0.0 or t > 1.0:
            return -np.inf
        return -0.5 * ((t - loc) / scale) ** 2

    starts = np.array([[0.01], [0.5], [0.9]])
    result = run_chains(
        log_density, starts, n_samples=3000, burn_in=1000, random_state=1
    )
    assert result.samples.min() >= 0.0
    assert result.samples.max() <= 1.0
    assert np.all(np.isfinite(result.log_density))
    truncated = stats.truncnorm((0 - loc) / scale, (1 - loc) / scale, loc, scale)
    assert result.pooled.mean() == pytest.approx(truncated.mean(), abs=0.01)


def test_one_dimensional_acceptance_targets_044():
    result = run_chains(
        standard_normal,
        np.zeros((2, 1)),
        n_samples=4000,
        burn_in=2000,
        random_state=3,
    )
    np.testing.assert_allclose(result.acceptance_rate, 0.44, atol=0.06)


def test_no_adaptation_keeps_the_proposal():
    cov = np.array([[0.5, 0.1], [0.1, 0.2]])
    result = run_chains(
        standard_normal,
        np.zeros((3, 2)),
        n_samples=100,
        burn_in=100,
        proposal_cov=cov,
        adapt=False,
        random_state=0,
    )
    np.testing.assert_allclose(result.proposal_cov, np.broadcast_to(cov, (3, 2, 2)))
    adapted = run_chains(
        standard_normal,
        np.zeros((3, 2)),
        n_samples=100,
        burn_in=300,
        proposal_cov=cov,
        random_state=0,
    )
    assert not np.allclose(adapted.proposal_cov, cov)


def test_per_chain_proposal_cov_and_no_burn_in():
    covs = np.stack([np.eye(2) * s for s in (0.1, 1.0)])
    result = run_chains(
        standard_normal,
        np.zeros((2, 2)),
        n_samples=50,
        burn_in=0,
        proposal_cov=covs,
        random_state=0,
    )
    # Without burn-in nothing is adapted.
    np.testing.assert_allclose(result.proposal_cov, covs)
    assert result.samples.shape == (2, 50, 2)


# ---------------------------------------------------------------------------
# Determinism


def _run(random_state, n_jobs):
    return run_chains(
        correlated_gaussian,
        dispersed_starts(3, seed=5),
        n_samples=300,
        burn_in=300,
        n_jobs=n_jobs,
        random_state=random_state,
    )


def _assert_identical(a, b):
    np.testing.assert_array_equal(a.samples, b.samples)
    np.testing.assert_array_equal(a.log_density, b.log_density)
    np.testing.assert_array_equal(a.acceptance_rate, b.acceptance_rate)
    np.testing.assert_array_equal(a.proposal_cov, b.proposal_cov)


def test_same_seed_gives_identical_results_for_any_n_jobs():
    serial = _run(42, n_jobs=1)
    _assert_identical(serial, _run(42, n_jobs=2))
    with joblib.parallel_config(backend="threading"):
        _assert_identical(serial, _run(42, n_jobs=2))
    other = _run(43, n_jobs=1)
    assert not np.array_equal(serial.samples, other.samples)
    # The chains of one run are not copies of each other.
    assert not np.array_equal(serial.samples[0, -1], serial.samples[1, -1])


def test_random_state_objects():
    a = _run(np.random.default_rng(7), n_jobs=1)
    b = _run(np.random.default_rng(7), n_jobs=1)
    _assert_identical(a, b)
    c = _run(np.random.RandomState(7), n_jobs=1)
    d = _run(np.random.RandomState(7), n_jobs=1)
    _assert_identical(c, d)
    # None draws fresh entropy.
    assert not np.array_equal(_run(None, 1).samples, _run(None, 1).samples)
    with pytest.raises(ValueError, match="random_state"):
        _run("seed", n_jobs=1)


# ---------------------------------------------------------------------------
# Errors


def test_start_with_zero_density_is_rejected():
    def log_density(theta):
        return 0.0 if theta[0] > 0 else -np.inf

    with pytest.raises(ValueError, match=r"starts\[1\]"):
        run_chains(log_density, np.array([[1.0], [-1.0]]), n_samples=10, burn_in=10)


@pytest.mark.parametrize("n_jobs", [1, 2])
def test_log_density_error_names_the_chain(n_jobs):
    # Chain 0 sits near -1000 and never reaches the region that raises;
    # chain 1 starts at its edge.
    def log_density(theta):
        if theta[0] > 100.0:
            raise ValueError("boom")
        return -0.5 * (theta[0] + 1000.0) ** 2

    starts = np.array([[-1000.0], [99.9]])
    with pytest.raises(RuntimeError, match=r"chain 1.*boom"):
        run_chains(
            log_density,
            starts,
            n_samples=100,
            burn_in=100,
            n_jobs=n_jobs,
            random_state=0,
        )


def test_log_density_error_at_a_start_names_the_chain():
    def log_density(theta):
        raise KeyError("missing")

    with pytest.raises(RuntimeError, match=r"chain 0.*missing") as info:
        run_chains(log_density, np.zeros((2, 1)), n_samples=10, burn_in=10)
    assert isinstance(info.value.__cause__, KeyError)


def test_nan_log_density_is_an_error():
    with pytest.raises(RuntimeError, match="nan"):
        run_chains(lambda t: np.nan, np.zeros((1, 1)), n_samples=10, burn_in=10)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"starts": np.zeros(3)}, "starts"),
        ({"starts": np.full((2, 1), np.nan)}, "starts"),
        ({"n_samples": 0}, "n_samples"),
        ({"burn_in": -1}, "burn_in"),
        ({"burn_in": 1.5}, "burn_in"),
        ({"proposal_cov": np.eye(3)}, "proposal_cov"),
        ({"proposal_cov": -np.eye(1)}, "proposal_cov"),
        ({"moments": 5.0}, "moments must be a pair"),
        (
            {"moments": (np.zeros(2), np.eye(1))},
            r"moments must be a mean of shape \(1,\)",
        ),
        ({"moments": (np.zeros(1), np.eye(2))}, r"covariance of shape \(1, 1\)"),
        ({"moments": (np.zeros(1), np.full((1, 1), np.nan))}, "moments must be finite"),
        (
            {"proposal_points": np.zeros((5, 3))},
            r"proposal_points must be an array of shape \(m, 1\)",
        ),
        ({"proposal_points": np.zeros((1, 1))}, "at least two rows"),
        (
            {"proposal_points": np.full((3, 1), np.nan)},
            "proposal_points must be finite",
        ),
    ],
)
def test_invalid_arguments(kwargs, match):
    arguments = {"starts": np.zeros((2, 1)), "n_samples": 10, "burn_in": 10}
    arguments.update(kwargs)
    with pytest.raises(ValueError, match=match):
        run_chains(standard_normal, **arguments)


class CountingDensity:
    """The standard normal log density, counting its calls."""

    def __init__(self):
        self.calls = 0

    def __call__(self, theta):
        self.calls += 1
        return standard_normal(theta)


def test_one_log_density_per_chain():
    # A sequence gives chain c the c-th callable (e.g. with its own cache):
    # each is called for its chain only, and the draws equal those of a
    # shared callable.
    densities = [CountingDensity() for _ in range(3)]
    starts = np.zeros((3, 2))
    per_chain = run_chains(
        densities, starts, n_samples=40, burn_in=60, n_jobs=1, random_state=3
    )
    assert [f.calls for f in densities] == [1 + 60 + 40] * 3
    shared = run_chains(
        standard_normal, starts, n_samples=40, burn_in=60, random_state=3
    )
    _assert_identical(per_chain, shared)


@pytest.mark.parametrize(
    ("log_density", "match"),
    [
        ("normal", "sequence of 2 callables"),
        ([standard_normal], "sequence of 2 callables .* got 1 entries"),
        (3.0, "callable or a sequence of callables"),
    ],
)
def test_invalid_log_density(log_density, match):
    with pytest.raises(TypeError, match=match):
        run_chains(log_density, np.zeros((2, 1)), n_samples=5, burn_in=5)


@pytest.mark.parametrize("n_jobs", [1, 2])
def test_verbose_progress_of_each_chain(capsys, n_jobs):
    # The parent process reports, also for chains run by workers.
    run_chains(
        standard_normal,
        np.zeros((2, 1)),
        n_samples=100,
        burn_in=50,
        random_state=0,
        verbose=2,
        n_jobs=n_jobs,
    )
    captured = capsys.readouterr()
    assert captured.out == ""
    err = captured.err
    assert "MCMC: 2 chain(s)" in err and "300/300" in err
    for c in range(2):
        assert f"chain {c}: burn-in of 50 steps done in" in err
        assert re.search(rf"chain {c}: 100 draws done in [\d.]+ s, acceptance", err)
    run_chains(standard_normal, np.zeros((2, 1)), n_samples=10, burn_in=10)
    assert capsys.readouterr() == ("", "")


def test_check_diagnostics_quiet_on_a_good_run(gaussian_result):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert check_diagnostics(gaussian_result) == []


# ---------------------------------------------------------------------------
# Independence moves

# A banana: x ~ N(0, 2^2), y | x ~ N(B (x^2 - 4), 1), so that E[x] = E[y] = 0,
# Var x = 4 and Var y = 1 + B^2 Var(x^2) = 1 + 32 B^2. A Student-t is a poor
# approximation of it.
BANANA_B = 0.15


def banana(theta):
    x, y = theta
    return -0.5 * (x / 2.0) ** 2 - 0.5 * (y - BANANA_B * (x**2 - 4.0)) ** 2


def _mixed(log_density, starts, independence, seed, n_jobs=None, **kwargs):
    return run_chains(
        log_density,
        starts,
        n_samples=kwargs.pop("n_samples", 4000),
        burn_in=kwargs.pop("burn_in", 2000),
        independence=independence,
        n_jobs=n_jobs,
        random_state=seed,
        **kwargs,
    )


def _assert_moments(result, mean, var):
    """Means and variances within 4 Monte Carlo standard errors, each from
    the bulk ESS of the draws (of their squared deviations for the
    variance)."""
    samples = result.samples
    draws = result.pooled
    se_mean = np.sqrt(draws.var(axis=0) / result.ess)
    assert np.all(np.abs(draws.mean(axis=0) - mean) < 4 * se_mean)
    squares = (samples - mean) ** 2
    ess = [ess_bulk(squares[:, :, j]) for j in range(samples.shape[-1])]
    se_var = np.sqrt(squares.reshape(-1, len(mean)).var(axis=0) / ess)
    assert np.all(
        np.abs(squares.reshape(-1, len(mean)).mean(axis=0) - var) < 4 * se_var
    )


def test_independence_moves_sample_a_correlated_gaussian_far_better():
    mixed = _mixed(correlated_gaussian, dispersed_starts(4, seed=0), 0.9, 0)
    _assert_moments(mixed, MEAN, np.diag(COV))
    assert np.all(mixed.rhat < 1.01)
    # A Student-t fitted to the burn-in is close to a Gaussian target: most
    # independence proposals are accepted, and the draws are nearly
    # independent (an effective draw per 2 steps, against 1 per 9 of the
    # adapted random walk alone).
    assert np.all(mixed.independence_rate > 0.6)
    assert np.all(mixed.ess > 0.4 * 4 * 4000)
    plain = _mixed(correlated_gaussian, dispersed_starts(4, seed=0), 0.0, 0)
    assert np.all(np.isnan(plain.independence_rate))
    assert np.all(mixed.ess > 3 * plain.ess)


@pytest.mark.parametrize("independence", [0.0, 0.9])
def test_banana_moments_with_and_without_independence_moves(independence):
    result = _mixed(
        banana, np.array([[0.0, 0.0], [1.0, 1.0], [-1.0, 0.0]]), independence, seed=2
    )
    _assert_moments(result, np.zeros(2), np.array([4.0, 1.0 + 32 * BANANA_B**2]))
    assert np.all(result.rhat < 1.02)


def test_a_heavy_tailed_target_keeps_its_tails():
    # A Student-t of 3 degrees of freedom has heavier tails than the
    # proposal (5 degrees of freedom): the random-walk steps and the
    # acceptance ratio keep its quantiles right.
    def t3(theta):
        return -2.5 * np.log1p(float(theta @ theta) / 3.0)

    result = _mixed(t3, np.zeros((4, 2)), 0.9, seed=3, n_samples=10000)
    # The marginals of a bivariate t3 are univariate t3.
    quantiles = np.quantile(result.pooled, [0.05, 0.25, 0.75, 0.95], axis=0)
    expected = stats.t(3).ppf([0.05, 0.25, 0.75, 0.95])
    np.testing.assert_allclose(quantiles, np.column_stack([expected] * 2), atol=0.15)
    assert np.all(result.rhat < 1.01)


class _Batched:
    """A standard normal log density with a ``batch`` method that records
    its calls."""

    def __init__(self):
        self.calls = []

    def __call__(self, theta):
        return standard_normal(theta)

    def batch(self, thetas):
        self.calls.append(len(thetas))
        return np.array([standard_normal(t) for t in thetas])


def test_a_batch_method_gets_the_independence_proposals_of_a_block():
    batched = _Batched()
    kwargs = dict(n_samples=2000, burn_in=500, n_jobs=1)
    starts = np.ones((1, 2))
    result = _mixed(batched, starts, 0.9, 4, **kwargs)
    # The same draws as one call per proposal.
    _assert_identical(result, _mixed(standard_normal, starts, 0.9, 4, **kwargs))
    # From halfway through the burn-in on: blocks of 50 steps, then the
    # draws' groups of the stops' grid (50 draws).
    assert STOP_GRID == 50
    assert len(batched.calls) == 5 + 2000 // STOP_GRID
    assert all(30 <= c <= 50 for c in batched.calls)


def test_a_batch_method_that_returns_nan_is_an_error():
    class Broken(_Batched):
        def batch(self, thetas):
            return np.full(len(thetas), np.nan)

    with pytest.raises(RuntimeError, match="batch returned"):
        _mixed(Broken(), np.ones((1, 2)), 0.9, 4, n_samples=10, burn_in=200)


def test_chains_with_independence_moves_are_identical_for_any_n_jobs():
    def run(independence, n_jobs):
        return _mixed(
            correlated_gaussian,
            dispersed_starts(3, seed=5),
            independence,
            42,
            n_jobs=n_jobs,
            n_samples=300,
            burn_in=300,
        )

    serial = run(0.9, 1)
    parallel = run(0.9, 2)
    _assert_identical(serial, parallel)
    np.testing.assert_array_equal(serial.independence_rate, parallel.independence_rate)
    assert not np.array_equal(run(0.0, 1).samples, serial.samples)


class _WithBlobs(_Batched):
    """A standard normal whose blob is theta's square, counted per call."""

    def __init__(self):
        super().__init__()
        self.blob_calls = 0

    def with_blob(self, theta):
        self.blob_calls += 1
        return standard_normal(theta), theta**2

    def batch_with_blobs(self, thetas):
        return self.batch(thetas), thetas**2


@pytest.mark.parametrize("n_jobs", [1, 2])
def test_kept_blobs_are_each_draw_s_and_change_no_draw(n_jobs):
    """The draws with their blobs are those without, and each blob is the
    target's at its draw (over random-walk and independence moves, across
    the ESS target's stop), at one more evaluation per chain."""
    kwargs = dict(n_samples=2000, burn_in=400, n_jobs=n_jobs)
    starts = np.random.default_rng(2).normal(size=(3, 2))
    stopping = EssTarget(1000)
    plain = _mixed(_Batched(), starts, 0.5, 8, stopping=stopping, **kwargs)
    target = _WithBlobs()
    kept = _mixed(target, starts, 0.5, 8, stopping=stopping, keep_blobs=True, **kwargs)
    _assert_identical(kept, plain)
    assert plain.blobs is None
    assert kept.samples.shape[1] < 2000  # stopped at a checkpoint
    np.testing.assert_array_equal(kept.blobs, kept.samples**2)
    if n_jobs == 1:  # the calls are counted in this process
        steps = 3 * (400 + kept.samples.shape[1])
        assert 0 < target.blob_calls - 3 < steps


def test_blobs_need_the_target_s_methods_and_no_labels():
    with pytest.raises(TypeError, match="with_blob"):
        _mixed(_Batched(), np.ones((1, 2)), 0.5, 0, keep_blobs=True, n_samples=10)
    labelled = _WithBlobs()
    labelled.n_labels = 2
    with pytest.raises(ValueError, match="labelled"):
        _mixed(labelled, np.ones((1, 2)), 0.5, 0, keep_blobs=True, n_samples=10)


def test_a_blob_method_that_returns_too_few_blobs_is_an_error():
    class Short(_WithBlobs):
        def batch_with_blobs(self, thetas):
            return self.batch(thetas), thetas[1:] ** 2

    with pytest.raises(RuntimeError, match="blobs for"):
        _mixed(Short(), np.ones((1, 2)), 0.9, 4, keep_blobs=True, n_samples=300)


def test_no_burn_in_means_no_independence_moves():
    result = run_chains(
        standard_normal, np.zeros((2, 2)), n_samples=50, burn_in=0, independence=0.9
    )
    assert np.all(np.isnan(result.independence_rate))


@pytest.mark.parametrize(
    "value, error, match",
    [
        ("yes", TypeError, "independence must be a number"),
        (True, TypeError, "independence must be a number"),
        (1.0, ValueError, r"independence must be in \[0, 1\)"),
        (-0.1, ValueError, r"independence must be in \[0, 1\)"),
    ],
)
def test_independence_must_be_a_probability_below_one(value, error, match):
    with pytest.raises(error, match=match):
        run_chains(
            standard_normal,
            np.zeros((1, 2)),
            n_samples=5,
            burn_in=0,
            independence=value,
        )


class _GaussianMixture:
    """A labelled target: ``p(theta, k) = w_k N(theta; m_k, C_k)``, three
    overlapping components of different scales and shapes, as the posterior
    of theta at different module-2 draws (``n_labels`` = 3)."""

    n_labels = 3
    weights = np.array([0.5, 0.3, 0.2])
    means = np.array([[0.0, 0.0], [0.8, 0.3], [-0.5, 0.8]])
    covs = np.array(
        [[[1.0, 0.8], [0.8, 1.0]], [[0.3, 0.0], [0.0, 0.6]], [[3.0, -0.5], [-0.5, 2.0]]]
    )

    def __init__(self):
        self.calls = {"labelled": 0, "components": 0, "batch": 0}
        # frozen once: building one per call (scipy formats its docstring)
        # took 0.2 ms, most of this toy target's cost over 20,000 steps
        self._components = [
            stats.multivariate_normal(m, c)
            for m, c in zip(self.means, self.covs, strict=True)
        ]

    def _joint(self, thetas):
        return np.column_stack(
            [
                np.log(w) + component.logpdf(thetas)
                for w, component in zip(self.weights, self._components, strict=True)
            ]
        )

    def __call__(self, theta):
        return float(np.logaddexp.reduce(self._joint(theta[None, :])[0]))

    def batch(self, thetas):
        self.calls["batch"] += len(thetas)
        return np.logaddexp.reduce(self._joint(thetas), axis=1)

    def labelled(self, thetas, labels):
        self.calls["labelled"] += len(thetas)
        return self._joint(thetas)[np.arange(len(thetas)), labels]

    def components(self, theta):
        self.calls["components"] += 1
        return self._joint(theta[None, :])[0]

    def moments(self):
        mean = self.weights @ self.means
        second = sum(
            w * (c + np.outer(m, m))
            for w, m, c in zip(self.weights, self.means, self.covs, strict=True)
        )
        return mean, second - np.outer(mean, mean)


@pytest.mark.parametrize(
    "independence, warm", [(0.9, False), (0.0, False), (0.9, True)]
)
def test_a_labelled_target_is_sampled_with_its_labels(independence, warm):
    """Theta and the label together (data augmentation): the draws of theta
    follow the mixture, each label is a draw of ``p(k | theta)``, and the
    stored log density is the mixture's. Without independence moves, Gibbs
    updates of the label keep the chains moving between components. With
    ``moments`` (here off the target's), the first independence moves
    propose the labels uniformly."""
    target = _GaussianMixture()
    starts = np.random.default_rng(0).normal(size=(4, 2))
    mean, cov = target.moments()
    result = run_chains(
        target,
        starts,
        n_samples=4000,
        burn_in=1000,
        independence=independence,
        random_state=1,
        moments=(mean + 0.3, 2.0 * cov) if warm else None,
    )
    draws = result.pooled
    se = np.sqrt(np.diag(cov) / np.min(result.ess))
    assert np.all(np.abs(draws.mean(axis=0) - mean) < 4 * se)
    # Variances within 4 standard errors, var * sqrt((kurtosis - 1) / ESS)
    # with the mixture's kurtosis about 5.
    variances = np.diag(np.cov(draws.T))
    assert np.all(
        np.abs(variances - np.diag(cov)) < 4 * np.diag(cov) * np.sqrt(4 / result.ess)
    )
    # The labels: each a draw of p(k | theta), so their frequencies are the
    # weights, and the draws of one label lie in its component.
    labels = result.labels.ravel()
    share = np.bincount(labels, minlength=3) / len(labels)
    np.testing.assert_allclose(share, target.weights, atol=0.06)
    np.testing.assert_allclose(
        draws[labels == 1].mean(axis=0), target.means[1], atol=0.3
    )
    # The mixture's log density at the draws, not the joint one.
    np.testing.assert_allclose(
        result.log_density.ravel(), target.batch(draws), rtol=1e-12
    )
    assert np.all(result.rhat < 1.05)


class _SameShapeMixture(_GaussianMixture):
    """Three components of one shape: ``p(k | theta)`` is the weights
    whatever theta, where a joint chain mixes as well as the mixture's (as
    the calibrator's module-2 draws on 4.7.3)."""

    means = np.zeros((3, 2))
    covs = np.array([[[1.0, 0.8], [0.8, 1.0]]] * 3)


def test_a_labelled_target_costs_one_component_per_step():
    target = _SameShapeMixture()
    starts = np.random.default_rng(0).normal(size=(2, 2))
    run_chains(target, starts, n_samples=1000, burn_in=500, independence=0.9,
               random_state=0)  # fmt: skip
    # One joint density per step; the label's Gibbs updates once per burn-in
    # block; the mixture at the distinct draws only.
    assert target.calls["labelled"] <= 2 * 1500
    assert target.calls["components"] == 2 * 10
    assert target.calls["batch"] < 2 * 1000
    # Labels independent of theta: the joint chains never fall back.
    result = run_chains(target, starts, n_samples=1000, burn_in=500,
                        independence=0.9, random_state=0)  # fmt: skip
    assert result.labels is not None


def test_labelled_chains_are_identical_for_any_n_jobs():
    starts = np.random.default_rng(0).normal(size=(3, 2))
    runs = [
        run_chains(
            _GaussianMixture(),
            starts,
            n_samples=300,
            burn_in=200,
            independence=0.9,
            random_state=5,
            n_jobs=n_jobs,
        )
        for n_jobs in (1, 2)
    ]
    np.testing.assert_array_equal(runs[0].samples, runs[1].samples)
    np.testing.assert_array_equal(runs[0].labels, runs[1].labels)


def test_labelled_chain_errors_name_the_method():
    class Broken(_GaussianMixture):
        def labelled(self, thetas, labels):
            return np.full(len(thetas), np.nan)

    with pytest.raises(RuntimeError, match=r"log_density\.labelled returned"):
        run_chains(Broken(), np.zeros((1, 2)), n_samples=10, burn_in=10)


class _ShiftedMixture(_GaussianMixture):
    """Two components whose label ``p(k | theta)`` depends strongly on
    theta (their means differ): a joint chain mixes poorly here."""

    n_labels = 2
    weights = np.array([0.5, 0.5])
    means = np.array([[-1.2, 0.0], [1.2, 0.0]])
    covs = np.array([[[0.3, 0.0], [0.0, 1.0]]] * 2)


def test_a_joint_chain_that_mixes_poorly_falls_back_to_the_mixture():
    from skmba.mcmc._chain import _JOINT_MIN_ACCEPTANCE, _JOINT_MIN_MOVES, Chain

    target = _ShiftedMixture()
    chain = Chain(np.zeros(2), target(np.zeros(2)), np.eye(2), 0, n_samples=10,
                  burn_in=100, adapt=True, chain=0, n_labels=2)  # fmt: skip
    chain.advance(target, 50)  # the label is drawn: a joint chain
    assert chain.labelled and chain.logp == target.components(chain.theta)[chain.label]
    moves = _JOINT_MIN_MOVES
    chain.burn_independent[:] = moves, int(_JOINT_MIN_ACCEPTANCE * moves)
    chain._check_joint(target)
    assert chain.labelled  # accepted often enough: stays joint
    chain.burn_independent[:] = moves, int(_JOINT_MIN_ACCEPTANCE * moves) - 1
    chain._check_joint(target)
    assert not chain.labelled and chain.label is None
    assert chain.logp == target(chain.theta)  # the mixture's density now
    # A run where some chains fall back: no labels, the mixture's moments.
    result = run_chains(target, np.random.default_rng(0).normal(size=(4, 2)),
                        n_samples=4000, burn_in=1000, independence=0.9,
                        random_state=2)  # fmt: skip
    assert result.labels is None
    mean, cov = target.moments()
    se = np.sqrt(np.diag(cov) / np.min(result.ess))
    assert np.all(np.abs(result.pooled.mean(axis=0) - mean) < 4 * se)
    np.testing.assert_allclose(
        result.log_density.ravel(), target.batch(result.pooled), rtol=1e-12
    )


# ``moments`` of the correlated Gaussian as an earlier run of a nearby
# target would give them: the mean one sd off along the first axis and the
# covariance twice too wide.
NEARBY = (MEAN + np.array([SD[0], 0.0]), 2.0 * COV)


def test_moments_start_the_independence_moves_at_the_first_step():
    batched = _Batched()
    kwargs = dict(n_samples=2000, burn_in=500, n_jobs=1)
    starts = np.ones((1, 2))
    result = _mixed(batched, starts, 0.9, 4, moments=(np.zeros(2), np.eye(2)), **kwargs)
    # Every block of the burn-in (10 of 50 steps) gets its proposals, then
    # the draws' 40 groups of 50.
    assert len(batched.calls) == 10 + 2000 // STOP_GRID
    assert all(30 <= c <= 50 for c in batched.calls[:10])
    assert not np.array_equal(
        result.samples, _mixed(batched, starts, 0.9, 4, **kwargs).samples
    )


def test_moments_of_a_nearby_target_sample_the_target_and_shorten_the_burn_in():
    def run(moments, seed):
        return _mixed(
            correlated_gaussian,
            dispersed_starts(4, seed=seed),
            0.9,
            seed,
            n_samples=2000,
            burn_in=200,
            moments=moments,
        )

    warm, cold = run(NEARBY, 7), run(None, 7)
    # The moments only propose: the draws follow the target, not them.
    _assert_moments(warm, MEAN, np.diag(COV))
    assert np.all(warm.rhat < 1.01)
    # With a burn-in of 200 steps, the cold chains' independence moves begin
    # after 100 random-walk steps, too few to find scales 1e5 apart; the
    # warm ones mix from the first step. Over seeds 0-7: warm bulk ESS
    # 2,700-4,800; cold 190-640 with R-hat 1.005-1.057, the shared mixture
    # after the burn-in recovering part of what its Student-t alone could
    # not (ESS 4-6, R-hat 2-4 over seeds 0-4): a ratio of 5.5 at least.
    assert np.all(warm.ess > 4 * cold.ess)


def test_chains_with_moments_are_identical_for_any_n_jobs():
    def run(n_jobs):
        return _mixed(
            correlated_gaussian,
            dispersed_starts(3, seed=5),
            0.9,
            42,
            n_jobs=n_jobs,
            n_samples=300,
            burn_in=300,
            moments=NEARBY,
        )

    _assert_identical(run(1), run(2))


def test_moments_with_a_singular_covariance_are_not_used():
    def run(moments):
        return _mixed(
            standard_normal,
            np.zeros((2, 2)),
            0.9,
            3,
            n_samples=200,
            burn_in=200,
            moments=moments,
        )

    _assert_identical(run((np.zeros(2), np.zeros((2, 2)))), run(None))


def _shared_proposals(monkeypatch):
    """The calls of Chain.share_proposal: (chain, steps done, proposal)."""
    calls = []
    original = Chain.share_proposal

    def spy(self, proposal):
        calls.append((self.chain, self.steps, proposal))
        original(self, proposal)

    monkeypatch.setattr(Chain, "share_proposal", spy)
    return calls


# A correlated Gaussian in standardised units, as the calibrator's chains
# see their posteriors: burn-ins of 1000 steps reach it.
UNIT_COV = np.array([[1.0, RHO], [RHO, 1.0]])
UNIT_PRECISION = np.linalg.inv(UNIT_COV)


def unit_gaussian(theta):
    return -0.5 * float(theta @ UNIT_PRECISION @ theta)


@pytest.mark.parametrize("verbose", [0, 1])
def test_the_chains_draw_from_one_proposal_fitted_to_all_their_burn_ins(
    monkeypatch, verbose
):
    calls = _shared_proposals(monkeypatch)
    z = np.random.default_rng(1).normal(size=(4, 2))
    _mixed(
        unit_gaussian,
        2.0 * z @ np.linalg.cholesky(UNIT_COV).T,
        0.9,
        1,
        n_samples=500,
        burn_in=1000,
        verbose=verbose,
    )
    # Once per chain, at the end of the burn-in, whatever the segments.
    assert [(c, steps) for c, steps, _ in calls] == [(c, 1000) for c in range(4)]
    proposal = calls[0][2]
    for _, _, other in calls[1:]:
        np.testing.assert_array_equal(other.mean, proposal.mean)
        np.testing.assert_array_equal(other.chol, proposal.chol)
    # One Gaussian component fits a Gaussian target best: the Student-t of
    # the latest halves of four burn-ins, 2000 draws, with the target's
    # moments (over seeds 0-7, means within 0.08, sds within 4 %, the
    # correlation within 0.013).
    assert isinstance(proposal, TProposal)
    mean = proposal.mean
    cov = proposal.chol @ proposal.chol.T / T_VARIANCE_FACTOR
    assert np.all(np.abs(mean) < 0.15)
    sd = np.sqrt(np.diag(cov))
    assert np.all((0.9 < sd) & (sd < 1.1))
    assert abs(cov[0, 1] / (sd[0] * sd[1]) - RHO) < 0.03


# Two modes, 0.3 and 0.7 of the mass, that one Student-t spans poorly.
TWO_MODES = np.array([[-2.0, 0.0], [2.0, 1.0]])
TWO_MODE_WEIGHTS = np.array([0.3, 0.7])
TWO_MODE_SD = 0.6


class _TwoModes:
    modes, sd = TWO_MODES, TWO_MODE_SD

    def __call__(self, theta):
        return float(self.batch(theta[None, :])[0])

    def batch(self, thetas):
        z = (thetas[:, None, :] - self.modes[None]) / self.sd
        return logsumexp(
            -0.5 * np.sum(z**2, axis=-1) + np.log(TWO_MODE_WEIGHTS), axis=1
        )


@pytest.mark.parametrize("seed", [0, 1])
def test_a_mixture_proposal_samples_two_modes_with_more_acceptances(monkeypatch, seed):
    def run():
        starts = np.random.default_rng(seed).normal(size=(4, 2)) * 2.0
        return _mixed(_TwoModes(), starts, 0.9, seed, n_samples=2000, burn_in=1000)

    mixed = run()
    mean = TWO_MODE_WEIGHTS @ TWO_MODES
    var = TWO_MODE_WEIGHTS @ (TWO_MODES**2 + TWO_MODE_SD**2) - mean**2
    _assert_moments(mixed, mean, var)
    # The Student-t alone (one component): measured 0.33-0.38 over seeds
    # 0-2, against 0.62-0.65 with the mixture.
    monkeypatch.setattr(proposals, "MAX_COMPONENTS", 1)
    single = run()
    _assert_moments(single, mean, var)
    assert np.all(mixed.independence_rate > 0.55)
    assert np.all(single.independence_rate < 0.45)
    assert np.all(mixed.ess > 1.5 * single.ess)


@pytest.mark.parametrize(
    "n_chains, independence, burn_in", [(1, 0.9, 1000), (4, 0.0, 1000), (4, 0.9, 50)]
)
def test_no_shared_proposal_without_chains_moves_or_burn_in_to_pool(
    monkeypatch, n_chains, independence, burn_in
):
    calls = _shared_proposals(monkeypatch)
    _mixed(
        correlated_gaussian,
        dispersed_starts(n_chains, seed=1),
        independence,
        1,
        n_samples=100,
        burn_in=burn_in,
    )
    assert calls == []


def _chain_at_zero(log_density, n_samples, **kwargs):
    """A chain of 100 burn-in steps with independence moves, from the origin."""
    return Chain(
        np.zeros(2),
        log_density(np.zeros(2)),
        np.eye(2),
        0,
        n_samples=n_samples,
        burn_in=100,
        adapt=True,
        chain=0,
        independence=0.9,
        **kwargs,
    )


def test_the_shared_proposal_is_set_between_burn_in_and_draws():
    chain = _chain_at_zero(standard_normal, 100)
    with pytest.raises(RuntimeError, match="after the burn-in and before the first"):
        chain.share_proposal(TProposal.of(np.zeros(2), np.eye(2)))
    chain.advance(standard_normal, 150)
    with pytest.raises(RuntimeError, match="after the burn-in and before the first"):
        chain.share_proposal(TProposal.of(np.zeros(2), np.eye(2)))


def test_a_labelled_chain_without_its_own_student_t_gets_a_label_proposal():
    # A joint chain whose windows never held enough accepted moves ends its
    # burn-in without a Student-t, hence without a label proposal (the
    # validity suite's a2 seed 170, the first pass); the shared Student-t
    # comes with the label proposal of its window.
    target = _GaussianMixture()
    chain = _chain_at_zero(target, 250, n_labels=3)
    chain.advance(target, 100)
    chain.proposal, chain.label_probs = None, None  # as after such a burn-in
    chain.share_proposal(TProposal.of(*target.moments()))
    conditionals = chain.label_conditionals[1:2].mean(axis=0)
    np.testing.assert_allclose(chain.label_probs, label_proposal(conditionals))
    chain.advance(target, 350)
    assert chain.drawn == 250 and np.all(np.isfinite(chain.samples))
    assert chain.n_independent > 0


# Two modes 8 apart (0.3 and 0.7 of the mass), which a random walk started
# in one does not cross in a short burn-in.
FAR_MODES = np.array([[-4.0, 0.0], [4.0, 1.0]])
FAR_MODE_SD = 0.5


class _FarModes(_TwoModes):
    modes, sd = FAR_MODES, FAR_MODE_SD


@pytest.mark.parametrize("seed", [0, 1])
def test_proposal_points_give_a_short_burn_in_the_mode_it_did_not_visit(
    monkeypatch, seed
):
    # Every chain starts in the lighter mode and burns in 100 steps, whose
    # windows see that mode alone. Independent draws of the target (as an
    # earlier run's draws reweighted to it would be) fit the shared
    # proposal to both.
    rng = np.random.default_rng(seed)
    starts = FAR_MODES[0] + 0.3 * rng.normal(size=(4, 2))
    modes = rng.choice(2, size=400, p=TWO_MODE_WEIGHTS)
    points = FAR_MODES[modes] + FAR_MODE_SD * rng.normal(size=(400, 2))
    calls = _shared_proposals(monkeypatch)

    def run(points):
        return _mixed(
            _FarModes(),
            starts,
            0.9,
            seed,
            n_samples=2000,
            burn_in=100,
            proposal_points=points,
        )

    informed = run(points)
    assert [steps for _, steps, _ in calls] == [100] * 4
    mean = TWO_MODE_WEIGHTS @ FAR_MODES
    var = TWO_MODE_WEIGHTS @ (FAR_MODES**2 + FAR_MODE_SD**2) - mean**2
    _assert_moments(informed, mean, var)
    assert np.all(informed.rhat < 1.01)
    heavier = (informed.samples[:, :, 0] > 0).mean(axis=1)
    assert np.all(np.abs(heavier - TWO_MODE_WEIGHTS[1]) < 0.1), heavier
    # Without them the chains stay where they started (measured, seeds
    # 0-3: R-hat 1.2-1.4, three chains of four in the lighter mode).
    alone = run(None)
    assert np.all(alone.rhat > 1.05)


def test_proposal_points_of_another_target_leave_the_draws_exact():
    # The points set the proposal only: drawn from a shifted, narrow
    # distribution, the chains still sample the target.
    points = np.random.default_rng(3).normal(1.0, 0.3, size=(500, 2))
    result = _mixed(
        unit_gaussian,
        dispersed_starts(4, seed=3),
        0.9,
        3,
        n_samples=3000,
        burn_in=200,
        proposal_points=points,
    )
    _assert_moments(result, np.zeros(2), np.ones(2))
