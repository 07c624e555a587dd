"""Will the calibrator warn? Its ``identifiability_`` predicted per subset.

For each replicate and response subset the designer already has what the
calibrator's diagnosis (:mod:`skmba.calibration._module3_identifiability`)
reads: theta's posterior mean and covariance, module 2's mode and the
emulator. :func:`replicate_identifiability` applies the calibrator's rule
to them: the data's information on
theta at the posterior mean, without a
discrepancy (the emulator's uncertainty and the noise of module 2's mode),
against the posterior covariance (``"propagate"``: the share of the width
the data account for), or, with the plug-in, against the linearised width
with a discrepancy of plausible size (the probe). Over the replicates, the
designer reports, per parameter, the median ratio and the share of
replicates on which the calibrator's warning would name it.

Without a discrepancy the field covariance of a subset ``S`` is a sum of
two Kronecker products, ``V_0 = Sigma_m[S, S] ⊗ T + diag(lambda_S) ⊗ I``.
With ``Lambda^-1/2 Sigma_m Lambda^-1/2 = W D W'`` and ``T = U E U'``,
``V_0 = (Lambda^1/2 W ⊗ U)(D ⊗ E + I)(Lambda^1/2 W ⊗ U)'``, so the
information ``J' V_0^-1 J`` costs two small eigen-decompositions instead
of a factorisation of order ``n |S|`` (:func:`kronecker_information`;
``tests/sensor_design/test_identifiability.py`` checks it against the
dense :func:`~skmba.calibration._module3_identifiability.data_information`).
The plug-in's probe adds a third Kronecker term and is factored densely.

Examples
--------
>>> import numpy as np
>>> J = np.ones((2, 1, 1))  # two field inputs, one response, one parameter
>>> kronecker_information(J, np.zeros((1, 1)), np.ones(1), np.eye(2))
array([[2.]])
"""

import numpy as np

from skmba.calibration._module3_identifiability import (
    IDENTIFIABILITY_THRESHOLD,
    PROBE_LEVEL,
    data_share,
    probe_sds,
    probe_share,
    sensitivities,
)


def kronecker_information(J, sigma2_m, noise, T):
    """``J' V_0^-1 J`` with ``V_0 = sigma2_m ⊗ T + diag(noise) ⊗ I``.

    Parameters
    ----------
    J : ndarray of shape (n, s, r)
        Sensitivities of the ``s`` responses at the ``n`` field inputs.
    sigma2_m : ndarray of shape (s, s)
        The emulator's covariance of the responses.
    noise : ndarray of shape (s,)
        Noise variances (positive).
    T : ndarray of shape (n, n)
        The emulator's correlation at the field inputs.

    Returns
    -------
    ndarray of shape (r, r)
    """
    root = 1.0 / np.sqrt(np.asarray(noise, dtype=float))
    d, W = np.linalg.eigh(sigma2_m * np.outer(root, root))
    e, U = np.linalg.eigh(0.5 * (T + T.T))
    # Round-off can leave a correlation or a covariance a hair below zero.
    d, e = np.clip(d, 0.0, None), np.clip(e, 0.0, None)
    # U' J_j Lambda^-1/2 W for every parameter j, then the diagonal weights.
    rotated = np.einsum("nl,nsj,s,sa->jla", U, J, root, W)
    weighted = rotated / (np.outer(e, d) + 1.0)
    return np.einsum("jla,kla->jk", weighted, rotated)


def replicate_identifiability(ctx, subsets, modes, means, covs):
    """The calibrator's ``identifiability_`` on one replicate's subsets.

    Parameters
    ----------
    ctx : MonteCarloContext
    subsets : sequence of tuple of int
    modes : sequence of DiscrepancyFit
        Module 2's mode for each subset: on all ``q`` responses (restricted
        here) or on the subset's alone.
    means, covs : ndarray of shape (m, r) and (m, r, r)
        Theta's posterior moments on each subset (user units).

    Returns
    -------
    ndarray of shape (m, r)
    """
    scale = ctx.scaler.theta_scale
    out = np.empty((len(subsets), len(scale)))
    # The sensitivities at every subset's posterior mean in blocks of one
    # conditional of the emulator each (BLAS-bound, bounded memory).
    step = max(1, _BLOCK_THETAS // (2 * len(scale) + 1))
    for start in range(0, len(subsets), step):
        block = slice(start, start + step)
        J, T = sensitivities(ctx.emulator, ctx.Xs, ctx.std_theta(means[block]))
        for k, j in enumerate(range(len(subsets))[block]):
            cov = covs[j] / np.outer(scale, scale)
            out[j] = _ratio(ctx, subsets[j], modes[j], J[k], T[k], cov)
    return out


#: Thetas of one conditional of the emulator (its cross-correlations with
#: the simulations are ``N x n`` per theta).
_BLOCK_THETAS = 128


def _ratio(ctx, subset, mode, J, T, cov):
    """One subset: the data share of the posterior (``"propagate"``) or the
    probe's ratio (the plug-in), ``J`` (n, q, r) and ``T`` at its mean."""
    idx = list(subset)
    J = J[:, idx]
    sigma2_m = ctx.emulator.sigma2[np.ix_(idx, idx)]
    noise, sigma2_d = mode.noise, mode.sigma2
    if len(noise) == ctx.q:
        noise, sigma2_d = noise[idx], sigma2_d[np.ix_(idx, idx)]
    information = kronecker_information(J, sigma2_m, noise, T)
    if ctx.hyperprior is not None:
        return data_share(information, cov)
    n, s = ctx.n, len(idx)
    sd = np.sqrt(np.clip(np.diag(sigma2_d), 1e-300, None))
    big = ctx.probe_prior.sd_quantile(PROBE_LEVEL, ctx.q)[idx]
    corr = sigma2_d / np.outer(sd, sd)
    K_d = np.kron(corr * np.outer(big, big), mode.kernel_(ctx.Xs))
    V0 = np.kron(sigma2_m, T) + np.kron(np.diag(noise), np.eye(n))
    J_vec = J.transpose(1, 0, 2).reshape(s * n, -1)  # response-slowest
    X_d = np.kron(np.eye(s), ctx.H_d)
    return probe_share(information, probe_sds(J_vec, V0, K_d, X_d))


def identifiability_summary(ratios):
    """The designer's prediction from the per-replicate ratios.

    Parameters
    ----------
    ratios : ndarray of shape (n_subsets, n_mc, r)

    Returns
    -------
    median : ndarray of shape (n_subsets, r)
        The median ratio per parameter (``identifiability_``).
    warning_rate : ndarray of shape (n_subsets, r)
        The share of replicates on which the parameter falls below
        :data:`~skmba.calibration._module3_identifiability.IDENTIFIABILITY_THRESHOLD`:
        the chance that the calibrator's warning names it on data from
        that subset.
    """
    ratios = np.asarray(ratios, dtype=float)
    return np.median(ratios, axis=1), np.mean(
        ratios < IDENTIFIABILITY_THRESHOLD, axis=1
    )
