"""The uniform priors of thesis Table 6.2, in the simulations' standardised units,
and the checks of ranges given in their place.

The thesis' sensor design draws its synthetic discrepancies and noise from
these ranges, and its module 2 (``discrepancy_uncertainty="plug-in"``)
maximises the likelihood inside the discrepancy's ranges. Read by
:mod:`skmba.calibration._module2_plug_in` and
:mod:`skmba.sensor_design._inputs`. The default prior of the propagated
module 2 is another one: :mod:`skmba.priors._hyperprior`.

:func:`check_discrepancy_ranges` checks the calibrator's
``discrepancy_prior`` under the plug-in, :func:`check_interval` one range.

Examples
--------
>>> from skmba.priors._table_6_2 import TABLE_6_2_RANGES
>>> TABLE_6_2_RANGES["variance"]
(0.01, 20.0)
"""

import numpy as np

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


def check_interval(value, name, size, *, lower=None):
    """``(lo, hi)`` of scalars or of arrays of length ``size``, checked.

    Examples
    --------
    >>> check_interval((0.1, [1.0, 2.0]), "ranges", 2)
    (array([0.1, 0.1]), array([1., 2.]))
    """
    try:
        lo, hi = value
        lo = np.broadcast_to(np.asarray(lo, dtype=float), (size,)).copy()
        hi = np.broadcast_to(np.asarray(hi, dtype=float), (size,)).copy()
    except (TypeError, ValueError):
        raise ValueError(
            f"{name} must be a pair (low, high) of numbers or of arrays of length "
            f"{size}, got {value!r}."
        ) from None
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise ValueError(f"{name} must be finite, got {value!r}.")
    if np.any(lo > hi):
        raise ValueError(f"{name} needs low <= high, got {value!r}.")
    if lower is not None and np.any(lo < lower):
        raise ValueError(f"{name} must be >= {lower}, got {value!r}.")
    return lo, hi


def check_discrepancy_ranges(spec, d, q, name="discrepancy_prior"):
    """The module-2 ranges of the discrepancy roughness and variance.

    ``spec`` is None (thesis Table 6.2) or a dict with keys among
    ``"roughness"`` and ``"variance"``: a pair ``(low, high)`` of scalars or
    arrays (``d`` roughnesses, ``q`` variances), or None for no range (the
    kernel's own bounds; the plain maximum-likelihood variance). Missing keys
    take Table 6.2's values. Returns a dict of ``(low, high)`` arrays or None.

    Examples
    --------
    >>> check_discrepancy_ranges({"roughness": None}, d=1, q=2)
    {'roughness': None, 'variance': (array([0.01, 0.01]), array([20., 20.]))}
    """
    if spec is None:
        spec = {}
    if not isinstance(spec, dict):
        raise TypeError(
            f"{name} must be None or a dict with keys among "
            f"{sorted(TABLE_6_2_RANGES)}, got {type(spec).__name__}."
        )
    unknown = set(spec) - set(TABLE_6_2_RANGES)
    if unknown:
        raise ValueError(
            f"{name} has unknown keys {sorted(unknown)}; the calibrator bounds "
            f"only {sorted(TABLE_6_2_RANGES)} (the discrepancy mean is estimated "
            "by generalised least squares and its correlation freely)."
        )
    spec = {**TABLE_6_2_RANGES, **spec}
    out = {}
    for key, size, lower in (("roughness", d, None), ("variance", q, 0.0)):
        if spec[key] is None:
            out[key] = None
            continue
        out[key] = check_interval(spec[key], f"{name}[{key!r}]", size, lower=lower)
    if out["roughness"] is not None and np.any(out["roughness"][0] <= 0):
        raise ValueError(
            f"{name}['roughness'] must be > 0, got {spec['roughness']!r}; use "
            "None to keep the kernel's own roughness_bounds."
        )
    return out


def ranges_text(ranges):
    """The variance range of :func:`check_discrepancy_ranges`, for a log line.

    Examples
    --------
    >>> ranges_text({"roughness": None, "variance": None})
    'none'
    """
    variance = ranges["variance"]
    if variance is None:
        return "none"
    lo, hi = (np.array2string(v, precision=3) for v in variance)
    return f"{lo} to {hi}"
