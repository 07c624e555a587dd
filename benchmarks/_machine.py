"""The machine a benchmark ran on, printed first by every ``bench_*`` script.

Two-core machines of this project's kind have run the same benchmark 1.8
times apart, and two kinds four to five times apart (the 4.7.3 default
fit: 7.7 s warm on one, 29-40 s over two runs on an AMD EPYC without
AVX-512). A time is only read against a target together with what the
machine does per unit of the work behind it, so :func:`machine_report`
gives, besides the processor and the BLAS threads
(:func:`skmba._core.threads.describe_threads`), three probes, each the
best of :data:`REPEATS` warm runs:

- **Python**: ``sum(range(10**6))``, the interpreter's speed (per-item
  loops, argument checks, the chains' bookkeeping);
- **small LAPACK**: one batched Cholesky factorisation of 12 matrices of
  order 145 on one BLAS thread, the unit of work of the 4.7.3 chains (a
  theta at 12 module-2 draws; skmba factors matrices below
  ``SMALL_ORDER`` on one thread);
- **large LAPACK**: a Cholesky factorisation of order 2000 on the
  process's BLAS threads (the GP's fits at thousands of points).

Run ``python benchmarks/_machine.py`` to print the report alone. Importing
this module imports neither numpy nor skmba (the scripts time those
imports in fresh processes); :func:`machine_report` does.
"""

import os
import platform
import time

#: Warm runs per probe; the best is reported.
REPEATS = 5


def _processor():
    """The processor's model name and number of CPUs."""
    name = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    name = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return f"processor: {name}; {os.cpu_count()} CPUs"


def best_time(fn, repeat=3):
    """Best wall time of ``repeat`` calls, and the last result."""
    best, out = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out


def _best_ms(work):
    """The best of :data:`REPEATS` timed runs of ``work`` after an untimed
    one, in milliseconds."""
    work()
    return 1e3 * best_time(work, REPEATS)[0]


def speed_probes():
    """The three probes' times in milliseconds, by name."""
    import numpy as np
    from threadpoolctl import threadpool_limits

    rng = np.random.default_rng(0)
    small = rng.standard_normal((12, 145, 145))
    small = small @ np.swapaxes(small, 1, 2) + 145 * np.eye(145)
    large = rng.standard_normal((2000, 2000))
    large = large @ large.T + 2000 * np.eye(2000)
    with threadpool_limits(limits=1, user_api="blas"):
        small_ms = _best_ms(lambda: np.linalg.cholesky(small))
    return {
        "python": _best_ms(lambda: sum(range(10**6))),
        "small LAPACK": small_ms,
        "large LAPACK": _best_ms(lambda: np.linalg.cholesky(large)),
    }


def machine_report():
    """Three lines: the processor, its vector extensions and the BLAS
    threads (:func:`~skmba._core.threads.describe_threads`), the speed
    probes."""
    from skmba._core.threads import describe_threads

    probes = speed_probes()
    return "\n".join(
        [
            _processor(),
            describe_threads(),
            f"speed (best of {REPEATS}): Python sum(range(10**6)) "
            f"{probes['python']:.1f} ms; 12 Cholesky factorisations of order "
            f"145 on one BLAS thread {probes['small LAPACK']:.2f} ms; one of "
            f"order 2000 {probes['large LAPACK']:.0f} ms",
        ]
    )


if __name__ == "__main__":
    print(machine_report())
