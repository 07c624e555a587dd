"""Module 3 for many response subsets and many theta at once (sensor design).

The sensor designer evaluates the module-3 likelihood of Eq. 4.30 for every response
subset of every Monte Carlo replicate at the same field inputs ``X_e``. What depends on
``theta`` through the emulator does not depend on the responses or on the field data
(:meth:`Emulator.conditional
<skmba.calibration._module1_emulator.Emulator.conditional>`), so
:class:`FieldDesignEmulator` computes it once per ``theta`` for all subsets, and the
simulation block of a subset once per subset; :class:`SubsetLikelihood` then factors the
Schur complement of each ``theta`` in one batched Cholesky
(:func:`~skmba.calibration._module3_likelihood.schur_log_likelihoods`).

Examples
--------
``tests/sensor_design/test_subset_likelihood.py`` checks
:class:`SubsetLikelihood` against
:class:`~skmba.calibration._module3_likelihood.GlobalModel` restricted to the
same responses:

>>> from skmba.sensor_design._subset_likelihood import (
...     FieldDesignEmulator,
...     SubsetLikelihood,
... )
"""

import numpy as np
from scipy import linalg

from skmba._core.linalg import cholesky, log_det_from_cholesky
from skmba.calibration._module3_likelihood import schur_log_likelihoods


class FieldDesignEmulator:
    """The theta-dependent pieces of the global model at a fixed design.

    Per ``theta`` (see
    :class:`~skmba.calibration._module1_emulator.EmulatorConditional`)::

        T(theta)    = R_m(D_e(theta)) - Rt' Rt                  (n, n)
        H_me(theta) = H_m(D_e(theta)) - Rt' C_m^-1 H_m          (n, p_m)
        M(theta)    = Rt' C_m^-1 Y_m                            (n, q)

    Parameters
    ----------
    emulator : Emulator
        The fitted module-1 emulator.
    X_e : ndarray of shape (n, d)
        The field design (standardised).
    """

    def __init__(self, emulator, X_e):
        self.emulator = emulator
        self.X_e = X_e
        self.N, self.q = emulator.Y.shape
        self.n = len(X_e)
        self.p_m = emulator.H_white.shape[1]
        self.log_det_R_m = log_det_from_cholesky(emulator.C)
        # R_m among the field points, when theta-free (a stationary kernel):
        # computed once instead of once per theta.
        self.R_ee = emulator.field_correlation(X_e)
        self._blocks = {}

    def pieces(self, thetas):
        """``T``, ``H_me`` and ``M`` at the rows of ``thetas`` (standardised).

        Returns
        -------
        T : ndarray of shape (k, n, n)
        H_me : ndarray of shape (k, n, p_m)
        M : ndarray of shape (k, n, q)
        """
        cond = self.emulator.conditional(self.X_e, thetas)
        return cond.correlation(prior=self.R_ee), cond.H_me(), cond.M()

    def simulation_block(self, responses):
        """The whitened simulation block of a response subset (cached).

        Returns ``(sigma2_m, G_top, b_top, rss_top_perp, log_det_A)`` for the subset:
        the QR of ``(L_S^-1 ⊗ C_m^-1 H_m)`` and the projection of the whitened
        simulations on it, as in
        :class:`~skmba.calibration._module3_likelihood.GlobalModel`.
        """
        key = tuple(responses)
        if key not in self._blocks:
            idx = list(key)
            s = len(idx)
            em = self.emulator
            sigma2 = em.sigma2[np.ix_(idx, idx)]
            L = cholesky(sigma2, what="emulator response covariance of the subset")
            L_inv = linalg.solve_triangular(L, np.eye(s), lower=True)
            X_top = np.kron(L_inv, em.H_white)
            y_top = linalg.solve_triangular(L, em.Y_white[:, idx].T, lower=True)
            y_top = y_top.ravel()
            Q, G = linalg.qr(X_top, mode="economic")
            b = Q.T @ y_top
            log_det_A = self.N * log_det_from_cholesky(L) + s * self.log_det_R_m
            self._blocks[key] = (sigma2, G, b, float(y_top @ y_top - b @ b), log_det_A)
        return self._blocks[key]


class SubsetLikelihood:
    """Eq. 4.30 for a subset of the responses, at many ``theta`` at once.

    The discrepancy and noise of the subset are those of all responses restricted to it
    (``Sigma_d[S, S]``, ``Lambda[S]``), which is what a multi-response GP implies for a
    subset. The Schur complement ``S(theta)`` of each ``theta`` is factored in one
    batched Cholesky and the regression coefficients are integrated out through one
    batched QR
    (:func:`~skmba.calibration._module3_likelihood.schur_log_likelihoods`, as for
    the calibrator).

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
        # [G_top, b_top] of the simulation block (no discrepancy columns).
        self.top = np.zeros((pm, self.P + 1))
        self.top[:, :pm] = G
        self.top[:, self.P] = b
        self.S_fixed = np.kron(sigma2_d[np.ix_(idx, idx)], R_d) + np.kron(
            np.diag(np.asarray(noise)[idx]), np.eye(n)
        )
        self.X_d = np.kron(np.eye(s), H_d)  # (n s, p_d s)
        self.Y_e = Y_e[:, idx]
        self.M = (design.N + n) * s
        # The model term of S(theta) is positive semi-definite: the noise
        # bounds its smallest eigenvalue from below.
        self.noise_floor = float(np.min(np.asarray(noise)[idx]))

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
        Z = np.concatenate([X, y[:, :, None]], axis=2)
        return schur_log_likelihoods(
            S, Z, self.noise_floor, self.top, self.rss_perp, self.log_det_A, self.M
        )
