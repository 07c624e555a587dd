"""Tests of the factorisation helpers and the memory check in skmba._core.linalg."""

import pickle

import numpy as np
import pytest
from scipy import linalg, stats

import skmba._core.linalg as _linalg
from skmba._core.linalg import (
    FactorizationError,
    check_memory,
    cholesky,
    cholesky_inverse,
    smallest_pivot,
    stacked_whitening,
)

GIB = 2**30


# ----------------------------------------------------------------- memory check
def test_check_memory_passes_when_the_allocation_fits(monkeypatch):
    monkeypatch.setattr(_linalg, "_available_memory", lambda: 4 * GIB)
    assert check_memory(4 * GIB, "a matrix", "use fewer points") is None
    assert check_memory(0, "nothing", "none") is None


def test_check_memory_message_gives_sizes_purpose_and_remedy(monkeypatch):
    monkeypatch.setattr(_linalg, "_available_memory", lambda: int(1.5 * GIB))
    with pytest.raises(MemoryError) as info:
        check_memory(
            8 * 20000**2, "the 20000 x 20000 correlation matrix", "Use fewer points."
        )
    message = str(info.value)
    assert message.startswith("the 20000 x 20000 correlation matrix needs 2.9802 GiB")
    assert "only 1.5 GiB is available" in message
    assert message.endswith("Use fewer points.")


def test_check_memory_does_nothing_when_memory_is_unknown(monkeypatch):
    monkeypatch.setattr(_linalg, "_available_memory", lambda: None)
    assert check_memory(2.0**100, "a huge array", "none") is None


@pytest.mark.parametrize("n_bytes", [-1, np.nan, np.inf])
def test_check_memory_rejects_invalid_sizes(n_bytes):
    with pytest.raises(ValueError, match="n_bytes must be finite and >= 0"):
        check_memory(n_bytes, "x", "y")


def test_meminfo_reader_parses_mem_available(tmp_path):
    meminfo = tmp_path / "meminfo"
    meminfo.write_text(
        "MemTotal:       16000000 kB\n"
        "MemFree:         1000000 kB\n"
        "MemAvailable:    8000000 kB\n"
    )
    assert _linalg._meminfo_available(str(meminfo)) == 8000000 * 1024
    meminfo.write_text("MemTotal:       16000000 kB\n")  # old kernels
    assert _linalg._meminfo_available(str(meminfo)) is None
    assert _linalg._meminfo_available(str(tmp_path / "missing")) is None


def test_cgroup_reader_gives_the_room_left_under_the_limit(tmp_path):
    (tmp_path / "memory.max").write_text("1073741824\n")
    (tmp_path / "memory.current").write_text("73741824\n")
    assert _linalg._cgroup_available(str(tmp_path)) == 10**9
    (tmp_path / "memory.current").write_text("2000000000\n")
    assert _linalg._cgroup_available(str(tmp_path)) == 0
    (tmp_path / "memory.max").write_text("max\n")  # no limit
    assert _linalg._cgroup_available(str(tmp_path)) is None
    assert _linalg._cgroup_available(str(tmp_path / "missing")) is None


def test_available_memory_combines_the_sources(monkeypatch):
    monkeypatch.setattr(_linalg, "_meminfo_available", lambda: 8 * GIB)
    monkeypatch.setattr(_linalg, "_cgroup_available", lambda: 2 * GIB)
    assert _linalg._available_memory() == 2 * GIB
    monkeypatch.setattr(_linalg, "_cgroup_available", lambda: None)
    assert _linalg._available_memory() == 8 * GIB
    monkeypatch.setattr(_linalg, "_meminfo_available", lambda: None)
    monkeypatch.setattr(_linalg, "_sysconf_memory", lambda: 3 * GIB)
    assert _linalg._available_memory() == 3 * GIB


def test_this_machine_reports_a_plausible_amount_of_memory():
    available = _linalg._available_memory()
    physical = _linalg._sysconf_memory()
    assert available is None or 0 <= available
    if physical is not None:
        assert physical > 2**20
        if _linalg._meminfo_available() is not None:
            assert available <= physical


# --------------------------------------------------------------- factorisations
def test_factorization_error_names_the_matrix_and_pickles():
    with pytest.raises(FactorizationError, match="increase alpha") as info:
        cholesky(np.ones((3, 3)), what="R", remedy="increase alpha")
    assert info.value.what == "R"
    assert isinstance(info.value, ValueError)
    back = pickle.loads(pickle.dumps(info.value))
    assert back.what == "R" and str(back) == str(info.value)
    assert FactorizationError("plain").what is None


def test_cholesky_rejects_non_finite_matrices():
    with pytest.raises(FactorizationError, match="non-finite"):
        cholesky(np.array([[1.0, np.nan], [np.nan, 1.0]]), what="R")


def test_smallest_pivot_tracks_the_nugget_of_a_singular_correlation():
    X = np.linspace(0, 1, 40)
    R = np.exp(-0.01 * (X[:, None] - X[None, :]) ** 2)  # numerically rank ~3
    for nugget in (1e-4, 1e-6, 1e-8):
        pivot = smallest_pivot(cholesky(R + nugget * np.eye(40)))
        assert nugget <= pivot * (1 + 1e-6) and pivot < 2 * nugget
    # well-conditioned: the pivot is of the order of the smallest eigenvalue
    A = np.array([[2.0, 0.5], [0.5, 1.0]])
    assert np.linalg.eigvalsh(A)[0] <= smallest_pivot(cholesky(A)) <= 1.0
    assert smallest_pivot(np.zeros((0, 0))) == 1.0


@pytest.mark.parametrize("shared", [True, False])
def test_stacked_whitening_equals_one_triangular_solve_per_matrix(shared):
    rng = np.random.default_rng(0)
    k, m, c = 5, 30, 4
    A = rng.normal(size=(k, m, m))
    floor = 0.1
    S = A @ np.swapaxes(A, 1, 2) + floor * np.eye(m)
    Z = rng.normal(size=(m, c)) if shared else rng.normal(size=(k, m, c))
    L, W = stacked_whitening(S, Z, floor)
    for j in range(k):
        L_j = np.linalg.cholesky(S[j])
        np.testing.assert_allclose(L[j], L_j, rtol=1e-12, atol=1e-12)
        Z_j = Z if shared else Z[j]
        expected = linalg.solve_triangular(L_j, Z_j, lower=True)
        np.testing.assert_allclose(W[j], expected, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("floor", [0.0, np.nan])
def test_stacked_whitening_needs_an_eigenvalue_bound(floor):
    S = np.eye(3)[None]
    with pytest.raises(np.linalg.LinAlgError, match="no bound"):
        stacked_whitening(S, np.ones((3, 1)), floor)


def test_stacked_whitening_of_a_matrix_not_positive_definite_raises():
    S = np.diag([1.0, -1.0])[None]
    with pytest.raises(np.linalg.LinAlgError):
        stacked_whitening(S, np.ones((2, 1)), 1.0)


def test_proposal_covariance_keeps_a_positive_definite_one_and_floors_others():
    from skmba._core.linalg import proposal_covariance

    A = np.array([[2.0, 0.3], [0.3, 1.0]])
    np.testing.assert_array_equal(proposal_covariance(A), A)  # bit for bit
    for bad, smallest, largest in (
        (np.ones((2, 2)), 2e-8, 2.0),  # rank one
        (np.array([[1.0, 2.0], [2.0, 1.0]]), 3e-8, 3.0),  # indefinite
        (np.zeros((3, 3)), 1e-8, 1e-8),  # no scale at all: 1e-8 of a unit one
    ):
        C = proposal_covariance(bad)
        values = np.linalg.eigvalsh(C)
        assert values.min() == pytest.approx(smallest, rel=1e-6)
        assert values.max() == pytest.approx(largest, rel=1e-6)
        stats.multivariate_normal(np.zeros(len(C)), C)  # scipy accepts it


# ------------------------------------------------------------ cholesky_inverse
def test_cholesky_inverse_is_the_inverse_and_names_a_singular_factor():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(300, 300))
    S = A @ A.T + 300 * np.eye(300)
    C = cholesky(S)
    inverse = cholesky_inverse(C)
    np.testing.assert_array_equal(inverse, inverse.T)
    np.testing.assert_allclose(
        inverse, linalg.cho_solve((C, True), np.eye(300)), rtol=1e-10, atol=1e-14
    )
    with pytest.raises(
        FactorizationError, match=r"on the noise block.*Add noise"
    ) as info:
        cholesky_inverse(
            np.array([[1.0, 0.0], [1.0, 0.0]]), what="noise block", remedy="Add noise."
        )
    assert info.value.what == "noise block"
