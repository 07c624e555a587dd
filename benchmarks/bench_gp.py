"""Benchmark MultiResponseGP against scikit-learn's GaussianProcessRegressor.

With ``--defaults`` (issue 34, what users get) it prints, each figure from
a fresh Python process (``cold``: the first fit + predict of the process,
its imports apart; ``warm``: a second one in the same process), with the
machine's CPUs and BLAS thread settings first:

0. at N=5000, d=4, q=4, fit + predict of 2,000 points by
   ``MultiResponseGP()`` with its defaults, by the same with the previous
   default search (``optimizer=`` scipy's L-BFGS-B on ``-loglik`` run to its
   own end, the reference of the ratio) and by the tuned configuration
   ``MultiResponseGP(Gauss(roughness=np.ones(4)), alpha=1e-8)``, in that
   order: times, the likelihood evaluations on all N samples, the held-out
   R^2, the process's peak resident memory; targets for the defaults: under
   60 s and 2 GiB, R^2 no worse than the previous search's;
0b. at N = 500, 1000, 2000 (q=4), the same with defaults on both sides
   against scikit-learn (one ``GaussianProcessRegressor()`` per response),
   then the tuned configurations (``GaussianProcessRegressor(RBF(ones),
   alpha=1e-8, normalize_y=True)``); target: skmba / sklearn <= 0.5 with
   the same or better R^2.

Without it, from one run in one process:

1. fit + predict wall time of ``MultiResponseGP`` (anisotropic Gauss kernel)
   and of sklearn's ``GaussianProcessRegressor`` (anisotropic RBF, the same
   kernel family, the same number of restarts, ``normalize_y=True``) on
   N=500 training points, d=4 inputs, q=8 responses, with the ratio, the
   log-likelihood each reached and the held-out R^2 of each;
2. the time of a noisy fit (``noise=True``) for q = 1, 2, 4, 8, 16 at N=400,
   with the ratio to q=2 (the Kronecker-eigen path should keep it far below
   q / 2).

With ``--large`` (issue 15, large emulators) it prints instead:

3. the peak traced memory (tracemalloc, which traces numpy's allocations)
   and time of one log-likelihood + gradient evaluation at N=3000, d=4,
   q=4, through the stacked (N, N, n_theta) gradient of the previous
   implementation and through the per-hyperparameter contraction;
4. fit + predict wall time, held-out R^2 and peak traced memory of
   ``MultiResponseGP`` at N=5000 and N=10000, d=4, q=4 (its search starts
   from a fit on a 1000-point subsample); targets: N=5000 under 60 s and
   2 GiB, N=10000 within 6 GiB;
5. the time ratio to sklearn (one ``GaussianProcessRegressor`` per
   response, anisotropic RBF, the same restarts, ``normalize_y=True``) at
   N = 500, 1000, 2000.

Every run starts with the threads line of ``skmba._core.threads``.

Run with ``python benchmarks/bench_gp.py`` (add ``--quick`` for a smaller
smoke run, ``--defaults`` for what users get (about an hour on two cores,
most of it scikit-learn's and the previous search's), ``--large`` for the
large emulators, ``--ratios`` for item 5 alone). Targets: ratio <= 1.0;
noisy q=16 under 16x the time of q=2.
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import time
import tracemalloc
import warnings

import numpy as np
from scipy import linalg
from scipy.optimize import minimize
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF
from sklearn.metrics import r2_score

import skmba.gp._search
from skmba import MultiResponseGP
from skmba._core.threads import blas_threads
from skmba.gp._likelihood import NoiseFreeLikelihood
from skmba.gp._search import correlation
from skmba.kernels import Gauss

try:  # run as a script (python benchmarks/bench_x.py) or as a module
    from _machine import machine_report
except ImportError:
    from benchmarks._machine import machine_report


def responses(X, q):
    """q smooth, correlated responses of 4 inputs in [0, 1]^4."""
    base = [
        np.sin(2 * X[:, 0]) + X[:, 1] ** 2,
        np.cos(1.5 * X[:, 1]) * X[:, 2],
        np.exp(-X[:, 3]) + 0.5 * X[:, 0] * X[:, 2],
        np.sin(X[:, 2] + X[:, 3]),
    ]
    cols = [
        base[k % 4] * (1 + 0.3 * (k // 4)) + 0.1 * k * X[:, k % 4] for k in range(q)
    ]
    return np.column_stack(cols)


def timed(fn):
    start = time.perf_counter()
    out = fn()
    return time.perf_counter() - start, out


def traced(fn):
    """``(seconds, peak traced bytes, fn())``."""
    tracemalloc.start()
    try:
        seconds, out = timed(fn)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return seconds, peak, out


class PerResponseGPR:
    """One sklearn ``GaussianProcessRegressor`` per column of ``Y``."""

    def __init__(self, **params):
        self.params = params

    def fit(self, X, Y):
        self.models_ = [GaussianProcessRegressor(**self.params).fit(X, y) for y in Y.T]
        return self

    def predict(self, X):
        return np.column_stack([m.predict(X) for m in self.models_])

    @property
    def log_marginal_likelihood_value_(self):
        return sum(m.log_marginal_likelihood_value_ for m in self.models_)


def compare_with_sklearn(n, d, q, restarts, seed=0, per_response=False):
    """Fit + predict time of both, and their ratio.

    ``per_response`` fits one sklearn GPR per response (each with its own
    kernel, as sklearn users would for independent responses) instead of
    one GPR on the q columns.
    """
    rng = np.random.default_rng(seed)
    X = rng.uniform(size=(n, d))
    Y = responses(X, q)
    X_test = rng.uniform(size=(500, d))
    Y_test = responses(X_test, q)

    ours = MultiResponseGP(
        Gauss(roughness=np.ones(d)),
        n_restarts_optimizer=restarts,
        normalize_y=True,
        alpha=1e-8,
        random_state=0,
    )
    theirs = (PerResponseGPR if per_response else GaussianProcessRegressor)(
        kernel=RBF(length_scale=np.ones(d)),
        n_restarts_optimizer=restarts,
        normalize_y=True,
        alpha=1e-8,
        random_state=0,
    )
    t_ours, _ = timed(lambda: ours.fit(X, Y).predict(X_test))
    t_theirs, _ = timed(lambda: theirs.fit(X, Y).predict(X_test))
    print(f"fit+predict, N={n}, d={d}, q={q}, restarts={restarts}")
    print(f"  MultiResponseGP (Gauss, full Sigma2): {t_ours:8.2f} s")
    which = "one GPR per response" if per_response else "normalize_y"
    print(f"  sklearn GPR (RBF, {which}): {t_theirs:8.2f} s")
    print(f"  ratio skmba / sklearn:                {t_ours / t_theirs:8.2f}")
    ll_ours = ours.log_marginal_likelihood_value_
    print(f"  log-likelihood skmba (y units):       {ll_ours:12.1f}")
    print(
        f"  log-likelihood sklearn (standardised y): "
        f"{theirs.log_marginal_likelihood_value_:9.1f}"
    )
    print(
        f"  held-out R^2 skmba / sklearn:         "
        f"{r2_score(Y_test, ours.predict(X_test)):.5f} / "
        f"{r2_score(Y_test, theirs.predict(X_test)):.5f}"
    )
    return t_ours / t_theirs


def noisy_scaling(n, qs, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.uniform(size=(n, 4))
    times = {}
    print(f"noisy fit (noise=True), N={n}, d=4")
    for q in qs:
        Y = responses(X, q) + 0.05 * rng.normal(size=(n, q))
        gp = MultiResponseGP(Gauss(roughness=np.ones(4)), noise=True, random_state=0)
        times[q], _ = timed(lambda gp=gp, Y=Y: gp.fit(X, Y))
        print(
            f"  q={q:3d}: {times[q]:7.2f} s   (ratio to q=2: "
            f"{times[q] / times.get(2, times[q]):5.2f})"
        )
    return times


def gradient_memory(n, d, q, seed=0):
    """Peak traced memory of one log-likelihood + gradient evaluation.

    "stacked" repeats the previous implementation: the cached (N, N, d)
    input differences, sklearn-style stacked (N, N, n_theta) gradient and
    its contraction; "per hyperparameter" is the current one.
    """
    rng = np.random.default_rng(seed)
    X = rng.uniform(size=(n, d))
    Y = responses(X, q)
    Y = (Y - Y.mean(axis=0)) / Y.std(axis=0)
    H = np.ones((n, 1))
    kernel = Gauss(roughness=np.full(d, 3.0))

    def stacked():
        differences = np.abs(X[:, np.newaxis, :] - X[np.newaxis, :, :])
        R, dR = kernel._from_differences(differences, True)
        R[np.diag_indices(n)] += 1e-8
        return NoiseFreeLikelihood(R, H, Y, dR).gradient

    def per_hyperparameter():
        R, dR = correlation(kernel, X, 1e-8, True)
        return NoiseFreeLikelihood(R, H, Y, dR).gradient

    print(f"one log-likelihood + gradient, N={n}, d={d}, q={q} (Gauss)")
    results = {}
    with blas_threads(n):
        for name, fn in [
            ("stacked", stacked),
            ("per hyperparameter", per_hyperparameter),
        ]:
            seconds, peak, grad = traced(fn)
            results[name] = grad
            print(
                f"  {name:20s}: peak traced {peak / 2**20:8.1f} MiB "
                f"({peak / (8 * n * n):5.1f} N x N arrays), {seconds:6.2f} s"
            )
    a, b = results.values()
    worst = np.max(np.abs(a - b) / np.abs(a))
    print(f"  max relative difference of the gradients: {worst:.1e}")
    # Any order of the N^2-term sums tr(W dR_k) is exact only to about
    # eps sum|W dR_k|; with the weight W = B'B - q R^-1 of a nearly singular
    # R that is far above eps |tr(W dR_k)|. For Gauss, dR_k <= 0, so
    # sum|W dR_k| is minus the contraction of |W|.
    with blas_threads(n):
        R, dR = correlation(kernel, X, 1e-8, True)
        fit = NoiseFreeLikelihood(R, H, Y)
        A = linalg.solve_triangular(fit.C, fit.gls.residual, lower=True, trans="T")
        B = linalg.solve_triangular(fit.sigma2_chol, A.T, lower=True)
        weight = B.T @ B - q * linalg.cho_solve((fit.C, True), np.eye(n))
        floor = np.finfo(float).eps * -dR(np.abs(weight)) / np.abs(b)
    print(f"  rounding floor eps sum|W dR_k| / |grad_k|:  {np.max(floor):.1e}")


def large_fit(n, d, q, n_test=10_000, seed=0):
    """Fit + predict (with std) of MultiResponseGP on n points."""
    rng = np.random.default_rng(seed)
    X = rng.uniform(size=(n, d))
    Y = responses(X, q)
    X_test = rng.uniform(size=(n_test, d))
    Y_test = responses(X_test, q)
    gp = MultiResponseGP(
        Gauss(roughness=np.ones(d)), normalize_y=True, alpha=1e-8, random_state=0
    )
    t_fit, peak_fit, _ = traced(lambda: gp.fit(X, Y))
    t_pred, peak_pred, (mean, _) = traced(lambda: gp.predict(X_test, return_std=True))
    print(f"MultiResponseGP fit + predict, N={n}, d={d}, q={q}")
    mib = peak_fit / 2**20
    print(f"  fit:                       {t_fit:8.1f} s, peak traced {mib:7.0f} MiB")
    print(
        f"  predict {n_test} points (std): {t_pred:8.1f} s, "
        f"peak traced {peak_pred / 2**20:7.0f} MiB"
    )
    print(f"  held-out R^2:              {r2_score(Y_test, mean):.6f}")
    print(f"  fitted kernel:             {gp.kernel_}")


def sklearn_ratios(ns):
    """Item 5: the time ratio to sklearn (one GPR per response) at ``ns``."""
    ratios = {
        n: compare_with_sklearn(n=n, d=4, q=4, restarts=0, per_response=True)
        for n in ns
    }
    print(
        "ratio skmba / sklearn (one GPR per response): "
        + ", ".join(f"N={n}: {r:.2f}" for n, r in ratios.items())
    )


# --------------------------------------- what users get (issue 34, --defaults)
def scipy_to_its_end(objective, start, bounds):
    """The previous default search: L-BFGS-B on ``-loglik`` with scipy's
    defaults, run until its own tests (or failed line searches) end it."""
    res = minimize(objective, start, jac=True, method="L-BFGS-B", bounds=bounds)
    return res.x, res.fun


#: name -> (estimator factory, skmba's or not); defaults first.
CONFIGS = {
    "skmba defaults": (lambda: MultiResponseGP(), True),
    "sklearn defaults": (lambda: PerResponseGPR(), False),
    "skmba previous search": (
        lambda: MultiResponseGP(optimizer=scipy_to_its_end),
        True,
    ),
    "skmba tuned": (
        lambda: MultiResponseGP(Gauss(roughness=np.ones(4)), alpha=1e-8),
        True,
    ),
    "sklearn tuned": (
        lambda: PerResponseGPR(
            kernel=RBF(length_scale=np.ones(4)), alpha=1e-8, normalize_y=True
        ),
        False,
    ),
}


def _one(name, n, n_test=2000, seed=0):
    """Fit + predict ``CONFIGS[name]`` twice in this (fresh) process; print
    one JSON line (times, full-size evaluations, R^2, peak RSS)."""
    rng = np.random.default_rng(seed)
    X = rng.uniform(size=(n, 4))
    Y = responses(X, 4)
    X_test = rng.uniform(size=(n_test, 4))
    Y_test = responses(X_test, 4)
    factory, ours = CONFIGS[name]
    count = {"evaluations": 0}

    class Counting(NoiseFreeLikelihood):
        def __init__(self, R, *args, **kwargs):
            count["evaluations"] += len(R) == n
            super().__init__(R, *args, **kwargs)

    skmba.gp._search.NoiseFreeLikelihood = Counting
    runs = []
    for _ in range(2):
        count["evaluations"] = 0
        model = factory()
        t_fit, _ = timed(lambda model=model: model.fit(X, Y))
        t_pred, mean = timed(lambda model=model: model.predict(X_test))
        runs.append((t_fit, t_pred, count["evaluations"]))
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # MiB
    print(
        json.dumps(
            {
                "cold": runs[0][:2],
                "warm": runs[1][:2],
                "evaluations": runs[1][2] if ours else None,
                "r2": r2_score(Y_test, mean),
                "peak_mib": peak,
            }
        )
    )


def run_fresh(name, n):
    """``_one(name, n)`` in a fresh Python process; prints one line."""
    run = subprocess.run(
        [sys.executable, __file__, "--one", name, "--n", str(n)],
        capture_output=True,
        text=True,
        check=True,
    )
    result = json.loads(run.stdout.strip().splitlines()[-1])
    fit, pred = result["cold"]
    w_fit, w_pred = result["warm"]
    evaluations = result["evaluations"]
    print(
        f"  {name:22s}: cold {fit + pred:7.1f} s, warm {w_fit + w_pred:7.1f} s "
        f"(fit {w_fit:6.1f} s, predict {w_pred:4.1f} s); "
        + (f"{evaluations} evaluations on all N; " if evaluations else "")
        + f"1 - R^2 {1 - result['r2']:.2e}; peak RSS {result['peak_mib']:5.0f} MiB",
        flush=True,
    )
    return result


def _load():
    """The load averages over 1, 5 and 15 minutes."""
    return ", ".join(f"{x:.1f}" for x in os.getloadavg())


def defaults_report(n_large, ns):
    """Item 0 at ``n_large`` and item 0b at each of ``ns``."""
    env = {k: os.environ.get(k) for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")}
    print(f"CPUs: {os.cpu_count()}; BLAS threads from the environment: {env}")
    print(f"load average (1, 5, 15 min) at the start: {_load()}")
    print("imports of skmba and sklearn.gaussian_process in a fresh process: ", end="")
    started = time.perf_counter()
    subprocess.run([sys.executable, "-c", "import skmba, sklearn.gaussian_process"])
    print(f"{time.perf_counter() - started:.1f} s (not in the times below)")

    def ratio(a, b):
        total = {k: [sum(r[k]) for r in (a, b)] for k in ("cold", "warm")}
        return ", ".join(f"{k} {x / y:.2f}" for k, (x, y) in total.items())

    print(f"fit + predict 2000 points, N={n_large}, d=4, q=4:")
    names = ("skmba defaults", "skmba previous search", "skmba tuned")
    r = {name: run_fresh(name, n_large) for name in names}
    print(
        f"  defaults / previous search: {ratio(*[r[k] for k in names[:2]])}; "
        f"defaults / tuned: {ratio(r[names[0]], r[names[2]])}"
    )
    for n in ns:
        print(f"fit + predict 2000 points, N={n}, d=4, q=4:")
        r = {name: run_fresh(name, n) for name in CONFIGS}
        print(
            "  skmba / sklearn: defaults "
            f"{ratio(r['skmba defaults'], r['sklearn defaults'])}; tuned "
            f"{ratio(r['skmba tuned'], r['sklearn tuned'])}; skmba defaults / "
            f"previous search {ratio(r['skmba defaults'], r['skmba previous search'])}"
        )
    print(f"load average (1, 5, 15 min) at the end: {_load()}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small smoke run")
    parser.add_argument(
        "--large", action="store_true", help="large emulators (issue 15)"
    )
    parser.add_argument(
        "--ratios",
        action="store_true",
        help="only item 5: the time ratio to sklearn at N = 500, 1000, 2000",
    )
    parser.add_argument(
        "--defaults",
        action="store_true",
        help="what users get: defaults first, fresh processes (issue 34)",
    )
    parser.add_argument("--one", choices=list(CONFIGS), help=argparse.SUPPRESS)
    parser.add_argument("--n", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    warnings.simplefilter("ignore", ConvergenceWarning)
    if args.one:
        _one(args.one, args.n)
        return
    print(machine_report(), flush=True)
    if args.defaults:
        defaults_report(
            *((1200, (200, 400)) if args.quick else (5000, (500, 1000, 2000)))
        )
    elif args.ratios:
        sklearn_ratios((200, 400) if args.quick else (500, 1000, 2000))
    elif args.large:
        n_mem, n_fit, ns = (
            (600, 1200, (200, 400)) if args.quick else (3000, 5000, (500, 1000, 2000))
        )
        gradient_memory(n=n_mem, d=4, q=4)
        large_fit(n=n_fit, d=4, q=4)
        if not args.quick:
            large_fit(n=10_000, d=4, q=4)  # about 3.5 minutes, 6 GB
        sklearn_ratios(ns)
    elif args.quick:
        compare_with_sklearn(n=100, d=4, q=3, restarts=0)
        noisy_scaling(n=80, qs=(1, 2, 4))
    else:
        # Same start (no restarts), then the setting with 2 restarts:
        # sklearn's random restarts often stop at the bounds after two
        # evaluations, ours run to an optimum, which costs time.
        compare_with_sklearn(n=500, d=4, q=8, restarts=0)
        compare_with_sklearn(n=500, d=4, q=8, restarts=2)
        noisy_scaling(n=400, qs=(1, 2, 4, 8, 16))


if __name__ == "__main__":
    main()
