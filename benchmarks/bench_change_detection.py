"""Benchmark ChangeDetector: the reference fit and one batch's decision.

The reference is a year of :func:`skmba.datasets.make_bridge_monitoring`
(8,760 hourly readings of 4 frequencies), calibrated with the thesis'
plug-in module 2 and 1 degC bins; the batches are weeks (168 readings x 4
frequencies) and months (730) of another year of the same bridge. Per
configuration, in a fresh Python process each (``--only NAME`` runs one):

- ``fit``: the reference calibration, the first call of the process;
- ``first week``: the first decision (``predict``) after it, then the mean
  of the next 10 weeks' (warm) and of 3 months';
- the data-driven baseline of ``validation.studies.change_detection``
  (spline regression on the temperature, ``MinCovDet`` Mahalanobis
  distance) on the same weeks, in the same process: the ratio of the
  detector's warm week to it ends each line.

Configurations, defaults first: the detector's defaults (batches at their
exact distinct temperatures, the emulator moves the prediction); 0.5 degC
batch bins; 0.5 degC bins and the finite element model as ``simulator``;
the validation study's (a Matern 3/2 discrepancy and 0.5 degC bins in the
reference, 0.2 degC batch bins, the simulator).

Run with ``python benchmarks/bench_change_detection.py`` (about 5 minutes
on two cores).
"""

import argparse
import json
import os
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
    "defaults": {},
    "bin_width=0.5": {"bin_width": 0.5},
    "bin_width=0.5, simulator": {"bin_width": 0.5, "simulator": True},
    # The validation study's: a Matern 3/2 discrepancy and 0.5 degC bins in
    # the reference, 0.2 degC batch bins, the simulator.
    "study": {"bin_width": 0.2, "simulator": True, "study_reference": True},
}
WEEK, MONTH = 168, 730


def _one(name):
    """Run one configuration in this (fresh) process; print a JSON line."""
    from skmba import ChangeDetector, ModularBayesCalibrator
    from skmba.datasets import make_bridge_monitoring
    from validation.studies.change_detection import Baseline

    ref = make_bridge_monitoring(random_state=0)
    other = make_bridge_monitoring(random_state=1)
    params = dict(CONFIGS[name])
    if params.pop("simulator", False):
        params["simulator"] = ref.simulator
    reference = {"bin_width": 1.0}
    if params.pop("study_reference", False):
        from sklearn.gaussian_process.kernels import Matern

        reference = {"bin_width": 0.5, "discrepancy_kernel": Matern(nu=1.5)}
    cal = ModularBayesCalibrator(
        prior=ref.prior,
        discrepancy_uncertainty="plug-in",
        random_state=0,
        **reference,
    )
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # identifiability: said in the docs
        t = time.perf_counter()
        det = ChangeDetector(cal, **params).fit(
            ref.X_obs,
            ref.y_obs,
            X_sim=ref.X_sim,
            theta_sim=ref.theta_sim,
            y_sim=ref.y_sim,
        )
        out["fit"] = time.perf_counter() - t

    def timed(length, k):
        rows = slice(k * length, (k + 1) * length)
        t = time.perf_counter()
        det.predict(other.X_obs[rows], other.y_obs[rows])
        return time.perf_counter() - t

    out["first"] = timed(WEEK, 0)
    out["week"] = float(np.mean([timed(WEEK, k) for k in range(1, 11)]))
    out["month"] = float(np.mean([timed(MONTH, k) for k in range(1, 4)]))
    baseline = Baseline(0.05).fit(ref.X_obs, ref.y_obs)
    t = time.perf_counter()
    for k in range(1, 11):
        rows = slice(k * WEEK, (k + 1) * WEEK)
        baseline.score(other.X_obs[rows], other.y_obs[rows])
    out["baseline_week"] = (time.perf_counter() - t) / 10
    print(json.dumps(out))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--one", help=argparse.SUPPRESS)
    parser.add_argument("--only", choices=list(CONFIGS))
    args = parser.parse_args()
    if args.one:
        _one(args.one)
        return
    print(machine_report(), flush=True)
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = {**os.environ, "PYTHONPATH": root}
    for name in [args.only] if args.only else CONFIGS:
        cmd = [sys.executable, __file__, "--one", name]
        run = subprocess.run(cmd, capture_output=True, text=True, check=True, env=env)
        r = json.loads(run.stdout.strip().splitlines()[-1])
        print(
            f"{name}: reference fit {r['fit']:.1f} s; first week {r['first']:.2f} s, "
            f"warm week {r['week']:.2f} s, month {r['month']:.2f} s; baseline week "
            f"{r['baseline_week'] * 1e3:.1f} ms (detector / baseline "
            f"{r['week'] / r['baseline_week']:.0f}x)",
            flush=True,
        )


if __name__ == "__main__":
    main()
