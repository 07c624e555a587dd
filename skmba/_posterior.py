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
    nugget : float, default=0.0
        The emulator's nugget ``alpha_``. It is on the diagonal of the model
        correlation at the field inputs as at the simulations, so that the
        model term of the global covariance is ``Sigma2_m ⊗ (R(D) + alpha
        I)`` over all its points: the emulator's own uncertainty at a
        simulated point. It also keeps the Schur complement positive
        definite when the round-off of ``R_ee - R_me' R_mm^-1 R_me``, scaled
        by a large ``Sigma2_m``, would exceed a vanishing noise.

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
        nugget=0.0,
    ):
        self.X_m, self.Y_m, self.X_e, self.Y_e = X_m, Y_m, X_e, Y_e
        self.nugget = float(nugget)
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
        cache = self._cache  # one read: another thread may replace it
        if cache is not None and np.array_equal(cache.theta, theta):
            return cache
        N, n, q = self.N, self.n, self.q
        P_e = self._field_inputs(theta, self.X_e)
        r = self.kernel_m(self.X_m, P_e)  # (N, n)
        Rt = linalg.solve_triangular(self.C_m, r, lower=True)
        T = self.kernel_m(P_e) - Rt.T @ Rt  # emulator correlation given sims
        T[np.diag_indices(n)] += self.nugget
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
        whitened = _Whitened(
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
        self._cache = whitened
        return whitened

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


# ---------------------------------------------------------------------------
# The same likelihood for many response subsets and many theta at once.
# ---------------------------------------------------------------------------
class FieldDesignEmulator:
    """The theta-dependent pieces of :class:`GlobalModel` at a fixed design.

    The sensor designer evaluates the module-3 likelihood of Eq. 4.30 for
    every response subset of every Monte Carlo replicate at the same field
    inputs ``X_e``. What depends on ``theta`` through the emulator does not
    depend on the responses or on the field data::

        Rt(theta)  = C_m^-1 R_m(D_m, D_e(theta))                 (N, n)
        T(theta)   = R_m(D_e(theta)) - Rt' Rt                     (n, n)
        H_me(theta) = H_m(D_e(theta)) - Rt' C_m^-1 H_m            (n, p_m)
        M(theta)   = Rt' C_m^-1 Y_m                               (n, q)

    so :meth:`pieces` computes them once per ``theta`` for all subsets, and
    :meth:`simulation_block` the theta-independent simulation block of a
    subset once per subset (both as in :class:`GlobalModel`).

    Parameters
    ----------
    model_fit : NoiseFreeLikelihood
        The fitted module-1 emulator state.
    X_m : ndarray of shape (N, d + r)
    Y_m : ndarray of shape (N, q)
    model_kernel : sklearn Kernel
    model_regression : str
    X_e : ndarray of shape (n, d)
        The field design (standardised).
    nugget : float, default=0.0
        The emulator's nugget, on the diagonal of ``T`` as in
        :class:`GlobalModel`.

    Examples
    --------
    ``tests/test_posterior.py`` checks :class:`SubsetLikelihood` against
    :class:`GlobalModel` restricted to the same responses.
    """

    def __init__(
        self, model_fit, X_m, Y_m, model_kernel, model_regression, X_e, nugget=0.0
    ):
        self.X_m, self.X_e = X_m, X_e
        self.nugget = float(nugget)
        self.kernel_m, self.regression_m = model_kernel, model_regression
        self.C_m = model_fit.C
        self.sigma2_m = model_fit.sigma2
        self.H_m_white = model_fit.gls.H_white
        self.Y_m_white = linalg.solve_triangular(self.C_m, Y_m, lower=True)
        self.N, self.q = Y_m.shape
        self.n = len(X_e)
        self.p_m = self.H_m_white.shape[1]
        self.log_det_R_m = log_det_from_cholesky(self.C_m)
        self._blocks = {}

    def pieces(self, thetas):
        """``T``, ``H_me`` and ``M`` at the rows of ``thetas`` (standardised).

        Returns
        -------
        T : ndarray of shape (k, n, n)
        H_me : ndarray of shape (k, n, p_m)
        M : ndarray of shape (k, n, q)
        """
        thetas = np.atleast_2d(thetas)
        k, n = len(thetas), self.n
        points = np.hstack([np.tile(self.X_e, (k, 1)), np.repeat(thetas, n, axis=0)])
        Rt = linalg.solve_triangular(
            self.C_m, self.kernel_m(self.X_m, points), lower=True
        )  # (N, k n)
        H_me = regression_basis(points, self.regression_m) - Rt.T @ self.H_m_white
        M = Rt.T @ self.Y_m_white
        Rt = Rt.reshape(self.N, k, n)
        prior = np.stack([self.kernel_m(points[i * n : (i + 1) * n]) for i in range(k)])
        T = prior - np.einsum("mki,mkj->kij", Rt, Rt)
        T[:, np.arange(n), np.arange(n)] += self.nugget  # as in GlobalModel
        return T, H_me.reshape(k, n, -1), M.reshape(k, n, -1)

    def simulation_block(self, responses):
        """The whitened simulation block of a response subset (cached).

        Returns ``(sigma2_m, G_top, b_top, rss_top_perp, log_det_A)`` for the
        subset: the QR of ``(L_S^-1 ⊗ C_m^-1 H_m)`` and the projection of the
        whitened simulations on it, as in :class:`GlobalModel`.
        """
        key = tuple(responses)
        if key not in self._blocks:
            idx = list(key)
            s = len(idx)
            sigma2 = self.sigma2_m[np.ix_(idx, idx)]
            L = cholesky(sigma2, what="emulator response covariance of the subset")
            L_inv = linalg.solve_triangular(L, np.eye(s), lower=True)
            X_top = np.kron(L_inv, self.H_m_white)
            y_top = linalg.solve_triangular(L, self.Y_m_white[:, idx].T, lower=True)
            y_top = y_top.ravel()
            Q, G = linalg.qr(X_top, mode="economic")
            b = Q.T @ y_top
            log_det_A = self.N * log_det_from_cholesky(L) + s * self.log_det_R_m
            self._blocks[key] = (sigma2, G, b, float(y_top @ y_top - b @ b), log_det_A)
        return self._blocks[key]


class SubsetLikelihood:
    """Eq. 4.30 for a subset of the responses, at many ``theta`` at once.

    The discrepancy and noise of the subset are those of all responses
    restricted to it (``Sigma_d[S, S]``, ``Lambda[S]``), which is what a
    multi-response GP implies for a subset. The Schur complement
    ``S(theta)`` of each ``theta`` is factored in one batched Cholesky, and
    the regression coefficients are integrated out through the normal
    equations of the stacked, whitened regression (small: ``(p_m + p_d) s``
    columns), which is equivalent to the QR of :class:`GlobalModel`.

    Parameters
    ----------
    design : FieldDesignEmulator
    responses : sequence of int
        The subset ``S``.
    Y_e : ndarray of shape (n, q)
        Field data of all responses (standardised).
    R_d : ndarray of shape (n, n)
        Discrepancy correlation at the field design.
    H_d : ndarray of shape (n, p_d)
        Discrepancy regression matrix.
    sigma2_d : ndarray of shape (q, q)
    noise : ndarray of shape (q,)
    """

    def __init__(self, design, responses, Y_e, R_d, H_d, sigma2_d, noise):
        self.design = design
        self.idx = list(responses)
        idx, n = self.idx, design.n
        s = len(idx)
        self.s = s
        self.sigma2_m, G, b, self.rss_perp, self.log_det_A = design.simulation_block(
            idx
        )
        self.p_m, self.p_d = design.p_m, H_d.shape[1]
        self.P = (self.p_m + self.p_d) * s
        pm = self.p_m * s
        self.GtG = np.zeros((self.P, self.P))
        self.GtG[:pm, :pm] = G.T @ G
        self.Gtb = np.zeros(self.P)
        self.Gtb[:pm] = G.T @ b
        self.bb = float(b @ b)
        self.S_fixed = np.kron(sigma2_d[np.ix_(idx, idx)], R_d) + np.kron(
            np.diag(np.asarray(noise)[idx]), np.eye(n)
        )
        self.X_d = np.kron(np.eye(s), H_d)  # (n s, p_d s)
        self.Y_e = Y_e[:, idx]
        self.M = (design.N + n) * s

    def log_likelihood(self, pieces):
        """Log-likelihood at the ``k`` parameter values of ``pieces``.

        Parameters
        ----------
        pieces : tuple
            ``FieldDesignEmulator.pieces(thetas)``.

        Returns
        -------
        ndarray of shape (k,)
            ``-inf`` where ``S(theta)`` is not positive definite.
        """
        T, H_me, Mk = pieces
        idx, s, n = self.idx, self.s, self.design.n
        k = len(T)
        S = self.S_fixed + np.einsum("ab,kij->kaibj", self.sigma2_m, T).reshape(
            k, n * s, n * s
        )
        X = np.empty((k, n * s, self.P))
        pm = self.p_m * s
        for a in range(s):
            X[:, a * n : (a + 1) * n, :pm] = 0.0
            X[:, a * n : (a + 1) * n, a * self.p_m : (a + 1) * self.p_m] = H_me
        X[:, :, pm:] = self.X_d
        y = (self.Y_e - Mk[:, :, idx]).transpose(0, 2, 1).reshape(k, n * s)
        out = np.full(k, -np.inf)
        ok = np.ones(k, dtype=bool)
        try:
            L = np.linalg.cholesky(S)
        except np.linalg.LinAlgError:
            L = np.zeros_like(S)
            for j in range(k):
                try:
                    L[j] = np.linalg.cholesky(S[j])
                except np.linalg.LinAlgError:
                    ok[j] = False
        if not ok.any():
            return out
        L, S, X, y = L[ok], S[ok], X[ok], y[ok]
        rhs = np.concatenate([X, y[:, :, None]], axis=2)
        solved = np.linalg.solve(S, rhs)  # S^-1 [X | y]
        XtSX = np.einsum("kip,kiq->kpq", X, solved[:, :, :-1])
        XtSy = np.einsum("kip,ki->kp", X, solved[:, :, -1])
        ySy = np.einsum("ki,ki->k", y, solved[:, :, -1])
        info = self.GtG + XtSX
        c = self.Gtb + XtSy
        try:
            L_info = np.linalg.cholesky(info)
        except np.linalg.LinAlgError:
            raise FactorizationError(
                "The global regression matrix H_Y(theta) is rank deficient: use "
                "lower-order regressions for the model or the discrepancy."
            ) from None
        z = np.linalg.solve(L_info, c[:, :, None])[:, :, 0]
        rss = self.rss_perp + self.bb + ySy - np.einsum("kp,kp->k", z, z)
        log_det_S = 2.0 * np.sum(np.log(np.diagonal(L, axis1=1, axis2=2)), axis=1)
        log_det_info = 2.0 * np.sum(
            np.log(np.diagonal(L_info, axis1=1, axis2=2)), axis=1
        )
        out[ok] = -0.5 * (
            (self.M - self.P) * LOG_2PI
            + self.log_det_A
            + log_det_S
            + log_det_info
            + rss
        )
        return out
