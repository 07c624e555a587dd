"""Cantilever beam reference problem of the thesis (sections 4.7 and 6.3).

The idealised *model* is an Euler-Bernoulli cantilever with a fixed support;
the *reality* is the same beam whose support is a rotational spring of
stiffness ``K*``. The spring is the source of model discrepancy. Both are
evaluated in closed form, so the problem is a cheap, fully known test bed for
the modular Bayesian approach (MBA): simulations of the model over a design of
(design variables, calibration parameters) and noisy observations of the
reality at the true parameters.

Units throughout are N, mm and MPa (N/mm²): forces in N, moments in N·mm,
lengths and displacements in mm, rotations in rad, Young's modulus in MPa,
second moment of area in mm⁴ and deformation energy in N·mm.

The model and the reality live in :mod:`skmba.datasets._cantilever_model`
and the checks of the arguments in :mod:`skmba.datasets._cantilever_checks`;
this module draws the designs, adds noise and outliers and assembles the
dataset, one step per function.

Examples
--------
>>> from skmba.datasets._cantilever import make_cantilever
>>> data = make_cantilever(10, 5, snr_db=20.0, n_outliers=1, random_state=0)
>>> data.y_obs.shape, data.outlier_indices.shape
((5, 2), (1,))
"""

import math
import textwrap

import numpy as np
from scipy import stats

from skmba.datasets._cantilever_checks import PARAMETER_BOUNDS, check_arguments
from skmba.datasets._cantilever_model import (
    RESPONSE_UNITS,
    CantileverModel,
    CantileverReality,
)
from skmba.datasets._design import (
    add_noise,
    as_generator,
    calibration_bunch,
    latin_hypercube,
    noise_variance,
    scale_to_bounds,
)

__all__ = ["CantileverModel", "CantileverReality", "make_cantilever"]

# Eq. (4.54): univariate (E only) and multivariate (E, I) Gaussian priors.
_GAUSS_1D = (50.0e3, 10.0e3)  # mean, standard deviation of E [MPa]
_GAUSS_2D_MEAN = (53.0e3, 47.2e7)  # [MPa, mm^4]
_GAUSS_2D_COV = ((1.0e8, 0.0), (0.0, 4.5e15))
# Outliers are placed this many standard deviations of the observed signal
# away from the noise-free reality (section 4.7.6: "mu + 6 sigma").
_OUTLIER_SHIFT = 6.0


# --------------------------------------------------------------------------
# the steps of make_cantilever
# --------------------------------------------------------------------------


def _grid(n, d):
    """Full-factorial grid with ``k**d`` points, ``k**d`` nearest to ``n``."""
    k_low = max(1, math.floor(n ** (1.0 / d)))
    # guard against floating-point error in the root
    while (k_low + 1) ** d <= n:
        k_low += 1
    while k_low > 1 and k_low**d > n:
        k_low -= 1
    k_high = k_low + 1
    k = k_low if n - k_low**d <= k_high**d - n else k_high
    k = max(k, 2)
    axes = [np.linspace(0.0, 1.0, k)] * d
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.column_stack([m.ravel() for m in mesh]), k


def _make_prior(prior, parameter_names):
    """Frozen scipy prior(s) of the calibration parameters (Tables 4.1, 4.3)."""
    if prior == "uniform":
        return [
            stats.uniform(loc=lo, scale=hi - lo)
            for lo, hi in (PARAMETER_BOUNDS[p] for p in parameter_names)
        ]
    if len(parameter_names) == 1:
        return [stats.norm(loc=_GAUSS_1D[0], scale=_GAUSS_1D[1])]
    return stats.multivariate_normal(
        mean=np.array(_GAUSS_2D_MEAN), cov=np.array(_GAUSS_2D_COV)
    )


def _model_and_reality(settings):
    """The fixed-support simulator and the spring-supported reality."""
    simulator = CantileverModel(
        response_names=settings.response_names,
        design_variable_names=settings.design_variable_names,
        parameter_names=settings.parameter_names,
        length=settings.length,
        I=settings.I_true,
    )
    reality = CantileverReality(
        response_names=settings.response_names,
        design_variable_names=settings.design_variable_names,
        E=settings.E_true,
        I=settings.I_true,
        spring_stiffness=settings.spring_stiffness,
        length=settings.length,
    )
    return simulator, reality


def _simulation_design(settings, rng):
    """Design of the simulations: LHS or grid over the variables' ranges.

    Returns ``X_sim``, ``theta_sim`` and the grid's points per axis ``k``
    (None for the LHS).
    """
    d = len(settings.design_variable_names)
    dimension = d + len(settings.parameter_names)
    if settings.simulation_design == "lhs":
        unit = latin_hypercube(settings.n_simulations, dimension, rng)
        k = None
    else:
        unit, k = _grid(settings.n_simulations, dimension)
    bounds = np.vstack([settings.X_bounds, settings.theta_bounds])
    design = scale_to_bounds(unit, bounds)
    return design[:, :d], design[:, d:], k


def _observation_sites(settings, rng):
    """Design variables of the observations: an LHS over their ranges."""
    d = len(settings.design_variable_names)
    unit = latin_hypercube(settings.n_observations, d, rng)
    return scale_to_bounds(unit, settings.X_bounds)


def _add_outliers(y_obs, y_true, variance, n_outliers, rng):
    """Replace ``n_outliers`` random rows of ``y_obs`` by outliers, in place.

    Each outlier is the noise-free ``y_true`` shifted by ``_OUTLIER_SHIFT``
    standard deviations of the observed signal (section 4.7.6), with a random
    sign per entry. The rows are drawn even when ``n_outliers`` is 0, so the
    random stream does not depend on it. Returns the sorted row indices.
    """
    n, q = y_true.shape
    indices = np.sort(rng.choice(n, size=n_outliers, replace=False)).astype(np.intp)
    if n_outliers:
        scale = np.sqrt(y_true.var(axis=0) + variance)
        # degenerate constant signal (e.g. a single observation)
        scale = np.where(scale > 0, scale, np.abs(y_true).max(axis=0) + 1.0)
        signs = rng.choice([-1.0, 1.0], size=(n_outliers, q))
        y_obs[indices] = y_true[indices] + _OUTLIER_SHIFT * signs * scale
    return indices


def _observe(y_true, settings, rng):
    """Observed responses: noise at the SNR, then outliers.

    Returns ``y_obs``, the noise variance per response and the outliers' rows.
    """
    variance = noise_variance(y_true, snr_db=settings.snr)
    y_obs = add_noise(y_true, variance, rng)
    outliers = _add_outliers(y_obs, y_true, variance, settings.n_outliers, rng)
    return y_obs, variance, outliers


def _description(settings, n_simulations, k):
    """``DESCR`` of the dataset: the problem, its constants and its sizes."""
    s = settings
    noise = (
        "noise-free"
        if s.snr is None
        else "SNR " + ", ".join(f"{v:g}" for v in s.snr) + " dB"
    )
    responses_line = ", ".join(f"{n} [{RESPONSE_UNITS[n]}]" for n in s.response_names)
    dimension = len(s.design_variable_names) + len(s.parameter_names)
    return (
        "Cantilever beam calibration problem (thesis sections 4.7 and 6.3).\n"
        "Model: Euler-Bernoulli cantilever with a fixed support; reality: the\n"
        f"same beam on a rotational spring K* = {s.spring_stiffness:g} N*mm/rad.\n"
        f"L = {s.length:g} mm, E* = {s.E_true:g} MPa, I* = {s.I_true:g} mm^4.\n"
        f"Design variables: {', '.join(s.design_variable_names)}; "
        f"parameters: {', '.join(s.parameter_names)} ({s.prior} prior).\n"
        + textwrap.fill(f"Responses: {responses_line}.", width=72)
        + "\n"
        f"{n_simulations} simulations ("
        + (f"{k}^{dimension} grid" if k is not None else "LHS")
        + f"), {s.n_observations} observations ({noise}, "
        f"{s.n_outliers} outliers).\n"
    )


def _dataset(settings, arrays, simulator, reality, variance, outlier_indices, k):
    """The returned Bunch: ``arrays`` (``X_sim``, ``theta_sim``, ``y_sim``,
    ``X_obs``, ``y_obs``, ``y_obs_true``) with what describes them."""
    y_sim = arrays[2]
    return calibration_bunch(
        *arrays,
        theta_true=settings.theta_true,
        prior=_make_prior(settings.prior, settings.parameter_names),
        simulator=simulator,
        reality=reality,
        outlier_indices=outlier_indices,
        noise_variance=variance,
        snr_db=settings.snr,
        response_names=settings.response_names,
        parameter_names=settings.parameter_names,
        design_variable_names=settings.design_variable_names,
        response_units=tuple(RESPONSE_UNITS[n] for n in settings.response_names),
        X_bounds=settings.X_bounds,
        theta_bounds=settings.theta_bounds,
        simulation_design=settings.simulation_design,
        grid_points_per_axis=k,
        DESCR=_description(settings, y_sim.shape[0], k),
    )


def make_cantilever(
    n_simulations=70,
    n_observations=25,
    *,
    responses=("tip_displacement", "energy"),
    parameters=("E",),
    design_variables=("force",),
    simulation_design="lhs",
    prior="uniform",
    snr_db=None,
    n_outliers=0,
    spring_stiffness=1.5e12,
    E_true=70e3,
    I_true=6.75e8,
    length=3000.0,
    random_state=None,
):
    r"""Generate the cantilever beam calibration problem of the thesis.

    Simulations come from the fixed-support Euler-Bernoulli cantilever (the
    model) over a design of design variables and calibration parameters;
    observations come from the same beam on a rotational spring support of
    stiffness ``K*`` (the reality) at the true parameters, optionally polluted
    by Gaussian noise at a given signal-to-noise ratio and by outliers.

    The defaults reproduce section 4.7.1 (one design variable F, one
    parameter E, tip displacement and energy, 70 LHS simulations, 25
    observations, uniform prior, no noise; Table 4.1 values).

    Parameters
    ----------
    n_simulations : int, default=70
        Number of model runs (70 as in section 4.7.1, Fig. 4.12). With
        ``simulation_design="grid"`` the actual number is the nearest
        ``k**D`` (see Notes).
    n_observations : int, default=25
        Number of observations of the reality (25 as in section 4.7.1,
        Fig. 4.13, and section 6.3).
    responses : "all" or sequence of str, default=("tip_displacement", "energy")
        Responses, columns of ``y_sim``/``y_obs``, from (Table 6.1 letter,
        unit):

        - ``"tip_displacement"`` (A, mm): displacement at the tip, x = L;
        - ``"energy"`` (B, N·mm): deformation (strain) energy;
        - ``"tip_rotation"`` (C, rad): rotation at the tip;
        - ``"mid_displacement"`` (D, mm): displacement at mid-span, x = L/2;
        - ``"quarter_displacement"`` (E, mm): displacement at x = L/4.

        ``"all"`` selects the five in Table 6.1 order (A to E). The default
        is the pair of sections 4.7.1-4.7.4 and 4.7.6.
    parameters : {("E",), ("E", "I")}, default=("E",)
        Calibration parameters: Young's modulus E [MPa] (sections 4.7.1,
        4.7.2, 4.7.4-4.7.6, 6.3), and the second moment of area I [mm⁴]
        (section 4.7.3, Table 4.3). When I is not calibrated the model uses
        the known ``I_true``.
    design_variables : {("force",), ("force", "moment")}, default=("force",)
        Design variables: tip force F in [1, 10] kN (Table 4.1) and tip moment
        M in [1, 30] kN·m = [1e6, 3e7] N·mm (Table 4.2, section 4.7.2). Without
        the moment, M = 0.
    simulation_design : {"lhs", "grid"}, default="lhs"
        ``"lhs"``: Latin hypercube (``scipy.stats.qmc.LatinHypercube``) over
        the design-variable ranges times the parameter ranges (the thesis'
        default from section 4.7.1 on). ``"grid"``: full-factorial grid as in
        Fig. 4.11 (6 x 6 = 36 points for ``n_simulations=36``).
    prior : {"uniform", "gaussian"}, default="uniform"
        Prior of the calibration parameters. ``"uniform"``: E in [20, 100] GPa
        (Table 4.1) and I in [2.25, 11.25] x 1e8 mm⁴ (Table 4.3).
        ``"gaussian"``: Eq. (4.54) of section 4.7.7, i.e. E ~ N(50e3, 10e3²)
        for one parameter, and for (E, I) a bivariate normal with mean
        (53e3, 4.72e8) and covariance diag(1e8, 4.5e15), uncorrelated as in
        the thesis ("the algorithm only allows for uncorrelated Gaussian
        priors"). In both cases the simulations span the uniform ranges of
        Tables 4.1/4.3, which contain the Gaussian priors' ±3 sd of E and I
        as well as the true values.
    snr_db : None, float or sequence of float, default=None
        Signal-to-noise ratio in dB, Eq. (3.34): SNR = 10 log10(var_signal /
        var_noise). ``None`` means noise-free observations. A scalar applies
        to all responses; a sequence gives one value per response (section
        4.7.6 uses 4.38 dB on the displacement and 71.6 dB on the energy).
        Section 4.7.4 uses -10, -3, 5, 11 and 18 dB.
    n_outliers : int, default=0
        Number of observations replaced by outliers (2 in section 4.7.6).
    spring_stiffness : float, default=1.5e12
        Rotational stiffness K* of the real support [N·mm/rad] (Table 4.1;
        section 4.7.5 uses 1.5e11 for a large discrepancy). ``inf`` removes
        the discrepancy.
    E_true : float, default=70e3
        True Young's modulus E* [MPa] (Table 4.1).
    I_true : float, default=6.75e8
        True second moment of area I* [mm⁴] of the 300 x 300 mm section
        (Tables 4.1 and 4.3).
    length : float, default=3000.0
        Beam length L [mm] (Table 4.1).
    random_state : int, RandomState, Generator or None, default=None
        Seed of the designs, the noise and the outliers. An int gives
        reproducible output.

    Returns
    -------
    data : :class:`~sklearn.utils.Bunch`
        With the following attributes (d design variables, r parameters,
        q responses):

        X_sim : ndarray of shape (n_sim, d)
            Design variables of the simulations.
        theta_sim : ndarray of shape (n_sim, r)
            Calibration parameters of the simulations.
        y_sim : ndarray of shape (n_sim, q)
            Model responses ``simulator(X_sim, theta_sim)``.
        X_obs : ndarray of shape (n_observations, d)
            Design variables of the observations (LHS over their ranges).
        y_obs : ndarray of shape (n_observations, q)
            Observed responses: reality + noise, with outliers.
        y_obs_true : ndarray of shape (n_observations, q)
            Noise-free reality ``reality(X_obs)``.
        theta_true : ndarray of shape (r,)
            True parameters (E*, and I* when calibrated).
        prior : list of frozen scipy distributions or frozen multivariate_normal
            One ``scipy.stats.uniform``/``norm`` per parameter, or a
            ``scipy.stats.multivariate_normal`` for the Gaussian (E, I) prior.
        simulator : CantileverModel
            Picklable callable ``simulator(X, theta) -> Y``.
        reality : CantileverReality
            Picklable callable ``reality(X) -> Y`` at the true parameters.
        outlier_indices : ndarray of int of shape (n_outliers,)
            Rows of ``y_obs`` replaced by outliers (sorted).
        noise_variance : ndarray of shape (q,)
            Variance of the added noise per response (zeros if noise-free).
        snr_db : ndarray of shape (q,) or None
            SNR per response.
        response_names, parameter_names, design_variable_names : tuple of str
            Column names of Y, theta and X.
        response_units : tuple of str
            Units of the responses.
        X_bounds, theta_bounds : ndarray of shape (d, 2) and (r, 2)
            Ranges of the design variables and of the simulated parameters.
        simulation_design : str
            ``"lhs"`` or ``"grid"``.
        grid_points_per_axis : int or None
            k of the ``k**(d + r)`` grid, None for the LHS.
        DESCR : str
            Description of the problem.

    Raises
    ------
    ValueError
        On unknown names, non-positive sizes, a non-finite ``snr_db``,
        ``n_outliers > n_observations``, an unknown prior or design, or
        non-positive physical constants; the message names the argument and
        the allowed values.

    See Also
    --------
    CantileverModel, CantileverReality

    Notes
    -----
    **Beam theory.** The beam of length L is clamped at x = 0 (model) or
    supported by a rotational spring K* (reality) and loaded at the tip by a
    force F and a moment M. The bending moment is m(x) = F (L - x) + M, and
    integrating EI w'' = m with w(0) = w'(0) = 0 gives the model

    .. math::

        w(x) &= \frac{F x^2 (3L - x)}{6EI} + \frac{M x^2}{2EI}, \qquad
        \theta_L = w'(L) = \frac{F L^2}{2EI} + \frac{M L}{EI},\\
        U &= \int_0^L \frac{m^2}{2EI}\,dx
          = \frac{F^2 L^3}{6EI} + \frac{F M L^2}{2EI} + \frac{M^2 L}{2EI},

    so w(L) = F L³/(3EI) + M L²/(2EI), w(L/2) = 5 F L³/(48EI) + M L²/(8EI)
    and w(L/4) = 11 F L³/(384EI) + M L²/(32EI). For M = 0 these are
    Eqs. (4.47) and (4.48). The spring carries the support moment
    F L + M and rotates rigidly by φ = (F L + M)/K*, so the reality adds φ x
    to the displacements, φ to the rotation and the spring energy
    (F L + M)²/(2 K*) to U (evaluated at E*, I*). For M = 0 the tip
    displacement is Eq. (4.49). Both satisfy Clapeyron's theorem
    U = ½ (F w(L) + M θ_L).

    The thesis' Eqs. (4.50) and (4.52) write the spring energy as F²L²/K*
    (+ M²/K*) without the factor ½ and without the cross term 2 F L M; the
    elastic energy of a linear spring is (F L + M)²/(2 K*) (as the thesis
    itself writes in section 4.7.3), which is what is implemented. Likewise
    Eq. (4.51) omits the cross term F M L²/(2EI) of the bending energy.

    **Designs.** The LHS spans the design-variable ranges (Tables 4.1, 4.2)
    times the parameter ranges (Tables 4.1, 4.3), whatever the prior. The
    grid has k points per axis in each of the D = d + r dimensions, k chosen
    so that k**D is the nearest to ``n_simulations`` (ties to the smaller,
    k >= 2), e.g. 36 -> 6 x 6, 54 -> 7 x 7 = 49, 70 -> 8 x 8 = 64. The
    observation sites are an LHS of ``n_observations`` points over the
    design-variable ranges.

    **Noise and outliers.** For each response j the noise is Gaussian with
    variance var_j / 10^(SNR_j / 10), var_j being the (population) variance
    of the noise-free reality over the observation sites (Eq. 3.34). Following
    section 4.7.6 ("μ + 6σ"), each outlier is the noise-free reality shifted
    by ±6 standard deviations of the observed signal, s_j = sqrt(var_j +
    noise variance_j), with a random sign per entry; so outliers are at least
    6 noise standard deviations and 6 signal standard deviations away from the
    reality, also in the noise-free case.

    References
    ----------
    The source thesis on the modular Bayesian approach for structural
    identification: section 4.7 (cantilever beam numerical examples; Tables
    4.1-4.3, Eqs. 4.47-4.55; 4.7.1 single parameter, 4.7.2 force and moment,
    4.7.3 E and I, 4.7.4 noise, 4.7.5 large discrepancy, 4.7.6 outliers,
    4.7.7 Gaussian priors), Eq. (3.34) (SNR) and section 6.3 (Tables 6.1,
    6.2; five responses, 54 simulations, 25 observations).

    Examples
    --------
    >>> from skmba.datasets import make_cantilever
    >>> data = make_cantilever(random_state=0)
    >>> data.X_sim.shape, data.theta_sim.shape, data.y_sim.shape
    ((70, 1), (70, 1), (70, 2))
    >>> data.X_obs.shape, data.y_obs.shape
    ((25, 1), (25, 2))
    >>> data.response_names
    ('tip_displacement', 'energy')
    >>> round(float(data.simulator([[10e3]], [[70e3]])[0, 0]), 3)  # FL^3/(3EI)
    1.905
    >>> round(float(data.reality([[10e3]])[0, 0]), 3)  # ... + F L^2 / K*
    1.965

    Section 6.3 (five responses on a grid) and section 4.7.3 (E and I):

    >>> data = make_cantilever(54, responses="all", simulation_design="grid",
    ...                        random_state=0)
    >>> data.grid_points_per_axis, data.y_sim.shape
    (7, (49, 5))
    >>> data = make_cantilever(170, 70, parameters=("E", "I"), random_state=0)
    >>> data.theta_sim.shape, data.theta_true.tolist()
    ((170, 2), [70000.0, 675000000.0])
    """
    settings = check_arguments(
        n_simulations,
        n_observations,
        responses,
        parameters,
        design_variables,
        simulation_design,
        prior,
        snr_db,
        n_outliers,
        spring_stiffness,
        E_true,
        I_true,
        length,
    )
    rng = as_generator(random_state)
    simulator, reality = _model_and_reality(settings)
    X_sim, theta_sim, k = _simulation_design(settings, rng)
    y_sim = simulator(X_sim, theta_sim)
    X_obs = _observation_sites(settings, rng)
    y_obs_true = reality(X_obs)
    y_obs, variance, outlier_indices = _observe(y_obs_true, settings, rng)
    return _dataset(
        settings,
        (X_sim, theta_sim, y_sim, X_obs, y_obs, y_obs_true),
        simulator,
        reality,
        variance,
        outlier_indices,
        k,
    )
