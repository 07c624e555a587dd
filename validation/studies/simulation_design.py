"""Does theta's interval move when only the simulation design does?

a1's field data (seed 0: 25 tip displacements and energies under forces
of 1-10 kN) are kept; the 70 Latin-hypercube simulations are run over
forces of ``[1, F_max]`` kN for each ``F_max`` of ``--ranges`` (same unit
design, same E values, only the force axis stretched). Each design is
fitted with ``random_state`` 0..``--refits``-1 and the study prints, per
design, the mean over the refits of E's posterior mean, sd and 95 % ends,
with the standard error of the mean sd over the refits, and the ratio of
each design's mean sd to the first design's.

DESIGN.md asks that "the result must not change when only the simulation
design does"; issue 30 sets the bar at posterior sds within +-15 % of each
other.

Usage::

    python -m validation.studies.simulation_design --ranges 10,20,40 \\
        --refits 5 --n-jobs 2
    python -m validation.studies.simulation_design --discrepancy-tol 0.05

Quoted in ``docs/validity.rst`` ("The simulation design").
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed

from skmba import ModularBayesCalibrator
from skmba.datasets import make_cantilever
from validation.__main__ import discrepancy_tol_argument
from validation.cases import CANTILEVER_SIZES, case_a1


def simulations(f_max_kn, seed=0):
    """a1's 70 simulations with the force axis over ``[1, f_max_kn]`` kN."""
    data = make_cantilever(*CANTILEVER_SIZES, random_state=seed)
    lo, hi = 1.0e3, 10.0e3
    unit = (data.X_sim - lo) / (hi - lo)
    X_sim = lo + unit * (f_max_kn * 1.0e3 - lo)
    return X_sim, data.theta_sim, data.simulator(X_sim, data.theta_sim)


def fit_one(f_max_kn, random_state, tol, seed=0):
    """E's posterior mean, sd and 95 % ends for one design and refit."""
    case = case_a1(seed)
    X_sim, theta_sim, y_sim = simulations(f_max_kn, seed)
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = ModularBayesCalibrator(
            prior=case.prior,
            random_state=random_state,
            n_jobs=1,
            discrepancy_tol=tol,
        ).fit(case.X, case.y, X_sim=X_sim, theta_sim=theta_sim, y_sim=y_sim)
    ends = np.quantile(cal.theta_samples_[:, 0], [0.025, 0.975])
    return np.r_[cal.theta_mean_[0], np.sqrt(cal.theta_cov_[0, 0]), ends]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ranges", default="10,20,40", help="F_max values, kN")
    parser.add_argument("--refits", type=int, default=5)
    parser.add_argument(
        "--discrepancy-tol",
        type=discrepancy_tol_argument,
        default="auto",
        help="a number, 'none' (16 draws) or 'auto' (the default)",
    )
    parser.add_argument("--n-jobs", type=int, default=1)
    args = parser.parse_args(argv)
    ranges = [float(v) for v in args.ranges.split(",")]
    tasks = [(f, k) for f in ranges for k in range(args.refits)]
    started = time.perf_counter()
    rows = Parallel(n_jobs=args.n_jobs)(
        delayed(fit_one)(f, k, args.discrepancy_tol) for f, k in tasks
    )
    values = np.array(rows).reshape(len(ranges), args.refits, 4)
    print(
        f"a1 seed 0, {args.refits} refits per design, discrepancy_tol="
        f"{args.discrepancy_tol}, {time.perf_counter() - started:.0f} s"
    )
    print("forces [kN] | mean E [MPa] | sd [MPa] (se) | 2.5 % | 97.5 % | sd ratio")
    base = values[0, :, 1].mean()
    for f, v in zip(ranges, values, strict=True):
        sd = v[:, 1]
        se = sd.std(ddof=1) / np.sqrt(len(sd)) if len(sd) > 1 else np.nan
        print(
            f"[1, {f:g}] | {v[:, 0].mean():.0f} | {sd.mean():.0f} ({se:.0f}) | "
            f"{v[:, 2].mean():.0f} | {v[:, 3].mean():.0f} | {sd.mean() / base:.2f}"
        )


if __name__ == "__main__":
    main()
