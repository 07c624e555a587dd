"""Field data checked against their simulations on both sides (issue 35).

Every kind of logger slip warns naming the response, and the package's clean
reference problems (the thesis cantilever and truss, every case of the
validity suite over seeds) stay silent.
"""

import re
import warnings

import numpy as np
import pandas as pd
import pytest

from skmba import ModularBayesCalibrator
from skmba.calibration._field_data import check_simulation_design
from skmba.calibration._response_checks import _input_spread, check_responses
from skmba.datasets import make_bridge_monitoring, make_cantilever, make_truss_bridge
from skmba.exceptions import FieldDataWarning
from skmba.priors._theta import check_prior
from validation.suite import registry

RESPONSES = ("tip_displacement", "energy")
DATA = make_cantilever(40, 20, responses=RESPONSES, random_state=0)


def _field_warnings(y, X=None, data=DATA, names=None):
    """The FieldDataWarning messages of the checks on field data ``y``."""
    X = data.X_obs if X is None else X
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_responses(X, y, data.X_sim, data.theta_sim, data.y_sim, names)
    return [str(w.message) for w in caught if w.category is FieldDataWarning]


def _slipped(kind):
    y = DATA.y_obs.copy()
    if kind == "metres for mm":
        y[:, 0] /= 1000.0
    elif kind == "x0.1":
        y[:, 0] *= 0.1
    elif kind == "x1000":
        y[:, 0] *= 1000.0
    elif kind == "sign":
        y[:, 1] *= -1.0
    elif kind == "stuck":
        y[:, 0] = y[3, 0]
    elif kind == "-9999":
        y[[2, 7], 1] = -9999.0
    elif kind == "slip":
        y[5, 0] = 80.0  # one reading in other units (tip range 0.3-5 mm)
    return y


@pytest.mark.parametrize(
    ("kind", "column", "expected"),
    [
        ("metres for mm", 0, r"0\.000\d+ times the size .* other units"),
        ("x0.1", 0, r"0\.0\d+ times the size .* other units"),
        ("x1000", 0, r"\d{3} times the size .* other units"),
        ("sign", 1, r"opposite sign .* sign convention"),
        ("stuck", 0, r"are all .* stuck at one value"),
        ("-9999", 1, r"2 reading\(s\) .*row: value 2: -9999, 7: -9999.*no reading"),
        ("slip", 0, r"1 reading\(s\) .*5: 80.*slips in single readings"),
    ],
)
def test_each_slip_warns_naming_the_response(kind, column, expected):
    messages = _field_warnings(_slipped(kind), names=list(RESPONSES))
    assert len(messages) == 1, messages
    assert f"response {RESPONSES[column]!r} (column {column} of y)" in messages[0]
    assert re.search(expected, messages[0]), messages[0]


def test_a_slip_is_named_by_the_row_label_of_a_table():
    y = pd.DataFrame(_slipped("-9999"), columns=list(RESPONSES))
    y.index = pd.date_range("2026-01-01", periods=len(y), freq="h")
    X = pd.DataFrame(DATA.X_obs, columns=["F"], index=y.index)
    with pytest.warns(FieldDataWarning, match="2026-01-01T02:00") as record:
        ModularBayesCalibrator(
            prior=DATA.prior,
            discrepancy_uncertainty="plug-in",
            n_restarts_optimizer=0,
            n_samples=200,
            random_state=0,
        ).fit(
            X,
            y,
            X_sim=pd.DataFrame(DATA.X_sim, columns=["F"]),
            theta_sim=DATA.theta_sim,
            y_sim=pd.DataFrame(DATA.y_sim, columns=list(RESPONSES)),
        )
    assert [w.filename for w in record if w.category is FieldDataWarning] == [__file__]


def test_a_slip_below_the_simulated_range_of_a_two_signed_response():
    """Strains of both signs: a gauge read in strain, not microstrain, hardly
    varies next to its simulations."""
    rng = np.random.default_rng(0)
    X_sim = rng.uniform(-10, 30, size=(60, 1))
    theta_sim = rng.uniform(0.8, 1.2, size=(60, 1))
    y_sim = 40.0 * theta_sim * X_sim + rng.normal(0, 5, size=(60, 1))  # microstrain
    X = np.linspace(-5, 25, 30)[:, None]
    y = 38.0 * X + rng.normal(0, 5, size=(30, 1))
    data = type("D", (), {"X_sim": X_sim, "theta_sim": theta_sim, "y_sim": y_sim})
    assert _field_warnings(y, X, data) == []
    (message,) = _field_warnings(y * 1e-6, X, data)
    assert "spread" in message and "units" in message


CLEAN = [("cantilever, five responses", lambda seed: _cantilever_case(seed))] + [
    (f"validity {name}", name) for name in sorted(registry())
]


def _cantilever_case(seed):
    data = make_cantilever(
        70,
        25,
        responses=(
            "tip_displacement",
            "mid_displacement",
            "quarter_displacement",
            "tip_rotation",
            "energy",
        ),
        random_state=seed,
    )
    return data.X_obs, data.y_obs, data.X_sim, data.theta_sim, data.y_sim, data.prior


@pytest.mark.parametrize(("label", "case"), CLEAN, ids=[c[0] for c in CLEAN])
def test_clean_reference_problems_stay_silent(label, case):
    """The checks on the package's reference problems and on every case of
    the validity suite, 10 seeds each: no FieldDataWarning."""
    for seed in range(10):
        if callable(case):
            X, y, X_sim, theta_sim, y_sim, prior = case(seed)
        else:
            X, y, X_sim, theta_sim, y_sim, prior, *_ = registry()[case].build(seed)
        y = np.asarray(y, dtype=float).reshape(len(X), -1)
        sims = type("S", (), {"X": X_sim, "theta": theta_sim, "y": y_sim})
        with warnings.catch_warnings():
            warnings.simplefilter("error", FieldDataWarning)
            check_responses(X, y, X_sim, theta_sim, np.reshape(y_sim, (len(X_sim), -1)))
            check_simulation_design(X, check_prior(prior), sims)


BRIDGE_WINDOWS = {"a week": slice(0, 168), "January": slice(0, 744), "the year": None}


@pytest.mark.parametrize("window", sorted(BRIDGE_WINDOWS))
def test_bridge_frequencies_that_temperature_moves_little_stay_silent(window):
    """The bridge year's prior moves its frequencies 10-50 times as much as
    a year's temperatures do: clean readings spread 0.02-0.3 times as much
    as the runs over the same temperatures, and must not be taken for a
    stuck sensor (seeds 0-4)."""
    rows = BRIDGE_WINDOWS[window] or slice(None)
    for seed in range(5):
        year = make_bridge_monitoring(random_state=seed)
        X, y = year.X_obs[rows], year.y_obs[rows]
        assert _field_warnings(y, X, year) == [], (seed, window)


def test_a_frequency_locked_at_one_mode_estimate_is_named_on_the_bridge():
    """A mode tracker that locks on one value (readings within 1 mHz of it,
    a year long) where the year's temperatures move the model's f3 by about
    0.6 Hz (interquartile ranges): the spread check names f3, and only f3."""
    year = make_bridge_monitoring(random_state=0)
    y = year.y_obs.copy()
    jitter = np.random.default_rng(1).uniform(-1e-3, 1e-3, len(y))
    y[:, 2] = np.where(np.isfinite(y[:, 2]), np.nanmedian(y[:, 2]) + jitter, np.nan)
    names = list(year.response_names)
    (message,) = _field_warnings(y, year.X_obs, year, names)
    assert "response 'f3' (column 2 of y)" in message
    assert re.search(r"spread 0\.0\d+ times as much .* stuck", message), message


def test_the_plane_needs_two_runs_per_coefficient():
    """One design variable and five parameters: a plane of 7 coefficients,
    whose slopes are noise on 13 runs (no spread check) and known on 14."""
    rng = np.random.default_rng(0)
    X, theta = rng.uniform(size=(14, 1)), rng.uniform(size=(14, 5))
    y = 2.0 * X[:, 0] + theta.sum(axis=1)
    assert _input_spread(X, X[:13], theta[:13], y[:13]) is None
    moved = _input_spread(X, X, theta, y)
    assert moved == pytest.approx(2.0 * np.subtract(*np.percentile(X, [75, 25])))


def test_the_truss_gauges_whose_reality_reverses_the_model_are_named():
    """The truss' top-heated reality strains some gauges with the opposite
    sign of the uniformly heated model at the true stiffness (its designed
    discrepancy): exactly those gauges get the sign warning, the others
    none."""
    data = make_truss_bridge(60, 20, random_state=0)
    model = data.simulator(data.X_obs, np.tile(data.theta_true, (len(data.X_obs), 1)))
    reversed_ = np.mean(np.sign(model) != np.sign(data.y_obs_true), axis=0) > 0.5
    assert 0 < reversed_.sum() < len(reversed_)
    names = list(data.response_names)
    messages = _field_warnings(data.y_obs, data=data, names=names)
    warned = {name for name in names if any(f"{name!r}" in m for m in messages)}
    assert warned == {n for n, r in zip(names, reversed_, strict=True) if r}
    assert all("opposite sign" in m for m in messages)


def _two_tables():
    X = pd.DataFrame(DATA.X_obs, columns=["F"])
    y = pd.DataFrame(DATA.y_obs, columns=list(RESPONSES))
    return X, y


@pytest.mark.parametrize("how", ["reversed", "shifted"])
def test_tables_with_different_indexes_are_refused(how):
    X, y = _two_tables()
    if how == "reversed":  # one table sorted the other way
        y = y.iloc[::-1]
    else:  # the logger's table starts one hour later
        y = y.set_axis(y.index + 1)
    expected = "another order" if how == "reversed" else "different row labels"
    sims = dict(X_sim=DATA.X_sim, theta_sim=DATA.theta_sim, y_sim=DATA.y_sim)
    cal = ModularBayesCalibrator(prior=DATA.prior)
    with pytest.raises(
        ValueError, match=rf"X and y have .*{expected}.*loc\[X\.index\]"
    ):
        cal.fit(X, y, **sims)


def test_integer_labels_are_labels():
    """Simulation tables with integer column labels in another order are
    matched by label, as string labels are (they were taken by position)."""
    X = pd.DataFrame(DATA.X_obs)  # label 0
    y = pd.DataFrame(DATA.y_obs)  # labels 0, 1
    y_sim = pd.DataFrame(DATA.y_sim)[[1, 0]]  # the simulator's order
    params = dict(
        prior=DATA.prior,
        discrepancy_uncertainty="plug-in",
        n_restarts_optimizer=0,
        n_samples=200,
        random_state=0,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        by_label = ModularBayesCalibrator(**params).fit(
            X, y, X_sim=pd.DataFrame(DATA.X_sim), theta_sim=DATA.theta_sim, y_sim=y_sim
        )
        arrays = ModularBayesCalibrator(**params).fit(
            DATA.X_obs,
            DATA.y_obs,
            X_sim=DATA.X_sim,
            theta_sim=DATA.theta_sim,
            y_sim=DATA.y_sim,
        )
    np.testing.assert_array_equal(by_label.y_sim_, arrays.y_sim_)
    np.testing.assert_array_equal(by_label.theta_mean_, arrays.theta_mean_)
    with pytest.raises(ValueError, match="do not match"):
        ModularBayesCalibrator(**params).fit(
            X,
            y,
            X_sim=pd.DataFrame(DATA.X_sim, columns=[5]),
            theta_sim=DATA.theta_sim,
            y_sim=y_sim,
        )


def test_a_simulator_returning_a_table_is_matched_by_response_name():
    model = DATA.simulator

    def simulator(X, theta):  # the FE program writes its columns its own way
        return pd.DataFrame(model(X, theta), columns=list(RESPONSES))[
            ["energy", "tip_displacement"]
        ]

    params = dict(
        prior=DATA.prior,
        n_simulations=30,
        discrepancy_uncertainty="plug-in",
        n_restarts_optimizer=0,
        n_samples=200,
        random_state=0,
    )
    y = pd.DataFrame(DATA.y_obs, columns=list(RESPONSES))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = ModularBayesCalibrator(simulator, **params).fit(DATA.X_obs, y)
        plain = ModularBayesCalibrator(model, **params).fit(DATA.X_obs, DATA.y_obs)
    np.testing.assert_array_equal(cal.y_sim_, plain.y_sim_)


def test_a_large_field_data_set_warns_before_the_fit_starts():
    """2000 readings of 2 responses: the estimate and the remedy come before
    anything runs (here the fit then stops at a bad simulation table)."""
    X = np.linspace(1e3, 10e3, 2000)[:, None]
    y = np.column_stack([X[:, 0] * 1e-3, X[:, 0] ** 2 * 1e-4])
    cal = ModularBayesCalibrator(prior=DATA.prior)
    with pytest.warns(
        UserWarning, match=r"2000 field readings hold 4000 measured"
    ) as w:
        with pytest.raises(ValueError, match="same number of rows"):
            cal.fit(
                X, y, X_sim=DATA.X_sim, theta_sim=DATA.theta_sim[:5], y_sim=DATA.y_sim
            )
    (message,) = [str(r.message) for r in w if "measured values" in str(r.message)]
    assert re.search(r"expect of the order of [\d.]+ h and [\d.]+ GiB", message)
    assert "Average close inputs with bin_width" in message
    # Readings repeated at the same inputs count once: 2000 readings at 100
    # loads are 200 values, which warn of nothing.
    X_repeated = np.repeat(X[::20], 20, axis=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        with pytest.raises(ValueError, match="same number of rows"):
            cal.fit(
                X_repeated,
                y,
                X_sim=DATA.X_sim,
                theta_sim=DATA.theta_sim[:5],
                y_sim=DATA.y_sim,
            )
    # 500 values or fewer: no such warning
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        with pytest.raises(ValueError, match="same number of rows"):
            cal.fit(
                X[:250],
                y[:250],
                X_sim=DATA.X_sim,
                theta_sim=DATA.theta_sim[:5],
                y_sim=DATA.y_sim,
            )


def test_score_leaves_out_a_response_without_readings_in_the_rows():
    """A response with no reading among the held-out rows was scikit-learn's
    'Found array with 0 sample(s)'."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = ModularBayesCalibrator(
            prior=DATA.prior,
            discrepancy_uncertainty="plug-in",
            n_restarts_optimizer=0,
            n_samples=200,
            random_state=0,
        ).fit(
            DATA.X_obs,
            DATA.y_obs,
            X_sim=DATA.X_sim,
            theta_sim=DATA.theta_sim,
            y_sim=DATA.y_sim,
        )
    y = DATA.y_obs.copy()
    y[:, 1] = np.nan  # the energy gauge was out
    from sklearn.metrics import r2_score

    expected = r2_score(y[:, 0], cal.predict(DATA.X_obs)[:, 0])
    assert cal.score(DATA.X_obs, y) == pytest.approx(expected, rel=1e-12)
    y[1:, 0] = np.nan
    with pytest.raises(ValueError, match="fewer than two readings of every response"):
        cal.score(DATA.X_obs, y)


def test_the_designer_leaves_out_failed_runs_as_the_calibrator_does():
    from sklearn.base import clone

    from skmba import PreposteriorDesigner

    X = np.hstack([DATA.X_sim, DATA.theta_sim])
    y = DATA.y_sim.copy()
    y[[3, 11], 0] = np.nan  # two runs that did not converge
    designer = PreposteriorDesigner(
        DATA.prior,
        calibrator=ModularBayesCalibrator(n_restarts_optimizer=0),
        n_design=5,
        n_mc=2,
        random_state=0,
    )
    with pytest.warns(UserWarning, match=r"2 of 40 simulation runs .* rows \[3, 11\]"):
        designer.fit(X, y)
    keep = np.setdiff1d(np.arange(40), [3, 11])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        same = clone(designer).fit(X[keep], y[keep])
    np.testing.assert_array_equal(designer.scores_, same.scores_)
    with pytest.raises(ValueError, match="every run"):
        designer.fit(X, np.full_like(y, np.nan))
