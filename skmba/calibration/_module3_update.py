"""Module 3 of an update: the last run's draws reweighted to the new posterior.

:meth:`~skmba.ModularBayesCalibrator.partial_fit` adds a batch of readings
to many earlier ones, so theta's posterior moves little. Before running
chains, :func:`reweighted_posterior` evaluates the new log posterior (the
mixture over the update's module-2 draws) once at each draw of the last
MCMC run's :class:`~skmba.mcmc._reweight.Anchor`, in joblib tasks (over
the module-2 draws that carry weight at 100 evenly thinned nodes, as the
chains do), and returns the reweighted posterior
(:mod:`skmba.mcmc._reweight`) with ``p(phi_k | theta, data)`` at every
node, which module 4's rule reads (each node is evaluated once). When the
weights are too uneven, module 3 runs chains instead: started from the
refused reweighting's draws, with a short burn-in, when they hold enough
effective draws; else from the last posterior's, with the full burn-in.
``tests/calibration/test_module3_update.py`` checks it against the chains.
"""

import time

import numpy as np

from skmba._core.linalg import FactorizationError
from skmba.calibration._module3_mixture import IDLE_CHECK_THETAS, draw_weights_of
from skmba.mcmc._diagnostics import MIN_ESS
from skmba.mcmc._reweight import (
    REWEIGHT_SHARE,
    Anchor,
    accepted,
    starts_chains,
    weighted,
)


def reweighted_posterior(
    log_post, earlier, *, n_jobs=None, random_state=None, say=None
):
    """The last run's draws reweighted to ``log_post``, the module-2
    draws' weights at them, and where chains may start when they do not do.

    Parameters
    ----------
    log_post : LogPosterior
        The update's log posterior (over its
        :class:`~skmba.calibration._module3_mixture.ModelMixture`).
    earlier : PosteriorResult
        The last update's posterior: MCMC with its log density, or
        reweighted (from its anchor); anything else gives None.
    n_jobs : int or None
        joblib tasks of the evaluation.
    random_state : int, SeedSequence or None
        Seeds the resampling of ``samples``.
    say : callable or None
        Receives one line on the outcome.

    Returns
    -------
    posterior : PosteriorResult or None
    draw_weights : ndarray of shape (M, K) or None
        ``p(phi_k | theta_i, data)`` at the posterior's nodes (its
        ``nodes``, all ``M`` of the anchor's) over the update's ``K``
        module-2 draws: zero at nodes outside the prior's support and at
        the draws left out as idle; what module 4's rule needs
        (:func:`~skmba.calibration._module4_prediction.prediction_rule`).
        None with ``posterior``.
    start : PosteriorResult or None
        When ``posterior`` is None: the refused reweighting, if its draws
        hold enough effective draws to start the chains near the new
        posterior (:func:`~skmba.mcmc._reweight.starts_chains`), else None.
    """
    anchor = Anchor.of(earlier)
    if anchor is None:
        return None, None, None
    started = time.perf_counter()
    thetas = anchor.thetas
    log_prior = np.ravel(log_post.prior.logpdf(thetas))
    inside = np.flatnonzero(np.isfinite(log_prior))
    if not len(inside):  # no node inside the prior's support
        return None, None, None
    nodes = log_post.scaler.theta(thetas[inside])
    model = log_post.model
    # The module-2 draws idle at evenly thinned nodes (the probes, evaluated
    # with every draw) change nothing; the other nodes go without them.
    probes = np.zeros(len(nodes), dtype=bool)
    probes[:: max(1, len(nodes) // IDLE_CHECK_THETAS)] = True
    values = np.full((len(nodes), len(model.models)), -np.inf)
    try:
        used, kept, at_probes = model.spread_restricted(nodes[probes], n_jobs)
        values[probes] = at_probes
        if not probes.all():
            values[np.ix_(~probes, kept)] = used.spread_component_log_likelihoods(
                nodes[~probes], n_jobs
            )
    except FactorizationError:
        return None, None, None  # the chains' own checks say why
    log_density = np.full(len(thetas), -np.inf)
    log_density[inside] = log_prior[inside] + np.logaddexp.reduce(values, axis=1)
    posterior, share = weighted(anchor, log_density, random_state)
    start = None
    if not accepted(posterior, share):
        start = posterior if starts_chains(posterior) else None
        posterior = None
    if say is not None:
        outcome = f"Kish share {share:.2f}"
        if posterior is None:
            source = (
                "from its draws" if start is not None else "from the last posterior"
            )
            outcome = (
                f"refused (a Kish share of at least {REWEIGHT_SHARE} and an ESS "
                f"of {MIN_ESS} needed, Kish share {share:.2f}): running chains "
                f"{source}"
            )
        say(
            f"module 3: the last run's {len(thetas)} draws reweighted in "
            f"{time.perf_counter() - started:.1f} s over the {len(kept)} of "
            f"{len(model.models)} module-2 draws with weight there; {outcome}"
        )
    if posterior is None:
        return None, None, start
    weights = np.zeros((len(thetas), len(model.models)))
    weights[inside] = draw_weights_of(values)
    return posterior, weights, None
