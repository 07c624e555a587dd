"""The multi-response Gaussian process of thesis chapter 3.

The folder is public, as :mod:`sklearn.gaussian_process` is: its name is
what a user searches for. Its files are private and may move:

=====================  ===================================================
file                   holds
=====================  ===================================================
``_estimator.py``      :class:`MultiResponseGP`, the estimator, and its fit
``_predict.py``        its ``predict`` and ``sample_y``
``_likelihood.py``     the noise-free and noisy likelihoods and gradients
``_search.py``         the maximum-likelihood search, nugget escalation
``_noisy.py``          the fit with per-response noise
``_checks.py``         checks of the training data
=====================  ===================================================

Examples
--------
>>> from skmba.gp import MultiResponseGP
>>> MultiResponseGP().regression
'constant'
"""

from skmba.gp._estimator import MultiResponseGP

__all__ = ["MultiResponseGP"]
