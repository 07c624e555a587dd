"""Running the validity suite: the case registry, one replicate, many in parallel.

- :func:`registry`: every case by name, from :mod:`validation.cases` and
  :mod:`validation.sbc_cases`;
- :func:`held_out_inputs`: the inputs of the predictive checks;
- :func:`run_replicate`: fit one seed of one case with the calibrator's
  defaults and score it (never raises; a failed fit is a record);
- :func:`run`: the replicates of several cases through joblib, slowest
  first, each with the calibrator's ``n_jobs=1`` and BLAS held to one
  thread.

Callers: ``python -m validation`` (:mod:`validation.__main__`), the studies
of :mod:`validation.studies` (:func:`registry`, :func:`held_out_inputs`) and
``tests/validation/test_suite.py``. The scores are those of
``docs/validity.rst`` ("What is measured").
"""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed

from skmba import ModularBayesCalibrator
from validation import cases, sbc_cases
from validation.statistics import (
    LEVEL,
    N_RANK,
    Z_LEVEL,
    fresh_observations,
    observation_coverage,
    prior_sd,
    thinned,
)

N_TEST = 50  # held-out inputs of the predictive checks
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


def registry():
    """Every case of the suite by name: ``validation.cases`` and ``sbc_cases``.

    The SBC cases of :mod:`validation.sbc_cases` (everything drawn from the
    default priors) are ``sbc_a1`` and ``sbc_a2``; the earlier ones of
    :mod:`validation.cases`, which draw only theta* and no discrepancy, stay
    reachable as ``sbc0_a1`` and ``sbc0_a2``.
    """
    out = dict(cases.CASES)
    for name in ("sbc_a1", "sbc_a2"):
        out[name.replace("sbc_", "sbc0_")] = out.pop(name)
    out.update(sbc_cases.SBC_CASES)
    return out


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


def _fit_and_score(spec, seed, n_test, n_rank, options=None):
    case = spec.build(seed)
    cal = ModularBayesCalibrator(
        prior=case.prior, random_state=seed, n_jobs=1, **(options or {})
    )
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
    return {
        "theta_true": t,
        "theta_mean": cal.theta_mean_,
        "theta_sd": sd,
        "prior_sd": prior_sd(case.prior),
        "lo": lo,
        "hi": hi,
        "covered": (lo <= t) & (t <= hi),
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


def run_replicate(name, seed, n_test=N_TEST, n_rank=N_RANK, options=None):
    """Fit one seed of one case and score it; never raises.

    Returns a dict with ``case``, ``seed``, ``ok``, ``error``, the warnings
    (``warning_categories``, ``warning_messages``), the wall time
    ``seconds`` and, when ``ok``, the scores of ``_fit_and_score``.
    ``options``: calibrator parameters other than the defaults.
    """
    spec = registry()[name]
    record = {"case": name, "seed": int(seed), "ok": False, "error": ""}
    started = time.perf_counter()
    with (
        threadpoolctl.threadpool_limits(1),
        warnings.catch_warnings(record=True) as caught,
    ):
        warnings.simplefilter("always")
        try:
            record.update(_fit_and_score(spec, seed, n_test, n_rank, options))
            record["ok"] = True
        except Exception as exc:  # a failed fit is a result, not a crash
            record["error"] = f"{type(exc).__name__}: {exc}"[:300]
    record["seconds"] = time.perf_counter() - started
    record["warning_categories"] = [w.category.__name__ for w in caught]
    record["warning_messages"] = [str(w.message)[:300] for w in caught]
    return record


# --------------------------------------------------------------------------
# many replicates
# --------------------------------------------------------------------------


def run(names, seeds_per_case, n_jobs=1, progress=True, options=None):
    """Run the replicates of ``names`` (``seeds_per_case[name]`` each), with
    the calibrator parameters ``options`` (None: the defaults).

    Returns the records sorted by case (in ``names`` order) and seed.
    """
    tasks = [(name, seed) for name in names for seed in range(seeds_per_case[name])]
    order = {name: i for i, name in enumerate(COST_ORDER)}
    # slowest cases first, seeds interleaved so that every case makes progress
    tasks.sort(key=lambda t: (t[1], order.get(t[0], -1)))
    results = Parallel(n_jobs=n_jobs, batch_size=1, return_as="generator_unordered")(
        delayed(run_replicate)(name, seed, options=options) for name, seed in tasks
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
