"""How honest are the intervals? Seeded replicate studies of the calibrator.

Not a unit test: a validation suite that measures, with the package's
*current defaults*, how often the 95 % intervals of ``ModularBayesCalibrator``
contain the truth, over seeded replicates of the problems of issue 13 (the
cases live in ``_validity_cases.py`` and, for the simulation-based
calibration with everything drawn from the default priors, ``_sbc_cases.py``;
see there what each one is).

Per replicate (one seed of one case) it fits
``ModularBayesCalibrator(prior=..., random_state=seed, n_jobs=1)`` on the
field data and the given simulations and records, per parameter:

- whether theta* lies inside the 95 % equal-tailed interval of
  ``theta_samples_`` (its 2.5 % and 97.5 % quantiles);
- ``z = (theta_mean_ - theta*) / sd``, ``sd`` from ``theta_cov_``;
- the rank of theta* among 100 evenly thinned posterior draws (0 to 100;
  uniform when the posterior is calibrated, Talts et al. 2018);

and, at 50 held-out inputs evenly spread over the range of the design
variables, the share of the 95 % intervals ``mean +- 1.96 sd`` of
``predict_reality`` that contain the noise-free reality, and the mean
probability that the interval of ``predict`` holds a fresh noisy
observation there (:func:`observation_coverage`, exact for the known noise;
the share of one seeded fresh draw per input, the estimate of earlier
versions, is kept as "one draw"), the fitted noise over the true noise
variance, and the categories of the warnings that fit and predict raised.

Per case it prints one row: the replicates, theta* covered (k/n per
parameter) with a 95 % Wilson interval, rms z (1 is calibrated, below 1 the
interval is too wide, above 1 too narrow), the p-values of a chi-square test
of the rank histogram (``max(2, min(10, n // 5))`` bins) and of a KS test of
the normalised ranks against the uniform, the mean predictive coverage of
reality and of new observations, and how many replicates raised each warning
category. A second table gives the mean z, the median and the largest
posterior sd, in how many replicates the posterior sd exceeds 0.9 times the
prior's ("sd ~ prior": the data taught nothing about theta), the median
ratio of the fitted to the true noise variance,
``identifiability_`` when the calibrator has one, how often
``theta_robust_interval_`` covers theta* with its median width relative to
the posterior interval's, the 95 % t-intervals of the mean predictive
coverages of reality and of new observations (from their spread between
seeds, the independent replicates), and the mean fit time.

Usage::

    python benchmarks/validity.py --n-seeds 20 --n-jobs 2 --out /tmp/validity
    python benchmarks/validity.py --cases a2,freq --n-seeds 4
    python benchmarks/validity.py --n-seeds 20 --case-seeds a2=10,sbc_a2=10
    python benchmarks/validity.py --combine /tmp/run1,/tmp/run2 --out /tmp/all

``--out DIR`` writes ``replicates.csv`` (one row per replicate and
parameter), ``replicates.npz`` (per case arrays), ``table.txt`` and the
rank histograms ``validity_ranks.png`` (one panel per case and parameter).
Replicates run in parallel through joblib (``--n-jobs``), each with the
calibrator's ``n_jobs=1`` and BLAS held to one thread.
"""

from __future__ import annotations

import argparse
import csv
import importlib
import re
import sys
import time
import warnings
from collections import Counter
from pathlib import Path

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed
from scipy import stats

from skmba import ModularBayesCalibrator

HERE = Path(__file__).resolve().parent
LEVEL = 0.95
Z_LEVEL = float(stats.norm.ppf(0.5 + LEVEL / 2))
N_TEST = 50  # held-out inputs of the predictive checks
N_RANK = 100  # thinned posterior draws of the SBC rank
PRIOR_LIKE = 0.9  # a posterior sd above this share of the prior's: nothing learnt
_NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")
# slowest first, so that the parallel replicates end together
COST_ORDER = (
    "sbc_a2",
    "sbc0_a2",
    "a2",
    "b2",
    "freq",
    "c3",
    "c1",
    "b1",
    "a1",
    "sbc_a1",
    "sbc0_a1",
)


def cases():
    """The registry of cases: ``_validity_cases`` and ``_sbc_cases``.

    The SBC cases of ``_sbc_cases`` (everything drawn from the default
    priors) are ``sbc_a1`` and ``sbc_a2``; the earlier ones of
    ``_validity_cases``, which draw only theta* and no discrepancy, stay
    reachable as ``sbc0_a1`` and ``sbc0_a2``.
    """
    if str(HERE) not in sys.path:
        sys.path.insert(0, str(HERE))
    registry = dict(importlib.import_module("_validity_cases").CASES)
    for name in ("sbc_a1", "sbc_a2"):
        registry[name.replace("sbc_", "sbc0_")] = registry.pop(name)
    registry.update(importlib.import_module("_sbc_cases").SBC_CASES)
    return registry


# --------------------------------------------------------------------------
# one replicate
# --------------------------------------------------------------------------


def held_out_inputs(bounds, n=N_TEST):
    """``n`` inputs evenly spread (cell midpoints) over a 1-d range."""
    bounds = np.asarray(bounds, dtype=float)
    if len(bounds) != 1:
        raise ValueError("held-out inputs are defined for one design variable")
    lo, hi = bounds[0]
    return (lo + (np.arange(n) + 0.5) / n * (hi - lo))[:, None]


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


def _fit_and_score(spec, seed, n_test, n_rank):
    case = spec.build(seed)
    cal = ModularBayesCalibrator(prior=case.prior, random_state=seed, n_jobs=1)
    started = time.perf_counter()
    cal.fit(case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim,
            y_sim=case.y_sim)  # fmt: skip
    seconds = time.perf_counter() - started
    t = case.theta_true
    samples = cal.theta_samples_
    lo, hi = np.quantile(samples, [(1 - LEVEL) / 2, (1 + LEVEL) / 2], axis=0)
    sd = np.sqrt(np.diag(cal.theta_cov_))
    X_test = held_out_inputs(spec.X_bounds, n_test)
    truth = case.reality_fn(X_test)
    mean, std = cal.predict_reality(X_test, return_std=True)
    cover_reality = np.mean(np.abs(truth - mean) <= Z_LEVEL * std)
    mean, std = cal.predict(X_test, return_std=True)
    cover_obs = np.mean(observation_coverage(mean, std, truth, case.noise_sd))
    y_new = fresh_observations(truth, case.noise_sd, seed)
    cover_obs_draw = np.mean(np.abs(y_new - mean) <= Z_LEVEL * std)
    identifiability = getattr(cal, "identifiability_", None)
    robust = getattr(cal, "theta_robust_interval_", None)
    if robust is None:
        robust = np.full((len(t), 2), np.nan)
    return {
        "theta_true": t,
        "theta_mean": cal.theta_mean_,
        "theta_sd": sd,
        "prior_sd": prior_sd(case.prior),
        "lo": lo,
        "hi": hi,
        "covered": (lo <= t) & (t <= hi),
        "covered_robust": (robust[:, 0] <= t) & (t <= robust[:, 1]),
        "robust_width": (robust[:, 1] - robust[:, 0]) / (hi - lo),
        "z": (cal.theta_mean_ - t) / sd,
        "rank": np.sum(thinned(samples, n_rank) < t, axis=0),
        "cover_reality": float(cover_reality),
        "cover_obs": float(cover_obs),
        "cover_obs_draw": float(cover_obs_draw),
        "noise_ratio": np.asarray(cal.noise_) / case.noise_sd**2,
        "identifiability": (
            np.full(len(t), np.nan)
            if identifiability is None
            else np.asarray(identifiability, dtype=float).ravel()
        ),
        "fit_seconds": seconds,
    }


def run_replicate(name, seed, n_test=N_TEST, n_rank=N_RANK):
    """Fit one seed of one case and score it; never raises.

    Returns a dict with ``case``, ``seed``, ``ok``, ``error``, the warnings
    (``warning_categories``, ``warning_messages``), the wall time
    ``seconds`` and, when ``ok``, the scores of ``_fit_and_score``.
    """
    spec = cases()[name]
    record = {"case": name, "seed": int(seed), "ok": False, "error": ""}
    started = time.perf_counter()
    with (
        threadpoolctl.threadpool_limits(1),
        warnings.catch_warnings(record=True) as caught,
    ):
        warnings.simplefilter("always")
        try:
            record.update(_fit_and_score(spec, seed, n_test, n_rank))
            record["ok"] = True
        except Exception as exc:  # a failed fit is a result, not a crash
            record["error"] = f"{type(exc).__name__}: {exc}"[:300]
    record["seconds"] = time.perf_counter() - started
    record["warning_categories"] = [w.category.__name__ for w in caught]
    record["warning_messages"] = [str(w.message)[:300] for w in caught]
    return record


# --------------------------------------------------------------------------
# summaries
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


def message_kind(message, width=90):
    """A warning message with its numbers masked as ``#``, cut to ``width``.

    Messages that differ only in the values they quote (an R-hat, an
    identifiability) then count as one kind.
    """
    return _NUMBER.sub("#", message)[:width]


def summarise(records, n_rank=N_RANK):
    """Per-case summary (dict of dicts, in the order of first appearance)."""
    by_case = {}
    for rec in records:
        by_case.setdefault(rec["case"], []).append(rec)
    out = {}
    for name, recs in by_case.items():
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
            stack = {k: np.array([r[k] for r in ok]) for k in ok[0] if k in _ARRAYS}
            k_cov = stack["covered"].sum(axis=0)
            s["covered"] = k_cov
            s["wilson"] = [wilson_interval(k, n) for k in k_cov]
            s["covered_robust"] = stack["covered_robust"].sum(axis=0)
            s["robust_width"] = np.median(stack["robust_width"], axis=0)
            s["rms_z"] = rms(stack["z"])
            s["mean_z"] = stack["z"].mean(axis=0)
            tests = [rank_tests(col, n_rank) for col in stack["rank"].T]
            s["chi2_p"] = np.array([c for c, _ in tests])
            s["ks_p"] = np.array([k for _, k in tests])
            s["ranks"] = stack["rank"]
            s["cover_reality"] = stack["cover_reality"].mean()
            s["cover_obs"] = stack["cover_obs"].mean()
            s["cover_obs_draw"] = stack["cover_obs_draw"].mean()
            s["cover_ci"] = [
                mean_interval(stack[k]) for k in ("cover_reality", "cover_obs")
            ]
            s["theta_sd"] = np.median(stack["theta_sd"], axis=0)
            s["theta_sd_max"] = stack["theta_sd"].max(axis=0)
            s["prior_like"] = np.sum(
                stack["theta_sd"] > PRIOR_LIKE * stack["prior_sd"], axis=0
            )
            s["noise_ratio"] = np.median(stack["noise_ratio"], axis=0)
            ident = stack["identifiability"]
            s["identifiability"] = (
                np.nanmean(ident, axis=0) if np.isfinite(ident).any() else ident[0]
            )
            s["fit_seconds"] = stack["fit_seconds"].mean()
        out[name] = s
    return out


_ARRAYS = (
    "theta_true",
    "theta_mean",
    "theta_sd",
    "prior_sd",
    "lo",
    "hi",
    "covered",
    "covered_robust",
    "robust_width",
    "z",
    "rank",
    "cover_reality",
    "cover_obs",
    "cover_obs_draw",
    "noise_ratio",
    "identifiability",
    "fit_seconds",
)


def _join(values, fmt):
    return ", ".join(format(v, fmt) for v in np.atleast_1d(values))


def format_tables(summary):
    """The two printed tables (results, details) as one string."""
    head = (
        f"{'case':<7} {'seeds':>5}  {'theta* covered':<14} "
        f"{'Wilson 95 %':<27} {'rms z':<11} {'SBC chi2 p':<16} "
        f"{'KS p':<16} {'reality':>7} {'new obs':>7}  warnings (seeds)"
    )
    lines = [head, "-" * len(head)]
    for name, s in summary.items():
        if not s["n_ok"]:
            lines.append(f"{name:<7} {s['n']:>5}  all fits failed: {dict(s['errors'])}")
            continue
        n = s["n_ok"]
        covered = ", ".join(f"{k}/{n}" for k in s["covered"])
        wilson = ", ".join(f"[{lo:.2f}, {hi:.2f}]" for lo, hi in s["wilson"])
        warned = ", ".join(f"{c} {k}" for c, k in sorted(s["warnings"].items()))
        failed = f" (+{s['n_failed']} failed)" if s["n_failed"] else ""
        lines.append(
            f"{name:<7} {n:>5}  {covered:<14} {wilson:<27} "
            f"{_join(s['rms_z'], '.2f'):<11} {_join(s['chi2_p'], '.2g'):<16} "
            f"{_join(s['ks_p'], '.2g'):<16} {s['cover_reality']:>7.3f} "
            f"{s['cover_obs']:>7.3f}  {warned or '-'}{failed}"
        )
    detail = (
        f"{'case':<7} {'mean z':<13} {'post. sd: median [max]':<34} "
        f"{'sd ~ prior':<10} {'noise_/true (median)':<21} "
        f"{'identifiability_':<17} {'robust covered [width]':<23} "
        f"{'reality, new obs: 95 % CI':<27} {'one draw':<8} fit [s]"
    )
    lines += ["", detail, "-" * len(detail)]
    for name, s in summary.items():
        if not s["n_ok"]:
            continue
        sd_text = ", ".join(
            f"{m:.3g} [{x:.3g}]"
            for m, x in zip(s["theta_sd"], s["theta_sd_max"], strict=True)
        )
        ident = s["identifiability"]
        ident = "-" if np.all(np.isnan(ident)) else _join(ident, ".3g")
        robust = ", ".join(
            f"{k}/{s['n_ok']} [{w:.3g}]"
            for k, w in zip(s["covered_robust"], s["robust_width"], strict=True)
        )
        ci = ", ".join(f"[{lo:.3f}, {hi:.3f}]" for lo, hi in s["cover_ci"])
        lines.append(
            f"{name:<7} {_join(s['mean_z'], '+.2f'):<13} "
            f"{sd_text:<34} {_join(s['prior_like'], 'd'):<10} "
            f"{_join(s['noise_ratio'], '.2f'):<21} {ident:<17} {robust:<23} "
            f"{ci:<27} {s['cover_obs_draw']:<8.3f} {s['fit_seconds']:.1f}"
        )
    messages = Counter()
    for s in summary.values():
        messages.update(s["messages"])
    if messages:
        lines += ["", "warning messages (replicates; numbers as #, first 90 chars):"]
        lines += [f"  {k:>4}  {m}" for m, k in messages.most_common()]
    errors = {n: dict(s["errors"]) for n, s in summary.items() if s["errors"]}
    if errors:
        lines += ["", f"failed fits: {errors}"]
    return "\n".join(lines)


# --------------------------------------------------------------------------
# output
# --------------------------------------------------------------------------


def save_records(records, out):
    """``replicates.csv`` (replicate x parameter) and ``replicates.npz``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    specs = cases()
    fields = [
        "case", "seed", "parameter", "theta_true", "theta_mean", "theta_sd",
        "prior_sd", "lo", "hi", "covered", "z", "rank", "cover_reality", "cover_obs",
        "cover_obs_draw", "noise_ratio", "identifiability", "covered_robust",
        "robust_width", "fit_seconds", "warnings", "error",
    ]  # fmt: skip
    with open(out / "replicates.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields)
        writer.writeheader()
        for r in records:
            names = specs[r["case"]].parameter_names
            for j, p in enumerate(names):
                row = {"case": r["case"], "seed": r["seed"], "parameter": p}
                row["warnings"] = ";".join(sorted(set(r["warning_categories"])))
                row["error"] = r["error"]
                if r["ok"]:
                    for k in [
                        *fields[3:12],
                        "identifiability",
                        "covered_robust",
                        "robust_width",
                    ]:
                        row[k] = r[k][j]
                    row["noise_ratio"] = _join(r["noise_ratio"], ".4g")
                    for k in ("cover_reality", "cover_obs", "cover_obs_draw"):
                        row[k] = r[k]
                    row["fit_seconds"] = r["fit_seconds"]
                writer.writerow(row)
    arrays = {}
    for name in dict.fromkeys(r["case"] for r in records):
        ok = [r for r in records if r["case"] == name and r["ok"]]
        arrays[f"{name}__seed"] = np.array([r["seed"] for r in ok], dtype=int)
        for k in _ARRAYS:
            arrays[f"{name}__{k}"] = np.array([r[k] for r in ok])
    np.savez(out / "replicates.npz", **arrays)


def plot_ranks(summary, path, n_rank=N_RANK):
    """Rank histograms, one panel per case and parameter, with the band of
    counts (grey) that a uniform histogram stays inside bin by bin with
    99 % probability (binomial quantiles)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    specs = cases()
    panels = [
        (name, j, p)
        for name, s in summary.items()
        if s["n_ok"]
        for j, p in enumerate(specs[name].parameter_names)
    ]
    ncols = min(4, len(panels))
    nrows = -(-len(panels) // ncols)
    fig, axes = plt.subplots(
        nrows, ncols, figsize=(3.2 * ncols, 2.6 * nrows), squeeze=False
    )
    for ax in axes.ravel()[len(panels) :]:
        ax.set_visible(False)
    for ax, (name, j, p) in zip(axes.ravel(), panels, strict=False):
        s = summary[name]
        ranks = s["ranks"][:, j]
        counts, share = rank_histogram(ranks, n_rank)
        n, n_bins = len(ranks), len(counts)
        edges = np.linspace(0, 1, n_bins + 1)
        lo = stats.binom.ppf(0.005, n, share)
        hi = stats.binom.ppf(0.995, n, share)
        ax.stairs(counts, edges, fill=True, color="C0", alpha=0.8)
        ax.fill_between(edges, np.r_[lo, lo[-1]], np.r_[hi, hi[-1]], step="post",
                        color="0.5", alpha=0.25, lw=0, zorder=3)  # fmt: skip
        ax.axhline(n / n_bins, color="0.4", lw=0.8)
        ax.set_title(
            f"{name}: {p}  (n={n})\nchi2 p={s['chi2_p'][j]:.2g}, "
            f"KS p={s['ks_p'][j]:.2g}",
            fontsize=9,
        )
        ax.set_xlabel("normalised rank of theta*", fontsize=8)
        ax.tick_params(labelsize=8)
    axes[0, 0].set_ylabel("replicates", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def combined_ranks(directories, n_rank=N_RANK):
    """What :func:`plot_ranks` needs, from the ``replicates.npz`` of runs.

    Cases of several runs (say, the cheap cases with 50 seeds and the MCMC
    cases with fewer) then share one figure.
    """
    summary = {}
    for directory in directories:
        arrays = np.load(Path(directory) / "replicates.npz")
        for key in arrays.files:
            name, field = key.split("__")
            if field != "rank":
                continue
            ranks = arrays[key]
            tests = [rank_tests(col, n_rank) for col in ranks.T]
            summary[name] = {
                "n_ok": len(ranks),
                "ranks": ranks,
                "chi2_p": [t[0] for t in tests],
                "ks_p": [t[1] for t in tests],
            }
    return summary


# --------------------------------------------------------------------------
# command line
# --------------------------------------------------------------------------


def parse_case_seeds(text):
    """``"a2=10,sbc_a2=8"`` -> ``{"a2": 10, "sbc_a2": 8}``."""
    out = {}
    for item in filter(None, (t.strip() for t in (text or "").split(","))):
        name, _, value = item.partition("=")
        out[name.strip()] = int(value)
    return out


def run(names, seeds_per_case, n_jobs=1, progress=True):
    """Run the replicates of ``names`` (``seeds_per_case[name]`` each).

    Returns the records sorted by case (in ``names`` order) and seed.
    """
    tasks = [(name, seed) for name in names for seed in range(seeds_per_case[name])]
    order = {name: i for i, name in enumerate(COST_ORDER)}
    # slowest cases first, seeds interleaved so that every case makes progress
    tasks.sort(key=lambda t: (t[1], order.get(t[0], -1)))
    results = Parallel(n_jobs=n_jobs, batch_size=1, return_as="generator_unordered")(
        delayed(run_replicate)(name, seed) for name, seed in tasks
    )
    records = []
    for i, rec in enumerate(results, 1):
        records.append(rec)
        if progress:
            status = "ok" if rec["ok"] else rec["error"][:60]
            print(
                f"  [{i}/{len(tasks)}] {rec['case']} seed {rec['seed']}: "
                f"{rec['seconds']:.1f} s, {status}",
                file=sys.stderr,
                flush=True,
            )
    rank = {name: i for i, name in enumerate(names)}
    records.sort(key=lambda r: (rank[r["case"]], r["seed"]))
    return records


def main(argv=None):
    specs = cases()
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--n-seeds", type=int, default=20, help="seeds per case")
    parser.add_argument(
        "--case-seeds",
        default="",
        help="per-case overrides of --n-seeds, e.g. 'a2=10,sbc_a2=10'",
    )
    parser.add_argument("--n-jobs", type=int, default=1, help="parallel replicates")
    parser.add_argument(
        "--cases", default=",".join(specs), help=f"comma list of {', '.join(specs)}"
    )
    parser.add_argument("--out", default=None, help="directory for the results")
    parser.add_argument("--quiet", action="store_true", help="no progress lines")
    parser.add_argument(
        "--combine",
        default="",
        help="comma list of earlier --out directories: draw their rank "
        "histograms in one figure, --out/validity_ranks.png, and stop",
    )
    args = parser.parse_args(argv)
    if args.combine:
        if not args.out:
            parser.error("--combine needs --out")
        Path(args.out).mkdir(parents=True, exist_ok=True)
        directories = [d for d in args.combine.split(",") if d]
        plot_ranks(combined_ranks(directories), Path(args.out) / "validity_ranks.png")
        return None
    names = [c.strip() for c in args.cases.split(",") if c.strip()]
    unknown = [c for c in names if c not in specs]
    if unknown:
        parser.error(f"unknown case(s) {unknown}; choose from {list(specs)}")
    seeds = dict.fromkeys(names, args.n_seeds)
    seeds.update({k: v for k, v in parse_case_seeds(args.case_seeds).items()
                  if k in seeds})  # fmt: skip

    print("skmba validity suite: ModularBayesCalibrator with its current defaults")
    for name in names:
        print(f"  {name:<7} {seeds[name]:>3} seeds  {specs[name].description}")
    print(f"  n_jobs={args.n_jobs}; 95 % intervals; 30 dB noise\n", flush=True)
    started = time.perf_counter()
    records = run(names, seeds, n_jobs=args.n_jobs, progress=not args.quiet)
    wall = time.perf_counter() - started
    summary = summarise(records)
    table = format_tables(summary)
    fits = sum(r["seconds"] for r in records)
    footer = (
        f"wall time {wall:.0f} s ({wall / 60:.1f} min) for {len(records)} "
        f"replicates, {fits:.0f} s of fits in total, n_jobs={args.n_jobs}"
    )
    print(table)
    print()
    print(footer)
    if args.out:
        out = Path(args.out)
        save_records(records, out)
        (out / "table.txt").write_text(table + "\n\n" + footer + "\n")
        plot_ranks(summary, out / "validity_ranks.png")
        print(f"results in {out}/ (replicates.csv, replicates.npz, table.txt, "
              "validity_ranks.png)")  # fmt: skip
    return summary


if __name__ == "__main__":
    main()
