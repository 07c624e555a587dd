"""The module-3 log likelihood of Eq. 4.30 at many values at once.

The global model's covariance ``V_Y`` is factored through its simulation
block ``A`` (the same for every theta and module-2 draw) and the Schur
complement ``S = D - B' A^-1 B`` of its field block (see
:class:`~skmba.calibration._module3_likelihood.GlobalModel`). With the simulation block
whitened and reduced once to the R factor ``G_top`` of its regression
rows and the projection ``b_top`` of its data, what changes with theta (or
with the module-2 hyperparameters, or the responses measured) is the
stack of ``S_k`` and of ``Z_k``, the field rows of the regression matrix
``H_Y`` and of the data after the simulation block is eliminated.
:func:`schur_log_likelihoods` factors a whole stack in one batched
Cholesky (:func:`~skmba._core.linalg.stacked_whitening`) and one batched QR:
the calibrator's sampler (many theta, many module-2 draws) and the sensor
designer (many response subsets, many theta) share it.

Examples
--------
``tests/calibration/test_module3_batch_likelihood.py`` checks it
against the dense Eq. 4.30; ``tests/calibration/test_module3_mixture.py`` and
``tests/sensor_design/test_subset_likelihood.py`` against
:class:`~skmba.calibration._module3_likelihood.GlobalModel`.
"""

import numpy as np
from scipy import linalg

from skmba._core.linalg import LOG_2PI, FactorizationError, stacked_whitening

#: The message of a rank-deficient global regression matrix.
RANK_DEFICIENT = (
    "The global regression matrix H_Y(theta) is rank deficient: use "
    "lower-order regressions for the model or the discrepancy."
)
#: A diagonal entry of the regression's R factor below this fraction of
#: the largest makes the regression rank deficient.
RANK_TOLERANCE = 1e-10


def schur_log_likelihoods(S, Z, eigenvalue_floor, top, rss_top_perp, log_det_A, n_data):
    """``log p(data)`` with the regression coefficients integrated out, per ``k``.

    ``-0.5 [(M - P) log 2 pi + log|A| + log|S_k| + log|H_Y' V_Y^-1 H_Y| +
    rss_k]`` (Eq. 4.30) from the R factor of the stacked whitened
    regression and data ``[[G_top, b_top], [L_k^-1 Z_k]]``: its leading
    ``P x P`` block is that of the whitened regression, and its last
    diagonal entry the norm of the residual beyond the simulations' own
    (``rss_top_perp``).

    Parameters
    ----------
    S : ndarray of shape (k, m, m)
        Schur complements of the field block.
    Z : ndarray of shape (k, m, P + 1)
        Field rows of ``H_Y`` and of the data, simulation block eliminated.
    eigenvalue_floor : float
        A lower bound of the smallest eigenvalue of every ``S_k`` (the
        smallest noise variance).
    top : ndarray of shape (t, P + 1)
        ``[G_top, b_top]`` of the whitened simulation block.
    rss_top_perp : float
        Residual sum of squares of the simulation block beyond ``b_top``.
    log_det_A : float
        ``log |A|``.
    n_data : int
        ``M``, the number of data (simulated and measured entries).

    Returns
    -------
    ndarray of shape (k,)
        ``-inf`` where ``S_k`` is not positive definite.

    Raises
    ------
    FactorizationError
        When the regression is rank deficient at some ``k``.
    """
    k = len(S)
    out = np.full(k, -np.inf)
    ok = np.ones(k, dtype=bool)
    try:
        L, W = stacked_whitening(S, Z, eigenvalue_floor)
    except np.linalg.LinAlgError:
        # One by one: the k where S_k is not positive definite are -inf.
        L, W = np.zeros_like(S), np.zeros_like(Z)
        for j in range(k):
            try:
                L[j] = np.linalg.cholesky(S[j])
            except np.linalg.LinAlgError:
                ok[j] = False
                continue
            W[j] = linalg.solve_triangular(L[j], Z[j], lower=True)
        if not ok.any():
            return out
        L, W = L[ok], W[ok]
    log_det_S = 2.0 * np.sum(np.log(np.diagonal(L, axis1=1, axis2=2)), axis=1)
    out[ok] = regression_log_likelihoods(
        log_det_S, W, top, rss_top_perp, log_det_A, n_data
    )
    return out


def regression_log_likelihoods(log_det_S, W, top, rss_top_perp, log_det_A, n_data):
    """Eq. 4.30 from whitened field rows, the regression integrated out.

    The last step of :func:`schur_log_likelihoods`, shared with the
    designer's prefix tree of response subsets
    (:func:`~skmba.sensor_design._subset_tree.subset_tree_log_likelihoods`), which
    whitens the field rows block by block.

    Parameters
    ----------
    log_det_S : ndarray of shape (k,)
        ``log |S_k|``.
    W : ndarray of shape (k, m, P + 1)
        Whitened field rows ``F_k^-1 Z_k``, for any square root ``F_k``
        (``F_k F_k' = S_k``).
    top, rss_top_perp, log_det_A, n_data
        As :func:`schur_log_likelihoods`.

    Returns
    -------
    ndarray of shape (k,)

    Raises
    ------
    FactorizationError
        When the regression is rank deficient at some ``k``.
    """
    P = W.shape[2] - 1
    stacked = np.concatenate([np.broadcast_to(top, (len(W), *top.shape)), W], axis=1)
    R = np.linalg.qr(stacked, mode="r")
    diag = np.abs(np.diagonal(R[:, :P, :P], axis1=1, axis2=2))
    if np.any(diag.min(axis=1) <= RANK_TOLERANCE * diag.max(axis=1)):
        raise FactorizationError(RANK_DEFICIENT)
    rss = rss_top_perp + R[:, P, P] ** 2
    return -0.5 * (
        (n_data - P) * LOG_2PI
        + log_det_A
        + log_det_S
        + 2.0 * np.sum(np.log(diag), axis=1)
        + rss
    )


#: Bytes of bordered matrices that one stacked factorisation may hold (the
#: chunks of :func:`stack_chunks`). Stacks that stay in the processor's
#: cache factor fastest: on the thesis' 4.7.3 set-up (orders of 147, one
#: module-2 draw, one thread) one theta took 0.43 ms on its own, 0.25 ms in
#: stacks of 1-2 MiB, 0.34 ms of 16 MiB and 1.5 ms of 64 MiB.
STACK_BYTES = 2**20


def stack_chunks(n_values, per_value, m, c):
    """Slices of ``range(n_values)`` whose stacks fit :data:`STACK_BYTES`.

    Each value (a theta) stacks ``per_value`` bordered matrices of order
    ``m + c`` (:func:`~skmba._core.linalg.stacked_whitening`); a chunk holds at
    least one value.

    Examples
    --------
    >>> stack_chunks(5, 1, 150, 3)
    [slice(0, 5, None)]
    >>> stack_chunks(3, 4, 300, 3)
    [slice(0, 1, None), slice(1, 2, None), slice(2, 3, None)]
    """
    size = max(1, STACK_BYTES // (8 * per_value * (m + c) ** 2))
    return [slice(i, min(n_values, i + size)) for i in range(0, n_values, size)]
