"""The arguments of :func:`~skmba.datasets.make_truss_bridge`, checked.

:func:`check_arguments` checks them in the order of the signature and
returns one frozen :class:`TrussBridgeSettings`, which the steps of
:mod:`skmba.datasets._truss_bridge` read; :func:`noise_levels` checks the
values of ``snr_db`` and ``noise_std``. The defaults of the thesis (Tables
5.1 and 5.2) live here with the checks that use them.

Examples
--------
>>> from skmba.datasets._truss_bridge_checks import check_arguments
>>> settings = check_arguments(10, 5, ["SB", 6], (20.0, 40.0), None, 552.26,
...                            0.4, 2.0, 20.0, None, None)
>>> settings.sensor_names, settings.temperature_range
(['SB', 'SG'], (20.0, 40.0))
"""

import numbers
from dataclasses import dataclass

import numpy as np
from scipy import stats

from skmba._core.validation import check_count
from skmba.datasets._design import check_positive, per_response, to_float
from skmba.datasets._truss_bridge_model import SENSORS

REFERENCE_TEMPERATURE = 20.0  # degC, T_0 of section 5.2.2
# Spring rate given by the supplier (thesis Table 5.1), N/mm.
NOMINAL_SPRING_STIFFNESS = 552.26
# Prior range of thesis Table 5.2, N/mm.
STIFFNESS_RANGE = (300.0, 1000.0)
# Temperature range of thesis Table 5.2, degC.
TEMPERATURE_RANGE = (20.19, 45.49)


def _check_sensors(sensors):
    """Gauge names chosen by ``sensors`` (names or indices); None is all."""
    names = list(SENSORS)
    if sensors is None:
        return names
    if isinstance(sensors, (str, numbers.Integral)):
        sensors = [sensors]
    try:
        sensors = list(sensors)
    except TypeError:
        raise ValueError(
            f"sensors must be None, a gauge name, an index or a list of them; "
            f"got {sensors!r}."
        ) from None
    if not sensors:
        raise ValueError(f"sensors must not be empty; choose among {names}.")
    chosen = []
    for s in sensors:
        if isinstance(s, str):
            if s not in SENSORS:
                raise ValueError(
                    f"sensors: unknown gauge {s!r}; valid names are {names}."
                )
            chosen.append(s)
        elif isinstance(s, numbers.Integral) and not isinstance(s, bool):
            if not 0 <= int(s) < len(names):
                raise ValueError(
                    f"sensors: index {s} out of range; use 0..{len(names) - 1} "
                    f"or a name in {names}."
                )
            chosen.append(names[int(s)])
        else:
            raise ValueError(f"sensors: {s!r} is neither a gauge name nor an index.")
    if len(set(chosen)) != len(chosen):
        raise ValueError(f"sensors contains duplicates: {chosen}.")
    return chosen


def _check_prior(prior):
    """A frozen univariate prior of ``k`` on ``[0, inf)``; None is U[300, 1000]."""
    if prior is None:
        low, high = STIFFNESS_RANGE
        return stats.uniform(loc=low, scale=high - low)
    if not all(callable(getattr(prior, a, None)) for a in ("rvs", "ppf", "support")):
        raise ValueError(
            "stiffness_prior must be a frozen univariate scipy.stats distribution "
            "(with rvs, ppf and support), e.g. scipy.stats.uniform(loc=300, "
            f"scale=700); got {prior!r}."
        )
    try:
        low, high = (float(v) for v in prior.support())
    except (TypeError, ValueError):
        raise ValueError(
            "stiffness_prior must be a univariate distribution whose support() "
            "returns two numbers."
        ) from None
    if not low >= 0.0:
        raise ValueError(
            f"stiffness_prior puts mass on negative spring stiffness (support "
            f"starts at {low}); use a prior on k >= 0, e.g. scipy.stats.uniform, "
            "truncnorm or lognorm."
        )
    return prior


def _check_temperature_range(temperature_range):
    """``(T_min, T_max)`` as finite floats with ``T_min < T_max``."""
    try:
        low, high = (float(v) for v in temperature_range)
    except (TypeError, ValueError):
        raise ValueError(
            "temperature_range must be a pair (T_min, T_max) in degC; got "
            f"{temperature_range!r}."
        ) from None
    if not (np.isfinite(low) and np.isfinite(high) and low < high):
        raise ValueError(
            "temperature_range must be finite with T_min < T_max; got "
            f"{temperature_range!r}."
        )
    return low, high


def _check_gradient(gradient):
    """The top-bottom temperature gradient factor, a number in [0, 1]."""
    g = to_float(gradient)
    if not 0.0 <= g <= 1.0:
        raise ValueError(f"gradient must be a number in [0, 1]; got {gradient!r}.")
    return g


def _check_reference_temperature(reference_temperature):
    """The stress-free temperature (degC), a finite number."""
    reference_temperature = to_float(reference_temperature)
    if not np.isfinite(reference_temperature):
        raise ValueError("reference_temperature must be a finite number (degC).")
    return reference_temperature


@dataclass(frozen=True, eq=False)
class TrussBridgeSettings:
    """The checked arguments of :func:`~skmba.datasets.make_truss_bridge`."""

    n_simulations: int
    n_observations: int
    sensor_names: list
    temperature_range: tuple
    prior: object
    k_true: float
    gradient: float
    gradient_exponent: float
    reference_temperature: float


def check_arguments(
    n_simulations,
    n_observations,
    sensors,
    temperature_range,
    stiffness_prior,
    k_true,
    gradient,
    gradient_exponent,
    reference_temperature,
    snr_db,
    noise_std,
):
    """Check the arguments of :func:`~skmba.datasets.make_truss_bridge` (same
    names), in order.

    Of ``snr_db`` and ``noise_std`` only their exclusion is checked here;
    :func:`noise_levels` checks their values.
    """
    settings = TrussBridgeSettings(
        check_count(n_simulations, "n_simulations"),
        check_count(n_observations, "n_observations"),
        _check_sensors(sensors),
        _check_temperature_range(temperature_range),
        _check_prior(stiffness_prior),
        check_positive(k_true, "k_true"),
        _check_gradient(gradient),
        check_positive(gradient_exponent, "gradient_exponent"),
        _check_reference_temperature(reference_temperature),
    )
    if snr_db is not None and noise_std is not None:
        raise ValueError(
            "snr_db and noise_std are mutually exclusive; pass only one of them "
            "(or neither for noise-free observations)."
        )
    return settings


def noise_levels(snr_db, noise_std, q):
    """``snr_db`` and ``noise_std`` as (q,) arrays, or None where not given."""
    if snr_db is not None:
        snr_db = per_response(snr_db, "snr_db", q, nonnegative=False)
    if noise_std is not None:
        noise_std = per_response(noise_std, "noise_std", q, nonnegative=True)
    return snr_db, noise_std
