"""Tests of the truss solver and of ``make_truss_bridge``.

The finite element cases are checked against hand calculations: a single bar,
the method of joints and the unit-load method. They run through the same
``Truss`` class that the bridge dataset uses.
"""

import pickle
import time

import numpy as np
import pytest
from scipy import stats

from skmba.datasets import make_truss_bridge
from skmba.datasets._truss_bridge_model import (
    N_PANELS,
    PANEL_LENGTH,
    SENSORS,
    THERMAL_EXPANSION,
    bridge_geometry,
    bridge_truss,
    temperature_profile,
)
from skmba.datasets._truss_solver import Truss

E = 70_000.0  # MPa
AREA = 100.0  # mm^2
ALPHA = 23e-6  # 1/degC
LENGTH = 1000.0  # mm
DT = 30.0  # degC


# ----------------------------------------------------------------- one bar
def _bar(supports, springs=None, angle=0.0):
    end = LENGTH * np.array([np.cos(angle), np.sin(angle)])
    return Truss(
        [[0.0, 0.0], end],
        [[0, 1]],
        E=E,
        A=AREA,
        alpha=ALPHA,
        supports=supports,
        springs=springs,
    )


def test_bar_free_to_slide_expands_freely():
    bar = _bar(supports=[0, 1, 3])  # node 1 slides along x
    u = bar.solve(dT=DT)
    assert u[2] == pytest.approx(ALPHA * DT * LENGTH, rel=1e-12)
    assert bar.total_strains(u)[0] == pytest.approx(ALPHA * DT, rel=1e-12)
    assert bar.bar_strains(u, dT=DT)[0] == pytest.approx(0.0, abs=1e-15)
    assert bar.bar_forces(u, dT=DT)[0] == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("angle", [0.0, 0.6, np.pi / 2, 2.5])
def test_bar_fixed_at_both_ends(angle):
    bar = _bar(supports=[0, 1, 2, 3], angle=angle)
    u = bar.solve(dT=DT)
    np.testing.assert_array_equal(u, 0.0)
    assert bar.bar_forces(u, dT=DT)[0] == pytest.approx(-E * AREA * ALPHA * DT)
    assert bar.bar_strains(u, dT=DT)[0] == pytest.approx(-ALPHA * DT)
    assert bar.total_strains(u)[0] == 0.0
    # The supports push the heated bar back: E A alpha dT inwards at each end.
    r = bar.reactions(u, dT=DT)
    axis = np.array([np.cos(angle), np.sin(angle)])
    np.testing.assert_allclose(r[:2], E * AREA * ALPHA * DT * axis, atol=1e-8)
    np.testing.assert_allclose(r[2:], -E * AREA * ALPHA * DT * axis, atol=1e-8)


@pytest.mark.parametrize("k", [0.0, 500.0, 7000.0, 1e5])
def test_bar_with_spring_is_two_springs_in_series(k):
    bar = _bar(supports=[0, 1, 3], springs={2: k})
    u = bar.solve(dT=DT)
    ea_l = E * AREA / LENGTH
    expected = -(k * ea_l) / (k + ea_l) * ALPHA * DT * LENGTH
    force = bar.bar_forces(u, dT=DT)[0]
    assert force == pytest.approx(expected, rel=1e-12, abs=1e-9)
    # The spring holds the bar: its force on the node balances the bar's.
    assert bar.spring_forces(u)[2] == pytest.approx(force, rel=1e-12, abs=1e-9)


# ------------------------------------------------------- determinate trusses
P, H = 10_000.0, 3_000.0  # N


def _triangle(areas=AREA):
    # 3-4-5 triangle: A(0, 0), B(4000, 0), C(2000, 1500); bars AB, AC, BC.
    nodes = [[0.0, 0.0], [4000.0, 0.0], [2000.0, 1500.0]]
    bars = [[0, 1], [0, 2], [1, 2]]
    return Truss(nodes, bars, E=E, A=areas, alpha=ALPHA, supports=[0, 1, 3])


def _warren():
    # Two-panel Warren truss, 3-4-5 diagonals: bottom 0-1-2, top 3-4.
    nodes = [[0, 0], [3000, 0], [6000, 0], [1500, 2000], [4500, 2000]]
    bars = [[0, 1], [1, 2], [3, 4], [0, 3], [3, 1], [1, 4], [4, 2]]
    return Truss(nodes, bars, E=E, A=AREA, alpha=ALPHA, supports=[0, 1, 5])


def test_triangle_bar_forces_match_method_of_joints():
    truss = _triangle()
    loads = np.zeros(truss.n_dof)
    loads[4], loads[5] = H, -P  # at C: horizontal H, downward P
    u = truss.solve(loads)
    # Joint C: sin = 0.6, cos = 0.8 for both inclined bars.
    n_ac = (-P / 0.6 + H / 0.8) / 2
    n_bc = (-P / 0.6 - H / 0.8) / 2
    # Joint B (roller): horizontal equilibrium.
    n_ab = -0.8 * n_bc
    np.testing.assert_allclose(truss.bar_forces(u), [n_ab, n_ac, n_bc], rtol=1e-10)


def test_warren_bar_forces_match_method_of_joints():
    truss = _warren()
    loads = np.zeros(truss.n_dof)
    loads[3] = -P  # downward P at the middle bottom node
    u = truss.solve(loads)
    # Joint 0: V = P/2, sin = 0.8, cos = 0.6; joint 3 gives the rest.
    n_diag = P / 1.6
    expected = [0.375 * P, 0.375 * P, -0.75 * P, -n_diag, n_diag, n_diag, -n_diag]
    np.testing.assert_allclose(truss.bar_forces(u), expected, rtol=1e-10)


def test_triangle_displacements_match_unit_load_method():
    areas = np.array([100.0, 150.0, 200.0])
    truss = _triangle(areas)
    lengths = np.array([4000.0, 2500.0, 2500.0])
    loads = np.zeros(truss.n_dof)
    loads[5] = -P
    u = truss.solve(loads)
    # Real forces N under P, virtual forces n under a unit downward load at C.
    N = np.array([2.0 / 3.0, -5.0 / 6.0, -5.0 / 6.0]) * P
    n = N / P
    delta_c = np.sum(N * n * lengths / (E * areas))
    assert -u[5] == pytest.approx(delta_c, rel=1e-10)
    # Horizontal movement of the roller B: a unit horizontal load at B loads
    # only AB (n = 1).
    assert u[2] == pytest.approx(N[0] * lengths[0] / (E * areas[0]), rel=1e-10)


@pytest.mark.parametrize("make", [_triangle, _warren])
def test_determinate_truss_has_no_thermal_stress(make):
    truss = make()
    rng = np.random.default_rng(0)
    for dT in (DT, rng.uniform(-20.0, 40.0, size=truss.n_bars)):
        u = truss.solve(dT=dT)
        assert np.abs(u).max() > 1e-2  # it does move
        forces = truss.bar_forces(u, dT=dT)
        np.testing.assert_allclose(forces, 0.0, atol=1e-8 * E * AREA * ALPHA * DT)


def test_several_load_cases_as_columns():
    truss = _warren()
    rng = np.random.default_rng(1)
    loads = rng.normal(size=(truss.n_dof, 3)) * 1e3
    dT = rng.uniform(0.0, 30.0, size=(truss.n_bars, 3))
    u = truss.solve(loads, dT)
    for j in range(3):
        np.testing.assert_allclose(u[:, j], truss.solve(loads[:, j], dT[:, j]))
        np.testing.assert_allclose(
            truss.bar_forces(u, dT)[:, j], truss.bar_forces(u[:, j], dT[:, j])
        )


# ----------------------------------------------------- bridge truss checks
def test_global_equilibrium_with_spring():
    truss, spring_dof = bridge_truss(k=552.26)
    rng = np.random.default_rng(2)
    loads = rng.normal(size=truss.n_dof) * 1e3
    dT = rng.uniform(0.0, 30.0, size=truss.n_bars)
    u = truss.solve(loads, dT)
    reactions = truss.reactions(u, loads, dT)
    springs = truss.spring_forces(u)
    assert springs[spring_dof] != 0.0
    np.testing.assert_array_equal(reactions[truss.free_dofs], 0.0)
    total = (loads + reactions + springs).reshape(-1, 2)
    x, y = truss.nodes.T
    scale = np.abs(loads).sum()
    assert abs(total[:, 0].sum()) < 1e-9 * scale
    assert abs(total[:, 1].sum()) < 1e-9 * scale
    moment = np.sum(x * total[:, 1] - y * total[:, 0])
    assert abs(moment) < 1e-9 * scale * x.max()


def test_stiffness_symmetric_singular_without_supports_positive_with():
    truss, _ = bridge_truss(k=0.0)
    K = truss.stiffness()
    np.testing.assert_allclose(K, K.T, rtol=0, atol=1e-9)
    eig = np.linalg.eigvalsh(K)
    # Three rigid-body modes of a free plane truss.
    assert np.sum(np.abs(eig) < 1e-8 * eig.max()) == 3
    reduced = np.linalg.eigvalsh(truss.stiffness(reduced=True))
    assert reduced.min() > 1e-6 * reduced.max()
    # The spring adds k to one diagonal entry.
    stiff, dof = bridge_truss(k=552.26)
    diff = stiff.stiffness() - K
    assert diff[dof, dof] == pytest.approx(552.26)
    diff[dof, dof] = 0.0
    np.testing.assert_array_equal(diff, 0.0)


@pytest.mark.parametrize(
    "make",
    [
        # A square without a diagonal sways.
        lambda: Truss(
            [[0, 0], [1, 0], [1, 1], [0, 1]],
            [[0, 1], [1, 2], [2, 3], [3, 0]],
            E=E,
            A=AREA,
            supports=[0, 1, 3],
        ),
        # A bar pinned at one end only rotates freely.
        lambda: _bar(supports=[0, 1]),
        # A node connected to nothing.
        lambda: Truss(
            [[0, 0], [1000, 0], [5, 5]], [[0, 1]], E=E, A=AREA, supports=[0, 1, 3]
        ),
    ],
)
def test_mechanism_raises(make):
    truss = make()
    with pytest.raises(ValueError, match="mechanism"):
        truss.solve(np.ones(truss.n_dof))


def test_truss_rejects_bad_definitions():
    with pytest.raises(ValueError, match="A must be positive"):
        Truss([[0, 0], [1, 0]], [[0, 1]], E=E, A=0.0)
    with pytest.raises(ValueError, match="bars"):
        Truss([[0, 0], [1, 0]], [[0, 2]], E=E, A=AREA)
    with pytest.raises(ValueError, match="distinct"):
        Truss([[0, 0], [0, 0]], [[0, 1]], E=E, A=AREA)
    with pytest.raises(ValueError, match="spring"):
        Truss([[0, 0], [1, 0]], [[0, 1]], E=E, A=AREA, springs={2: -1.0})


# ------------------------------------------------------------ bridge model
SPAN = N_PANELS * PANEL_LENGTH
LOWER = ["SA", "SG", "SI"]  # lower-chord gauges


def test_model_without_spring_expands_freely():
    data = make_truss_bridge(n_simulations=5, n_observations=5, random_state=0)
    X = np.array([[10.0], [20.0], [35.0], [45.49]])
    np.testing.assert_allclose(data.simulator(X, np.zeros((4, 1))), 0.0, atol=1e-9)
    # Free expansion of the span at the roller.
    truss, dof = bridge_truss(k=0.0)
    u = truss.solve(dT=25.0)
    assert u[dof] == pytest.approx(THERMAL_EXPANSION * 25.0 * SPAN, rel=1e-10)


def test_model_with_stiff_spring_compresses_lower_chord():
    data = make_truss_bridge(n_simulations=5, sensors=LOWER, random_state=0)
    dT = np.array([5.0, 10.0, 25.0])
    X = 20.0 + dT[:, None]
    y = data.simulator(X, np.full((3, 1), 1e12))
    assert np.all(y < 0.0)
    per_degree = y / dT[:, None]
    np.testing.assert_allclose(per_degree, per_degree[[0, 0, 0]], rtol=1e-12)
    # The roller no longer moves, so the lower chord's total elongation is
    # zero: its mean mechanical strain is -alpha dT.
    truss, _ = bridge_truss(k=1e12)
    u = truss.solve(dT=25.0)
    _, _, names, kinds = bridge_geometry()
    lower = [i for i, kind in enumerate(kinds) if kind == "lower chord"]
    assert [names[i] for i in lower] == [f"L{i}-L{i + 1}" for i in range(N_PANELS)]
    strain = truss.bar_strains(u, dT=25.0)[lower]
    assert strain.mean() == pytest.approx(-THERMAL_EXPANSION * 25.0, rel=1e-6)
    # ... and much less than that with a spring of the prior's range.
    y_k = data.simulator([[45.0]], [[1000.0]])
    assert np.all(-1e6 * THERMAL_EXPANSION * 25.0 < y_k) and np.all(y_k < 0.0)


def test_spring_force_follows_series_springs():
    # K_t: horizontal stiffness of the truss at the roller (unit-load solve).
    truss, dof = bridge_truss(k=0.0)
    unit = np.zeros(truss.n_dof)
    unit[dof] = 1.0
    k_truss = 1.0 / truss.solve(unit)[dof]
    k, dT = 552.26, 20.0
    spring, _ = bridge_truss(k=k)
    u = spring.solve(dT=dT)
    force = -spring.spring_forces(u)[dof]  # compression in the spring
    free = THERMAL_EXPANSION * dT * SPAN
    assert force == pytest.approx(k * k_truss / (k + k_truss) * free, rel=1e-10)
    # The end panel of the lower chord (statically determinate) carries it.
    data = make_truss_bridge(n_simulations=5, sensors=["SA"], random_state=0)
    strain = data.simulator([[20.0 + dT]], [[k]])[0, 0]
    area = spring.A[data.sensor_bars[0]]
    assert strain == pytest.approx(-1e6 * force / (spring.E[0] * area), rel=1e-10)


def test_strains_linear_in_temperature_change():
    data = make_truss_bridge(n_simulations=5, random_state=0)
    k = [[700.0]]
    y1 = data.simulator([[20.0 + 7.0]], k)
    y2 = data.simulator([[20.0 + 14.0]], k)
    y3 = data.simulator([[20.0 - 7.0]], k)
    np.testing.assert_allclose(y2, 2.0 * y1, rtol=1e-12)
    np.testing.assert_allclose(y3, -y1, rtol=1e-12)
    np.testing.assert_allclose(data.simulator([[20.0]], k), 0.0, atol=1e-12)
    np.testing.assert_allclose(
        data.reality([[34.0]]), 2.0 * data.reality([[27.0]]), rtol=1e-12
    )


def test_strains_increase_with_stiffness():
    data = make_truss_bridge(n_simulations=5, random_state=0)
    k = np.array([[100.0], [300.0], [552.26], [1000.0], [5000.0]])
    y = data.simulator(np.full((5, 1), 40.0), k)
    assert np.all(np.diff(np.abs(y), axis=0) > 0.0)


def test_vectorised_simulator_matches_row_by_row():
    data = make_truss_bridge(n_simulations=5, random_state=0)
    rng = np.random.default_rng(3)
    X = rng.uniform(20.0, 45.0, size=(12, 1))
    theta = rng.choice([300.0, 552.26, 900.0], size=(12, 1))
    y = data.simulator(X, theta)
    rows = np.vstack(
        [data.simulator(X[i : i + 1], theta[i : i + 1]) for i in range(12)]
    )
    np.testing.assert_allclose(y, rows, rtol=1e-12)
    # One theta row is used for every X row.
    np.testing.assert_allclose(
        data.simulator(X, theta[:1]),
        data.simulator(X, np.repeat(theta[:1], 12, axis=0)),
    )


def test_reality_differs_from_model_by_the_gradient():
    data = make_truss_bridge(n_simulations=5, random_state=0)
    X = np.array([[30.0], [45.0]])
    model = data.simulator(X, np.full((2, 1), data.theta_true[0]))
    reality = data.reality(X)
    assert np.abs(reality - model).max() > 5.0  # microstrain
    # The upper-chord gauge SB changes sign (as strain B in the thesis).
    sb = data.response_names.index("SB")
    assert np.all(model[:, sb] > 0.0) and np.all(reality[:, sb] < 0.0)

    flat = make_truss_bridge(n_simulations=5, gradient=0.0, random_state=0)
    np.testing.assert_allclose(flat.reality(X), model, rtol=1e-12)


@pytest.mark.parametrize("p", [1.0, 2.0, 3.0])
def test_temperature_profile_by_member(p):
    g = 0.4
    truss, _ = bridge_truss()
    kinds = bridge_geometry()[3]
    profile = temperature_profile(truss, g, p)
    kinds = np.array(kinds)
    # Mean of (1 - g) + g eta**p over the height the member spans.
    expected = {
        "upper chord": 1.0,
        "lower chord": 1.0 - g,
        "vertical": 1.0 - g + g / (p + 1.0),
        "diagonal": 1.0 - g + g / (p + 1.0),
        "end post": 1.0 - g + g / (p + 1.0),
    }
    for kind, value in expected.items():
        np.testing.assert_allclose(profile[kinds == kind], value, rtol=1e-12)


def test_linear_profile_only_scales_the_spring_force():
    g = 0.3
    data = make_truss_bridge(
        n_simulations=5, gradient=g, gradient_exponent=1.0, random_state=0
    )
    X = np.array([[40.0]])
    model = data.simulator(X, [[data.theta_true[0]]])
    np.testing.assert_allclose(data.reality(X), (1.0 - g) * model, rtol=1e-9)


def test_model_gauges_are_proportional_reality_along_another_direction():
    # Documented property: one spring force drives every model strain.
    data = make_truss_bridge(n_simulations=30, n_observations=10, random_state=0)
    sv = np.linalg.svd(data.y_sim, compute_uv=False)
    assert sv[1] < 1e-10 * sv[0]
    sv_obs = np.linalg.svd(data.y_obs_true, compute_uv=False)
    assert sv_obs[1] < 1e-10 * sv_obs[0]
    both = np.vstack([data.y_sim, data.y_obs_true])
    sv_both = np.linalg.svd(both, compute_uv=False)
    assert sv_both[1] > 1e-2 * sv_both[0]


# --------------------------------------------------------- dataset contract
def test_shapes_and_contents():
    data = make_truss_bridge(n_simulations=40, n_observations=15, random_state=0)
    q = len(SENSORS)
    assert data.X_sim.shape == (40, 1) and data.theta_sim.shape == (40, 1)
    assert data.y_sim.shape == (40, q)
    assert data.X_obs.shape == (15, 1) and data.y_obs.shape == (15, q)
    assert data.y_obs_true.shape == (15, q)
    assert data.theta_true.shape == (1,) and data.theta_true[0] == 552.26
    assert data.response_names == tuple(SENSORS)
    assert data.noise_variance.shape == (q,)
    assert data.nodes.shape == (16, 2) and data.bars.shape == (35, 2)
    for name, bar in zip(data.response_names, data.sensor_bars, strict=True):
        assert data.bar_names[bar] == SENSORS[name]
    np.testing.assert_allclose(data.y_sim, data.simulator(data.X_sim, data.theta_sim))
    np.testing.assert_allclose(data.y_obs_true, data.reality(data.X_obs))
    np.testing.assert_array_equal(data.y_obs, data.y_obs_true)  # noise-free
    assert len(data.prior) == 1 and data.prior[0].support() == (300.0, 1000.0)
    assert "SA" in data.DESCR and "L0-L1" in data.DESCR


def test_design_is_a_latin_hypercube_over_the_ranges():
    prior = stats.uniform(loc=400.0, scale=200.0)
    n = 25
    data = make_truss_bridge(
        n_simulations=n,
        temperature_range=(15.0, 40.0),
        stiffness_prior=prior,
        random_state=1,
    )
    assert data.prior[0] is prior
    t = (data.X_sim[:, 0] - 15.0) / 25.0
    k = (data.theta_sim[:, 0] - 400.0) / 200.0
    for column in (t, k):
        assert np.all((column >= 0.0) & (column < 1.0))
        np.testing.assert_array_equal(np.sort(np.floor(column * n)), np.arange(n))
    assert np.all((data.X_obs >= 15.0) & (data.X_obs <= 40.0))
    np.testing.assert_array_equal(data.X_bounds, [[15.0, 40.0]])
    np.testing.assert_array_equal(data.theta_bounds, [[400.0, 600.0]])


def test_sensor_selection_by_name_and_index():
    by_name = make_truss_bridge(n_simulations=8, sensors=["SG", "SB"], random_state=0)
    by_index = make_truss_bridge(n_simulations=8, sensors=[6, 1], random_state=0)
    full = make_truss_bridge(n_simulations=8, random_state=0)
    assert by_name.response_names == ("SG", "SB")
    np.testing.assert_array_equal(by_name.y_sim, by_index.y_sim)
    np.testing.assert_array_equal(by_name.y_sim, full.y_sim[:, [6, 1]])
    single = make_truss_bridge(n_simulations=8, sensors="SH", random_state=0)
    assert single.y_sim.shape == (8, 1)


def test_deterministic_per_seed():
    a = make_truss_bridge(n_simulations=10, snr_db=20.0, random_state=7)
    b = make_truss_bridge(n_simulations=10, snr_db=20.0, random_state=7)
    c = make_truss_bridge(n_simulations=10, snr_db=20.0, random_state=8)
    for key in ("X_sim", "theta_sim", "y_sim", "X_obs", "y_obs"):
        np.testing.assert_array_equal(a[key], b[key])
        assert not np.array_equal(a[key], c[key])
    g = make_truss_bridge(n_simulations=10, random_state=np.random.default_rng(0))
    assert g.X_sim.shape == (10, 1)


@pytest.mark.parametrize("snr", [0.0, 10.0, 25.0])
def test_noise_snr(snr):
    data = make_truss_bridge(n_observations=20_000, snr_db=snr, random_state=0)
    signal = data.y_obs_true.var(axis=0)
    np.testing.assert_allclose(data.noise_variance, signal / 10 ** (snr / 10))
    noise = (data.y_obs - data.y_obs_true).var(axis=0)
    measured = 10.0 * np.log10(signal / noise)
    assert np.all(np.abs(measured - snr) < 0.5), measured
    np.testing.assert_array_equal(data.snr_db, snr)


def test_noise_std():
    data = make_truss_bridge(
        n_observations=20_000,
        sensors=["SA", "SH"],
        noise_std=[2.0, 0.5],
        random_state=0,
    )
    np.testing.assert_allclose(data.noise_variance, [4.0, 0.25])
    std = (data.y_obs - data.y_obs_true).std(axis=0)
    np.testing.assert_allclose(std, [2.0, 0.5], rtol=0.03)


def test_simulator_and_reality_pickle():
    data = make_truss_bridge(n_simulations=5, random_state=0)
    X = np.array([[25.0], [41.0]])
    theta = np.array([[350.0], [800.0]])
    sim = pickle.loads(pickle.dumps(data.simulator))
    real = pickle.loads(pickle.dumps(data.reality))
    np.testing.assert_array_equal(sim(X, theta), data.simulator(X, theta))
    np.testing.assert_array_equal(real(X), data.reality(X))


def test_simulator_is_fast():
    data = make_truss_bridge(n_simulations=5, random_state=0)
    rng = np.random.default_rng(0)
    X = rng.uniform(20.0, 45.0, size=(100, 1))
    theta = rng.uniform(300.0, 1000.0, size=(100, 1))  # 100 distinct k
    start = time.perf_counter()
    data.simulator(X, theta)
    assert time.perf_counter() - start < 0.5


@pytest.mark.parametrize(
    ("kwargs", "argument"),
    [
        ({"sensors": ["SZ"]}, "sensors"),
        ({"sensors": []}, "sensors"),
        ({"sensors": [11]}, "sensors"),
        ({"sensors": ["SA", "SA"]}, "sensors"),
        ({"sensors": [1.5]}, "sensors"),
        ({"n_simulations": 0}, "n_simulations"),
        ({"n_simulations": 2.5}, "n_simulations"),
        ({"n_observations": -3}, "n_observations"),
        ({"k_true": 0.0}, "k_true"),
        ({"k_true": -10.0}, "k_true"),
        ({"temperature_range": (40.0, 20.0)}, "temperature_range"),
        ({"temperature_range": (20.0,)}, "temperature_range"),
        ({"temperature_range": (20.0, np.nan)}, "temperature_range"),
        ({"stiffness_prior": "uniform"}, "stiffness_prior"),
        ({"stiffness_prior": [300.0, 1000.0]}, "stiffness_prior"),
        ({"stiffness_prior": stats.norm(550.0, 100.0)}, "stiffness_prior"),
        ({"snr_db": 10.0, "noise_std": 1.0}, "snr_db and noise_std"),
        ({"noise_std": -1.0}, "noise_std"),
        ({"snr_db": [10.0, 20.0]}, "snr_db"),
        ({"gradient": 1.5}, "gradient"),
        ({"gradient": "steep"}, "gradient"),
        ({"gradient_exponent": 0.0}, "gradient_exponent"),
        ({"random_state": "seed"}, "random_state"),
    ],
)
def test_bad_input_raises(kwargs, argument):
    with pytest.raises(ValueError, match=argument):
        make_truss_bridge(**kwargs)


def test_simulator_rejects_bad_input():
    data = make_truss_bridge(n_simulations=5, random_state=0)
    with pytest.raises(ValueError, match="theta"):
        data.simulator([[30.0]], [[-1.0]])
    with pytest.raises(ValueError, match="X"):
        data.simulator(np.ones((3, 2)), np.ones((3, 1)))
    with pytest.raises(ValueError, match="same number of rows"):
        data.simulator(np.ones((3, 1)), np.ones((2, 1)))
