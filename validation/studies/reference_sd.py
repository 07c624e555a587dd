"""Posterior sd of theta with the default treatment over a discrepancy-free fit.

Issue 13 asks that on an identifiable design the posterior sd of theta stay
within 1.5 times what the discrepancy-free likelihood gives: the width must
come from the data, not from assumptions about the discrepancy. Per seed of
a case of :mod:`validation.cases` this fits the calibrator twice on the same
data:

- with its defaults;
- without a discrepancy: the plug-in module 2 with the discrepancy variance
  held in ``[0, 1e-12]`` of the simulated variance (the noise still
  estimated),

and prints the ratio of the two posterior sds (median, range) and, for
reference, how often each interval covers theta*.

Usage::

    python -m validation.studies.reference_sd --case freq --n-seeds 50 --n-jobs 2

The freq result is quoted in ``docs/validity.rst``.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed

from skmba import ModularBayesCalibrator
from validation.cases import CASES

NO_DISCREPANCY = {
    "discrepancy_uncertainty": "plug-in",
    "discrepancy_prior": {"variance": (0.0, 1e-12)},
}


def one_seed(case, seed):
    """Posterior sd and coverage with the defaults and without a discrepancy."""
    data = CASES[case].build(seed)
    out = {}
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for label, params in (("default", {}), ("no discrepancy", NO_DISCREPANCY)):
            cal = ModularBayesCalibrator(
                prior=data.prior, random_state=seed, n_jobs=1, **params
            ).fit(
                data.X,
                data.y,
                X_sim=data.X_sim,
                theta_sim=data.theta_sim,
                y_sim=data.y_sim,
            )
            lo, hi = np.quantile(cal.theta_samples_, [0.025, 0.975], axis=0)
            covered = (lo <= data.theta_true) & (data.theta_true <= hi)
            out[label] = (np.sqrt(np.diag(cal.theta_cov_)), covered)
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(
        prog="python -m validation.studies.reference_sd",
        description=__doc__.split("\n")[0],
    )
    parser.add_argument("--case", default="freq", choices=sorted(CASES))
    parser.add_argument("--n-seeds", type=int, default=20)
    parser.add_argument("--n-jobs", type=int, default=1)
    args = parser.parse_args(argv)
    results = Parallel(n_jobs=args.n_jobs)(
        delayed(one_seed)(args.case, seed) for seed in range(args.n_seeds)
    )
    ratio = np.array([r["default"][0] / r["no discrepancy"][0] for r in results])
    print(f"case {args.case}, {args.n_seeds} seeds")
    for label in ("default", "no discrepancy"):
        sd = np.array([r[label][0] for r in results])
        covered = np.array([r[label][1] for r in results]).sum(axis=0)
        print(
            f"  {label:15s} posterior sd median {np.median(sd, axis=0)}, "
            f"covered {covered} of {args.n_seeds}"
        )
    print(
        f"  sd ratio default / no discrepancy: median {np.median(ratio, axis=0)}, "
        f"range {ratio.min(axis=0)} to {ratio.max(axis=0)}, "
        f"above 1.5 in {np.sum(ratio > 1.5, axis=0)} seeds"
    )


if __name__ == "__main__":
    main()
