"""The BLAS thread policy (skmba._core.threads)."""

import os
import threading
from contextlib import contextmanager

import numpy as np
import pytest
from joblib import Parallel, delayed, parallel_config
from threadpoolctl import threadpool_info, threadpool_limits

from skmba import MultiResponseGP
from skmba._core import threads
from skmba._core.threads import (
    SMALL_ORDER,
    BlasTask,
    blas_threads,
    describe_threads,
    process_threads,
    stack_map,
    stack_threads,
    thread_budget,
)


def blas_now():
    """The thread counts of the loaded BLAS libraries."""
    return {i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}


def test_small_work_runs_on_one_thread_and_the_limit_ends_with_the_block():
    before = blas_now()
    with blas_threads(SMALL_ORDER - 1) as limit:
        assert limit == 1
        assert blas_now() == {1}
    assert blas_now() == before


def test_large_work_in_the_calling_process_uses_the_process_threads():
    with threadpool_limits(1, user_api="blas"):  # nested inside a limit
        with blas_threads(SMALL_ORDER) as limit:
            assert limit == thread_budget(None) == process_threads()
            assert blas_now() == {limit}


def test_the_libraries_are_found_once_per_process(monkeypatch):
    # Finding them scans every loaded shared library: once, not per limit.
    import threadpoolctl

    from skmba._core import threads

    made = []

    class Counted(threadpoolctl.ThreadpoolController):
        def __init__(self):
            made.append(1)
            super().__init__()

    monkeypatch.setattr(threads, "ThreadpoolController", Counted)
    threads._controller.cache_clear()
    try:
        before = blas_now()
        for _ in range(3):
            with blas_threads(SMALL_ORDER - 1):
                assert blas_now() == {1}
            assert blas_now() == before
        assert len(made) == 1
        threads._controller(-1)  # another process id: its own libraries
        assert len(made) == 2
    finally:
        threads._controller.cache_clear()


@pytest.mark.parametrize("n_jobs", [1, 2, 4, -1])
def test_a_task_gets_its_share_of_the_cores(n_jobs, monkeypatch):
    monkeypatch.setattr("skmba._core.threads.cpu_count", lambda: 8)
    monkeypatch.setattr("skmba._core.threads._PROCESS_THREADS", (os.getpid(), 8))
    monkeypatch.setattr("skmba._core.threads.n_workers", lambda n: 8 if n == -1 else n)
    expected = {1: 8, 2: 4, 4: 2, -1: 1}[n_jobs]
    assert thread_budget(n_jobs) == expected
    assert thread_budget(10_000) == 1


def test_a_task_never_gets_more_than_the_process_started_with(monkeypatch):
    # In a loky worker (or under OMP_NUM_THREADS=1) the process's own
    # budget is the ceiling, whatever the machine has.
    monkeypatch.setattr("skmba._core.threads.cpu_count", lambda: 16)
    monkeypatch.setattr("skmba._core.threads._PROCESS_THREADS", (os.getpid(), 1))
    assert thread_budget(None) == 1


def _threads_inside():
    return sorted(blas_now())


@pytest.mark.parametrize("backend", ["loky", "threading"])
def test_blas_task_limits_threads_inside_workers(backend):
    task = BlasTask(_threads_inside, 10, 2)
    with parallel_config(backend=backend), task.held():
        small = Parallel(n_jobs=2)(delayed(task)() for _ in range(8))
    assert small == [[1]] * 8


def test_describe_threads_names_cores_and_libraries():
    line = describe_threads()
    assert line.startswith("cores: ")
    assert "BLAS:" in line and str(SMALL_ORDER) in line


@pytest.mark.parametrize("n", [49, 50])
def test_a_gp_fit_takes_its_threads_by_its_number_of_samples(n, monkeypatch):
    monkeypatch.setattr("skmba._core.threads.SMALL_ORDER", 50)
    seen = []

    @contextmanager
    def recording(order, n_jobs=None):
        with blas_threads(order, n_jobs) as limit:
            seen.append((order, limit, sorted(blas_now())))
            yield limit

    monkeypatch.setattr("skmba.gp._estimator.blas_threads", recording)
    rng = np.random.default_rng(0)
    X = rng.uniform(size=(n, 2))
    gp = MultiResponseGP(n_restarts_optimizer=0).fit(X, np.sin(3 * X[:, 0]))
    limit = 1 if n < 50 else process_threads()
    assert seen == [(n, limit, [limit])]
    assert gp.score(X, np.sin(3 * X[:, 0])) > 0.999


def test_a_stack_s_chunks_use_the_block_s_threads_in_order(monkeypatch):
    monkeypatch.setattr(threads, "thread_budget", lambda n_jobs=None: 2)
    where = []

    def square(i):
        where.append(threading.get_ident())
        return i * i

    # outside a block: one thread, this one
    assert stack_threads() == 1
    assert stack_map(square, range(5)) == [0, 1, 4, 9, 16]
    assert set(where) == {threading.get_ident()}
    where.clear()
    with blas_threads(SMALL_ORDER - 1):
        assert stack_threads() == 2
        assert stack_map(square, range(5)) == [0, 1, 4, 9, 16]
        assert len(set(where)) == 2 and where.count(threading.get_ident()) == 3

        # the pool's threads never split again, even inside a block of their own
        def inner(_):
            with blas_threads(SMALL_ORDER - 1):
                return stack_threads()

        assert stack_map(inner, range(2)) == [2, 1]
        with blas_threads(SMALL_ORDER):  # large work: BLAS has the threads
            assert stack_threads() == 1
        assert stack_threads() == 2
    assert stack_threads() == 1


def test_a_failing_chunk_raises_once_every_chunk_has_ended(monkeypatch):
    monkeypatch.setattr(threads, "thread_budget", lambda n_jobs=None: 2)
    done = []

    def chunk(i):
        if i == 1:  # on the pool's thread
            raise ValueError("chunk 1 failed")
        done.append(i)
        return i

    with blas_threads(SMALL_ORDER - 1):
        with pytest.raises(ValueError, match="chunk 1 failed"):
            stack_map(chunk, range(4))
    assert sorted(done) == [0, 2]
