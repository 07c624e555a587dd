"""Benchmark a year of monitoring: the first fit and a daily ``partial_fit``.

The data set is :func:`skmba.datasets.make_bridge_monitoring` with its
defaults: 8,760 hourly readings of 4 natural frequencies (5 % missing),
the temperature logged to 0.1 degC (434 distinct values), 60 simulations,
two calibration parameters (E and the bearing stiffness). Per
configuration, in a fresh Python process each (``--one`` runs one):

- ``first fit (cold)``: ``fit`` on the first 364 days, the first call of
  the process (imports, joblib's workers and BLAS start-up included);
- ``daily update``: then ``partial_fit`` of the last day's 24 readings
  (module 1 kept, modules 2-3 warm-started; module 3 by chains or by
  reweighting the first fit's draws, printed);
- ``first fit (warm)``: ``fit`` on the 364 days again in the same process
  (skipped with ``--skip-warm``);
- the peak resident memory of the process (``ru_maxrss``), the distinct
  inputs after binning, the bulk ESS and R-hat of the update.

Configurations, defaults first: the calibrator's defaults with ``bin_width``
1 degC (the readings' exact means need 434 x 4 values: ``fit`` warns of
hours, printed here from that warning's estimate); the same with 2 degC
bins; the thesis' plug-in module 2 with 1 degC bins; and 2 degC bins with
chains of 1,000 draws after 300 (``MONITORING``). Each line ends with the
update's time over the cold first fit's, the ratio a daily update saves.

Run with ``python benchmarks/bench_monitoring.py`` (about 8 minutes on two
cores); ``--only NAME`` runs one configuration.

``--updates LAST`` times a season of daily updates instead, in one process
(the way a monitoring system runs them): the defaults with 2 degC bins fit
January, then ``partial_fit`` adds each day from February 1st (day 32) to
day ``LAST`` of the year, one call per day; it prints each day that ran
chains (its time, draws per chain, ESS and the Kish share that refused the
reweighting) and the reweighted days' median and largest time.
``--n-jobs`` sets the calibrator's (joblib's workers start with the
January fit, so that the days time warm workers).
"""

import argparse
import json
import resource
import subprocess
import sys
import time
import warnings

import numpy as np

try:  # run as a script (python benchmarks/bench_x.py) or as a module
    from _machine import machine_report
except ImportError:
    from benchmarks._machine import machine_report

CONFIGS = {
    "defaults, bin_width=1": {"bin_width": 1.0},
    "defaults, bin_width=2": {"bin_width": 2.0},
    "plug-in, bin_width=1": {"bin_width": 1.0, "discrepancy_uncertainty": "plug-in"},
    "MONITORING: bin_width=2, 1000 draws after 300": {
        "bin_width": 2.0,
        "n_samples": 1000,
        "burn_in": 300,
    },
}


def _one(name, skip_warm):
    """Run one configuration in this (fresh) process; print a JSON line."""
    started = time.perf_counter()
    from skmba import ModularBayesCalibrator
    from skmba.datasets import make_bridge_monitoring

    data = make_bridge_monitoring(random_state=0)
    X = data.frame[["temperature"]]
    Y = data.frame[list(data.response_names)]
    sims = dict(X_sim=data.X_sim, theta_sim=data.theta_sim, y_sim=data.y_sim)
    year, day = slice(0, 8760 - 24), slice(8760 - 24, 8760)
    out = {"imports": time.perf_counter() - started}

    def calibrator():
        return ModularBayesCalibrator(prior=data.prior, random_state=0, **CONFIGS[name])

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # identifiability: said in the docs
        cal = calibrator()
        t = time.perf_counter()
        cal.partial_fit(X[year], Y[year], **sims)
        out["cold"] = time.perf_counter() - t
        t = time.perf_counter()
        cal.partial_fit(X[day], Y[day])
        out["update"] = time.perf_counter() - t
        out["means"] = int(cal.theta_history_["n_means"].iloc[-1])
        out["module3"] = "chains" if hasattr(cal, "theta_chains_") else "reweighted"
        out["ess"] = np.asarray(getattr(cal, "ess_", [np.nan])).tolist()
        out["rhat"] = np.asarray(getattr(cal, "rhat_", [np.nan])).tolist()
        out["theta_sd"] = np.sqrt(np.diag(cal.theta_cov_)).tolist()
        if not skip_warm:
            t = time.perf_counter()
            calibrator().fit(X[year], Y[year], **sims)
            out["warm"] = time.perf_counter() - t
    out["peak_gib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    print(json.dumps(out))


def _updates(last, n_jobs):
    """January, then one ``partial_fit`` per day up to day ``last``."""
    import skmba.calibration._module3_update as update
    from skmba import ModularBayesCalibrator
    from skmba.datasets import make_bridge_monitoring

    shares, weighted = [], update.weighted

    def recorded(anchor, log_density, random_state=None):
        posterior, share = weighted(anchor, log_density, random_state)
        shares.append(share)
        return posterior, share

    update.weighted = recorded
    data = make_bridge_monitoring(random_state=0)
    X = data.frame[["temperature"]]
    Y = data.frame[list(data.response_names)]
    day = data.frame.index.day_of_year
    cal = ModularBayesCalibrator(
        prior=data.prior, bin_width=2.0, random_state=0, n_jobs=n_jobs
    )
    times = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # identifiability: said in the docs
        t = time.perf_counter()
        cal.partial_fit(
            X[day <= 31],
            Y[day <= 31],
            X_sim=data.X_sim,
            theta_sim=data.theta_sim,
            y_sim=data.y_sim,
        )
        print(f"January: {time.perf_counter() - t:.1f} s", flush=True)
        for d in range(32, last + 1):
            shares.clear()
            t = time.perf_counter()
            cal.partial_fit(X[day == d], Y[day == d])
            seconds = time.perf_counter() - t
            if hasattr(cal, "theta_chains_"):
                print(
                    f"day {d}: chains, {seconds:.1f} s, "
                    f"{cal.theta_chains_.shape[1]} draws per chain, ESS "
                    f"{np.round(cal.ess_)}, Kish share of the refused "
                    f"reweighting {shares[0]:.3f}",
                    flush=True,
                )
            else:
                times.append(seconds)
    print(
        f"{len(times)} of {last - 31} days reweighted: median {np.median(times):.2f}"
        f" s, largest {np.max(times):.2f} s (n_jobs={n_jobs})"
    )


def _exact_estimate():
    """``fit``'s own warning for the readings' exact means (no bins)."""
    from skmba import ModularBayesCalibrator
    from skmba.calibration._fit_setup import warn_field_size
    from skmba.calibration._settings import CalibrationSettings
    from skmba.datasets import make_bridge_monitoring

    data = make_bridge_monitoring(random_state=0)
    X = data.X_obs[:, 0]
    values = sum(len(np.unique(X[np.isfinite(data.y_obs[:, k])])) for k in range(4))
    settings = CalibrationSettings.from_params(ModularBayesCalibrator().get_params())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warn_field_size(values, len(X), settings)
    return values, str(caught[0].message) if caught else ""


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--one", help=argparse.SUPPRESS)
    parser.add_argument("--only", choices=list(CONFIGS))
    parser.add_argument("--skip-warm", action="store_true")
    parser.add_argument("--updates", type=int, metavar="LAST")
    parser.add_argument("--n-jobs", type=int, default=None)
    args = parser.parse_args()
    if args.one:
        _one(args.one, args.skip_warm)
        return
    print(machine_report(), flush=True)
    if args.updates:
        _updates(args.updates, args.n_jobs)
        return
    values, message = _exact_estimate()
    print(f"exact means (no bins): {values} values; fit says: {message[:200]}...")
    for name in [args.only] if args.only else CONFIGS:
        cmd = [sys.executable, __file__, "--one", name]
        if args.skip_warm:
            cmd.append("--skip-warm")
        run = subprocess.run(cmd, capture_output=True, text=True, check=True)
        r = json.loads(run.stdout.strip().splitlines()[-1])
        warm = f"{r['warm']:.1f} s" if "warm" in r else "skipped"
        print(
            f"{name}: {r['means']} distinct inputs; first fit cold {r['cold']:.1f} s "
            f"(imports {r['imports']:.1f} s), warm {warm}; daily update "
            f"{r['update']:.1f} s ({r['module3']}, ESS {np.round(r['ess'])}, R-hat "
            f"{np.round(r['rhat'], 3)}); peak {r['peak_gib']:.2f} GiB; "
            f"update / cold fit {r['update'] / r['cold']:.2f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
