"""What a prior mass on "no discrepancy" would do: a what-if study (issue 13).

New observations are covered at 0.93-0.94 instead of 0.95 on the validity
suite's designs whose truth has no discrepancy on some response
(``new_observation_noise --pure-noise`` shows why: the default prior's
discrepancy takes up part of the noise). A spike-and-slab prior, "no
discrepancy" with probability ``pi0`` and the default prior otherwise,
would let such data switch the discrepancy off. This script estimates what
it would give, without building it, by Bayesian model averaging of two
calibrations of the same data:

* the **slab**: the default calibrator;
* the **spike**: the default calibrator with ``discrepancy_prior``'s
  ``sd_scale`` at ``1e-3`` (a discrepancy 500 times smaller than the
  default's, in practice none).

Each fit's evidence ``p(data)`` is its module-3 posterior density
(``log_posterior``: the prior times the likelihood mixed over module 2's
draws, both normalised) integrated over theta on a grid of 801 points
(+-12 posterior sds, clipped to the prior's support), so one-parameter
cases only. The spike's posterior probability is then ``pi0 Z_spike / (pi0
Z_spike + (1 - pi0) Z_slab)``, and theta and the predictions are the two
posteriors mixed with these weights: theta's 95 % interval from the mixed
draws, the predictions' mean and sd of the normal mixture (intervals mean
+- 1.96 sd, as the validity suite scores ``predict``). Per case it prints
the median spike probability and, for slab, spike and their mixture,
theta's coverage and rms z, and the coverage of the reality and of new
observations (mean over seeds).

Usage::

    python -m validation.studies.spike_probe --cases a1,b1,c1,c3,freq --n-seeds 40

(add ``--n-jobs 2`` for two processes). The results are in
``docs/validity.rst`` ("A prior mass on 'no discrepancy' would not close
it").
"""

import argparse
import warnings

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed
from scipy import special

from skmba import ModularBayesCalibrator
from validation.statistics import LEVEL, Z_LEVEL, observation_coverage
from validation.suite import N_TEST, held_out_inputs, registry

#: The spike's ``sd_scale`` (the default's is 0.5).
SPIKE_SD_SCALE = 1e-3
#: Grid of the evidence: points and half-width in posterior sds.
GRID_POINTS, GRID_SDS = 801, 12.0


def log_evidence(cal, prior):
    """``log p(data)``: ``log_posterior`` integrated over theta on a grid."""
    mean, sd = cal.theta_mean_[0], float(np.sqrt(cal.theta_cov_[0, 0]))
    lo, hi = prior[0].support()
    grid = np.linspace(
        max(lo, mean - GRID_SDS * sd), min(hi, mean + GRID_SDS * sd), GRID_POINTS
    )
    values = cal.log_posterior(grid[:, None])
    return float(special.logsumexp(values) + np.log(grid[1] - grid[0]))


def mixed_interval(samples, weights, level=LEVEL):
    """Equal-tailed interval of the draws of two posteriors, each draw
    weighted by its posterior's probability over its number of draws."""
    values = np.concatenate(samples)
    w = np.concatenate(
        [np.full(len(s), p / len(s)) for s, p in zip(samples, weights, strict=True)]
    )
    order = np.argsort(values)
    cdf = np.cumsum(w[order]) / w.sum()
    return np.interp([(1 - level) / 2, (1 + level) / 2], cdf, values[order])


def mixed_normal(means, sds, weights):
    """Mean and sd of a mixture of normals (same shapes, one per weight)."""
    mean = sum(p * m for p, m in zip(weights, means, strict=True))
    second = sum(p * (s**2 + m**2) for p, m, s in zip(weights, means, sds, strict=True))
    return mean, np.sqrt(np.maximum(second - mean**2, 0.0))


def run_replicate(name, seed, pi0):
    spec = registry()[name]
    case = spec.build(seed)
    X_test = held_out_inputs(spec.X_bounds, N_TEST)
    truth = case.reality_fn(X_test)
    fits = {}
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for label, prior in (("slab", None), ("spike", {"sd_scale": SPIKE_SD_SCALE})):
            cal = ModularBayesCalibrator(
                prior=case.prior, random_state=seed, discrepancy_prior=prior
            )
            cal.fit(case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim,
                    y_sim=case.y_sim)  # fmt: skip
            fits[label] = {
                "log_z": log_evidence(cal, case.prior),
                "samples": cal.theta_samples_[:, 0],
                "mean": cal.theta_mean_[0],
                "sd": float(np.sqrt(cal.theta_cov_[0, 0])),
                "reality": cal.predict_reality(X_test, return_std=True),
                "obs": cal.predict(X_test, return_std=True),
            }
    slab, spike = fits["slab"], fits["spike"]
    p_spike = float(special.expit(spike["log_z"] - slab["log_z"] + special.logit(pi0)))
    t = float(np.ravel(case.theta_true)[0])
    out = {"p_spike": p_spike}
    for label, weights in (("slab", (1.0, 0.0)), ("spike", (0.0, 1.0)),
                           ("mixed", (1.0 - p_spike, p_spike))):  # fmt: skip
        lo, hi = mixed_interval([slab["samples"], spike["samples"]], weights)
        mean, sd = mixed_normal(
            [slab["mean"], spike["mean"]], [slab["sd"], spike["sd"]], weights
        )
        out[label] = {"covered": lo <= t <= hi, "z": (mean - t) / sd}
        for what in ("reality", "obs"):
            m, s = mixed_normal(
                [slab[what][0], spike[what][0]],
                [slab[what][1], spike[what][1]],
                weights,
            )
            covered = (
                np.abs(truth - m) <= Z_LEVEL * s
                if what == "reality"
                else observation_coverage(m, s, truth, case.noise_sd)
            )
            out[label][what] = float(np.mean(covered))
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(
        prog="python -m validation.studies.spike_probe",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--cases", default="a1,b1,c1,c3,freq")
    parser.add_argument("--n-seeds", type=int, default=20)
    parser.add_argument("--n-jobs", type=int, default=1)
    parser.add_argument("--pi0", type=float, default=0.5, help="prior of the spike")
    args = parser.parse_args(argv)
    print(
        f"spike: sd_scale {SPIKE_SD_SCALE:g}; prior probability {args.pi0:g}; "
        f"{args.n_seeds} seeds per case"
    )
    print(
        f"{'case':6s} {'P(spike)':>9s}  {'':7s} {'covered':>8s} {'rms z':>6s} "
        f"{'reality':>8s} {'new obs':>8s}"
    )
    for name in args.cases.split(","):
        records = Parallel(n_jobs=args.n_jobs)(
            delayed(run_replicate)(name, seed, args.pi0) for seed in range(args.n_seeds)
        )
        p = np.median([r["p_spike"] for r in records])
        for label in ("slab", "spike", "mixed"):
            rows = [r[label] for r in records]
            z = np.array([r["z"] for r in rows])
            print(
                f"{name if label == 'slab' else '':6s} "
                f"{(f'{p:.3f}' if label == 'slab' else ''):>9s}  {label:7s} "
                f"{sum(r['covered'] for r in rows):>4d}/{len(rows):<3d} "
                f"{np.sqrt(np.mean(z**2)):6.2f} "
                f"{np.mean([r['reality'] for r in rows]):8.3f} "
                f"{np.mean([r['obs'] for r in rows]):8.3f}",
                flush=True,
            )


if __name__ == "__main__":
    main()
