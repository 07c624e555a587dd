"""Coverage of the bridge year: does theta's 95 % interval cover the truth?

For each seed, :func:`skmba.datasets.make_bridge_monitoring` draws a year
of hourly readings (no damage) and its simulations, and the calibrator is
fitted on all of it (``--bin-width`` degC bins, chains of ``--n-samples``
draws after ``--burn-in``, otherwise the defaults). Printed per parameter:
how often the central 95 % interval covers the true value, with its Wilson
interval; the rms z-score of the truth; the posterior sd over the prior's
(near 1: the data taught little); and how often ``fit`` warned that the
parameter is not identified. Then reality's posterior
(:meth:`~skmba.ModularBayesCalibrator.predict_reality`) against the
noise-free frequencies at up to 200 distinct field temperatures, below and
above 0 degC, where the bearings stiffen: the rms z-score and the share of
the 95 % intervals ``mean ± 1.96 sd`` that cover them. ``--discrepancy-power
p`` replaces the default Gaussian discrepancy correlation by
``GeneralizedExp(power=p)`` (p fixed; 2 is the Gaussian's shape). Fits run
in parallel (``--n-jobs``), one BLAS thread each.

Usage::

    python -m validation.studies.monitoring_coverage --n-seeds 50 --n-jobs 2
    python -m validation.studies.monitoring_coverage --discrepancy-power 1.75

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
from skmba.kernels import GeneralizedExp
from validation.statistics import LEVEL, rms, wilson_interval

#: Distinct field temperatures at which reality's posterior is scored.
REALITY_POINTS = 200


def _reality_z(cal, data):
    """z-scores of reality's posterior against the noise-free readings at up
    to :data:`REALITY_POINTS` distinct temperatures, and whether each lies
    below 0 degC (both flattened over the frequencies)."""
    X = np.asarray(data.X_obs, dtype=float)
    truth = np.asarray(data.y_obs_true, dtype=float)
    _, first = np.unique(X, axis=0, return_index=True)
    rows = first[:: max(1, len(first) // REALITY_POINTS)]
    mean, std = cal.predict_reality(X[rows], return_std=True)
    z = (np.asarray(mean) - truth[rows]) / np.asarray(std)
    cold = np.broadcast_to((X[rows, 0] < 0.0)[:, None], z.shape)
    return z.ravel(), cold.ravel()


def replicate(seed, bin_width, n_samples, burn_in, power):
    """One seed: (covered (r,), z (r,), sd / prior sd (r,), warned (r,),
    reality's z-scores, below 0 degC)."""
    data = make_bridge_monitoring(random_state=seed)
    kernel = {}
    if power is not None:
        kernel["discrepancy_kernel"] = GeneralizedExp(power=power, power_bounds="fixed")
    cal = ModularBayesCalibrator(
        prior=data.prior,
        bin_width=bin_width,
        n_samples=n_samples,
        burn_in=burn_in,
        random_state=seed,
        **kernel,
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
    with threadpoolctl.threadpool_limits(1):
        reality_z, cold = _reality_z(cal, data)
    return (
        (low <= truth) & (truth <= high),
        (cal.theta_mean_ - truth) / sd,
        sd / np.sqrt(np.diag(cal.prior_.cov())),
        np.array(warned),
        reality_z,
        cold,
    )


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-seeds", type=int, default=50)
    parser.add_argument("--n-jobs", type=int, default=1)
    parser.add_argument("--bin-width", type=float, default=2.0)
    parser.add_argument("--n-samples", type=int, default=1000)
    parser.add_argument("--burn-in", type=int, default=300)
    parser.add_argument("--discrepancy-power", type=float, default=None)
    args = parser.parse_args(argv)
    started = time.perf_counter()
    out = Parallel(n_jobs=args.n_jobs)(
        delayed(replicate)(
            s, args.bin_width, args.n_samples, args.burn_in, args.discrepancy_power
        )
        for s in range(args.n_seeds)
    )
    covered, z, ratio, warned = (np.array(v) for v in list(zip(*out, strict=True))[:4])
    reality_z = np.concatenate([o[4] for o in out])
    cold = np.concatenate([o[5] for o in out])
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
    print("reality | scored | covered by mean ± 1.96 sd | rms z")
    for label, band in (("below 0 degC", cold), ("at or above 0 degC", ~cold)):
        inside = np.abs(reality_z[band]) <= 1.96
        print(
            f"{label} | {band.sum()} | {inside.mean():.3f} | {rms(reality_z[band]):.2f}"
        )


if __name__ == "__main__":
    main()
