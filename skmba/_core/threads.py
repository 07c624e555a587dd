"""BLAS threads: the one policy of the package.

Every dense computation of skmba runs under :func:`blas_threads`, which
decides how many BLAS threads it may use from two facts:

* the **order** of its largest matrix. Below :data:`SMALL_ORDER` a second
  thread only adds synchronisation (and numpy and scipy each bring their
  own OpenBLAS pool, whose idle threads spin while the other works), so such
  work runs on one thread. It is also what makes results bit-identical for
  any ``n_jobs``: the last bits of a larger factorisation change with the
  number of threads, and a Metropolis-Hastings chain or an optimiser turns
  last bits into another path.
* **how many tasks run at once.** Work in the calling process uses the
  threads the process started with (all cores unless the user, or joblib's
  loky worker, set ``OMP_NUM_THREADS``/``OPENBLAS_NUM_THREADS``); a task run
  by joblib with ``n_jobs`` workers gets ``cpu_count() // n_workers`` of
  them, so that workers x threads does not oversubscribe the machine.

Small work on one BLAS thread leaves the budget's other threads idle.
The chunks of a **stack of small factorisations** (numpy's batched Cholesky
and QR, which release the GIL) spend them instead: :func:`stack_map` runs
the chunks on the threads of the running :func:`blas_threads` block, on a
pool of this process (joblib's threading backend costs 11-15 ms per call,
against 1-3 ms per chunk). A chunk's values do not depend on the thread
that computes it: the same bits for any number of threads.

Nothing here limits threads globally: the limit holds inside the ``with``
block only. Measurements: docs/internals.rst, section skmba._core.threads.

Examples
--------
>>> from skmba._core.threads import SMALL_ORDER, blas_threads, thread_budget
>>> with blas_threads(SMALL_ORDER - 1):
...     pass  # one BLAS thread in here
>>> thread_budget(n_jobs=1) >= 1
True
"""

import functools
import os
import threading
from concurrent.futures import ThreadPoolExecutor, wait
from contextlib import contextmanager

from joblib import cpu_count
from threadpoolctl import ThreadpoolController, threadpool_info

from skmba._core.linalg import n_workers

#: Matrices of lower order than this are handled on one BLAS thread (the
#: timings behind it: docs/internals.rst, section skmba._core.threads).
SMALL_ORDER = 2500

# The stack threads of the innermost blas_threads block, per thread (the
# pool's threads and threads outside any block: one).
_stack = threading.local()


def _blas_threads_now():
    """The largest thread count of the loaded BLAS libraries (>= 1)."""
    counts = [
        info["num_threads"]
        for info in threadpool_info()
        if info["user_api"] == "blas" and info.get("num_threads")
    ]
    return max(counts, default=1)


# The threads this process's BLAS started with, read once at import: the
# machine's cores, or what OMP_NUM_THREADS/OPENBLAS_NUM_THREADS (set by the
# user, or by joblib's loky backend in its workers) allow.
_PROCESS_THREADS = (os.getpid(), _blas_threads_now())


def process_threads():
    """BLAS threads this process may use: what its BLAS started with.

    Read when :mod:`skmba._core.threads` is first imported in the process (in a
    joblib worker, that is the worker's own share).

    Examples
    --------
    >>> process_threads() >= 1
    True
    """
    pid, threads = _PROCESS_THREADS
    return threads if pid == os.getpid() else _blas_threads_now()


def thread_budget(n_jobs=None):
    """BLAS threads for one of ``n_jobs`` tasks that run at the same time.

    Parameters
    ----------
    n_jobs : int or None, default=None
        As for :class:`joblib.Parallel`; ``None`` is work in the calling
        process (one task, unless joblib's ``parallel_config`` says more).

    Returns
    -------
    int
        ``min(process_threads(), cpu_count() // workers)``, at least 1.

    Examples
    --------
    >>> thread_budget(n_jobs=10_000)
    1
    """
    return max(1, min(process_threads(), cpu_count() // n_workers(n_jobs)))


@contextmanager
def blas_threads(order, n_jobs=None):
    """Hold BLAS to the threads that work on matrices of ``order`` may use.

    One thread below :data:`SMALL_ORDER`, else :func:`thread_budget`.

    Parameters
    ----------
    order : int
        Order (rows) of the largest matrix factored or multiplied inside.
    n_jobs : int or None, default=None
        The ``n_jobs`` of the :class:`joblib.Parallel` that runs this work
        as one of its tasks; ``None`` in the calling process.

    Examples
    --------
    >>> from threadpoolctl import threadpool_info
    >>> with blas_threads(10):
    ...     {i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}
    {1}
    """
    limit = 1 if order < SMALL_ORDER else thread_budget(n_jobs)
    outer = stack_threads()
    _stack.threads = thread_budget(n_jobs) if limit == 1 else 1
    try:
        with _controller(os.getpid()).limit(limits=limit, user_api="blas"):
            yield limit
    finally:
        _stack.threads = outer


def stack_threads():
    """Threads that the chunks of a stack of small factorisations may use.

    Inside :func:`blas_threads` of a small order, the block's
    :func:`thread_budget` (its BLAS runs on one thread); otherwise one, and
    always one in the threads of :func:`stack_map`'s pool.

    Examples
    --------
    >>> with blas_threads(10, n_jobs=10_000):
    ...     stack_threads()
    1
    """
    return 1 if getattr(_stack, "pool", False) else getattr(_stack, "threads", 1)


def _pool_thread():
    """Mark a thread of the pool: its work never splits again (no pool
    thread waits on another)."""
    _stack.pool = True


@functools.cache
def _pool(pid):
    """The threads of :func:`stack_map` in process ``pid`` (this one; a
    forked child makes its own)."""
    return ThreadPoolExecutor(
        max(1, cpu_count()), thread_name_prefix="skmba-stack", initializer=_pool_thread
    )


def stack_map(func, items):
    """``[func(item) for item in items]`` on the :func:`stack_threads`: item
    ``i`` on thread ``i % n``, the first share in this thread, the others on
    the pool. An exception is raised once every share has ended.

    For items each worth a thread's hand-over (about 0.05 ms): e.g. the
    1 MiB chunks of a stack of factorisations, whose Python steps hold the
    GIL while their LAPACK calls release it.

    Examples
    --------
    >>> with blas_threads(10):
    ...     stack_map(abs, [-1, 2, -3])
    [1, 2, 3]
    """
    items = list(items)
    n = min(stack_threads(), len(items))
    if n <= 1:
        return [func(item) for item in items]

    def share(i):
        return [func(item) for item in items[i::n]]

    others = [_pool(os.getpid()).submit(share, i) for i in range(1, n)]
    try:
        shares = [share(0)]
    finally:
        wait(others)
    shares += [future.result() for future in others]
    out = [None] * len(items)
    for i, values in enumerate(shares):
        out[i::n] = values
    return out


@functools.cache
def _controller(pid):
    """The BLAS libraries of process ``pid`` (this one), found once.

    Finding them scans every shared library the process has loaded, 1-4 ms
    in a process with scikit-learn and pandas, which a limit per task would
    repeat hundreds of times in a fit. numpy's and scipy's libraries, the
    ones skmba computes with, are loaded when skmba is imported; the
    process id keys the cache so that a forked worker finds its own.
    """
    return ThreadpoolController()


def vector_level():
    """The processor's widest vector extension that numpy sees:
    ``"avx512"``, ``"avx2"`` or ``"other"``.

    It decides numpy's own loops (with AVX-512 numpy has its own float64
    ``exp`` and ``log``; without, glibc's), so results differ in their last
    bits between levels as between BLAS kernels.

    Examples
    --------
    >>> vector_level() in {"avx512", "avx2", "other"}
    True
    """
    try:
        from numpy._core._multiarray_umath import __cpu_features__
    except ImportError:  # numpy < 2
        from numpy.core._multiarray_umath import __cpu_features__
    for level, feature in (("avx512", "AVX512F"), ("avx2", "AVX2")):
        if __cpu_features__.get(feature):
            return level
    return "other"


def describe_threads():
    """One line on the machine's cores and the BLAS libraries' threads.

    Benchmarks print it, so that a time can be read with the threads it
    ran with.

    Examples
    --------
    >>> describe_threads().startswith("cores:")
    True
    """
    libs = ", ".join(
        f"{info['internal_api']} {info.get('version') or ''} "
        f"{info.get('architecture') or ''} {info['num_threads']} threads".replace(
            "  ", " "
        )
        for info in threadpool_info()
        if info["user_api"] == "blas"
    )
    env = {
        k: os.environ[k]
        for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "OPENBLAS_CORETYPE")
        if k in os.environ
    }
    return (
        f"cores: {cpu_count()} ({vector_level()}); BLAS: {libs or 'none found'}; "
        f"skmba: {SMALL_ORDER}+ order work on {process_threads()} threads, "
        f"smaller on 1; env {env or '{}'}"
    )


class BlasTask:
    """``func`` as a joblib task under :func:`blas_threads`.

    ``delayed(BlasTask(func, order, n_jobs))(*args)`` runs ``func(*args)``
    with the BLAS threads of work on matrices of ``order`` as one of the
    tasks of ``Parallel(n_jobs)``, in whichever process or thread the
    backend runs it. Picklable when ``func`` is a module-level function.

    The caller holds the same limit around the ``Parallel`` call
    (``with task.held(): ...``): a thread-based backend runs the tasks in
    the caller's process, whose BLAS limit is one for all its threads, and
    a task ending would otherwise restore the caller's threads under the
    feet of a task still running.

    Examples
    --------
    >>> from joblib import Parallel, delayed
    >>> task = BlasTask(pow, 10, 2)
    >>> with task.held():
    ...     Parallel(n_jobs=2)(delayed(task)(2, k) for k in range(3))
    [1, 2, 4]
    """

    def __init__(self, func, order, n_jobs=None):
        self.func, self.order, self.n_jobs = func, int(order), n_jobs

    def __call__(self, *args, **kwargs):
        with blas_threads(self.order, self.n_jobs):
            return self.func(*args, **kwargs)

    def held(self):
        """The tasks' limit as a context manager, for the caller."""
        return blas_threads(self.order, self.n_jobs)
