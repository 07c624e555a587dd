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
    stacked_probe_sds,
)


def kronecker_information(J, sigma2_m, noise, T):
    """``J' V_0^-1 J`` with ``V_0 = sigma2_m ⊗ T + diag(noise) ⊗ I``.

    Parameters
    ----------
    J : ndarray of shape (..., n, s, r)
        Sensitivities of the ``s`` responses at the ``n`` field inputs.
    sigma2_m : ndarray of shape (..., s, s)
        The emulator's covariance of the responses.
    noise : ndarray of shape (..., s)
        Noise variances (positive).
    T : ndarray of shape (..., n, n)
        The emulator's correlation at the field inputs.

    Returns
    -------
    ndarray of shape (..., r, r)
    """
    root = 1.0 / np.sqrt(np.asarray(noise, dtype=float))
    d, W = np.linalg.eigh(sigma2_m * root[..., :, None] * root[..., None, :])
    e, U = np.linalg.eigh(0.5 * (T + np.swapaxes(T, -1, -2)))
    # Round-off can leave a correlation or a covariance a hair below zero.
    d, e = np.clip(d, 0.0, None), np.clip(e, 0.0, None)
    # U' J_j Lambda^-1/2 W for every parameter j, then the diagonal weights.
    rotated = np.einsum("...nl,...nsj,...s,...sa->...jla", U, J, root, W)
    weighted = rotated / (e[..., None, :, None] * d[..., None, None, :] + 1.0)
    return np.einsum("...jla,...kla->...jk", weighted, rotated)


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
    r, n = len(scale), ctx.n
    # The sensitivities at every subset's posterior mean, in blocks of one
    # conditional of the emulator each (BLAS-bound, bounded memory).
    step = max(1, _BLOCK_THETAS // (2 * r + 1))
    pieces = [
        sensitivities(ctx.emulator, ctx.Xs, ctx.std_theta(means[i : i + step]))
        for i in range(0, len(subsets), step)
    ]
    J = np.concatenate([p[0] for p in pieces])  # (m, n, q, r)
    T = np.concatenate([p[1] for p in pieces])  # (m, n, n)
    covs = covs / np.outer(scale, scale)
    out = np.empty((len(subsets), r))
    # Subsets of one size in stacks of at most _STACK_BYTES of covariance.
    by_size = {}
    for j, subset in enumerate(subsets):
        by_size.setdefault(len(subset), []).append(j)
    for size, members in by_size.items():
        chunk = max(1, _STACK_BYTES // (8 * (size * n) ** 2))
        for c in range(0, len(members), chunk):
            group = np.array(members[c : c + chunk])
            parts = ([subsets[j] for j in group], [modes[j] for j in group])
            out[group] = _ratios(ctx, *parts, J[group], T[group], covs[group])
    return out


#: Thetas of one conditional of the emulator (its cross-correlations with
#: the simulations are ``N x n`` per theta).
_BLOCK_THETAS = 128
#: Bytes of the field covariances one stack of the plug-in's probe holds.
_STACK_BYTES = 64 * 2**20


def _ratios(ctx, subsets, modes, J, T, covs):
    """Subsets of one size: the data share of the posterior
    (``"propagate"``) or the probe's ratio (the plug-in), with ``J``
    (g, n, q, r) and ``T`` (g, n, n) at their means."""
    idx = np.array(subsets)  # (g, s)
    g, s = idx.shape
    n = ctx.n
    J = np.swapaxes(J[np.arange(g)[:, None], :, idx], 1, 2)  # (g, n, s, r)
    sigma2_m = ctx.emulator.sigma2[idx[:, :, None], idx[:, None, :]]
    restricted = [
        _restricted(mode, list(subset), ctx.q)
        for mode, subset in zip(modes, subsets, strict=True)
    ]
    noise = np.array([pair[0] for pair in restricted])  # (g, s)
    sigma2_d = np.array([pair[1] for pair in restricted])  # (g, s, s)
    information = kronecker_information(J, sigma2_m, noise, T)
    if ctx.hyperprior is not None:
        return data_share(information, covs)
    kernels = {}
    for mode in modes:  # one discrepancy correlation per mode
        kernels.setdefault(id(mode), mode.kernel_(ctx.Xs))
    R_d = np.array([kernels[id(mode)] for mode in modes])
    sd = np.sqrt(np.clip(np.diagonal(sigma2_d, axis1=1, axis2=2), 1e-300, None))
    big = ctx.probe_prior.sd_quantile(PROBE_LEVEL, ctx.q)[idx] / sd  # (g, s)
    K = sigma2_d * big[:, :, None] * big[:, None, :]
    # V_0 + K_d, response-slowest: (g, s, n, s, n) blocks.
    V = sigma2_m[:, :, None, :, None] * T[:, None, :, None, :]
    V += K[:, :, None, :, None] * R_d[:, None, :, None, :]
    V = V.reshape(g, s * n, s * n)
    V[:, np.arange(s * n), np.arange(s * n)] += np.repeat(noise, n, axis=1)
    J_vec = np.swapaxes(J, 1, 2).reshape(g, s * n, -1)
    X_d = np.kron(np.eye(s), ctx.H_d)
    try:
        probe_sd = stacked_probe_sds(J_vec, V, X_d, 0.5 * float(noise.min()))
    except np.linalg.LinAlgError:
        # The bound (half the smallest noise variance) failed: a correlation
        # with round-off below zero beside a tiny noise. One by one, as the
        # calibrator factors its own probe.
        probe_sd = np.array([probe_sds(J_vec[k], V[k], 0.0, X_d) for k in range(g)])
    return probe_share(information, probe_sd)


def _restricted(mode, idx, q):
    """The noise variances and discrepancy covariance of a mode on the
    responses ``idx`` (a mode fitted on them alone is already)."""
    if len(mode.noise) != q:
        return mode.noise, mode.sigma2
    return mode.noise[idx], mode.sigma2[np.ix_(idx, idx)]


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
    warning_rate_mcse : ndarray of shape (n_subsets, r)
        Its binomial standard error over the independent replicates,
        ``sqrt(p (1 - p) / n_mc)`` (0 where every replicate agrees).
    """
    ratios = np.asarray(ratios, dtype=float)
    rate = np.mean(ratios < IDENTIFIABILITY_THRESHOLD, axis=1)
    mcse = np.sqrt(rate * (1.0 - rate) / ratios.shape[1])
    return np.median(ratios, axis=1), rate, mcse


def predicted_identified(warning_rate, max_warning_rate):
    """Which subsets are predicted to identify theta: every parameter's
    warning rate at most ``max_warning_rate`` (None: all of them).

    >>> predicted_identified(np.array([[0.1, 0.2], [0.1, 0.6]]), 0.5)
    array([ True, False])
    """
    rate = np.asarray(warning_rate, dtype=float)
    if max_warning_rate is None:
        return np.ones(len(rate), dtype=bool)
    return np.all(rate <= max_warning_rate, axis=1)
