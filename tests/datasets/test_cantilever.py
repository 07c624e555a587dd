"""Tests of the cantilever beam reference problem (thesis sections 4.7, 6.3)."""

import pickle

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from skmba.datasets import CantileverModel, CantileverReality, make_cantilever

ALL = (
    "tip_displacement",
    "energy",
    "tip_rotation",
    "mid_displacement",
    "quarter_displacement",
)
L = 3000.0
K = 1.5e12
E0, I0 = 70e3, 6.75e8

rng = np.random.default_rng(12345)
F = rng.uniform(1e3, 10e3, 7)
M = rng.uniform(1e6, 30e6, 7)
E = rng.uniform(20e3, 100e3, 7)
II = rng.uniform(2.25e8, 11.25e8, 7)


def _model(responses=ALL, moment=True, two_params=True):
    return CantileverModel(
        response_names=responses,
        design_variable_names=("force", "moment") if moment else ("force",),
        parameter_names=("E", "I") if two_params else ("E",),
        length=L,
        I=I0,
    )


def _reality(responses=ALL, moment=True, K=K):
    return CantileverReality(
        response_names=responses,
        design_variable_names=("force", "moment") if moment else ("force",),
        E=E0,
        I=I0,
        spring_stiffness=K,
        length=L,
    )


# --------------------------------------------------------------------------
# closed forms
# --------------------------------------------------------------------------


def test_model_force_only_matches_eqs_4_47_4_48():
    y = _model(moment=False)(F[:, None], np.column_stack([E, II]))
    EI = E * II
    assert_allclose(y[:, 0], F * L**3 / (3 * EI), rtol=1e-12)  # Eq. 4.47
    assert_allclose(y[:, 1], F**2 * L**3 / (6 * EI), rtol=1e-12)  # Eq. 4.48
    assert_allclose(y[:, 2], F * L**2 / (2 * EI), rtol=1e-12)


def test_model_single_parameter_uses_fixed_inertia():
    model = _model(responses=("tip_displacement",), moment=False, two_params=False)
    y = model(F[:, None], E[:, None])
    assert_allclose(y[:, 0], F * L**3 / (3 * E * I0), rtol=1e-12)
    # a 1-D theta is broadcast to every row
    assert_allclose(model(F[:, None], [E0]), model(F[:, None], np.full((7, 1), E0)))


def test_reality_force_only_matches_eq_4_49():
    y = _reality(moment=False)(F[:, None])
    expected = F * L**3 / (3 * E0 * I0) + F * L**2 / K  # Eq. 4.49
    assert_allclose(y[:, 0], expected, rtol=1e-12)
    # corrected Eq. 4.50: spring energy (F L)^2 / (2 K*)
    energy = F**2 * L**3 / (6 * E0 * I0) + (F * L) ** 2 / (2 * K)
    assert_allclose(y[:, 1], energy, rtol=1e-12)


def test_model_with_moment_hand_calculation():
    y = _model()(np.column_stack([F, M]), np.column_stack([E, II]))
    EI = E * II
    tip = F * L**3 / (3 * EI) + M * L**2 / (2 * EI)
    rot = F * L**2 / (2 * EI) + M * L / EI
    energy = (F**2 * L**3 / 3 + F * M * L**2 + M**2 * L) / (2 * EI)
    mid = 5 * F * L**3 / (48 * EI) + M * L**2 / (8 * EI)
    quarter = 11 * F * L**3 / (384 * EI) + M * L**2 / (32 * EI)
    assert_allclose(y, np.column_stack([tip, energy, rot, mid, quarter]), rtol=1e-12)


@pytest.mark.parametrize("x_frac, column", [(0.5, 3), (0.25, 4), (1.0, 0)])
def test_displacement_field(x_frac, column):
    x = x_frac * L
    EI = E * II
    w_model = F * x**2 * (3 * L - x) / (6 * EI) + M * x**2 / (2 * EI)
    y = _model()(np.column_stack([F, M]), np.column_stack([E, II]))
    assert_allclose(y[:, column], w_model, rtol=1e-12)
    phi = (F * L + M) / K
    w_real = F * x**2 * (3 * L - x) / (6 * E0 * I0) + M * x**2 / (2 * E0 * I0)
    y = _reality()(np.column_stack([F, M]))
    assert_allclose(y[:, column], w_real + phi * x, rtol=1e-12)


def test_reality_rotation_adds_spring_rotation():
    y = _reality()(np.column_stack([F, M]))
    rot = F * L**2 / (2 * E0 * I0) + M * L / (E0 * I0) + (F * L + M) / K
    assert_allclose(y[:, 2], rot, rtol=1e-12)


@pytest.mark.parametrize("kind", ["model", "reality", "soft_reality"])
def test_clapeyron_energy(kind):
    X = np.column_stack([F, M])
    if kind == "model":
        y = _model()(X, np.column_stack([E, II]))
    else:
        y = _reality(K=K if kind == "reality" else 1e9)(X)
    # U = 1/2 (F w(L) + M theta(L)), independent of the energy formula
    assert_allclose(y[:, 1], 0.5 * (F * y[:, 0] + M * y[:, 2]), rtol=1e-12)


def test_reality_tends_to_model_for_stiff_spring():
    X = np.column_stack([F, M])
    model = _model()(X, np.tile([E0, I0], (7, 1)))
    errors = [
        np.max(np.abs(_reality(K=k)(X) / model - 1)) for k in (1e12, 1e14, 1e16, 1e18)
    ]
    assert errors[0] > errors[1] > errors[2] > errors[3]
    assert errors[3] < 1e-6
    assert_allclose(_reality(K=np.inf)(X), model, rtol=1e-14)


def test_callables_validate_shapes():
    model = _model(moment=False, two_params=False)
    with pytest.raises(ValueError, match="X must"):
        model(F, E[:, None])
    with pytest.raises(ValueError, match="theta must"):
        model(F[:, None], E[:3, None])
    with pytest.raises(ValueError, match="X must"):
        _reality()(F[:, None])


# --------------------------------------------------------------------------
# generator
# --------------------------------------------------------------------------

KEYS = {
    "X_sim",
    "theta_sim",
    "y_sim",
    "X_obs",
    "y_obs",
    "y_obs_true",
    "theta_true",
    "prior",
    "simulator",
    "reality",
    "outlier_indices",
    "noise_variance",
    "response_names",
    "parameter_names",
    "design_variable_names",
    "DESCR",
}


@pytest.mark.parametrize("responses", [("tip_displacement", "energy"), "all"])
@pytest.mark.parametrize("parameters", [("E",), ("E", "I")])
@pytest.mark.parametrize("design_variables", [("force",), ("force", "moment")])
def test_shapes_keys_and_ranges(responses, parameters, design_variables):
    data = make_cantilever(
        40,
        13,
        responses=responses,
        parameters=parameters,
        design_variables=design_variables,
        random_state=0,
    )
    q = 5 if responses == "all" else 2
    d, r = len(design_variables), len(parameters)
    assert KEYS <= set(data)
    assert data.X_sim.shape == (40, d)
    assert data.theta_sim.shape == (40, r)
    assert data.y_sim.shape == (40, q)
    assert data.X_obs.shape == (13, d)
    assert data.y_obs.shape == data.y_obs_true.shape == (13, q)
    assert data.theta_true.shape == (r,)
    assert data.noise_variance.shape == (q,)
    assert data.outlier_indices.shape == (0,)
    assert data.response_names == (ALL if responses == "all" else responses)
    assert data.parameter_names == parameters
    assert data.design_variable_names == design_variables
    assert isinstance(data.DESCR, str) and "Cantilever" in data.DESCR
    # simulations inside the ranges of Tables 4.1-4.3
    lo = np.array([1e3, 1e6][:d] + [20e3, 2.25e8][:r])
    hi = np.array([10e3, 30e6][:d] + [100e3, 11.25e8][:r])
    design = np.hstack([data.X_sim, data.theta_sim])
    assert np.all(design >= lo) and np.all(design <= hi)
    assert np.all(data.X_obs >= lo[:d]) and np.all(data.X_obs <= hi[:d])
    # LHS: one point per stratum along every axis
    strata = np.floor((design - lo) / (hi - lo) * 40).astype(int)
    for column in strata.T:
        assert sorted(column) == list(range(40))
    # outputs are consistent with the callables, noise-free by default
    assert_allclose(data.y_sim, data.simulator(data.X_sim, data.theta_sim))
    assert_allclose(data.y_obs_true, data.reality(data.X_obs))
    assert_allclose(data.y_obs, data.y_obs_true)
    assert_allclose(data.noise_variance, 0.0)
    assert np.all(data.y_sim > 0)


def test_defaults_reproduce_section_4_7_1():
    data = make_cantilever(random_state=1)
    assert data.X_sim.shape == (70, 1) and data.X_obs.shape == (25, 1)
    assert data.response_names == ("tip_displacement", "energy")
    assert_allclose(data.theta_true, [70e3])
    assert data.reality.spring_stiffness == 1.5e12
    assert data.simulation_design == "lhs" and data.grid_points_per_axis is None


@pytest.mark.parametrize(
    "n, parameters, design_variables, k, n_expected",
    [
        (36, ("E",), ("force",), 6, 36),  # Fig. 4.11, 6 x 6
        (54, ("E",), ("force",), 7, 49),  # section 6.3
        (70, ("E",), ("force",), 8, 64),
        (150, ("E",), ("force", "moment"), 5, 125),
        (170, ("E", "I"), ("force", "moment"), 4, 256),
        (3, ("E",), ("force",), 2, 4),
    ],
)
def test_grid_design(n, parameters, design_variables, k, n_expected):
    data = make_cantilever(
        n,
        5,
        parameters=parameters,
        design_variables=design_variables,
        simulation_design="grid",
        random_state=0,
    )
    assert data.grid_points_per_axis == k
    assert data.y_sim.shape[0] == n_expected
    design = np.hstack([data.X_sim, data.theta_sim])
    assert design.shape == (n_expected, len(parameters) + len(design_variables))
    for column, (lo, hi) in zip(
        design.T, np.vstack([data.X_bounds, data.theta_bounds]), strict=True
    ):
        assert_allclose(np.unique(column), np.linspace(lo, hi, k))
    assert len(np.unique(design, axis=0)) == n_expected


def test_determinism_and_seed_dependence():
    kwargs = dict(snr_db=5.0, n_outliers=2, design_variables=("force", "moment"))
    a = make_cantilever(30, 10, random_state=7, **kwargs)
    b = make_cantilever(30, 10, random_state=7, **kwargs)
    c = make_cantilever(30, 10, random_state=8, **kwargs)
    for key in ("X_sim", "theta_sim", "y_sim", "X_obs", "y_obs", "outlier_indices"):
        assert_allclose(a[key], b[key])
    assert not np.allclose(a.X_sim, c.X_sim)
    assert not np.allclose(a.y_obs, c.y_obs)
    # RandomState and Generator are accepted and reproducible too
    d = make_cantilever(30, 10, random_state=np.random.RandomState(3), **kwargs)
    e = make_cantilever(30, 10, random_state=np.random.RandomState(3), **kwargs)
    assert_allclose(d.y_obs, e.y_obs)
    f = make_cantilever(30, 10, random_state=np.random.default_rng(3), **kwargs)
    g = make_cantilever(30, 10, random_state=np.random.default_rng(3), **kwargs)
    assert_allclose(f.y_obs, g.y_obs)


@pytest.mark.parametrize("snr_db", [-10.0, 5.0, 18.0])
def test_noise_matches_snr(snr_db):
    data = make_cantilever(10, 2000, responses="all", snr_db=snr_db, random_state=0)
    noise = data.y_obs - data.y_obs_true
    signal_var = data.y_obs_true.var(axis=0)
    assert_allclose(data.noise_variance, signal_var / 10 ** (snr_db / 10))
    empirical = 10 * np.log10(signal_var / noise.var(axis=0))
    assert np.all(np.abs(empirical - snr_db) < 0.5)
    assert_allclose(data.snr_db, snr_db)


def test_noise_per_response_snr():
    # section 4.7.6: 4.38 dB on the displacement, 71.6 dB on the energy
    data = make_cantilever(10, 2000, snr_db=[4.38, 71.6], random_state=0)
    noise = data.y_obs - data.y_obs_true
    empirical = 10 * np.log10(data.y_obs_true.var(axis=0) / noise.var(axis=0))
    assert np.all(np.abs(empirical - [4.38, 71.6]) < 0.5)


@pytest.mark.parametrize("snr_db", [None, -3.0, 18.0])
def test_outliers(snr_db):
    data = make_cantilever(10, 60, snr_db=snr_db, n_outliers=4, random_state=2)
    idx = data.outlier_indices
    assert idx.shape == (4,) and len(np.unique(idx)) == 4
    assert np.all((idx >= 0) & (idx < 60))
    deviation = np.abs(data.y_obs - data.y_obs_true)
    sd = np.sqrt(data.y_obs_true.var(axis=0) + data.noise_variance)
    # outliers are 6 sd of the observed signal away from the reality ...
    assert_allclose(deviation[idx], np.broadcast_to(6 * sd, (4, 2)), rtol=1e-9)
    # ... and at least 6 noise sd and 6 signal sd
    assert np.all(deviation[idx] >= 6 * np.sqrt(data.noise_variance))
    others = np.setdiff1d(np.arange(60), idx)
    if snr_db is None:
        assert_allclose(data.y_obs[others], data.y_obs_true[others])
    assert deviation[idx].min(axis=0).min() > 0
    assert np.all(deviation[idx].min(axis=0) > deviation[others].max(axis=0) / 2)


def test_all_observations_outliers():
    data = make_cantilever(5, 3, n_outliers=3, random_state=0)
    assert_allclose(data.outlier_indices, [0, 1, 2])


# --------------------------------------------------------------------------
# priors and pickling
# --------------------------------------------------------------------------


def test_uniform_prior():
    prior = make_cantilever(5, 3, parameters=("E", "I"), random_state=0).prior
    assert len(prior) == 2
    for dist, (lo, hi) in zip(prior, [(20e3, 100e3), (2.25e8, 11.25e8)], strict=True):
        assert isinstance(dist.dist, type(stats.uniform))
        assert_allclose(dist.support(), (lo, hi))


def test_gaussian_priors_eq_4_54():
    prior = make_cantilever(5, 3, prior="gaussian", random_state=0).prior
    assert len(prior) == 1 and isinstance(prior[0].dist, type(stats.norm))
    assert_allclose([prior[0].mean(), prior[0].std()], [50e3, 10e3])
    data = make_cantilever(
        20, 3, prior="gaussian", parameters=("E", "I"), random_state=0
    )
    mvn = data.prior
    assert hasattr(mvn, "logpdf") and mvn.dim == 2
    assert_allclose(mvn.mean, [53e3, 4.72e8])
    assert_allclose(mvn.cov, np.diag([1e8, 4.5e15]))
    # simulations span the uniform ranges of Tables 4.1/4.3 (cover the truth)
    assert np.all(data.theta_sim.min(axis=0) < data.theta_true)
    assert np.all(data.theta_sim.max(axis=0) > data.theta_true)


def test_pickle_round_trip():
    data = make_cantilever(
        8,
        6,
        responses="all",
        parameters=("E", "I"),
        design_variables=("force", "moment"),
        random_state=0,
    )
    simulator = pickle.loads(pickle.dumps(data.simulator))
    reality = pickle.loads(pickle.dumps(data.reality))
    assert simulator == data.simulator and reality == data.reality
    assert_allclose(
        simulator(data.X_sim, data.theta_sim),
        data.simulator(data.X_sim, data.theta_sim),
    )
    assert_allclose(reality(data.X_obs), data.y_obs_true)


# --------------------------------------------------------------------------
# bad input
# --------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(n_simulations=0), "n_simulations"),
        (dict(n_simulations=2.5), "n_simulations"),
        (dict(n_observations=-1), "n_observations"),
        (dict(n_observations=True), "n_observations"),
        (dict(responses=("tip_displacement", "stress")), "responses"),
        (dict(responses=()), "responses"),
        (dict(responses=("energy", "energy")), "responses"),
        (dict(parameters=("E", "A")), "parameters"),
        (dict(parameters=("I",)), "parameters"),
        (dict(design_variables=("moment",)), "design_variables"),
        (dict(design_variables=("force", "torque")), "design_variables"),
        (dict(simulation_design="sobol"), "simulation_design"),
        (dict(prior="beta"), "prior"),
        (dict(snr_db=np.inf), "snr_db"),
        (dict(snr_db=np.nan), "snr_db"),
        (dict(snr_db="loud"), "snr_db"),
        (dict(snr_db=[1.0, 2.0, 3.0]), "snr_db"),
        (dict(n_outliers=26), "n_outliers"),
        (dict(n_outliers=-1), "n_outliers"),
        (dict(spring_stiffness=0.0), "spring_stiffness"),
        (dict(E_true=-1.0), "E_true"),
        (dict(I_true=np.nan), "I_true"),
        (dict(length=np.inf), "length"),
        (dict(random_state="seed"), "random_state"),
    ],
)
def test_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        make_cantilever(**kwargs)


def test_error_lists_allowed_values():
    with pytest.raises(ValueError, match="quarter_displacement"):
        make_cantilever(responses=("bogus",))
    with pytest.raises(ValueError, match="gaussian"):
        make_cantilever(prior="normal")
