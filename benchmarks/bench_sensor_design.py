"""Benchmark the fast preposterior analysis (PreposteriorDesigner).

Prints, from one run in one process:

(a) The wall time of an exhaustive FPA over the nine strain gauges SA-SI of
    the truss bridge (``skmba.datasets.make_truss_bridge``; thesis section
    6.4): all 2^9 - 1 = 511 subsets x 100 Monte Carlo replicates, 30
    simulations, 12 design temperatures, ``n_jobs`` workers (default 2),
    started once before (their start-up time is printed on its own: a
    Python session pays it at its first parallel fit only). The split into
    step 1 + phase 1 (emulator, synthetic data and one module-2 fit per
    replicate) and phase 2 (posterior of theta for every subset and
    replicate, along a prefix tree of the subsets) is printed from the
    designer's ``verbose`` output, with the best subset of each size.
    Target (issue 15) on a 2-core machine: under 20 s with ``n_jobs=2``
    (the thesis reports about 6 hours, Arendt's method an estimated 15.3 h).
(b) The parallel efficiency of (a): the same FPA with ``n_jobs=1``, timed
    here, ``t_1 / (n_jobs t_n)``, and the largest relative difference of
    the two runs' scores (the results do not depend on ``n_jobs``). Target:
    at least 0.85 at ``n_jobs=2``. Skipped with ``--no-serial``.
(c) The fast/full speed ratio: the same FPA with ``fast=True`` (phase-1
    discrepancy estimates reused for every subset) and ``fast=False``
    (re-estimated for every subset and replicate, as Arendt et al.) on a
    smaller problem (4 gauges, 15 subsets, 10 replicates), both timed here,
    with the Spearman correlation of the two rankings.

Usage::

    python benchmarks/bench_sensor_design.py [--n-mc 100] [--n-jobs 2] [--no-serial]
"""

import argparse
import importlib
import os
import time
import warnings

import numpy as np
from joblib import Parallel, delayed
from scipy import stats

from skmba import ModularBayesCalibrator, PreposteriorDesigner
from skmba.datasets import make_truss_bridge

try:  # run as a script (python benchmarks/bench_x.py) or as a module
    from _machine import machine_report
except ImportError:
    from benchmarks._machine import machine_report

GAUGES = ["SA", "SB", "SC", "SD", "SE", "SF", "SG", "SH", "SI"]


def run(sensors, *, n_mc, n_jobs, fast=True, verbose=0):
    data = make_truss_bridge(30, sensors=sensors, random_state=0)
    X = np.hstack([data.X_sim, data.theta_sim])
    designer = PreposteriorDesigner(
        data.prior,
        calibrator=ModularBayesCalibrator(n_restarts_optimizer=0),
        n_design=12,
        n_mc=n_mc,
        fast=fast,
        n_jobs=n_jobs,
        random_state=0,
        verbose=verbose,
    )
    started = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        designer.fit(X, data.y_sim)
    return designer, time.perf_counter() - started


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--n-mc", type=int, default=100)
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument(
        "--no-serial", action="store_true", help="skip (b), the n_jobs=1 run"
    )
    args = parser.parse_args()
    print(machine_report())
    print(f"n_jobs={args.n_jobs}")
    started = time.perf_counter()
    Parallel(n_jobs=args.n_jobs)(
        delayed(importlib.import_module)("skmba") for _ in range(os.cpu_count())
    )
    print(
        "joblib workers started (once per Python session, with skmba imported): "
        f"{time.perf_counter() - started:.2f} s"
    )

    print(f"\n(a) exhaustive FPA, 9 gauges, 511 subsets x {args.n_mc} replicates")
    designer, elapsed = run(GAUGES, n_mc=args.n_mc, n_jobs=args.n_jobs, verbose=1)
    n_subsets = len(designer.subsets_)
    print(f"  wall time:                      {elapsed:8.1f} s  (target < 20 s)")
    print(f"  subsets x replicates:           {n_subsets} x {args.n_mc}")
    print(
        f"  per (subset, replicate):        "
        f"{1e3 * elapsed / (n_subsets * args.n_mc):8.2f} ms"
    )
    print(f"  ratio to the thesis' ~6 h:      {elapsed / (6 * 3600):8.4f}")
    names = np.array(GAUGES)
    for size in range(1, 10):
        sel = [i for i, s in enumerate(designer.subsets_) if len(s) == size]
        best = sel[int(np.argmin(designer.scores_[sel]))]
        print(
            f"  best of size {size}: {'+'.join(names[list(designer.subsets_[best])])}"
            f"  score {designer.scores_[best]:.4f}"
            f"  (worst {designer.scores_[sel].max():.4f})"
        )
    ranking = dict(zip(GAUGES, designer.ranking_.tolist(), strict=True))
    print(f"  single-gauge ranking: {ranking}")

    if not args.no_serial:
        print(f"\n(b) the same FPA with n_jobs=1 (against n_jobs={args.n_jobs})")
        serial, t_serial = run(GAUGES, n_mc=args.n_mc, n_jobs=1)
        efficiency = t_serial / (args.n_jobs * elapsed)
        diff = np.max(np.abs(serial.scores_ / designer.scores_ - 1.0))
        print(f"  wall time, n_jobs=1:            {t_serial:8.1f} s")
        print(f"  parallel efficiency:            {efficiency:8.2f}  (target >= 0.85)")
        print(f"  largest relative score change:  {diff:8.1e}")

    print("\n(c) fast (phase-1 reuse) against full (per-subset module 2)")
    small = ["SA", "SB", "SG", "SH"]
    fast, t_fast = run(small, n_mc=10, n_jobs=args.n_jobs, fast=True)
    full, t_full = run(small, n_mc=10, n_jobs=args.n_jobs, fast=False)
    rho = stats.spearmanr(fast.scores_, full.scores_).statistic
    print("  4 gauges, 15 subsets x 10 replicates")
    print(f"  fast=True:                      {t_fast:8.1f} s")
    print(f"  fast=False:                     {t_full:8.1f} s")
    print(f"  speed ratio full / fast:        {t_full / t_fast:8.1f}")
    print(f"  Spearman correlation of scores: {rho:8.3f}")


if __name__ == "__main__":
    main()
