"""The integral over the discrepancy hyperparameters to ``discrepancy_tol``.

Two measurements of the calibrator with ``discrepancy_tol`` set (issue 30):

- ``--refits N``: per case, the seed-0 data refitted with ``random_state``
  0..N-1: the spread of theta's posterior mean, sd and 95 % interval ends
  over the refits (coefficient of variation of the sd, largest distance of
  each end from its mean in posterior sds), against the Monte Carlo errors
  the fits report (``theta_mcse_``, and the rms z of each refit's deviation
  from the refits' mean over its own reported error, scaled by
  ``sqrt(N / (N - 1))``), the draws and the time;
- ``--reference``: each (case, seed, parameter) row of
  ``validation/results/joint_reference/joint_reference.csv`` (``--reference-csv``
  for another) fitted with
  ``random_state=seed`` (the reference's emulator): its posterior sd and
  mean against the joint-MCMC reference's.

``--tol none`` measures module 2's fixed draws instead (the default with
several parameters), ``--hyper-draws K`` their number (16 unless set; a
power of two); with ``--refits``, a case and seed found in
``--reference-csv`` also print the refits' sds over the reference's.

Usage::

    python -m validation.studies.converged_integral --cases a1,c1,c3,freq \\
        --refits 6 --tol 0.05 --n-jobs 2
    python -m validation.studies.converged_integral --reference --tol 0.05 --n-jobs 2
    python -m validation.studies.converged_integral --cases a2 --refits 4 \\
        --tol none --hyper-draws 64 --n-jobs 2 \\
        --reference-csv validation/results/jref_a2_field_prior/joint_reference.csv

Quoted in ``docs/validity.rst`` ("The same data, the same interval").
"""

from __future__ import annotations

import argparse
import csv
import time
import warnings
from pathlib import Path

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed

import skmba.calibration._module2_posterior as module2_posterior
from skmba import ModularBayesCalibrator
from skmba.calibration._module2_converged_nodes import weighted_quantiles
from validation.suite import registry

REFERENCE = (
    Path(__file__).resolve().parents[1]
    / "results"
    / "joint_reference"
    / "joint_reference.csv"
)


def fit_summary(name, seed, random_state, tol, hyper_draws=None):
    """One fit: mean, sd, 95 % ends, their reported errors, draws, seconds.
    ``hyper_draws`` sets module 2's number of fixed draws for this fit."""
    defaults = module2_posterior.fit_hyperposterior.__kwdefaults__
    saved = defaults["n_draws"]
    if hyper_draws is not None:
        defaults["n_draws"] = hyper_draws
    try:
        return _fit_summary(name, seed, random_state, tol)
    finally:
        defaults["n_draws"] = saved


def _fit_summary(name, seed, random_state, tol):
    case = registry()[name].build(seed)
    started = time.perf_counter()
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = ModularBayesCalibrator(
            prior=case.prior, random_state=random_state, n_jobs=1, discrepancy_tol=tol
        ).fit(
            case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim, y_sim=case.y_sim
        )
    ends = np.quantile(cal.theta_samples_, [0.025, 0.975], axis=0)
    if (
        getattr(cal, "theta_weights_", None) is not None
        and cal.theta_nodes_.shape[1] > 1
    ):
        # several parameters: the weighted nodes' own quantiles, not those
        # of the resampled draws (which add resampling noise)
        ends = np.array(
            [
                weighted_quantiles(t, cal.theta_weights_, (0.025, 0.975))
                for t in cal.theta_nodes_.T
            ]
        ).T
    sd = np.sqrt(np.diag(cal.theta_cov_))
    mcse = getattr(cal, "theta_mcse_", None)  # None: module 2's fixed draws
    return {
        "values": np.vstack([cal.theta_mean_, sd, ends]),  # (4, r)
        "mcse": np.full((4, len(sd)), np.nan) if mcse is None else mcse,
        "draws": cal.discrepancy_draws_,
        "seconds": time.perf_counter() - started,
    }


def refit_row(name, fits, j=0, reference_sd=None):
    """The spread over refits of one case's data, in its posterior sds, for
    parameter ``j``; with ``reference_sd``, each refit's sd over it."""
    values = np.array([f["values"][:, j] for f in fits])
    against = (
        ""
        if reference_sd is None
        else "  sd / reference "
        + np.array2string(values[:, 1] / reference_sd, precision=2)
    )
    sd = values[:, 1].mean()
    deviation = np.abs(values - values.mean(axis=0)).max(axis=0) / sd
    mcse = np.array([f["mcse"][:, j] for f in fits])
    reported = mcse.mean(axis=0) / sd
    # each refit's deviation from the refits' mean over its reported error
    n = len(fits)
    z = (values - values.mean(axis=0)) / mcse * np.sqrt(n / max(n - 1, 1))
    rms_z = np.sqrt(np.mean(z**2, axis=0))
    seconds = [f["seconds"] for f in fits]
    label = name if fits[0]["values"].shape[1] == 1 else f"{name}[{j}]"
    return (
        f"{label:8s} sd {sd:.5g}  CV of sd {values[:, 1].std(ddof=1) / sd:.3f}  "
        f"mean spread {values[:, 0].std(ddof=1) / sd:.3f} sd  ends max dev. "
        f"{deviation[2]:.2f}, {deviation[3]:.2f} sd  reported se (mean, sd, ends) "
        f"{np.array2string(reported, precision=3)}  its rms z "
        f"{np.array2string(rms_z, precision=2)}  draws "
        f"{np.mean([f['draws'] for f in fits]):.0f}  time "
        f"{min(seconds):.0f}-{max(seconds):.0f} s{against}"
    )


def reference_rows(path=REFERENCE):
    """The (case, seed, parameter index, reference mean, sd, its error,
    16-draw ratio) rows of a joint reference's table."""
    with open(path) as handle:
        rows = csv.DictReader(line for line in handle if not line.startswith("#"))
        return [
            (
                r["case"],
                int(r["seed"]),
                registry()[r["case"]].parameter_names.index(r["parameter"]),
                float(r["reference_mean"]),
                float(r["reference_sd"]),
                float(r["reference_sd_mcse"]),
                float(r["sd_ratio"]),
            )
            for r in rows
        ]


def reference_row(row, fit):
    """One fit against the joint reference."""
    name, seed, j, mean, sd, mcse, default = row
    ratio = fit["values"][1, j] / sd
    return (
        f"{name:8s} {seed} [{j}]  sd ratio {ratio:.3f} (reference's error "
        f"{mcse / sd:.3f}, reported error {fit['mcse'][1, j] / sd:.3f}; 16 draws "
        f"{default:.3f})  |dmean| {abs(fit['values'][0, j] - mean) / sd:.3f} sd  "
        f"draws {fit['draws']}  {fit['seconds']:.0f} s"
    )


def _parser():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default="a1,c1,c3,freq")
    parser.add_argument("--refits", type=int, default=6)
    parser.add_argument("--reference", action="store_true")
    parser.add_argument(
        "--only", action="store_true", help="with --reference: only --cases"
    )
    parser.add_argument("--reference-csv", type=Path, default=REFERENCE)
    parser.add_argument(
        "--tol",
        type=lambda v: None if v == "none" else float(v),
        default=0.05,
        help="discrepancy_tol, or none (module 2's fixed draws)",
    )
    parser.add_argument("--hyper-draws", type=int, default=None)
    parser.add_argument("--n-jobs", type=int, default=1)
    return parser


def main(argv=None):
    args = _parser().parse_args(argv)
    run = Parallel(n_jobs=args.n_jobs)
    if args.reference:
        cases = args.cases.split(",") if args.only else None
        rows = [
            r
            for r in reference_rows(args.reference_csv)
            if cases is None or r[0] in cases
        ]
        fits = run(delayed(fit_summary)(r[0], r[1], r[1], args.tol) for r in rows)
        for row, fit in zip(rows, fits, strict=True):
            print(reference_row(row, fit))
        return
    names = args.cases.split(",")
    tasks = [(n, k) for n in names for k in range(args.refits)]
    fits = run(
        delayed(fit_summary)(n, 0, k, args.tol, args.hyper_draws) for n, k in tasks
    )
    references = (
        {(r[0], r[2]): r[4] for r in reference_rows(args.reference_csv) if r[1] == 0}
        if args.reference_csv.exists()
        else {}
    )
    for name in names:
        pairs = zip(tasks, fits, strict=True)
        mine = [f for (n, _), f in pairs if n == name]
        for j in range(mine[0]["values"].shape[1]):
            print(refit_row(name, mine, j, references.get((name, j))))


if __name__ == "__main__":
    main()
