"""Benchmark what a user gets from ``ModularBayesCalibrator(prior=...)``.

The thesis' section 4.7.3 set-up (the cantilever with two calibration
parameters E and I, two responses, 170 simulations, 70 observations), fitted
with the calibrator's defaults and nothing else: the propagated module 2 and
4 chains stopped at ``target_ess=2000`` (at most 5,000 draws after 1,000
burn-in steps). Per configuration, in a fresh Python process each (``--one``
runs one):

- ``cold``: the first ``fit`` of the process (imports and BLAS start-up
  included; the import time is printed on its own);
- ``warm``: a second ``fit`` of the same data in the same process;
- the draws kept per chain, the smallest bulk and tail ESS and the largest
  R-hat of the warm fit, and the ESS per second.

Configurations, defaults first: ``defaults``; ``full length``, the same with
``target_ess=None`` (always 5,000 draws: the default before the ESS target),
the reference of the ratio printed last. The machine's CPUs and BLAS thread
settings are printed first. Run with ``python benchmarks/bench_defaults.py``
(about 3 minutes on two cores).
"""

import argparse
import json
import os
import subprocess
import sys
import time
import warnings

CONFIGS = {
    "defaults": {},
    "full length": {"target_ess": None},
}


def _one(name):
    """Fit the configuration ``name`` twice in this (fresh) process; print
    one JSON line."""
    started = time.perf_counter()
    from skmba import ModularBayesCalibrator
    from skmba.datasets import make_cantilever
    from skmba.mcmc._diagnostics import ess_tail

    imports = time.perf_counter() - started
    data = make_cantilever(
        n_simulations=170, n_observations=70, parameters=("E", "I"), random_state=0
    )
    times = []
    for _ in range(2):
        cal = ModularBayesCalibrator(prior=data.prior, random_state=0, **CONFIGS[name])
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cal.fit(
                data.X_obs,
                data.y_obs,
                X_sim=data.X_sim,
                theta_sim=data.theta_sim,
                y_sim=data.y_sim,
            )
        times.append(time.perf_counter() - t0)
    chains = cal.theta_chains_
    tail = [ess_tail(chains[:, :, j]) for j in range(chains.shape[-1])]
    print(
        json.dumps(
            {
                "imports": imports,
                "cold": times[0] + imports,
                "warm": times[1],
                "draws": chains.shape[1],
                "ess": float(cal.ess_.min()),
                "tail": float(min(tail)),
                "rhat": float(cal.rhat_.max()),
            }
        )
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--one", choices=list(CONFIGS), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        _one(args.one)
        return
    threads = {
        k: os.environ.get(k) for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")
    }
    print(f"CPUs: {os.cpu_count()}; BLAS threads from the environment: {threads}")
    results = {}
    for name in CONFIGS:
        run = subprocess.run(
            [sys.executable, __file__, "--one", name],
            capture_output=True,
            text=True,
            check=True,
        )
        r = results[name] = json.loads(run.stdout.strip().splitlines()[-1])
        print(
            f"{name}: cold {r['cold']:.1f} s (imports {r['imports']:.1f} s), warm "
            f"{r['warm']:.1f} s; {r['draws']} draws per chain, smallest bulk ESS "
            f"{r['ess']:.0f}, tail ESS {r['tail']:.0f}, largest R-hat "
            f"{r['rhat']:.4f}; {r['ess'] / r['warm']:.0f} ESS/s",
            flush=True,
        )
    d, f = results["defaults"], results["full length"]
    print(
        f"defaults / full length: cold {d['cold'] / f['cold']:.2f}, warm "
        f"{d['warm'] / f['warm']:.2f}"
    )


if __name__ == "__main__":
    main()
