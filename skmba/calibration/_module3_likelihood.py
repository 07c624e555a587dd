"""Module 3's global model: the likelihood of Eq. 4.30 through the Schur complement.

Simulations ``Y_m`` (N x q at inputs ``[X_m, Theta_m]``) and field data
``Y_e`` (n x q at ``X_e``) are jointly Gaussian given the calibration
parameters ``theta`` (thesis Eqs. 4.25-4.29)::

    Y = [vec(Y_m); vec(Y_e)] ~ N(H_Y(theta) beta, V_Y(theta))

    V_Y = [[A,  B(theta)], [B', D(theta)]],
    A = Sigma_m ⊗ R_m(D_m, D_m)                       (fixed)
    B = Sigma_m ⊗ R_m(D_m, D_e(theta))
    D = Lambda ⊗ I + Sigma_m ⊗ R_m(D_e(theta)) + Sigma_d ⊗ R_d(X_e)

with ``D_e(theta) = [X_e, theta]``. The regression coefficients ``beta =
[vec(beta_m); vec(beta_delta)]`` are integrated out under a flat prior, which
adds the ``|W_Y|^1/2`` term of Eq. 4.30 (appendix B).

Nothing of size ``(N + n) q`` is factored per ``theta`` (DESIGN rule 3): ``A``
is factored once (Kronecker of two Cholesky factors), ``B' A^-1`` reduces to
``I ⊗ R_me' R_mm^-1`` and only the Schur complement

    S(theta) = D - B' A^-1 B
             = Lambda ⊗ I + Sigma_d ⊗ R_d + Sigma_m ⊗ (R_ee - R_me' R_mm^-1 R_me)

(size nq) is factored per ``theta``. The block Cholesky factor
``L = [[L_A, 0], [B' L_A^-T, L_S]]`` of ``V_Y`` whitens data, regression
matrix and cross-covariances, after which the generalised least squares and
the kriging predictions of module 4 (Eqs. 4.35-4.45) follow from one QR of a
small stacked matrix, as in appendix C.

All of :class:`GlobalModel` is in the calibrator's standardised units;
:mod:`skmba.calibration._module3_posterior` turns it into the posterior of theta.

Examples
--------
``tests/calibration/test_module3_posterior.py`` and
``tests/calibration/test_module3_batch_likelihood.py`` check it against the dense Eq.
4.30.
"""

import copy
from dataclasses import dataclass

import numpy as np
from scipy import linalg

from skmba._core.linalg import (
    FactorizationError,
    cholesky,
    log_det_from_cholesky,
    observed_block,
    observed_entries,
)
from skmba._core.regression import regression_basis
from skmba.calibration._module3_batch_likelihood import (
    RANK_DEFICIENT,
    RANK_TOLERANCE,
    schur_log_likelihoods,
    stack_chunks,
)

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
        Its nugget is on the diagonal of the model correlation at the field
        inputs as at the simulations, so that the model term of the global
        covariance is ``Sigma2_m ⊗ (R(D) + alpha I)`` over all its points:
        the emulator's own uncertainty at a simulated point. It also keeps
        the Schur complement positive definite when the round-off of
        ``R_ee - R_me' R_mm^-1 R_me``, scaled by a large ``Sigma2_m``, would
        exceed a vanishing noise.
    X_e : ndarray of shape (n, d)
        Standardised field inputs.
    Y_e : ndarray of shape (n, q)
        Standardised field data; NaN marks an entry that was not measured.
        The field block is then restricted to the measured entries
        (``observed``), at the cost of one more index per factorisation.
    discrepancy : DiscrepancyFit
        The fitted module-2 discrepancy (``kernel_``, ``regression``,
        ``sigma2``, ``noise``).

    Examples
    --------
    ``tests/calibration/test_module3_posterior.py`` checks the
    log-likelihood against the dense Eq. 4.30.
    """

    def __init__(self, emulator, X_e, Y_e, discrepancy):
        self.emulator = emulator
        self.X_m, self.Y_m, self.X_e, self.Y_e = emulator.Z, emulator.Y, X_e, Y_e
        self.nugget = float(emulator.nugget)
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
        self.S_fixed = observed_block(
            np.kron(self.sigma2_d, self.kernel_d(self.X_e))
            + np.kron(np.diag(self.noise), np.eye(self.n)),
            self.observed,
        )
        # The other terms of S(theta) are positive semi-definite: the
        # smallest noise variance bounds its smallest eigenvalue.
        self.noise_floor = float(np.min(self.noise))
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
        T = cond.correlation(self.nugget, prior=self.R_ee)
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
        """:func:`~skmba.calibration._module3_batch_likelihood.schur_log_likelihoods`
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
        coefficients, so that it equals the dense formula.

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
        return out
