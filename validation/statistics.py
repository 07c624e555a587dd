"""The statistics of the validity suite: per-replicate scores and summaries.

Holds, with no fitting and no output:

- the levels: ``LEVEL`` (0.95), ``Z_LEVEL`` (1.96), ``N_RANK`` (posterior
  draws of an SBC rank), ``PRIOR_LIKE`` (the "sd ~ prior" threshold);
- per replicate: :func:`thinned` (the draws an SBC rank counts),
  :func:`prior_sd`, :func:`observation_coverage` (the exact chance that a
  fresh noisy observation falls in a predictive interval) and
  :func:`fresh_observations` (one seeded fresh draw per input, the
  "one draw" estimate);
- over replicates: :func:`wilson_interval`, :func:`mean_interval` (the
  t-interval of a mean coverage over seeds), :func:`rms` and its range
  :func:`rms_band`, :func:`spread_ratio` (the spread of estimates over
  seeds against their reported errors), the rank
  histogram and its chi-square and KS tests (:func:`rank_histogram`,
  :func:`rank_tests`, :func:`n_rank_bins`), the simultaneous 95 % band of
  the rank ECDF (:func:`rank_ecdf_band`), :func:`message_kind` and
  :func:`summarise`, the per-case summary behind the printed tables.

Callers: :mod:`validation.suite` (scores), :mod:`validation.report`
(tables), the studies of :mod:`validation.studies` and
``tests/validation/test_statistics.py``. What each number means is in
``docs/validity.rst`` ("What is measured").
"""

from __future__ import annotations

import functools
import re
from collections import Counter

import numpy as np
from scipy import stats

LEVEL = 0.95
Z_LEVEL = float(stats.norm.ppf(0.5 + LEVEL / 2))
N_RANK = 100  # thinned posterior draws of the SBC rank
PRIOR_LIKE = 0.9  # a posterior sd above this share of the prior's: nothing learnt
_NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")

#: The per-replicate scores that :func:`summarise` stacks and
#: :func:`validation.report.save_records` stores in ``replicates.npz``.
RECORD_ARRAYS = (
    "theta_true",
    "theta_mean",
    "theta_sd",
    "prior_sd",
    "lo",
    "hi",
    "covered",
    "z",
    "rank",
    "cover_reality",
    "cover_obs",
    "cover_obs_draw",
    "noise_ratio",
    "identifiability",
    "fit_seconds",
)


# --------------------------------------------------------------------------
# per replicate
# --------------------------------------------------------------------------


def thinned(samples, n_rank=N_RANK):
    """``n_rank`` draws of ``samples`` at evenly spaced positions.

    The positions ``floor(i m / (n_rank + 1))``, i = 1..n_rank, stay clear
    of both ends, so that for the sorted (stratified) draws of the
    quadrature posterior they are its ``i / (n_rank + 1)`` quantiles and the
    rank of a calibrated theta* is uniform on 0..n_rank.
    """
    m = len(samples)
    idx = (np.arange(1, n_rank + 1) * m) // (n_rank + 1)
    return samples[idx]


def prior_sd(prior):
    """Standard deviation of each parameter under ``prior``."""
    if hasattr(prior, "cov"):  # frozen multivariate_normal
        return np.sqrt(np.diag(np.atleast_2d(prior.cov)))
    return np.array([float(d.std()) for d in prior])


def observation_coverage(mean, std, truth, noise_sd, level=LEVEL):
    """The probability that a fresh observation falls in ``mean +- z std``.

    A new observation at a held-out input is ``truth + eps`` with ``eps ~
    N(0, noise_sd^2)`` (per response), so the chance that the interval of
    ``level`` holds it is known in closed form,
    ``Phi((mean + z std - truth) / noise_sd) - Phi((mean - z std - truth) /
    noise_sd)``: the expectation, over the fresh noise, of the indicator
    that one drawn observation is covered (its Rao-Blackwellisation). Its
    mean over inputs and seeds estimates the coverage of new observations
    with the fresh draws' own Monte Carlo error taken out.

    Examples
    --------
    >>> p = observation_coverage(np.zeros(2), np.full(2, 1.0), np.zeros(2), 1.0)
    >>> np.round(p, 4)
    array([0.95, 0.95])
    """
    z = float(stats.norm.ppf(0.5 + level / 2))
    mean, std, truth = (np.asarray(a, dtype=float) for a in (mean, std, truth))
    dist = stats.norm(truth, noise_sd)
    return dist.cdf(mean + z * std) - dist.cdf(mean - z * std)


def fresh_observations(truth, noise_sd, seed):
    """One fresh noisy observation of ``truth`` per held-out input (seeded)."""
    rng = np.random.default_rng([int(seed), 99])
    return truth + rng.normal(size=np.shape(truth)) * noise_sd


# --------------------------------------------------------------------------
# over replicates
# --------------------------------------------------------------------------


def wilson_interval(k, n, level=LEVEL):
    """Wilson score interval of a binomial proportion ``k / n``.

    SciPy's ``binomtest(k, n).proportion_ci(method="wilson")`` (Wilson
    1927, without continuity correction; Newcombe 1998, method 3).
    """
    if n == 0:
        return np.nan, np.nan
    ci = stats.binomtest(int(k), int(n)).proportion_ci(
        confidence_level=level, method="wilson"
    )
    return float(ci.low), float(ci.high)


def mean_interval(values, level=LEVEL):
    """The mean of per-seed values and its ``level`` t-interval over seeds.

    The seeds are independent replicates; the held-out inputs of one seed
    are not (they share its fit), so a coverage averaged over seeds gets
    its uncertainty from the spread between seeds.

    Examples
    --------
    >>> lo, hi = mean_interval(np.array([0.9, 1.0, 0.95, 0.93]))
    >>> round(lo, 3), round(hi, 3)
    (0.878, 1.012)
    """
    values = np.asarray(values, dtype=float)
    n = len(values)
    mean = float(values.mean())
    if n < 2:
        return mean, mean
    half = stats.t.ppf(0.5 + level / 2, n - 1) * values.std(ddof=1) / np.sqrt(n)
    return float(mean - half), float(mean + half)


def rms(z):
    """Root mean square along axis 0 (nan for no values)."""
    z = np.asarray(z, dtype=float)
    return np.sqrt(np.mean(z**2, axis=0)) if len(z) else np.nan


def rms_band(n, level=LEVEL):
    """The central ``level`` range of the rms of ``n`` independent standard
    normal z: ``n rms^2`` is chi-squared with ``n`` degrees of freedom. An
    rms z outside it says the errors behind the z are not honest."""
    return np.sqrt(stats.chi2.ppf([(1 - level) / 2, (1 + level) / 2], n) / n)


def spread_ratio(estimates, errors, level=LEVEL):
    """How the spread of estimates over seeds compares with their errors.

    ``estimates`` and ``errors`` (S, K, ...): ``K`` runs (seeds) of each of
    ``S`` problems, each estimate with its reported standard error. The
    ratio is ``sqrt(sum ((x_sk - mean_k x_sk) / e_sk)^2 / (S (K - 1)))``
    over the problems and runs, per remaining index: one when the errors
    are honest, above one when they read low. Returns ``(ratio, lower,
    upper)``, the last two its ``level`` interval, taking ``S (K - 1)``
    times its square as chi-squared with ``S (K - 1)`` degrees of freedom
    (exact for normal estimates whose runs of one problem share a known
    error).

    Examples
    --------
    >>> x = np.array([[1.0, 3.0], [0.0, 2.0]])[..., None]  # 2 problems, 2 runs
    >>> ratio, lower, upper = spread_ratio(x, np.full_like(x, np.sqrt(2.0)))
    >>> round(float(ratio[0]), 12), bool(lower[0] < 1.0 < upper[0])
    (1.0, True)
    """
    x = np.asarray(estimates, dtype=float)
    e = np.asarray(errors, dtype=float)
    if x.shape != e.shape or x.ndim < 2 or x.shape[1] < 2:
        raise ValueError(
            "estimates and errors must have one shape (S, K, ...) with K >= 2 "
            f"runs per problem; got {x.shape} and {e.shape}"
        )
    df = x.shape[0] * (x.shape[1] - 1)
    z = (x - x.mean(axis=1, keepdims=True)) / e
    ratio = np.sqrt(np.sum(z**2, axis=(0, 1)) / df)
    # df (ratio / true ratio)^2 ~ chi2(df): its quantiles bound the true one
    small, large = np.sqrt(stats.chi2.ppf([(1 - level) / 2, (1 + level) / 2], df) / df)
    return ratio, ratio / large, ratio / small


def n_rank_bins(n):
    """Bins of the rank histogram of ``n`` ranks: about 5 or more per bin."""
    return max(2, min(10, n // 5))


def rank_histogram(ranks, n_rank=N_RANK, n_bins=None):
    """Counts of ``ranks`` (0..n_rank) in bins and their expected shares.

    The ``n_rank + 1`` possible ranks are split into ``n_bins`` consecutive
    bins (rank ``k`` in bin ``k * n_bins // (n_rank + 1)``); the expected
    share of a bin is its number of possible ranks over ``n_rank + 1``.
    """
    ranks = np.asarray(ranks, dtype=int)
    n_bins = n_rank_bins(len(ranks)) if n_bins is None else n_bins
    bins = np.arange(n_rank + 1) * n_bins // (n_rank + 1)
    share = np.bincount(bins, minlength=n_bins) / (n_rank + 1)
    counts = np.bincount(ranks * n_bins // (n_rank + 1), minlength=n_bins)
    return counts, share


def rank_tests(ranks, n_rank=N_RANK):
    """p-values of the uniformity of SBC ranks: chi-square and KS.

    Chi-square on the rank histogram (:func:`rank_histogram`); KS of the
    normalised ranks ``(rank + 0.5) / (n_rank + 1)`` against U(0, 1).
    """
    ranks = np.asarray(ranks, dtype=int)
    if len(ranks) < 2:
        return np.nan, np.nan
    counts, share = rank_histogram(ranks, n_rank)
    chi2 = stats.chisquare(counts, share * len(ranks)).pvalue
    ks = stats.kstest((ranks + 0.5) / (n_rank + 1), "uniform").pvalue
    return float(chi2), float(ks)


@functools.lru_cache(maxsize=32)
def _ecdf_band(n, n_rank, prob):
    """ArviZ's simultaneous band for ``n`` ranks (cached: its optimisation
    takes about 0.3 s)."""
    from arviz.stats.ecdf_utils import ecdf_confidence_band

    points = np.arange(1, n_rank + 1) / (n_rank + 1)
    return ecdf_confidence_band(n, points, points, prob=prob)


def rank_ecdf_band(ranks, n_rank=N_RANK, prob=LEVEL):
    """Whether the ECDF of SBC ranks stays inside its simultaneous band.

    The band is Säilynoja, Bürkner and Vehtari's (2022, Stat. Comput. 32:
    32) simultaneous ``prob`` band of the ECDF of ``len(ranks)`` uniform
    draws, from ArviZ (``arviz.stats.ecdf_utils.ecdf_confidence_band``,
    the "optimized" method), at the ``n_rank`` points ``i / (n_rank + 1)``
    where the rank ECDF, the share of ranks below ``i``, has the uniform's
    value under calibration. Returns ``(inside, excess)``: ``excess`` is
    the largest distance of the ECDF outside the band (0 inside); ``(nan,
    nan)`` with fewer than 2 ranks.
    """
    ranks = np.asarray(ranks, dtype=int)
    if len(ranks) < 2:
        return np.nan, np.nan
    lower, upper = _ecdf_band(len(ranks), n_rank, prob)
    ecdf = np.mean(ranks[:, None] < np.arange(1, n_rank + 1), axis=0)
    excess = float(np.max(np.r_[0.0, lower - ecdf, ecdf - upper]))
    return excess == 0.0, excess


def message_kind(message, width=90):
    """A warning message with its numbers masked as ``#``, cut to ``width``.

    Messages that differ only in the values they quote (an R-hat, an
    identifiability) then count as one kind.
    """
    return _NUMBER.sub("#", message)[:width]


# --------------------------------------------------------------------------
# the per-case summary
# --------------------------------------------------------------------------


def summarise(records, n_rank=N_RANK):
    """Per-case summary (dict of dicts, in the order of first appearance).

    ``records`` are those of :func:`validation.suite.run_replicate`; the
    keys of each summary are read by :func:`validation.report.format_tables`.
    """
    by_case = {}
    for rec in records:
        by_case.setdefault(rec["case"], []).append(rec)
    return {name: _summarise_case(recs, n_rank) for name, recs in by_case.items()}


def _summarise_case(recs, n_rank):
    """The summary of the replicates ``recs`` of one case."""
    ok = [r for r in recs if r["ok"]]
    n = len(ok)
    s = {"n": len(recs), "n_ok": n, "n_failed": len(recs) - n}
    s["errors"] = Counter(r["error"].split(":")[0] for r in recs if not r["ok"])
    fired = Counter()
    messages = Counter()
    for r in recs:
        fired.update(set(r["warning_categories"]))
        messages.update({message_kind(m) for m in r["warning_messages"]})
    s["warnings"], s["messages"] = fired, messages
    if n:
        stack = {k: np.array([r[k] for r in ok]) for k in ok[0] if k in RECORD_ARRAYS}
        s.update(_theta_scores(stack, n, n_rank))
        s.update(_prediction_scores(stack))
    return s


def _theta_scores(stack, n, n_rank):
    """Coverage, z, SBC ranks and posterior sds of theta over ``n`` seeds."""
    s = {}
    k_cov = stack["covered"].sum(axis=0)
    s["covered"] = k_cov
    s["wilson"] = [wilson_interval(k, n) for k in k_cov]
    s["rms_z"] = rms(stack["z"])
    s["mean_z"] = stack["z"].mean(axis=0)
    tests = [rank_tests(col, n_rank) for col in stack["rank"].T]
    s["chi2_p"] = np.array([c for c, _ in tests])
    s["ks_p"] = np.array([k for _, k in tests])
    bands = [rank_ecdf_band(col, n_rank) for col in stack["rank"].T]
    s["ecdf_inside"] = np.array([b for b, _ in bands])
    s["ecdf_excess"] = np.array([e for _, e in bands])
    s["ranks"] = stack["rank"]
    s["theta_sd"] = np.median(stack["theta_sd"], axis=0)
    s["theta_sd_max"] = stack["theta_sd"].max(axis=0)
    s["prior_like"] = np.sum(stack["theta_sd"] > PRIOR_LIKE * stack["prior_sd"], axis=0)
    ident = stack["identifiability"]
    s["identifiability"] = (
        np.nanmean(ident, axis=0) if np.isfinite(ident).any() else ident[0]
    )
    return s


def _prediction_scores(stack):
    """Predictive coverages, the noise ratio and the fit time, over seeds."""
    return {
        "cover_reality": stack["cover_reality"].mean(),
        "cover_obs": stack["cover_obs"].mean(),
        "cover_obs_draw": stack["cover_obs_draw"].mean(),
        "cover_ci": [mean_interval(stack[k]) for k in ("cover_reality", "cover_obs")],
        "noise_ratio": np.median(stack["noise_ratio"], axis=0),
        "fit_seconds": stack["fit_seconds"].mean(),
    }
