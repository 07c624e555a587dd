"""Module 3 and 4 of the modular Bayesian approach: the global data model.

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

All quantities are in the calibrator's standardised units.

Examples
--------
>>> import numpy as np
>>> from skmba._posterior import LOG_2PI
>>> round(float(LOG_2PI), 4)
1.8379
"""

from dataclasses import dataclass

import numpy as np
from scipy import linalg

from skmba._linalg import FactorizationError, cholesky, log_det_from_cholesky
from skmba._regression import regression_basis

LOG_2PI = np.log(2.0 * np.pi)

_S_REMEDY = (
    "The field-data covariance (Schur complement of the simulation block) is "
    "not positive definite for this theta. Use a smoother model kernel, a "
    "larger nugget `alpha` for the emulator, or check that the noise variances "
    "are not all at their lower bound."
)


@dataclass
class _Whitened:
    """Per-theta pieces of the block-whitened global model."""

    theta: np.ndarray
    P_e: np.ndarray  # field inputs with theta appended, (n, d + r)
    Rt: np.ndarray  # C_m^-1 R_m(D_m, D_e(theta)), (N, n)
    L_S: np.ndarray  # Cholesky factor of the Schur complement, (nq, nq)
    G: np.ndarray  # R factor of the stacked whitened regression matrix, (P, P)
    beta: np.ndarray  # GLS estimate, (P,)
    resid_top: np.ndarray  # whitened residual, simulation block, (Nq,)
    resid_bot: np.ndarray  # whitened residual, field block, (nq,)
    X_bot: np.ndarray  # L_S^-1 times the field rows of H_Y, (nq, P)
    log_likelihood: float


class GlobalModel:
    """The module-3 likelihood and the module-4 conditional predictions.

    Parameters
    ----------
    model_fit : NoiseFreeLikelihood
        The fitted module-1 emulator state (``C``, ``gls``, ``sigma2``).
    X_m : ndarray of shape (N, d + r)
        Standardised simulation inputs ``[X_sim, theta_sim]``.
    Y_m : ndarray of shape (N, q)
    model_kernel : sklearn Kernel
        The fitted module-1 correlation.
    model_regression : str
    X_e : ndarray of shape (n, d)
    Y_e : ndarray of shape (n, q)
    discrepancy_kernel : sklearn Kernel
    discrepancy_regression : str
    sigma2_d : ndarray of shape (q, q)
    noise : ndarray of shape (q,)

    Examples
    --------
    See ``tests/test_posterior.py``, which checks the log-likelihood against
    the dense Eq. 4.30.
    """

    def __init__(
        self,
        model_fit,
        X_m,
        Y_m,
        model_kernel,
        model_regression,
        X_e,
        Y_e,
        discrepancy_kernel,
        discrepancy_regression,
        sigma2_d,
        noise,
    ):
        self.X_m, self.Y_m, self.X_e, self.Y_e = X_m, Y_m, X_e, Y_e
        self.kernel_m, self.regression_m = model_kernel, model_regression
        self.kernel_d, self.regression_d = discrepancy_kernel, discrepancy_regression
        self.C_m = model_fit.C
        self.sigma2_m = model_fit.sigma2
        self.L_sm = model_fit.sigma2_chol
        self.sigma2_d = sigma2_d
        self.noise = np.asarray(noise, dtype=float)
        N, q = Y_m.shape
        n = len(X_e)
        self.N, self.n, self.q = N, n, q
        H_m = regression_basis(X_m, model_regression)
        self.p_m = H_m.shape[1]
        self.H_d = regression_basis(X_e, discrepancy_regression)
        self.p_d = self.H_d.shape[1]
        self.P = (self.p_m + self.p_d) * q
        # Simulation block, whitened once: L_A = L_sm ⊗ C_m.
        self.H_m_white = model_fit.gls.H_white  # C_m^-1 H_m
        self.Y_m_white = linalg.solve_triangular(self.C_m, Y_m, lower=True)
        L_sm_inv = linalg.solve_triangular(self.L_sm, np.eye(q), lower=True)
        X_top = np.kron(L_sm_inv, self.H_m_white)  # (Nq, p_m q)
        y_top = (self._solve_sigma_m(self.Y_m_white)).T.ravel()
        Q_t, G_t = linalg.qr(X_top, mode="economic")
        self.G_top = np.hstack([G_t, np.zeros((G_t.shape[0], self.p_d * q))])
        self.b_top = Q_t.T @ y_top
        self.X_top_full = np.hstack([X_top, np.zeros((N * q, self.p_d * q))])
        self.y_top = y_top
        self.rss_top_perp = float(y_top @ y_top - self.b_top @ self.b_top)
        self.log_det_A = N * log_det_from_cholesky(self.L_sm) + q * (
            log_det_from_cholesky(self.C_m)
        )
        R_d = discrepancy_kernel(X_e)
        self.S_fixed = np.kron(sigma2_d, R_d) + np.kron(np.diag(self.noise), np.eye(n))
        self._cache = None

    # ------------------------------------------------------------ helpers
    def _solve_sigma_m(self, Z):
        """``Z L_sm^-T`` for Z of shape (., q): whitening across responses."""
        return linalg.solve_triangular(self.L_sm, Z.T, lower=True).T

    def _field_inputs(self, theta, X):
        theta = np.asarray(theta, dtype=float).reshape(1, -1)
        return np.hstack([X, np.repeat(theta, len(X), axis=0)])

    def whiten(self, theta):
        """Factor the global model at ``theta`` (cached for the last theta)."""
        theta = np.asarray(theta, dtype=float).ravel()
        if self._cache is not None and np.array_equal(self._cache.theta, theta):
            return self._cache
        N, n, q = self.N, self.n, self.q
        P_e = self._field_inputs(theta, self.X_e)
        r = self.kernel_m(self.X_m, P_e)  # (N, n)
        Rt = linalg.solve_triangular(self.C_m, r, lower=True)
        T = self.kernel_m(P_e) - Rt.T @ Rt  # emulator correlation given sims
        S = self.S_fixed + np.kron(self.sigma2_m, T)
        L_S = cholesky(S, what="Schur complement S(theta)", remedy=_S_REMEDY)
        # Field rows of H_Y minus B'A^-1 times the simulation rows, whitened.
        H_me = regression_basis(P_e, self.regression_m) - Rt.T @ self.H_m_white
        X_bot = np.hstack(
            [np.kron(np.eye(q), H_me), np.kron(np.eye(q), self.H_d)]
        )  # (nq, P)
        y_bot = (self.Y_e - Rt.T @ self.Y_m_white).T.ravel()
        X_bot = linalg.solve_triangular(L_S, X_bot, lower=True)
        y_bot = linalg.solve_triangular(L_S, y_bot, lower=True)
        stacked = np.vstack([self.G_top, X_bot])
        Q, G = linalg.qr(stacked, mode="economic")
        diag = np.abs(np.diag(G))
        if diag.min() <= 1e-10 * diag.max():
            raise FactorizationError(
                "The global regression matrix H_Y(theta) is rank deficient: use "
                "lower-order regressions for the model or the discrepancy."
            )
        rhs = np.concatenate([self.b_top, y_bot])
        beta = linalg.solve_triangular(G, Q.T @ rhs)
        resid_bot = y_bot - X_bot @ beta
        resid_top = self.y_top - self.X_top_full @ beta
        rss = float(resid_top @ resid_top + resid_bot @ resid_bot)
        M = (N + n) * q
        log_likelihood = -0.5 * (
            (M - self.P) * LOG_2PI
            + self.log_det_A
            + log_det_from_cholesky(L_S)
            + 2.0 * np.sum(np.log(diag))
            + rss
        )
        self._cache = _Whitened(
            theta=theta,
            P_e=P_e,
            Rt=Rt,
            L_S=L_S,
            G=G,
            beta=beta,
            resid_top=resid_top,
            resid_bot=resid_bot,
            X_bot=X_bot,
            log_likelihood=log_likelihood,
        )
        return self._cache

    def log_likelihood(self, theta):
        """``log p(Y | theta, D, phi)`` with ``beta`` integrated out (Eq. 4.30).

        It includes every constant, ``(2 pi)^-(M - P)/2 |V_Y|^-1/2
        |H_Y' V_Y^-1 H_Y|^-1/2 exp(-rss/2)`` with ``M = (N + n) q`` data and
        ``P`` regression coefficients, so that it equals the dense formula.
        """
        return self.whiten(theta).log_likelihood

    # ------------------------------------------------------------ module 4
    def predict(self, theta, X, component, return_var=True):
        """Conditional moments at ``X`` (s, d) given ``theta`` and all data.

        Parameters
        ----------
        theta : ndarray of shape (r,)
        X : ndarray of shape (s, d)
        component : {"model", "discrepancy", "reality", "observation"}
            ``reality`` is the true process ``y_m + delta``; ``observation``
            adds the measurement noise (a new field measurement, Eq. 4.36).
        return_var : bool
            Also return the marginal variances.

        Returns
        -------
        mean : ndarray of shape (s, q)
        var : ndarray of shape (s, q)
            Only when ``return_var`` is True.
        """
        w = self.whiten(theta)
        q, s = self.q, len(X)
        with_model = component in ("model", "reality", "observation")
        with_delta = component in ("discrepancy", "reality", "observation")
        P_s = self._field_inputs(w.theta, X)
        # Cross-covariances with the data, whitened block by block.
        top = np.zeros((self.N * q, s * q))
        bot = np.zeros((self.n * q, s * q))
        h_m = np.zeros((s, self.p_m))
        h_d = np.zeros((s, self.p_d))
        prior_diag = np.zeros((s, q))
        if with_model:
            K_ms = linalg.solve_triangular(
                self.C_m, self.kernel_m(self.X_m, P_s), lower=True
            )
            top = np.kron(self.L_sm.T, K_ms)  # L_A^-1 (Sigma_m ⊗ r_ms)
            bot = np.kron(self.sigma2_m, self.kernel_m(w.P_e, P_s) - w.Rt.T @ K_ms)
            h_m = regression_basis(P_s, self.regression_m)
            prior_diag += np.outer(self.kernel_m.diag(P_s), np.diag(self.sigma2_m))
        if with_delta:
            bot = bot + np.kron(self.sigma2_d, self.kernel_d(self.X_e, X))
            h_d = regression_basis(X, self.regression_d)
            prior_diag += np.outer(self.kernel_d.diag(X), np.diag(self.sigma2_d))
        if component == "observation":
            prior_diag += self.noise
        bot = linalg.solve_triangular(w.L_S, bot, lower=True)
        h = np.hstack([np.kron(np.eye(q), h_m), np.kron(np.eye(q), h_d)])  # (sq, P)
        mean = h @ w.beta + top.T @ w.resid_top + bot.T @ w.resid_bot
        mean = mean.reshape(q, s).T
        if not return_var:
            return mean
        U = h.T - self.X_top_full.T @ top - w.X_bot.T @ bot  # (P, sq)
        Ut = linalg.solve_triangular(w.G, U, trans="T")
        reduction = np.sum(top**2, axis=0) + np.sum(bot**2, axis=0)
        var = prior_diag.T.ravel() - reduction + np.sum(Ut**2, axis=0)
        return mean, np.clip(var.reshape(q, s).T, 0.0, None)
