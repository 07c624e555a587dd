"""Module 3's two paths per (theta, draw), and where their times cross.

A batch of module-3 likelihoods (``ModelMixture`` of
``skmba.calibration._module3_mixture``) goes either dense (a bordered
Cholesky factorisation of order ``m + c`` per theta and draw, ``c = P +
1``) or through a low-rank model term of rank ``rho``
(:mod:`skmba.calibration._module3_low_rank`: the term's factor per theta,
a triangular solve per draw for all the thetas, a Cholesky factorisation
of order ``rho + c`` per theta and draw). The package picks the low-rank
path up to the rank that ``max_low_rank`` allows. Per field block order
``m`` and ``c``, this prints, for ranks from half to one and a half times
the rule's, the time per (theta, draw) of each path (48 thetas, 16 draws
of random positive definite fixed parts, the factor of the model term
included), with one thread (a joblib worker's share) and with the two
threads of the calling process's block (both paths split their work over
them), and the ratio of the low-rank time to the dense one.

Warm timings (best of three after a first call) in one process: the
figures are microseconds of BLAS-bound work, not a user's first call.
Run with ``python benchmarks/bench_low_rank.py`` (about 3 minutes;
``--quick`` for ``m`` of 30 and 75 only). What to look for: at the rule's
rank, ratios near one (where the paths cost the same); below it, under
one; above it, over one.
"""

import argparse
import time
import types

import numpy as np

from skmba._core.threads import blas_threads, stack_map
from skmba.calibration._module3_likelihood import schur_log_likelihoods, stack_chunks
from skmba.calibration._module3_low_rank import (
    fixed_factors,
    low_rank_log_likelihoods,
    max_low_rank,
    model_term_factor,
)

try:  # run as a script (python benchmarks/bench_x.py) or as a module
    from _machine import best_time, machine_report
except ImportError:
    from benchmarks._machine import best_time, machine_report

THETAS, DRAWS = 48, 16
#: The ranks timed, as multiples of the rule's (``max_low_rank``).
MULTIPLES = (0.5, 0.75, 1.0, 1.25, 1.5)


def _problem(m, c, rng):
    """Random fixed parts (DRAWS, m, m), field rows (THETAS, m, c) and a
    simulation block with ``c - 2`` rows."""
    A = rng.normal(size=(DRAWS, m, m)) / np.sqrt(m)
    fixed = A @ np.swapaxes(A, 1, 2) + 0.5 * np.eye(m)
    rows = rng.normal(size=(THETAS, m, c))
    top = np.triu(rng.normal(size=(c - 2, c)) + 5.0 * np.eye(c - 2, c))
    model = types.SimpleNamespace(
        top=top, rss_top_perp=1.0, log_det_A=0.0, N=10, q=1, n_observed=m
    )
    return fixed, rows, model


def _paths(fixed, rows, model, terms):
    """The two paths as the mixture runs them (stack threads included)."""
    K, m, _ = fixed.shape
    c = rows.shape[2]
    factors, log_dets = fixed_factors(fixed)

    def dense():
        def chunk(part):
            b = part.stop - part.start
            S = (fixed[None] + terms[part, None]).reshape(b * K, m, m)
            Z = np.broadcast_to(rows[part, None], (b, K, m, c)).reshape(b * K, m, c)
            return schur_log_likelihoods(S, Z, 0.5, model.top, 1.0, 0.0, 10 + m)

        return np.concatenate(stack_map(chunk, stack_chunks(len(terms), K, m, c)))

    def low_rank():
        U = model_term_factor(terms, 0.5, m)
        halves = np.array_split(np.arange(K), 2)
        parts = stack_map(
            lambda draws: low_rank_log_likelihoods(
                factors, log_dets, U, rows, model, draws
            ),
            halves,
        )
        return np.concatenate(parts, axis=1)

    return dense, low_rank


def measure(m, c, rng):
    """Per rank: the rank, and per thread count the two times (us)."""
    fixed, rows, model = _problem(m, c, rng)
    out = []
    for multiple in MULTIPLES:
        rho = min(m, max(1, round(multiple * max_low_rank(m, c))))
        V = rng.normal(size=(THETAS, m, rho))
        terms = 0.1 * V @ np.swapaxes(V, 1, 2)
        dense, low_rank = _paths(fixed, rows, model, terms)
        times = []
        for n_jobs in (2, None):  # one thread of two workers; the block's
            with blas_threads(m, n_jobs):
                for path in (dense, low_rank):
                    path()
                    times.append(best_time(path)[0] * 1e6 / (THETAS * DRAWS))
        out.append((rho, *times))
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="m of 30 and 75 only")
    args = parser.parse_args()
    print(machine_report(), flush=True)
    orders = (30, 75) if args.quick else (30, 50, 75, 100, 140, 200)
    rng = np.random.default_rng(0)
    start = time.perf_counter()
    print(f"{THETAS} thetas x {DRAWS} draws; us per (theta, draw), dense / low rank")
    for m in orders:
        for c in (3, 5, 9):
            results = measure(m, c, rng)
            print(f"m = {m}, c = {c}, max_low_rank = {max_low_rank(m, c)}:")
            for rho, d1, l1, d2, l2 in results:
                print(
                    f"  rank {rho:4d}: one thread {d1:7.1f} / {l1:7.1f} "
                    f"({l1 / d1:4.2f}); two {d2:7.1f} / {l2:7.1f} ({l2 / d2:4.2f})"
                )
    print(f"total {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
