"""The calibrator's fitted attributes of a run of modules 1-3.

:func:`fitted_attributes` turns a
:class:`~skmba.calibration._pipeline.ModulesResult` into the public
attributes the calibrator sets (user units); :data:`OPTIONAL_FITTED` are
those that only one posterior method sets, which a new fit removes first.
"""

import numpy as np

#: Fitted attributes that only one posterior method sets.
OPTIONAL_FITTED = (
    "acceptance_rate_",
    "rhat_",
    "ess_",
    "theta_chains_",
    "theta_log_posterior_",
    "theta_nodes_",
    "theta_weights_",
)


def _mcse(error, r):
    """``theta_mcse_``: rows mean, sd, 2.5 % and 97.5 % ends (r columns);
    NaN where the integral over the hyperparameters has no estimate."""
    if error is None:
        return np.full((4, r), np.nan)
    rows = (error.mean, error.sd, error.lower, error.upper)
    return np.array([np.broadcast_to(row, (r,)) for row in rows], dtype=float)


def fitted_attributes(result):
    """The calibrator's public fitted attributes of the modules (user units).

    Returns a dict ``{attribute name: value}``; the optional attributes
    (:data:`OPTIONAL_FITTED`) are present only for their posterior method.
    """
    scaler = result.inputs.scaler
    disc = result.module2.mode
    posterior = result.module3.posterior
    out = {
        "X_mean_": scaler.X_mean,
        "X_scale_": scaler.X_scale,
        "theta_offset_": scaler.theta_offset,
        "theta_scale_": scaler.theta_scale,
        "y_mean_": scaler.y_mean,
        "y_scale_": scaler.y_scale,
        "model_gp_": result.inputs.emulator.gp,
        "discrepancy_kernel_": disc.kernel_,
        "discrepancy_sigma2_": scaler.y_covariance_to_user(disc.sigma2),
        "discrepancy_beta_": disc.beta * scaler.y_scale,
        "noise_": disc.noise * scaler.y_scale**2,
        "theta_samples_": posterior.samples,
        "theta_mean_": posterior.mean,
        "theta_cov_": posterior.cov,
        "identifiability_": result.identifiability.ratio,
        "global_model_": result.module3.log_post.model,
        "theta_mcse_": _mcse(result.module3.error, len(posterior.mean)),
        "discrepancy_draws_": len(result.module2.components),
        "discrepancy_prior_units_": result.inputs.units,
        "estimand_": "physical" if result.best_fit is None else "best_fit",
    }
    if result.best_fit is not None:  # theta's draws are the best fit's
        best = result.best_fit
        out["theta_samples_"] = best.posterior.samples
        out["theta_mean_"], out["theta_cov_"] = best.posterior.mean, best.posterior.cov
        out["theta_mcse_"] = best.mcse
    if posterior.method != "mcmc":
        out["theta_nodes_"], out["theta_weights_"] = posterior.nodes, posterior.weights
    if posterior.method == "reweighted":
        out["ess_"] = posterior.ess
    elif posterior.method == "mcmc":
        out["theta_chains_"] = posterior.chains
        out["theta_log_posterior_"] = posterior.log_density
        out["acceptance_rate_"] = posterior.acceptance_rate
        out["rhat_"], out["ess_"] = posterior.rhat, posterior.ess
    return out
