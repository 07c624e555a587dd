"""Benchmark how the sensor designer's cost grows with the field design size.

``PreposteriorDesigner(prior, n_design=n, n_mc=20, n_jobs=2)`` with its
defaults otherwise (the calibrator's defaults, ``discrepancy_uncertainty=
"plug-in"``, ``fast=True``), exhaustive over the 511 subsets of the nine
strain gauges SA-SI of the truss bridge (``make_truss_bridge(30, ...)``,
thesis section 6.4), for ``n`` = 12, 30 and 60 design points (``--n-design``).

Per size, in a fresh Python process each:

- ``cold``: the first ``fit`` of the process (imports, the joblib workers'
  start-up and the first calls' caches included);
- ``warm``: a second ``fit`` of the same data in the same process;
- the warm fit's split, read from its ``verbose=1`` lines: step 1 (emulator
  and prior-integrated emulator), phase 1 (one module-2 fit per replicate,
  on ``n q`` field values: its likelihood factors an ``n q x n q``
  covariance) and phase 2 (the posterior of theta for every subset and
  replicate, along the prefix tree of the subsets);
- the best subset.

Last, each size's times over the smallest size's, beside the ratio of the
design sizes: a cost that grows no faster than the number of design points
has a time ratio at most the size ratio. Run with ``python
benchmarks/bench_design_scaling.py`` (about 8 minutes on two cores).
"""

import argparse
import io
import json
import re
import subprocess
import sys
import time
import warnings
from contextlib import redirect_stderr

try:  # run as a script (python benchmarks/bench_x.py) or as a module
    from _machine import machine_report
except ImportError:
    from benchmarks._machine import machine_report

GAUGES = ["SA", "SB", "SC", "SD", "SE", "SF", "SG", "SH", "SI"]
#: The designer's ``verbose=1`` lines that end a step, and the step's name.
STEPS = {"step 1": "step 1", "phase 1": "phase 1", "done": "total"}


def _split(lines):
    """Seconds of each step from the designer's ``verbose=1`` lines."""
    out = {}
    for line in lines.splitlines():
        for start, name in STEPS.items():
            match = re.search(rf"\] {start}\b.*\(([0-9.]+) s\)\s*$", line)
            if match:
                out[name] = float(match.group(1))
    out["phase 2"] = out["total"] - out["step 1"] - out["phase 1"]
    return out


def _one(n_design, n_mc, n_jobs):
    """Fit the designer twice in this (fresh) process; print one JSON line."""
    started = time.perf_counter()
    import numpy as np

    from skmba import PreposteriorDesigner
    from skmba.datasets import make_truss_bridge

    data = make_truss_bridge(30, sensors=GAUGES, random_state=0)
    X = np.hstack([data.X_sim, data.theta_sim])
    imports = time.perf_counter() - started
    times, log = [], io.StringIO()
    for verbose in (0, 1):
        designer = PreposteriorDesigner(
            data.prior,
            n_design=n_design,
            n_mc=n_mc,
            n_jobs=n_jobs,
            random_state=0,
            verbose=verbose,
        )
        t0 = time.perf_counter()
        with warnings.catch_warnings(), redirect_stderr(log):
            warnings.simplefilter("ignore")
            designer.fit(X, data.y_sim)
        times.append(time.perf_counter() - t0)
    out = {"cold": times[0] + imports, "warm": times[1], **_split(log.getvalue())}
    out["best"] = [GAUGES[k] for k in designer.best_subset_]
    out["scores"] = designer.scores_.tolist()
    print(json.dumps(out))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--n-design", default="12,30,60")
    parser.add_argument("--n-mc", type=int, default=20)
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--one", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one is not None:
        _one(args.one, args.n_mc, args.n_jobs)
        return
    sizes = [int(n) for n in args.n_design.split(",")]
    print(machine_report())
    print(f"n_jobs={args.n_jobs}")
    print(f"exhaustive FPA, 9 gauges, 511 subsets x {args.n_mc} replicates, defaults")
    header = "n_design   cold s   warm s   step 1   phase 1   phase 2   best subset"
    print(header)
    results = {}
    for n in sizes:
        command = [sys.executable, __file__, "--one", str(n)]
        command += ["--n-mc", str(args.n_mc), "--n-jobs", str(args.n_jobs)]
        done = subprocess.run(command, capture_output=True, text=True, check=True)
        r = results[n] = json.loads(done.stdout.strip().splitlines()[-1])
        print(
            f"{n:8d} {r['cold']:8.1f} {r['warm']:8.1f} {r['step 1']:8.1f} "
            f"{r['phase 1']:9.1f} {r['phase 2']:9.1f}   {'+'.join(r['best'])}"
        )
    base = sizes[0]
    print(f"\nratios to n_design={base} (a cost linear in n_design: the size ratio)")
    print("n_design   size   cold   warm   phase 1   phase 2")
    for n in sizes[1:]:
        r, b = results[n], results[base]
        print(
            f"{n:8d} {n / base:6.1f} {r['cold'] / b['cold']:6.1f} "
            f"{r['warm'] / b['warm']:6.1f} {r['phase 1'] / b['phase 1']:9.1f} "
            f"{r['phase 2'] / b['phase 2']:9.1f}"
        )


if __name__ == "__main__":
    main()
