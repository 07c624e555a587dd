"""Sensor design by fast preposterior analysis (thesis chapter 6).

Public for its estimator; the files are private:

=============================  ============================================
file                           holds
=============================  ============================================
``_estimator.py``              :class:`PreposteriorDesigner`
``_inputs.py``                 its inputs checked: priors, field design
``_replicates.py``             the Monte Carlo replicates (FPA step 2)
``_subset_likelihood.py``      module 3 for many subsets and thetas
``_subset_tree.py``            module 3 along a prefix tree of subsets
``_posterior_moments.py``      posterior moments by importance quadrature
``_identifiability.py``        the calibrator's warning, predicted
``_subset_search.py``          exhaustive, greedy and genetic searches
=============================  ============================================

Examples
--------
>>> from skmba.sensor_design import PreposteriorDesigner
>>> PreposteriorDesigner().search
'exhaustive'
"""

from skmba.sensor_design._estimator import PreposteriorDesigner

__all__ = ["PreposteriorDesigner"]
