"""Multi-response Gaussian process likelihoods and predictive moments.

Two exact evaluators of the Gaussian log-likelihood of ``vec(Y)`` under the
model ``vec(Y) ~ N((I_q ⊗ H) vec(beta), V)`` (thesis chapter 3), each also
returning what prediction needs:

* :class:`NoiseFreeLikelihood`, ``V = Sigma2 ⊗ R``: ``beta`` and ``Sigma2``
  are concentrated out in closed form (GLS, and ``Sigma2 = E' R^-1 E / N``,
  the maximum-likelihood estimate of Eq. 4.6), so one N x N Cholesky serves
  any number of responses (Eq. 3.19 with the corrected constant).
* :class:`NoisyLikelihood`, ``V = Sigma2 ⊗ R + Lambda ⊗ I`` (Eq. 3.35) with
  diagonal ``Lambda``: evaluated through :class:`skmba._core.linalg.KroneckerEigen`
  in O(N^3 + q^3), with analytic gradients with respect to the kernel
  hyperparameters, the Cholesky factor of ``Sigma2`` and ``log Lambda``.

Both use ``beta`` at its GLS estimate, so by the envelope theorem the gradient
is ``1/2 [alpha' dV alpha - tr(V^-1 dV)]`` with ``alpha = V^-1 vec(Y - H beta)``.
Predictions are universal kriging: the variance includes the regression term
``u' (H' V^-1 H)^-1 u`` (Eqs. 3.33 and 3.40).

All quantities here are in the internal (possibly standardised) units of the
caller; :class:`skmba.MultiResponseGP` converts to user units.

Examples
--------
>>> import numpy as np
>>> from skmba.gp._likelihood import NoiseFreeLikelihood
>>> R = np.array([[1.0, 0.2], [0.2, 1.0]])
>>> fit = NoiseFreeLikelihood(R, np.ones((2, 1)), np.array([[0.0], [1.0]]))
>>> fit.sigma2
array([[0.3125]])
"""

import numpy as np
from scipy import linalg

from skmba._core.linalg import (
    LOG_2PI,
    FactorizationError,
    KroneckerEigen,
    cholesky,
    cholesky_inverse,
    log_det_from_cholesky,
    symmetric_eigh,
    whitened_gls,
)

#: Name given to the correlation matrix in factorisation errors
#: (``FactorizationError.what``): only its failures are repaired by a larger
#: nugget.
R_WHAT = "correlation matrix R"

R_REMEDY = (
    "Increase the nugget `alpha` (e.g. alpha=1e-8 or larger), remove "
    "duplicated input points, or use a rougher kernel (Exp, Matern, "
    "a larger lower bound on the roughness)."
)


class GradientContraction:
    """The derivatives of ``R`` given through their contractions.

    ``contraction(weight)`` returns ``[sum(weight * dR[:, :, k]) for k]``
    for a symmetric (N, N) ``weight``, which is all the likelihood
    gradients need (``tr(W dR_k)``), without the stacked (N, N, n_dims)
    array: the DACE kernels compute it one hyperparameter at a time
    (:meth:`skmba._core.dace.DACECorrelation._weighted_log_gradient`).

    Parameters
    ----------
    contract : callable
        ``contract(weight) -> ndarray of shape (n_dims,)``.
    n_dims : int
        Number of hyperparameters.

    Examples
    --------
    >>> import numpy as np
    >>> dR = GradientContraction(lambda w: np.array([np.trace(w)]), 1)
    >>> dR(np.eye(3)), dR.with_diagonal(2.0)(np.eye(3))
    (array([3.]), array([3., 6.]))
    """

    def __init__(self, contract, n_dims):
        self.contract = contract
        self.n_dims = n_dims

    def __call__(self, weight):
        return np.asarray(self.contract(weight), dtype=float)

    def with_diagonal(self, scale):
        """One more derivative, ``scale * I`` (a log nugget), appended last."""
        return GradientContraction(
            lambda weight: np.append(self(weight), scale * np.trace(weight)),
            self.n_dims + 1,
        )


def _n_gradients(dR):
    """Number of hyperparameters of a stacked ``dR`` or a contraction."""
    return dR.n_dims if isinstance(dR, GradientContraction) else dR.shape[2]


def _weighted_trace_gradient(dR, weight):
    """``[sum(weight * dR[:, :, k]) for k]``: through the contraction, or
    without a Python loop from a stacked (N, N, n_theta) array."""
    if isinstance(dR, GradientContraction):
        return dR(weight)
    n = weight.shape[0]
    return dR.reshape(n * n, -1).T @ weight.ravel()


class NoiseFreeLikelihood:
    """Concentrated likelihood of ``vec(Y) ~ N(vec(H beta), Sigma2 ⊗ R)``.

    Parameters
    ----------
    R : ndarray of shape (N, N)
        Correlation matrix (nugget already added).
    H : ndarray of shape (N, p)
    Y : ndarray of shape (N, q)
    dR : ndarray of shape (N, N, n_theta) or GradientContraction, optional
        Derivatives of ``R`` with respect to the kernel's log-hyperparameters
        (stacked, or through their contractions); when given,
        :attr:`gradient` is computed.
    ridge : float, default=0
        Added to the diagonal of ``Sigma2`` (internal units): lets exactly
        linearly dependent responses (whose ``E' R^-1 E`` is singular) be
        emulated. The likelihood is then evaluated at this plug-in ``Sigma2``
        and its gradient includes the dependence of ``Sigma2`` on the kernel.

    Attributes
    ----------
    log_likelihood : float
        ``-(Nq/2) log 2 pi - (N/2) log|Sigma2| - (q/2) log|R|
        - tr(Sigma2^-1 E' R^-1 E) / 2``, which is
        ``-(Nq/2)(log 2 pi + 1) - ...`` without ridge.
    gradient : ndarray of shape (n_theta,) or None
    beta : ndarray of shape (p, q)
    sigma2 : ndarray of shape (q, q)
        ``E' R^-1 E / N + ridge I`` with ``E = Y - H beta``.
    """

    def __init__(self, R, H, Y, dR=None, ridge=0.0):
        N, q = Y.shape
        self.C = cholesky(R, what=R_WHAT, remedy=R_REMEDY)
        self.gls = whitened_gls(self.C, H, Y)
        resid = self.gls.residual
        S = resid.T @ resid
        self.sigma2 = S / N + ridge * np.eye(q)
        self.sigma2_chol = cholesky(
            self.sigma2,
            what="estimated response covariance Sigma2",
            remedy=(
                "Some responses are (nearly) linear combinations of others. "
                "Drop the redundant responses, set a response_nugget, or fit "
                "with noise=True."
            ),
        )
        if ridge == 0.0:
            explained = np.diag(self.sigma2_chol) ** 2 <= 1e-12 * np.maximum(
                Y.var(axis=0), 1e-300
            )
            if np.any(explained):
                raise FactorizationError(
                    "The estimated response covariance Sigma2 is singular: "
                    f"response(s) {np.flatnonzero(explained).tolist()} are "
                    "exactly explained by the regression terms or by the other "
                    "responses. Drop the redundant responses, use a lower-order "
                    "regression, set a response_nugget, or fit with noise=True."
                )
        # tr(Sigma2^-1 S) = Nq without ridge (the concentrated optimum).
        L_inv_resid = linalg.solve_triangular(self.sigma2_chol, resid.T, lower=True)
        quad = float(np.sum(L_inv_resid**2))
        self.log_likelihood = (
            -0.5 * N * q * LOG_2PI
            - 0.5 * N * log_det_from_cholesky(self.sigma2_chol)
            - 0.5 * q * log_det_from_cholesky(self.C)
            - 0.5 * quad
        )
        self.gradient = None
        if dR is not None:
            # alpha = R^-1 E Sigma2^-1 in matrix form; quadratic weight
            # A Sigma2^-1 A' with A = R^-1 E = C^-T resid. With a ridge,
            # Sigma2 = S/N + ridge I is not the optimum, and its dependence on
            # theta adds ridge * A Sigma2^-2 A'.
            A = linalg.solve_triangular(self.C, resid, lower=True, trans="T")
            B = linalg.solve_triangular(self.sigma2_chol, A.T, lower=True)
            # B'B - q R^-1, built in place (fewer N x N temporaries).
            weight = cholesky_inverse(self.C, what=R_WHAT, remedy=R_REMEDY)
            weight *= -q
            weight += B.T @ B
            if ridge:
                D = linalg.cho_solve((self.sigma2_chol, True), A.T)
                weight += ridge * (D.T @ D)
            self.gradient = 0.5 * _weighted_trace_gradient(dR, weight)

    @property
    def beta(self):
        return self.gls.beta

    def predict(self, r_cross, h_star, r_star, full_cov):
        """Predictive mean and correlation factor at new points.

        Parameters
        ----------
        r_cross : ndarray of shape (N, s)
            Correlations between training and new points.
        h_star : ndarray of shape (s, p)
        r_star : ndarray of shape (s,) or (s, s)
            Prior correlations at the new points (diagonal or full).
        full_cov : bool

        Returns
        -------
        mean : ndarray of shape (s, q)
        c : ndarray of shape (s,) or (s, s)
            The predictive covariance is ``Sigma2 ⊗ c`` (Eq. 3.33).
        """
        g = self.gls
        Rt = linalg.solve_triangular(self.C, r_cross, lower=True)
        mean = h_star @ g.beta + Rt.T @ g.residual
        u = h_star.T - g.H_white.T @ Rt
        ut = linalg.solve_triangular(g.G, u, trans="T")
        if full_cov:
            c = r_star - Rt.T @ Rt + ut.T @ ut
        else:
            c = r_star - np.sum(Rt**2, axis=0) + np.sum(ut**2, axis=0)
        return mean, c

    def expand_covariance(self, c):
        """Expand ``Sigma2 ⊗ c`` into (s, q) variances or the (s, q, s, q) cov."""
        if c.ndim == 1:
            return np.outer(c, np.diag(self.sigma2))
        return np.einsum("ab,kl->akbl", c, self.sigma2)


class NoisyLikelihood:
    """Likelihood of ``vec(Y) ~ N(vec(H beta), Sigma2 ⊗ R + diag(lam) ⊗ I)``.

    Parameters
    ----------
    R : ndarray of shape (N, N)
        Correlation matrix (nugget already added).
    H : ndarray of shape (N, p)
    Y : ndarray of shape (N, q)
    sigma2 : ndarray of shape (q, q)
        Symmetric positive semi-definite ``Sigma2`` (singular allowed).
    lam : ndarray of shape (q,)
        Noise variances.
    dR : ndarray of shape (N, N, n_theta) or GradientContraction, optional
        When given, the gradients below are computed (``n_theta`` may be 0:
        then only those with respect to ``L`` and ``lam``).
    eig : tuple (s, U), optional
        A precomputed eigendecomposition of ``R`` (reused while only ``L``
        and ``lam`` change).

    Attributes
    ----------
    log_likelihood : float
    grad_kernel : ndarray of shape (n_theta,)
        With respect to the kernel's log-hyperparameters.
    grad_sigma2 : ndarray of shape (q, q)
        Symmetric matrix with ``d loglik = tr(grad_sigma2 dSigma2)`` for any
        symmetric perturbation ``dSigma2``.
    grad_lam : ndarray of shape (q,)
        With respect to ``lam``.
    beta : ndarray of shape (p, q)
    """

    def __init__(self, R, H, Y, sigma2, lam, dR=None, eig=None):
        N, q = Y.shape
        s, U = symmetric_eigh(R, what=R_WHAT) if eig is None else eig
        self.sigma2 = sigma2
        ke = self.ke = KroneckerEigen(s, U, self.sigma2, lam)
        # GLS decouples per eigen-column i in the reparametrisation
        # gamma = beta M: weighted least squares of Z[:, i] on F.
        self.F = U.T @ H
        Z = ke.to_eigenbasis(Y)
        root_w = np.sqrt(ke.w)  # (N, q)
        Fw = root_w.T[:, :, None] * self.F[None]  # (q, N, p)
        Q, self.G_reg = np.linalg.qr(Fw)  # batched: G_reg[i]' G_reg[i] = F' W_i F
        diag = np.abs(np.diagonal(self.G_reg, axis1=1, axis2=2))  # (q, p)
        if np.any(diag.min(axis=1) <= 1e-10 * diag.max(axis=1)):
            raise FactorizationError(
                "The regression matrix H is rank deficient: use a lower-order "
                "regression or provide more distinct input points."
            )
        rhs = np.einsum("inp,ni->ip", Q, root_w * Z)  # (q, p)
        gamma = np.stack(
            [linalg.solve_triangular(self.G_reg[i], rhs[i]) for i in range(q)], axis=1
        )  # (p, q)
        self.beta = gamma @ ke.G.T
        resid = self.resid = Z - self.F @ gamma
        self.zw = ke.w * resid  # V^-1 vec(E) in eigen coordinates
        self.log_likelihood = -0.5 * (
            N * q * LOG_2PI + ke.log_det + np.sum(resid * self.zw)
        )
        self.grad_kernel = self.grad_sigma2 = self.grad_lam = None
        if dR is not None:
            A = U @ self.zw @ ke.M.T  # V^-1 vec(E) as (N, q)
            self.grad_kernel = np.zeros(_n_gradients(dR))
            if self.grad_kernel.size:
                c1 = ke.w @ ke.e  # (N,): sum_i e_i w_ji
                # A Sigma2 A' - U diag(c1) U', built in place.
                weight = (U * c1) @ U.T
                weight *= -1.0
                weight += (A @ self.sigma2) @ A.T
                self.grad_kernel = 0.5 * _weighted_trace_gradient(dR, weight)
            RA = U @ (s[:, None] * (U.T @ A))
            c2 = s @ ke.w  # (q,): sum_j s_j w_ji
            self.grad_sigma2 = 0.5 * (A.T @ RA - (ke.M * c2) @ ke.M.T)
            c3 = ke.w.sum(axis=0)  # (q,)
            self.grad_lam = 0.5 * (np.sum(A**2, axis=0) - (ke.M**2) @ c3)

    def predict(self, r_cross, h_star, r_star, full_cov):
        """Predictive mean and per-eigencolumn covariance factors.

        Returns
        -------
        mean : ndarray of shape (s, q)
        K : ndarray of shape (q, s) or (q, s, s)
            The predictive covariance is
            ``cov[(k, a), (l, b)] = sum_i G[k, i] G[l, i] K[i, a, b]`` with
            ``G = Lambda^1/2 W`` (Eq. 3.40 in the eigenbasis).
        """
        ke = self.ke
        T = ke.U.T @ r_cross  # (N, s)
        mean = h_star @ self.beta + T.T @ (self.zw * ke.e) @ ke.G.T
        q = ke.e.size
        K = []
        for i in range(q):
            wT = ke.w[:, i : i + 1] * T
            v = h_star - ke.e[i] * (wT.T @ self.F)  # (s, p)
            vt = linalg.solve_triangular(self.G_reg[i], v.T, trans="T")
            if full_cov:
                K.append(ke.e[i] * r_star - ke.e[i] ** 2 * (T.T @ wT) + vt.T @ vt)
            else:
                K.append(
                    ke.e[i] * r_star
                    - ke.e[i] ** 2 * np.sum(T * wT, axis=0)
                    + np.sum(vt**2, axis=0)
                )
        return mean, np.asarray(K)

    def expand_covariance(self, K):
        """Expand the factors into (s, q) variances or the (s, q, s, q) cov."""
        G = self.ke.G
        if K.ndim == 2:
            return K.T @ (G**2).T
        return np.einsum("ki,li,iab->akbl", G, G, K)

    def fisher_score_and_information(self, L):
        """Score and expected information in ``(L, log lam)`` coordinates.

        ``Sigma2 = L L'`` with ``L`` lower triangular (entries unconstrained,
        so singular ``Sigma2`` is allowed) and ``lam = exp(log lam)``. In the
        eigenbasis of ``R`` the residual rows are independent with covariance
        ``C_j = s_j Sigma2 + Lambda``; in the coordinates ``S = M' Sigma2 M``
        the expected information of ``S`` is diagonal and closed form in
        ``w = 1/(1 + s e')``. The chain rule through ``Sigma2 = L L'`` gives
        a Gauss-Newton (Fisher) approximation of the Hessian.

        Returns
        -------
        score : ndarray of shape (q(q+1)/2 + q,)
        information : ndarray of shape (q(q+1)/2 + q, q(q+1)/2 + q)
        """
        ke = self.ke
        q = ke.e.size
        rows, cols = np.triu_indices(q)  # pairs (c <= d) of S
        mult = np.where(rows == cols, 1.0, 2.0)
        s = ke.s[:, None]
        swz = np.sqrt(s) * self.zw
        score_S = 0.5 * (swz.T @ swz - np.diag((s * ke.w).sum(axis=0)))
        noise_resid = self.zw @ ke.M.T
        score_lam = 0.5 * (
            np.sum(noise_resid**2, axis=0) - (ke.M**2) @ ke.w.sum(axis=0)
        )
        P = (s**2 * ke.w).T @ ke.w  # sum_j s_j^2 w_ja w_jb
        T = (s * ke.w).T @ ke.w  # sum_j s_j w_ja w_jb
        Omega = ke.w.T @ ke.w  # sum_j w_ja w_jb
        Mr, Mc = ke.M[:, rows], ke.M[:, cols]  # (q, n_pairs)
        info_SS = np.diag(0.5 * mult * P[rows, cols])
        info_Sl = 0.5 * (mult * T[rows, cols])[:, None] * (Mr * Mc).T
        MM = np.einsum("ka,la->kla", ke.M, ke.M)
        info_ll = 0.5 * np.einsum("ab,kla,klb->kl", Omega, MM, MM)
        # Jacobian of the S pairs w.r.t. the lower entries L[a, b], a >= b:
        # dS = M'(E_ab L' + L E_ba) M = outer(M[a], K[b]) + outer(K[b], M[a]).
        K = L.T @ ke.M
        la, lb = np.tril_indices(q)
        J_S = ke.M[la][:, rows] * K[lb][:, cols] + K[lb][:, rows] * ke.M[la][:, cols]
        J_S = J_S.T  # (n_pairs, n_lower)
        lam = ke.lam
        score = np.concatenate([J_S.T @ (mult * score_S[rows, cols]), lam * score_lam])
        info = np.block(
            [
                [J_S.T @ info_SS @ J_S, (J_S.T @ info_Sl) * lam],
                [lam[:, None] * (info_Sl.T @ J_S), np.outer(lam, lam) * info_ll],
            ]
        )
        return score, info


def _lower_root(sigma2):
    """Lower-triangular L with L L' = sigma2 (PSD), through a QR."""
    values, vectors = linalg.eigh(0.5 * (sigma2 + sigma2.T))
    root = vectors * np.sqrt(np.clip(values, 0.0, None))
    return linalg.qr(root.T, mode="r")[0][: len(sigma2)].T


class _FixedKernel:
    """The noisy likelihood as a function of ``(Sigma2, log lam)`` alone."""

    def __init__(self, R, H, Y, eig):
        self.R, self.H, self.Y, self.eig = R, H, Y, eig

    def evaluate(self, sigma2, log_lam, gradient=False):
        N = len(self.Y)
        dR = np.zeros((N, N, 0)) if gradient else None
        return NoisyLikelihood(
            self.R, self.H, self.Y, sigma2, np.exp(log_lam), dR, eig=self.eig
        )

    def revive(self, fit, log_lam):
        """Grow a singular Sigma2 along its null space where that helps.

        Columns of L that reach 0 are stationary in L coordinates, so the
        Levenberg-Marquardt iterations cannot bring them back; the
        Karush-Kuhn-Tucker condition on the null space of Sigma2 can.
        """
        values, vectors = linalg.eigh(fit.sigma2)
        null = vectors[:, values <= 1e-8 * max(values[-1], 1e-300)]
        if null.shape[1] == 0:
            return None
        grad = self.evaluate(fit.sigma2, log_lam, gradient=True).grad_sigma2
        mu, v = linalg.eigh(null.T @ grad @ null)
        if mu[-1] <= 0:
            return None
        u = null @ v[:, -1]
        best, size = None, 1e-6 * max(np.trace(fit.sigma2), np.exp(log_lam).max())
        for _ in range(12):
            candidate = self.evaluate(fit.sigma2 + size * np.outer(u, u), log_lam)
            if candidate.log_likelihood <= (best or fit).log_likelihood:
                break
            best, size = candidate, size * 4.0
        return best

    def damped_step(self, fit, L, log_lam, damping, log_bounds):
        """One Levenberg-Marquardt step from ``fit`` that raises the likelihood.

        Returns ``((L, log_lam, fit) or None, damping)``: the damping grows
        until a step is accepted (or beyond 1e10: None), then shrinks.
        """
        la, lb = np.tril_indices(len(L))
        score, info = fit.fisher_score_and_information(L)
        scale = np.diag(info).copy()
        scale[scale <= 0] = 1.0
        while damping < 1e10:
            try:
                factor = linalg.cho_factor(info + damping * np.diag(scale))
            except linalg.LinAlgError:
                damping *= 10.0
                continue
            step = linalg.cho_solve(factor, score)
            L_new = L.copy()
            L_new[la, lb] += step[: la.size]
            log_lam_new = np.clip(
                log_lam + step[la.size :], log_bounds[:, 0], log_bounds[:, 1]
            )
            try:
                candidate = self.evaluate(L_new @ L_new.T, log_lam_new)
            except FactorizationError:
                candidate = None
            if candidate is not None and candidate.log_likelihood > fit.log_likelihood:
                return (L_new, log_lam_new, candidate), max(damping / 3.0, 1e-9)
            damping *= 4.0
        return None, damping


def maximise_noise_and_sigma2(R, H, Y, sigma2, lam, *, eig, lam_bounds, tol, max_iter):
    """Maximise the likelihood over ``(Sigma2, lam)`` with the kernel fixed.

    Levenberg-Marquardt on the Fisher information
    (:meth:`NoisyLikelihood.fisher_score_and_information`) in the coordinates
    ``(L, log lam)``, ``Sigma2 = L L'``: positive semi-definite by
    construction, and able to reach the singular ``Sigma2`` that strongly
    correlated responses often have. A step is kept only when the
    likelihood increases (``beta`` is re-estimated by GLS at every
    evaluation); the damping adapts. ``lam`` stays within ``lam_bounds``
    (shape (q, 2)). When the steps stop gaining (less than
    ``tol * (1 + |loglik|)``) at a singular ``Sigma2``, the gradient on its
    null space is checked and ``Sigma2`` grown along any ascent direction
    before the iterations resume, so the result satisfies the first-order
    optimality conditions of the constrained problem.

    Returns
    -------
    fit : NoisyLikelihood
        At the final ``(Sigma2, lam)``.
    n_iter : int
        Number of information evaluations.
    """
    model = _FixedKernel(R, H, Y, eig)
    log_bounds = np.log(lam_bounds)  # (q, 2)
    log_lam = np.clip(np.log(lam), log_bounds[:, 0], log_bounds[:, 1])
    fit = model.evaluate(_lower_root(sigma2) @ _lower_root(sigma2).T, log_lam)
    L = _lower_root(fit.sigma2)
    damping = 1e-3
    n_iter = 0
    while n_iter < max_iter:
        n_iter += 1
        accepted, damping = model.damped_step(fit, L, log_lam, damping, log_bounds)
        if accepted is not None:
            gain = accepted[2].log_likelihood - fit.log_likelihood
            L, log_lam, fit = accepted
            if gain > tol * (1.0 + abs(fit.log_likelihood)):
                continue
        revived = model.revive(fit, log_lam)
        if revived is None:
            break
        fit, L, damping = revived, _lower_root(revived.sigma2), 1e-3
    return fit, n_iter
