"""The Monte Carlo error of module 3's mixture over module 2's fixed draws.

With ``discrepancy_tol=None``, and by default with several calibration
parameters, module 3 mixes a fixed number of draws of the discrepancy and
noise hyperparameters ``phi`` (16, :data:`~skmba.calibration.
_module2_posterior.N_HYPER_DRAWS`) instead of integrating them out to a
tolerance. Another ``random_state`` draws other ``phi``, and theta's
posterior moves with them. :func:`mixture_errors` estimates by how much
from the draws themselves: each enters through its conditional posterior of
theta, read from the posterior's thetas and each draw's weight ``p(phi_k |
theta, data)`` there (the chains keep it at every draw from their own
evaluations; a quadrature posterior reads it on its grid), with the
delta method of the converged integrals (:func:`~skmba.calibration.
_module2_converged_nodes.draw_errors`). :func:`mixture_error` makes it the
fit's :class:`~skmba.calibration._module2_converged.MonteCarloError`
(``theta_mcse_``) and warns above :data:`MIXTURE_TOL`.

The draws see only themselves. Where a few of them carry the posterior,
a draw that another seed would add, with its own narrow posterior of theta
elsewhere, is not among them, and the estimate reads low: measured against
refits in docs/validity.rst, section "Module 2's 16 draws".

Examples
--------
Two draws whose conditional posteriors of theta sit at 0 and 1 with equal
shares: the mean's error is the delta method's ``sqrt(sum_k s_k^2 (m_k -
m)^2)`` = ``sqrt(2 * 0.25 * 0.25)``.

>>> import numpy as np
>>> thetas = np.array([[0.0], [1.0]])
>>> _, se = mixture_errors(thetas, np.array([0.5, 0.5]), np.eye(2))
>>> float(np.round(se[0, 0], 6))
0.353553
"""

import numpy as np

from skmba._core.warn import warn
from skmba.calibration._module2_converged import (
    END_TOLERANCE,
    MonteCarloError,
    tolerances,
)
from skmba.calibration._module2_converged_nodes import draw_errors, node_summaries
from skmba.calibration._module3_mixture import IDLE_WEIGHT
from skmba.calibration._module4_prediction import draw_weights_at
from skmba.calibration._summary import parameter_names

#: The errors of theta's posterior mean and sd (and, ``END_TOLERANCE`` times
#: it, of its 95 % interval ends), in posterior sds, above which a fit on
#: fixed draws warns: the interval would move by about that much with
#: ``random_state``.
MIXTURE_TOL = 0.1


def mixture_errors(thetas, weights, draw_weights):
    """Theta's summaries (4, r: mean, sd, 95 % ends) and their standard
    errors (4, r) over the draws of ``phi``.

    Parameters
    ----------
    thetas : ndarray of shape (N, r)
        The posterior's thetas (user units): a fine grid, or draws.
    weights : ndarray of shape (N,)
        Their posterior weights (summing to one).
    draw_weights : ndarray of shape (N, K)
        ``p(phi_k | theta_i, data)`` (each row summing to one).

    Returns
    -------
    summaries, errors : ndarray of shape (4, r)
        From the joint weights ``w_i p(phi_k | theta_i, data)``: the
        summaries and :func:`~skmba.calibration._module2_converged_nodes.
        draw_errors` (NaN where no draw has weight). Read at draws rather
        than on a grid, each draw's conditional posterior is read from the
        draws it weighs, so their sampling noise adds to the errors.
    """
    weights = np.asarray(weights, dtype=float)
    thetas = np.asarray(thetas, dtype=float).reshape(len(weights), -1)
    with np.errstate(divide="ignore"):
        A = np.log(weights)[:, None] + np.log(draw_weights)
    summaries, w = node_summaries(A, thetas)
    return summaries, draw_errors(A, thetas, summaries, w)


def mixture_error(thetas, weights, draw_weights, names=None):
    """The :class:`~skmba.calibration._module2_converged.MonteCarloError` of
    a mixture over fixed draws (:func:`mixture_errors`); ``converged`` when
    every error is within :data:`MIXTURE_TOL` (the ends ``END_TOLERANCE``
    times it), a warning otherwise naming the parameters (``names``)."""
    summaries, se = mixture_errors(thetas, weights, draw_weights)
    with np.errstate(divide="ignore", invalid="ignore"):
        relative = se / summaries[1][None, :]
    over = relative > tolerances(MIXTURE_TOL)[:, None]
    shares = np.asarray(weights, float) @ np.asarray(draw_weights, float)
    error = MonteCarloError(
        *se,
        n_draws=draw_weights.shape[1],
        ess=float(1.0 / np.sum(shares**2)),
        converged=not over.any(),
    )
    if over.any():
        _warn(relative, over, draw_weights.shape[1], error.ess, names)
    return error


def fixed_draws_error(posterior, rule, draw_weights, log_post, n_jobs=None):
    """:func:`mixture_error` of module 3's ``posterior`` over its fixed draws
    of ``phi``, or None (one draw, or a rule without draws: ``draw_weights``
    None).

    ``rule`` and ``draw_weights`` are module 4's thetas before its draws
    are picked and the draws' weights there (:func:`~skmba.calibration.
    _module4_prediction.prediction_rule`). Chains are read at all their
    draws instead, equally weighted, from the weights they kept
    (``posterior.draw_weights``: no evaluation); a quadrature posterior on
    its own fine grid, at the cost of one batch of evaluations (``n_jobs``
    joblib tasks) over the draws with weight at the rule's thetas (above
    :data:`~skmba.calibration._module3_mixture.IDLE_WEIGHT` at one of them,
    the chains' rule for idle draws; the others get none); reweighted draws
    (an update) at the rule's.
    """
    if draw_weights is None or draw_weights.shape[1] < 2:
        return None
    if posterior.method == "mcmc":
        thetas, draw_weights = posterior.samples, posterior.draw_weights
        weights = np.full(len(thetas), 1.0 / len(thetas))
    elif posterior.method == "quadrature":
        thetas, weights = posterior.nodes, posterior.weights
        # the draws idle at the rule's thetas stay idle (as in the chains)
        kept = np.flatnonzero(draw_weights.max(axis=0) > IDLE_WEIGHT)
        used = log_post.model.keeping(kept)[0]
        at_kept = draw_weights_at(used, log_post.scaler.theta(thetas), n_jobs)
        draw_weights = np.zeros((len(thetas), draw_weights.shape[1]))
        draw_weights[:, kept] = at_kept
    else:  # reweighted: the rule's thetas, whose draws' weights are known
        thetas, weights = rule.thetas, rule.weights
    return mixture_error(thetas, weights, draw_weights, parameter_names(log_post.prior))


def _warn(relative, over, n_draws, ess, names):
    names = names or [f"theta{j}" for j in range(relative.shape[1])]
    worst = [
        f"{name} ({np.array2string(relative[:, j], precision=2)})"
        for j, name in enumerate(names)
        if over[:, j].any()
    ]
    ends = END_TOLERANCE * MIXTURE_TOL
    warn(
        f"Theta's posterior mixes {n_draws} fixed draws of the discrepancy and "
        f"noise hyperparameters (module 2), and they disagree about "
        f"{', '.join(worst)}: estimated from the draws themselves, those are "
        f"the Monte Carlo errors of its posterior mean, sd and 95 % interval "
        f"ends in posterior sds (above {MIXTURE_TOL:g}, {ends:g} for "
        f"the ends; {ess:.1f} draws' worth of weight). Another random_state "
        "draws others and moves the interval by about that much or more: the "
        "draws see only themselves, and where a few carry the weight the "
        "estimate reads low. Set discrepancy_tol (e.g. 0.05) to integrate the "
        "hyperparameters out to a tolerance (slower); summary()'s mcse columns "
        "give these errors.",
        UserWarning,
    )
