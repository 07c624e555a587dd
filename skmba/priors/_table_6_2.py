"""The uniform priors of thesis Table 6.2, in the simulations' standardised units.

The thesis' sensor design draws its synthetic discrepancies and noise from
these ranges, and its module 2 (``discrepancy_uncertainty="plug-in"``)
maximises the likelihood inside the discrepancy's ranges. Read by
:mod:`skmba.calibration._module2_plug_in` and
:mod:`skmba.sensor_design._inputs`. The default prior of the propagated
module 2 is another one: :mod:`skmba.priors._hyperprior`.

Examples
--------
>>> from skmba.priors._table_6_2 import TABLE_6_2_RANGES
>>> TABLE_6_2_RANGES["variance"]
(0.01, 20.0)
"""

#: Ranges of the discrepancy roughness (per standardised design variable)
#: and variance (per response, relative to the variance of the simulated
#: response), the prior of the discrepancy hyperparameters.
TABLE_6_2_RANGES = {"roughness": (0.1, 9.0), "variance": (1e-2, 20.0)}

#: The designer's prior of the synthetic discrepancy: the ranges above, its
#: regression coefficients (in response standard deviations) and the
#: correlation between the responses' discrepancies.
DEFAULT_DISCREPANCY_PRIOR = {
    **TABLE_6_2_RANGES,
    "mean": (-5.0, 5.0),
    "correlation": "random",
}

#: Observation noise variance relative to each response's variance.
DEFAULT_NOISE_PRIOR = (0.0, 1e-4)
