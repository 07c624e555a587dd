"""Warnings and errors of skmba.

Examples
--------
>>> from skmba.exceptions import NonIdentifiabilityWarning
>>> issubclass(NonIdentifiabilityWarning, UserWarning)
True
"""

__all__ = ["NonIdentifiabilityWarning"]


class NonIdentifiabilityWarning(UserWarning):
    """The data cannot tell a calibration parameter from the discrepancy.

    Raised by :meth:`skmba.ModularBayesCalibrator.fit` when a discrepancy of
    plausible size (its prior's 95 % point) could mimic the effect of the
    parameter on the observed responses (``identifiability_`` below 1/3).
    The parameter's interval then reflects the prior on the discrepancy more
    than the data. See the User Guide, "How honest are the intervals?".
    """
