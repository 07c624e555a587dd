"""Module 2's hyperparameters integrated out to a stated Monte Carlo error.

The default treatment for one calibration parameter
(``discrepancy_uncertainty="propagate"``, quadrature). The posterior of theta
is an integral over the discrepancy and noise hyperparameters ``phi``::

    p(theta | data) ∝ p(theta) ∫ p(data | theta, phi) p(phi) d phi,

computed here on a trapezoid grid over theta and by importance sampling
over ``phi``. Each draw's log likelihood is evaluated on a coarse grid
(spacing :data:`GRID_STEP` first-pass sds) and carried to a finer one for
the integral by a cubic spline (it is smooth in theta, nearly quadratic
where the draw's conditional posterior is narrow), checked against exact
values at the coarse midpoints before the result is returned (the grids,
the spline and its check: :mod:`~skmba.calibration._module2_theta_grid`):

1. :func:`marginal_laplace`: the mode and Hessian of the posterior of ``phi``
   with theta integrated out on the grid, ``log p(phi) + log ∫ p(theta)
   p(data | theta, phi) d theta``, started at module 2's mode (whose theta
   integral is a Gaussian moment match, :mod:`~skmba.calibration.
   _module2_posterior`): a proposal that matches the target the weights
   correct to;
2. :func:`converge`: blocks of :data:`N_BLOCK` draws of a defensive
   proposal (a Student-t around that mode, scrambled Halton with a fresh
   scramble per block, and the prior), added until the Monte Carlo standard
   errors of theta's posterior mean, sd and 95 % interval ends (the delta
   method over the draws, :mod:`~skmba.calibration._module2_errors`) are
   below ``tol`` posterior sds (the ends: :data:`END_TOLERANCE` times
   that); when the first 512 draws' Kish effective share is below
   :data:`ADAPT_SHARE`, the proposal moves to their weighted moments and
   the draws start again (once); the next blocks come from a second
   proposal fitted to those draws weighted by their influences on the
   summaries, every draw weighted against both
   (:mod:`~skmba.calibration._module2_proposal_mixture`); the fine grid is
   refined where a draw's
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
from scipy import optimize, special

from skmba._core.validation import seed_sequence
from skmba._core.warn import warn
from skmba.calibration._module2_errors import (
    draw_conditionals,
    influence_errors,
    moment_influences,
)
from skmba.calibration._module2_posterior import (
    HyperposteriorDraws,
    clamped_inverse,
    proposal_draws,
    proposal_log_density,
)
from skmba.calibration._module2_proposal_mixture import (
    DrawBlocks,
    draw_moments,
    influence_proposal,
)
from skmba.calibration._module2_theta_grid import (
    INTERVAL,
    SPLINE_TOL,
    GridEvaluator,
    ThetaGrid,
    ThetaGrids,
    density_cdf,
    grid_problems,
    grid_summaries,
    spline_error,
)
from skmba.mcmc._posterior import PosteriorResult
from skmba.mcmc._reweight import systematic_indices

#: The tolerance of ``discrepancy_tol="auto"``, in posterior sds: the sd's
#: coefficient of variation over seeds is about this (docs/validity.rst).
AUTO_TOL = 0.05
#: Field entries (measured readings or their means) up to which ``"auto"``
#: applies it: each draw costs a Cholesky factor of that order per node,
#: and 4096 draws stack as many of them (on a1's 50 entries a fit takes
#: 1-13 s; at 200, about 60 times as much per factor).
AUTO_MAX_ENTRIES = 200
#: Draws per randomised block (a power of two, for the Halton points).
N_BLOCK = 128
#: Blocks before the first check of the error: fewer draws would rarely hold
#: the few of wide, shifted conditional posteriors that set the upper end
#: on confounded designs, and their error estimate would read low.
MIN_BLOCKS = 4
#: Most draws: a fit that needs more warns.
MAX_DRAWS = 4096
#: Scale of the Student-t proposal against the Laplace approximation.
INFLATION = 1.5
#: Kish effective share of the first round's draws below which the
#: proposal is refitted to their weighted moments and the draws start again
#: (once): the Laplace approximation then missed the marginal of ``phi``.
ADAPT_SHARE = 0.1
#: Share of each block drawn from the prior (defensive mixture).
PRIOR_SHARE = 0.125
#: Half-width of the first grid, in first-pass posterior sds; the spacing of
#: the nodes where the likelihood is evaluated.
GRID_HALF_WIDTH, GRID_STEP = 7.0, 1.2
#: Integration nodes per evaluation spacing at first (the spline fills them).
FINE_FACTOR = 4
#: Most integration nodes.
MAX_FINE_NODES = 1200
#: Module-4 pairs (theta, phi draw), stratified from the joint posterior.
N_RULE_PAIRS = 256
#: Relative step of the finite differences of the marginal's mode search.
_STEP = 1e-2
#: Interval ends are held to this multiple of the tolerance: the tails rest
#: on fewer draws than the mean and sd. 1.5 since the second, influence-fitted
#: proposal (2.0 before): the ends of ten refits within 0.05 posterior sds
#: of their mean on a1 and c3 (docs/validity.rst).
END_TOLERANCE = 1.5
#: Most nodes a refinement may make (each node costs a factorisation per
#: draw).
_MAX_NODES = 600
#: Most refinements of the evaluation grid or extensions of both (the
#: integration grid's own refinements are bounded by MAX_FINE_NODES).
_GRID_CHANGES = 8


@dataclass(frozen=True)
class MonteCarloError:
    """Monte Carlo standard errors of a posterior's summaries.

    Attributes
    ----------
    mean, sd, lower, upper : float or ndarray of shape (r,)
        Errors of the posterior mean, sd and 95 % interval ends (user
        units), from the integral over the module-2 hyperparameters (and,
        with several parameters, over theta's importance nodes).
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
    models : list of GlobalModel
        Each draw's global model, as built for the integral (what
        :class:`~skmba.calibration._module3_mixture.ModelMixture` of
        ``draws`` holds).
    """

    draws: HyperposteriorDraws
    posterior: PosteriorResult
    error: MonteCarloError
    rule_thetas: np.ndarray
    rule_draws: np.ndarray
    rule_weights: np.ndarray
    models: list


def _new_blocks(draws, evaluate, grids, space, proposals, n_blocks, seed):
    """``draws`` with blocks of the last of ``proposals`` (its ``(mode,
    cov)`` pairs) added up to ``n_blocks``."""
    first = 0 if draws is None else len(draws.log_p) // N_BLOCK
    mode, cov = proposals[-1]
    for _ in range(first, n_blocks):
        V, log_p, log_q = proposal_draws(
            space.coordinates, mode, cov, N_BLOCK, seed.spawn(1)[0], PRIOR_SHARE
        )
        log_q = np.column_stack(
            [proposal_log_density(*p, V, log_p, PRIOR_SHARE) for p in proposals[:-1]]
            + [log_q]
        )
        source = np.full(N_BLOCK, len(proposals) - 1)
        L = evaluate(V, grids.coarse.nodes)
        F = evaluate.splined(V, L, grids)
        if draws is None:
            draws = DrawBlocks(V, log_p, log_q, source, L, F)
        else:
            draws = draws.add(V, log_p, log_q, source, L, F)
    return draws


def _regridded(draws, grids, prior, evaluate, change):
    """New grids and the draws' log likelihoods on them. ``change``:
    ``"fine"`` halves the fine spacing (the spline alone); ``"coarse"``
    halves the coarse one (the old nodes keep their values, the new ones
    are evaluated) and keeps the fine one; ``(lower, upper)`` extends
    both at the flagged ends (the new nodes evaluated)."""
    coarse, factor = grids.coarse, grids.factor
    if change == "fine":
        grids, L = ThetaGrids.of(prior, coarse, 2 * factor), draws.L
    elif change == "coarse":
        grids = ThetaGrids.of(prior, coarse.refined(prior), max(factor // 2, 1))
        L = np.empty((len(grids.coarse.nodes), len(draws.log_w)))
        L[::2], L[1::2] = draws.L, evaluate(draws.V, grids.coarse.nodes[1::2])
    else:
        wider, n_below, n_above = coarse.extended(prior, *change)
        grids, J = ThetaGrids.of(prior, wider, factor), len(coarse.nodes)
        new = np.r_[np.arange(n_below), n_below + J + np.arange(n_above)]
        L = np.empty((len(wider.nodes), len(draws.log_w)))
        L[n_below : n_below + J], L[new] = draws.L, evaluate(draws.V, wider.nodes[new])
    F = evaluate.splined(draws.V, L, grids)
    return grids, draws.with_grids(L, F)


def _targeted(draws, errors, tol):
    """The second proposal's ``(mode, cov)``: at the draws weighted by
    their influences on theta's summaries over each summary's tolerance
    (:func:`~skmba.calibration._module2_proposal_mixture.influence_proposal`);
    None while an error is unknown."""
    pooled, targets = errors[0], errors[4]
    if targets is None:
        return None
    kept, share, influence = targets
    scales = tolerances(tol) * pooled[1]
    return influence_proposal(draws.V[kept], share, influence, scales)


def tolerances(tol):
    """The tolerance of the mean, sd and interval ends, in posterior sds."""
    return tol * np.array([1.0, 1.0, END_TOLERANCE, END_TOLERANCE])


def _grown(n_blocks, relative, tol):
    """Blocks for the next round: as many as the error's decay as
    ``1 / sqrt(draws)`` asks, at most twice as many, at most
    :data:`MAX_DRAWS` draws; twice as many while the error is unknown (no
    draw with weight, or a zero density at an interval end)."""
    if not math.isfinite(relative):
        return min(2 * n_blocks, MAX_DRAWS // N_BLOCK)
    needed = math.ceil(n_blocks * (relative / tol) ** 2)
    return min(max(needed, n_blocks + 1), 2 * n_blocks, MAX_DRAWS // N_BLOCK)


def _sample(grid, w, n_samples, seed):
    """Stratified inverse-CDF draws of the grid posterior (one uniform)."""
    rng = np.random.default_rng(seed)
    u = (np.arange(n_samples) + rng.uniform()) / n_samples
    return np.interp(u, density_cdf(w, grid), grid.nodes)[:, None]


def rule_pairs(A, nodes, seed):
    """Module 4's pairs: :data:`N_RULE_PAIRS` systematic draws of (node,
    draw of phi) from their joint posterior ``A`` (J, K), merged with their
    counts: the nodes' rows of ``nodes`` (J, r), the draws' indices and the
    pairs' weights."""
    W = np.exp(A - special.logsumexp(A)).ravel()
    picked = systematic_indices(W, N_RULE_PAIRS, np.random.default_rng(seed))
    flat, counts = np.unique(picked, return_counts=True)
    j, k = np.unravel_index(flat, A.shape)
    return nodes[j], k, counts / counts.sum()


def _result(module2, evaluate, draws, grid, proposal, errors, n_samples, seeds):
    """The mixture's draws, theta's posterior on the fine ``grid`` and
    module 4's pairs."""
    w, A = errors[2:4]
    hyper = mixture_draws(module2, evaluate, draws.V, draws.log_w, proposal, A)
    samples = _sample(grid, w, n_samples, seeds[0])
    posterior = PosteriorResult.from_rule(
        samples, grid.nodes[:, None], w, (grid.nodes[0], grid.nodes[-1])
    )
    rule = rule_pairs(A, grid.nodes[:, None], seeds[1])
    return hyper, posterior, rule


def mixture_draws(module2, evaluate, V, log_w, proposal, A):
    """Module 3's mixture over the draws ``V`` of ``phi`` (importance log
    weights ``log_w``, from ``proposal``), with the noise variances'
    posterior mean under their marginal weights in the joint ``A``."""
    marginal = marginal_weights(A)
    components = evaluate.components(V)  # built while evaluating
    noise = marginal @ np.array([c.noise for c in components])
    return HyperposteriorDraws(
        module2.mode,
        components,
        log_w - special.logsumexp(log_w),
        proposal[2],
        noise,
        float(1.0 / np.sum(marginal**2)),
        V,
        proposal[1],
        evaluate.space,
    )


def _errors(draws, grid):
    """Estimates from all the draws, their standard errors over the draws
    of ``phi``, the pooled node weights and the joint log weights (J, K),
    on the fine ``grid``.

    The errors are the delta method's (:func:`influence_errors`), each draw
    entering through its conditional posterior of theta on the grid (its
    mean, its mean square deviation and its CDF at each interval end). The
    spread of the blocks' own estimates, used before, read low: on the
    confounded cantilever cases an rms z of 1.3-1.5 for the mean and sd and
    2.1-2.3 for the upper end over ten refits, against 0.5-1.0 with this
    (``docs/validity.rst``, "The same data, the same interval"). It ignores
    what the scrambled Halton points gain over independent draws, so on a
    smooth integrand it reads high (freq: rms z 0.35-0.52). A zero sd or
    density at an end gives an unknown (infinite or NaN) error, which
    :func:`converge` treats as not yet converged.
    """
    A = draws.F + grid.log_weights[:, None] + draws.log_w[None, :]
    pooled, w = grid_summaries(A, grid)
    conditionals = draw_conditionals(A)
    if conditionals is None:  # no draw with weight: no estimate
        return pooled, np.full(4, np.nan), w, A, None
    share, P, kept = conditionals
    density, cdf = w / grid.spacings, grid.cdfs(P)
    with np.errstate(divide="ignore", invalid="ignore"):
        influence = moment_influences(grid.nodes, P, *pooled[:2])
        for p, end in zip(INTERVAL, pooled[2:], strict=True):
            influence.append((grid.at(end, cdf) - p) / grid.at(end, density))
        influence = np.array(influence).T
        se = influence_errors(share, influence, draws.source[kept])
    return pooled, se, w, A, (kept, share, influence)


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
    evaluate = GridEvaluator(base, space, scaler)
    grids = ThetaGrids.of(
        prior,
        ThetaGrid.around(
            prior,
            float(first.mean[0]),
            math.sqrt(first.cov[0, 0]),
            GRID_HALF_WIDTH,
            GRID_STEP,
        ),
        FINE_FACTOR,
    )
    draw_seed, sample_seed, rule_seed = seed_sequence(random_state).spawn(3)
    mode, cov = marginal_laplace(evaluate, grids, module2.mode_coordinates)
    proposal = (space, mode, INFLATION**2 * cov)
    proposals = [proposal[1:]]  # drawn from, in turn
    # One block first: the grids are set on it, before more draws need them.
    draws, n_blocks, changes, checked, refitted = None, 1, 0, None, False
    while True:
        draws = _new_blocks(
            draws, evaluate, grids, space, proposals, n_blocks, draw_seed
        )
        errors = _errors(draws, grids.fine)
        change = _grid_change(errors, grids) if changes < _GRID_CHANGES else None
        if change is None and n_blocks < MIN_BLOCKS:
            n_blocks = MIN_BLOCKS
            continue
        if change is None:
            pooled, se = errors[:2]
            relative = float(np.max(se / tolerances(tol)) * tol / pooled[1])
            _say_errors(say, draws, grids, se / pooled[1], tol)
            first_round = not refitted and n_blocks == MIN_BLOCKS
            if first_round and kish_share(errors[3]) < ADAPT_SHARE:
                proposal, refitted = adapted(proposal, draws, errors[3]), True
                proposals = [proposal[1:]]
                say("module 2: the proposal refitted to the first draws' weights")
                draws, n_blocks, checked = None, 1, None
                continue
            done = relative <= tol or n_blocks * N_BLOCK >= MAX_DRAWS
            if n_blocks == MIN_BLOCKS and len(proposals) == 1 and not done:
                targeted = _targeted(draws, errors, tol)
                if targeted is not None:
                    proposals.append(targeted)
                    draws = draws.with_proposal(*targeted, PRIOR_SHARE)
                    say("module 2: the next draws from the first draws' influences")
            # The spline is checked on the first round (before the errors
            # it smooths steer the draws) and on the draws returned.
            now = (grids.coarse, len(draws.log_w))
            fresh = checked is None or checked[0] is not now[0] or checked[1] != now[1]
            if (done or n_blocks == MIN_BLOCKS) and fresh:
                checked = now
                spline = spline_error(draws, grids, errors[3], evaluate, prior)
                refinable = 2 * len(grids.coarse.nodes) - 1 <= _MAX_NODES
                if spline > SPLINE_TOL and refinable and changes < _GRID_CHANGES:
                    change = "coarse"
        if change is not None:
            grids, draws = _regridded(draws, grids, prior, evaluate, change)
            changes += change != "fine"  # the spline's refinements cost nothing
            continue
        if done:
            break
        n_blocks = _grown(n_blocks, relative, tol)
    hyper, posterior, rule = _result(
        module2,
        evaluate,
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
    warn_unmet(error, se / pooled[1], tol, spline)
    return ConvergedIntegral(
        hyper, posterior, error, *rule, models=evaluate.models(draws.V)
    )


def marginal_weights(A):
    """Each draw's posterior weight: its joint log weights (J, K) summed
    over theta, normalised."""
    Z = special.logsumexp(A, axis=0)
    return np.exp(Z - special.logsumexp(Z))


def kish_share(A):
    """Kish's effective sample size of the draws over their number."""
    W = marginal_weights(A)
    return float(1.0 / np.sum(W**2)) / len(W)


def adapted(proposal, draws, A):
    """The proposal moved toward the draws' weighted mean and covariance,
    each weighed against the old one by the draws' Kish effective size
    against ``2 (m + 1)`` (a few effective draws barely move it), the same
    inflation and defensive mixture."""
    space, mode, inflated = proposal
    W = marginal_weights(A)
    ess, prior_size = 1.0 / np.sum(W**2), 2.0 * (len(mode) + 1)
    share = ess / (ess + prior_size)
    mean, cov = draw_moments(draws.V, W)
    old = inflated / INFLATION**2
    new_mode = share * mean + (1.0 - share) * np.asarray(mode)
    new_cov = share * cov + (1.0 - share) * old
    if not (np.all(np.isfinite(new_mode)) and np.all(np.isfinite(new_cov))):
        return proposal
    return (space, new_mode, INFLATION**2 * new_cov)


def _grid_change(errors, grids):
    """What the grids need before the errors can be read: extending at an
    end that holds mass (``(lower, upper)``), a finer integration grid
    (``"fine"``) where draws with weight have narrow conditionals, or
    nothing (None)."""
    narrow, lower, upper = grid_problems(errors[3], grids.fine, errors[2], grids.factor)
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


def warn_unmet(error, relative, tol, spline, spent=None):
    """The warnings of a tolerance not reached: Monte Carlo (``spent``
    says what was drawn, by default ``error.n_draws`` draws), spline."""
    if not error.converged:
        spent = spent or f"{error.n_draws} draws"
        warn(
            f"The integral over the discrepancy and noise hyperparameters did "
            f"not reach its Monte Carlo tolerance in {spent}: the "
            f"errors of theta's posterior mean, sd and interval ends are "
            f"{np.array2string(relative, precision=3)} posterior sds "
            f"(discrepancy_tol={tol:g}, {END_TOLERANCE:g} times that for the "
            "ends); "
            "summary()'s mcse columns give them. Where a discrepancy can "
            "mimic theta (identifiability_ low), each draw of the "
            "hyperparameters has its own narrow posterior of theta at its "
            "own place, and the interval's ends rest on the few that reach "
            "them; elsewhere, the draws' proposal missed their posterior "
            "(check the discrepancy prior and the field data).",
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
