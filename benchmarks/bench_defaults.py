"""Benchmark what a user gets from ``ModularBayesCalibrator(prior=...)``.

Two set-ups, each fitted with the calibrator's defaults and nothing else
first, then with a reference configuration:

- **two parameters** (the thesis' section 4.7.3: the cantilever with E
  and I, two responses, 170 simulations, 70 observations): the propagated
  module 2 and 4 chains stopped at ``target_ess=2000`` (at most 5,000
  draws after 1,000 burn-in steps); reference ``full length``, the same
  with ``target_ess=None`` (always 5,000 draws: the default before the
  ESS target);
- **one parameter** (the quick start's data, ``make_cantilever(random_state=0)``:
  E, 30 simulations, 10 observations): quadrature over theta and the
  discrepancy's hyperparameters integrated to ``discrepancy_tol="auto"``
  (Monte Carlo errors of theta's mean and sd below 0.05 posterior sds);
  reference ``16 draws``, ``discrepancy_tol=None`` (module 2's 16 draws,
  the default before, whose sd moved with ``random_state``).

Per configuration, in a fresh Python process each (``--one`` runs one):

- ``cold``: the first ``fit`` of the process (imports and BLAS start-up
  included; the import time is printed on its own);
- ``warm``: a second ``fit`` of the same data in the same process;
- MCMC: the draws kept per chain, the smallest bulk and tail ESS and the
  largest R-hat of the warm fit, and the ESS per second; quadrature: the
  module-2 draws and the largest Monte Carlo error of theta's mean and sd
  in posterior sds (NaN when it is not estimated).

The machine's CPUs and BLAS thread settings are printed first, each
reference's ratio last. Run with ``python benchmarks/bench_defaults.py``
(about 3 minutes on two cores).
"""

import argparse
import json
import math
import os
import subprocess
import sys
import time
import warnings

TWO, ONE = "two parameters", "one parameter"
#: name: (set-up, calibrator parameters); each set-up's defaults first.
CONFIGS = {
    "defaults": (TWO, {}),
    "full length": (TWO, {"target_ess": None}),
    "defaults, one parameter": (ONE, {}),
    "16 draws": (ONE, {"discrepancy_tol": None}),
}
#: The ratios printed: (configuration, its reference).
RATIOS = (("defaults", "full length"), ("defaults, one parameter", "16 draws"))


def _data(setup):
    from skmba.datasets import make_cantilever

    if setup == ONE:
        return make_cantilever(random_state=0)
    return make_cantilever(
        n_simulations=170, n_observations=70, parameters=("E", "I"), random_state=0
    )


def _figures(cal):
    """What the warm fit reached: MCMC diagnostics or quadrature errors."""
    from skmba.mcmc._diagnostics import ess_tail

    chains = getattr(cal, "theta_chains_", None)
    if chains is None:
        sd = math.sqrt(cal.theta_cov_[0, 0])
        return {
            "draws": cal.discrepancy_draws_,
            "mcse": float(cal.theta_mcse_[:2, 0].max()) / sd,
        }
    tail = [ess_tail(chains[:, :, j]) for j in range(chains.shape[-1])]
    return {
        "draws": chains.shape[1],
        "ess": float(cal.ess_.min()),
        "tail": float(min(tail)),
        "rhat": float(cal.rhat_.max()),
    }


def _one(name):
    """Fit the configuration ``name`` twice in this (fresh) process; print
    one JSON line."""
    started = time.perf_counter()
    from skmba import ModularBayesCalibrator

    imports = time.perf_counter() - started
    setup, params = CONFIGS[name]
    data = _data(setup)
    times = []
    for _ in range(2):
        cal = ModularBayesCalibrator(prior=data.prior, random_state=0, **params)
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
    out = {"imports": imports, "cold": times[0] + imports, "warm": times[1]}
    print(json.dumps({**out, **_figures(cal)}))


def _line(name, r):
    head = (
        f"{name}: cold {r['cold']:.1f} s (imports {r['imports']:.1f} s), warm "
        f"{r['warm']:.1f} s; "
    )
    if "ess" in r:
        return head + (
            f"{r['draws']} draws per chain, smallest bulk ESS {r['ess']:.0f}, "
            f"tail ESS {r['tail']:.0f}, largest R-hat {r['rhat']:.4f}; "
            f"{r['ess'] / r['warm']:.0f} ESS/s"
        )
    return head + (
        f"{r['draws']} module-2 draws, Monte Carlo error of theta's mean and sd "
        f"at most {r['mcse']:.3f} posterior sds"
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
        results[name] = json.loads(run.stdout.strip().splitlines()[-1])
        print(_line(name, results[name]), flush=True)
    for name, reference in RATIOS:
        d, f = results[name], results[reference]
        print(
            f"{name} / {reference}: cold {d['cold'] / f['cold']:.2f}, warm "
            f"{d['warm'] / f['warm']:.2f}"
        )


if __name__ == "__main__":
    main()
