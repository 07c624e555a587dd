"""Warnings and errors of skmba.

Examples
--------
>>> from skmba.exceptions import NonIdentifiabilityWarning
>>> issubclass(NonIdentifiabilityWarning, UserWarning)
True
>>> from skmba.exceptions import FieldDataWarning
>>> issubclass(FieldDataWarning, UserWarning)
True
"""

__all__ = ["FieldDataWarning", "NonIdentifiabilityWarning"]


class NonIdentifiabilityWarning(UserWarning):
    """The data cannot tell a calibration parameter from the discrepancy.

    Raised by :meth:`skmba.ModularBayesCalibrator.fit` when a discrepancy of
    plausible size (its prior's 95 % point) could mimic the effect of the
    parameter on the observed responses (``identifiability_`` below 1/3).
    The parameter's interval then reflects the prior on the discrepancy more
    than the data. See the User Guide, "How honest are the intervals?".
    """


class FieldDataWarning(UserWarning):
    """Field data that look wrong against their simulations.

    Raised by :meth:`skmba.ModularBayesCalibrator.fit`, naming the response
    (or design variable) and the likely cause: readings in other units or
    with the opposite sign convention than the simulations, a sensor stuck at
    one value, a logger's "no reading" code or a slip in single readings,
    field inputs outside the simulated region. The fit goes on with the data
    as given; the discrepancy would otherwise absorb the slip without a
    word. See the User Guide, "Working with monitoring data".
    """
