"""Coverage of the bridge year: does theta's 95 % interval cover the truth?

For each seed, :func:`skmba.datasets.make_bridge_monitoring` draws a year
of hourly readings (no damage) and its simulations, and the calibrator is
fitted on all of it (``--bin-width`` degC bins, chains of ``--n-samples``
draws after ``--burn-in``, otherwise the defaults). Printed per parameter:
how often the central 95 % interval covers the true value, with its Wilson
interval; the rms z-score of the truth; the posterior sd over the prior's
(near 1: the data taught little); and how often ``fit`` warned that the
parameter is not identified. Fits run in parallel (``--n-jobs``), one BLAS
thread each.

Usage::

    python -m validation.studies.monitoring_coverage --n-seeds 50 --n-jobs 2

The results are in ``docs/monitoring.rst``.
"""

import argparse
import time
import warnings

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed

from skmba import ModularBayesCalibrator
from skmba.datasets import make_bridge_monitoring
from skmba.exceptions import NonIdentifiabilityWarning
from validation.statistics import LEVEL, rms, wilson_interval


def _replicate(seed, bin_width, n_samples, burn_in):
    """One seed: (covered (r,), z (r,), sd / prior sd (r,), warned (r,))."""
    data = make_bridge_monitoring(random_state=seed)
    cal = ModularBayesCalibrator(
        prior=data.prior,
        bin_width=bin_width,
        n_samples=n_samples,
        burn_in=burn_in,
        random_state=seed,
    )
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        cal.fit(
            data.X_obs,
            data.y_obs,
            X_sim=data.X_sim,
            theta_sim=data.theta_sim,
            y_sim=data.y_sim,
        )
    truth = np.asarray(data.theta_true, dtype=float)
    tail = (1 - LEVEL) / 2
    low, high = np.quantile(cal.theta_samples_, [tail, 1 - tail], axis=0)
    sd = np.sqrt(np.diag(cal.theta_cov_))
    warned = [
        any(
            issubclass(x.category, NonIdentifiabilityWarning) and name in str(x.message)
            for x in w
        )
        for name in cal.parameter_names_
    ]
    return (
        (low <= truth) & (truth <= high),
        (cal.theta_mean_ - truth) / sd,
        sd / np.sqrt(np.diag(cal.prior_.cov())),
        np.array(warned),
    )


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-seeds", type=int, default=50)
    parser.add_argument("--n-jobs", type=int, default=1)
    parser.add_argument("--bin-width", type=float, default=2.0)
    parser.add_argument("--n-samples", type=int, default=1000)
    parser.add_argument("--burn-in", type=int, default=300)
    args = parser.parse_args(argv)
    started = time.perf_counter()
    out = Parallel(n_jobs=args.n_jobs)(
        delayed(_replicate)(s, args.bin_width, args.n_samples, args.burn_in)
        for s in range(args.n_seeds)
    )
    covered, z, ratio, warned = (np.array(v) for v in zip(*out, strict=True))
    n = len(covered)
    names = ["E", "k_bearing"]
    print(f"{n} seeds, {time.perf_counter() - started:.0f} s")
    print("parameter | covered | Wilson 95 % | rms z | sd / prior sd | warned")
    for j, name in enumerate(names):
        lo, hi = wilson_interval(int(covered[:, j].sum()), n)
        print(
            f"{name} | {covered[:, j].sum()}/{n} | [{lo:.3f}, {hi:.3f}] | "
            f"{rms(z[:, j]):.2f} | {np.median(ratio[:, j]):.2f} (median) | "
            f"{warned[:, j].sum()}/{n}"
        )


if __name__ == "__main__":
    main()
