"""The Monte Carlo steps of the fast preposterior analysis (chapter 6).

Step 2 of the FPA for one replicate (:func:`draw_replicate`: synthetic
field data drawn from the priors of theta, the emulator, the discrepancy
and the noise, then module 2), and its posterior moments for response
subsets (:func:`posterior_block`), on module 1-3 functions only; the
designer (:class:`~skmba.PreposteriorDesigner`) orchestrates them.

Two module-2 treatments, those of the calibrator: ``"plug-in"`` (the
thesis: data from the uniform priors of Table 6.2, module 2's estimates
plugged into module 3) and ``"propagate"`` (data from the calibrator's
default hyperprior, :class:`~skmba.priors._hyperprior.Hyperprior`; module 2's
hyperposterior draws mixed in module 3, as
``ModularBayesCalibrator(discrepancy_uncertainty="propagate")`` does).

Examples
--------
>>> import numpy as np
>>> from skmba.sensor_design._replicates import criterion_value
>>> criterion_value(np.diag([1.0, 4.0]), np.diag([1.0, 4.0]), "trace")
1.0
>>> prior_cov = np.array([[1.0, 0.8], [0.8, 1.0]])
>>> round(criterion_value(prior_cov, prior_cov, "max_eig"), 12)
1.0
"""

import time
import warnings
from dataclasses import dataclass, replace

import numpy as np
from joblib import delayed, effective_n_jobs
from scipy import special, stats
from scipy.linalg import solve_triangular
from sklearn.base import clone
from sklearn.exceptions import ConvergenceWarning

from skmba._core.progress import results_as_ready
from skmba._core.regression import regression_basis
from skmba._core.threads import BlasTask
from skmba._core.validation import int_seed
from skmba._core.warn import warn
from skmba.calibration._module2_plug_in import (
    discrepancy_kernel,
    fit_discrepancy,
)
from skmba.calibration._module2_posterior import fit_hyperposterior
from skmba.calibration._module2_prior_integral import (
    integrate_over_prior,
    integrate_over_rule,
)
from skmba.priors._hyperprior import Hyperprior
from skmba.sensor_design._posterior_moments import posterior_moments
from skmba.sensor_design._subset_likelihood import (
    FieldDesignEmulator,
    SubsetLikelihood,
)
from skmba.sensor_design._subset_tree import (
    FieldTerms,
    path_bytes,
    subset_tree_log_likelihoods,
)


def criterion_value(cov, prior_cov, criterion):
    """Norm of a covariance whitened by the prior's covariance.

    Each parameter is first divided by its prior standard deviation (units
    drop out), then the covariance is whitened by the Cholesky factor ``L``
    of the prior's correlation matrix, ``S = L^-1 C L^-T``, and the
    criterion is the trace of ``S`` over ``r``, ``det(S)^(1/r)`` or the
    largest eigenvalue of ``S``. Each is exactly 1 at the prior's own
    covariance, for any number of parameters and any prior correlation;
    with independent parameters (``L`` the identity) ``S`` is the
    covariance scaled by the prior standard deviations.

    Parameters
    ----------
    cov : ndarray of shape (r, r) or (..., r, r)
        The (preposterior) covariance of ``theta`` to score, or a stack of
        them (scored at once: the designer scores every subset's running
        and left-one-out means).
    prior_cov : ndarray of shape (r, r)
        The prior covariance of ``theta``, in the units of ``cov``.
    criterion : {"trace", "det", "max_eig"}

    Returns
    -------
    float, or ndarray of shape (...) for a stack
    """
    prior_cov = np.atleast_2d(np.asarray(prior_cov, dtype=float))
    r = len(prior_cov)
    cov = np.asarray(cov, dtype=float)
    single = cov.ndim <= 2
    stack = cov.reshape(-1, r, r)
    sd = np.sqrt(np.diag(prior_cov))
    scale = np.outer(sd, sd)
    correlation = prior_cov / scale
    # Exactly 1 on the diagonal: an independent prior whitens by the
    # identity, which leaves the scaled covariance bit for bit.
    np.fill_diagonal(correlation, 1.0)
    L = np.linalg.cholesky(correlation)

    def whiten_rows(A):  # L^-1 A for every A of the stack, one solve
        columns = solve_triangular(L, A.transpose(1, 0, 2).reshape(r, -1), lower=True)
        return columns.reshape(r, len(A), r).transpose(1, 0, 2)

    half = whiten_rows(stack / scale)  # L^-1 C
    S = whiten_rows(half.transpose(0, 2, 1)).transpose(0, 2, 1)  # L^-1 C L^-T
    if criterion == "trace":
        values = np.trace(S, axis1=1, axis2=2) / r
    elif criterion == "det":
        values = np.maximum(np.linalg.det(S), 0.0) ** (1.0 / r)
    else:
        values = np.linalg.eigvalsh(S)[:, -1]
    return float(values[0]) if single else values.reshape(cov.shape[:-2])


@dataclass(frozen=True)
class MonteCarloContext:
    """What every Monte Carlo task needs; shipped once per task by joblib.

    Complete when constructed: :meth:`build` makes it from step 1's pieces.
    """

    scaler: object
    design: object  # FieldDesignEmulator at the field design
    prior: object
    priors: object  # the plug-in ranges (a dict) or a Hyperprior (propagate)
    module2: object  # the calibrator's DiscrepancySettings
    fast: bool
    module2_max_iter: int | None
    integrated: object  # the emulator integrated over the prior
    kernel_d: object  # the discrepancy correlation the data are drawn with
    nodes: np.ndarray  # the prior's integration rule (user units)
    weights: np.ndarray
    pieces: object  # the design's emulator pieces at the nodes

    @classmethod
    def build(cls, settings, emulator, scaler, X_design, prior, priors, seeds, **kw):
        """Step 1 at the design: the prior-integrated emulator, the discrepancy
        kernel and the prior's rule (``seeds``: of the integral and the
        rule); ``kw``: ``fast`` and ``module2_max_iter``."""
        Xs = scaler.x(X_design)
        design = FieldDesignEmulator(emulator, Xs)
        integrated = integrate_over_prior(
            emulator,
            scaler,
            prior,
            Xs,
            **settings.integration.kwargs(),
            random_state=seeds[0],
        )
        kernel_d = discrepancy_kernel(settings.discrepancy.kernel, Xs)
        if "roughness" not in kernel_d.get_params():
            raise TypeError(
                "The calibrator's discrepancy_kernel has no 'roughness' "
                "hyperparameter for discrepancy_prior to draw: use a kernel of "
                "skmba.kernels (e.g. Gauss())."
            )
        n_nodes = 33 if prior.dim == 1 else 64
        nodes, weights = prior.integration_nodes(n_nodes, random_state=seeds[1])
        pieces = design.pieces(scaler.theta(nodes))
        return cls(
            scaler,
            design,
            prior,
            priors,
            settings.discrepancy,
            integrated=integrated,
            kernel_d=kernel_d,
            nodes=nodes,
            weights=weights,
            pieces=pieces,
            **kw,
        )

    @property
    def hyperprior(self):
        """The Hyperprior of the propagated module 2, else None (plug-in)."""
        return self.priors if isinstance(self.priors, Hyperprior) else None

    @property
    def emulator(self):
        return self.design.emulator

    @property
    def Xs(self):
        return self.design.X_e

    @property
    def n(self):
        return self.design.n

    @property
    def q(self):
        return self.design.q

    @property
    def H_d(self):
        return regression_basis(self.Xs, self.module2.regression)

    def std_theta(self, theta):
        return self.scaler.theta(theta)


class Replicate:
    """One Monte Carlo replicate: the draws, the data and module 2."""

    def __init__(self, theta, Y_e, seed):
        self.theta, self.Y_e, self.seed = theta, Y_e, seed
        self.kernel_d = self.sigma2_d = self.noise = None
        self.draws = None  # module-2 hyperposterior draws (propagate, fast)
        self.truth = None
        self.n_unconverged = 0
        self.n_repaired = 0  # covariances of the second pass given a jitter


def _mask(subset):
    """A subset as the integer whose bits are its responses."""
    return sum(1 << int(a) for a in subset)


def _root(A):
    """A square root ``B`` with ``B B^T = A`` of a covariance (eigh, clipped)."""
    values, vectors = np.linalg.eigh(0.5 * (A + A.T))
    return vectors * np.sqrt(np.clip(values, 0.0, None))


def draw_replicate(ctx, sequence):
    """Step 2a (and 2b in phase 1): synthetic field data and module 2."""
    rng = np.random.default_rng(sequence)
    n, q = ctx.n, ctx.q
    theta = ctx.prior.rvs(1, random_state=rng)[0]
    Z = np.hstack([ctx.Xs, np.tile(ctx.std_theta(theta), (n, 1))])
    Y_m = ctx.emulator.gp.sample_y(Z, 1, random_state=int_seed(sequence)).reshape(n, q)
    if ctx.hyperprior is not None:
        delta, noise, truth = _draw_from_hyperprior(ctx, rng)
    else:
        delta, noise, truth = _draw_from_ranges(ctx, rng)
    eps = rng.standard_normal((n, q)) * np.sqrt(noise)
    rep = Replicate(theta, Y_m + delta + eps, int_seed(sequence))
    rep.truth = truth
    if ctx.fast and ctx.hyperprior is not None:
        rep.draws = _fit_module2_draws(ctx, rep, range(q))
    elif ctx.fast:
        disc = _fit_module2(ctx, rep, range(q))
        rep.kernel_d, rep.sigma2_d, rep.noise = disc.kernel_, disc.sigma2, disc.noise
    return rep


def _draw_from_ranges(ctx, rng):
    """Discrepancy and noise variance from the uniform priors (Table 6.2)."""
    p = ctx.priors
    n, q = ctx.n, ctx.q
    roughness = rng.uniform(*p["roughness"])
    R_d = clone(ctx.kernel_d).set_params(roughness=roughness)(ctx.Xs)
    sd = np.sqrt(rng.uniform(*p["variance"]))
    corr = p["correlation"]
    if isinstance(corr, str) and corr == "random":
        corr = np.atleast_2d(
            stats.wishart(df=q + 1, scale=np.eye(q)).rvs(random_state=rng)
        )
        d = np.sqrt(np.diag(corr))
        corr = corr / np.outer(d, d)
    sigma2_d = corr * np.outer(sd, sd)
    H_d = ctx.H_d
    beta = rng.uniform(*p["mean"], size=(H_d.shape[1], q))  # per response
    delta = H_d @ beta + _root(R_d) @ rng.standard_normal((n, q)) @ _root(sigma2_d).T
    noise = rng.uniform(*p["noise"])
    return delta, noise, (roughness, sigma2_d, noise)


def _draw_from_hyperprior(ctx, rng):
    """Discrepancy and noise variance from the calibrator's hyperprior.

    The discrepancy's mean has a flat prior, integrated out by the
    restricted likelihood of module 2 and by module 3, whose posteriors do
    not depend on it: it is drawn as zero.
    """
    n, q = ctx.n, ctx.q
    draw = ctx.hyperprior.rvs(ctx.Xs.shape[1], q, random_state=rng)
    R_d = clone(ctx.kernel_d).set_params(roughness=draw["roughness"])(ctx.Xs)
    sigma2_d = draw["correlation"] * np.outer(draw["sd"], draw["sd"])
    delta = _root(R_d) @ rng.standard_normal((n, q)) @ _root(sigma2_d).T
    return delta, draw["noise"], (draw["roughness"], sigma2_d, draw["noise"])


def _fit_module2(ctx, rep, responses):
    """Discrepancy and noise of the responses by maximum likelihood."""
    idx = list(responses)
    integrated = ctx.integrated.restrict(idx)
    residual = rep.Y_e[:, idx] - integrated.mean
    seed = int_seed(np.random.SeedSequence([rep.seed, 1, _mask(idx)]))
    roughness, sigma2_d, noise = rep.truth

    def start(fit):
        # The hyperparameters that generated the replicate: the natural
        # first start of the search for their maximum-likelihood estimate.
        kernel = clone(ctx.kernel_d).set_params(roughness=roughness)
        S = sigma2_d[np.ix_(idx, idx)]
        L = np.linalg.cholesky(
            S + 1e-8 * np.diag(np.diag(S)) + 1e-12 * np.eye(len(idx))
        )
        return fit.pack(kernel.theta, np.maximum(noise[idx], 1e-300), L)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        disc = fit_discrepancy(
            ctx.Xs,
            residual,
            integrated.cov,
            **ctx.module2.kwargs(),
            ranges={key: ctx.priors[key] for key in ("roughness", "variance")},
            random_state=seed,
            start=start,
            max_iter=ctx.module2_max_iter,
            responses=idx,
        )
    rep.n_unconverged += sum(issubclass(w.category, ConvergenceWarning) for w in caught)
    return disc


def _fit_module2_draws(ctx, rep, responses):
    """The module-2 hyperposterior draws of the responses (propagate).

    As the calibrator's default: the hyperposterior
    (:func:`~skmba.calibration._module2_posterior.fit_hyperposterior`, the hyperprior
    restricted to ``responses``) with the emulator integrated over the prior
    of theta; then, a second pass, again with the emulator integrated over
    the first pass's posterior of theta from these responses.
    """
    idx = list(responses)
    prior = replace(ctx.hyperprior, sd_scale=ctx.hyperprior.scales(ctx.q)[idx])
    first, second, moments = np.random.SeedSequence([rep.seed, 1, _mask(idx)]).spawn(3)

    def hyperposterior(integrated, seed):
        return fit_hyperposterior(
            ctx.Xs,
            rep.Y_e[:, idx] - integrated.mean,
            integrated.cov,
            prior=prior,
            kernel=ctx.module2.kernel,
            regression=ctx.module2.regression,
            noise=ctx.module2.noise,
            n_restarts=ctx.module2.n_restarts,
            random_state=seed,
            # The designer predicts no new observation: the noise
            # variances' posterior mean (512 evaluations) would go unused.
            noise_mean=False,
        )

    draws = hyperposterior(ctx.integrated.restrict(idx), first)
    likes, log_w = _likelihoods(ctx, rep, idx, draws)
    *_, (nodes, weights) = posterior_moments(
        lambda thetas: _mixed(likes, log_w, ctx.design.pieces(ctx.std_theta(thetas))),
        ctx.prior,
        ctx.nodes,
        ctx.weights,
        _mixed(likes, log_w, ctx.pieces),
        seed=int_seed(moments),
        return_rule=True,
    )
    keep = weights > 0
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        integrated = integrate_over_rule(
            ctx.emulator, ctx.Xs, ctx.std_theta(nodes[keep]), weights[keep]
        )
    rep.n_repaired += len(caught)  # reported once by the designer (phase 1)
    return hyperposterior(integrated.restrict(idx), second)


def warn_replicate_problems(replicates):
    """Warn about the replicates' module-2 fits that did not fully converge
    and the second-pass covariances that needed a jitter (their counts)."""
    unconverged = sum(rep.n_unconverged for rep in replicates)
    if unconverged:
        warn(
            f"{unconverged} module-2 likelihood maximisations of the "
            f"{len(replicates)} replicates did not fully converge; their "
            "estimates are used as they are. More restarts (calibrator "
            "n_restarts_optimizer) make them more robust.",
            ConvergenceWarning,
        )
    repaired = sum(rep.n_repaired for rep in replicates)
    if repaired:
        warn(
            f"{repaired} posterior-integrated emulator covariances of the "
            "second module-2 pass (discrepancy_uncertainty='propagate') "
            "were not positive definite and got a jitter, usually a "
            "round-off effect of a narrow posterior of theta.",
            UserWarning,
        )


def _embedded(sigma2_d, noise, subset, q):
    """A subset's discrepancy covariance and noise in ``q x q`` arrays."""
    full = np.zeros((q, q))
    full[np.ix_(subset, subset)] = sigma2_d
    noise_full = np.ones(q)
    noise_full[list(subset)] = noise
    return full, noise_full


#: Bytes that one prefix tree of the subsets may hold along its path
#: (:func:`~skmba.sensor_design._subset_tree.path_bytes` per field and theta): its
#: fields and stage-1 nodes are split to fit. On the truss (12 design points, 9 gauges,
#: 33 nodes) stacks of 2 to 31 fields ran alike.
TREE_BYTES = 64 * 2**20


def _plug_in(rep):
    """A replicate's module-2 estimates as a single draw (plug-in, fast)."""
    return _PlugIn(rep.kernel_d, rep.sigma2_d, rep.noise)


def _subset_likelihoods(ctx, rep, subset):
    """The module-3 likelihoods of a subset and their log weights.

    One likelihood with module 2 plugged in, or one per hyperposterior draw
    (propagate), mixed with the draws' importance weights.
    """
    if ctx.hyperprior is not None:
        draws = rep.draws if ctx.fast else _fit_module2_draws(ctx, rep, subset)
    elif ctx.fast:
        draws = _plug_in(rep)
    else:
        disc = _fit_module2(ctx, rep, subset)
        draws = _PlugIn(disc.kernel_, disc.sigma2, disc.noise)
    return _likelihoods(ctx, rep, list(subset), draws)


class _PlugIn:
    """Module 2's estimates as a single draw of weight one."""

    def __init__(self, kernel_, sigma2, noise):
        self.components = [self]
        self.log_weights = np.zeros(1)
        self.kernel_, self.sigma2, self.noise = kernel_, sigma2, noise


def _likelihoods(ctx, rep, idx, draws):
    """One :class:`SubsetLikelihood` per draw of module 2, and the log weights.

    A draw fitted on the subset alone (``q_S x q_S``) is embedded in the
    ``q x q`` arrays the likelihood restricts.
    """
    likes = []
    for c in draws.components:
        sigma2_d, noise = c.sigma2, c.noise
        if len(sigma2_d) != ctx.q:
            sigma2_d, noise = _embedded(sigma2_d, noise, idx, ctx.q)
        likes.append(
            SubsetLikelihood(
                ctx.design, idx, rep.Y_e, c.kernel_(ctx.Xs), ctx.H_d, sigma2_d, noise
            )
        )
    return likes, draws.log_weights


def _mixed(likes, log_weights, pieces):
    """``log sum_k w_k L_k`` at the emulator ``pieces`` of some thetas."""
    if len(likes) == 1:
        return likes[0].log_likelihood(pieces)
    values = np.array([like.log_likelihood(pieces) for like in likes])
    with np.errstate(invalid="ignore"):  # -inf + finite weights
        return special.logsumexp(values + log_weights[:, None], axis=0)


def posterior_block(ctx, replicates, subsets):
    """Step 2b-2c for some replicates and subsets: posterior moments.

    With ``fast`` (module 2 fitted once per replicate), the likelihoods at the stage-1
    nodes of every subset come from one prefix tree per block of replicates
    (:func:`~skmba.sensor_design._subset_tree.subset_tree_log_likelihoods`); a subset's
    own :class:`SubsetLikelihood` is built only when its posterior needs the stage-2
    nodes.
    """
    r = ctx.prior.dim
    means = np.empty((len(replicates), len(subsets), r))
    covs = np.empty((len(replicates), len(subsets), r, r))
    design = ctx.design
    stage1 = _stage1_log_likelihoods(ctx, replicates, subsets) if ctx.fast else None
    for i, rep in enumerate(replicates):
        for j, subset in enumerate(subsets):
            cache = {}

            def at(pieces, subset=subset, rep=rep, cache=cache):
                if not cache:
                    cache["mixture"] = _subset_likelihoods(ctx, rep, subset)
                return _mixed(*cache["mixture"], pieces)

            def log_likelihood(thetas, at=at):
                return at(design.pieces(ctx.std_theta(thetas)))

            seed = int_seed(np.random.SeedSequence([rep.seed, 2, _mask(subset)]))
            at_nodes = at(ctx.pieces) if stage1 is None else stage1[i, j]
            means[i, j], covs[i, j] = posterior_moments(
                log_likelihood,
                ctx.prior,
                ctx.nodes,
                ctx.weights,
                at_nodes,
                seed=seed,
            )
    return means, covs


def _stage1_log_likelihoods(ctx, replicates, subsets):
    """The (mixed) log-likelihood of every replicate and subset at the
    stage-1 nodes, ``(n_replicates, n_subsets, k)``, from prefix trees.

    The fields (one per replicate and module-2 draw) and, when a single
    field would not fit, the nodes are split so that a tree holds at most
    :data:`TREE_BYTES` along its path.
    """
    fields, owner, log_w = [], [], []
    for i, rep in enumerate(replicates):
        draws = rep.draws if ctx.hyperprior is not None else _plug_in(rep)
        for c, lw in zip(draws.components, draws.log_weights, strict=True):
            fields.append(FieldTerms(rep.Y_e, c.kernel_(ctx.Xs), c.sigma2, c.noise))
            owner.append(i)
            log_w.append(lw)
    k = len(ctx.nodes)
    p = ctx.design.p_m + ctx.H_d.shape[1]
    per_tree = max(1, TREE_BYTES // path_bytes(ctx.n, ctx.q, p))  # (field, theta)s
    n_fields, n_thetas = max(1, per_tree // k), min(k, per_tree)
    values = np.concatenate(
        [
            np.concatenate(
                [
                    subset_tree_log_likelihoods(
                        ctx.design,
                        subsets,
                        fields[g : g + n_fields],
                        ctx.H_d,
                        tuple(piece[t : t + n_thetas] for piece in ctx.pieces),
                    )
                    for t in range(0, k, n_thetas)
                ],
                axis=2,
            )
            for g in range(0, len(fields), n_fields)
        ],
        axis=1,
    )  # (n_subsets, n_fields, k)
    owner, log_w = np.array(owner), np.array(log_w)
    out = np.empty((len(replicates), len(subsets), k))
    for i in range(len(replicates)):
        mine = owner == i
        if mine.sum() == 1:
            out[i] = values[:, mine][:, 0]
        else:
            with np.errstate(invalid="ignore"):  # -inf + finite weights
                out[i] = special.logsumexp(
                    values[:, mine] + log_w[mine][None, :, None], axis=1
                )
    return out


#: An exhaustive search expected to take longer than this (in seconds, after
#: its first task) warns (a UserWarning), whatever ``verbose``.
LONG_SEARCH_SECONDS = 600.0
# Phase 2 runs in joblib tasks of about this many (subset, replicate)
# posterior evaluations (a few ms each on a small design): a bar update
# every few seconds and an early first estimate, while each task is long
# enough that shipping its context to a worker costs little (measured on
# the truss FPA: 200 per task took 127 s, 1000 per task 121 s, the
# undivided blocks of before 115 s).
_TASK_EVALUATIONS = 1000


def subset_moments(
    ctx, replicates, subsets, blocks, bar, *, estimate, n_jobs, progress
):
    """Posterior means and covariances of ``subsets`` for every replicate.

    Tasks of a block of replicates and, with ``fast``, all the subsets
    (they share a prefix tree); otherwise a chunk of about
    ``_TASK_EVALUATIONS / len(block)`` subsets, taken with a stride so
    that every chunk mixes small and large subsets. The bar advances as
    each task returns. With ``estimate``, the first task's time gives
    the expected time of all (a line, and a warning beyond
    ``LONG_SEARCH_SECONDS``). Each (subset, replicate) is computed on
    its own seed, so the tasks do not change the results. Returns
    ``{subset: (means (n_mc, r), covs (n_mc, r, r))}``.
    """
    size = max(len(block) for block in blocks)
    # With ``fast``, a task's subsets share one prefix tree: all in one chunk.
    n_chunks = (
        1
        if ctx.fast
        else min(len(subsets), -(-len(subsets) * size // _TASK_EVALUATIONS))
    )
    chunks = [subsets[c::n_chunks] for c in range(n_chunks)]
    tasks = [(chunk, block) for chunk in chunks for block in blocks]
    task = BlasTask(_timed_posterior_block, ctx.n * ctx.q, n_jobs)
    calls = (
        delayed(task)(ctx, [replicates[i] for i in block], chunk)
        for chunk, block in tasks
    )
    parts = []
    with task.held():
        for k, (part, seconds) in enumerate(results_as_ready(calls, n_jobs)):
            chunk, block = tasks[k]
            parts.append(part)
            bar.update(len(chunk) * len(block))
            if k == 0 and estimate:
                _announce(
                    seconds, len(chunk) * len(block), len(tasks), n_jobs, progress
                )
    out = {}
    for c, chunk in enumerate(chunks):
        own = parts[c * len(blocks) : (c + 1) * len(blocks)]
        means = np.concatenate([p[0] for p in own])
        covs = np.concatenate([p[1] for p in own])
        for j, s in enumerate(chunk):
            out[s] = (means[:, j], covs[:, j])
    return {s: out[s] for s in subsets}


def _announce(seconds, n_evaluations, n_tasks, n_jobs, progress):
    """The expected time of phase 2 from its first task: a line, and a
    warning beyond ``LONG_SEARCH_SECONDS``."""
    workers = max(1, min(n_tasks, effective_n_jobs(n_jobs)))
    expected = seconds * n_tasks / workers
    progress.info(
        f"phase 2: expected time about {_duration(expected)} (first task: "
        f"{n_evaluations} evaluations in {seconds:.2f} s; {n_tasks} tasks on "
        f"{workers} worker(s))"
    )
    if expected > LONG_SEARCH_SECONDS:
        warn(
            f"The exhaustive search is expected to take about "
            f"{_duration(expected)} ({n_tasks} tasks of about {seconds:.1f} s "
            f"on {workers} worker(s)). It goes on; to shorten it, interrupt "
            "and lower n_mc, set max_responses, use search='greedy' or "
            "'genetic', or raise n_jobs.",
            UserWarning,
        )


def _timed_posterior_block(ctx, replicates, subsets):
    """:func:`~skmba.sensor_design._replicates.posterior_block` and its time in
    seconds."""
    started = time.perf_counter()
    moments = posterior_block(ctx, replicates, subsets)
    return moments, time.perf_counter() - started


def _duration(seconds):
    """A time for people: ``"40 s"``, ``"12 min"``, ``"3.5 h"``.

    Examples
    --------
    >>> _duration(40.2), _duration(725.0), _duration(12600.0)
    ('40 s', '12 min', '3.5 h')
    """
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"
