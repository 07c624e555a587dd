"""Can the data tell theta from the discrepancy? ``identifiability_``.

Near the posterior mean ``theta_bar`` the field data depend on theta through
the emulator's sensitivities ``J = d m(X_e, theta) / d theta`` (nq x r,
standardised). With only the noise and the emulator's own uncertainty
``V_0 = Lambda ⊗ I + Sigma_m ⊗ T(theta_bar)`` in the way, the data's
information on theta is ``J' V_0^-1 J``: its inverse's diagonal gives
``data_sd``, the linearised posterior sd of each parameter if the model had
no error (the fitted noise variances, a flat prior on theta). A
discrepancy adds ``Sigma_d ⊗ R_d`` and a mean ``(I ⊗ H_d) beta_d`` with a
flat prior, which leaves ``J' Pi J`` with ``Pi = V^-1 - V^-1 X (X' V^-1
X)^-1 X' V^-1``, ``V = V_0 + Sigma_d ⊗ R_d``, ``X = I ⊗ H_d``.

``identifiability_[j]`` is ``data_sd[j]`` over theta_j's posterior sd (at
most 1): the share of the interval's width that the data alone account
for (``"propagate"``, the default). The posterior integrates over the
discrepancy's hyperparameters (the module-3 mixture), so the diagnosis is
integrated over module 2's posterior as the interval is. Near 1 the data
identify theta whatever the discrepancy; near 0 the discrepancy widened
the interval many times over: a discrepancy shaped like theta's effect on the observed
responses mimics a change of theta, and the width is set by what the prior
says about the discrepancy (its roughness range first), not by the data.
Below :data:`IDENTIFIABILITY_THRESHOLD` ``fit`` warns
(:class:`~skmba.exceptions.NonIdentifiabilityWarning`). Where the data carry
no information at all the interval is the prior's, whatever the
discrepancy: 1, no warning. With several parameters each is judged given
the others (:func:`data_share`): a parameter tied to another along a
ridge is judged by the width across it.

The plug-in (``discrepancy_uncertainty="plug-in"``) has no posterior of
the hyperparameters to integrate over: an estimate near zero would leave
the data's width and no warning where a discrepancy of theta's shape
would go unseen. There ``identifiability_`` is the probe's ratio, ``data_sd``
over ``probe_sd`` below: what a discrepancy of plausible size would do.

The linearised posterior sd with a discrepancy of plausible size, each
response's sd at the 95 % point of its prior
(:meth:`~skmba.priors._hyperprior.Hyperprior.sd_quantile`) with the fitted
roughness and correlation between responses, is ``probe_sd``. (It gave
``theta_robust_interval_``, removed: a Gaussian width at one fixed
discrepancy size, labelled 95 % with no posterior behind it; the range of
theta over a stated class of discrepancy priors is the ``union`` rows of
``prior_sensitivity()``.)

Examples
--------
A sensitivity orthogonal to the discrepancy's constant mean, and a
discrepancy of no size: the same sd with and without it.

>>> import numpy as np
>>> J, V0 = np.array([[1.0], [-1.0]]), np.eye(2)
>>> linearised_sds(J, V0, 0.0 * V0, np.ones((2, 1)))
(array([0.70710678]), array([0.70710678]))
"""

from dataclasses import dataclass

import numpy as np
from scipy import linalg

from skmba._core.linalg import observed_block, observed_rows, stacked_whitening
from skmba._core.regression import regression_basis
from skmba._core.warn import warn
from skmba.calibration._field_replicates import noise_covariance
from skmba.exceptions import NonIdentifiabilityWarning

#: ``fit`` warns for a parameter whose ``identifiability_`` is below this:
#: the discrepancy more than tripled its posterior sd.
IDENTIFIABILITY_THRESHOLD = 1.0 / 3.0
#: Prior quantile of the discrepancy sd at which theta is probed.
PROBE_LEVEL = 0.95
# Finite-difference step of the sensitivities (standardised theta).
_STEP = 1e-3


@dataclass(frozen=True)
class Identifiability:
    """The probe of :func:`identifiability` (standardised theta).

    Attributes
    ----------
    ratio : ndarray of shape (r,)
        ``identifiability_`` (:func:`data_share`).
    probe_sd : ndarray of shape (r,)
        The linearised posterior sd with a discrepancy of plausible size
        (``inf`` where it can explain all of theta's effect).
    """

    ratio: np.ndarray
    probe_sd: np.ndarray


def _marginal_variances(info):
    """Diagonal of ``info^-1``, ``inf`` where ``info`` is singular there
    (``info`` (r, r) or a stack of them)."""
    values, vectors = np.linalg.eigh(0.5 * (info + np.swapaxes(info, -1, -2)))
    tol = 1e-12 * np.maximum(values.max(axis=-1, keepdims=True), 1e-300)
    inv = np.where(values > tol, 1.0 / np.maximum(values, tol), np.inf)
    with np.errstate(invalid="ignore"):
        out = np.einsum("...ij,...j,...ij->...i", vectors, inv, vectors)
    return np.where(np.isnan(out), np.inf, out)


def linearised_sds(J, V0, K_d, X_d):
    """Linearised posterior sds of theta, without and with the discrepancy.

    ``sqrt(diag((J' V0^-1 J)^-1))`` and ``sqrt(diag((J' Pi J)^-1))``
    (module docstring), ``inf`` where the information is singular.

    Parameters
    ----------
    J : ndarray of shape (m, r)
        Sensitivities of the data to theta.
    V0 : ndarray of shape (m, m)
        Covariance without a discrepancy.
    K_d : ndarray of shape (m, m)
        The discrepancy's covariance.
    X_d : ndarray of shape (m, p)
        The discrepancy's mean basis (flat prior on its coefficients).

    Returns
    -------
    sd0, sd1 : ndarray of shape (r,)
    """
    var0 = _marginal_variances(data_information(J, V0))
    var1 = _marginal_variances(probe_information(J, V0, K_d, X_d))
    return np.sqrt(var0), np.sqrt(var1)


def data_information(J, V0):
    """The data's information on theta without a discrepancy, ``J' V0^-1 J``."""
    Jw = linalg.solve_triangular(linalg.cholesky(V0, lower=True), J, lower=True)
    return Jw.T @ Jw


def probe_information(J, V0, K_d, X_d):
    """Its information with the discrepancy ``K_d`` and mean basis ``X_d``
    (flat prior on the coefficients), ``J' Pi J`` (module docstring)."""
    C1 = linalg.cholesky(V0 + K_d, lower=True)
    Jw1 = linalg.solve_triangular(C1, J, lower=True)
    Xw1 = linalg.solve_triangular(C1, X_d, lower=True)
    Q, _ = np.linalg.qr(Xw1)
    Jp = Jw1 - Q @ (Q.T @ Jw1)
    return Jp.T @ Jp


def data_share(information, posterior_cov):
    """``identifiability_``: per parameter, its posterior sd given the other
    parameters over the data's alone, ``sqrt(P_jj / I_jj)``, at most 1.

    ``information`` is the data's information ``J' V_0^-1 J`` (r, r),
    ``posterior_cov`` theta's posterior covariance (r, r), ``P`` its
    inverse; both standardised alike. For one parameter: the linearised sd
    without a discrepancy over the posterior sd. 1 where the data carry no
    information on the parameter, or the posterior none beyond the data's.

    Examples
    --------
    One parameter whose data sd is 0.1 and posterior sd 1; then two whose
    posterior sds are 1 but correlated: given the second, the first's is
    0.14, against the data's 0.1 given the second; the second's, 0.14, is
    within the data's 0.2:

    >>> info = np.diag([100.0, 25.0])
    >>> data_share(info[:1, :1], np.array([[1.0]]))
    array([0.1])
    >>> cov = np.array([[1.0, 0.99], [0.99, 1.0]])
    >>> np.round(data_share(info, cov), 3)
    array([0.709, 1.   ])
    """
    # diag(posterior_cov^-1), inf along a direction the posterior pins down
    precision = _marginal_variances(np.atleast_2d(posterior_cov))
    diagonal = np.diagonal(np.atleast_2d(information), axis1=-2, axis2=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.sqrt(precision / diagonal)
    return np.where(np.isnan(ratio), 1.0, np.minimum(ratio, 1.0))


def identifiability(model, theta, posterior_cov, hyperprior):
    """``identifiability_`` of a fitted global model at ``theta`` (standardised).

    Parameters
    ----------
    model : GlobalModel
        At the module-2 mode (its roughness, correlation and noise are used).
    theta : ndarray of shape (r,)
        The posterior mean.
    posterior_cov : ndarray of shape (r, r) or None
        Theta's posterior covariance (standardised), with the
        hyperparameters integrated out; None for the plug-in, whose
        estimate leaves no posterior to integrate over: the ratio is then
        the probe's (module docstring).
    hyperprior : Hyperprior

    Returns
    -------
    Identifiability
    """
    X_e, q, n = model.X_e, model.q, model.n
    J, T = sensitivities(model.emulator, X_e, theta[None, :])
    J = J[0].transpose(1, 0, 2).reshape(q * n, theta.size)  # response-slowest, vec(Y)
    T = T[0]
    V0 = np.kron(model.sigma2_m, T) + noise_covariance(model.noise, n, model.replicates)
    sd = np.sqrt(np.clip(np.diag(model.sigma2_d), 1e-300, None))
    corr = model.sigma2_d / np.outer(sd, sd)
    big = hyperprior.sd_quantile(PROBE_LEVEL, q)
    K_d = np.kron(corr * np.outer(big, big), model.kernel_d(X_e))
    X_d = np.kron(np.eye(q), regression_basis(X_e, model.regression_d))
    obs = model.observed  # the measured entries only
    args = (
        observed_rows(J, obs),
        observed_block(V0, obs),
        observed_block(K_d, obs),
        observed_rows(X_d, obs),
    )
    information = data_information(*args[:2])
    probe_sd = probe_sds(*args)
    if posterior_cov is not None:
        return Identifiability(data_share(information, posterior_cov), probe_sd)
    return Identifiability(probe_share(information, probe_sd), probe_sd)


def probe_share(information, probe_sd):
    """The plug-in's ``identifiability_``: the linearised sd without a
    discrepancy (from the data's ``information``) over ``probe_sd``, the
    one with a discrepancy of plausible size; 0 where that is infinite."""
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.sqrt(_marginal_variances(information)) / probe_sd
    return np.where(np.isfinite(ratio), ratio, 0.0)


def probe_sds(J, V0, K_d, X_d):
    """``probe_sd``: the linearised posterior sd of each parameter with the
    discrepancy ``K_d`` of plausible size (``inf`` where it can explain all
    of the parameter's effect)."""
    return np.sqrt(_marginal_variances(probe_information(J, V0, K_d, X_d)))


def stacked_probe_sds(J, S, X_d, eigenvalue_floor):
    """:func:`probe_sds` for a stack: ``S`` (k, m, m) holds ``V_0 + K_d``,
    ``J`` (k, m, r), ``X_d`` (m, p) or (k, m, p); ``eigenvalue_floor``
    bounds every ``S``'s smallest eigenvalue from below (the smallest noise
    variance). One bordered Cholesky whitens all (``stacked_whitening``)."""
    r = J.shape[-1]
    X_d = np.broadcast_to(X_d, (len(S), *X_d.shape[-2:]))
    _, W = stacked_whitening(S, np.concatenate([J, X_d], axis=2), eigenvalue_floor)
    Jw1 = W[:, :, :r]
    Q, _ = np.linalg.qr(W[:, :, r:])
    Jp = Jw1 - Q @ (np.swapaxes(Q, 1, 2) @ Jw1)
    return np.sqrt(_marginal_variances(np.swapaxes(Jp, 1, 2) @ Jp))


def sensitivities(emulator, X_e, thetas):
    """The emulator's mean sensitivities and correlation at some thetas.

    Central differences of step :data:`_STEP` (standardised theta), all
    thetas in one conditional of the emulator.

    Parameters
    ----------
    thetas : ndarray of shape (m, r)

    Returns
    -------
    J : ndarray of shape (m, n, q, r)
        ``d m(X_e, theta) / d theta`` at each theta.
    T : ndarray of shape (m, n, n)
        The emulator's correlation at ``X_e`` given the simulations.
    """
    m, r = thetas.shape
    steps = np.eye(r) * _STEP
    points = np.concatenate(
        [
            (thetas[:, None, :] + steps).reshape(m * r, r),
            (thetas[:, None, :] - steps).reshape(m * r, r),
            thetas,
        ]
    )
    cond = emulator.conditional(X_e, points)
    means = cond.mean()  # (2 m r + m, n, q)
    n, q = means.shape[1:]
    plus = means[: m * r].reshape(m, r, n, q)
    minus = means[m * r : 2 * m * r].reshape(m, r, n, q)
    J = ((plus - minus) / (2 * _STEP)).transpose(0, 2, 3, 1)
    T = cond.correlation(prior=emulator.field_correlation(X_e))
    return J, T[2 * m * r :]


def warn_if_confounded(values, names):
    """Warn for each parameter below :data:`IDENTIFIABILITY_THRESHOLD`."""
    weak = [
        f"{name} ({value:.2g})"
        for name, value in zip(names, values, strict=True)
        if value < IDENTIFIABILITY_THRESHOLD
    ]
    if not weak:
        return
    warn(
        f"The field data cannot tell {', '.join(weak)} from the model "
        f"discrepancy (identifiability_ below {IDENTIFIABILITY_THRESHOLD:.2f}: "
        "the discrepancy more than triples its interval's width, or would at "
        "a plausible size with the plug-in): a discrepancy shaped like its "
        "effect on the observed responses (e.g. proportional to them) "
        "mimics a change of it, so its interval reflects the discrepancy "
        "prior (mostly its roughness range; prior_sensitivity() shows how "
        "much) more than the data, and misses the true value when the model "
        "error has that shape, whatever its size. To identify it, measure "
        "other responses (PreposteriorDesigner ranks them), add prior "
        "information on it, or constrain the discrepancy; or ask for what "
        "the data do tell, the model's best fit (estimand='best_fit').",
        NonIdentifiabilityWarning,
    )
