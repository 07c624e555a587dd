"""Does theta's range over a stated class of discrepancy priors cover theta*?

Per case and seed, the default calibrator is fitted and
``prior_sensitivity()`` refits it with the discrepancy prior's roughness
range divided and multiplied by 10 and its size by 4; the ``union`` row is
the union of the five 95 % intervals (robust Bayes over that class). The
study prints, per case, how often the fit's own interval and the union
cover theta* (Wilson 95 % intervals), and the median widths of both as a
share of the prior's central 95 % (``prior_share``).

It replaces ``theta_robust_interval_`` (a Gaussian width at one fixed
discrepancy size, most of the prior by construction), removed; issue 31
asks a robust range to cover theta* on a1, c1 and c3 in at least 90 % of
seeds, with its width against the prior's.

Usage::

    python -m validation.studies.robust_range --cases a1,c1,c3,freq \\
        --n-seeds 20 --n-jobs 2

Quoted in ``docs/validity.rst`` ("A range over a class of priors").
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed

from skmba import ModularBayesCalibrator
from validation.statistics import wilson_interval
from validation.suite import registry


def one(case_name, seed):
    """Per parameter: own interval covered, union covered, their prior
    shares (4, r)."""
    case = registry()[case_name].build(seed)
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = ModularBayesCalibrator(prior=case.prior, random_state=seed, n_jobs=1)
        cal.fit(case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim,
                y_sim=case.y_sim)  # fmt: skip
        tab = cal.prior_sensitivity()
    t = np.asarray(case.theta_true, dtype=float)
    out = []
    for j, name in enumerate(cal.parameter_names_):
        own, union = tab.loc[f"default[{name}]"], tab.loc[f"union[{name}]"]
        out.append(
            [
                own["2.5%"] <= t[j] <= own["97.5%"],
                union["2.5%"] <= t[j] <= union["97.5%"],
                own["prior_share"],
                union["prior_share"],
            ]
        )
    return np.array(out, dtype=float).T


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", default="a1,c1,c3,freq")
    parser.add_argument("--n-seeds", type=int, default=20)
    parser.add_argument("--n-jobs", type=int, default=1)
    args = parser.parse_args(argv)
    cases = args.cases.split(",")
    started = time.perf_counter()
    tasks = [(c, s) for c in cases for s in range(args.n_seeds)]
    rows = Parallel(n_jobs=args.n_jobs)(delayed(one)(c, s) for c, s in tasks)
    seconds = time.perf_counter() - started
    print(f"{args.n_seeds} seeds per case, defaults, {seconds:.0f} s")
    print("case | own covered [Wilson] | union covered [Wilson] | median prior share:"
          " own, union")  # fmt: skip
    for i, case in enumerate(cases):
        values = np.stack(rows[i * args.n_seeds : (i + 1) * args.n_seeds])
        for j in range(values.shape[2]):
            v, n = values[:, :, j], args.n_seeds
            own, union = int(v[:, 0].sum()), int(v[:, 1].sum())
            lo1, hi1 = wilson_interval(own, n)
            lo2, hi2 = wilson_interval(union, n)
            print(
                f"{case}[{j}] | {own}/{n} [{lo1:.2f}, {hi1:.2f}] | {union}/{n} "
                f"[{lo2:.2f}, {hi2:.2f}] | {np.median(v[:, 2]):.3f}, "
                f"{np.median(v[:, 3]):.3f}"
            )


if __name__ == "__main__":
    main()
