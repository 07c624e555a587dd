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
"""

from __future__ import annotations

import math
import numbers
import textwrap
from dataclasses import dataclass

import numpy as np
from scipy import stats
from sklearn.utils import Bunch

from skmba.datasets._design import as_generator, latin_hypercube, per_response

__all__ = ["CantileverModel", "CantileverReality", "make_cantilever"]

#: Responses in the order of Table 6.1 of the thesis (letters A to E).
RESPONSES = (
    "tip_displacement",  # A: displacement at point A (beam tip, x = L)
    "energy",  # B: deformation energy of the beam
    "tip_rotation",  # C: rotation angle at point A (beam tip)
    "mid_displacement",  # D: displacement at point B (mid-span, x = L/2)
    "quarter_displacement",  # E: displacement at point C (quarter-span, x = L/4)
)
RESPONSE_UNITS = {
    "tip_displacement": "mm",
    "energy": "N*mm",
    "tip_rotation": "rad",
    "mid_displacement": "mm",
    "quarter_displacement": "mm",
}
_PARAMETER_SETS = (("E",), ("E", "I"))
_DESIGN_SETS = (("force",), ("force", "moment"))
_PRIORS = ("uniform", "gaussian")
_DESIGNS = ("lhs", "grid")

# Table 4.1 (F, E), Table 4.2 (M) and Table 4.3 (I) sampling ranges.
_DESIGN_BOUNDS = {"force": (1.0e3, 10.0e3), "moment": (1.0e6, 30.0e6)}
_PARAMETER_BOUNDS = {"E": (20.0e3, 100.0e3), "I": (2.25e8, 11.25e8)}
# Eq. (4.54): univariate (E only) and multivariate (E, I) Gaussian priors.
_GAUSS_1D = (50.0e3, 10.0e3)  # mean, standard deviation of E [MPa]
_GAUSS_2D_MEAN = (53.0e3, 47.2e7)  # [MPa, mm^4]
_GAUSS_2D_COV = ((1.0e8, 0.0), (0.0, 4.5e15))
# Outliers are placed this many standard deviations of the observed signal
# away from the noise-free reality (section 4.7.6: "mu + 6 sigma").
_OUTLIER_SHIFT = 6.0


def _beam_responses(force, moment, E, I, length, spring_stiffness, names):
    """Closed-form responses of a tip-loaded cantilever on a rotational spring.

    All inputs broadcast; ``spring_stiffness = inf`` gives the fixed support.
    Returns an array of shape ``(n, len(names))``.
    """
    L = length
    EI = E * I
    support_moment = force * L + moment
    phi = support_moment / spring_stiffness  # rigid rotation of the support

    def w(x):
        return (force * x**2 * (3.0 * L - x) / 6.0 + moment * x**2 / 2.0) / EI + (
            phi * x
        )

    out = {}
    for name in names:
        if name == "tip_displacement":
            out[name] = w(L)
        elif name == "mid_displacement":
            out[name] = w(L / 2.0)
        elif name == "quarter_displacement":
            out[name] = w(L / 4.0)
        elif name == "tip_rotation":
            out[name] = (force * L**2 / 2.0 + moment * L) / EI + phi
        elif name == "energy":
            bending = (
                force**2 * L**3 / 3.0 + force * moment * L**2 + moment**2 * L
            ) / (2.0 * EI)
            out[name] = bending + support_moment**2 / (2.0 * spring_stiffness)
        else:  # pragma: no cover - names are validated upstream
            raise ValueError(f"unknown response {name!r}")
    return np.column_stack([np.broadcast_to(out[n], np.shape(force)) for n in names])


def _check_X(X, n_columns, names):
    X = np.asarray(X, dtype=float)
    if X.ndim != 2 or X.shape[1] != n_columns:
        raise ValueError(
            f"X must be a 2-D array with {n_columns} column(s) {names}, "
            f"got shape {X.shape}"
        )
    return X


def _loads(X, design_variable_names):
    force = X[:, 0]
    if "moment" in design_variable_names:
        moment = X[:, 1]
    else:
        moment = np.zeros_like(force)
    return force, moment


@dataclass(frozen=True)
class CantileverModel:
    """Fixed-support cantilever model ``y^m(x, theta)`` (the simulator).

    A picklable callable: ``model(X, theta)`` returns the responses of an
    Euler-Bernoulli cantilever with a fixed support, row by row.

    Parameters
    ----------
    response_names : tuple of str, default=("tip_displacement", "energy")
        Responses (columns of the output), see :func:`make_cantilever`.
    design_variable_names : tuple of str, default=("force",)
        Columns of ``X``: ``("force",)`` or ``("force", "moment")``.
    parameter_names : tuple of str, default=("E",)
        Columns of ``theta``: ``("E",)`` or ``("E", "I")``.
    length : float, default=3000.0
        Beam length ``L`` [mm].
    I : float, default=6.75e8
        Second moment of area [mm⁴] used when ``"I"`` is not a calibration
        parameter (Table 4.1).

    Examples
    --------
    >>> model = CantileverModel()
    >>> y = model([[10e3]], [[70e3]])  # F L^3/(3EI), F^2 L^3/(6EI)
    >>> [round(float(v), 3) for v in y[0]]
    [1.905, 9523.81]
    """

    response_names: tuple = ("tip_displacement", "energy")
    design_variable_names: tuple = ("force",)
    parameter_names: tuple = ("E",)
    length: float = 3000.0
    I: float = 6.75e8

    def __call__(self, X, theta):
        """Evaluate the model.

        Parameters
        ----------
        X : array-like of shape (n, d)
            Design variables (force [N] and optionally moment [N·mm]).
        theta : array-like of shape (n, r) or (r,)
            Calibration parameters (E [MPa] and optionally I [mm⁴]), one row
            per row of ``X``; a 1-D ``theta`` is used for every row.

        Returns
        -------
        Y : ndarray of shape (n, q)
        """
        X = _check_X(X, len(self.design_variable_names), self.design_variable_names)
        r = len(self.parameter_names)
        theta = np.asarray(theta, dtype=float)
        if theta.ndim == 1 and theta.shape[0] == r:
            theta = np.broadcast_to(theta, (X.shape[0], r))
        if theta.ndim != 2 or theta.shape != (X.shape[0], r):
            raise ValueError(
                f"theta must have shape ({X.shape[0]}, {r}) or ({r},) for "
                f"parameters {self.parameter_names}, got shape {theta.shape}"
            )
        force, moment = _loads(X, self.design_variable_names)
        E = theta[:, 0]
        I = theta[:, 1] if r == 2 else self.I
        return _beam_responses(
            force, moment, E, I, self.length, np.inf, self.response_names
        )


@dataclass(frozen=True)
class CantileverReality:
    """Spring-supported cantilever ``y^e(x)`` at the true parameters.

    A picklable callable: ``reality(X)`` returns the noise-free responses of
    the cantilever whose support is a rotational spring of stiffness
    ``spring_stiffness`` (``inf`` recovers the fixed-support model).

    Parameters
    ----------
    response_names : tuple of str, default=("tip_displacement", "energy")
        Responses (columns of the output), see :func:`make_cantilever`.
    design_variable_names : tuple of str, default=("force",)
        Columns of ``X``: ``("force",)`` or ``("force", "moment")``.
    E : float, default=70e3
        True Young's modulus ``E*`` [MPa].
    I : float, default=6.75e8
        True second moment of area ``I*`` [mm⁴].
    spring_stiffness : float, default=1.5e12
        Rotational stiffness ``K*`` of the support [N·mm/rad].
    length : float, default=3000.0
        Beam length ``L`` [mm].

    Examples
    --------
    >>> reality = CantileverReality()
    >>> y = reality([[10e3]])  # model + F L^2/K*, + (F L)^2/(2 K*)
    >>> [round(float(v), 3) for v in y[0]]
    [1.965, 9823.81]
    """

    response_names: tuple = ("tip_displacement", "energy")
    design_variable_names: tuple = ("force",)
    E: float = 70.0e3
    I: float = 6.75e8
    spring_stiffness: float = 1.5e12
    length: float = 3000.0

    def __call__(self, X):
        """Evaluate the reality.

        Parameters
        ----------
        X : array-like of shape (n, d)
            Design variables (force [N] and optionally moment [N·mm]).

        Returns
        -------
        Y : ndarray of shape (n, q)
        """
        X = _check_X(X, len(self.design_variable_names), self.design_variable_names)
        force, moment = _loads(X, self.design_variable_names)
        return _beam_responses(
            force,
            moment,
            self.E,
            self.I,
            self.length,
            self.spring_stiffness,
            self.response_names,
        )


# --------------------------------------------------------------------------
# input validation
# --------------------------------------------------------------------------


def _check_names(value, argument, allowed):
    """Validate a tuple of response names (``"all"`` or a subset)."""
    if isinstance(value, str):
        value = allowed if value == "all" else (value,)
    try:
        value = tuple(value)
    except TypeError:
        value = (value,)
    bad = [v for v in value if not isinstance(v, str) or v not in allowed]
    if not value or bad or len(set(value)) != len(value):
        raise ValueError(
            f"{argument} must be 'all' or a non-empty sequence of distinct names "
            f"from {allowed}, got {value!r}"
        )
    return value


def _check_choice(value, argument, allowed):
    """Validate a tuple that must equal one of ``allowed``."""
    if isinstance(value, str):
        value = (value,)
    try:
        value = tuple(value)
    except TypeError:
        value = (value,)
    if value not in allowed:
        raise ValueError(f"{argument} must be one of {allowed}, got {value!r}")
    return value


def _check_int(value, argument, minimum):
    if (
        not isinstance(value, numbers.Integral)
        or isinstance(value, bool)
        or value < minimum
    ):
        raise ValueError(f"{argument} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _check_positive(value, argument, allow_inf=False):
    try:
        value = float(value)
    except (TypeError, ValueError):
        value = math.nan
    if not value > 0 or (math.isinf(value) and not allow_inf):
        kind = (
            "positive number (inf allowed)" if allow_inf else "finite positive number"
        )
        raise ValueError(f"{argument} must be a {kind}, got {value!r}")
    return value


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


def _scale(unit, bounds):
    bounds = np.asarray(bounds, dtype=float)
    return bounds[:, 0] + unit * (bounds[:, 1] - bounds[:, 0])


def _make_prior(prior, parameter_names):
    if prior == "uniform":
        return [
            stats.uniform(loc=lo, scale=hi - lo)
            for lo, hi in (_PARAMETER_BOUNDS[p] for p in parameter_names)
        ]
    if len(parameter_names) == 1:
        return [stats.norm(loc=_GAUSS_1D[0], scale=_GAUSS_1D[1])]
    return stats.multivariate_normal(
        mean=np.array(_GAUSS_2D_MEAN), cov=np.array(_GAUSS_2D_COV)
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
    n_simulations = _check_int(n_simulations, "n_simulations", 1)
    n_observations = _check_int(n_observations, "n_observations", 1)
    response_names = _check_names(responses, "responses", RESPONSES)
    parameter_names = _check_choice(parameters, "parameters", _PARAMETER_SETS)
    design_variable_names = _check_choice(
        design_variables, "design_variables", _DESIGN_SETS
    )
    if simulation_design not in _DESIGNS:
        raise ValueError(
            f"simulation_design must be one of {_DESIGNS}, got {simulation_design!r}"
        )
    if prior not in _PRIORS:
        raise ValueError(f"prior must be one of {_PRIORS}, got {prior!r}")
    q = len(response_names)
    snr = None if snr_db is None else per_response(snr_db, "snr_db", q)
    n_outliers = _check_int(n_outliers, "n_outliers", 0)
    if n_outliers > n_observations:
        raise ValueError(
            f"n_outliers must be between 0 and n_observations={n_observations}, "
            f"got {n_outliers}"
        )
    spring_stiffness = _check_positive(
        spring_stiffness, "spring_stiffness", allow_inf=True
    )
    E_true = _check_positive(E_true, "E_true")
    I_true = _check_positive(I_true, "I_true")
    length = _check_positive(length, "length")
    rng = as_generator(random_state)

    d, r = len(design_variable_names), len(parameter_names)
    X_bounds = np.array([_DESIGN_BOUNDS[v] for v in design_variable_names])
    theta_bounds = np.array([_PARAMETER_BOUNDS[p] for p in parameter_names])
    bounds = np.vstack([X_bounds, theta_bounds])

    simulator = CantileverModel(
        response_names=response_names,
        design_variable_names=design_variable_names,
        parameter_names=parameter_names,
        length=length,
        I=I_true,
    )
    reality = CantileverReality(
        response_names=response_names,
        design_variable_names=design_variable_names,
        E=E_true,
        I=I_true,
        spring_stiffness=spring_stiffness,
        length=length,
    )

    # simulations
    if simulation_design == "lhs":
        unit = latin_hypercube(n_simulations, d + r, rng)
        k = None
    else:
        unit, k = _grid(n_simulations, d + r)
    design = _scale(unit, bounds)
    X_sim, theta_sim = design[:, :d], design[:, d:]
    y_sim = simulator(X_sim, theta_sim)

    # observations
    X_obs = _scale(latin_hypercube(n_observations, d, rng), X_bounds)
    y_obs_true = reality(X_obs)
    signal_variance = y_obs_true.var(axis=0)
    if snr is None:
        noise_variance = np.zeros(q)
    else:
        noise_variance = signal_variance / 10.0 ** (snr / 10.0)
    y_obs = y_obs_true + rng.standard_normal((n_observations, q)) * np.sqrt(
        noise_variance
    )
    outlier_indices = np.sort(
        rng.choice(n_observations, size=n_outliers, replace=False)
    ).astype(np.intp)
    if n_outliers:
        scale = np.sqrt(signal_variance + noise_variance)
        # degenerate constant signal (e.g. a single observation)
        scale = np.where(scale > 0, scale, np.abs(y_obs_true).max(axis=0) + 1.0)
        signs = rng.choice([-1.0, 1.0], size=(n_outliers, q))
        y_obs[outlier_indices] = (
            y_obs_true[outlier_indices] + _OUTLIER_SHIFT * signs * scale
        )

    theta_true = np.array([E_true, I_true][:r])
    response_units = tuple(RESPONSE_UNITS[n] for n in response_names)
    noise = (
        "noise-free"
        if snr is None
        else "SNR " + ", ".join(f"{s:g}" for s in snr) + " dB"
    )
    responses_line = ", ".join(
        f"{n} [{u}]" for n, u in zip(response_names, response_units, strict=True)
    )
    descr = (
        "Cantilever beam calibration problem (thesis sections 4.7 and 6.3).\n"
        "Model: Euler-Bernoulli cantilever with a fixed support; reality: the\n"
        f"same beam on a rotational spring K* = {spring_stiffness:g} N*mm/rad.\n"
        f"L = {length:g} mm, E* = {E_true:g} MPa, I* = {I_true:g} mm^4.\n"
        f"Design variables: {', '.join(design_variable_names)}; "
        f"parameters: {', '.join(parameter_names)} ({prior} prior).\n"
        + textwrap.fill(f"Responses: {responses_line}.", width=72)
        + "\n"
        f"{y_sim.shape[0]} simulations ("
        + (f"{k}^{d + r} grid" if k is not None else "LHS")
        + f"), {n_observations} observations ({noise}, "
        f"{n_outliers} outliers).\n"
    )
    return Bunch(
        X_sim=X_sim,
        theta_sim=theta_sim,
        y_sim=y_sim,
        X_obs=X_obs,
        y_obs=y_obs,
        y_obs_true=y_obs_true,
        theta_true=theta_true,
        prior=_make_prior(prior, parameter_names),
        simulator=simulator,
        reality=reality,
        outlier_indices=outlier_indices,
        noise_variance=noise_variance,
        snr_db=snr,
        response_names=response_names,
        parameter_names=parameter_names,
        design_variable_names=design_variable_names,
        response_units=response_units,
        X_bounds=X_bounds,
        theta_bounds=theta_bounds,
        simulation_design=simulation_design,
        grid_points_per_axis=k,
        DESCR=descr,
    )
