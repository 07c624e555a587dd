"""The arguments of :func:`~skmba.datasets.make_bridge_monitoring`, checked.

:func:`check_arguments` checks them in the order of the signature and
returns one frozen :class:`BridgeMonitoringSettings`, which the steps of
:mod:`skmba.datasets._bridge_monitoring` read. The prior's ranges and the
true parameters' defaults live here with the checks that use them.

Examples
--------
>>> from skmba.datasets._bridge_monitoring_checks import check_arguments
>>> settings = check_arguments(48, 10, 2, "2025-01-01", 20, 35e9, 3e9, 0.02,
...                            0.1, 0.2, None, "2025-01-02", None, 0.05)
>>> settings.damage_element, settings.damage_start, str(settings.start)
(5, 24, '2025-01-01T00')
"""

import numbers
from dataclasses import dataclass

import numpy as np

from skmba._core.validation import check_count
from skmba.datasets._design import check_positive, per_response, to_float

#: The uniform prior of E [Pa] and the log-uniform prior of k_bearing [N/m].
E_RANGE = (25.0e9, 45.0e9)
K_BEARING_RANGE = (3.0e8, 3.0e10)
#: Defaults of the true parameters.
E_TRUE = 35.0e9
K_BEARING_TRUE = 3.0e9


def _check_start(start):
    """``start`` as a naive ``datetime64[h]`` on the hour."""
    if getattr(start, "tzinfo", None) is not None:
        raise ValueError(
            f"start must be a naive (local) date or time, got {start!r} with a "
            "time zone."
        )
    try:
        time = np.datetime64(start)
    except (TypeError, ValueError):
        time = np.datetime64("NaT")
    if np.isnat(time) or isinstance(start, numbers.Number):
        raise ValueError(
            f"start must be a date or time such as '2025-01-01', got {start!r}."
        )
    hour = time.astype("datetime64[h]")
    if hour != time:
        raise ValueError(f"start must fall on the hour, got {start!r}.")
    return hour


def _check_fraction(value, name):
    """``value`` as a float in [0, 1)."""
    number = to_float(value)
    if not 0.0 <= number < 1.0:
        raise ValueError(f"{name} must be a number in [0, 1), got {value!r}.")
    return number


def _check_nonnegative(value, name):
    """``value`` as a finite float >= 0."""
    number = to_float(value)
    if not (np.isfinite(number) and number >= 0.0):
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}.")
    return number


def _check_true_value(value, name, bounds, unit):
    """A positive true parameter inside its prior's support ``bounds``."""
    number = check_positive(value, name)
    low, high = bounds
    if not low <= number <= high:
        raise ValueError(
            f"{name} must lie in the prior's support [{low:g}, {high:g}] {unit}, "
            f"got {number:g}."
        )
    return number


def _check_damage_location(location, n_elements):
    """The damaged element's index; None is the element at a quarter span."""
    if location is None:
        return n_elements // 4
    if not isinstance(location, numbers.Integral) or isinstance(location, bool):
        raise ValueError(
            f"damage_location must be an element index (an int) or None, got "
            f"{location!r}."
        )
    if not 0 <= location < n_elements:
        raise ValueError(
            f"damage_location must be an element index in 0..{n_elements - 1} "
            f"(n_elements={n_elements}), got {location}."
        )
    return int(location)


def _check_damage_start(damage_start, start, n_hours):
    """The hour index of the damage; None is three quarters into the record.

    An int is an hour index; anything else a time, which must fall on an
    hour of the record.
    """
    if damage_start is None:
        return (3 * n_hours) // 4
    if isinstance(damage_start, numbers.Integral) and not isinstance(
        damage_start, bool
    ):
        index = int(damage_start)
    else:
        try:
            hour = _check_start(damage_start)
        except ValueError as error:
            message = str(error).replace("start must", "damage_start must", 1)
            raise ValueError(message + " (or give an hour index)") from None
        index = int((hour - start) / np.timedelta64(1, "h"))
    if not 0 <= index < n_hours:
        last = start + np.timedelta64(n_hours - 1, "h")
        raise ValueError(
            f"damage_start must fall inside the record, hour 0..{n_hours - 1} "
            f"({start} .. {last}), got {damage_start!r}."
        )
    return index


@dataclass(frozen=True, eq=False)
class BridgeMonitoringSettings:
    """The checked arguments of :func:`~skmba.datasets.make_bridge_monitoring`.

    ``damage_element`` and ``damage_start`` (an hour index) are filled in
    even without damage; ``damage_size == 0`` means none.
    """

    n_hours: int
    n_simulations: int
    n_modes: int
    start: np.datetime64
    n_elements: int
    E_true: float
    k_bearing_true: float
    deck_frost_stiffening: float
    bearing_frost_stiffening: float
    damage_size: float
    damage_element: int
    damage_start: int
    noise_sd: np.ndarray | None
    missing_fraction: float

    @property
    def theta_true(self):
        """True parameters ``(E, k_bearing)``."""
        return np.array([self.E_true, self.k_bearing_true])


def check_arguments(
    n_hours,
    n_simulations,
    n_modes,
    start,
    n_elements,
    E_true,
    k_bearing_true,
    deck_frost_stiffening,
    bearing_frost_stiffening,
    damage_size,
    damage_location,
    damage_start,
    noise_sd,
    missing_fraction,
):
    """Check the arguments of :func:`~skmba.datasets.make_bridge_monitoring`
    (same names), in order."""
    n_hours = check_count(n_hours, "n_hours")
    n_simulations = check_count(n_simulations, "n_simulations")
    n_modes = check_count(n_modes, "n_modes")
    start = _check_start(start)
    n_elements = check_count(n_elements, "n_elements", minimum=2)
    if n_modes > n_elements:
        raise ValueError(
            f"n_modes must be at most n_elements={n_elements}, got {n_modes}."
        )
    if noise_sd is not None:
        noise_sd = per_response(noise_sd, "noise_sd", n_modes, nonnegative=True)
    return BridgeMonitoringSettings(
        n_hours,
        n_simulations,
        n_modes,
        start,
        n_elements,
        _check_true_value(E_true, "E_true", E_RANGE, "Pa"),
        _check_true_value(k_bearing_true, "k_bearing_true", K_BEARING_RANGE, "N/m"),
        _check_nonnegative(deck_frost_stiffening, "deck_frost_stiffening"),
        _check_nonnegative(bearing_frost_stiffening, "bearing_frost_stiffening"),
        _check_fraction(damage_size, "damage_size"),
        _check_damage_location(damage_location, n_elements),
        _check_damage_start(damage_start, start, n_hours),
        noise_sd,
        _check_fraction(missing_fraction, "missing_fraction"),
    )
