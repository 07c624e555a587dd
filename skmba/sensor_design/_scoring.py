"""Scoring sensor subsets: the posterior of theta per replicate and subset.

Phase 2 of the fast preposterior analysis (thesis chapter 6):

* :func:`posterior_block`: the posterior moments of theta for some
  replicates and subsets (steps 2b-2c), from the module-3 likelihoods of
  :mod:`skmba.sensor_design._replicates`, by prefix trees over the subsets
  when ``fast`` (:mod:`skmba.sensor_design._subset_tree`) and by importance
  quadrature (:mod:`skmba.sensor_design._posterior_moments`);
* :func:`subset_moments`: those blocks as joblib tasks, with the progress
  bar and the expected time of an exhaustive search;
* :func:`criterion_value`, :func:`jackknife_mcse`, :func:`design_table`:
  the score of a (preposterior) covariance, its Monte Carlo error over the
  replicates, and the ranking table of ``summary()``.

:class:`~skmba.PreposteriorDesigner` calls them.

Examples
--------
>>> import numpy as np
>>> from skmba.sensor_design._scoring import criterion_value
>>> criterion_value(np.diag([1.0, 4.0]), np.diag([1.0, 4.0]), "trace")
1.0
>>> prior_cov = np.array([[1.0, 0.8], [0.8, 1.0]])
>>> round(criterion_value(prior_cov, prior_cov, "max_eig"), 12)
1.0
>>> covs = np.array([[[[1.0]], [[3.0]]]])  # 1 subset, 2 replicates, r = 1
>>> jackknife_mcse(covs, lambda stack: np.trace(stack, axis1=1, axis2=2))
array([1.])
"""

import time

import numpy as np
from joblib import Parallel, delayed, effective_n_jobs
from scipy import special, stats
from scipy.linalg import solve_triangular

from skmba._core.progress import duration_text, results_as_ready
from skmba._core.threads import BlasTask
from skmba._core.validation import int_seed
from skmba._core.warn import warn
from skmba.calibration._summary import table
from skmba.exceptions import NonIdentifiabilityWarning
from skmba.sensor_design._identifiability import (
    identifiability_summary,
    predicted_identified,
    replicate_identifiability,
)
from skmba.sensor_design._posterior_moments import posterior_moments
from skmba.sensor_design._replicates import likelihoods, mask, mixed, subset_draws
from skmba.sensor_design._subset_tree import (
    FieldTerms,
    path_bytes,
    subset_tree_log_likelihoods,
)

#: What a subset predicted to leave theta unidentified adds to its score in
#: the search, with ``max_warning_rate`` (a lexicographic order: scores are
#: norms of covariances whitened by the prior, 1 at the prior itself, far
#: below this), so that it ranks after every subset predicted to identify
#: theta.
UNIDENTIFIED_OFFSET = 1e6


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


#: Bytes that one prefix tree of the subsets may hold along its path
#: (:func:`~skmba.sensor_design._subset_tree.path_bytes` per field and theta): its
#: fields and stage-1 nodes are split to fit (measured: docs/internals.rst,
#: section skmba.sensor_design._scoring).
TREE_BYTES = 64 * 2**20


def posterior_block(ctx, replicates, subsets):
    """Step 2b-2c for some replicates and subsets: posterior moments, and
    the calibrator's ``identifiability_`` on each
    (:func:`~skmba.sensor_design._identifiability.replicate_identifiability`).

    With ``fast`` (module 2 fitted once per replicate), the likelihoods at the stage-1
    nodes of every subset come from one prefix tree per block of replicates
    (:func:`~skmba.sensor_design._subset_tree.subset_tree_log_likelihoods`); a subset's
    own :class:`SubsetLikelihood` is built only when its posterior needs the stage-2
    nodes.
    """
    r = ctx.prior.dim
    means = np.empty((len(replicates), len(subsets), r))
    covs = np.empty((len(replicates), len(subsets), r, r))
    ratios = np.empty((len(replicates), len(subsets), r))
    design = ctx.design
    stage1 = _stage1_log_likelihoods(ctx, replicates, subsets) if ctx.fast else None
    for i, rep in enumerate(replicates):
        modes = []
        for j, subset in enumerate(subsets):
            draws = subset_draws(ctx, rep, subset)
            modes.append(draws.mode)
            cache = {}

            def at(pieces, subset=subset, rep=rep, draws=draws, cache=cache):
                if not cache:
                    cache["mixture"] = likelihoods(ctx, rep, list(subset), draws)
                return mixed(*cache["mixture"], pieces)

            def log_likelihood(thetas, at=at):
                return at(design.pieces(ctx.std_theta(thetas)))

            seed = int_seed(np.random.SeedSequence([rep.seed, 2, mask(subset)]))
            at_nodes = at(ctx.pieces) if stage1 is None else stage1[i, j]
            means[i, j], covs[i, j] = posterior_moments(
                log_likelihood,
                ctx.prior,
                ctx.nodes,
                ctx.weights,
                at_nodes,
                seed=seed,
            )
        ratios[i] = replicate_identifiability(ctx, subsets, modes, means[i], covs[i])
    return means, covs, ratios


#: An exhaustive search expected to take longer than this (in seconds, after
#: its first task) warns (a UserWarning), whatever ``verbose``.
LONG_SEARCH_SECONDS = 600.0


# Phase 2 runs in joblib tasks of about this many (subset, replicate)
# posterior evaluations: a bar update every few seconds, and tasks long
# enough that shipping the context costs little (docs/internals.rst,
# section skmba.sensor_design._scoring).
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
    ``{subset: (means (n_mc, r), covs (n_mc, r, r), ratios (n_mc, r))}``
    (ratios: the calibrator's ``identifiability_``).
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
        means, covs, ratios = (np.concatenate([p[m] for p in own]) for m in range(3))
        for j, s in enumerate(chunk):
            out[s] = (means[:, j], covs[:, j], ratios[:, j])
    return {s: out[s] for s in subsets}


def _announce(seconds, n_evaluations, n_tasks, n_jobs, progress):
    """The expected time of phase 2 from its first task: a line, and a
    warning beyond ``LONG_SEARCH_SECONDS``."""
    workers = max(1, min(n_tasks, effective_n_jobs(n_jobs)))
    expected = seconds * n_tasks / workers
    progress.info(
        f"phase 2: expected time about {duration_text(expected)} (first task: "
        f"{n_evaluations} evaluations in {seconds:.2f} s; {n_tasks} tasks on "
        f"{workers} worker(s))"
    )
    if expected > LONG_SEARCH_SECONDS:
        warn(
            f"The exhaustive search is expected to take about "
            f"{duration_text(expected)} ({n_tasks} tasks of about {seconds:.1f} s "
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


def jackknife_mcse(covs, score):
    """Jackknife Monte Carlo standard error of each subset's score.

    The score of a subset is ``score(mean_i V_i)``, a norm of the mean of its
    per-replicate posterior covariances ``V_i``. With ``s_(i)`` the score of
    the mean without replicate ``i`` and ``s_(.)`` their mean, the jackknife
    standard error is ``sqrt((n - 1) / n * sum_i (s_(i) - s_(.))**2)``; for
    the (linear) trace criterion it equals the standard error of the mean of
    the per-replicate criteria, ``std(ddof=1) / sqrt(n)``.

    Parameters
    ----------
    covs : ndarray of shape (n_subsets, n_mc, r, r)
        Per-replicate posterior covariances.
    score : callable
        ``score(covs) -> ndarray (m,)`` for a stack of ``m`` covariances
        ``(m, r, r)``, e.g. :func:`~skmba.sensor_design._replicates.criterion_value`
        with the prior's covariance and a criterion bound.

    Returns
    -------
    mcse : ndarray of shape (n_subsets,)
        NaN when there is a single replicate.
    """
    covs = np.asarray(covs, dtype=float)
    n = covs.shape[1]
    if n < 2:
        return np.full(covs.shape[0], np.nan)
    left_out = (covs.sum(axis=1, keepdims=True) - covs) / (n - 1)
    scores = score(left_out.reshape(-1, *covs.shape[2:])).reshape(covs.shape[:2])
    spread = ((scores - scores.mean(axis=1, keepdims=True)) ** 2).sum(axis=1)
    return np.sqrt((n - 1) / n * spread)


def design_table(names, subsets, scores, mcse, rates, parameters, identified=None):
    """The scored sensor subsets, best first: one row per subset with the
    response ``names`` of its members, its size, score, Monte Carlo
    standard error and, per parameter (named by ``parameters``), the share
    of replicates on which the calibrator's warning would name it and that
    share's standard error (``rates``: the pair of arrays ``warning_rate``,
    ``warning_rate_mcse``; see :meth:`skmba.PreposteriorDesigner.summary`).
    With ``identified`` (a mask over ``subsets``), those subsets come
    first and a column says which they are."""
    keys = (np.asarray(scores, dtype=float),)
    if identified is not None:
        keys = (*keys, ~np.asarray(identified, dtype=bool))
    order = np.lexsort(keys)  # the last key sorts first; stable
    ranked = [subsets[i] for i in order]
    columns = {
        "subset": np.array([", ".join(names[k] for k in s) for s in ranked]),
        "n_responses": np.array([len(s) for s in ranked]),
        "score": keys[0][order],
        "mcse": np.asarray(mcse, dtype=float)[order],
    }
    if identified is not None:
        columns["identified"] = np.asarray(identified, dtype=bool)[order]
    rate, rate_mcse = (np.asarray(a, dtype=float)[order] for a in rates)
    for j, name in enumerate(parameters):
        columns[f"warning_rate[{name}]"] = rate[:, j]
    for j, name in enumerate(parameters):
        columns[f"warning_rate_mcse[{name}]"] = rate_mcse[:, j]
    return table("rank", np.arange(1, len(order) + 1), columns)


def _stage1_log_likelihoods(ctx, replicates, subsets):
    """The (mixed) log-likelihood of every replicate and subset at the
    stage-1 nodes, ``(n_replicates, n_subsets, k)``, from prefix trees.

    The fields (one per replicate and module-2 draw) and, when a single
    field would not fit, the nodes are split so that a tree holds at most
    :data:`TREE_BYTES` along its path.
    """
    fields, owner, log_w = [], [], []
    for i, rep in enumerate(replicates):
        draws = rep.draws
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


def phase2(
    ctx,
    replicates,
    criterion,
    search,
    *,
    n_jobs,
    progress,
    started,
    max_warning_rate=None,
):
    """Phase 2: the posterior moments of every subset the search scores.

    ``criterion(means)`` scores a stack of mean posterior covariances;
    ``search`` is a :class:`~skmba.sensor_design._subset_search.SearchSettings`.
    With ``max_warning_rate``, the search prefers the subsets predicted to
    identify theta (:func:`~skmba.sensor_design._identifiability.predicted_identified`):
    the others score :data:`UNIDENTIFIED_OFFSET` more.
    Each batch of new subsets the search asks for runs in joblib tasks of a
    block of replicates and a chunk of subsets (:func:`subset_moments`); a
    bar counts the (subset, replicate) evaluations. An exhaustive search
    scores all its subsets in one batch, announced with its size before it
    starts. Returns ``{subset: (means, covs, ratios)}`` over the replicates.
    """
    results = {}
    n_mc, q = len(replicates), ctx.q
    parallel = Parallel(n_jobs=n_jobs)  # its n_jobs under any parallel_config
    n_tasks = max(1, min(n_mc, 4 * abs(parallel.n_jobs or 1)))
    blocks = [b for b in np.array_split(np.arange(n_mc), n_tasks) if len(b)]
    exhaustive = search.search == "exhaustive"
    n_subsets = search.planned(q)
    if exhaustive:
        progress.info(
            f"phase 2: exhaustive search over {n_subsets} subsets (of at most "
            f"{search.max_size} of {q} responses) x {n_mc} replicates = "
            f"{n_subsets * n_mc} posterior evaluations"
        )
    bar = progress.bar(
        n_subsets * n_mc, f"phase 2: {search.search} search", unit="eval"
    )

    def evaluate(subsets):
        subsets = [tuple(s) for s in subsets]
        new = [s for s in dict.fromkeys(subsets) if s not in results]
        if new:
            bar.total = max(bar.total, bar.n + len(new) * n_mc)
            results.update(
                subset_moments(
                    ctx,
                    replicates,
                    new,
                    blocks,
                    bar,
                    estimate=exhaustive,
                    n_jobs=n_jobs,
                    progress=progress,
                )
            )
            progress.detail(
                f"scored {len(results)} subsets ({time.perf_counter() - started:.1f} s)"
            )
        means = np.array([results[s][1].mean(axis=0) for s in subsets])
        ratios = [results[s][2] for s in subsets]
        return search_values(criterion(means), ratios, max_warning_rate).tolist()

    with bar:
        search.run(evaluate, q)
    return results


def search_values(scores, ratios, max_warning_rate):
    """What the search minimises: the ``scores``, plus
    :data:`UNIDENTIFIED_OFFSET` for the subsets whose identifiability
    ``ratios`` (one (n_mc, r) array per subset) predict a warning rate above
    ``max_warning_rate``, so that they rank after all the others, in the
    order of their scores (None: the scores).

    >>> ratios = [np.full((2, 1), 0.9), np.full((2, 1), 0.1)]
    >>> search_values(np.array([0.5, 0.2]), ratios, 0.1)
    array([5.000000e-01, 1.000000e+06])
    """
    scores = np.asarray(scores, dtype=float)
    if max_warning_rate is None:
        return scores
    rate = identifiability_summary(ratios)[1]
    return scores + UNIDENTIFIED_OFFSET * ~predicted_identified(rate, max_warning_rate)


def design_scores(results, replicates, prior_cov, criterion, q, max_warning_rate=None):
    """Step 3: the designer's scores from the posterior moments ``results``
    (``{subset: (means, covs, ratios)}`` over the replicates), as a dict of
    its fitted attributes (names without the trailing underscore). With
    ``max_warning_rate``, the best subset is the best of those predicted to
    identify theta, or, when there is none, of all (with a warning)."""

    def score(cov):
        return criterion_value(cov, prior_cov, criterion)

    subsets = sorted(results, key=lambda s: (len(s), s))
    covs = np.array([results[s][1] for s in subsets])  # (S, n_mc, r, r)
    means = np.array([results[s][0] for s in subsets])
    theta_draws = np.array([rep.theta for rep in replicates])
    n_mc = covs.shape[1]
    out = {"theta_draws": theta_draws, "subsets": subsets}
    out["preposterior_cov"] = covs.mean(axis=1)
    out["scores"] = score(out["preposterior_cov"])
    out["scores_mcse"] = jackknife_mcse(covs, score)
    running = np.cumsum(covs, axis=1) / np.arange(1, n_mc + 1)[:, None, None]
    out["convergence"] = score(running).T
    out["expected_error"] = np.sqrt(np.mean((means - theta_draws[None]) ** 2, axis=1))
    rates = identifiability_summary([results[s][2] for s in subsets])
    out["identifiability"], out["warning_rate"], out["warning_rate_mcse"] = rates
    out["identified"] = predicted_identified(out["warning_rate"], max_warning_rate)
    out["best_subset"] = subsets[_best_index(out["scores"], out["identified"])]
    out["support"] = np.zeros(q, dtype=bool)
    out["support"][list(out["best_subset"])] = True
    single = score(np.array([results[(j,)][1].mean(axis=0) for j in range(q)]))
    out["ranking"] = stats.rankdata(single, method="min").astype(int)
    if not out["identified"].any():
        warn(
            f"No scored subset is predicted to identify theta at "
            f"max_warning_rate={max_warning_rate:g}: every one has a parameter "
            "that the calibrator's NonIdentifiabilityWarning would name more "
            f"often (lowest largest rate {out['warning_rate'].max(axis=1).min():.2f}"
            "). best_subset_ is the best of all of them; see warning_rate_ "
            "for what each subset leaves to the discrepancy prior.",
            NonIdentifiabilityWarning,
        )
    return out


def _best_index(scores, identified):
    """The lowest score among the ``identified`` subsets, or among all when
    none is."""
    if not identified.any():
        return int(np.argmin(scores))
    return int(np.flatnonzero(identified)[np.argmin(scores[identified])])
