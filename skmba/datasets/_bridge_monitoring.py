"""A year of hourly monitoring of a concrete bridge: frequencies and temperature.

:func:`make_bridge_monitoring` draws the air temperature of each hour
(season, day and weather), evaluates the frost-stiffened and optionally
damaged bridge at it, adds the identification noise and the outages, runs
the simulator on a Latin hypercube and assembles the dataset, one step per
function. The arguments are checked in
:mod:`skmba.datasets._bridge_monitoring_checks`; the finite element model,
the temperature and frost laws and the simulator and reality callables are
in :mod:`skmba.datasets._bridge_model`.

Examples
--------
>>> from skmba.datasets._bridge_monitoring import make_bridge_monitoring
>>> data = make_bridge_monitoring(48, 10, n_modes=2, random_state=0)
>>> data.X_obs.shape, data.y_obs.shape, data.y_sim.shape
((48, 1), (48, 2), (10, 2))
"""

import dataclasses

import numpy as np
from scipy import signal, stats

from skmba.datasets._bridge_model import (
    REFERENCE_TEMPERATURE,
    SPAN,
    TEMPERATURE_COEFFICIENT,
    BridgeModel,
    BridgeReality,
)
from skmba.datasets._bridge_monitoring_checks import (
    E_RANGE,
    E_TRUE,
    K_BEARING_RANGE,
    K_BEARING_TRUE,
    check_arguments,
)
from skmba.datasets._design import (
    add_noise,
    as_generator,
    calibration_bunch,
    latin_hypercube,
    scale_to_bounds,
)

__all__ = ["make_bridge_monitoring"]

# The climate of the air temperature [degC] (our choice, a temperate
# inland site): annual mean, seasonal and daily half-ranges, the day of the
# year (days after 1 January) of the coldest and the hour of the warmest
# weather, and the weather's AR(1) standard deviation and time scale [h].
TEMPERATURE_MEAN = 10.0
SEASONAL_AMPLITUDE = 12.0
COLDEST_DAY = 20.0
DAILY_AMPLITUDE = 4.0
WARMEST_HOUR = 15.0
WEATHER_SD = 3.0
WEATHER_TIME_SCALE = 48.0
# Default identification noise: this fraction of each frequency.
NOISE_FRACTION = 0.002
# Outages last from one hour to a week, log-uniformly.
OUTAGE_HOURS = (1.0, 168.0)
# The simulations cover the readings' temperatures widened by this [degC].
DESIGN_MARGIN = 2.0


# ------------------------------------------------------------------ steps
def _pandas():
    """The pandas module, or None when it cannot be imported."""
    try:
        import pandas
    except ImportError:
        return None
    return pandas


def _air_temperature(timestamps, rng):
    """Hourly air temperature [degC] at ``timestamps``, logged to 0.1 degC.

    Season and day are cosines of the day of the year and of the hour of
    the day; the weather is a stationary AR(1) process.
    """
    days = timestamps.astype("datetime64[D]")
    year_start = timestamps.astype("datetime64[Y]").astype("datetime64[D]")
    day_of_year = (days - year_start).astype(float)
    hour = (timestamps - days).astype(float)
    season = -SEASONAL_AMPLITUDE * np.cos(
        2.0 * np.pi * (day_of_year + hour / 24.0 - COLDEST_DAY) / 365.25
    )
    daily = DAILY_AMPLITUDE * np.cos(2.0 * np.pi * (hour - WARMEST_HOUR) / 24.0)
    phi = np.exp(-1.0 / WEATHER_TIME_SCALE)
    shocks = rng.standard_normal(timestamps.shape[0])
    shocks[1:] *= np.sqrt(1.0 - phi**2)
    weather = WEATHER_SD * signal.lfilter([1.0], [1.0, -phi], shocks)
    return np.round(TEMPERATURE_MEAN + season + daily + weather, 1)


def _model_and_reality(settings):
    """The simulator, the healthy reality and the damaged one (or None)."""
    deck = {"n_modes": settings.n_modes, "n_elements": settings.n_elements}
    simulator = BridgeModel(**deck)
    reality = BridgeReality(
        **deck,
        E=settings.E_true,
        k_bearing=settings.k_bearing_true,
        deck_frost_stiffening=settings.deck_frost_stiffening,
        bearing_frost_stiffening=settings.bearing_frost_stiffening,
    )
    damaged = None
    if settings.damage_size > 0.0:
        damaged = dataclasses.replace(
            reality,
            damage_element=settings.damage_element,
            damage_size=settings.damage_size,
        )
    return simulator, reality, damaged


def _true_frequencies(settings, X_obs, reality, damaged):
    """Noise-free readings: the healthy reality, the damaged one from its start."""
    y = reality(X_obs)
    if damaged is not None:
        after = slice(settings.damage_start, None)
        y[after] = damaged(X_obs[after])
    return y


def _noise_sd(settings, simulator):
    """``noise_sd``, by default ``NOISE_FRACTION`` of the model's frequencies
    at the true parameters and the reference temperature."""
    if settings.noise_sd is not None:
        return settings.noise_sd
    f_ref = simulator([[REFERENCE_TEMPERATURE]], settings.theta_true)[0]
    return NOISE_FRACTION * f_ref


def _outage(n_hours, rng):
    """The hours of one outage: a random start and a log-uniform length."""
    low, high = np.log(OUTAGE_HOURS)
    length = int(np.exp(rng.uniform(low, high)))
    start = int(rng.integers(n_hours))
    return np.arange(start, min(start + length, n_hours))


def _outages(n_hours, n_modes, fraction, rng):
    """Mask of the missing readings: ``round(fraction * n_hours * n_modes)``.

    Half of them (to the nearest whole hour) are hours with the logger down
    (whole rows), the rest blocks of one mode at a time. Blocks are drawn
    until the count is reached; the last one is cut to reach it exactly.
    """
    mask = np.zeros((n_hours, n_modes), dtype=bool)
    target = round(fraction * mask.size)
    rows_down = round(target / (2 * n_modes))
    down = np.zeros(n_hours, dtype=bool)
    while down.sum() < rows_down:
        hours = _outage(n_hours, rng)
        down[hours[~down[hours]][: rows_down - down.sum()]] = True
    mask[down] = True
    while mask.sum() < target:
        column = int(rng.integers(n_modes))
        hours = _outage(n_hours, rng)
        hours = hours[~mask[hours, column]][: target - mask.sum()]
        mask[hours, column] = True
    return mask


def _make_prior():
    """Uniform ``E`` [Pa] and log-uniform ``k_bearing`` [N/m], by name."""
    (e_low, e_high), (k_low, k_high) = E_RANGE, K_BEARING_RANGE
    return {
        "E": stats.uniform(loc=e_low, scale=e_high - e_low),
        "k_bearing": stats.loguniform(k_low, k_high),
    }


def _simulation_design(n_simulations, prior, temperature, rng):
    """Latin hypercube over the readings' temperatures (widened by
    ``DESIGN_MARGIN``) x the prior's quantiles. Returns ``X_sim``,
    ``theta_sim`` and the temperature bounds (1, 2)."""
    X_bounds = np.array(
        [[temperature.min() - DESIGN_MARGIN, temperature.max() + DESIGN_MARGIN]]
    )
    unit = latin_hypercube(n_simulations, 3, rng)
    X_sim = scale_to_bounds(unit[:, :1], X_bounds)
    theta_sim = np.column_stack(
        [prior[name].ppf(unit[:, j + 1]) for j, name in enumerate(prior)]
    )
    return X_sim, theta_sim, X_bounds


def _response_names(n_modes):
    """``("f1", ..., "f{n_modes}")``."""
    return tuple(f"f{j + 1}" for j in range(n_modes))


def _frame(timestamps, X_obs, y_obs, response_names):
    """The readings as a DataFrame on an hourly DatetimeIndex, or None."""
    pandas = _pandas()
    if pandas is None:
        return None
    index = pandas.DatetimeIndex(timestamps, name="time", freq=pandas.offsets.Hour())
    columns = {"temperature": X_obs[:, 0]}
    columns.update(zip(response_names, y_obs.T, strict=True))
    return pandas.DataFrame(columns, index=index)


def _damage_record(settings, timestamps, damaged):
    """What was damaged, how much and from when; None without damage."""
    if damaged is None:
        return None
    h = SPAN / settings.n_elements
    element = settings.damage_element
    return {
        "size": settings.damage_size,
        "element": element,
        "position": (element * h, (element + 1) * h),
        "start": timestamps[settings.damage_start],
        "start_index": settings.damage_start,
        "reality": damaged,
    }


def _description(settings, timestamps, noise_sd, missing):
    """``DESCR`` of the dataset: the bridge, the laws, the record and its gaps."""
    s = settings
    damage = (
        "none"
        if s.damage_size == 0.0
        else f"{s.damage_size:g} of element {s.damage_element}'s stiffness lost "
        f"from {timestamps[s.damage_start]}"
    )
    return (
        "Hourly monitoring of a concrete bridge: frequencies and temperature\n"
        "--------------------------------------------------------------------\n"
        f"Deck: single span of {SPAN:g} m, {s.n_elements} Euler-Bernoulli "
        "elements (consistent mass)\non two vertical bearing springs.\n"
        "x: air temperature T (degC); theta: E (Pa, at 20 degC) and k_bearing "
        f"(N/m);\ny: frequencies of the first {s.n_modes} bending modes (Hz).\n"
        f"Model: E(T) = E (1 - {-TEMPERATURE_COEFFICIENT:g} (T - 20)).\n"
        f"Reality: E = {s.E_true:g} Pa, k_bearing = {s.k_bearing_true:g} N/m; "
        "below 0 degC the deck's EI\n"
        f"and the bearings stiffen by {s.deck_frost_stiffening:g} and "
        f"{s.bearing_frost_stiffening:g} per degree of frost.\n"
        f"Damage: {damage}.\n"
        f"Readings: {s.n_hours} hours from {timestamps[0]}; noise sd "
        f"{np.round(noise_sd, 4)} Hz;\n{missing} of {s.n_hours * s.n_modes} "
        "readings missing (outages).\n"
        f"Simulations: {s.n_simulations} (Latin hypercube).\n"
    )


def _dataset(settings, arrays, readings, models, noise_sd, X_bounds):
    """The returned Bunch: ``arrays`` (``X_sim``, ``theta_sim``, ``y_sim``,
    ``X_obs``, ``y_obs``, ``y_obs_true``), ``readings`` (the timestamps and
    the frame) and ``models`` (prior, simulator, reality, damaged reality)."""
    timestamps, frame = readings
    prior, simulator, reality, damaged = models
    names = _response_names(settings.n_modes)
    missing = int(np.isnan(arrays[4]).sum())
    return calibration_bunch(
        *arrays,
        timestamps=timestamps,
        frame=frame,
        readings=frame,
        theta_true=settings.theta_true,
        prior=prior,
        simulator=simulator,
        reality=reality,
        damage=_damage_record(settings, timestamps, damaged),
        noise_sd=noise_sd,
        noise_variance=noise_sd**2,
        response_names=names,
        design_variable_names=("temperature",),
        parameter_names=tuple(prior),
        response_units=("Hz",) * settings.n_modes,
        parameter_units=("Pa", "N/m"),
        X_bounds=X_bounds,
        theta_bounds=np.array([prior[p].support() for p in prior], dtype=float),
        reference_temperature=REFERENCE_TEMPERATURE,
        DESCR=_description(settings, timestamps, noise_sd, missing),
    )


# ------------------------------------------------------------------ public
def make_bridge_monitoring(
    n_hours=8760,
    n_simulations=60,
    *,
    n_modes=4,
    start="2025-01-01",
    n_elements=20,
    E_true=E_TRUE,
    k_bearing_true=K_BEARING_TRUE,
    deck_frost_stiffening=0.02,
    bearing_frost_stiffening=0.1,
    damage_size=0.0,
    damage_location=None,
    damage_start=None,
    noise_sd=None,
    missing_fraction=0.05,
    random_state=None,
):
    """Generate a year of hourly frequency readings of a monitored bridge.

    A single-span concrete bridge deck (30 m) on two elastomeric bearings is
    watched for ``n_hours`` hours: each hour a logger records the air
    temperature and the natural frequencies of the first ``n_modes``
    vertical bending modes, identified from ambient vibration. The
    simulator is a finite element model of the deck
    (:class:`~skmba.datasets.BridgeModel`) whose only design variable is
    the temperature, through the concrete's Young's modulus. The bridge
    itself (:class:`~skmba.datasets.BridgeReality`) also stiffens below
    freezing, as the Z24 bridge did: that is the model discrepancy. An
    optional damage event lowers the stiffness of one element from a given
    hour on, and the readings have gaps.

    Parameters
    ----------
    n_hours : int, default=8760
        Number of hourly readings (8760: a year).
    n_simulations : int, default=60
        Number of simulator runs, a Latin hypercube over the readings'
        temperature range widened by 2 degC on each side x the prior's
        quantiles.
    n_modes : int, default=4
        Number of modes, the responses ``f1`` ... ``f{n_modes}`` [Hz].
    start : str or datetime-like, default="2025-01-01"
        Time of the first reading (naive local time, on the hour).
    n_elements : int, default=20
        Number of beam elements of the deck (at least ``n_modes``).
    E_true : float, default=35e9
        True Young's modulus of the deck's concrete at 20 degC [Pa], inside
        the prior's support [25e9, 45e9].
    k_bearing_true : float, default=3e9
        True vertical stiffness of each bearing above freezing [N/m], inside
        the prior's support [3e8, 3e10].
    deck_frost_stiffening : float, default=0.02
        Relative gain of the deck's flexural rigidity per degree of frost
        (the asphalt surfacing freezes); 0 removes it.
    bearing_frost_stiffening : float, default=0.1
        Relative gain of the bearings' stiffness per degree of frost; with
        ``deck_frost_stiffening=0`` too, reality is the model at
        ``theta_true``.
    damage_size : float in [0, 1), default=0.0
        Fraction of one element's stiffness lost in the damage event; 0
        means no damage.
    damage_location : int or None, default=None
        Index of the damaged element, 0 .. ``n_elements - 1`` from the left
        bearing (element ``e`` spans ``[e, e + 1] * 30 / n_elements`` m).
        None is element ``n_elements // 4``, near a quarter of the span.
    damage_start : int, str, datetime-like or None, default=None
        First damaged reading: an hour index (0 is ``start``) or a time
        inside the record. None is hour ``3 * n_hours // 4`` (1 October,
        18:00, for the default year).
    noise_sd : None, float or array-like of shape (n_modes,), default=None
        Standard deviation of the identification noise of each frequency
        [Hz]. None is 0.2 % of each mode's frequency (model at the true
        parameters and 20 degC); 0 gives noise-free readings.
    missing_fraction : float in [0, 1), default=0.05
        Fraction of the readings (of ``n_hours * n_modes``) missing, as NaN
        in ``y_obs``: half of them whole hours with the logger down, the
        rest one mode at a time; outages last from an hour to a week.
    random_state : int, RandomState, Generator or None, default=None
        Seeds the weather, the noise, the outages and the simulation design.
        An int gives reproducible output.

    Returns
    -------
    data : sklearn.utils.Bunch
        With ``q = n_modes``:

        - ``X_sim`` (n_simulations, 1): temperatures of the runs [degC].
        - ``theta_sim`` (n_simulations, 2): ``E`` [Pa] and ``k_bearing``
          [N/m] of the runs.
        - ``y_sim`` (n_simulations, q): ``simulator(X_sim, theta_sim)`` [Hz].
        - ``X_obs`` (n_hours, 1): the logged temperature [degC], rounded to
          0.1 degC; never missing.
        - ``y_obs`` (n_hours, q): the identified frequencies [Hz], NaN where
          missing.
        - ``y_obs_true`` (n_hours, q): the noise-free reality at ``X_obs``
          (healthy before the damage, damaged from it on), without gaps.
        - ``timestamps`` (n_hours,): ``numpy.datetime64[h]`` of the readings.
        - ``frame`` and ``readings`` (the same object): with pandas, a
          DataFrame indexed by an hourly ``DatetimeIndex`` named ``time``,
          with the columns ``temperature``, ``f1`` ... ``f{q}``; None
          without pandas.
        - ``theta_true`` (2,): ``[E_true, k_bearing_true]``.
        - ``prior``: ``{"E": scipy.stats.uniform(25e9, 20e9), "k_bearing":
          scipy.stats.loguniform(3e8, 3e10)}``.
        - ``simulator``: picklable :class:`~skmba.datasets.BridgeModel`,
          ``simulator(X, theta) -> (n, q)``.
        - ``reality``: picklable :class:`~skmba.datasets.BridgeReality` of
          the healthy bridge, ``reality(X) -> (n, q)``.
        - ``damage``: None, or a dict with ``size``, ``element``,
          ``position`` (its ends along the span [m]), ``start`` (the time
          of the first damaged reading), ``start_index`` and ``reality``
          (the damaged bridge).
        - ``noise_sd`` (q,) [Hz] and ``noise_variance`` (q,) [Hz^2].
        - ``response_names`` (``("f1", ...)``), ``design_variable_names``
          (``("temperature",)``), ``parameter_names`` (``("E",
          "k_bearing")``), ``response_units``, ``parameter_units``.
        - ``X_bounds`` (1, 2) and ``theta_bounds`` (2, 2): the simulated
          ranges; ``reference_temperature`` (20 degC); ``DESCR``.

    Raises
    ------
    ValueError
        On invalid arguments; the message names the argument.

    See Also
    --------
    BridgeModel, BridgeReality, make_truss_bridge

    Notes
    -----
    **The bridge.** A 30 m single-span deck, ``I = 2.0 m^4``, ``m = 12 t/m``,
    of ``n_elements`` Euler-Bernoulli elements with the consistent mass, on
    two vertical springs (the bearings) with free rotations; the exact
    definition (node numbering, dofs, units) is in
    :class:`~skmba.datasets.BridgeModel`. The model's only temperature
    effect is ``E(T) = E (1 - 0.003 (T - 20))``.

    **The discrepancy.** Below 0 degC the deck's ``EI`` grows by
    ``deck_frost_stiffening`` and the bearings' stiffness by
    ``bearing_frost_stiffening`` per degree of frost, smoothed over the
    first 2 degC (:func:`~skmba.datasets._bridge_model.frost_degrees`):
    the bilinear frequency-temperature relation with its knee at freezing
    that Peeters and De Roeck (2001) observed on the Z24 bridge. At and
    above 0 degC reality is exactly the model at ``theta_true``.

    **The record.** The air temperature is ``10 - 12 cos(2 pi (d - 20) /
    365.25) + 4 cos(2 pi (t - 15) / 24) + w`` degC at day of the year ``d``
    and hour ``t``, with weather ``w`` a stationary AR(1) process of
    standard deviation 3 degC and correlation ``exp(-1/48)`` from hour to
    hour (a two-day time scale); it is logged to 0.1 degC and the bridge
    is taken to be at the logged temperature (no thermal lag). The
    frequencies are the reality plus independent Gaussian noise. The
    damaged element keeps ``1 - damage_size`` of its stiffness, its mass
    unchanged.

    References
    ----------
    Peeters, B. and De Roeck, G. (2001). One-year monitoring of the Z24
    bridge: environmental effects versus damage events. *Earthquake
    Engineering and Structural Dynamics* 30(2), 149-171.

    Examples
    --------
    >>> from skmba.datasets import make_bridge_monitoring
    >>> data = make_bridge_monitoring(random_state=0)
    >>> data.X_obs.shape, data.y_obs.shape, data.y_sim.shape
    ((8760, 1), (8760, 4), (60, 4))
    >>> data.parameter_names, data.theta_true.tolist()
    (('E', 'k_bearing'), [35000000000.0, 3000000000.0])
    >>> data.frame.head(3).round(3)  # with pandas installed
                         temperature     f1      f2      f3      f4
    time
    2025-01-01 00:00:00         -4.0  4.416  16.943  34.998  54.911
    2025-01-01 01:00:00         -3.7  4.417  16.884  34.776  54.568
    2025-01-01 02:00:00         -4.2  4.426  16.965  35.058  55.153

    A damage event on 1 September: element 10 loses 30 % of its stiffness.

    >>> data = make_bridge_monitoring(damage_size=0.3, damage_location=10,
    ...                               damage_start="2025-09-01",
    ...                               random_state=0)
    >>> data.damage["start_index"], data.damage["position"]
    (5832, (15.0, 16.5))
    """
    settings = check_arguments(
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
    )
    rng = as_generator(random_state)
    timestamps = settings.start + np.arange(settings.n_hours).astype("timedelta64[h]")
    X_obs = _air_temperature(timestamps, rng)[:, None]
    simulator, reality, damaged = _model_and_reality(settings)
    y_obs_true = _true_frequencies(settings, X_obs, reality, damaged)
    sd = _noise_sd(settings, simulator)
    y_obs = add_noise(y_obs_true, sd**2, rng)
    missing = _outages(
        settings.n_hours, settings.n_modes, settings.missing_fraction, rng
    )
    y_obs[missing] = np.nan
    prior = _make_prior()
    X_sim, theta_sim, X_bounds = _simulation_design(
        settings.n_simulations, prior, X_obs[:, 0], rng
    )
    y_sim = simulator(X_sim, theta_sim)
    frame = _frame(timestamps, X_obs, y_obs, _response_names(settings.n_modes))
    return _dataset(
        settings,
        (X_sim, theta_sim, y_sim, X_obs, y_obs, y_obs_true),
        (timestamps, frame),
        (prior, simulator, reality, damaged),
        sd,
        X_bounds,
    )
