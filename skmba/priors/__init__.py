"""Priors: of the calibration parameters theta and of the module-2
hyperparameters (discrepancy and noise).

Public for the classes a fitted calibrator's ``prior_`` may be; the files
are private:

=====================  ===================================================
file                   holds
=====================  ===================================================
``_base.py``           :class:`Prior`, the interface every theta prior has
``_theta.py``          the priors of theta and ``check_prior``, which
                       recognises what the user gives
``_checks.py``         checks of the user's distributions and names
``_hyperprior.py``     the default prior of the discrepancy and noise
``_table_6_2.py``      the uniform ranges of thesis Table 6.2 (plug-in)
=====================  ===================================================

Examples
--------
>>> from scipy.stats import uniform
>>> from skmba.priors import IndependentPrior
>>> IndependentPrior([uniform(0, 1)]).dim
1
"""

from skmba.priors._base import Prior
from skmba.priors._theta import GaussianPrior, GenericPrior, IndependentPrior

__all__ = ["GaussianPrior", "GenericPrior", "IndependentPrior", "Prior"]
