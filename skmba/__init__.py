"""skmba: modular Bayesian model calibration and sensor design.

A scikit-learn compatible implementation of the modular Bayesian approach
(MBA) to the calibration of physics-based models, with multi-response
Gaussian processes as emulators and discrepancy models.

Examples
--------
>>> import skmba
>>> sorted(name for name in skmba.__all__ if not name.startswith("_"))
['ChangeDetector', 'ModularBayesCalibrator', 'MultiResponseGP', 'PreposteriorDesigner']
"""

from skmba.calibration import ChangeDetector, ModularBayesCalibrator
from skmba.gp import MultiResponseGP
from skmba.sensor_design import PreposteriorDesigner

__version__ = "0.1.0.dev0"

__all__ = [
    "ChangeDetector",
    "ModularBayesCalibrator",
    "MultiResponseGP",
    "PreposteriorDesigner",
    "__version__",
]
