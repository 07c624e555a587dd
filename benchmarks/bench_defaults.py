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

- **sensor design** (``PreposteriorDesigner(prior)`` with its defaults:
  the cantilever's five candidate responses, all 31 subsets, 54
  simulations, 25 design points, 100 replicates, serial); reference
  ``designer, n_jobs=2``.

Per configuration, in a fresh Python process each (``--one`` runs one):

- ``cold``: the first ``fit`` of the process (imports and BLAS start-up
  included; the import time is printed on its own);
- ``warm``: a second ``fit`` of the same data in the same process;
- MCMC: the draws kept per chain, the smallest bulk and tail ESS and the
  largest R-hat of the warm fit, and the ESS per second; quadrature: the
  module-2 draws and the largest Monte Carlo error of theta's mean and sd
  in posterior sds (NaN when it is not estimated); the designer: its best
  subset;
- for the two-parameter defaults, a third fit under ``cProfile``: the
  share of its time outside LAPACK and BLAS (:func:`_outside_blas`). The
  profiler charges a matrix product written ``A @ B`` to the Python
  function that wrote it, and adds its own cost per Python call, so the
  share is an upper bound;
- for the same configuration, when ``py-spy`` is installed (``pip install
  py-spy``; it is not a dependency), the same share sampled from native
  stacks in another fresh process (:func:`_native_shares`): of the samples
  of a cold and a warm fit in which a thread works (not waiting for work
  or for the GIL; imports left out), those inside OpenBLAS (BLAS and
  LAPACK), those in other native code (numpy's loops and copies, the
  wrappers, libc) and those in the Python interpreter.

The machine's CPUs and BLAS thread settings are printed first, each
reference's ratio and every first-to-warm ratio last (with the import
of skmba, and without it: the first ``fit`` call alone). Run with ``python
benchmarks/bench_defaults.py`` (about 6 minutes on two cores).
"""

import argparse
import cProfile
import json
import math
import os
import pstats
import shutil
import subprocess
import sys
import tempfile
import time
import warnings

try:  # run as a script (python benchmarks/bench_x.py) or as a module
    from _machine import machine_report
except ImportError:
    from benchmarks._machine import machine_report

TWO, ONE, DESIGN = "two parameters", "one parameter", "sensor design"
#: name: (set-up, estimator parameters); each set-up's defaults first.
CONFIGS = {
    "defaults": (TWO, {}),
    "full length": (TWO, {"target_ess": None}),
    "defaults, one parameter": (ONE, {}),
    "16 draws": (ONE, {"discrepancy_tol": None}),
    "designer defaults": (DESIGN, {}),
    "designer, n_jobs=2": (DESIGN, {"n_jobs": 2}),
}
#: The ratios printed: (configuration, its reference).
RATIOS = (
    ("defaults", "full length"),
    ("defaults, one parameter", "16 draws"),
    ("designer defaults", "designer, n_jobs=2"),
)
#: The configurations fitted a third time under the profiler.
PROFILED = ("defaults",)
#: The cantilever's five candidate responses (the designer's set-up).
RESPONSES = (
    "tip_displacement",
    "energy",
    "tip_rotation",
    "mid_displacement",
    "quarter_displacement",
)
#: Where LAPACK and BLAS work is called from: numpy's and scipy's linear
#: algebra modules, and numpy's product built-ins.
LINALG_FILES = ("numpy/linalg/", "scipy/linalg/")
PRODUCTS = ("einsum", "matmul", "dot", "inner", "vdot", "tensordot")


def _data(setup):
    from skmba.datasets import make_cantilever

    if setup == ONE:
        return make_cantilever(random_state=0)
    if setup == DESIGN:
        return make_cantilever(54, responses=RESPONSES, random_state=0)
    return make_cantilever(
        n_simulations=170, n_observations=70, parameters=("E", "I"), random_state=0
    )


def _figures(cal):
    """What the warm fit reached: MCMC diagnostics, quadrature errors or the
    designer's best subset."""
    from skmba.mcmc._diagnostics import ess_tail

    if hasattr(cal, "best_subset_"):
        return {"best": [int(k) for k in cal.best_subset_]}
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


def _estimator_and_fit(setup, params, data):
    """A fresh estimator of the set-up and how to fit it to ``data``."""
    from skmba import ModularBayesCalibrator, PreposteriorDesigner

    if setup == DESIGN:
        import numpy as np

        X = np.hstack([data.X_sim, data.theta_sim])
        est = PreposteriorDesigner(data.prior, random_state=0, **params)
        return est, lambda: est.fit(X, data.y_sim)
    cal = ModularBayesCalibrator(prior=data.prior, random_state=0, **params)
    return cal, lambda: cal.fit(
        data.X_obs,
        data.y_obs,
        X_sim=data.X_sim,
        theta_sim=data.theta_sim,
        y_sim=data.y_sim,
    )


def _outside_blas(stats):
    """The share of a profile's time spent outside LAPACK and BLAS: one
    minus the own time of the functions of :data:`LINALG_FILES` and of
    numpy's product built-ins (:data:`PRODUCTS`), over the total."""
    inside = total = 0.0
    for (filename, _, function), (_, _, own, _, _) in stats.stats.items():
        total += own
        path = filename.replace(os.sep, "/")
        if any(part in path for part in LINALG_FILES) or (
            filename == "~" and any(p in function for p in PRODUCTS)
        ):
            inside += own
    return 1.0 - inside / total


def _one(name):
    """Fit the configuration ``name`` twice in this (fresh) process (three
    times, the last profiled, for :data:`PROFILED`); print one JSON line."""
    started = time.perf_counter()
    import skmba  # noqa: F401  (the import is timed)

    imports = time.perf_counter() - started
    setup, params = CONFIGS[name]
    data = _data(setup)
    times = []
    for _ in range(2):
        est, fit = _estimator_and_fit(setup, params, data)
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit()
        times.append(time.perf_counter() - t0)
    out = {"imports": imports, "cold": times[0] + imports, "warm": times[1]}
    out.update(_figures(est))
    if name in PROFILED:
        _, fit = _estimator_and_fit(setup, params, data)
        profiler = cProfile.Profile()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            profiler.runcall(fit)
        out["outside"] = _outside_blas(pstats.Stats(profiler))
    print(json.dumps(out))


def _sampled(name):
    """A cold and a warm fit of the configuration ``name``, for py-spy."""
    setup, params = CONFIGS[name]
    data = _data(setup)
    for _ in range(2):
        _, fit = _estimator_and_fit(setup, params, data)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit()


#: Frames of a thread that waits: for work (a pool's queue) or for the GIL.
WAITING = ("_queue_SimpleQueue_get_impl", "PyThread_acquire_lock_timed")
GIL_WAIT = ("pthread_cond_timedwait", "take_gil")


def _native_shares(lines):
    """Shares of py-spy's raw samples (``frame;frame;... count`` per line,
    ``--native``): inside OpenBLAS, in other native code and in the Python
    interpreter, of the samples of a working thread outside imports; and
    their number."""
    counts = dict.fromkeys(("blas", "native", "python"), 0)
    for line in lines:
        stack, _, n = line.rstrip().rpartition(" ")
        frames = stack.split(";")
        if not n.isdigit() or any("_find_and_load" in f for f in frames):
            continue
        leaf = frames[-1]
        if any(w in f for f in frames[-4:] for w in WAITING) or any(
            w in leaf for w in GIL_WAIT
        ):
            continue
        if any("openblas" in f.lower() for f in frames):
            counts["blas"] += int(n)
        elif ".py:" in leaf:
            counts["python"] += int(n)
        else:
            counts["native"] += int(n)
    total = sum(counts.values())
    return {k: v / total for k, v in counts.items()}, total


def _sample_natively(name):
    """:func:`_native_shares` of ``py-spy record --native`` over
    :func:`_sampled` in a fresh process, or a sentence saying why not."""
    spy = shutil.which("py-spy")
    if spy is None:
        return "not measured (py-spy is not installed: pip install py-spy)"
    with tempfile.TemporaryDirectory() as folder:
        out = os.path.join(folder, "samples.txt")
        command = [sys.executable, __file__, "--sampled", name]
        run = subprocess.run(
            [
                spy,
                "record",
                "--native",
                "-r",
                "250",
                "-f",
                "raw",
                "-o",
                out,
                "--",
                *command,
            ],
            capture_output=True,
            text=True,
        )
        if run.returncode != 0 or not os.path.exists(out):
            return f"not measured (py-spy failed: {run.stderr.strip()[-200:]})"
        with open(out) as f:
            shares, total = _native_shares(f)
    return (
        f"OpenBLAS (BLAS and LAPACK) {shares['blas']:.0%}, other native code "
        f"{shares['native']:.0%}, the Python interpreter {shares['python']:.0%} "
        f"({total} samples of working threads, a cold and a warm fit)"
    )


def _line(name, r):
    head = (
        f"{name}: cold {r['cold']:.1f} s (imports {r['imports']:.1f} s), warm "
        f"{r['warm']:.1f} s; "
    )
    if "best" in r:
        return head + f"best subset {tuple(r['best'])}"
    if "ess" in r:
        outside = (
            f"; outside LAPACK and BLAS (profiled, at most) {r['outside']:.0%}"
            if "outside" in r
            else ""
        )
        return head + (
            f"{r['draws']} draws per chain, smallest bulk ESS {r['ess']:.0f}, "
            f"tail ESS {r['tail']:.0f}, largest R-hat {r['rhat']:.4f}; "
            f"{r['ess'] / r['warm']:.0f} ESS/s{outside}"
        )
    return head + (
        f"{r['draws']} module-2 draws, Monte Carlo error of theta's mean and sd "
        f"at most {r['mcse']:.3f} posterior sds"
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--one", choices=list(CONFIGS), help=argparse.SUPPRESS)
    parser.add_argument("--sampled", choices=list(CONFIGS), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        _one(args.one)
        return
    if args.sampled:
        _sampled(args.sampled)
        return
    print(machine_report(), flush=True)
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
        if name in PROFILED:
            print(f"{name}, sampled natively: {_sample_natively(name)}", flush=True)
    for name, reference in RATIOS:
        d, f = results[name], results[reference]
        print(
            f"{name} / {reference}: cold {d['cold'] / f['cold']:.2f}, warm "
            f"{d['warm'] / f['warm']:.2f}"
        )
    firsts = ", ".join(
        f"{n} {r['cold'] / r['warm']:.2f} "
        f"({(r['cold'] - r['imports']) / r['warm']:.2f})"
        for n, r in results.items()
    )
    print(f"first fit / warm fit, with the import (without it): {firsts}")


if __name__ == "__main__":
    main()
