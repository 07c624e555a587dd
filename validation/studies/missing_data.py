"""Field data with gaps: readings removed at random, the calibration with the rest.

For each seed of a case of the validity suite
(:func:`validation.suite.registry`) the calibrator is fitted twice with
the defaults: on the complete field data, and with a share of the entries
of ``y`` (``--fraction``, 10 % by default) set to NaN at random, never a
whole response. Printed per case:

* how often the gapped posterior mean of each parameter lies inside the
  complete data's 95 % interval (the gaps cost information, they must not
  move theta), and the ratio of the posterior sds (gapped over complete);
* the coverage of the removed readings by the gapped fit's 95 %
  predictive intervals of a new measurement (``predict(return_std=True)``
  at the rows of the removed entries), with a Wilson interval, and the rms
  z-score of the removed readings (1 is calibrated).

Usage::

    python -m validation.studies.missing_data --cases a1,b1 --n-seeds 40 --n-jobs 2

``tests/validation/test_missing_data.py`` runs a fixed-seed subset; the
results are in ``docs/monitoring_data.rst``.
"""

import argparse
import time
import warnings

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed

from skmba import ModularBayesCalibrator
from validation.statistics import LEVEL, Z_LEVEL, rms, wilson_interval
from validation.suite import registry

FRACTION = 0.1


def with_gaps(y, fraction, rng):
    """``y`` with ``round(fraction * y.size)`` entries set to NaN at random,
    never every entry of a response; returns it and the boolean mask."""
    y = np.array(y, dtype=float).reshape(len(y), -1)
    n, q = y.shape
    while True:
        flat = rng.choice(n * q, size=round(fraction * n * q), replace=False)
        mask = np.zeros(n * q, dtype=bool)
        mask[flat] = True
        mask = mask.reshape(n, q)
        if not mask.all(axis=0).any():
            break
    gapped = y.copy()
    gapped[mask] = np.nan
    return gapped, mask


def _fit(case, y, seed):
    cal = ModularBayesCalibrator(prior=case.prior, random_state=seed, n_jobs=1)
    return cal.fit(
        case.X, y, X_sim=case.X_sim, theta_sim=case.theta_sim, y_sim=case.y_sim
    )


def run_replicate(name, seed, fraction=FRACTION):
    """Fit one seed of case ``name`` complete and with gaps; the scores."""
    case = registry()[name].build(seed)
    y = np.asarray(case.y, dtype=float).reshape(len(case.X), -1)
    rng = np.random.default_rng([int(seed), 2027])
    gapped, mask = with_gaps(y, fraction, rng)
    started = time.perf_counter()
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        full = _fit(case, y, seed)
        part = _fit(case, gapped, seed)
    lo, hi = np.quantile(full.theta_samples_, [(1 - LEVEL) / 2, (1 + LEVEL) / 2], 0)
    rows = np.flatnonzero(mask.any(axis=1))
    mean, std = part.predict(case.X[rows], return_std=True)
    mean, std = mean.reshape(len(rows), -1), std.reshape(len(rows), -1)
    held = mask[rows]
    z = (y[rows][held] - mean[held]) / std[held]
    return {
        "case": name,
        "seed": int(seed),
        "n_removed": int(mask.sum()),
        "inside": (lo <= part.theta_mean_) & (part.theta_mean_ <= hi),
        "sd_ratio": np.sqrt(np.diag(part.theta_cov_) / np.diag(full.theta_cov_)),
        "z": z,
        "seconds": time.perf_counter() - started,
    }


def summarise(records):
    """Per case: theta inside the complete interval, sd ratio, coverage."""
    out = {}
    for name in dict.fromkeys(r["case"] for r in records):
        recs = [r for r in records if r["case"] == name]
        inside = np.array([r["inside"] for r in recs])
        ratio = np.array([r["sd_ratio"] for r in recs])
        z = np.concatenate([r["z"] for r in recs])
        covered = int(np.sum(np.abs(z) <= Z_LEVEL))
        out[name] = {
            "seeds": len(recs),
            "inside": inside.sum(axis=0),
            "sd_ratio_median": np.median(ratio, axis=0),
            "sd_ratio_max": ratio.max(axis=0),
            "n_removed": len(z),
            "covered": covered,
            "wilson": wilson_interval(covered, len(z)),
            "rms_z": float(rms(z)),
        }
    return out


def format_table(summary):
    lines = [
        "case  seeds  theta inside complete 95%  sd ratio median (max)  "
        "removed readings covered  Wilson         rms z"
    ]
    for name, s in summary.items():
        inside = ",".join(f"{k}/{s['seeds']}" for k in s["inside"])
        ratio = ",".join(
            f"{m:.2f} ({x:.2f})"
            for m, x in zip(s["sd_ratio_median"], s["sd_ratio_max"], strict=True)
        )
        lo, hi = s["wilson"]
        share = s["covered"] / s["n_removed"]
        lines.append(
            f"{name:5s} {s['seeds']:5d}  {inside:26s} {ratio:22s} "
            f"{s['covered']:4d}/{s['n_removed']:<4d} = {share:.3f}"
            f"    [{lo:.3f},{hi:.3f}]  {s['rms_z']:.2f}"
        )
    return "\n".join(lines)


def run(names, n_seeds, n_jobs=1, fraction=FRACTION):
    tasks = [(name, seed) for name in names for seed in range(n_seeds)]
    records = Parallel(n_jobs=n_jobs, batch_size=1)(
        delayed(run_replicate)(name, seed, fraction) for name, seed in tasks
    )
    return records


def main(argv=None):
    parser = argparse.ArgumentParser(
        prog="python -m validation.studies.missing_data",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--cases", default="a1,b1", help="comma list of cases")
    parser.add_argument("--n-seeds", type=int, default=20, help="seeds per case")
    parser.add_argument("--n-jobs", type=int, default=1, help="parallel replicates")
    parser.add_argument(
        "--fraction", type=float, default=FRACTION, help="share of entries removed"
    )
    args = parser.parse_args(argv)
    names = [c.strip() for c in args.cases.split(",") if c.strip()]
    started = time.perf_counter()
    records = run(names, args.n_seeds, args.n_jobs, args.fraction)
    print(format_table(summarise(records)))
    print(f"({time.perf_counter() - started:.0f} s, {args.n_jobs} job(s))")
    return records


if __name__ == "__main__":
    main()
