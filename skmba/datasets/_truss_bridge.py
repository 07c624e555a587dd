"""Aluminium truss bridge under thermal loading (thesis section 5.2 and 6.4).

A reduced-scale aluminium truss bridge is heated from above; the stiffness
``k`` of the spring that restrains one of its ends is calibrated from
strain-gauge readings at different temperatures. This module provides the
dataset generator, :func:`make_truss_bridge`: it draws the designs, runs
the uniformly heated model and the top-heated reality, adds noise and
assembles the dataset, one step per function. The arguments are checked in
:mod:`skmba.datasets._truss_bridge_checks`; the finite element model is
:mod:`skmba.datasets._truss_bridge_model`, solved by the direct stiffness
method of :mod:`skmba.datasets._truss_solver`.

The bridge's geometry (our choice), units and sign conventions, thermal
load, gauge layout, and why reality is heated as it is: docs/internals.rst,
section skmba.datasets._truss_bridge.

Examples
--------
>>> from skmba.datasets._truss_bridge import make_truss_bridge
>>> data = make_truss_bridge(8, 4, sensors=["SH", "SI"], noise_std=0.5,
...                          random_state=0)
>>> data.y_sim.shape, data.y_obs.shape, data.noise_variance.tolist()
((8, 2), (4, 2), [0.25, 0.25])
"""

import numpy as np

from skmba.datasets._design import (
    add_noise,
    as_generator,
    calibration_bunch,
    latin_hypercube,
    noise_variance,
    scale_to_bounds,
)
from skmba.datasets._truss_bridge_checks import (
    NOMINAL_SPRING_STIFFNESS,
    REFERENCE_TEMPERATURE,
    TEMPERATURE_RANGE,
    check_arguments,
    noise_levels,
)
from skmba.datasets._truss_bridge_model import (
    N_PANELS,
    PANEL_LENGTH,
    SENSORS,
    THERMAL_EXPANSION,
    TRUSS_HEIGHT,
    YOUNGS_MODULUS,
    AtFixedParameter,
    TrussBridgeResponse,
    bridge_geometry,
    bridge_truss,
    temperature_profile,
)

__all__ = ["make_truss_bridge"]


# ------------------------------------------------------------------ steps
def _model_and_reality(settings, sensor_bars):
    """The uniformly heated simulator and the top-heated reality at ``k_true``."""
    truss, _ = bridge_truss()
    simulator = TrussBridgeResponse(
        sensor_bars, np.ones(truss.n_bars), settings.reference_temperature
    )
    profile = temperature_profile(truss, settings.gradient, settings.gradient_exponent)
    reality = AtFixedParameter(
        TrussBridgeResponse(sensor_bars, profile, settings.reference_temperature),
        [settings.k_true],
    )
    return simulator, reality


def _simulation_design(settings, rng):
    """Latin hypercube over the temperature range x the prior's quantiles."""
    unit = latin_hypercube(settings.n_simulations, 2, rng)
    X_sim = scale_to_bounds(unit[:, :1], [settings.temperature_range])
    theta_sim = np.asarray(settings.prior.ppf(unit[:, 1]), dtype=float)
    return X_sim, theta_sim.reshape(-1, 1)


def _observation_temperatures(settings, rng):
    """Uniform temperatures over the range, sorted as along a heating cycle."""
    t_low, t_high = settings.temperature_range
    return np.sort(rng.uniform(t_low, t_high, size=settings.n_observations))[:, None]


def _description(settings, sensor_bars, bar_kinds, variance):
    """``DESCR`` of the dataset: structure, gauges, model, reality and sizes."""
    s = settings
    layout = "\n".join(
        f"    {name}: bar {SENSORS[name]} ({bar_kinds[b]})"
        for name, b in zip(s.sensor_names, sensor_bars, strict=True)
    )
    return (
        "Aluminium truss bridge under thermal loading (thesis sections 5.2, 6.4)\n"
        "-----------------------------------------------------------------------\n"
        f"Pratt truss, {N_PANELS} panels of {PANEL_LENGTH:g} mm, depth "
        f"{TRUSS_HEIGHT:g} mm, crossed interior panels; pinned at L0, roller "
        "with a horizontal spring k at L8.\n"
        f"E = {YOUNGS_MODULUS:g} MPa, alpha = {THERMAL_EXPANSION:g} /degC, "
        f"T_ref = {s.reference_temperature:g} degC.\n"
        "x: temperature T (degC) at the top of the bridge; theta: spring "
        "stiffness k (N/mm); y: mechanical strain (microstrain) at the gauges\n"
        f"{layout}\n"
        "Model: uniform T - T_ref on all bars. Reality: k = "
        f"{s.k_true:g} N/mm and top-heated profile (1 - g) + g eta^p with "
        f"g = {s.gradient:g}, p = {s.gradient_exponent:g}.\n"
        f"Simulations: {s.n_simulations} (Latin hypercube); observations: "
        f"{s.n_observations}; noise variance: {np.round(variance, 4)}.\n"
    )


def _dataset(
    settings, arrays, simulator, reality, variance, snr, geometry, sensor_bars
):
    """The returned Bunch: ``arrays`` (``X_sim``, ``theta_sim``, ``y_sim``,
    ``X_obs``, ``y_obs``, ``y_obs_true``) with what describes them and the
    bridge's ``geometry`` (nodes, bars, bar names, bar kinds)."""
    names = settings.sensor_names
    nodes, bars, bar_names, bar_kinds = geometry
    return calibration_bunch(
        *arrays,
        theta_true=np.array([settings.k_true]),
        prior=[settings.prior],
        simulator=simulator,
        reality=reality,
        noise_variance=variance,
        snr_db=snr,
        response_names=tuple(names),
        parameter_names=("k",),
        design_variable_names=("T",),
        response_units=("microstrain",) * len(names),
        X_bounds=np.array([settings.temperature_range]),
        theta_bounds=np.array([[float(v) for v in settings.prior.support()]]),
        nodes=nodes,
        bars=bars,
        bar_names=tuple(bar_names),
        bar_kinds=tuple(bar_kinds),
        sensor_bars=sensor_bars,
        reference_temperature=settings.reference_temperature,
        DESCR=_description(settings, sensor_bars, bar_kinds, variance),
    )


# ------------------------------------------------------------------ public
def make_truss_bridge(
    n_simulations=60,
    n_observations=30,
    *,
    sensors=None,
    temperature_range=TEMPERATURE_RANGE,
    stiffness_prior=None,
    k_true=NOMINAL_SPRING_STIFFNESS,
    gradient=0.4,
    gradient_exponent=2.0,
    reference_temperature=REFERENCE_TEMPERATURE,
    snr_db=None,
    noise_std=None,
    random_state=None,
):
    """Generate the aluminium truss bridge calibration problem (thesis 5.2, 6.4).

    A simply supported aluminium Pratt truss (8 panels, span 3.2 m) is
    heated. One end is pinned. The other sits on a roller held back by a
    horizontal spring of stiffness ``k``, the calibration parameter. The
    design variable is the temperature ``T`` measured at the top of the
    bridge. The responses are the readings of temperature-compensated strain
    gauges, i.e. the mechanical strains in microstrain, zeroed at
    ``reference_temperature``. The model (``simulator``) heats every bar
    uniformly by ``T - T_ref``. Reality is hotter at the top than at the
    bottom (see ``gradient``), and this is the model discrepancy. See
    :ref:`internals-datasets-truss-bridge` for the geometry, conventions and
    gauge layout.

    Parameters
    ----------
    n_simulations : int, default=60
        Number of simulator runs. The design is a Latin hypercube over
        ``temperature_range`` x the prior's quantiles (over its support for a
        uniform prior).
    n_observations : int, default=30
        Number of field observations. Their temperatures are drawn uniformly
        from ``temperature_range`` and sorted, as along a heating cycle.
    sensors : None, str, int or list of str/int, default=None
        Gauges to return, by name (``"SA"`` ... ``"SK"``) or index (0-10).
        None returns all eleven; ``["SA", ..., "SI"]`` are the nine gauges of
        the sensor-design study of thesis section 6.4.
    temperature_range : (float, float), default=(20.19, 45.49)
        Range of ``T`` in degC (thesis Table 5.2).
    stiffness_prior : frozen scipy.stats distribution or None, default=None
        Prior of ``k`` in N/mm with support in ``[0, inf)``. None means
        ``scipy.stats.uniform(loc=300, scale=700)``, i.e. U[300, 1000] N/mm
        as in thesis Table 5.2.
    k_true : float, default=552.26
        True spring stiffness (N/mm), the supplier's rate (thesis Table 5.1).
    gradient : float in [0, 1], default=0.4
        Top-bottom temperature gradient of reality. The upper chord's
        temperature change is ``T - T_ref``, the lower chord's
        ``(1 - gradient) (T - T_ref)``. 0 makes reality equal to the model.
    gradient_exponent : float, default=2.0
        Shape ``p`` of the profile ``(1 - g) + g * eta**p`` over the relative
        height ``eta``. With 1 (linear) reality is the model scaled by
        ``1 - g``, the same factor at every gauge (see
        :ref:`internals-datasets-truss-bridge`).
    reference_temperature : float, default=20.0
        Temperature (degC) at which the bridge is stress-free and the gauges
        are zeroed (thesis T_0).
    snr_db : float, array-like of shape (n_responses,) or None, default=None
        Signal-to-noise ratio in dB of each response (thesis Eq. 3.34):
        ``SNR_dB = 10 log10(var_signal / var_noise)``. The signal variance
        is that of the noise-free observations of the response.
    noise_std : float, array-like of shape (n_responses,) or None, default=None
        Standard deviation of the Gaussian measurement noise in microstrain.
        Give at most one of ``snr_db`` and ``noise_std``. With neither, the
        observations are noise-free.
    random_state : int, RandomState, Generator or None, default=None
        Seeds the simulation design, the observation temperatures and the
        noise. An int gives reproducible output.

    Returns
    -------
    data : sklearn.utils.Bunch
        With ``q = len(sensors)``:

        - ``X_sim`` (n_simulations, 1): temperatures of the runs (degC).
        - ``theta_sim`` (n_simulations, 1): spring stiffnesses (N/mm).
        - ``y_sim`` (n_simulations, q): model strains (microstrain).
        - ``X_obs`` (n_observations, 1): observed temperatures (degC).
        - ``y_obs`` (n_observations, q): noisy measured strains.
        - ``y_obs_true`` (n_observations, q): noise-free reality.
        - ``theta_true`` (1,): ``[k_true]``.
        - ``prior``: ``[stiffness_prior]``.
        - ``simulator``: picklable callable ``simulator(X, theta) -> Y``
          with ``X`` and ``theta`` of shape (n, 1), read row by row.
        - ``reality``: picklable callable ``reality(X) -> Y`` (true ``k``,
          with the gradient).
        - ``noise_variance`` (q,): variance of the added noise
          (microstrain^2); ``snr_db`` (q,) or None.
        - ``response_names`` (gauge names), ``parameter_names`` (``("k",)``),
          ``design_variable_names`` (``("T",)``), ``response_units``.
        - ``X_bounds`` (1, 2): ``temperature_range``; ``theta_bounds``
          (1, 2): the prior's support.
        - ``nodes`` (16, 2) in mm, ``bars`` (35, 2) node indices,
          ``bar_names``, ``bar_kinds``; ``sensor_bars`` (q,): the bar of
          each gauge.
        - ``reference_temperature``, ``DESCR``.

    Raises
    ------
    ValueError
        On invalid arguments. The message names the argument.

    See Also
    --------
    skmba.ModularBayesCalibrator : calibrates ``k`` from such data.

    Notes
    -----
    Simplifications with respect to the thesis:

    - The thesis FE model (ANSYS) uses beam elements with rotational joint
      stiffness, and its gauges sit on the lower face of the bars. This
      model is pin-jointed and its gauges read the axial strain, so the
      local bending the thesis mentions is absent.
    - The bridge has two truss planes, and each has one spring of the pair at
      the restrained end. The 2-D model is one plane with one spring, so
      ``k`` is the stiffness of a single spring.
    - Friction at the supports, the residual thermal lag of the hollow
      sections (the hysteresis of thesis Fig. 5.5) and the dead load
      (cancelled by zeroing) are not modelled. All responses are exactly
      linear in ``T - T_ref``.
    - The model's gauge strains are proportional to one another (see
      :ref:`internals-datasets-truss-bridge`). A noise-free emulator of
      several gauges therefore has a singular response covariance and needs
      a noise term.
      The geometry and sections are our own choice, since Fig. 5.4 is not
      available.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.datasets import make_truss_bridge
    >>> data = make_truss_bridge(n_simulations=20, n_observations=10,
    ...                          snr_db=30.0, random_state=0)
    >>> data.X_sim.shape, data.theta_sim.shape, data.y_sim.shape
    ((20, 1), (20, 1), (20, 11))
    >>> data.X_obs.shape, data.y_obs.shape, data.theta_true
    ((10, 1), (10, 11), array([552.26]))
    >>> data.response_names[:4], data.bar_names[data.sensor_bars[0]]
    (('SA', 'SB', 'SC', 'SD'), 'L0-L1')

    Model and reality at 40 degC and the true stiffness, gauges SB (upper
    chord) and SG (lower chord): the gradient changes the sign of SB.

    >>> pair = make_truss_bridge(sensors=["SB", "SG"], random_state=0)
    >>> np.round(pair.simulator([[40.0]], [[552.26]]), 1)
    array([[  2.7, -44.2]])
    >>> np.round(pair.reality([[40.0]]), 1)
    array([[ -2. , -29.9]])
    """
    settings = check_arguments(
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
    )
    names = settings.sensor_names
    geometry = bridge_geometry()  # nodes, bars, bar names, bar kinds
    sensor_bars = np.array([geometry[2].index(SENSORS[s]) for s in names])
    simulator, reality = _model_and_reality(settings, sensor_bars)
    rng = as_generator(random_state)
    X_sim, theta_sim = _simulation_design(settings, rng)
    y_sim = simulator(X_sim, theta_sim)
    X_obs = _observation_temperatures(settings, rng)
    y_obs_true = reality(X_obs)
    snr, std = noise_levels(snr_db, noise_std, len(names))
    variance = noise_variance(y_obs_true, snr_db=snr, noise_std=std)
    y_obs = add_noise(y_obs_true, variance, rng)
    return _dataset(
        settings,
        (X_sim, theta_sim, y_sim, X_obs, y_obs, y_obs_true),
        simulator,
        reality,
        variance,
        snr,
        geometry,
        sensor_bars,
    )
