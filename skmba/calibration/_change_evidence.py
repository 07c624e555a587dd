"""The evidence of one batch of readings for a change of the parameters.

Under the reference state, a batch's mean readings ``ybar`` at its distinct
inputs are Gaussian around the reference's prediction of reality ``m`` with
covariance ``Sigma``: the reference posterior's covariance of reality there
(the emulator, the discrepancy and theta, all integrated over the reference
data) plus the noise of each mean. A relative change ``Delta`` of the
parameters, ``theta = theta_0 (1 + Delta)``, moves the mean by ``eta(Delta) =
y_m(x, theta_0 (1 + Delta)) - y_m(x, theta_0)``, ``G Delta`` to first order.
:func:`change_evidence` is the one home of what follows from that:

- the score test of ``Delta = 0``, ``T = b^T A^+ b`` with ``A = G^T Sigma^-1
  G`` and ``b = G^T Sigma^-1 r``, ``r = ybar - m``, chi-squared with ``rank A``
  degrees of freedom under the reference (the linearisation is exact there);
- the posterior of ``Delta`` under a ``N(0, tau^2 I)`` prior (Gauss-Newton on
  ``eta``, then its Laplace covariance);
- Bayes factors of "changed" against "unchanged" with the discrepancy
  integrated out (it is in ``Sigma``): all parameters free, and each alone.

Examples
--------
>>> import numpy as np
>>> G = np.array([[1.0], [1.0]])
>>> ev = change_evidence(np.zeros(2), np.eye(2), lambda d: G @ d, 1, 0.1)
>>> round(ev.p_value, 6), ev.change_mean.tolist()
(1.0, [0.0])
"""

from dataclasses import dataclass

import numpy as np
from scipy import linalg, stats

from skmba._core.linalg import cholesky

_JACOBIAN_STEP = 1e-4  # relative step of the central differences of eta
_GAUSS_NEWTON_STEPS = 20
_RANK_RTOL = 1e-10


@dataclass(frozen=True)
class BatchEvidence:
    """What one batch says about a change (the parameters' relative changes).

    Attributes
    ----------
    statistic : float
        The score statistic ``T`` of "no change".
    degrees : int
        Its degrees of freedom (the parameters the batch can see).
    p_value, log_p_value : float
        ``P(chi2_degrees >= T)``, the false-alarm probability of an alarm
        at this batch, and its logarithm (finite where it underflows).
    log10_bayes_factor : float
        ``log10 p(batch | changed) / p(batch | unchanged)``, the relative
        changes ``N(0, tau^2 I)`` under "changed".
    single_log10_bayes_factors : ndarray of shape (r,)
        The same with only parameter ``j`` free.
    change_mean, change_sd : ndarray of shape (r,)
        The posterior mean and sd of each relative change.
    change_cov : ndarray of shape (r, r)
        Their posterior covariance (Laplace, at the mode).
    residual_statistic, residual_p_value : float
        ``r^T Sigma^-1 r`` and its chi-squared tail with ``n_means`` degrees
        of freedom: how far the batch is from the reference in any
        direction, explained by the parameters or not (a control chart).
    misfit_statistic, misfit_p_value : float
        ``r^T Sigma^-1 r - T``, what no change of the parameters explains
        (to first order), and its chi-squared tail with ``n_means -
        degrees`` degrees of freedom: small where the batch changed in a
        way the model's parameters cannot represent.
    n_means : int
        The measured means of the batch (distinct inputs x responses).
    """

    statistic: float
    degrees: int
    p_value: float
    log_p_value: float
    log10_bayes_factor: float
    single_log10_bayes_factors: np.ndarray
    change_mean: np.ndarray
    change_sd: np.ndarray
    change_cov: np.ndarray
    residual_statistic: float
    residual_p_value: float
    misfit_statistic: float
    misfit_p_value: float
    n_means: int


def jacobian(eta, delta, step=_JACOBIAN_STEP):
    """Central differences ``d eta / d Delta`` (m, r) at ``delta`` (r,)."""
    columns = []
    for j in range(len(delta)):
        e = np.zeros(len(delta))
        e[j] = step
        columns.append((eta(delta + e) - eta(delta - e)) / (2.0 * step))
    return np.column_stack(columns)


def change_evidence(r, Sigma, eta, n_parameters, tau):
    """The evidence of residuals ``r`` (m,) for a change (see the module).

    Parameters
    ----------
    r : ndarray of shape (m,)
        The batch's means minus the reference's prediction of reality.
    Sigma : ndarray of shape (m, m)
        Their covariance under the reference.
    eta : callable
        ``eta(Delta) -> (m,)``, the model's shift for relative changes
        ``Delta`` (r,), zero at zero.
    n_parameters : int
        ``r``.
    tau : float
        Prior sd of each relative change under "changed".

    Returns
    -------
    BatchEvidence

    Raises
    ------
    FactorizationError
        ``Sigma`` is not positive definite.
    """
    L = cholesky(
        Sigma,
        what="covariance of the batch's means under the reference",
        remedy="Group the batch's readings with a coarser bin_width.",
    )

    def white(A):
        return linalg.solve_triangular(L, A, lower=True)

    rw = white(r)
    n_par = n_parameters
    Gw = white(jacobian(eta, np.zeros(n_par)))
    A, b = Gw.T @ Gw, Gw.T @ rw
    values, vectors = linalg.eigh(A)
    seen = values > _RANK_RTOL * max(values.max(), np.finfo(float).tiny)
    proj = vectors[:, seen].T @ b
    statistic = float(np.sum(proj**2 / values[seen]))
    degrees = int(np.sum(seen))
    log_p = float(stats.chi2.logsf(statistic, degrees)) if degrees else 0.0
    residual = float(rw @ rw)
    log_bf = _log_bayes_factor(A, b, tau)
    singles = np.array(
        [
            _log_bayes_factor(A[j : j + 1, j : j + 1], b[j : j + 1], tau)
            for j in range(n_par)
        ]
    )
    mean, cov = _posterior(rw, white, eta, Gw, tau)
    return BatchEvidence(
        statistic,
        degrees,
        float(np.exp(log_p)),
        log_p,
        log_bf / np.log(10.0),
        singles / np.log(10.0),
        mean,
        np.sqrt(np.diag(cov)),
        cov,
        residual,
        float(stats.chi2.sf(residual, len(r))),
        residual - statistic,
        float(stats.chi2.sf(residual - statistic, len(r) - degrees)),
        len(r),
    )


def _log_bayes_factor(A, b, tau):
    """``log N(r; 0, Sigma + tau^2 G G^T) - log N(r; 0, Sigma)`` from the
    whitened ``A = G^T Sigma^-1 G`` and ``b = G^T Sigma^-1 r`` (Woodbury)."""
    P = A + np.eye(len(b)) / tau**2
    C = cholesky(P, what="posterior precision of the relative changes")
    z = linalg.solve_triangular(C, b, lower=True)
    log_det = 2.0 * np.sum(np.log(np.diag(C))) + len(b) * np.log(tau**2)
    return 0.5 * float(z @ z) - 0.5 * log_det


def _posterior(rw, white, eta, Gw, tau):
    """Mode and Laplace covariance of ``Delta`` (Gauss-Newton on ``eta``),
    from ``Delta = 0`` where the whitened Jacobian is ``Gw``; each step's
    Jacobian serves the next step and, at the mode, the covariance."""
    n_par = Gw.shape[1]
    delta = np.zeros(n_par)
    prior_precision = np.eye(n_par) / tau**2
    for _ in range(_GAUSS_NEWTON_STEPS):
        misfit = rw - white(eta(delta)) + Gw @ delta
        C = cholesky(Gw.T @ Gw + prior_precision, what="posterior precision")
        new = linalg.cho_solve((C, True), Gw.T @ misfit)
        done = np.max(np.abs(new - delta)) < 1e-9
        delta = new
        Gw = white(jacobian(eta, delta))
        if done:
            break
    C = cholesky(Gw.T @ Gw + prior_precision, what="posterior precision")
    return delta, linalg.cho_solve((C, True), np.eye(n_par))
