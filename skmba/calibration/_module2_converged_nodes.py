"""Module 2's hyperparameters integrated out to a stated Monte Carlo error,
with several calibration parameters.

The counterpart of :mod:`~skmba.calibration._module2_converged` for ``r >= 2``
parameters, where a grid over theta would need too many nodes. Theta is
integrated by importance sampling at nodes ``u_i`` of the sampling
coordinates of :class:`~skmba.calibration._module3_posterior.LogPosterior`,
drawn from a Student-t fitted to the first pass's draws (:class:`NodeProposal`),
and the hyperparameters ``phi`` by the draws of
:func:`~skmba.calibration._module2_posterior.proposal_draws` around the mode of
their marginal posterior (:func:`~skmba.calibration._module2_converged.
marginal_laplace`, theta integrated over the first nodes), as with one
parameter. Node ``i`` and draw ``k`` carry the joint log weight::

    A_ik = log p(u_i) + log p(data | theta_i, phi_k) - log q(u_i)
           + log p(phi_k) - log q(phi_k),

so theta's posterior is the nodes weighted by ``sum_k exp(A_ik)``, module
4's rule is pairs drawn from ``A`` and the noise's posterior mean comes
from the draws' marginal weights (one posterior for ``phi``). Nodes come in
groups of :data:`N_GROUP` scrambled Halton points, draws in blocks of
:data:`~skmba.calibration._module2_converged.N_BLOCK`: the Monte Carlo error
of each summary (mean, sd and 95 % ends of each parameter) adds in squares
its errors over the draws of ``phi`` (each draw entering through its
conditional posterior of theta on the nodes) and over the nodes (each
through its value), both the delta method's (:func:`node_errors`), and the
larger part grows until both together are below the tolerance
(:func:`converge_nodes`).

Examples
--------
>>> import numpy as np
>>> weighted_quantiles(np.array([0.0, 1.0, 2.0, 3.0]), np.full(4, 0.25), [0.5])
array([1.5])
"""

import math
from dataclasses import dataclass

import numpy as np
from scipy import special, stats

from skmba._core.linalg import proposal_covariance
from skmba._core.validation import seed_sequence
from skmba.calibration._module2_converged import (
    ADAPT_SHARE,
    END_TOLERANCE,
    INFLATION,
    MAX_DRAWS,
    N_BLOCK,
    PRIOR_SHARE,
    ConvergedIntegral,
    MonteCarloError,
    adapted,
    kish_share,
    marginal_laplace,
    mixture_draws,
    rule_pairs,
    tolerances,
    warn_unmet,
)
from skmba.calibration._module2_errors import (
    draw_conditionals,
    influence_errors,
    moment_influences,
)
from skmba.calibration._module2_posterior import (
    PROPOSAL_DF,
    halton_student_t,
    proposal_draws,
)
from skmba.calibration._module2_theta_grid import INTERVAL, GridEvaluator
from skmba.mcmc._posterior import PosteriorResult
from skmba.mcmc._reweight import systematic_indices

#: Nodes per randomised group (a power of two, for the Halton points).
N_GROUP = 64
#: Groups of nodes and blocks of draws before the first check of the error.
MIN_GROUPS, MIN_BLOCKS = 4, 4
#: Most refits of the nodes' proposal to their weights.
NODE_ADAPTATIONS = 3
#: Most nodes; and most (node, draw) pairs, each a factorisation.
MAX_NODES, MAX_PAIRS = 2048, 2**20


@dataclass(frozen=True)
class NodeProposal:
    """A defensive mixture in the sampling coordinates of theta: a
    Student-t (``mean``, ``cov`` already inflated, :data:`~skmba.calibration.
    _module2_posterior.PROPOSAL_DF` degrees of freedom) and, with share
    :data:`~skmba.calibration._module2_converged.PRIOR_SHARE`, the prior of
    theta itself (``log_post``'s prior carried to its coordinates), so that
    a first pass that missed the posterior (chains stuck at a bound of the
    prior) leaves nodes where the posterior is."""

    mean: np.ndarray
    cov: np.ndarray
    log_post: object

    @classmethod
    def around(cls, log_post, U, weights=None):
        """Fitted to the rows of ``U`` (weighted), inflated by
        :data:`~skmba.calibration._module2_converged.INFLATION`."""
        mean = np.average(U, axis=0, weights=weights)
        cov = np.atleast_2d(np.cov(U, rowvar=False, aweights=weights))
        return cls(mean, INFLATION**2 * proposal_covariance(cov), log_post)

    def log_prior(self, U):
        """The prior's log density in the sampling coordinates (the
        Jacobian of ``u = (log theta - mean) / scale`` or of its linear
        counterpart included); ``-inf`` outside its support."""
        lp = self.log_post
        theta = lp.from_u(U)
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.ravel(lp.prior.logpdf(theta)) + np.sum(
                np.log(lp.coordinates.u_scale)
            )
            out = out + lp.log_jacobian(theta)
        return np.where(np.isnan(out), -np.inf, out)

    def draw(self, n, seed):
        """``n`` draws (scrambled Halton for the Student-t, the prior's for
        the rest) and their log densities under the mixture."""
        r = len(self.mean)
        t_seed, p_seed = seed.spawn(2)
        n_prior = round(PRIOR_SHARE * n)
        prior_draws = self.log_post.prior.rvs(
            n_prior, random_state=np.random.default_rng(p_seed)
        )
        prior_u = self.log_post.to_u(np.reshape(prior_draws, (n_prior, r)))
        U = np.vstack(
            [halton_student_t(self.mean, self.cov, n - n_prior, t_seed), prior_u]
        )
        t = stats.multivariate_t(self.mean, self.cov, df=PROPOSAL_DF)
        log_q = np.logaddexp(
            np.log1p(-PRIOR_SHARE) + np.atleast_1d(t.logpdf(U)),
            np.log(PRIOR_SHARE) + self.log_prior(U),
        )
        return U, log_q


class NodeEvaluator(GridEvaluator):
    """``log p(u_i) + log p(data | theta_i, phi_k)`` (N, K) at nodes ``u_i``
    of ``log_post`` for draws ``v_k``; ``log_marginal`` for
    :func:`~skmba.calibration._module2_converged.marginal_laplace`."""

    def __init__(self, base, space, scaler, log_post):
        super().__init__(base, space, scaler)
        self.log_post = log_post

    def __call__(self, V, U):
        mixture = self.mixture(np.atleast_2d(V))
        out = self.log_post.with_model(mixture).log_density_u_components(U)
        return np.where(np.isnan(out), -np.inf, out)

    def log_marginal(self, V, nodes):
        """``log p(phi) + log mean_i exp(A_i - log q(u_i))`` (K,) over the
        ``nodes`` ``(U, log_q)``."""
        V = np.atleast_2d(V)
        U, log_q = nodes
        L = self(V, U) - log_q[:, None]
        log_prior = np.array([self.space.log_prior(v) for v in V])
        with np.errstate(invalid="ignore"):
            return special.logsumexp(L, axis=0) - math.log(len(U)) + log_prior


def weighted_quantiles(x, w, probs):
    """Quantiles ``probs`` of the values ``x`` with weights ``w`` (summing to
    one): the weighted empirical distribution, linear between the values'
    midpoints of mass."""
    order = np.argsort(x, kind="stable")
    xs, ws = x[order], w[order]
    return np.interp(probs, np.cumsum(ws) - 0.5 * ws, xs)


def node_summaries(A, theta):
    """Mean, sd and 95 % ends (4, r) of the nodes ``theta`` (N, r) weighted
    by ``A`` (N, K) summed over its columns, and the normalised weights."""
    log_mass = special.logsumexp(A, axis=1)
    w = np.exp(log_mass - special.logsumexp(log_mass))
    mean = w @ theta
    sd = np.sqrt(np.maximum(w @ (theta - mean) ** 2, 0.0))
    ends = np.array([weighted_quantiles(t, w, INTERVAL) for t in theta.T]).T
    return np.vstack([mean, sd, ends]), w


@dataclass(frozen=True)
class _Pairs:
    """Nodes (sampling coordinates ``U``, user units ``theta``, log proposal
    ``log_q``, group) and draws (``V``, log weights ``log_w``; whole blocks
    of :data:`~skmba.calibration._module2_converged.N_BLOCK`), and the log
    density ``L`` (nodes x draws)."""

    U: np.ndarray
    theta: np.ndarray
    log_q: np.ndarray
    group: np.ndarray
    V: np.ndarray
    log_w: np.ndarray
    L: np.ndarray

    @property
    def A(self):
        return self.L - self.log_q[:, None] + self.log_w[None, :]


def _with_groups(pairs, evaluate, proposal, n_groups, seed):
    """``pairs`` with node groups added up to ``n_groups`` (evaluated at
    every draw so far)."""
    for g in range(int(pairs.group.max()) + 1 if len(pairs.group) else 0, n_groups):
        U, log_q = proposal.draw(N_GROUP, seed.spawn(1)[0])
        L = evaluate(pairs.V, U)
        theta = evaluate.log_post.from_u(U)
        pairs = _Pairs(
            np.vstack([pairs.U, U]),
            np.vstack([pairs.theta, theta]),
            np.r_[pairs.log_q, log_q],
            np.r_[pairs.group, np.full(len(U), g)],
            pairs.V,
            pairs.log_w,
            np.vstack([pairs.L, L]),
        )
    return pairs


def _with_blocks(pairs, evaluate, proposal, n_blocks, seed):
    """``pairs`` with draw blocks added up to ``n_blocks`` (evaluated at
    every node so far)."""
    space, mode, cov = proposal
    for _ in range(len(pairs.log_w) // N_BLOCK, n_blocks):
        V, log_p, log_q = proposal_draws(
            space.coordinates, mode, cov, N_BLOCK, seed.spawn(1)[0], PRIOR_SHARE
        )
        L = evaluate(V, pairs.U)
        pairs = _Pairs(
            pairs.U,
            pairs.theta,
            pairs.log_q,
            pairs.group,
            np.vstack([pairs.V, V]),
            np.r_[pairs.log_w, log_p - log_q],
            np.hstack([pairs.L, L]),
        )
    return pairs


def inverse_densities(theta, w):
    """One over the density of each parameter at its 95 % interval ends
    (2, r), for the nodes ``theta`` (N, r) weighted by ``w``: the distance
    between the weighted quantiles ``p / 2`` either side of each end's
    level ``p``, over ``p``."""
    out = []
    for p in INTERVAL:
        h = min(p, 1 - p) / 2
        width = [np.diff(weighted_quantiles(t, w, [p - h, p + h]))[0] for t in theta.T]
        out.append(np.array(width) / (2 * h))
    return np.array(out)


def node_errors(theta, w, summaries):
    """Standard errors (4, r) of the ``summaries`` (4, r: mean, sd, 95 %
    ends) of the nodes ``theta`` (N, r) with self-normalised importance
    weights ``w``, over the nodes (the integral over ``phi`` taken as
    exact): the delta method, ``sum_i w_i^2 g_i^2`` for each summary's
    influence ``g`` (Owen 2013, Monte Carlo theory, ch. 9), the ends'
    divided by the density there (:func:`inverse_densities`)."""
    mean, sd = summaries[0], summaries[1]
    centred = theta - mean
    se_mean = influence_errors(w, centred)
    se_sd = influence_errors(w, centred**2 - sd**2) / (2.0 * np.maximum(sd, 1e-300))
    scales = inverse_densities(theta, w)
    ends = []
    for p, q, scale in zip(INTERVAL, summaries[2:], scales, strict=True):
        below = (theta <= q).astype(float) - p
        ends.append(influence_errors(w, below) * scale)
    return np.vstack([se_mean, se_sd, *ends])


def draw_errors(A, theta, summaries, w):
    """Standard errors (4, r) of the ``summaries`` over the draws of
    ``phi`` (the nodes taken as fixed), from the joint log weights ``A``
    (N nodes, K draws): the delta method over the draws, each entering
    through its conditional posterior of theta on the nodes (its mean,
    mean square deviation and CDF at each end; :func:`~skmba.calibration.
    _module2_converged.moment_influences`), the ends' scaled as in
    :func:`node_errors`. NaN when no draw has weight."""
    conditionals = draw_conditionals(A)
    if conditionals is None:
        return np.full(summaries.shape, np.nan)
    share, P, _ = conditionals
    scales = inverse_densities(theta, w)
    with np.errstate(divide="ignore", invalid="ignore"):
        influence = moment_influences(theta, P, summaries[0], summaries[1])
        for p, q, scale in zip(INTERVAL, summaries[2:], scales, strict=True):
            below = (theta <= q).astype(float)
            influence.append(((below.T @ P).T - p) * scale)
        return influence_errors(share, np.stack(influence, axis=1))


def _errors(pairs):
    """The pooled summaries (4, r), node weights, and the standard errors
    (4, r) over ``phi`` (:func:`draw_errors`) and over theta
    (:func:`node_errors`)."""
    A, theta = pairs.A, pairs.theta
    pooled, w = node_summaries(A, theta)
    return pooled, w, draw_errors(A, theta, pooled, w), node_errors(theta, w, pooled)


def _empty(r, m):
    return _Pairs(
        np.empty((0, r)),
        np.empty((0, r)),
        np.empty(0),
        np.empty(0, int),
        np.empty((0, m)),
        np.empty(0),
        np.empty((0, 0)),
    )


def _start(evaluate, node_proposal, module2, seeds, say):
    """The first nodes, the marginal posterior's mode of ``phi`` on them and
    the draws' proposal around it."""
    space = module2.coordinates
    U, log_q = node_proposal.draw(N_GROUP, seeds.spawn(1)[0])
    mode, cov = marginal_laplace(evaluate, (U, log_q), module2.mode_coordinates)
    say("module 2: the marginal posterior's mode of the hyperparameters found")
    return (space, mode, INFLATION**2 * cov)


def _refit_proposals(pairs, w, nodes, proposal, rounds, say):
    """After a first round: the nodes' proposal refitted to their weights
    where their Kish share is below :data:`~skmba.calibration.
    _module2_converged.ADAPT_SHARE` (again on the next round, at most
    :data:`NODE_ADAPTATIONS` times: a first pass stuck at a bound of the
    prior leaves its nodes far from the posterior, which the prior's share
    of the nodes finds a step at a time), the draws' proposal likewise
    (once, as with one parameter). Returns the rounds of adaptation left,
    both proposals and whether the draws start again."""
    redo = False
    if 1.0 / np.sum(w**2) / len(w) < ADAPT_SHARE:
        nodes, redo = NodeProposal.around(nodes.log_post, pairs.U, weights=w), True
        say("module 3: the nodes' proposal refitted to their weights")
    if rounds == NODE_ADAPTATIONS and kish_share(pairs.A) < ADAPT_SHARE:
        proposal, redo = adapted(proposal, pairs, pairs.A), True
        say("module 2: the proposal refitted to the first draws' weights")
    return (rounds - 1 if redo else 0), nodes, proposal, redo


def converge_nodes(
    module2, base, log_post, first, *, tol, n_samples, random_state=None, say=None
):
    """The integral over ``phi`` to ``tol`` posterior sds, several parameters.

    Parameters
    ----------
    module2 : HyperposteriorDraws
        Module 2's mode and coordinates.
    base : GlobalModel
        The global model at that mode.
    log_post : LogPosterior
        Theta's prior and sampling coordinates (its model is replaced).
    first : PosteriorResult
        A first posterior of theta (draws): where the nodes start.
    tol : float
        Target Monte Carlo standard error of each parameter's posterior
        mean, sd and (``END_TOLERANCE`` times it) 95 % interval ends, in
        posterior sds.
    n_samples : int
        Posterior draws of theta to return (resampled from the nodes).
    random_state : int, SeedSequence or None
    say : callable, default=None

    Returns
    -------
    ConvergedIntegral
    """
    say = say or (lambda message: None)
    evaluate = NodeEvaluator(base, module2.coordinates, log_post.scaler, log_post)
    node_seed, draw_seed, sample_seed, rule_seed = seed_sequence(random_state).spawn(4)
    nodes = NodeProposal.around(log_post, log_post.to_u(first.samples))
    proposal = _start(evaluate, nodes, module2, node_seed, say)
    r, m = len(nodes.mean), len(proposal[1])
    n_groups, n_blocks, rounds = MIN_GROUPS, MIN_BLOCKS, NODE_ADAPTATIONS
    pairs = _empty(r, m)
    while True:
        pairs = _with_blocks(pairs, evaluate, proposal, n_blocks, draw_seed)
        pairs = _with_groups(pairs, evaluate, nodes, n_groups, node_seed)
        pooled, w, se_phi, se_theta = _errors(pairs)
        if rounds > 0:  # the first rounds: refit a proposal that missed
            rounds, nodes, proposal, redo = _refit_proposals(
                pairs, w, nodes, proposal, rounds, say
            )
            if redo:
                pairs = _empty(r, m)
                continue
        scale = tolerances(tol)[:, None] * pooled[1][None, :]
        part_phi, part_theta = np.max(se_phi / scale), np.max(se_theta / scale)
        relative = np.sqrt(se_phi**2 + se_theta**2) / pooled[1][None, :]
        _say(say, pairs, w, relative, (part_phi, part_theta), tol)
        total = float(np.max(relative / tolerances(tol)[:, None]))
        n_nodes, n_draws = len(pairs.U), len(pairs.V)
        cap_groups = min(MAX_NODES // N_GROUP, MAX_PAIRS // (N_GROUP * n_draws))
        cap_blocks = min(MAX_DRAWS // N_BLOCK, MAX_PAIRS // (N_BLOCK * n_nodes))
        room_nodes, room_draws = cap_groups > n_groups, cap_blocks > n_blocks
        if total <= 1.0 or not (room_nodes or room_draws):
            break
        if room_nodes and (part_theta >= part_phi or not room_draws):
            n_groups = _grown(n_groups, part_theta, part_phi, cap_groups)
        else:
            n_blocks = _grown(n_blocks, part_phi, part_theta, cap_blocks)
    hyper = mixture_draws(module2, evaluate, pairs.V, pairs.log_w, proposal, pairs.A)
    picked = systematic_indices(w, n_samples, np.random.default_rng(sample_seed))
    samples = pairs.theta[picked]
    posterior = PosteriorResult.from_rule(
        samples, pairs.theta, w, (pairs.theta.min(axis=0), pairs.theta.max(axis=0))
    )
    se = np.sqrt(se_phi**2 + se_theta**2)
    error = MonteCarloError(*se, len(pairs.V), hyper.noise_ess, total <= 1.0)
    spent = (
        f"{len(pairs.V)} draws at {len(pairs.U)} nodes of theta (its budget: "
        f"{MAX_DRAWS} draws, {MAX_NODES} nodes, {MAX_PAIRS} node-draw pairs)"
    )
    warn_unmet(error, relative, tol, 0.0, spent)
    return ConvergedIntegral(
        hyper,
        posterior,
        error,
        *rule_pairs(pairs.A, pairs.theta, rule_seed),
        models=evaluate.models(pairs.V),
    )


def _grown(n, part, other, cap):
    """Groups (or blocks) for the next round: as many as the error's decay
    as ``1 / sqrt(count)`` asks for ``part`` (its error over the tolerance)
    to leave room for ``other`` (the other integral's; the two add in
    squares), at least one more, at most twice as many and ``cap``."""
    room = max(1.0 - other**2, 0.25) if math.isfinite(other) else 0.25
    needed = math.ceil(n * part**2 / room) if math.isfinite(part) else 2 * n
    return min(max(needed, n + 1), 2 * n, cap)


def _say(say, pairs, w, relative, parts, tol):
    """The progress line of a round: draws, nodes (weights ``w``), the
    largest errors of each summary and the shares of ``phi`` and theta in
    them."""
    ess_nodes = 1.0 / np.sum(w**2)
    ess_draws = kish_share(pairs.A) * len(pairs.V)
    say(
        f"module 2: {len(pairs.V)} draws of the hyperparameters (effective "
        f"{ess_draws:.0f}) at {len(pairs.U)} nodes of theta (effective "
        f"{ess_nodes:.0f}); Monte Carlo errors of theta's means, sds and "
        f"interval ends at most {np.array2string(relative.max(axis=1), precision=3)} "
        f"posterior sds (targets {tol:g}, {tol:g}, {END_TOLERANCE * tol:g}; over the "
        f"hyperparameters {parts[0]:.2f}, over theta {parts[1]:.2f} of them)"
    )
