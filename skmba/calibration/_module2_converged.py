"""Module 2's hyperparameters integrated out to a stated Monte Carlo error.

The default treatment for one calibration parameter
(``discrepancy_uncertainty="propagate"``, quadrature). The posterior of theta
is an integral over the discrepancy and noise hyperparameters ``phi``::

    p(theta | data) ∝ p(theta) ∫ p(data | theta, phi) p(phi) d phi,

computed here on a trapezoid grid over theta (:class:`ThetaGrid`) and by
importance sampling over ``phi``:

1. :func:`marginal_laplace`: the mode and Hessian of the posterior of ``phi``
   with theta integrated out on the grid, ``log p(phi) + log ∫ p(theta)
   p(data | theta, phi) d theta``, started at module 2's mode (whose theta
   integral is a Gaussian moment match, :mod:`~skmba.calibration.
   _module2_posterior`): a proposal that matches the target the weights
   correct to;
2. :func:`converge`: blocks of :data:`N_BLOCK` draws of a defensive
   proposal (a Student-t around that mode, scrambled Halton with a fresh
   scramble per block, and the prior), added until the Monte Carlo standard
   errors of theta's posterior mean, sd and 95 % interval ends, from the
   spread of the blocks' own estimates (randomised quasi-Monte Carlo), are
   below ``tol`` posterior sds; the grid is refined where a draw's
   conditional posterior is narrower than its spacing and extended where
   mass reaches an end that is not the prior's.

:class:`ConvergedIntegral` holds the result: the draws and weights of module
3's mixture, the posterior of theta on the grid, the posterior mean of the
noise variances (what a new observation adds, from the same weights: one
posterior for ``phi``), module 4's rule and the Monte Carlo errors
(:class:`MonteCarloError`). Measurements: ``docs/internals.rst``.

Examples
--------
``tests/calibration/test_module2_converged.py`` checks the grid against the
mixture's own log posterior and the errors against repeated fits.
"""

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize, special

from skmba._core.linalg import FactorizationError
from skmba._core.validation import seed_sequence
from skmba._core.warn import warn
from skmba.calibration._module2_posterior import (
    HyperposteriorDraws,
    clamped_inverse,
    proposal_draws,
)
from skmba.calibration._module3_mixture import ModelMixture
from skmba.mcmc._posterior import PosteriorResult

#: Draws per randomised block (a power of two, for the Halton points).
N_BLOCK = 128
#: Blocks before the first check of the error (its own estimate needs them).
MIN_BLOCKS = 4
#: Most draws: a fit that needs more warns.
MAX_DRAWS = 4096
#: Scale of the Student-t proposal against the Laplace approximation.
INFLATION = 1.5
#: Share of each block drawn from the prior (defensive mixture).
PRIOR_SHARE = 0.125
#: Half-width of the first grid, in first-pass posterior sds; its spacing.
GRID_HALF_WIDTH, GRID_STEP = 7.0, 0.4
#: The interval whose ends the error covers.
INTERVAL = (0.025, 0.975)
#: Module-4 pairs (theta, phi draw), stratified from the joint posterior.
N_RULE_PAIRS = 256
#: Relative step of the finite differences of the marginal's mode search.
_STEP = 1e-2
#: Posterior mass at a grid end (not the prior's) that extends the grid.
_END_MASS = 1e-9
#: Posterior weight of draws whose conditional posterior of theta is
#: narrower than half the grid's spacing, above which the grid is refined
#: (at half a spacing the trapezoid rule's relative error on a Gaussian is
#: ``exp(-pi^2 / 2)``, 0.7 %).
_NARROW_SHARE = 0.01
#: Interval ends are held to this multiple of the tolerance: the tails rest
#: on fewer draws than the mean and sd.
END_TOLERANCE = 2.0
#: Most nodes a refinement may make (each node costs a factorisation per
#: draw).
_MAX_NODES = 600
#: Most refinements or extensions of the grid.
_GRID_CHANGES = 6


@dataclass(frozen=True)
class MonteCarloError:
    """Monte Carlo standard errors of a one-parameter posterior summary.

    Attributes
    ----------
    mean, sd, lower, upper : float
        Errors of the posterior mean, sd and 95 % interval ends (user
        units), from the integral over the module-2 hyperparameters.
    n_draws : int
        Draws of the hyperparameters.
    ess : float
        Kish's effective sample size of their posterior weights.
    converged : bool
        Whether every error is below the tolerance in posterior sds.
    """

    mean: float
    sd: float
    lower: float
    upper: float
    n_draws: int
    ess: float
    converged: bool


@dataclass(frozen=True)
class ThetaGrid:
    """A trapezoid grid over one parameter (user units).

    Attributes
    ----------
    nodes : ndarray of shape (J,)
    log_weights : ndarray of shape (J,)
        ``log`` of the trapezoid weight times the prior density.
    support : tuple
        The prior's 0.9999 interval: ends at it are not extended.
    """

    nodes: np.ndarray
    log_weights: np.ndarray
    support: tuple

    @classmethod
    def build(cls, prior, lo, hi, n_nodes):
        """``n_nodes`` equally spaced nodes on ``[lo, hi]`` inside the prior's
        0.9999 interval."""
        support = tuple(prior.bounds(0.9999)[0])
        lo, hi = max(lo, support[0]), min(hi, support[1])
        nodes = np.linspace(lo, hi, max(int(n_nodes), 3))
        trapezoid = np.full(len(nodes), nodes[1] - nodes[0])
        trapezoid[[0, -1]] *= 0.5
        with np.errstate(divide="ignore"):
            log_prior = np.ravel(prior.logpdf(nodes[:, None]))
        return cls(nodes, np.log(trapezoid) + log_prior, support)

    @classmethod
    def around(cls, prior, mean, sd):
        """The first grid: :data:`GRID_HALF_WIDTH` sds each side of ``mean``,
        spacing :data:`GRID_STEP` sds."""
        n_nodes = 2 * math.ceil(GRID_HALF_WIDTH / GRID_STEP) + 1
        return cls.build(
            prior, mean - GRID_HALF_WIDTH * sd, mean + GRID_HALF_WIDTH * sd, n_nodes
        )

    @property
    def step(self):
        return float(self.nodes[1] - self.nodes[0])

    def refined(self, prior):
        """The grid with a node between each two (the old nodes kept)."""
        return self.build(prior, self.nodes[0], self.nodes[-1], 2 * len(self.nodes) - 1)

    def extended(self, prior, lower, upper):
        """The grid extended by a quarter of its width at the flagged ends,
        on the same spacing."""
        width = self.nodes[-1] - self.nodes[0]
        lo = self.nodes[0] - 0.25 * width * lower
        hi = self.nodes[-1] + 0.25 * width * upper
        return self.build(prior, lo, hi, round((hi - lo) / self.step) + 1)


class _Evaluator:
    """``log p(data | theta_j, phi_k)`` on a grid for draws ``v_k``."""

    def __init__(self, base, space, scaler):
        self.base, self.space, self.scaler = base, space, scaler

    def mixture(self, V):
        components = [self.space.component(v) for v in V]
        draws = HyperposteriorDraws(
            None, components, np.zeros(len(V)), None, None, None
        )
        return ModelMixture(self.base, draws)

    def __call__(self, V, nodes):
        """(J, K): ``-inf`` where a factorisation fails."""
        mixture = self.mixture(np.atleast_2d(V))
        thetas = self.scaler.theta(np.asarray(nodes, float)[:, None])
        try:
            return mixture.batch_component_log_likelihoods(thetas)
        except FactorizationError:  # a rank-deficient regression somewhere
            out = np.full((len(thetas), len(mixture.models)), -np.inf)
            for j, theta in enumerate(thetas):
                try:
                    out[j] = mixture.batch_component_log_likelihoods(theta[None])[0]
                except FactorizationError:
                    continue
            return out

    def log_marginal(self, V, grid):
        """``log p(phi) + log ∫ p(theta) p(data | theta, phi) d theta`` (K,)."""
        V = np.atleast_2d(V)
        L = self(V, grid.nodes) + grid.log_weights[:, None]
        log_prior = np.array([self.space.log_prior(v) for v in V])
        with np.errstate(invalid="ignore"):
            return special.logsumexp(L, axis=0) + log_prior


def marginal_laplace(evaluate, grid, start):
    """Mode and Laplace covariance of the marginal posterior of ``phi``.

    L-BFGS-B on ``-log_marginal`` with forward-difference gradients (the
    ``m + 1`` points evaluated as one stack), from ``start``; the covariance
    is :func:`clamped_inverse` of a forward-difference Hessian.
    """
    m = len(start)
    steps = _STEP * np.eye(m)

    def objective(v):
        f = -evaluate.log_marginal(np.vstack([v, v + steps]), grid)
        if not np.isfinite(f[0]):
            return 1e300, np.zeros(m)
        g = np.where(np.isfinite(f[1:]), (f[1:] - f[0]) / _STEP, 0.0)
        return float(f[0]), g

    res = optimize.minimize(objective, start, jac=True, method="L-BFGS-B")
    v = res.x if res.fun < objective(start)[0] else np.asarray(start, float)
    pairs = v + steps[:, None, :] + steps[None, :, :]
    points = np.vstack([v, v + steps, pairs.reshape(m * m, m)])
    f = -evaluate.log_marginal(points, grid)
    f0, fi, fij = f[0], f[1 : m + 1], f[m + 1 :].reshape(m, m)
    H = (fij - fi[:, None] - fi[None, :] + f0) / _STEP**2
    H = np.where(np.isfinite(H), H, 0.0)
    return v, clamped_inverse(H)


@dataclass(frozen=True)
class _Draws:
    """Draws of ``phi`` so far: coordinates, log weights ``p / q``, blocks
    and their log likelihoods on the grid."""

    V: np.ndarray
    log_w: np.ndarray
    block: np.ndarray
    L: np.ndarray

    def add(self, V, log_w, block, L):
        return _Draws(
            np.vstack([self.V, V]),
            np.r_[self.log_w, log_w],
            np.r_[self.block, np.full(len(V), block)],
            np.hstack([self.L, L]),
        )


def _grid_problems(A, grid, weights):
    """Whether the grid needs refining (a draw with weight whose conditional
    posterior is narrower than half a spacing) or extending (mass at an end
    that is not the prior's)."""
    t = grid.nodes
    Z = special.logsumexp(A, axis=0)
    share = np.exp(Z - special.logsumexp(Z))
    heavy = share > 0.01 / len(share)
    P = np.exp(A[:, heavy] - Z[heavy])
    mu = t @ P
    sd = np.sqrt(np.maximum((t**2) @ P - mu**2, 0.0))
    narrow = float(np.sum(share[heavy][sd < 0.5 * grid.step])) > _NARROW_SHARE
    lower = weights[0] > _END_MASS and t[0] > grid.support[0]
    upper = weights[-1] > _END_MASS and t[-1] < grid.support[1]
    return narrow, lower, upper


@dataclass(frozen=True)
class ConvergedIntegral:
    """The integral over ``phi``: module 3's posterior and module 4's rule.

    Attributes
    ----------
    draws : HyperposteriorDraws
        The draws and importance weights of the mixture, with the noise
        variances' posterior mean from the same weights.
    posterior : PosteriorResult
        Theta on the grid (method ``"quadrature"``).
    error : MonteCarloError
    rule_thetas, rule_draws : ndarray
        Module 4's pairs: a theta (user units, (s, 1)) and the index of the
        draw of ``phi`` with it, drawn from their joint posterior.
    rule_weights : ndarray of shape (s,)
    """

    draws: HyperposteriorDraws
    posterior: PosteriorResult
    error: MonteCarloError
    rule_thetas: np.ndarray
    rule_draws: np.ndarray
    rule_weights: np.ndarray


def _density_cdf(w, grid):
    """The CDF at the nodes of the trapezoid posterior with weights ``w``."""
    trapezoid = np.full(len(w), grid.step)
    trapezoid[[0, -1]] *= 0.5
    f = w / trapezoid
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * grid.step)])
    return cdf / cdf[-1]


def _summaries(log_joint, grid):
    """Mean, sd and 95 % interval ends of the grid posterior of the columns
    ``log_joint`` (J, K) sum over, and its normalised node weights."""
    log_mass = special.logsumexp(log_joint, axis=1)
    w = np.exp(log_mass - special.logsumexp(log_mass))
    t = grid.nodes
    mean = w @ t
    sd = math.sqrt(max(w @ (t - mean) ** 2, 0.0))
    return np.r_[mean, sd, np.interp(INTERVAL, _density_cdf(w, grid), t)], w


def _new_blocks(draws, evaluate, grid, proposal, n_blocks, seed):
    """``draws`` with blocks added up to ``n_blocks``."""
    space, mode, cov = proposal
    first = 0 if draws is None else int(draws.block.max()) + 1
    for b in range(first, n_blocks):
        V, log_p, log_q = proposal_draws(
            space.coordinates, mode, cov, N_BLOCK, seed.spawn(1)[0], PRIOR_SHARE
        )
        L = evaluate(V, grid.nodes)
        if draws is None:
            draws = _Draws(V, log_p - log_q, np.zeros(len(V), int), L)
        else:
            draws = draws.add(V, log_p - log_q, b, L)
    return draws


def _regridded(draws, grid, prior, evaluate, narrow, lower, upper):
    """The grid refined (``narrow``; the old nodes, every other new one,
    keep their values) or extended at the flagged ends, and the draws'
    log likelihoods on it."""
    if narrow:
        grid = grid.refined(prior)
        L = np.empty((len(grid.nodes), len(draws.log_w)))
        L[::2], L[1::2] = draws.L, evaluate(draws.V, grid.nodes[1::2])
    else:
        grid = grid.extended(prior, lower, upper)
        L = evaluate(draws.V, grid.nodes)
    return grid, _Draws(draws.V, draws.log_w, draws.block, L)


def _tolerances(tol):
    """The tolerance of the mean, sd and interval ends, in posterior sds."""
    return tol * np.array([1.0, 1.0, END_TOLERANCE, END_TOLERANCE])


def _grown(n_blocks, relative, tol):
    """Blocks for the next round: as many as the error's decay as
    ``1 / sqrt(draws)`` asks, at most twice as many, at most
    :data:`MAX_DRAWS` draws."""
    needed = math.ceil(n_blocks * (relative / tol) ** 2)
    return min(max(needed, n_blocks + 1), 2 * n_blocks, MAX_DRAWS // N_BLOCK)


def _sample(grid, w, n_samples, seed):
    """Stratified inverse-CDF draws of the grid posterior (one uniform)."""
    rng = np.random.default_rng(seed)
    u = (np.arange(n_samples) + rng.uniform()) / n_samples
    return np.interp(u, _density_cdf(w, grid), grid.nodes)[:, None]


def _rule_pairs(A, grid, seed):
    """Module 4's pairs: :data:`N_RULE_PAIRS` systematic draws of (node,
    draw of phi) from their joint posterior, merged with their counts."""
    W = np.exp(A - special.logsumexp(A)).ravel()
    rng = np.random.default_rng(seed)
    u = (np.arange(N_RULE_PAIRS) + rng.uniform()) / N_RULE_PAIRS
    picked = np.minimum(np.searchsorted(np.cumsum(W), u), len(W) - 1)
    flat, counts = np.unique(picked, return_counts=True)
    j, k = np.unravel_index(flat, A.shape)
    return grid.nodes[j][:, None], k, counts / counts.sum()


def _result(module2, space, draws, grid, proposal, errors, n_samples, seeds):
    """The :class:`ConvergedIntegral` of the final draws."""
    _, _, w, A = errors
    Z = special.logsumexp(A, axis=0)
    marginal = np.exp(Z - special.logsumexp(Z))
    components = [space.component(v) for v in draws.V]
    noise = marginal @ np.array([c.noise for c in components])
    hyper = HyperposteriorDraws(
        module2.mode,
        components,
        draws.log_w - special.logsumexp(draws.log_w),
        proposal[2],
        noise,
        float(1.0 / np.sum(marginal**2)),
        draws.V,
        proposal[1],
        space,
    )
    samples = _sample(grid, w, n_samples, seeds[0])
    posterior = PosteriorResult.from_rule(
        samples, grid.nodes[:, None], w, (grid.nodes[0], grid.nodes[-1])
    )
    rule = _rule_pairs(A, grid, seeds[1])
    return hyper, posterior, rule


def _block_errors(draws, grid):
    """Estimates from all the draws, the standard errors of the four
    summaries from the spread of the blocks' estimates, the pooled node
    weights and the joint log weights (J, K)."""
    A = draws.L + grid.log_weights[:, None] + draws.log_w[None, :]
    pooled, w = _summaries(A, grid)
    blocks = np.unique(draws.block)
    each = np.array([_summaries(A[:, draws.block == b], grid)[0] for b in blocks])
    se = each.std(axis=0, ddof=1) / math.sqrt(len(blocks))
    return pooled, se, w, A


def converge(
    module2, base, scaler, prior, first, *, tol, n_samples, random_state=None, say=None
):
    """The integral over ``phi`` to ``tol`` posterior sds.

    Parameters
    ----------
    module2 : HyperposteriorDraws
        Module 2's mode and coordinates (its Gaussian-integrated pass).
    base : GlobalModel
        The global model at that mode.
    scaler : Standardizer
    prior : skmba prior object of one parameter
    first : PosteriorResult
        A first posterior of theta: where the grid starts.
    tol : float
        Target Monte Carlo standard error of theta's mean, sd and 95 %
        interval ends, in posterior sds.
    n_samples : int
        Posterior draws of theta to return.
    random_state : int, SeedSequence or None
    say : callable, default=None
        Progress messages.

    Returns
    -------
    ConvergedIntegral
    """
    say = say or (lambda message: None)
    space = module2.coordinates
    evaluate = _Evaluator(base, space, scaler)
    grid = ThetaGrid.around(prior, float(first.mean[0]), math.sqrt(first.cov[0, 0]))
    draw_seed, sample_seed, rule_seed = seed_sequence(random_state).spawn(3)
    mode, cov = marginal_laplace(evaluate, grid, module2.mode_coordinates)
    proposal = (space, mode, INFLATION**2 * cov)
    draws, n_blocks, changes = None, MIN_BLOCKS, 0
    while True:
        draws = _new_blocks(draws, evaluate, grid, proposal, n_blocks, draw_seed)
        errors = _block_errors(draws, grid)
        narrow, lower, upper = _grid_problems(errors[3], grid, errors[2])
        narrow = narrow and 2 * len(grid.nodes) - 1 <= _MAX_NODES
        if (narrow or lower or upper) and changes < _GRID_CHANGES:
            grid, draws = _regridded(draws, grid, prior, evaluate, narrow, lower, upper)
            changes += 1
            continue
        pooled, se = errors[:2]
        relative = float(np.max(se / _tolerances(tol)) * tol / pooled[1])
        say(
            f"module 2: {len(draws.log_w)} draws of the hyperparameters on "
            f"{len(grid.nodes)} nodes; Monte Carlo errors of theta's mean, sd "
            f"and interval ends {np.array2string(se / pooled[1], precision=3)} "
            f"posterior sds (targets {tol:g}, {tol:g}, {END_TOLERANCE * tol:g})"
        )
        if relative <= tol or n_blocks * N_BLOCK >= MAX_DRAWS:
            break
        n_blocks = _grown(n_blocks, relative, tol)
    hyper, posterior, rule = _result(
        module2,
        space,
        draws,
        grid,
        proposal,
        errors,
        n_samples,
        (sample_seed, rule_seed),
    )
    error = MonteCarloError(
        *map(float, se), len(draws.log_w), hyper.noise_ess, relative <= tol
    )
    if not error.converged:
        warn(
            f"The integral over the discrepancy and noise hyperparameters did "
            f"not reach its Monte Carlo tolerance in {MAX_DRAWS} draws: the "
            f"errors of theta's posterior mean, sd and interval ends are "
            f"{np.array2string(se / pooled[1], precision=3)} posterior sds "
            f"(discrepancy_tol={tol:g}, twice that for the ends); see "
            "summary()'s mcse columns. "
            "Their posterior is far from the Laplace approximation the draws "
            "come from: check the discrepancy prior and the field data.",
            UserWarning,
        )
    return ConvergedIntegral(hyper, posterior, error, *rule)
