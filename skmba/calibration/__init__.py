"""Calibration with model discrepancy: the four modules of thesis chapter 4.

Public for its estimator and :class:`Simulations` (a precomputed
simulation dataset that cross-validation keeps whole); the files are
private and named in pipeline order, so that an option value leads to its
file:

=================================  ========================================
file                               holds
=================================  ========================================
``_estimator.py``                  :class:`ModularBayesCalibrator`
``_settings.py``                   its parameter table and the frozen
                                   settings built from ``get_params()``
``_fit_setup.py``                  what ``fit`` settles first: the field
                                   data checked, the size warning, module
                                   2's prior, the simulations
``_pipeline.py``                   modules 1-3 run in order (and again,
                                   warm, by ``partial_fit``)
``_fitted.py``                     the fitted attributes of a run of
                                   modules 1-3
``_field_data.py``                 checks of the field data, alone and
                                   against the simulations and the prior
``_response_checks.py``            each field response against its
                                   simulations (units, sign, stuck sensors)
``_field_replicates.py``           readings at one input as their mean and
                                   count (``bin_width``), the batches of
                                   ``partial_fit``
``_simulations.py``                the simulation runs
``_module1_emulator.py``           module 1: the emulator, standardisation
``_module2_prior_integral.py``     module 2: the emulator integrated over
                                   the prior (``integration``), the units
                                   of the discrepancy prior
``_module2_kernel.py``             the discrepancy correlation and its
                                   roughness range in module 2's units
``_module2_plug_in.py``            module 2 by maximum likelihood
                                   (``discrepancy_uncertainty="plug-in"``)
``_module2_posterior.py``          module 2's posterior draws
                                   (``discrepancy_uncertainty="propagate"``)
``_module2_converged.py``          the hyperparameters integrated out to a
                                   stated error (``discrepancy_tol``)
``_module2_converged_nodes.py``    the same with several parameters, theta
                                   at weighted importance nodes
``_module2_proposal_mixture.py``   its draws of phi and their proposals
``_module2_errors.py``             its Monte Carlo errors (delta method)
``_module2_theta_grid.py``         theta's grids for it: the likelihood
                                   evaluated coarsely, splined finely
``_module3_fit.py``                module 3 of a run: the posterior over
                                   module 2's draws, module 4's rule
``_module3_likelihood.py``         module 3: the global model (Eq. 4.30),
                                   also for a stack of thetas at once
``_module3_mixture.py``            module 3 over module 2's draws
``_module3_low_rank.py``           the same through a low-rank model term
                                   (the determinant lemma), for batches
``_module3_posterior.py``          the posterior of theta (``sampler``):
                                   the log posterior, the chains
``_module3_coordinates.py``        the chains' coordinates of theta: log,
                                   soft ends of a finite support
``_module3_quadrature.py``         one parameter by quadrature
``_module3_mixture_error.py``      the error of a mixture over fixed
                                   module-2 draws, and its warning
``_module3_update.py``             ``partial_fit``'s reweighted draws
``_module3_density.py``            the ``log_posterior`` method
``_module3_identifiability.py``    ``identifiability_`` and its warning
``_module4_prediction.py``         module 4: the predictions
``_best_fit.py``                   ``estimand="best_fit"``: reality's
                                   posterior projected on the model
``_summary.py``                    ``summary`` and ``to_inference_data``
``_sensitivity.py``                ``prior_sensitivity``: refits under a
                                   stated class of discrepancy priors
``_change_detector.py``            :class:`ChangeDetector`: the reference
                                   state and a batch's decision and report
``_change_evidence.py``            the evidence of one batch for a change
                                   (score test, Bayes factors, posterior)
=================================  ========================================

Examples
--------
>>> from skmba.calibration import ModularBayesCalibrator
>>> ModularBayesCalibrator().discrepancy_uncertainty
'propagate'
"""

from skmba.calibration._change_detector import ChangeDetector
from skmba.calibration._estimator import ModularBayesCalibrator
from skmba.calibration._simulations import Simulations

__all__ = ["ChangeDetector", "ModularBayesCalibrator", "Simulations"]
