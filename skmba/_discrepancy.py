"""Module 2, steps 3-5: the discrepancy GP and the noise by maximum likelihood.

Given the prior-integrated emulator at the field inputs (mean ``m_bar`` and
covariance ``V_bar``, see :mod:`skmba._integration`), the field data obey
(thesis Eqs. 4.18-4.21)::

    vec(Y_e) ~ N(vec(m_bar) + (I_q ⊗ H_d) vec(beta_d),
                 V_bar + Sigma_d ⊗ R_d(omega_d) + Lambda ⊗ I_n)

``beta_d`` is the GLS estimate; ``omega_d`` (the discrepancy kernel),
``Sigma_d`` (full q x q, through its Cholesky factor with a log diagonal)
and ``Lambda`` (diagonal, in log space) maximise the likelihood with analytic
gradients, from the starting point and random restarts, or by scipy's
differential evolution followed by L-BFGS-B (the analogue of the thesis'
genetic algorithm, appendix C.1.3). ``V_bar`` has no Kronecker structure, so
each evaluation factors the ``nq x nq`` covariance once.

Examples
--------
>>> import numpy as np
>>> from skmba._discrepancy import DISCREPANCY_OPTIMIZERS
>>> DISCREPANCY_OPTIMIZERS
('fmin_l_bfgs_b', 'differential_evolution')
"""

import warnings

import numpy as np
from scipy import linalg, optimize
from sklearn.exceptions import ConvergenceWarning
from sklearn.utils import check_random_state

from skmba._linalg import FactorizationError, cholesky, log_det_from_cholesky

DISCREPANCY_OPTIMIZERS = ("fmin_l_bfgs_b", "differential_evolution")
_LOG_REL_NOISE = (np.log(1e-8), np.log(10.0))
_LOG_REL_CHOL_DIAG = (np.log(1e-5), np.log(1e2))
_OFF_DIAG = (-1e2, 1e2)
_LOG_2PI = np.log(2.0 * np.pi)


class DiscrepancyFit:
    """Maximum-likelihood discrepancy GP and noise on top of a fixed covariance.

    Parameters
    ----------
    kernel : sklearn Kernel
        Discrepancy correlation (its ``theta`` is optimised).
    X : ndarray of shape (n, d)
    Y : ndarray of shape (n, q)
        Field data minus the integrated emulator mean.
    H : ndarray of shape (n, p)
        Discrepancy regression matrix.
    V_fixed : ndarray of shape (n q, n q)
        The integrated emulator covariance (``vec`` response-slowest).

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.kernels import Gauss
    >>> X = np.linspace(0, 1, 15)[:, None]
    >>> Y = np.column_stack([np.sin(4 * X[:, 0]), X[:, 0]])
    >>> fit = DiscrepancyFit(Gauss(), X, Y, np.ones((15, 1)), np.zeros((30, 30)))
    >>> fit.optimize(random_state=0).sigma2.shape
    (2, 2)
    """

    def __init__(self, kernel, X, Y, H, V_fixed):
        self.kernel, self.X, self.Y, self.H, self.V_fixed = kernel, X, Y, H, V_fixed
        self.n, self.q = Y.shape
        self.scale = np.maximum(Y.std(axis=0), 1e-8 * max(np.abs(Y).max(), 1e-300))
        self.rows, self.cols = np.tril_indices(self.q)
        self.on_diag = self.rows == self.cols
        self.n_kernel = kernel.n_dims
        self.fixed_noise = None

    def fix_noise(self, relative):
        """Hold the noise at ``relative`` times each response's variance."""
        self.fixed_noise = float(relative)
        return self

    # ------------------------------------------------------- parameters
    def unpack(self, params):
        k, q = self.n_kernel, self.q
        theta = params[:k]
        lam = np.exp(params[k : k + q]) * self.scale**2
        L = np.zeros((q, q))
        L[self.rows, self.cols] = params[k + q :]
        L[np.diag_indices(q)] = np.exp(np.diag(L))
        return theta, lam, L * self.scale[:, None]

    def pack(self, theta, lam, L):
        Ls = L / self.scale[:, None]
        Ls[np.diag_indices(self.q)] = np.log(np.diag(Ls))
        return np.concatenate(
            [theta, np.log(lam / self.scale**2), Ls[self.rows, self.cols]]
        )

    def bounds(self):
        tri = np.array(
            [_LOG_REL_CHOL_DIAG if d else _OFF_DIAG for d in self.on_diag]
        ).reshape(-1, 2)
        parts = [self.kernel.bounds if self.n_kernel else np.zeros((0, 2))]
        noise = _LOG_REL_NOISE
        if self.fixed_noise is not None:
            noise = (np.log(self.fixed_noise),) * 2
        parts += [np.tile(noise, (self.q, 1)), tri]
        return np.vstack(parts)

    # ------------------------------------------------------- likelihood
    def evaluate(self, params, eval_gradient=True):
        """Log-likelihood (and gradient in ``params``) with GLS ``beta``."""
        n, q = self.n, self.q
        theta, lam, L = self.unpack(params)
        k = self.kernel.clone_with_theta(theta) if self.n_kernel else self.kernel
        if eval_gradient:
            R, dR = k(self.X, eval_gradient=True)
        else:
            R, dR = k(self.X), None
        sigma2 = L @ L.T
        V = self.V_fixed + np.kron(sigma2, R) + np.kron(np.diag(lam), np.eye(n))
        C = cholesky(
            V,
            what="field-data covariance of module 2",
            remedy="Use another discrepancy kernel or a larger noise lower bound.",
        )
        Xr = np.kron(np.eye(q), self.H)
        y = self.Y.T.ravel()
        Xw = linalg.solve_triangular(C, Xr, lower=True)
        yw = linalg.solve_triangular(C, y, lower=True)
        Q, G = linalg.qr(Xw, mode="economic")
        beta = linalg.solve_triangular(G, Q.T @ yw)
        rw = yw - Xw @ beta
        ll = -0.5 * (n * q * _LOG_2PI + log_det_from_cholesky(C) + rw @ rw)
        self.last = (k, sigma2, lam, beta.reshape(q, -1).T)
        if not eval_gradient:
            return ll
        alpha = linalg.solve_triangular(C, rw, lower=True, trans="T")
        Vinv = linalg.cho_solve((C, True), np.eye(n * q))
        K = (np.outer(alpha, alpha) - Vinv).reshape(q, n, q, n)
        M = np.einsum("ab,aibj->ij", sigma2, K)
        g_kernel = 0.5 * (dR.reshape(n * n, -1).T @ M.ravel())
        g_sigma = 0.5 * np.einsum("aibj,ij->ab", K, R)
        # Chain rule through L = diag(scale) Ls with a log diagonal.
        g_full = 2.0 * g_sigma @ L
        g_L = g_full[self.rows, self.cols] * self.scale[self.rows]
        g_L[self.on_diag] = np.diag(g_full) * np.diag(L)
        g_lam = 0.5 * np.einsum("aiai->a", K) * lam
        return ll, np.concatenate([g_kernel, g_lam, g_L])

    def _objective(self, params, eval_gradient=True):
        try:
            out = self.evaluate(params, eval_gradient)
        except FactorizationError:
            return (np.inf, np.zeros_like(params)) if eval_gradient else np.inf
        if eval_gradient:
            return -out[0], -out[1]
        return -out

    def start(self):
        """Starting point: discrepancy and noise share the residual variance."""
        cov = np.atleast_2d(np.cov(self.Y, rowvar=False, bias=True))
        L0 = np.linalg.cholesky(0.5 * cov + 1e-3 * np.diag(self.scale**2))
        relative = 0.1 if self.fixed_noise is None else self.fixed_noise
        return self.pack(self.kernel.theta, relative * self.scale**2, L0)

    def optimize(
        self,
        *,
        optimizer="fmin_l_bfgs_b",
        n_restarts=0,
        random_state=None,
        start=None,
        max_iter=None,
    ):
        """Maximise the likelihood; returns ``self`` with the fitted values.

        Sets ``kernel_``, ``sigma2``, ``noise``, ``beta`` (p, q) and
        ``log_likelihood``. ``start`` (packed parameters, see :meth:`pack`)
        replaces the default starting point of :meth:`start`; it is clipped
        to the bounds. ``max_iter`` bounds the L-BFGS-B iterations of each
        start (None: scipy's default); reaching it is not warned about, the
        caller asked for it.
        """
        rng = check_random_state(random_state)
        bounds = self.bounds()
        x0 = self.start() if start is None else np.clip(start, *bounds.T)
        starts = [x0]
        for _ in range(n_restarts):
            s = x0.copy()
            if self.n_kernel:
                kb = bounds[: self.n_kernel]
                s[: self.n_kernel] = rng.uniform(kb[:, 0], kb[:, 1])
            if self.fixed_noise is None:
                s[self.n_kernel : self.n_kernel + self.q] = rng.uniform(
                    np.log(1e-4), 0.0, self.q
                )
            starts.append(s)
        if optimizer == "differential_evolution":
            box = bounds.copy()
            box[~np.isfinite(box)] = 0.0
            off = np.flatnonzero(np.r_[np.zeros(self.n_kernel + self.q), ~self.on_diag])
            box[off] = (-3.0, 3.0)  # off-diagonals of chol(Sigma_d) / scale
            result = optimize.differential_evolution(
                lambda p: self._objective(p, eval_gradient=False),
                box,
                seed=rng.randint(2**31 - 1),
                polish=False,
                tol=1e-6,
                maxiter=300,
            )
            starts = [result.x]
        elif optimizer != "fmin_l_bfgs_b":
            raise ValueError(
                f"discrepancy optimizer={optimizer!r} is not supported; use one "
                f"of {DISCREPANCY_OPTIMIZERS}."
            )
        best = None
        for s in starts:
            res = optimize.minimize(
                self._objective,
                s,
                jac=True,
                method="L-BFGS-B",
                bounds=bounds,
                options={} if max_iter is None else {"maxiter": max_iter},
            )
            capped = max_iter is not None and res.nit >= max_iter
            if not res.success and np.isfinite(res.fun) and not capped:
                warnings.warn(
                    f"The discrepancy likelihood did not fully converge "
                    f"({res.message}).",
                    ConvergenceWarning,
                    stacklevel=2,
                )
            if best is None or res.fun < best.fun:
                best = res
        if not np.isfinite(best.fun):
            raise FactorizationError(
                "The module-2 likelihood could not be evaluated at any start: the "
                "field-data covariance is singular. Check the field data (are "
                "there duplicated rows?) or use another discrepancy kernel."
            )
        self.log_likelihood = self.evaluate(best.x, eval_gradient=False)
        self.kernel_, self.sigma2, self.noise, self.beta = self.last
        self.params = best.x
        return self
