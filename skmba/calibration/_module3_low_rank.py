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

from skmba._core.triangular import lower_solve
from skmba.calibration._module3_likelihood import RANK_TOLERANCE, regression_terms

#: Eigenvalues of the projected model term below this share of the smallest
#: noise variance are dropped; the columns are picked until the remaining
#: diagonal is below it everywhere.
LOW_RANK_TOL = 1e-6
#: The low-rank path is taken while its flops per (theta, draw) stay within
#: this many times the dense path's (:func:`max_low_rank`), for field blocks
#: of order up to :data:`COST_ORDER`; above, the bound falls towards one as
#: ``(COST_ORDER / m)^2`` (the dense path's factorisations of larger order
#: run more flops per second). Measured crossovers: docs/internals.rst,
#: section skmba.calibration._module3_mixture.
COST_RATIO = 2.5
COST_ORDER = 75
#: Where a regression column's diagonal entry in the factor falls below this
#: share of the column's norm (the sine of its angle to the columns before
#: it), the Gram matrix's rounding (the square of the columns') could
#: misjudge the rank: the dense path's QR decides. It decides too where the
#: entries span more than its own ``RANK_TOLERANCE``.
GRAM_RANK_TOLERANCE = 1e-4


def max_low_rank(m, c):
    """The largest rank of the model term at which the low-rank path is
    taken for a field block of order ``m`` and ``c`` columns (``P + 1``),
    or -1 for none.

    The low-rank path costs ``m^2 w + 2 m w^2`` flops per (theta, draw)
    (``w = rho + c``: the triangular solve and the Gram matrix) against
    ``(m + c)^3 / 3`` for the dense factorisation; it is taken while the
    ratio stays within :data:`COST_RATIO`, lowered above :data:`COST_ORDER`.

    Examples
    --------
    >>> max_low_rank(50, 5), max_low_rank(75, 9), max_low_rank(30, 3)
    (21, 32, 13)
    """
    width = np.arange(m + 1) + c
    low = m * m * width + 2.0 * m * width**2
    bound = 1.0 + (COST_RATIO - 1.0) * min(1.0, (COST_ORDER / m) ** 2)
    return int(np.sum(low <= bound * (m + c) ** 3 / 3.0)) - 1


def model_term_factor(terms, noise_floor, max_rank):
    """A factor ``U`` (B, m, rho) of the model terms (B, m, m), or None.

    ``U U'`` is the Rayleigh-Ritz projection of each term on the span of
    the columns that a pivoted Cholesky factorisation picks (until every
    remaining diagonal entry is below ``LOW_RANK_TOL * noise_floor``), its
    eigenvalues below that threshold dropped; ``rho`` is the largest rank
    of the batch (zero columns pad the others). None when more than
    ``max_rank`` columns (:func:`max_low_rank`) would be needed, or when
    the span leaves out more than ``m`` thresholds of a term's trace.
    """
    n_terms, m, _ = terms.shape
    threshold = LOW_RANK_TOL * noise_floor
    if max_rank < 0:
        return None
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
        lower rank than ``P + 1``), or a regression column is within
        :data:`GRAM_RANK_TOLERANCE` of the span of the ones before it: the
        dense path then decides, and says why.
    """
    B, m, rho = U.shape
    c = Z.shape[2]
    P, width = c - 1, rho + c
    # In Fortran order: the solve copies it as it is instead of transposing
    # it at every draw, and the solution's transpose holds each theta's
    # columns as rows (a view, no copy).
    rhs = np.concatenate([U, Z], axis=2).transpose(0, 2, 1).reshape(B * width, m).T
    # The simulation block joins the bordered Gram matrix: the trailing
    # factor of [[I + U' S^-1 U, .], [., Z' S^-1 Z + top' top]] is then the
    # regression's (``R'`` of eq. 4.30's stacked QR), no QR per draw.
    border = np.zeros((width, width))
    border[:rho, :rho] = np.eye(rho)
    border[rho:, rho:] = model.top.T @ model.top
    draws = range(len(factors)) if draws is None else draws
    out = np.empty((B, len(draws)))
    for j, k in enumerate(draws):
        W = lower_solve(factors[k], rhs)  # the GIL released: threads run
        rows = W.T.reshape(B, width, m)
        gram = rows @ np.swapaxes(rows, 1, 2) + border
        F = np.linalg.cholesky(gram)
        diag = np.diagonal(F, axis1=1, axis2=2)
        regression = diag[:, rho : rho + P]
        norms = np.sqrt(np.diagonal(gram, axis1=1, axis2=2)[:, rho : rho + P])
        if np.any(regression <= GRAM_RANK_TOLERANCE * norms) or np.any(
            regression.min(axis=1) <= RANK_TOLERANCE * regression.max(axis=1)
        ):
            # Normal equations cannot tell: the dense path's QR decides.
            raise np.linalg.LinAlgError("near rank-deficient regression")
        out[:, j] = regression_terms(
            log_dets[k] + 2.0 * np.sum(np.log(diag[:, :rho]), axis=1),
            np.sum(np.log(regression), axis=1),
            model.rss_top_perp + diag[:, rho + P] ** 2,
            model.log_det_A,
            model.N * model.q + model.n_observed,
            P,
        )
    return out
