"""Tests of the bridge finite element model and of ``make_bridge_monitoring``.

The finite element model is checked against beam theory: the closed-form
frequencies of a simply supported beam, the convergence of the consistent
mass formulation from above, and the rigid-body modes on soft bearings.
"""

import pickle

import numpy as np
import pytest

from skmba.datasets import BridgeModel, BridgeReality, make_bridge_monitoring
from skmba.datasets import _bridge_monitoring as monitoring
from skmba.datasets._bridge_model import (
    MASS_PER_LENGTH,
    REFERENCE_TEMPERATURE,
    SECOND_MOMENT,
    SPAN,
    TEMPERATURE_COEFFICIENT,
    beam_mass,
    beam_stiffness,
    deck_matrices,
    frost_degrees,
    natural_frequencies,
)

E = 35e9  # Pa
EI = E * SECOND_MOMENT
STIFF = 1e16  # N/m: bearings far stiffer than the deck
MODES = np.arange(1, 5)


def _closed_form(EI=EI, span=SPAN, m=MASS_PER_LENGTH):
    """Simply supported uniform beam: f_k = k^2 pi / (2 L^2) sqrt(EI / m)."""
    return MODES**2 * np.pi / (2.0 * span**2) * np.sqrt(EI / m)


# ------------------------------------------------------ the element matrices
def test_element_matrices_symmetric_with_rigid_body_modes():
    h = 1.5
    for matrix in (beam_stiffness(EI, h), beam_mass(MASS_PER_LENGTH, h)):
        np.testing.assert_array_equal(matrix, matrix.T)
    K1, M = deck_matrices(20, SPAN, MASS_PER_LENGTH)
    np.testing.assert_array_equal(K1, K1.T)
    eigenvalues = np.linalg.eigvalsh(K1)
    # A free beam: translation and rotation cost no strain energy.
    assert np.sum(np.abs(eigenvalues) < 1e-9 * eigenvalues.max()) == 2
    assert np.linalg.eigvalsh(M).min() > 0.0
    # The deflection dofs carry the deck's mass m L under a unit translation.
    translation = np.zeros(K1.shape[0])
    translation[::2] = 1.0
    assert translation @ M @ translation == pytest.approx(MASS_PER_LENGTH * SPAN)
    np.testing.assert_allclose(K1 @ translation, 0.0, atol=1e-12)


# ------------------------------------------------------------ beam theory
def test_simply_supported_beam_matches_closed_form():
    exact = _closed_form()
    springs = natural_frequencies(EI, STIFF, 4, n_elements=40)
    pinned = natural_frequencies(EI, np.inf, 4, n_elements=40)
    np.testing.assert_allclose(springs, exact, rtol=1e-4)
    np.testing.assert_allclose(pinned, exact, rtol=1e-4)
    np.testing.assert_allclose(springs, pinned, rtol=1e-6)
    # The simulator is the same model: E at T_ref, stiff bearings.
    model = BridgeModel(n_elements=40)
    f = model([[REFERENCE_TEMPERATURE]], [E, STIFF])[0]
    np.testing.assert_allclose(f, exact, rtol=1e-4)


def test_convergence_from_above_like_h_to_the_fourth():
    exact = _closed_form()
    meshes = (5, 10, 20, 40)
    errors = np.array(
        [natural_frequencies(EI, np.inf, 4, n_elements=n) / exact - 1.0 for n in meshes]
    )
    # Consistent mass (Rayleigh-Ritz): every frequency converges from above.
    assert np.all(errors > 0.0)
    assert np.all(np.diff(errors, axis=0) < 0.0)
    # Halving h divides the error by about 2^4.
    ratio = errors[-2] / errors[-1]
    assert np.all((12.0 < ratio) & (ratio < 20.0)), ratio
    assert errors[1:, 0].max() < 1e-4  # the first mode from 10 elements on


def test_soft_bearings_give_the_rigid_body_modes():
    # A stiff deck on soft springs bounces and rocks as a rigid body:
    # omega^2 = 2 k / (m L) and 6 k / (m L), up to the deck's flexibility
    # (relatively about 2 k L^3 / (22.4^2 EI), the first free-free bending
    # mode's share: 1.5e-5 here).
    k = 1e4
    f = natural_frequencies(EI, k, 3)
    omega = np.sqrt(np.array([2.0, 6.0]) * k / (MASS_PER_LENGTH * SPAN))
    np.testing.assert_allclose(f[:2], omega / (2.0 * np.pi), rtol=1e-4)
    assert f[2] > 100.0 * f[1]  # the first bending mode, far above


def test_bearing_stiffness_raises_every_frequency():
    k = np.array([3e8, 3e9, 3e10])
    f = natural_frequencies(EI, k, 4)
    assert np.all(np.diff(f, axis=0) > 0.0)
    assert np.all(f < _closed_form() * (1.0 + 1e-3))


def test_simulator_applies_the_temperature_law():
    model = BridgeModel()
    T = np.array([[-10.0], [5.0], [20.0], [33.3]])
    theta = np.array([[30e9, 1e9], [35e9, 3e9], [40e9, 1e10], [45e9, 3e8]])
    factor = 1.0 + TEMPERATURE_COEFFICIENT * (T[:, 0] - REFERENCE_TEMPERATURE)
    expected = natural_frequencies(theta[:, 0] * factor * SECOND_MOMENT, theta[:, 1], 4)
    np.testing.assert_array_equal(model(T, theta), expected)
    # On pinned bearings the frequencies scale with sqrt(E(T)).
    pinned = model(T, np.column_stack([np.full(4, E), np.full(4, np.inf)]))
    np.testing.assert_allclose(
        pinned / pinned[2], np.sqrt(factor / factor[2])[:, None] * np.ones(4)
    )


def test_frost_degrees_is_a_smoothed_ramp():
    T = np.array([10.0, 0.0, -0.5, -1.0, -2.0, -3.0, -10.0])
    np.testing.assert_allclose(
        frost_degrees(T), [0.0, 0.0, 0.0625, 0.25, 1.0, 2.0, 9.0]
    )
    # Continuous slope: -1 below the transition, 0 above freezing.
    step = 1e-6
    for t0, slope in ((-2.0, -1.0), (0.0, 0.0), (-5.0, -1.0)):
        rise = frost_degrees(t0 + step) - frost_degrees(t0 - step)
        assert rise / (2 * step) == pytest.approx(slope, abs=1e-5)


# ------------------------------------------------------------ the dataset
@pytest.fixture(scope="module")
def year():
    return make_bridge_monitoring(random_state=0)


def test_shapes_names_and_table(year):
    data = year
    assert data.X_obs.shape == (8760, 1) and data.y_obs.shape == (8760, 4)
    assert data.y_obs_true.shape == (8760, 4)
    assert data.X_sim.shape == (60, 1) and data.theta_sim.shape == (60, 2)
    assert data.y_sim.shape == (60, 4)
    assert data.response_names == ("f1", "f2", "f3", "f4")
    assert data.design_variable_names == ("temperature",)
    assert data.parameter_names == ("E", "k_bearing")
    assert list(data.prior) == ["E", "k_bearing"]
    assert data.damage is None
    assert data.timestamps.dtype == np.dtype("datetime64[h]")
    assert str(data.timestamps[0]) == "2025-01-01T00"
    assert str(data.timestamps[-1]) == "2025-12-31T23"
    frame = data.frame
    assert frame is data.readings
    assert list(frame.columns) == ["temperature", "f1", "f2", "f3", "f4"]
    pd = pytest.importorskip("pandas")
    assert isinstance(frame.index, pd.DatetimeIndex)
    assert frame.index.freq == pd.Timedelta(hours=1)
    assert frame.index[0] == pd.Timestamp("2025-01-01")
    np.testing.assert_array_equal(frame["temperature"], data.X_obs[:, 0])
    np.testing.assert_array_equal(frame[list(data.response_names)], data.y_obs)
    for text in ("30 m", "frost", "Latin hypercube"):
        assert text in data.DESCR


def test_missing_readings_in_blocks(year):
    data = year
    missing = np.isnan(data.y_obs)
    assert missing.sum() == round(0.05 * missing.size)
    assert not np.isnan(data.X_obs).any() and not np.isnan(data.y_obs_true).any()
    whole_rows = missing.all(axis=1)
    assert 0.3 < whole_rows.sum() * 4 / missing.sum() < 0.7  # about half
    assert (missing.any(axis=1) & ~whole_rows).sum() > 0  # single sensors too
    # Outages are blocks: far fewer starts than missing readings.
    starts = np.sum(missing[1:] & ~missing[:-1]) + missing[0].sum()
    assert starts < missing.sum() / 4
    measured = ~missing
    np.testing.assert_array_equal(
        np.isfinite(data.y_obs), measured
    )  # NaN only where missing
    for fraction in (0.0, 0.3):
        other = make_bridge_monitoring(
            500, 5, n_modes=2, missing_fraction=fraction, random_state=1
        )
        assert np.isnan(other.y_obs).sum() == round(fraction * 1000)


def test_temperature_logged_to_a_tenth_with_seasons(year):
    T = year.X_obs[:, 0]
    np.testing.assert_allclose(T * 10.0, np.round(T * 10.0), atol=1e-9)
    assert 8.0 < T.mean() < 12.0
    january, july = T[: 31 * 24], T[181 * 24 : 212 * 24]
    assert july.mean() - january.mean() > 15.0
    assert T.min() < -5.0 and T.max() > 25.0
    below = T < 0.0
    assert 0.02 < below.mean() < 0.4  # frost is a part of the record


def test_reproducible_with_random_state():
    a = make_bridge_monitoring(300, 8, random_state=3)
    b = make_bridge_monitoring(300, 8, random_state=3)
    c = make_bridge_monitoring(300, 8, random_state=4)
    for key in ("X_sim", "theta_sim", "y_sim", "X_obs", "y_obs"):
        np.testing.assert_array_equal(a[key], b[key])
        assert not np.array_equal(a[key], c[key], equal_nan=True)
    g = make_bridge_monitoring(24, 4, random_state=np.random.default_rng(0))
    assert g.y_obs.shape == (24, 4)


def test_reality_stiffens_below_freezing_and_is_the_model_above(year):
    data = year
    below = np.linspace(-15.0, -1.0, 15)[:, None]
    above = np.linspace(5.0, 35.0, 31)[:, None]
    for T, frosty in ((below, True), (above, False)):
        model = data.simulator(T, data.theta_true)
        reality = data.reality(T)
        if frosty:
            assert np.all(reality > model * (1.0 + 1e-3))
        else:
            np.testing.assert_allclose(reality, model, rtol=1e-9)
    # The knee: the frequencies rise much faster below 0 degC than above.
    T = np.array([[-10.0], [0.0], [10.0]])
    f1 = data.reality(T)[:, 0]
    assert (f1[0] - f1[1]) > 5.0 * (f1[1] - f1[2])
    # Without frost stiffening reality is the model everywhere.
    plain = make_bridge_monitoring(
        24, 4, deck_frost_stiffening=0, bearing_frost_stiffening=0, random_state=0
    )
    np.testing.assert_allclose(
        plain.reality(below), plain.simulator(below, plain.theta_true), rtol=1e-12
    )


def test_readings_are_the_reality_plus_noise(year):
    data = year
    np.testing.assert_array_equal(data.y_obs_true, data.reality(data.X_obs))
    f_ref = data.simulator([[20.0]], data.theta_true)[0]
    np.testing.assert_allclose(data.noise_sd, 0.002 * f_ref)
    np.testing.assert_allclose(data.noise_variance, data.noise_sd**2)
    residual = data.y_obs - data.y_obs_true
    sd = np.nanstd(residual, axis=0)
    np.testing.assert_allclose(sd, data.noise_sd, rtol=0.05)
    clean = make_bridge_monitoring(100, 4, noise_sd=0.0, random_state=0)
    measured = ~np.isnan(clean.y_obs)
    np.testing.assert_array_equal(clean.y_obs[measured], clean.y_obs_true[measured])


def test_damage_lowers_the_frequencies_after_its_start():
    data = make_bridge_monitoring(
        2000,
        5,
        damage_size=0.4,
        damage_location=10,
        damage_start="2025-02-01",
        random_state=2,
    )
    damage = data.damage
    start = 31 * 24
    assert damage["start_index"] == start
    assert damage["start"] == np.datetime64("2025-02-01T00")
    assert damage["element"] == 10 and damage["size"] == 0.4
    assert damage["position"] == pytest.approx((15.0, 16.5))
    healthy = data.reality(data.X_obs)
    np.testing.assert_array_equal(data.y_obs_true[:start], healthy[:start])
    after = data.y_obs_true[start:] / healthy[start:]
    assert np.all(after[:, 0] < 1.0 - 1e-3)  # the first mode, at mid-span
    assert np.all(after <= 1.0 + 1e-12)
    np.testing.assert_array_equal(
        data.y_obs_true[start:], damage["reality"](data.X_obs[start:])
    )
    by_index = make_bridge_monitoring(
        2000,
        5,
        damage_size=0.4,
        damage_location=10,
        damage_start=start,
        random_state=2,
    )
    np.testing.assert_array_equal(by_index.y_obs_true, data.y_obs_true)
    # Defaults: a quarter of the span, three quarters into the record.
    default = make_bridge_monitoring(400, 5, damage_size=0.2, random_state=0)
    assert default.damage["element"] == 5 and default.damage["start_index"] == 300


def test_simulator_pickles_and_is_the_finite_element_model(year):
    data = year
    np.testing.assert_array_equal(
        data.y_sim, data.simulator(data.X_sim, data.theta_sim)
    )
    simulator = pickle.loads(pickle.dumps(data.simulator))
    reality = pickle.loads(pickle.dumps(data.reality))
    X, theta = data.X_sim[:7], data.theta_sim[:7]
    np.testing.assert_array_equal(simulator(X, theta), data.simulator(X, theta))
    np.testing.assert_array_equal(reality(X), data.reality(X))
    factor = 1.0 + TEMPERATURE_COEFFICIENT * (X[:, 0] - REFERENCE_TEMPERATURE)
    direct = natural_frequencies(theta[:, 0] * factor * SECOND_MOMENT, theta[:, 1], 4)
    np.testing.assert_array_equal(simulator(X, theta), direct)
    assert isinstance(simulator, BridgeModel) and isinstance(reality, BridgeReality)


def test_prior_covers_theta_true_and_the_design_spans_it(year):
    data = year
    for j, name in enumerate(data.parameter_names):
        distribution = data.prior[name]
        low, high = distribution.support()
        assert low < data.theta_true[j] < high
        assert distribution.pdf(data.theta_true[j]) > 0.0
        np.testing.assert_array_equal(data.theta_bounds[j], [low, high])
        # A Latin hypercube in the prior's quantiles.
        strata = np.floor(distribution.cdf(data.theta_sim[:, j]) * 60)
        np.testing.assert_array_equal(np.sort(strata), np.arange(60))
    T = data.X_obs[:, 0]
    low, high = data.X_bounds[0]
    assert low == pytest.approx(T.min() - 2.0) and high == pytest.approx(T.max() + 2.0)
    assert np.all((data.X_sim >= low) & (data.X_sim <= high))


def test_without_pandas_the_arrays_and_timestamps(monkeypatch):
    monkeypatch.setattr(monitoring, "_pandas", lambda: None)
    data = make_bridge_monitoring(48, 5, random_state=0)
    assert data.frame is None and data.readings is None
    assert data.timestamps.shape == (48,) and data.y_obs.shape == (48, 4)


def test_start_sets_the_season():
    summer = make_bridge_monitoring(24 * 14, 4, start="2025-07-01", random_state=0)
    assert str(summer.timestamps[0]) == "2025-07-01T00"
    assert summer.X_obs.mean() > 15.0


@pytest.mark.parametrize(
    ("kwargs", "argument"),
    [
        ({"n_hours": 0}, "n_hours"),
        ({"n_hours": -5}, "n_hours"),
        ({"n_simulations": 0}, "n_simulations"),
        ({"n_simulations": 2.5}, "n_simulations"),
        ({"n_modes": 0}, "n_modes"),
        ({"n_modes": 5, "n_elements": 4}, "n_modes"),
        ({"n_elements": 1}, "n_elements"),
        ({"start": "yesterday"}, "start"),
        ({"start": "2025-01-01 10:30"}, "start"),
        ({"start": 5}, "start"),
        ({"E_true": -1.0}, "E_true"),
        ({"E_true": 60e9}, "E_true"),
        ({"k_bearing_true": 1e12}, "k_bearing_true"),
        ({"deck_frost_stiffening": -0.1}, "deck_frost_stiffening"),
        ({"bearing_frost_stiffening": np.inf}, "bearing_frost_stiffening"),
        ({"damage_size": 1.0}, "damage_size"),
        ({"damage_size": -0.1}, "damage_size"),
        ({"damage_size": 0.2, "damage_location": 20}, "damage_location"),
        ({"damage_size": 0.2, "damage_location": -1}, "damage_location"),
        ({"damage_size": 0.2, "damage_location": 2.5}, "damage_location"),
        ({"damage_size": 0.2, "damage_start": 8760}, "damage_start"),
        ({"damage_size": 0.2, "damage_start": -1}, "damage_start"),
        ({"damage_size": 0.2, "damage_start": "2024-12-31"}, "damage_start"),
        ({"damage_size": 0.2, "damage_start": "soon"}, "damage_start"),
        ({"noise_sd": -0.01}, "noise_sd"),
        ({"noise_sd": [0.01, 0.02]}, "noise_sd"),
        ({"missing_fraction": 1.0}, "missing_fraction"),
        ({"missing_fraction": -0.1}, "missing_fraction"),
        ({"random_state": "seed"}, "random_state"),
    ],
)
def test_bad_arguments_raise_naming_the_argument(kwargs, argument):
    with pytest.raises(ValueError, match=argument):
        make_bridge_monitoring(**kwargs)


def test_simulator_rejects_bad_input():
    model = BridgeModel()
    with pytest.raises(ValueError, match="X"):
        model(np.ones((3, 2)), [E, 3e9])
    with pytest.raises(ValueError, match="theta"):
        model([[10.0]], [[E, 3e9, 1.0]])
    with pytest.raises(ValueError, match="theta"):
        model([[10.0]], [[-E, 3e9]])
    with pytest.raises(ValueError, match="finite"):
        model([[np.nan]], [[E, 3e9]])
