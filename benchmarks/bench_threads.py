"""The BLAS thread policy (``skmba._core.threads``), measured.

Prints, from one run in one process, with the thread settings it ran with:

1. the crossover behind ``SMALL_ORDER``: a Cholesky factorisation, a
   triangular solve with 8 right-hand sides and their product, with one
   BLAS thread and with all of them, by matrix order, and the ratio;
2. one ``MultiResponseGP`` log-likelihood with its gradient (d=4, q=4) at
   N = 300 to 4000 with one BLAS thread (what the package did before the
   policy) and with all of them, and the ratio; then fit + predict under
   the policy at N = 1000 and 4000 with the held-out R^2;
3. the noisy fit (``noise=True``, q=16, N=400; many small matrices) under
   the policy against all threads on everything, which is what the policy
   guards against (two OpenBLAS pools spinning on small matrices).

Run with ``python benchmarks/bench_threads.py`` (``--quick`` for a smoke
run). What to look for: the ratios of (1) and (2) above 1 from
``SMALL_ORDER`` on, where the policy uses every thread; (3) near 1.
"""

import argparse
import warnings

import numpy as np
from scipy import linalg
from sklearn.metrics import r2_score
from threadpoolctl import threadpool_limits

import skmba.gp._estimator
from skmba import MultiResponseGP
from skmba._core.threads import SMALL_ORDER, process_threads

try:  # run as a script (python benchmarks/bench_x.py) or as a module
    from _machine import best_time, machine_report
except ImportError:
    from benchmarks._machine import best_time, machine_report


def crossover(orders):
    rng = np.random.default_rng(0)
    print("1. Cholesky + solve (8 rhs) + product, by order:")
    for n in orders:
        A = rng.normal(size=(n, n))
        S = A @ A.T + n * np.eye(n)
        B = rng.normal(size=(n, 8))
        reps = max(3, int(2e8 / n**3))

        def work(S=S, B=B, reps=reps):
            for _ in range(reps):
                L = linalg.cholesky(S, lower=True, check_finite=False)
                X = linalg.solve_triangular(L, B, lower=True, check_finite=False)
                X.T @ X

        times = {}
        for threads in (1, process_threads()):
            with threadpool_limits(threads, user_api="blas"):
                times[threads] = best_time(work)[0] / reps
        one, many = times[1], times[process_threads()]
        mark = "  <- SMALL_ORDER" if n == SMALL_ORDER else ""
        print(
            f"   order {n:5d}: 1 thread {one * 1e3:9.3f} ms, "
            f"{process_threads()} threads {many * 1e3:9.3f} ms, "
            f"ratio {one / many:5.2f}{mark}"
        )


def responses(X):
    return np.column_stack(
        [
            np.sin(2 * X[:, 0]) + X[:, 1] ** 2,
            np.cos(1.5 * X[:, 1]) * X[:, 2],
            np.exp(-X[:, 3]) + 0.5 * X[:, 0] * X[:, 2],
            np.sin(X[:, 2] + X[:, 3]),
        ]
    )


def gp_evaluation(n, seed=0):
    """Best time of one log-likelihood with gradient, 1 and all threads.

    At the same hyperparameters, so that both time the same arithmetic (a
    whole fit under other thread counts can take another optimiser path:
    the last bits of a Cholesky factor depend on them).
    """
    rng = np.random.default_rng(seed)
    X = rng.uniform(size=(n, 4))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gp = MultiResponseGP(optimizer=None).fit(X, responses(X))
    theta = gp.kernel_.theta
    times = {}
    for threads in (1, process_threads()):
        with threadpool_limits(threads, user_api="blas"):
            gp.log_marginal_likelihood(theta, eval_gradient=True)
            times[threads] = best_time(
                lambda: gp.log_marginal_likelihood(theta, eval_gradient=True)
            )[0]
    return times[1], times[process_threads()]


def gp_fit_time(n, seed=0):
    """Wall time and held-out R^2 of a default fit + predict (the policy)."""
    rng = np.random.default_rng(seed)
    X, X_test = rng.uniform(size=(n, 4)), rng.uniform(size=(2000, 4))

    def run():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            gp = MultiResponseGP(random_state=seed).fit(X, responses(X))
        return r2_score(responses(X_test), gp.predict(X_test))

    return best_time(run, repeat=1)


def gp_section(sizes, fit_sizes):
    print("2. MultiResponseGP (d=4, q=4), one log-likelihood with its gradient:")
    for n in sizes:
        one, many = gp_evaluation(n)
        policy = "all" if n >= SMALL_ORDER else "1"
        print(
            f"   N={n:5d}: 1 thread {one * 1e3:9.1f} ms, {process_threads()} "
            f"threads {many * 1e3:9.1f} ms, ratio {one / many:5.2f} "
            f"(policy: {policy})"
        )
    for n in fit_sizes:
        seconds, r2 = gp_fit_time(n)
        print(f"   fit + predict under the policy, N={n}: {seconds:.2f} s, R2 {r2:.6f}")


class _AllThreads:
    """Stand-in for ``blas_threads`` that leaves every thread on."""

    def __call__(self, order, n_jobs=None):
        return threadpool_limits(process_threads(), user_api="blas")


def noisy_section(n, q):
    rng = np.random.default_rng(1)
    X = rng.uniform(size=(n, 4))
    Y = np.column_stack([responses(X)[:, k % 4] * (1 + k / q) for k in range(q)])
    Y = Y + 0.01 * rng.normal(size=Y.shape)

    def run():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return MultiResponseGP(noise=True, random_state=0).fit(X, Y)

    t_policy = best_time(run, repeat=1)[0]
    policy = skmba.gp._estimator.blas_threads
    skmba.gp._estimator.blas_threads = _AllThreads()
    try:
        t_all = best_time(run, repeat=1)[0]
    finally:
        skmba.gp._estimator.blas_threads = policy
    print(
        f"3. noisy fit N={n}, q={q}: policy {t_policy:.2f} s, all threads on "
        f"everything {t_all:.2f} s, ratio {t_all / t_policy:.2f}"
    )


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="smaller sizes")
    args = parser.parse_args(argv)
    print(machine_report(), flush=True)
    if args.quick:
        crossover(sorted({50, 200, 600, SMALL_ORDER}))
        gp_section([200, 500], [500])
        noisy_section(200, 4)
    else:
        crossover(sorted({50, 100, 200, 400, 600, 1000, SMALL_ORDER, 2000, 4000}))
        gp_section([300, 1000, 2000, 3000, 4000], [1000, 4000])
        noisy_section(400, 16)


if __name__ == "__main__":
    main()
