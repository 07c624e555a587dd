"""Markov chain Monte Carlo for any log-density: it knows no GP.

Public for the convergence diagnostics, which a user may apply to a
calibrator's ``theta_chains_``; the files are private:

=====================  ===================================================
file                   holds
=====================  ===================================================
``_chain.py``          one adaptive Metropolis-Hastings chain
``_proposals.py``      its independence and label proposals, and the
                       mixture the chains share after the burn-in
``_target.py``         the target's log density, checked per chain
``_run.py``            ``run_chains``: several chains in joblib workers
``_checks.py``         ``run_chains``' arguments, checked
``_diagnostics.py``    split R-hat and bulk ESS (Vehtari et al. 2021)
``_posterior.py``      a posterior's draws and moments, Laplace approximation
``_stopping.py``       the ESS target that ends the chains' draws
``_reweight.py``       an earlier run's draws reweighted to a new posterior,
                       or placing its chains when they do not do
=====================  ===================================================

Examples
--------
>>> import numpy as np
>>> from skmba.mcmc import ess_bulk, split_rhat
>>> chains = np.random.default_rng(0).normal(size=(4, 1000))
>>> bool(split_rhat(chains) < 1.01), bool(ess_bulk(chains) > 3000)
(True, True)
"""

from skmba.mcmc._diagnostics import ess_bulk, split_rhat

__all__ = ["ess_bulk", "split_rhat"]
