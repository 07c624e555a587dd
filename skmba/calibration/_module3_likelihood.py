"""Module 3's global model: the likelihood of Eq. 4.30 through the Schur complement.

Simulations ``Y_m`` (N x q at ``[X_m, Theta_m]``) and field data ``Y_e``
(n x q at ``X_e``) are jointly Gaussian given ``theta`` (thesis Eqs.
4.25-4.29)::

    Y = [vec(Y_m); vec(Y_e)] ~ N(H_Y(theta) beta, V_Y(theta))
    V_Y = [[A,  B(theta)], [B', D(theta)]],   A = Sigma_m ⊗ R_m(D_m, D_m) fixed

with ``D_e(theta) = [X_e, theta]``; ``beta`` is integrated out under a flat
prior (the ``|W_Y|^1/2`` term of Eq. 4.30, appendix B). ``A`` is factored
once and only the Schur complement ``S(theta) = D - B' A^-1 B`` (size nq)
per theta (DESIGN rule 3); the block-Cholesky factor of ``V_Y`` whitens the
data, regressions and cross-covariances for module 4.

- :class:`GlobalModel`: the model at one value of the module-2
  hyperparameters (standardised units), factored per theta by
  :meth:`GlobalModel.whiten`;
- :func:`schur_log_likelihoods`: Eq. 4.30 for a stack of Schur complements
  at once (one batched Cholesky and QR), shared by the calibrator's sampler
  (many theta and module-2 draws, :mod:`skmba.calibration._module3_mixture`)
  and the sensor designer (many response subsets).

:mod:`skmba.calibration._module3_posterior` turns it into the posterior of
theta. ``tests/calibration/test_module3_posterior.py`` and
``tests/calibration/test_module3_stacked_likelihood.py`` check it against
the dense Eq. 4.30.
"""

import copy
from dataclasses import dataclass

import numpy as np
from scipy import linalg

from skmba._core.linalg import (
    LOG_2PI,
    FactorizationError,
    cholesky,
    kron_sum,
    log_det_from_cholesky,
    observed_block,
    observed_entries,
    stacked_whitening,
)
from skmba._core.regression import regression_basis
from skmba.calibration._field_replicates import noise_diagonal

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
    short = P + 1 - top.shape[0] - W.shape[1]
    if short > 0:  # no more rows than coefficients (readings at one input):
        # zero rows leave the factor as it is and give it its last row.
        W = np.concatenate([W, np.zeros((len(W), short, P + 1))], axis=1)
    stacked = np.concatenate([np.broadcast_to(top, (len(W), *top.shape)), W], axis=1)
    R = np.linalg.qr(stacked, mode="r")
    diag = np.abs(np.diagonal(R[:, :P, :P], axis1=1, axis2=2))
    if np.any(diag.min(axis=1) <= RANK_TOLERANCE * diag.max(axis=1)):
        raise FactorizationError(RANK_DEFICIENT)
    rss = rss_top_perp + R[:, P, P] ** 2
    return regression_terms(
        log_det_S, np.sum(np.log(diag), axis=1), rss, log_det_A, n_data, P
    )


def regression_terms(log_det_S, log_det_R, rss, log_det_A, n_data, P):
    """Eq. 4.30 from its parts: ``log |S_k|``, ``log |R_k|`` (the
    regression's triangular factor, leading ``P`` columns), the residual sum
    of squares (with the simulation block's), ``log |A|``, the number of
    data and of coefficients."""
    return -0.5 * (
        (n_data - P) * LOG_2PI + log_det_A + log_det_S + 2.0 * log_det_R + rss
    )


#: Bytes of bordered matrices that one stacked factorisation may hold (the
#: chunks of :func:`stack_chunks`). Stacks that stay in the processor's
#: cache factor fastest: on the thesis' 4.7.3 set-up (orders of 147, one
#: module-2 draw, one thread) one theta took 0.43 ms on its own, 0.25 ms in
#: stacks of 1-2 MiB, 0.34 ms of 16 MiB and 1.5 ms of 64 MiB.
STACK_BYTES = 2**20
#: Bytes of model terms (order ``m`` per theta) that one computation of
#: the emulator's conditionals may hold: a batch of thetas (e.g. a chain's
#: independence proposals) gets its conditionals together, in BLAS calls
#: over all of them, and is then factored in stacks of :data:`STACK_BYTES`.
CONDITIONAL_BYTES = 2**24


def stack_chunks(n_values, per_value, m, c, budget=STACK_BYTES):
    """Slices of ``range(n_values)`` whose stacks fit ``budget`` bytes.

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
    size = max(1, budget // (8 * per_value * (m + c) ** 2))
    return [slice(i, min(n_values, i + size)) for i in range(0, n_values, size)]


S_REMEDY = (
    "The field-data covariance (Schur complement of the simulation block) is "
    "not positive definite for this theta. Use a smoother model kernel, a "
    "larger nugget `alpha` for the emulator, or check that the noise variances "
    "are not all at their lower bound."
)


@dataclass
class Whitened:
    """Per-theta pieces of the block-whitened global model."""

    theta: np.ndarray
    P_e: np.ndarray  # field inputs with theta appended, (n, d + r)
    Rt: np.ndarray  # C_m^-1 R_m(D_m, D_e(theta)), (N, n)
    # The field block has one row per measured entry of vec(Y_e), m <= nq.
    L_S: np.ndarray  # Cholesky factor of the Schur complement, (m, m)
    G: np.ndarray  # R factor of the stacked whitened regression matrix, (P, P)
    beta: np.ndarray  # GLS estimate, (P,)
    resid_top: np.ndarray  # whitened residual, simulation block, (Nq,)
    resid_bot: np.ndarray  # whitened residual, field block, (m,)
    X_bot: np.ndarray  # L_S^-1 times the field rows of H_Y, (m, P)


class GlobalModel:
    """The module-3 likelihood of Eq. 4.30 through the Schur complement.

    Parameters
    ----------
    emulator : Emulator
        The fitted module-1 emulator (simulations, correlation, nugget).
        Its nugget is on the simulations' block only: the model term at the
        field inputs is the simulator's output there, a deterministic
        function (:meth:`EmulatorConditional.correlation
        <skmba.calibration._module1_emulator.EmulatorConditional.correlation>`).
    X_e : ndarray of shape (n, d)
        Standardised field inputs.
    Y_e : ndarray of shape (n, q)
        Standardised field data; NaN marks an entry that was not measured.
        The field block is then restricted to the measured entries
        (``observed``), at the cost of one more index per factorisation.
    discrepancy : DiscrepancyFit
        The fitted module-2 discrepancy (``kernel_``, ``regression``,
        ``sigma2``, ``noise``).
    replicates : ReplicateTerms, default=None
        When the rows of ``Y_e`` are means of repeated readings
        (:class:`~skmba.calibration._field_replicates.ReplicateTerms`): their
        noise is divided by the counts and the likelihood carries the
        readings' factor, so that it equals the likelihood of the readings.

    Examples
    --------
    ``tests/calibration/test_module3_posterior.py`` checks the
    log-likelihood against the dense Eq. 4.30.
    """

    def __init__(self, emulator, X_e, Y_e, discrepancy, replicates=None):
        self.emulator = emulator
        self.replicates = replicates
        self.X_m, self.Y_m, self.X_e, self.Y_e = emulator.Z, emulator.Y, X_e, Y_e
        self.kernel_m, self.regression_m = emulator.kernel, emulator.regression
        self.regression_d = discrepancy.regression
        self.C_m = emulator.C
        self.sigma2_m = emulator.sigma2
        self.L_sm = emulator.likelihood.sigma2_chol
        N, q = self.Y_m.shape
        n = len(X_e)
        self.N, self.n, self.q = N, n, q
        # The measured entries of vec(Y_e) (None: all), and their number.
        self.observed = observed_entries(Y_e)
        self.n_observed = n * q if self.observed is None else len(self.observed)
        # The model correlation among the field points, when theta-free.
        self.R_ee = emulator.field_correlation(X_e)
        self.p_m = emulator.H_white.shape[1]
        self.H_d = regression_basis(X_e, self.regression_d)
        self.p_d = self.H_d.shape[1]
        self.P = (self.p_m + self.p_d) * q
        # Simulation block, whitened once: L_A = L_sm ⊗ C_m.
        self.H_m_white = emulator.H_white  # C_m^-1 H_m
        self.Y_m_white = emulator.Y_white
        L_sm_inv = linalg.solve_triangular(self.L_sm, np.eye(q), lower=True)
        X_top = np.kron(L_sm_inv, self.H_m_white)  # (Nq, p_m q)
        y_top = (self.solve_sigma_m(self.Y_m_white)).T.ravel()
        Q_t, G_t = linalg.qr(X_top, mode="economic")
        self.G_top = np.hstack([G_t, np.zeros((G_t.shape[0], self.p_d * q))])
        self.b_top = Q_t.T @ y_top
        self.top = np.column_stack([self.G_top, self.b_top])
        self.X_top_full = np.hstack([X_top, np.zeros((N * q, self.p_d * q))])
        self.y_top = y_top
        self.rss_top_perp = float(y_top @ y_top - self.b_top @ self.b_top)
        self.log_det_A = N * log_det_from_cholesky(self.L_sm) + q * (
            log_det_from_cholesky(self.C_m)
        )
        self._set_discrepancy(discrepancy)

    def _set_discrepancy(self, discrepancy):
        self.kernel_d = discrepancy.kernel_
        self.sigma2_d = discrepancy.sigma2
        self.noise = np.asarray(discrepancy.noise, dtype=float)
        # What a new observation adds to the reality (module 4): the plugged
        # noise here; a ModelMixture holds its posterior mean.
        self.predictive_noise = self.noise
        reps = self.replicates
        # sigma2_d ⊗ R_d plus the noise on its diagonal: the sum of the
        # dense formula, entry for entry, without its (n q)^2 noise matrix.
        S = kron_sum((self.sigma2_d, self.kernel_d(self.X_e)))
        S[np.diag_indices_from(S)] += noise_diagonal(self.noise, self.n, reps)
        self.S_fixed = observed_block(S, self.observed)
        # The other terms of S(theta) are positive semi-definite: the
        # smallest noise variance bounds its smallest eigenvalue.
        self.noise_floor = (
            float(np.min(self.noise))
            if reps is None
            else reps.smallest_noise(self.noise)
        )
        # The repeated readings' factor (a function of the noise alone).
        self.replicate_factor = 0.0 if reps is None else reps.log_factor(self.noise)
        self._cache = None

    def with_discrepancy(self, discrepancy):
        """A copy with other module-2 hyperparameters (same regression).

        The simulation block, factored once, is shared.
        """
        other = copy.copy(self)
        other._set_discrepancy(discrepancy)
        return other

    def solve_sigma_m(self, Z):
        """``Z L_sm^-T`` for Z of shape (., q): whitening across responses."""
        return linalg.solve_triangular(self.L_sm, Z.T, lower=True).T

    def conditionals(self, thetas):
        """The emulator given the simulations at the field inputs, per theta.

        Returns the :class:`~skmba.calibration._module1_emulator.EmulatorConditional` at
        the rows of ``thetas`` (k, r) and the model terms ``Sigma_m ⊗ T`` of their Schur
        complements (k, m, m), at the measured entries; neither depends on the module-2
        hyperparameters.
        """
        cond = self.emulator.conditional(self.X_e, thetas)
        T = cond.correlation(prior=self.R_ee)
        k, n, q = len(T), self.n, self.q
        terms = np.einsum("ij,kab->kiajb", self.sigma2_m, T).reshape(k, q * n, q * n)
        if self.observed is not None:
            terms = terms[:, self.observed[:, None], self.observed]
        return cond, terms

    def conditional(self, theta):
        """:meth:`conditionals` at one ``theta``: the conditional and its
        model term (m, m)."""
        cond, terms = self.conditionals(np.ravel(theta)[None, :])
        return cond, terms[0]

    def field_data(self, cond):
        """The field rows of ``H_Y`` (k, m, P) and the field data minus the
        emulator's conditional mean (k, m), at the measured entries
        (unwhitened), per theta of ``cond``."""
        q, n, k, p_m = self.q, self.n, cond.k, self.p_m
        X_bot = np.zeros((k, q * n, self.P))
        H_me = cond.H_me()
        for j in range(q):
            rows = slice(j * n, (j + 1) * n)
            X_bot[:, rows, j * p_m : (j + 1) * p_m] = H_me
            start = q * p_m + j * self.p_d
            X_bot[:, rows, start : start + self.p_d] = self.H_d
        y_bot = (self.Y_e - cond.M()).transpose(0, 2, 1).reshape(k, q * n)
        if self.observed is None:
            return X_bot, y_bot
        return X_bot[:, self.observed], y_bot[:, self.observed]

    def field_rows(self, cond):
        """``[X_bot, y_bot]`` of :meth:`field_data` side by side (k, m, P + 1)."""
        X_bot, y_bot = self.field_data(cond)
        return np.concatenate([X_bot, y_bot[:, :, None]], axis=2)

    def stacked_log_likelihoods(self, S, Z, noise_floor=None):
        """:func:`~skmba.calibration._module3_likelihood.schur_log_likelihoods`
        of this model's data for Schur complements ``S`` (k, m, m) and field
        rows ``Z``, whose smallest noise variance is ``noise_floor`` (None:
        this model's)."""
        return schur_log_likelihoods(
            S,
            Z,
            self.noise_floor if noise_floor is None else noise_floor,
            self.top,
            self.rss_top_perp,
            self.log_det_A,
            self.N * self.q + self.n_observed,
        )

    def whiten(self, theta, conditional=None):
        """Factor the global model at ``theta`` (cached for the last theta).

        ``conditional``, the output of :meth:`conditional` at this
        ``theta``, saves recomputing it (models that differ only in the
        module-2 hyperparameters share it).
        """
        theta = np.asarray(theta, dtype=float).ravel()
        cache = self._cache  # one read: another thread may replace it
        if cache is not None and np.array_equal(cache.theta, theta):
            return cache
        cond, model_term = conditional or self.conditional(theta)
        S = self.S_fixed + model_term
        L_S = cholesky(S, what="Schur complement S(theta)", remedy=S_REMEDY)
        # Field rows of H_Y minus B'A^-1 times the simulation rows, whitened.
        X_bot, y_bot = self.field_data(cond)
        X_bot = linalg.solve_triangular(L_S, X_bot[0], lower=True)
        y_bot = linalg.solve_triangular(L_S, y_bot[0], lower=True)
        stacked = np.vstack([self.G_top, X_bot])
        Q, G = linalg.qr(stacked, mode="economic")
        diag = np.abs(np.diag(G))
        if diag.min() <= RANK_TOLERANCE * diag.max():
            raise FactorizationError(RANK_DEFICIENT)
        rhs = np.concatenate([self.b_top, y_bot])
        beta = linalg.solve_triangular(G, Q.T @ rhs)
        resid_bot = y_bot - X_bot @ beta
        resid_top = self.y_top - self.X_top_full @ beta
        whitened = Whitened(
            theta=theta,
            P_e=cond.points,
            Rt=cond.Rt,
            L_S=L_S,
            G=G,
            beta=beta,
            resid_top=resid_top,
            resid_bot=resid_bot,
            X_bot=X_bot,
        )
        self._cache = whitened
        return whitened

    def log_likelihood(self, theta):
        """``log p(Y | theta, D, phi)`` with ``beta`` integrated out (Eq. 4.30).

        It includes every constant, ``(2 pi)^-(M - P)/2 |V_Y|^-1/2
        |H_Y' V_Y^-1 H_Y|^-1/2 exp(-rss/2)`` with ``M = N q + m`` data (``m``
        measured field entries, ``n q`` without gaps) and ``P`` regression
        coefficients, so that it equals the dense formula; with means of
        repeated readings, times their factor, so that it equals the
        formula over the readings.

        Raises
        ------
        FactorizationError
            When it cannot be evaluated (saying why).
        """
        theta = np.ravel(theta)
        value = self.log_likelihoods(theta[None, :])[0]
        if value == -np.inf:
            self.whiten(theta)  # raises, saying why
            raise FactorizationError(
                "The Schur complement S(theta) is not positive definite. " + S_REMEDY
            )
        return float(value)

    def log_likelihoods(self, thetas):
        """:meth:`log_likelihood` at the rows of ``thetas`` (k, r): (k,).

        ``-inf`` where the Schur complement is not positive definite; the
        Schur complements of several theta are factored as one stack.

        Raises
        ------
        FactorizationError
            When the regression is rank deficient at one of ``thetas``.
        """
        out = np.empty(len(thetas))
        for chunk in stack_chunks(len(thetas), 1, self.n_observed, self.P + 1):
            cond, terms = self.conditionals(thetas[chunk])
            out[chunk] = self.stacked_log_likelihoods(
                self.S_fixed + terms, self.field_rows(cond)
            )
        return out + self.replicate_factor if self.replicates is not None else out
