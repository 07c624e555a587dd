"""The Monte Carlo errors of theta's posterior summaries over the draws of
``phi`` (the delta method for self-normalised importance sampling).

Each draw enters through its conditional posterior of theta on the nodes:
:func:`draw_conditionals` gives the draws' shares and those posteriors,
:func:`moment_influences` their influences on the mean and sd, and
:func:`influence_errors` the standard errors, stratified by the proposal
each draw came from when there are several
(:mod:`~skmba.calibration._module2_proposal_mixture`). Used by the
one-parameter grid (:mod:`~skmba.calibration._module2_converged`) and the
importance nodes of several parameters
(:mod:`~skmba.calibration._module2_converged_nodes`).
"""

import numpy as np
from scipy import special


def influence_errors(w, influence, strata=None):
    """Standard errors of self-normalised importance estimates by the delta
    method: ``sqrt(sum_i w_i^2 g_i^2)`` down the first axis of the
    influences ``g`` (N, ...), for weights ``w`` (N,) that sum to one (Owen
    2013, Monte Carlo theory, ch. 9).

    ``strata`` (N,) labels draws made in fixed numbers from different
    proposals: each stratum's terms ``w_i g_i`` are then centred on their
    own mean (with the factor ``n / (n - 1)``), the variance of a
    stratified sum; the between-strata spread, which the draws' fixed
    numbers remove, is left out. One stratum (or None): the formula above.
    """
    w = w.reshape(-1, *([1] * (influence.ndim - 1)))
    if strata is None or np.all(strata == strata[0]):
        return np.sqrt(np.sum(w**2 * influence**2, axis=0))
    terms = w * influence
    total = np.zeros(influence.shape[1:])
    for label in np.unique(strata):
        part = terms[strata == label]
        n = len(part)
        if n > 1:
            total += n / (n - 1) * np.sum((part - part.mean(axis=0)) ** 2, axis=0)
        else:
            total += np.sum(part**2, axis=0)
    return np.sqrt(total)


def draw_conditionals(A):
    """The draws' shares of the posterior and each draw's conditional
    posterior on the nodes (the columns of ``P``, each summing to one),
    from the joint log weights ``A`` (nodes, draws); draws without weight
    left out (``kept`` marks the others), None when none has any."""
    Z = special.logsumexp(A, axis=0)
    kept = np.isfinite(Z)
    if not kept.any():
        return None
    share = np.exp(Z[kept] - special.logsumexp(Z[kept]))
    return share, np.exp(A[:, kept] - Z[kept]), kept


def moment_influences(theta, P, mean, sd):
    """The influences of the draws of ``phi`` on theta's posterior mean and
    sd: each draw's conditional mean minus the mean, and its conditional
    mean square deviation minus the variance over ``2 sd``, where column
    ``k`` of ``P`` (N, K) is draw ``k``'s conditional posterior on the
    nodes ``theta`` ((N,) or (N, r): then each (K, r))."""
    first = (theta.T @ P).T - mean
    second = (((theta - mean) ** 2).T @ P).T - sd**2
    return [first, second / (2.0 * sd)]
