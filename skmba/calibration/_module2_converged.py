"""Module 2's hyperparameters integrated out to a stated Monte Carlo error.

The default treatment for one calibration parameter
(``discrepancy_uncertainty="propagate"``, quadrature). The posterior of theta
is an integral over the discrepancy and noise hyperparameters ``phi``::

    p(theta | data) ∝ p(theta) ∫ p(data | theta, phi) p(phi) d phi,

computed here on a trapezoid grid over theta and by importance sampling
over ``phi``. Each draw's log likelihood is evaluated on a coarse grid
(:class:`ThetaGrid`, spacing :data:`GRID_STEP` first-pass sds) and carried
to a finer one for the integral by a cubic spline (it is smooth in theta,
nearly quadratic where the draw's conditional posterior is narrow), checked
against exact values at the coarse midpoints before the result is returned
(:func:`_spline_error`):

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
   below ``tol`` posterior sds; the fine grid is refined where a draw's
   conditional posterior is narrower than its spacing, the coarse one where
   the spline misses the exact values, and both extended where mass
   reaches an end that is not the prior's.

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
from scipy import interpolate, optimize, special

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

#: The tolerance of ``discrepancy_tol="auto"``, in posterior sds: the sd's
#: coefficient of variation over seeds is about this (docs/validity.rst).
AUTO_TOL = 0.05
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
#: Half-width of the first grid, in first-pass posterior sds; the spacing of
#: the nodes where the likelihood is evaluated.
GRID_HALF_WIDTH, GRID_STEP = 7.0, 1.2
#: Integration nodes per evaluation spacing at first (the spline fills them).
FINE_FACTOR = 4
#: Most integration nodes.
MAX_FINE_NODES = 1200
#: Largest error of the spline, in log likelihood, at a coarse midpoint
#: within :data:`_RELEVANT` of its draw's largest log posterior, above which
#: the coarse grid is refined (1 % of the density there).
SPLINE_TOL = 0.01
#: Log posterior below a draw's largest where its spline is not checked.
_RELEVANT = 25.0
#: Draws checked against the spline: those carrying the most weight.
_N_CHECKED = 32
#: The interval whose ends the error covers.
INTERVAL = (0.025, 0.975)
#: Module-4 pairs (theta, phi draw), stratified from the joint posterior.
N_RULE_PAIRS = 256
#: Relative step of the finite differences of the marginal's mode search.
_STEP = 1e-2
#: Posterior mass within a coarse spacing of a grid end (not the prior's)
#: that extends the grid: a tail of 1e-7 at 20 sds moves the variance by
#: 4e-5 of itself, far below any tolerance of the summaries.
_END_MASS = 1e-7
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
_GRID_CHANGES = 8


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
    """A trapezoid grid over one parameter (user units): a lattice of
    spacing ``step``, whose end intervals may be shorter where it stops at
    the prior's 0.9999 interval.

    Attributes
    ----------
    nodes : ndarray of shape (J,)
    log_weights : ndarray of shape (J,)
        ``log`` of the trapezoid weight times the prior density.
    support : tuple
        The prior's 0.9999 interval: ends at it are not extended.
    step : float
        The lattice's spacing.
    """

    nodes: np.ndarray
    log_weights: np.ndarray
    support: tuple
    step: float

    @classmethod
    def build(cls, prior, nodes, step, support=None):
        """The trapezoid rule of the increasing ``nodes``."""
        nodes = np.asarray(nodes, dtype=float)
        support = support or tuple(prior.bounds(0.9999)[0])
        trapezoid = 0.5 * (
            np.diff(nodes, prepend=nodes[0]) + np.diff(nodes, append=nodes[-1])
        )
        with np.errstate(divide="ignore"):
            log_prior = np.ravel(prior.logpdf(nodes[:, None]))
        return cls(nodes, np.log(trapezoid) + log_prior, support, float(step))

    @classmethod
    def around(cls, prior, mean, sd):
        """The first grid: :data:`GRID_HALF_WIDTH` sds each side of ``mean``,
        spacing :data:`GRID_STEP` sds, inside the prior's 0.9999 interval."""
        support = tuple(prior.bounds(0.9999)[0])
        step = GRID_STEP * sd
        half = math.ceil(GRID_HALF_WIDTH / GRID_STEP)
        lattice = mean + step * np.arange(-half, half + 1)
        nodes = _clipped(lattice, *support, step)
        return cls.build(prior, nodes, step, support)

    def refined(self, prior):
        """The grid with a node between each two (the old nodes kept)."""
        t = self.nodes
        nodes = np.empty(2 * len(t) - 1)
        nodes[::2], nodes[1::2] = t, 0.5 * (t[1:] + t[:-1])
        return self.build(prior, nodes, 0.5 * self.step, self.support)

    def subdivided(self, prior, factor):
        """``factor`` equal spacings in each of the grid's (its nodes kept)."""
        t = self.nodes
        inner = t[:-1, None] + np.diff(t)[:, None] * (np.arange(factor) / factor)
        return self.build(
            prior, np.r_[inner.ravel(), t[-1]], self.step / factor, self.support
        )

    def extended(self, prior, lower, upper):
        """The grid extended on its lattice by a quarter of its width at the
        flagged ends, within the prior's 0.9999 interval; and the numbers of
        nodes added below and above (the old nodes are kept between)."""
        t, h = self.nodes, self.step
        n_add = max(math.ceil(0.25 * (t[-1] - t[0]) / h), 1)
        below = t[0] - h * np.arange(n_add, 0, -1) if lower else t[:0]
        above = t[-1] + h * np.arange(1, n_add + 1) if upper else t[:0]
        lo, hi = self.support
        below, above = _clipped(below, lo, np.inf, h), _clipped(above, -np.inf, hi, h)
        nodes = np.r_[below, t, above]
        return self.build(prior, nodes, h, self.support), len(below), len(above)


def _clipped(points, lo, hi, step):
    """The increasing ``points`` inside ``(lo, hi)``, with ``lo`` (``hi``) in
    place of those at or beyond it, and of the nearest inside when that is
    within a quarter step of it."""
    inside = points[(points > lo) & (points < hi)]
    low = len(points) > 0 and points[0] <= lo
    high = len(points) > 0 and points[-1] >= hi
    if low and len(inside) and inside[0] - lo < 0.25 * step:
        inside = inside[1:]
    if high and len(inside) and hi - inside[-1] < 0.25 * step:
        inside = inside[:-1]
    return np.r_[[lo] if low else [], inside, [hi] if high else []]


class _Evaluator:
    """``log p(data | theta_j, phi_k)`` on a grid for draws ``v_k``."""

    def __init__(self, base, space, scaler):
        self.base, self.space, self.scaler = base, space, scaler
        self._components = {}  # each draw's model, built once

    def _component(self, v):
        key = v.tobytes()
        if key not in self._components:
            self._components[key] = self.space.component(v)
        return self._components[key]

    def mixture(self, V):
        components = [self._component(v) for v in V]
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

    def splined(self, V, L, grids):
        """The draws' log likelihoods ``L`` on the coarse nodes carried to the
        fine ones by a cubic spline; evaluated there for a draw with a failed
        factorisation (no spline through ``-inf``)."""
        V, L = np.atleast_2d(V), np.asarray(L)
        ok = np.all(np.isfinite(L), axis=0)
        out = np.empty((len(grids.fine.nodes), L.shape[1]))
        if ok.any():
            spline = interpolate.CubicSpline(grids.coarse.nodes, L[:, ok], axis=0)
            out[:, ok] = spline(grids.fine.nodes)
        if not ok.all():
            out[:, ~ok] = self(V[~ok], grids.fine.nodes)
        return out

    def log_marginal(self, V, grids):
        """``log p(phi) + log ∫ p(theta) p(data | theta, phi) d theta`` (K,)."""
        V = np.atleast_2d(V)
        L = self.splined(V, self(V, grids.coarse.nodes), grids)
        log_prior = np.array([self.space.log_prior(v) for v in V])
        with np.errstate(invalid="ignore"):
            return (
                special.logsumexp(L + grids.fine.log_weights[:, None], axis=0)
                + log_prior
            )


@dataclass(frozen=True)
class _Grids:
    """The nodes where the likelihood is evaluated (``coarse``) and those of
    the integral (``fine``, ``factor`` spacings per coarse one, the coarse
    nodes among them)."""

    coarse: ThetaGrid
    fine: ThetaGrid
    factor: int

    @classmethod
    def of(cls, prior, coarse, factor):
        return cls(coarse, coarse.subdivided(prior, factor), factor)


def marginal_laplace(evaluate, grids, start):
    """Mode and Laplace covariance of the marginal posterior of ``phi``.

    L-BFGS-B on ``-log_marginal`` with forward-difference gradients (the
    ``m + 1`` points evaluated as one stack), from ``start``; the covariance
    is :func:`clamped_inverse` of a forward-difference Hessian.
    """
    m = len(start)
    steps = _STEP * np.eye(m)

    def objective(v):
        f = -evaluate.log_marginal(np.vstack([v, v + steps]), grids)
        if not np.isfinite(f[0]):
            return 1e300, np.zeros(m)
        g = np.where(np.isfinite(f[1:]), (f[1:] - f[0]) / _STEP, 0.0)
        return float(f[0]), g

    res = optimize.minimize(objective, start, jac=True, method="L-BFGS-B")
    v = res.x if res.fun < objective(start)[0] else np.asarray(start, float)
    pairs = v + steps[:, None, :] + steps[None, :, :]
    points = np.vstack([v, v + steps, pairs.reshape(m * m, m)])
    f = -evaluate.log_marginal(points, grids)
    f0, fi, fij = f[0], f[1 : m + 1], f[m + 1 :].reshape(m, m)
    H = (fij - fi[:, None] - fi[None, :] + f0) / _STEP**2
    H = np.where(np.isfinite(H), H, 0.0)
    return v, clamped_inverse(H)


@dataclass(frozen=True)
class _Draws:
    """Draws of ``phi`` so far: coordinates, log weights ``p / q``, blocks
    and their log likelihoods on the coarse (``L``) and fine (``F``) grids."""

    V: np.ndarray
    log_w: np.ndarray
    block: np.ndarray
    L: np.ndarray
    F: np.ndarray

    def add(self, V, log_w, block, L, F):
        return _Draws(
            np.vstack([self.V, V]),
            np.r_[self.log_w, log_w],
            np.r_[self.block, np.full(len(V), block)],
            np.hstack([self.L, L]),
            np.hstack([self.F, F]),
        )


def _grid_problems(A, grid, weights, span=1):
    """Whether the grid needs refining (a draw with weight whose conditional
    posterior is narrower than half a spacing) or extending (mass on the
    ``span`` nodes at an end that is not the prior's)."""
    t = grid.nodes
    Z = special.logsumexp(A, axis=0)
    share = np.exp(Z - special.logsumexp(Z))
    heavy = share > 0.01 / len(share)
    P = np.exp(A[:, heavy] - Z[heavy])
    mu = t @ P
    sd = np.sqrt(np.maximum((t**2) @ P - mu**2, 0.0))
    narrow = float(np.sum(share[heavy][sd < 0.5 * grid.step])) > _NARROW_SHARE
    lower = weights[:span].sum() > _END_MASS and t[0] > grid.support[0]
    upper = weights[-span:].sum() > _END_MASS and t[-1] < grid.support[1]
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
    t = grid.nodes
    f = w / (0.5 * (np.diff(t, prepend=t[0]) + np.diff(t, append=t[-1])))
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(t))])
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


def _new_blocks(draws, evaluate, grids, proposal, n_blocks, seed):
    """``draws`` with blocks added up to ``n_blocks``."""
    space, mode, cov = proposal
    first = 0 if draws is None else int(draws.block.max()) + 1
    for b in range(first, n_blocks):
        V, log_p, log_q = proposal_draws(
            space.coordinates, mode, cov, N_BLOCK, seed.spawn(1)[0], PRIOR_SHARE
        )
        L = evaluate(V, grids.coarse.nodes)
        F = evaluate.splined(V, L, grids)
        if draws is None:
            draws = _Draws(V, log_p - log_q, np.zeros(len(V), int), L, F)
        else:
            draws = draws.add(V, log_p - log_q, b, L, F)
    return draws


def _regridded(draws, grids, prior, evaluate, change):
    """New grids and the draws' log likelihoods on them. ``change``:
    ``"fine"`` halves the fine spacing (the spline alone); ``"coarse"``
    halves the coarse one (the old nodes keep their values, the new ones
    are evaluated) and keeps the fine one; ``(lower, upper)`` extends
    both at the flagged ends (the new nodes evaluated)."""
    coarse, factor = grids.coarse, grids.factor
    if change == "fine":
        grids, L = _Grids.of(prior, coarse, 2 * factor), draws.L
    elif change == "coarse":
        grids = _Grids.of(prior, coarse.refined(prior), max(factor // 2, 1))
        L = np.empty((len(grids.coarse.nodes), len(draws.log_w)))
        L[::2], L[1::2] = draws.L, evaluate(draws.V, grids.coarse.nodes[1::2])
    else:
        wider, n_below, n_above = coarse.extended(prior, *change)
        grids, J = _Grids.of(prior, wider, factor), len(coarse.nodes)
        new = np.r_[np.arange(n_below), n_below + J + np.arange(n_above)]
        L = np.empty((len(wider.nodes), len(draws.log_w)))
        L[n_below : n_below + J], L[new] = draws.L, evaluate(draws.V, wider.nodes[new])
    F = evaluate.splined(draws.V, L, grids)
    return grids, _Draws(draws.V, draws.log_w, draws.block, L, F)


def _spline_error(draws, grids, A, evaluate, prior):
    """The spline's largest error at the coarse midpoints, for the
    :data:`_N_CHECKED` draws of most weight, where their log posterior is
    within :data:`_RELEVANT` of its largest (0 with one coarse spacing)."""
    nodes = grids.coarse.nodes
    Z = special.logsumexp(A, axis=0)
    heavy = np.argsort(Z)[::-1][:_N_CHECKED]
    heavy = heavy[np.all(np.isfinite(draws.L[:, heavy]), axis=0)]
    if len(heavy) == 0 or len(nodes) < 2:
        return 0.0
    mid = 0.5 * (nodes[1:] + nodes[:-1])
    exact = evaluate(draws.V[heavy], mid)
    splined = interpolate.CubicSpline(nodes, draws.L[:, heavy], axis=0)(mid)
    with np.errstate(divide="ignore"):
        log_post = exact + np.ravel(prior.logpdf(mid[:, None]))[:, None]
    top = np.nanmax(log_post, axis=0)
    relevant = np.isfinite(exact) & (log_post >= top - _RELEVANT)
    return float(np.max(np.abs(exact - splined)[relevant], initial=0.0))


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
    """The mixture's draws, theta's posterior on the fine ``grid`` and
    module 4's pairs."""
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
    weights and the joint log weights (J, K), on the fine ``grid``."""
    A = draws.F + grid.log_weights[:, None] + draws.log_w[None, :]
    pooled, w = _summaries(A, grid)
    blocks = np.unique(draws.block)
    if len(blocks) < 2:  # no spread yet
        return pooled, np.full(4, np.nan), w, A
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
    grids = _Grids.of(
        prior,
        ThetaGrid.around(prior, float(first.mean[0]), math.sqrt(first.cov[0, 0])),
        FINE_FACTOR,
    )
    draw_seed, sample_seed, rule_seed = seed_sequence(random_state).spawn(3)
    mode, cov = marginal_laplace(evaluate, grids, module2.mode_coordinates)
    proposal = (space, mode, INFLATION**2 * cov)
    # One block first: the grids are set on it, before more draws need them.
    draws, n_blocks, changes, checked = None, 1, 0, None
    while True:
        draws = _new_blocks(draws, evaluate, grids, proposal, n_blocks, draw_seed)
        errors = _block_errors(draws, grids.fine)
        change = _grid_change(errors, grids) if changes < _GRID_CHANGES else None
        if change is None and n_blocks < MIN_BLOCKS:
            n_blocks = MIN_BLOCKS
            continue
        if change is None:
            pooled, se = errors[:2]
            relative = float(np.max(se / _tolerances(tol)) * tol / pooled[1])
            _say_errors(say, draws, grids, se / pooled[1], tol)
            done = relative <= tol or n_blocks * N_BLOCK >= MAX_DRAWS
            if done and checked is not grids.coarse:
                checked = grids.coarse
                spline = _spline_error(draws, grids, errors[3], evaluate, prior)
                refinable = 2 * len(grids.coarse.nodes) - 1 <= _MAX_NODES
                if spline > SPLINE_TOL and refinable and changes < _GRID_CHANGES:
                    change = "coarse"
        if change is not None:
            grids, draws = _regridded(draws, grids, prior, evaluate, change)
            changes += 1
            continue
        if done:
            break
        n_blocks = _grown(n_blocks, relative, tol)
    hyper, posterior, rule = _result(
        module2,
        space,
        draws,
        grids.fine,
        proposal,
        errors,
        n_samples,
        (sample_seed, rule_seed),
    )
    error = MonteCarloError(
        *map(float, se), len(draws.log_w), hyper.noise_ess, relative <= tol
    )
    _warn_unmet(error, se / pooled[1], tol, spline)
    return ConvergedIntegral(hyper, posterior, error, *rule)


def _grid_change(errors, grids):
    """What the grids need before the errors can be read: extending at an
    end that holds mass (``(lower, upper)``), a finer integration grid
    (``"fine"``) where draws with weight have narrow conditionals, or
    nothing (None)."""
    narrow, lower, upper = _grid_problems(
        errors[3], grids.fine, errors[2], grids.factor
    )
    if lower or upper:
        return (lower, upper)
    n_fine = (len(grids.coarse.nodes) - 1) * 2 * grids.factor + 1
    return "fine" if narrow and n_fine <= MAX_FINE_NODES else None


def _say_errors(say, draws, grids, relative, tol):
    say(
        f"module 2: {len(draws.log_w)} draws of the hyperparameters, "
        f"evaluated on {len(grids.coarse.nodes)} nodes and integrated on "
        f"{len(grids.fine.nodes)}; Monte Carlo errors of theta's mean, sd "
        f"and interval ends {np.array2string(relative, precision=3)} "
        f"posterior sds (targets {tol:g}, {tol:g}, {END_TOLERANCE * tol:g})"
    )


def _warn_unmet(error, relative, tol, spline):
    """The warnings of a tolerance not reached: Monte Carlo, spline."""
    if not error.converged:
        warn(
            f"The integral over the discrepancy and noise hyperparameters did "
            f"not reach its Monte Carlo tolerance in {MAX_DRAWS} draws: the "
            f"errors of theta's posterior mean, sd and interval ends are "
            f"{np.array2string(relative, precision=3)} posterior sds "
            f"(discrepancy_tol={tol:g}, twice that for the ends); see "
            "summary()'s mcse columns. "
            "Their posterior is far from the Laplace approximation the draws "
            "come from: check the discrepancy prior and the field data.",
            UserWarning,
        )
    if spline > SPLINE_TOL:
        warn(
            f"The log likelihood of theta between the grid's nodes is "
            f"interpolated with an error of {spline:.3g} (more than "
            f"{SPLINE_TOL:g}) after {_GRID_CHANGES} refinements: the "
            "posterior of theta is narrow against its prior range; give "
            "theta a narrower prior around the data's estimate.",
            UserWarning,
        )
