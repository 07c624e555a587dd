"""Aluminium truss bridge under thermal loading (thesis section 5.2 and 6.4).

A reduced-scale aluminium truss bridge is heated from above. A pair of
linear springs restrains the horizontal movement of one of its ends, and their
stiffness ``k`` is the parameter to calibrate from strain-gauge readings taken
at different temperatures. This module provides the dataset generator,
:func:`make_truss_bridge`. It is built on a small finite element model of
such a bridge (:mod:`skmba.datasets._truss_bridge_model`, solved by the
direct stiffness method of :mod:`skmba.datasets._truss_solver`).

Structure
---------
The figure of the laboratory bridge (thesis Fig. 5.4) is not available in
text form, so the geometry below is our own choice, sized like a
laboratory model. It is a parallel-chord Pratt truss of eight 400 mm panels
(span 3200 mm, depth 400 mm) with inclined end posts and crossed diagonals
(both diagonals) in the six interior panels. The diagonals of a panel are
not connected where they cross::

           U1      U2      U3      U4      U5      U6      U7
            o-------o-------o-------o-------o-------o-------o
          / | \\   / | \\   / | \\   / | \\   / | \\   / | \\   / | \\
        /   |   X   |   X   |   X   |   X   |   X   |   X   |   \\
      /     | /   \\ | /   \\ | /   \\ | /   \\ | /   \\ | /   \\ |     \\
    o-------o-------o-------o-------o-------o-------o-------o-------o--/\\/\\/--|
    L0     L1      L2      L3      L4      L5      L6      L7      L8    k
    ^ pin                                                          o roller

16 nodes (lower chord ``L0``-``L8``, upper chord ``U1``-``U7``) and 35 bars.
``L0`` is pinned. ``L8`` sits on a roller (restrained vertically), and a
horizontal spring of stiffness ``k`` connects it to the abutment. The
supports are statically determinate. The crossed panels make the truss
internally indeterminate six times, so a non-uniform temperature field stresses
it even when ``k = 0``.

Members are square hollow sections of aluminium 6082-T6. Chords and end
posts are 30x30x2 mm (A = 224 mm^2); verticals and diagonals are 20x20x2 mm
(A = 144 mm^2). The material constants are those of the thesis FE model:
E = 70 GPa and alpha = 23.1e-6 /degC.

Units and sign conventions
--------------------------
Forces are in N, lengths in mm, stresses and E in MPa (N/mm^2), stiffnesses in
N/mm, temperatures in degC. ``x`` points along the span from ``L0`` to ``L8``
and ``y`` points up. Nodal displacements and loads are positive along ``x``
and ``y``. Global dof ``2 i`` is the ``x`` dof of node ``i`` and
``2 i + 1`` its ``y`` dof. Bar forces and strains are positive in tension.
A positive temperature change means heating. Responses are strains in
microstrain (1e-6).

Thermal load and strain gauges
------------------------------
Take a bar of length ``L`` with temperature change ``dT``. It would expand
freely by ``alpha dT L``. In the stiffness method this becomes a pair of
equivalent nodal forces ``+-E A alpha dT`` along the bar axis, pushing its
end nodes apart. From the nodal displacements the bar's total strain is its
elongation divided by ``L``. Its mechanical (stress-producing) strain is
``elongation / L - alpha dT``, and its axial force is ``E A`` times the
mechanical strain.

The gauges on the bridge are temperature compensated for aluminium, and the
thesis removes their remaining thermal output in post-processing. Such a
gauge reads the **mechanical** strain: it reads zero on a bar that expands
freely. The gauges are also taken to be zeroed at the reference
temperature ``T_ref = 20 degC`` (thesis section 5.2.2). The dead load
therefore cancels (the model is linear), and every response is linear in
``T - T_ref``.

Model and reality
-----------------
The model (the simulator) follows the thesis FE model. It applies the
measured temperature ``T`` uniformly to every bar. A uniform temperature
change leaves any truss stress-free when its supports are statically
determinate, so every strain in the model comes from the spring force. This
force restrains the expansion of the lower chord::

    F_s = k K_t / (k + K_t) * alpha (T - T_ref) * span,

where ``K_t`` is the horizontal stiffness of the truss at the roller.
Every model strain is this one force times a fixed influence coefficient.
The model's gauge readings are therefore exactly proportional to one
another, ``y_m(T, k) = (T - T_ref) s(k) w`` for a fixed vector ``w``. The
thesis FE model has the same property (one spring force, uniform
temperature, linear elasticity). It matters for emulators: a noise-free
multi-response Gaussian process fitted to several gauges of ``y_sim`` has a
singular response covariance. Fit such an emulator with a noise term, or
emulate one gauge at a time.

In reality (the laboratory experiment) the heaters are above the bridge and
its top is hotter than its bottom. In the thesis, ``T`` is the temperature
measured at the top of the bridge. We therefore give reality the following
temperature change at relative height ``eta = y / h``::

    dT(eta) = (T - T_ref) * [(1 - g) + g * eta**p],

averaged along each bar. The upper chord gets the full ``T - T_ref``, the
lower chord ``(1 - g)`` of it, and verticals and diagonals values in between.
``g`` is the ``gradient`` factor and ``p`` the ``gradient_exponent``. This
temperature field is the model discrepancy: with ``g = 0`` reality and model
coincide.

The default is ``p = 2``: the temperature drops faster than linearly
below the irradiated upper chord. The choice matters. A temperature field
that is linear in the coordinates (``p = 1``) leaves any truss free of
internal stress. Reality is then just the model times ``(1 - g)`` (a
smaller spring force), the same factor at every gauge, and the discrepancy
is indistinguishable from a change of ``k``. With ``p != 1`` the crossed
panels develop self-stresses, and each gauge sees its own discrepancy. The
real bridge behaved like this: at some gauges the strain trend had opposite
signs in model and experiment (thesis section 5.2.4). Reality is still
linear in ``T - T_ref`` at fixed ``k``, so its noise-free readings are
proportional across gauges too, but along a different vector than the
model's.

Strain gauges
-------------
The thesis had eleven gauges ``SA``-``SK`` (section 5.2). Nine of them,
``SA``-``SI``, were used in the sensor-design study of section 6.4. The
text places ``A`` and ``E`` near the bridge ends. It places ``B`` and ``G``
one at the top and one at the bottom, and ``H`` and ``I`` at the centre.
We keep these names and hints and choose the rest:

====  ========  ==========================================
Name  Bar       Position
====  ========  ==========================================
SA    L0-L1     lower chord, end panel at the pinned support
SB    U2-U3     upper chord, third panel
SC    U2-L3     diagonal, third panel
SD    L2-U2     vertical, second panel point
SE    L7-U7     vertical next to the spring end
SF    L5-U6     diagonal, sixth panel
SG    L3-L4     lower chord, fourth panel
SH    U4-U5     upper chord, mid-span
SI    L4-L5     lower chord, mid-span
SJ    L4-U4     vertical, mid-span
SK    U4-L5     diagonal, fifth panel (mid-span)
====  ========  ==========================================

Examples
--------
>>> from skmba.datasets._truss_bridge import make_truss_bridge
>>> data = make_truss_bridge(8, 4, sensors=["SH", "SI"], noise_std=0.5,
...                          random_state=0)
>>> data.y_sim.shape, data.y_obs.shape, data.noise_variance.tolist()
((8, 2), (4, 2), [0.25, 0.25])
"""

import numbers
from dataclasses import dataclass

import numpy as np
from scipy import stats

from skmba._core.validation import check_count
from skmba.datasets._design import (
    add_noise,
    as_generator,
    calibration_bunch,
    check_positive,
    latin_hypercube,
    noise_variance,
    per_response,
    scale_to_bounds,
    to_float,
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

REFERENCE_TEMPERATURE = 20.0  # degC, T_0 of section 5.2.2
# Spring rate given by the supplier (thesis Table 5.1), N/mm.
NOMINAL_SPRING_STIFFNESS = 552.26
# Prior range of thesis Table 5.2, N/mm.
STIFFNESS_RANGE = (300.0, 1000.0)
# Temperature range of thesis Table 5.2, degC.
TEMPERATURE_RANGE = (20.19, 45.49)


# ------------------------------------------------------------- validation
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
class _Settings:
    """The checked arguments of :func:`make_truss_bridge`."""

    n_simulations: int
    n_observations: int
    sensor_names: list
    temperature_range: tuple
    prior: object
    k_true: float
    gradient: float
    gradient_exponent: float
    reference_temperature: float


def _check_arguments(
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
    """Check the arguments of :func:`make_truss_bridge` (same names), in order.

    Of ``snr_db`` and ``noise_std`` only their exclusion is checked here;
    :func:`_noise_levels` checks their values.
    """
    settings = _Settings(
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


def _noise_levels(snr_db, noise_std, q):
    """``snr_db`` and ``noise_std`` as (q,) arrays, or None where not given."""
    if snr_db is not None:
        snr_db = per_response(snr_db, "snr_db", q, nonnegative=False)
    if noise_std is not None:
        noise_std = per_response(noise_std, "noise_std", q, nonnegative=True)
    return snr_db, noise_std


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
    bottom (see ``gradient``), and this is the model discrepancy. See the
    module docstring for the geometry, conventions and gauge layout.

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
        ``1 - g``, the same factor at every gauge (see module docstring).
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
    - The model's gauge strains are proportional to one another (see the
      module docstring). A noise-free emulator of several gauges therefore
      has a singular response covariance and needs a noise term.
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
    settings = _check_arguments(
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
    nodes, bars, bar_names, bar_kinds = bridge_geometry()
    sensor_bars = np.array([bar_names.index(SENSORS[s]) for s in names])
    simulator, reality = _model_and_reality(settings, sensor_bars)
    rng = as_generator(random_state)
    X_sim, theta_sim = _simulation_design(settings, rng)
    y_sim = simulator(X_sim, theta_sim)
    X_obs = _observation_temperatures(settings, rng)
    y_obs_true = reality(X_obs)
    snr, std = _noise_levels(snr_db, noise_std, len(names))
    variance = noise_variance(y_obs_true, snr_db=snr, noise_std=std)
    y_obs = add_noise(y_obs_true, variance, rng)
    return calibration_bunch(
        X_sim,
        theta_sim,
        y_sim,
        X_obs,
        y_obs,
        y_obs_true,
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
