"""Module 3's likelihood through a low-rank model term (the determinant lemma).

Each Schur complement of a mixture is ``S_k(theta) = F_k + M(theta)``: the
draw's fixed part ``F_k`` (discrepancy and noise, factored once per draw)
plus the model term ``M = Sigma_m ⊗ T(theta)``, the emulator's correlation
at the field points given the simulations. Where the emulator knows the
simulator well there, ``M`` has a small numerical rank, and with a factor
``U`` of it (``U U' ~ M``, :func:`model_term_factor`) the matrix
determinant lemma and Woodbury's identity give every draw's likelihood from
one triangular solve with ``F_k``'s factor for all the thetas of a batch
and a Cholesky factorisation of order ``rho + P + 1``
(:func:`low_rank_log_likelihoods`), instead of a factorisation of order
``m + P + 1`` per theta and draw.

The factor is a Rayleigh-Ritz projection of ``M`` on the span of the
columns that a pivoted Cholesky factorisation picks, its eigenvalues below
:data:`LOW_RANK_TOL` times the smallest noise variance dropped: the
pivoted factor's own columns divide rounding noise by small pivots. The
measurements behind it: docs/internals.rst, section
skmba.calibration._module3_mixture. ``tests/calibration/test_module3_low_rank.py``
checks it against the dense path.
"""

import numpy as np
from scipy import linalg

from skmba.calibration._module3_likelihood import regression_log_likelihoods

#: Eigenvalues of the projected model term below this share of the smallest
#: noise variance are dropped; the columns are picked until the remaining
#: diagonal is below it everywhere.
LOW_RANK_TOL = 1e-6
#: The low-rank path is taken when the rank stays within this share of the
#: field block's order (beyond, the dense path costs less).
MAX_RANK_SHARE = 0.25


def model_term_factor(terms, noise_floor):
    """A factor ``U`` (B, m, rho) of the model terms (B, m, m), or None.

    ``U U'`` is the Rayleigh-Ritz projection of each term on the span of
    the columns that a pivoted Cholesky factorisation picks (until every
    remaining diagonal entry is below ``LOW_RANK_TOL * noise_floor``), its
    eigenvalues below that threshold dropped; ``rho`` is the largest rank
    of the batch (zero columns pad the others). None when more than
    ``MAX_RANK_SHARE * m`` columns would be needed, or when the span leaves
    out more than ``m`` thresholds of a term's trace.
    """
    n_terms, m, _ = terms.shape
    threshold = LOW_RANK_TOL * noise_floor
    max_rank = int(MAX_RANK_SHARE * m)
    rows = np.arange(n_terms)
    remaining = np.diagonal(terms, axis1=1, axis2=2).copy()
    columns = np.zeros((n_terms, m, max_rank))
    pivots = np.zeros((n_terms, max_rank), dtype=int)
    picked = 0
    while np.any(remaining.max(axis=1) > threshold):
        if picked == max_rank:
            return None
        p = np.argmax(remaining, axis=1)
        pivot = np.maximum(remaining[rows, p], threshold)
        column = terms[rows, :, p] - np.einsum(
            "bij,bj->bi", columns[:, :, :picked], columns[rows, p, :picked]
        )
        column /= np.sqrt(pivot)[:, None]
        columns[:, :, picked], pivots[:, picked] = column, p
        remaining -= column**2
        remaining[rows, p] = -np.inf  # picked once
        picked += 1
    if picked == 0:
        return np.zeros((n_terms, m, 0))
    spanning = np.take_along_axis(terms, pivots[:, None, :picked], axis=2)
    Q = np.linalg.qr(spanning)[0]
    projected = np.swapaxes(Q, 1, 2) @ terms @ Q
    # What the span leaves out, by its trace: within m thresholds.
    left = np.trace(terms, axis1=1, axis2=2) - np.trace(projected, axis1=1, axis2=2)
    if np.any(left > m * threshold):
        return None
    values, vectors = np.linalg.eigh(projected)
    rank = int(np.max(np.sum(values > threshold, axis=1)))
    kept = np.clip(values[:, picked - rank :], 0.0, None)
    kept[kept <= threshold] = 0.0
    return Q @ (vectors[:, :, picked - rank :] * np.sqrt(kept)[:, None, :])


def fixed_factors(S_fixed):
    """The Cholesky factors of the draws' fixed parts (K, m, m) and their
    log determinants (K,)."""
    L = np.linalg.cholesky(S_fixed)
    return L, 2.0 * np.sum(np.log(np.diagonal(L, axis1=1, axis2=2)), axis=1)


def low_rank_log_likelihoods(factors, log_dets, U, Z, model, draws=None):
    """Eq. 4.30 at every (theta, draw) with ``S_k = F_k + U U'``: (B, K),
    or (B, len(draws)).

    Parameters
    ----------
    factors, log_dets : ndarray of shape (K, m, m) and (K,)
        :func:`fixed_factors` of the draws' fixed parts.
    U : ndarray of shape (B, m, rho)
        :func:`model_term_factor` of the thetas' model terms.
    Z : ndarray of shape (B, m, P + 1)
        The thetas' field rows of ``H_Y`` and of the data.
    model : GlobalModel
        The simulation block (``top``, ``rss_top_perp``, ``log_det_A``)
        and the number of data.
    draws : sequence of int, default=None
        The draws to evaluate, in this order (None: all): the columns of
        the result.

    Raises
    ------
    numpy.linalg.LinAlgError
        When a bordered matrix is not positive definite (field rows of
        lower rank than ``P + 1``): the dense path then says why.
    FactorizationError
        When the regression is rank deficient.
    """
    B, m, rho = U.shape
    c = Z.shape[2]
    rhs = np.concatenate([U, Z], axis=2).transpose(1, 0, 2).reshape(m, -1)
    draws = range(len(factors)) if draws is None else draws
    out = np.empty((B, len(draws)))
    identity = np.eye(rho)
    for j, k in enumerate(draws):
        W = linalg.solve_triangular(factors[k], rhs, lower=True, check_finite=False)
        W = W.reshape(m, B, rho + c).transpose(1, 0, 2)
        gram = np.swapaxes(W, 1, 2) @ W
        gram[:, :rho, :rho] += identity
        F = np.linalg.cholesky(gram)
        log_det_S = log_dets[k] + 2.0 * np.sum(
            np.log(np.diagonal(F[:, :rho, :rho], axis1=1, axis2=2)), axis=1
        )
        # F's trailing block G has G G' = Z' S_k^-1 Z: G' whitens the rows.
        whitened = np.swapaxes(F[:, rho:, rho:], 1, 2)
        out[:, j] = regression_log_likelihoods(
            log_det_S,
            whitened,
            model.top,
            model.rss_top_perp,
            model.log_det_A,
            model.N * model.q + model.n_observed,
        )
    return out
