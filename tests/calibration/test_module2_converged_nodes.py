"""The integral over module 2's hyperparameters to a stated Monte Carlo error
with several calibration parameters (skmba.calibration._module2_converged_nodes,
``discrepancy_tol`` with ``r >= 2``)."""

import warnings
from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

import skmba.calibration._module2_converged_nodes as nodes
from skmba import ModularBayesCalibrator
from skmba.calibration._module2_theta_grid import INTERVAL
from validation.cases import case_a2


def test_weighted_quantiles_are_hazens_with_equal_weights():
    x = np.random.default_rng(0).normal(size=101)
    probs = [0.025, 0.3, 0.5, 0.975]
    got = nodes.weighted_quantiles(x, np.full(101, 1 / 101), probs)
    np.testing.assert_allclose(got, np.quantile(x, probs, method="hazen"), rtol=1e-12)


def test_node_proposal_draws_its_own_density():
    """A Student-t and, for an eighth of the nodes, the prior carried to the
    sampling coordinates: log densities of the mixture, the prior's part
    checked against a density transformed by hand (E, of support [1, 3],
    log with soft ends, its Jacobian by central differences; the other
    linear)."""
    from skmba.calibration._module3_posterior import LogPosterior
    from skmba.priors._theta import check_prior

    prior = check_prior([stats.uniform(1.0, 2.0), stats.norm(0.0, 1.0)])
    theta_sim = np.column_stack([np.linspace(1.0, 3.0, 9), np.linspace(-2, 2, 9)])
    log_post = LogPosterior(prior, None, SimpleNamespace(), theta_sim)
    assert list(log_post.coordinates.log_dims) == [True, False]
    assert list(log_post.coordinates.bounded_dims) == [True, False]
    U = log_post.to_u(np.column_stack([np.full(400, 2.0), np.zeros(400)]))
    U = U + np.random.default_rng(1).normal(scale=[0.1, 0.3], size=U.shape)
    proposal = nodes.NodeProposal.around(log_post, U)
    draws, log_q = proposal.draw(4096, np.random.SeedSequence(0))
    t = stats.multivariate_t(proposal.mean, proposal.cov, df=nodes.PROPOSAL_DF)
    theta = log_post.from_u(draws)
    h = 1e-6
    step = np.array([h, 0.0])
    slope = (log_post.from_u(draws + step) - log_post.from_u(draws - step))[:, 0]
    with np.errstate(divide="ignore"):
        log_p = (
            stats.uniform(1.0, 2.0).logpdf(theta[:, 0])
            + np.log(slope / (2 * h))
            + stats.norm.logpdf(theta[:, 1])
            + np.log(log_post.coordinates.u_scale[1])
        )
    share = nodes.PRIOR_SHARE
    expected = np.logaddexp(np.log1p(-share) + t.logpdf(draws), np.log(share) + log_p)
    # (the central differences' error, about 1e-9 in the log slope)
    np.testing.assert_allclose(log_q, expected, rtol=0, atol=1e-7)
    # the prior's eighth lies in its support; the t's moments are the fit's
    n_prior = round(share * 4096)
    assert np.all((theta[-n_prior:, 0] > 1.0) & (theta[-n_prior:, 0] < 3.0))
    head = draws[:-n_prior]
    np.testing.assert_allclose(head.mean(axis=0), proposal.mean, atol=0.02)
    np.testing.assert_allclose(
        np.cov(head, rowvar=False), 5 / 3 * proposal.cov, rtol=0.15, atol=1e-3
    )


def test_node_errors_are_the_spread_of_repeated_estimates():
    """Self-normalised importance sampling of a correlated Gaussian from an
    inflated Student-t: over 400 independent repetitions the reported
    standard errors of the mean, sd and 95 % ends are the spread of the
    estimates (rms z near 1; 400 repetitions put an honest rms z in about
    [0.93, 1.07], the ends' density estimate adds its own error)."""
    rng = np.random.default_rng(2)
    mean, cov = np.array([1.0, -1.0]), np.array([[1.0, 0.6], [0.6, 0.5]])
    target = stats.multivariate_normal(mean, cov)
    sd = np.sqrt(np.diag(cov))
    truth = np.vstack([mean, sd, mean + stats.norm.ppf(INTERVAL)[:, None] * sd])
    proposal = stats.multivariate_t(mean + 0.3, 2.25 * cov, df=5)
    z = []
    for _ in range(400):
        theta = proposal.rvs(800, random_state=rng)
        log_w = target.logpdf(theta) - proposal.logpdf(theta)
        summaries, w = nodes.node_summaries(log_w[:, None], theta)
        se = nodes.node_errors(theta, w, summaries)
        z.append((summaries - truth) / se)
    rms = np.sqrt(np.mean(np.square(z), axis=0))
    assert np.all(rms > 0.8) and np.all(rms < 1.2), rms


def test_errors_over_nodes_and_draws_match_their_spread_over_replicates():
    """Both errors on a mixture whose answer is known: phi ~ N(0, 1) drawn
    from a Student-t with 4 degrees of freedom (weights p / q), theta | phi
    ~ N(phi b, 0.5^2 I) with b = (1, -0.5) at nodes of an inflated
    bivariate t, so theta_j ~ N(0, b_j^2 + 0.25).

    With 256 nodes held fixed, the error over the draws of the mean and sd
    matches their spread over 200 replicates of 256 draws (rms z about the
    replicates' mean within 0.85-1.15; measured 0.93-1.03 over seeds 0-3,
    where four blocks' spread, the estimate used before, gives 1.3-2.7).
    With 512 nodes and the draws both fresh, the two errors in quadrature
    match the deviations from the truth over 200 replicates (mean and sd
    within 0.85-1.15, measured 0.87-1.11; the ends within 0.8-1.2, as their
    density estimate adds an error of its own, measured 0.96-1.15). The
    ends' error over the draws alone is not checked: given the nodes it
    scales with their local spacing rather than the density (rms z 0.4-1.4
    over three node sets), which averages out over fresh nodes."""
    b = np.array([1.0, -0.5])
    sd = np.sqrt(b**2 + 0.25)
    truth = np.vstack([np.zeros(2), sd, stats.norm.ppf(INTERVAL)[:, None] * sd])
    node_q = stats.multivariate_t(np.zeros(2), np.diag(2.25 * sd**2), df=5)
    phi_q = stats.t(4)
    rng = np.random.default_rng(0)

    def errors(theta, phi):
        d = theta[:, None, :] - phi[None, :, None] * b
        log_w = stats.norm.logpdf(phi) - phi_q.logpdf(phi)
        A = -2.0 * np.sum(d**2, axis=2) - node_q.logpdf(theta)[:, None] + log_w
        return nodes._errors(SimpleNamespace(A=A, theta=theta))

    def rms(z):
        return np.sqrt(np.mean(np.square(z), axis=0))

    theta = node_q.rvs(256, random_state=rng)
    fixed = [errors(theta, phi_q.rvs(256, random_state=rng)) for _ in range(200)]
    pooled = np.array([f[0] for f in fixed])
    z = (pooled - pooled.mean(axis=0)) / np.array([f[2] for f in fixed])
    got = rms(z * np.sqrt(200 / 199))[:2]
    assert np.all((got > 0.85) & (got < 1.15)), got
    z = []
    for _ in range(200):
        pooled, _, se_phi, se_theta = errors(
            node_q.rvs(512, random_state=rng), phi_q.rvs(256, random_state=rng)
        )
        z.append((pooled - truth) / np.hypot(se_phi, se_theta))
    got = rms(z)
    assert np.all((got[:2] > 0.85) & (got[:2] < 1.15)), got
    assert np.all((got[2:] > 0.8) & (got[2:] < 1.2)), got


@pytest.fixture(scope="module")
def case():
    return case_a2(0)


def _fit(case, random_state, tol):
    """The fit and the messages of the UserWarnings it raised."""
    cal = ModularBayesCalibrator(
        prior=case.prior, random_state=random_state, discrepancy_tol=tol
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cal.fit(
            case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim, y_sim=case.y_sim
        )
    return cal, [str(w.message) for w in caught if issubclass(w.category, UserWarning)]


def test_several_parameters_integrate_at_weighted_nodes(case, monkeypatch):
    """The first round, at a budget of (node, draw) pairs that ends it: the
    fit says it fell short and what it spent, the posterior is the weighted
    nodes, its errors are reported per parameter, the same seed gives the
    same bits, and the fit predicts."""
    budget = nodes.MIN_GROUPS * nodes.N_GROUP * nodes.MIN_BLOCKS * nodes.N_BLOCK
    monkeypatch.setattr(nodes, "MAX_PAIRS", budget)
    cal, messages = _fit(case, 0, 1e-3)
    assert not any("is not applied" in m for m in messages)
    said = [m for m in messages if "did not reach its Monte Carlo tolerance" in m]
    assert len(said) == 1, messages
    spent = f"in {cal.discrepancy_draws_} draws at {len(cal.theta_nodes_)} nodes"
    assert spent in said[0]
    assert len(cal.theta_nodes_) * cal.discrepancy_draws_ <= budget
    assert cal.theta_nodes_.shape[1] == 2
    assert len(cal.theta_nodes_) >= nodes.MIN_GROUPS * nodes.N_GROUP
    np.testing.assert_allclose(cal.theta_weights_.sum(), 1.0)
    np.testing.assert_allclose(cal.theta_mean_, cal.theta_weights_ @ cal.theta_nodes_)
    assert cal.theta_mcse_.shape == (4, 2) and np.all(np.isfinite(cal.theta_mcse_))
    sd = np.sqrt(np.diag(cal.theta_cov_))
    assert np.all(cal.theta_mcse_ > 1e-4 * sd)
    assert cal.discrepancy_draws_ >= nodes.MIN_BLOCKS * nodes.N_BLOCK
    assert np.all(np.isfinite(cal.summary()["mcse_sd"]))
    assert cal.summary(kind="text").startswith(
        "ModularBayesCalibrator (importance nodes)"
    )
    posterior = cal.to_inference_data().posterior
    assert posterior.attrs["sampler"] == "importance nodes (skmba)"
    assert np.isfinite(posterior.attrs["mcse_sd_theta1"])
    again, _ = _fit(case, 0, 1e-3)
    np.testing.assert_array_equal(again.theta_weights_, cal.theta_weights_)
    mean, std = cal.predict(case.X[:3], return_std=True)
    assert mean.shape == (3, 2) and np.all(std > 0)


@pytest.mark.slow
def test_same_data_same_interval_within_the_reported_error(case):
    """Two seeds at the default tolerance differ by their reported Monte
    Carlo errors, no more (4 combined standard errors), and those errors
    are what was asked or the fit said it fell short."""
    (a, said_a), (b, said_b) = (
        _fit(case, random_state, 0.05) for random_state in (0, 1)
    )

    def summaries(cal):
        ends = [
            nodes.weighted_quantiles(t, cal.theta_weights_, INTERVAL)
            for t in cal.theta_nodes_.T
        ]
        sd = np.sqrt(np.diag(cal.theta_cov_))
        return np.vstack([cal.theta_mean_, sd, np.array(ends).T])

    se = np.hypot(a.theta_mcse_, b.theta_mcse_)
    assert np.all(np.abs(summaries(a) - summaries(b)) <= 4 * se)
    for cal, said in ((a, said_a), (b, said_b)):
        relative = cal.theta_mcse_ / np.sqrt(np.diag(cal.theta_cov_))
        met = np.all(relative[:2] <= 0.05) and np.all(relative[2:] <= 0.1)
        assert met or any("did not reach" in m for m in said)
