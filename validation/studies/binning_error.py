"""``bin_width``'s approximation: the posterior with binned readings against
the readings' exact means.

On the first ``--hours`` readings of ``make_bridge_monitoring(random_state=
SEED)`` (744: January, the frost region included) the calibrator is fitted
with the exact means of the readings at each distinct temperature (the
reference, ``bin_width=None``) and with each ``--widths`` (degC). Printed per
width: the distinct inputs, the fit's time, the shift of each parameter's
posterior mean in the reference's posterior sds, the ratio of the posterior
sds and of the noise sds to the reference's. The fits run in parallel
(``--n-jobs``), each under one BLAS thread.

Usage::

    python -m validation.studies.binning_error --widths 0.5,1,2 --n-jobs 2

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

SEED = 0


def _fit(width, hours, uncertainty, seed):
    """One fit: (width, distinct inputs, seconds, mean, sd, noise sd)."""
    data = make_bridge_monitoring(random_state=seed)
    X, Y = data.X_obs[:hours], data.y_obs[:hours]
    cal = ModularBayesCalibrator(
        prior=data.prior,
        random_state=0,
        bin_width=width,
        discrepancy_uncertainty=uncertainty,
    )
    started = time.perf_counter()
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # E is not identified: docs say so
        cal.fit(X, Y, X_sim=data.X_sim, theta_sim=data.theta_sim, y_sim=data.y_sim)
    seconds = time.perf_counter() - started
    n_means = int(np.asarray(cal.theta_history_["n_means"])[-1])
    sd = np.sqrt(np.diag(cal.theta_cov_))
    return width, n_means, seconds, cal.theta_mean_, sd, np.sqrt(cal.noise_)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--widths", default="0.5,1,2")
    parser.add_argument("--hours", type=int, default=744)
    parser.add_argument("--uncertainty", default="plug-in")
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--n-jobs", type=int, default=1)
    args = parser.parse_args(argv)
    widths = [None] + [float(w) for w in args.widths.split(",")]
    results = Parallel(n_jobs=args.n_jobs)(
        delayed(_fit)(w, args.hours, args.uncertainty, args.seed) for w in widths
    )
    _, _, _, mean0, sd0, noise0 = results[0]
    print("width | distinct | fit s | mean shift / sd | sd ratio | noise sd ratio")
    for width, n, seconds, mean, sd, noise in results:
        print(
            f"{width} | {n} | {seconds:.1f} | {np.round((mean - mean0) / sd0, 3)} | "
            f"{np.round(sd / sd0, 3)} | {np.round(noise / noise0, 3)}"
        )


if __name__ == "__main__":
    main()
