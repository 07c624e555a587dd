"""Module 2, step 2: the emulator integrated over the prior of theta.

At the field inputs ``X_e`` the model output is unknown because ``theta``
is. Module 2 replaces it by the emulator averaged over the prior (thesis
Eqs. 4.13-4.17)::

    m_bar(x_i)    = ∫ E[y_m(x_i, θ) | D_m] p(θ) dθ                     (4.14)
    V_cond[i, j]  = ∫ Cov[y_m(x_i, θ), y_m(x_j, θ) | D_m] p(θ) dθ       (4.15)
                  = Sigma_m ⊗ ∫ c(x_i, x_j; θ) p(θ) dθ                  (4.17)

where ``c`` is the emulator's universal-kriging correlation at the two
points with the same ``θ``. Eq. 4.15 keeps only this conditional
covariance. The law of total variance also adds the spread of the emulator
mean over the prior,

    V_spread[(i, a), (j, b)] = ∫ (m_a(x_i, θ) - m_bar_a(x_i))
                                 (m_b(x_j, θ) - m_bar_b(x_j)) p(θ) dθ,

which tells the discrepancy GP how much of the field data the unknown
``theta`` can already explain; :func:`integrate_emulator` returns both.

The integrals use the prior's nodes and weights (Gauss-Legendre on the
prior quantiles for one parameter, scrambled Sobol points for several, see
:mod:`skmba._priors`), vectorised over nodes and parallel over blocks of
nodes through joblib.

Examples
--------
>>> import numpy as np
>>> from skmba._integration import weighted_moments
>>> mean, spread = weighted_moments(np.array([[[1.0]], [[3.0]]]), np.array([0.5, 0.5]))
>>> mean.ravel(), spread.ravel()
(array([2.]), array([1.]))
"""

import numpy as np
from joblib import Parallel, delayed
from scipy import linalg
from threadpoolctl import threadpool_limits

from skmba._regression import regression_basis

# Bytes of the (k, n, n) correlation temporaries of one block of nodes: the
# number of nodes per block is lowered so that they stay below this.
BLOCK_BYTES = 64 * 2**20


def nodes_per_block(n, block=64):
    """Number of integration nodes per block for ``n`` field inputs.

    At most ``block``, and few enough that a block's three (k, n, n)
    temporaries fit in :data:`BLOCK_BYTES`. It depends on the problem only
    (never on ``n_jobs``), so the blocks, hence the bits, are the same for
    any ``n_jobs``.

    Examples
    --------
    >>> nodes_per_block(20), nodes_per_block(1000)
    (64, 2)
    """
    return int(max(1, min(block, BLOCK_BYTES // (3 * 8 * max(n, 1) ** 2))))


def _node_block(state, kernel, regression, X_m, X_e, nodes, weights):
    """Emulator means (k, n, q) at the nodes and ``sum_k w_k c_k`` (n, n).

    BLAS is held to one thread, so that a block gives the same bits in any
    joblib worker (process or thread) as in the calling process.
    """
    with threadpool_limits(limits=1, user_api="blas"):
        means, corr = _node_block_body(state, kernel, regression, X_m, X_e, nodes)
        return means, np.tensordot(weights, corr, axes=1)


def _node_block_body(state, kernel, regression, X_m, X_e, nodes):
    n = len(X_e)
    k = len(nodes)
    points = np.hstack([np.tile(X_e, (k, 1)), np.repeat(nodes, n, axis=0)])
    r_cross = kernel(X_m, points)  # (N, k n)
    h_star = regression_basis(points, regression)
    g = state.gls
    Rt = linalg.solve_triangular(state.C, r_cross, lower=True)
    means = (h_star @ g.beta + Rt.T @ g.residual).reshape(k, n, -1)
    u = h_star.T - g.H_white.T @ Rt
    ut = linalg.solve_triangular(g.G, u, trans="T")
    Rt = Rt.reshape(-1, k, n)
    ut = ut.reshape(-1, k, n)
    # Prior correlation at (x_i, θ) and (x_j, θ): the θ-part is exactly 1
    # for stationary kernels, but evaluate it to accept any kernel.
    prior = np.stack([kernel(points[i * n : (i + 1) * n]) for i in range(k)])
    corr = prior - np.einsum("mki,mkj->kij", Rt, Rt) + np.einsum("mki,mkj->kij", ut, ut)
    return means, corr


def weighted_moments(values, weights):
    """Weighted mean and covariance over the first axis.

    Parameters
    ----------
    values : ndarray of shape (k, n, q)
    weights : ndarray of shape (k,)
        Non-negative, summing to one.

    Returns
    -------
    mean : ndarray of shape (n, q)
    spread : ndarray of shape (n q, n q)
        ``sum_k w_k (v_k - mean)(v_k - mean)'`` with ``v_k`` vectorised
        response-slowest (``vec`` of the (n, q) array), matching
        ``Sigma ⊗ R`` layouts.
    """
    mean = np.tensordot(weights, values, axes=1)
    centred = (values - mean).transpose(0, 2, 1).reshape(len(weights), -1)
    spread = (centred * weights[:, None]).T @ centred
    return mean, spread


def integrate_emulator(
    state, kernel, regression, X_m, X_e, nodes, weights, *, n_jobs=None, block=64
):
    """Prior-integrated emulator moments at the field inputs (Eqs. 4.14-4.17).

    Parameters
    ----------
    state : NoiseFreeLikelihood
        Fitted module-1 emulator (standardised units).
    kernel : sklearn Kernel
        Fitted module-1 correlation.
    regression : str
        Module-1 regression basis.
    X_m : ndarray of shape (N, d + r)
        Simulation inputs.
    X_e : ndarray of shape (n, d)
        Field inputs.
    nodes : ndarray of shape (k, r)
    weights : ndarray of shape (k,)
    n_jobs : int, default=None
        Blocks of nodes run in parallel through joblib. The blocks are fixed
        by ``block`` and ``n``, not by ``n_jobs``, and each is computed with
        one BLAS thread: the result is bit-identical for any ``n_jobs`` and
        backend.
    block : int, default=64
        Largest number of nodes per block (lowered for many field inputs,
        see :func:`nodes_per_block`). Each block returns its weighted sum of
        correlations, so the memory is that of the blocks in flight, not of
        all nodes.

    Returns
    -------
    mean : ndarray of shape (n, q)
        ``m_bar`` of Eq. 4.14.
    cond_corr : ndarray of shape (n, n)
        The integrated correlation of Eq. 4.17: the conditional covariance of
        Eq. 4.15 is ``Sigma_m ⊗ cond_corr``.
    spread : ndarray of shape (n q, n q)
        The covariance of the emulator mean over the prior (law of total
        variance), ``vec`` ordering response-slowest.
    """
    block = nodes_per_block(len(X_e), block)
    starts = range(0, len(nodes), block)
    parts = Parallel(n_jobs=n_jobs)(
        delayed(_node_block)(
            state,
            kernel,
            regression,
            X_m,
            X_e,
            nodes[s : s + block],
            weights[s : s + block],
        )
        for s in starts
    )
    means = np.concatenate([p[0] for p in parts])
    mean, spread = weighted_moments(means, weights)
    cond_corr = parts[0][1]
    for part in parts[1:]:  # in block order, whatever finished first
        cond_corr = cond_corr + part[1]
    return mean, 0.5 * (cond_corr + cond_corr.T), 0.5 * (spread + spread.T)
