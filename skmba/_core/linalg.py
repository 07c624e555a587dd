"""Factorisations used by every Gaussian process in :mod:`skmba`.

This module is the one home of the Cholesky, QR and Kronecker-eigen
factorisations (thesis appendix C). No explicit matrix inverse is formed to
solve a system anywhere in the package.

* :func:`cholesky` factors a symmetric positive definite matrix and turns a
  failure into a :class:`FactorizationError` that names the remedy.
* :func:`whitened_gls` solves the generalised least squares problem
  ``H beta ~ Y`` with covariance ``C C'`` by whitening with ``C`` and an
  economy QR of the whitened regression matrix (Eqs. C.2-C.4, C.16).
* :class:`KroneckerEigen` diagonalises ``Sigma2 ⊗ R + Lambda ⊗ I`` (Lambda
  diagonal) from the eigendecompositions of ``R`` (N x N) and of
  ``Lambda^-1/2 Sigma2 Lambda^-1/2`` (q x q), so that solves, determinants and
  gradients cost O(N^3 + q^3) instead of O((Nq)^3).
* :func:`cholesky_inverse`: ``(C C')^-1``, only for gradients' trace terms.
* :func:`check_memory` refuses, before anything is allocated, a planned
  allocation larger than the memory the machine has available.
* :func:`observed_entries`, :func:`observed_rows` and
  :func:`observed_block` restrict a field-data vector, its regression rows
  and its covariance to the entries that were measured (field data with
  gaps).

Examples
--------
>>> import numpy as np
>>> from skmba._core.linalg import cholesky, whitened_gls
>>> R = np.array([[1.0, 0.5], [0.5, 1.0]])
>>> C = cholesky(R, what="R")
>>> fit = whitened_gls(C, np.ones((2, 1)), np.array([[1.0], [3.0]]))
>>> fit.beta
array([[2.]])
"""

import os
from dataclasses import dataclass

import numpy as np
from joblib import effective_n_jobs
from scipy import linalg
from scipy.linalg import lapack

from skmba._core.workspace import scratch

#: ``log(2 pi)``, the constant of every Gaussian log-density in the package.
LOG_2PI = float(np.log(2.0 * np.pi))
_GIB = float(2**30)
#: Bytes of a float64, for the memory budgets of :func:`check_memory`.
FLOAT_BYTES = 8
#: The remedy when the field data make a module's matrices too large.
FEWER_FIELD_DATA = (
    "Use fewer field observations or responses (average repeated "
    "measurements, or calibrate on a subset of the responses), or a smaller "
    "n_jobs."
)


class FactorizationError(np.linalg.LinAlgError):
    """A matrix that must be positive definite could not be factored.

    Subclass of :class:`numpy.linalg.LinAlgError` (itself a ``ValueError``);
    the message says which matrix failed and what to change.

    Parameters
    ----------
    message : str
    what : str, optional
        Name of the matrix that failed (as passed to :func:`cholesky`), so
        that a caller can tell, e.g., a singular correlation matrix (which a
        larger nugget repairs) from a singular response covariance (which it
        does not).

    Examples
    --------
    >>> import numpy as np
    >>> try:
    ...     cholesky(np.ones((2, 2)), what="R", remedy="increase alpha")
    ... except FactorizationError as exc:
    ...     print("increase alpha" in str(exc), exc.what)
    True R
    """

    def __init__(self, message="", *, what=None):
        super().__init__(message)
        self.what = what


def cholesky(A, *, what="matrix", remedy=None):
    """Lower Cholesky factor of a symmetric positive definite matrix.

    Parameters
    ----------
    A : ndarray of shape (n, n)
    what : str
        Name of the matrix, used in the error message.
    remedy : str, optional
        What the user can change when the factorisation fails.

    Returns
    -------
    C : ndarray of shape (n, n)
        Lower triangular with ``C @ C.T == A``.

    Raises
    ------
    FactorizationError
        When ``A`` is not (numerically) positive definite or not finite.

    Examples
    --------
    >>> import numpy as np
    >>> cholesky(np.array([[4.0, 2.0], [2.0, 2.0]]))
    array([[2., 0.],
           [1., 1.]])
    """
    try:
        if not np.all(np.isfinite(A)):
            raise np.linalg.LinAlgError("non-finite entries")
        return linalg.cholesky(A, lower=True, check_finite=False)
    except np.linalg.LinAlgError as exc:
        message = f"The {what} is not positive definite ({exc})."
        if remedy:
            message += f" {remedy}"
        raise FactorizationError(message, what=what) from exc


def cholesky_inverse(C, *, what="matrix", remedy=None):
    """``(C C')^-1`` from its lower Cholesky factor by LAPACK potri (``2 m^3 / 3``
    flops), for the trace terms of likelihood gradients; a failure raises
    :class:`FactorizationError` naming ``what`` and ``remedy``."""
    inv, info = lapack.dpotri(C, lower=1)
    if info != 0:
        message = f"LAPACK dpotri failed on the {what} (info={info}). {remedy or ''}"
        raise FactorizationError(message.strip(), what=what)
    inv = np.tril(inv)  # symmetrised in place: two m x m arrays at most
    inv += np.tril(inv, -1).T
    return inv


def stacked_whitening(S, Z, eigenvalue_floor):
    """Cholesky factors of a stack ``S_k`` and the whitened ``L_k^-1 Z_k``.

    One batched Cholesky factorisation of the bordered matrices
    ``[[S_k, Z_k], [Z_k', c_k I]]`` gives both ``L_k`` (its leading block)
    and ``(L_k^-1 Z_k)'`` (its lower-left block), which would otherwise take
    a triangular solve per matrix (numpy has no batched one). ``c_k`` exceeds
    ``||Z_k||_F^2 / lambda_min(S_k)``: the bordered matrices are positive
    definite when the ``S_k`` are. They are built in a ``scratch`` buffer.

    Parameters
    ----------
    S : ndarray of shape (k, m, m)
        Symmetric positive definite matrices.
    Z : ndarray of shape (m, c) or (k, m, c)
        Right-hand sides (one for all, or one per matrix).
    eigenvalue_floor : float
        A lower bound of every ``lambda_min(S_k)`` (e.g. the smallest noise
        variance, when the other terms are positive semi-definite).

    Returns
    -------
    L : ndarray of shape (k, m, m)
    W : ndarray of shape (k, m, c)
        ``L_k^-1 Z_k``.

    Raises
    ------
    numpy.linalg.LinAlgError
        When an ``S_k`` is not positive definite or ``eigenvalue_floor``
        gives no bound (zero or not finite).

    Examples
    --------
    >>> import numpy as np
    >>> S = np.array([[[4.0, 2.0], [2.0, 2.0]]])
    >>> L, W = stacked_whitening(S, np.array([[2.0], [1.0]]), 1.0)
    >>> L[0].tolist(), W[0].ravel().tolist()
    ([[2.0, 0.0], [1.0, 1.0]], [1.0, 0.0])
    """
    k, m = S.shape[:2]
    Z = np.broadcast_to(Z, (k, *Z.shape[-2:]))
    c = Z.shape[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        border = 2.0 * np.sum(Z**2, axis=(1, 2)) / eigenvalue_floor + 1.0
    if not (eigenvalue_floor > 0 and np.all(np.isfinite(border))):
        raise np.linalg.LinAlgError("no bound on the bordered matrix")
    bordered = scratch((k, m + c, m + c))
    bordered[:, :m, :m] = S
    bordered[:, :m, m:] = Z
    bordered[:, m:, :m] = np.swapaxes(Z, 1, 2)
    bordered[:, m:, m:] = border[:, None, None] * np.eye(c)
    factor = np.linalg.cholesky(bordered)
    return factor[:, :m, :m], np.swapaxes(factor[:, m:, :m], 1, 2)


def kron_sum(*pairs):
    """``sum_t A_t ⊗ B_t`` for square ``A_t`` (q, q) and ``B_t`` of one shape.

    Assembled block by block, ``q^2`` scaled copies of the ``B_t``: for the
    small ``q`` of responses this is several times faster than ``np.kron``
    or a four-dimensional broadcast (0.5 against 2-3 ms for two 4 x 4 by
    100 x 100 terms).

    Examples
    --------
    >>> import numpy as np
    >>> A, B = np.array([[1.0, 2.0], [3.0, 4.0]]), np.eye(2)
    >>> bool(np.array_equal(kron_sum((A, B), (A, B)), 2 * np.kron(A, B)))
    True
    """
    (A0, B0), rest = pairs[0], pairs[1:]
    q, (a, b) = len(A0), B0.shape
    out = np.empty((q, a, q, b))
    for i in range(q):
        for j in range(q):
            block = out[i, :, j, :]
            np.multiply(A0[i, j], B0, out=block)
            for A, B in rest:
                block += A[i, j] * B
    return out.reshape(q * a, q * b)


def log_det_from_cholesky(C):
    """``log |C C'|`` from a Cholesky factor ``C``.

    Examples
    --------
    >>> import numpy as np
    >>> round(float(log_det_from_cholesky(np.diag([2.0, 3.0]))), 6)
    3.583519
    """
    return 2.0 * np.sum(np.log(np.diag(C)))


def smallest_pivot(C):
    """Smallest squared diagonal entry of a Cholesky factor ``C``.

    A cheap diagnostic of near-singularity: for ``A = C C'``,
    ``min_i C_ii^2`` is the smallest conditional variance of one entry given
    the preceding ones, at least the smallest eigenvalue of ``A`` and usually
    of its order. For a correlation matrix with nugget ``alpha`` it is close
    to ``alpha`` when only the nugget keeps the matrix positive definite.

    Examples
    --------
    >>> import numpy as np
    >>> R = np.array([[1.0, 0.999], [0.999, 1.0]])
    >>> round(float(smallest_pivot(cholesky(R))), 6)
    0.001999
    """
    return float(np.min(np.diag(C)) ** 2) if C.size else 1.0


def _meminfo_available(path="/proc/meminfo"):
    """``MemAvailable`` of ``/proc/meminfo`` in bytes (Linux), else None."""
    try:
        with open(path) as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def _cgroup_available(directory="/sys/fs/cgroup"):
    """Memory left under a cgroup v2 limit (containers) in bytes, else None."""
    try:
        with open(os.path.join(directory, "memory.max")) as handle:
            limit = handle.read().strip()
        if limit == "max":
            return None
        with open(os.path.join(directory, "memory.current")) as handle:
            current = int(handle.read().strip())
        return max(int(limit) - current, 0)
    except (OSError, ValueError):
        return None


def _sysconf_memory():
    """Physical memory from ``os.sysconf`` in bytes, else None."""
    try:
        pages = os.sysconf("SC_PHYS_PAGES")
        size = os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None
    if pages <= 0 or size <= 0:
        return None
    return int(pages) * int(size)


def _available_memory():
    """Bytes available for new allocations, or None when unknown.

    Linux: ``MemAvailable`` of ``/proc/meminfo``, lowered to what is left
    under a cgroup v2 memory limit (containers) when there is one. Elsewhere:
    the physical memory ``os.sysconf("SC_PHYS_PAGES") * SC_PAGE_SIZE``.
    """
    available = _meminfo_available()
    if available is None:
        return _sysconf_memory()
    limit = _cgroup_available()
    return available if limit is None else min(available, limit)


def n_workers(n_jobs):
    """Tasks joblib runs at the same time for ``n_jobs`` (and its context).

    Examples
    --------
    >>> n_workers(1)
    1
    """
    return max(1, effective_n_jobs(n_jobs))


def check_memory(n_bytes, what, remedy):
    """Refuse a planned allocation larger than the available memory.

    Call it *before* allocating: a large dense matrix that does not fit
    makes the machine swap or the process killed, losing the work done so
    far; a :class:`MemoryError` with the size and the remedy does not.

    Parameters
    ----------
    n_bytes : int or float
        Size of the planned allocation in bytes (e.g. ``8 * n * n`` for an
        ``n x n`` float64 matrix; include the temporaries that are alive at
        the same time).
    what : str
        What the memory is for, e.g. ``"the 20000 x 20000 correlation
        matrix"``; it starts the error message.
    remedy : str
        What the user can change to need less memory.

    Returns
    -------
    None

    Raises
    ------
    MemoryError
        When ``n_bytes`` exceeds the available memory. The message gives the
        size needed and the memory available in GiB, ``what`` and ``remedy``.
    ValueError
        When ``n_bytes`` is negative or not finite.

    Notes
    -----
    The available memory is ``MemAvailable`` of ``/proc/meminfo`` on Linux
    (lowered to the room left under a cgroup v2 memory limit, as in
    containers), otherwise the physical memory
    ``os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")``. When
    neither can be read, nothing is checked.

    Examples
    --------
    >>> check_memory(8 * 100 * 100, "a 100 x 100 matrix", "Use fewer points.")
    >>> check_memory(2**80, "a 2**38 x 2**38 matrix", "Use fewer points.")
    Traceback (most recent call last):
    ...
    MemoryError: a 2**38 x 2**38 matrix needs 1.1259e+15 GiB of memory, but only ... GiB is available. Use fewer points.
    """  # noqa: E501
    n_bytes = float(n_bytes)
    if not np.isfinite(n_bytes) or n_bytes < 0:
        raise ValueError(f"n_bytes must be finite and >= 0, got {n_bytes!r}.")
    available = _available_memory()
    if available is None or n_bytes <= available:
        return
    raise MemoryError(
        f"{what} needs {n_bytes / _GIB:.5g} GiB of memory, but only "
        f"{available / _GIB:.3g} GiB is available. {remedy}"
    )


@dataclass
class GLSFit:
    """Result of :func:`whitened_gls` (all quantities whitened by ``C``).

    Attributes
    ----------
    H_white : ndarray of shape (n, p)
        ``C^-1 H``.
    Q : ndarray of shape (n, p)
        Orthonormal factor of the economy QR of ``H_white``.
    G : ndarray of shape (p, p)
        Upper triangular factor, ``H_white = Q G`` (the thesis' ``G'``), so
        that ``H' R^-1 H = G' G``.
    beta : ndarray of shape (p, q)
        The generalised least squares coefficients.
    residual : ndarray of shape (n, q)
        Whitened residual ``C^-1 (Y - H beta)``.
    """

    H_white: np.ndarray
    Q: np.ndarray
    G: np.ndarray
    beta: np.ndarray
    residual: np.ndarray


def whitened_gls(C, H, Y):
    """Generalised least squares with covariance ``C C'`` (Eqs. C.2-C.4, C.16).

    Parameters
    ----------
    C : ndarray of shape (n, n)
        Lower Cholesky factor of the correlation (or covariance) matrix.
    H : ndarray of shape (n, p)
        Regression matrix.
    Y : ndarray of shape (n, q)
        Responses (one column per response).

    Returns
    -------
    GLSFit

    Raises
    ------
    FactorizationError
        When the whitened regression matrix is rank deficient (fewer distinct
        inputs than regression terms, or collinear inputs).

    Examples
    --------
    >>> import numpy as np
    >>> fit = whitened_gls(np.eye(3), np.ones((3, 1)), np.array([[1.0], [2.0], [6.0]]))
    >>> fit.beta, fit.residual.ravel()
    (array([[3.]]), array([-2., -1.,  3.]))
    """
    H_white = linalg.solve_triangular(C, H, lower=True, check_finite=False)
    Y_white = linalg.solve_triangular(C, Y, lower=True, check_finite=False)
    Q, G = linalg.qr(H_white, mode="economic", check_finite=False)
    diag = np.abs(np.diag(G))
    if diag.size and diag.min() <= 1e-10 * max(diag.max(), 1.0):
        raise FactorizationError(
            "The regression matrix H is rank deficient after whitening: the "
            f"{H.shape[1]} regression terms cannot be identified from these "
            "inputs. Use a lower-order regression ('constant' or 'linear'), "
            "or provide more distinct input points."
        )
    beta = linalg.solve_triangular(G, Q.T @ Y_white, check_finite=False)
    residual = Y_white - H_white @ beta
    return GLSFit(H_white=H_white, Q=Q, G=G, beta=beta, residual=residual)


def proposal_covariance(cov, floor=1e-8):
    """``cov`` when it is positive definite, else with its eigenvalues floored.

    For the covariance of a proposal (an importance or quadrature rule's
    Gaussian or Student-t): any positive definite matrix is a valid
    proposal, so a singular or slightly indefinite estimate (a posterior
    concentrated on a ridge, nearly dependent responses) gets its eigenvalues
    raised to ``floor`` times the largest (above scipy's own singularity
    tolerance, 2.2e-10 times the largest) instead of an error. Returned
    unchanged, bit for bit, when its Cholesky factor exists.

    Examples
    --------
    >>> C = proposal_covariance(np.ones((2, 2)))
    >>> bool(np.all(np.linalg.eigvalsh(C) > 0))
    True
    """
    cov = np.atleast_2d(np.asarray(cov, dtype=float))
    try:
        np.linalg.cholesky(cov)
        return cov
    except np.linalg.LinAlgError:
        pass
    values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))
    finite = np.isfinite(values)
    top = values[finite].max() if finite.any() else 1.0
    top = top if top > 0 else 1.0
    values = np.where(finite, np.maximum(values, floor * top), top)
    return (vectors * values) @ vectors.T


def symmetric_eigh(R, *, what="correlation matrix", rtol=1e-8):
    """Eigendecomposition of a symmetric positive semi-definite matrix.

    Round-off negative eigenvalues (above ``-rtol * max eigenvalue``) are set
    to zero; clearly negative ones raise :class:`FactorizationError`, since
    the kernel is then not a valid correlation for these inputs.

    Returns
    -------
    s : ndarray of shape (n,)
        Eigenvalues, ascending, non-negative.
    U : ndarray of shape (n, n)
        Orthonormal eigenvectors (columns).

    Examples
    --------
    >>> import numpy as np
    >>> s, U = symmetric_eigh(np.array([[2.0, 1.0], [1.0, 2.0]]))
    >>> s
    array([1., 3.])
    """
    if not np.all(np.isfinite(R)):
        raise FactorizationError(f"The {what} has non-finite entries.", what=what)
    s, U = linalg.eigh(R, check_finite=False)
    scale = max(abs(s[-1]), 1e-300)
    if s[0] < -rtol * scale:
        raise FactorizationError(
            f"The {what} is not positive semi-definite (smallest eigenvalue "
            f"{s[0]:.3g}). The kernel is not a valid correlation for these "
            "inputs: use Gauss, Exp or GeneralizedExp, which are positive "
            "definite in any dimension.",
            what=what,
        )
    return np.clip(s, 0.0, None), U


class KroneckerEigen:
    """Diagonalisation of ``V = Sigma2 ⊗ R + diag(lam) ⊗ I_N``.

    With ``R = U diag(s) U'`` and ``diag(lam)^-1/2 Sigma2 diag(lam)^-1/2 =
    W diag(e) W'``,

    ``V = (M^-T ⊗ U) diag(1 + e ⊗ s) (M^-1 ⊗ U')`` with ``M = diag(lam)^-1/2 W``,

    so ``V^-1 = (M ⊗ U) diag(w) (M' ⊗ U')`` with ``w = 1 / (1 + s e')``
    arranged as an (N, q) array, and ``log|V| = N sum(log lam) - sum(log w)``.
    Here ``vec`` stacks columns, so the (N, q) array ``Y`` has ``vec(Y)`` with
    the response index varying slowest, matching ``Sigma2 ⊗ R``.

    Parameters
    ----------
    s, U : ndarray
        Eigendecomposition of ``R`` (see :func:`symmetric_eigh`).
    sigma2 : ndarray of shape (q, q)
        Symmetric positive semi-definite cross-response covariance.
    lam : ndarray of shape (q,)
        Positive noise variances.

    Examples
    --------
    >>> import numpy as np
    >>> R = np.array([[1.0, 0.3], [0.3, 1.0]])
    >>> S = np.array([[2.0, 0.5], [0.5, 1.0]])
    >>> lam = np.array([0.1, 0.2])
    >>> ke = KroneckerEigen(*symmetric_eigh(R), S, lam)
    >>> V = np.kron(S, R) + np.kron(np.diag(lam), np.eye(2))
    >>> bool(np.isclose(ke.log_det, np.linalg.slogdet(V)[1]))
    True
    """

    def __init__(self, s, U, sigma2, lam):
        lam = np.asarray(lam, dtype=float)
        if np.any(lam <= 0) or not np.all(np.isfinite(lam)):
            raise FactorizationError(
                "The noise variances must be positive and finite to use the "
                "Kronecker-eigen factorisation."
            )
        root = np.sqrt(lam)
        scaled = sigma2 / np.outer(root, root)
        e, W = linalg.eigh(0.5 * (scaled + scaled.T), check_finite=False)
        self.s = s
        self.U = U
        self.lam = lam
        self.e = np.clip(e, 0.0, None)
        self.W = W
        self.M = W / root[:, None]  # Lambda^-1/2 W
        self.G = W * root[:, None]  # Lambda^1/2 W, so Sigma2 = G diag(e) G'
        self.w = 1.0 / (1.0 + np.outer(s, self.e))  # (N, q)
        self.log_det = s.size * np.sum(np.log(lam)) - np.sum(np.log(self.w))

    def to_eigenbasis(self, Y):
        """``U' Y M``: the (N, q) coordinates in which ``V`` is diagonal."""
        return self.U.T @ Y @ self.M


# ------------------------------------------------------------ missing entries
def observed_entries(Y):
    """Positions of the observed (finite) entries of ``vec(Y)``, or None.

    ``vec`` is response-slowest, as every field-data vector of the package:
    entry ``(i, j)`` of an (n, q) ``Y`` is position ``j n + i``. None when
    every entry is observed: the callers then keep their full (and, where
    they have one, Kronecker) path.

    Examples
    --------
    >>> observed_entries(np.array([[1.0, np.nan], [2.0, 3.0]]))
    array([0, 1, 3])
    >>> observed_entries(np.ones((2, 2))) is None
    True
    """
    mask = np.isfinite(np.asarray(Y, dtype=float)).T.ravel()
    return None if mask.all() else np.flatnonzero(mask)


def observed_rows(A, observed):
    """The rows of ``A`` (indexed like ``vec(Y)``) at the observed entries."""
    return A if observed is None else A[observed]


def observed_block(S, observed):
    """The block of the covariance ``S`` of ``vec(Y)`` between observed entries."""
    return S if observed is None else S[np.ix_(observed, observed)]
