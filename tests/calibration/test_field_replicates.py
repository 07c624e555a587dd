"""Readings repeated at one input enter as their mean and count: the
likelihoods of modules 2 and 3 on the means equal those on the readings (the
identity of Binois, Gramacy & Ludkovski 2018), and the grouping, the bins
and the batches of ``partial_fit`` are what they say."""

import numpy as np
import pytest

from skmba.calibration._field_replicates import (
    FieldReadings,
    ReplicateTerms,
    appended_readings,
    check_bin_width,
)
from skmba.calibration._module1_emulator import Emulator
from skmba.calibration._module2_plug_in import DiscrepancyFit
from skmba.calibration._module3_likelihood import GlobalModel
from skmba.kernels import Gauss
from tests.conftest import discrepancy

# Readings of the six inputs of the conftest problem: input i is read
# COUNTS[i] times, in a shuffled order.
COUNTS = np.array([3, 1, 4, 2, 1, 5])


def _readings(X_e, Y_e, noise, rng, gaps=False):
    """The readings: each row of ``X_e`` COUNTS times, ``Y_e`` plus noise."""
    index = rng.permutation(np.repeat(np.arange(len(X_e)), COUNTS))
    Y = Y_e[index] + rng.normal(size=(len(index), 2)) * np.sqrt(noise)
    if gaps:  # one response of some readings not taken; input 4's only one
        Y[[0, 3, 7], [1, 0, 0]] = np.nan
        Y[np.flatnonzero(index == 4), 0] = np.nan
    return X_e[index], Y


def test_means_counts_and_sums_of_squares_known_answer():
    X = np.array([[2.0], [1.0], [2.0], [1.0], [3.0]])
    Y = np.array([[1.0, 5.0], [4.0, np.nan], [3.0, 7.0], [6.0, 8.0], [0.5, 1.0]])
    r = FieldReadings.from_readings(X, Y)
    # groups in the order of their first reading: 2, 1, 3
    np.testing.assert_array_equal(r.X.ravel(), [2.0, 1.0, 3.0])
    np.testing.assert_array_equal(r.Y, [[2.0, 6.0], [5.0, 8.0], [0.5, 1.0]])
    np.testing.assert_array_equal(r.counts, [[2, 2], [2, 1], [1, 1]])
    np.testing.assert_array_equal(r.sum_squares, [[2.0, 2.0], [2.0, 0.0], [0, 0]])
    assert r.n_readings == 5 and r.repeated


def test_distinct_inputs_are_the_readings_bit_for_bit():
    rng = np.random.default_rng(1)
    X, Y = rng.normal(size=(9, 2)), rng.normal(size=(9, 3))
    Y[2, 1] = np.nan
    r = FieldReadings.from_readings(X, Y)
    assert np.array_equal(r.X, X) and np.array_equal(r.Y, Y, equal_nan=True)
    assert not r.repeated and r.terms(np.ones(3)) is None


def test_bins_average_at_the_mean_input():
    X = np.array([[0.12, 5.0], [0.31, 5.2], [0.08, 5.4], [0.3, 6.1]])
    Y = np.array([[1.0], [2.0], [3.0], [4.0]])
    r = FieldReadings.from_readings(X, Y, bin_width=np.array([0.25, 1.0]))
    # bins (0, 5): readings 0, 2; (1, 5): reading 1; (1, 6): reading 3
    np.testing.assert_allclose(r.X, [[0.1, 5.2], [0.31, 5.2], [0.3, 6.1]])
    np.testing.assert_array_equal(r.Y.ravel(), [2.0, 2.0, 4.0])
    np.testing.assert_array_equal(r.counts.ravel(), [2, 1, 1])


def test_a_trend_across_a_bin_is_not_counted_as_noise():
    # Readings on a line y = 2 x + 1 plus noise of known variance, in bins
    # of width 1: the sum of squares is the noise's alone, with a - 2
    # degrees of freedom, and the mean sits on the line at the bin's centre.
    rng = np.random.default_rng(6)
    x = rng.uniform(0.0, 3.0, size=3000)
    X = x[:, None]
    y = 2.0 * x + 1.0 + rng.normal(scale=0.1, size=x.size)
    y[::7] = np.nan  # gaps: that response's own readings, own mean input
    r = FieldReadings.from_readings(X, y[:, None], bin_width=1.0)
    np.testing.assert_array_equal(r.degrees[:, 0], r.counts[:, 0] - 2)
    variance = r.sum_squares[:, 0] / r.degrees[:, 0]
    np.testing.assert_allclose(variance, 0.01, rtol=0.15)  # chi2 of ~850 dof
    np.testing.assert_allclose(r.Y[:, 0], 2.0 * r.X[:, 0] + 1.0, atol=0.02)
    # Around the bin means alone, the slope across a bin would add about
    # 2^2 / 12 = 0.33 to the noise variance of 0.01.
    measured = np.isfinite(y)
    bins = np.floor(x[measured])
    around_means = sum(np.var(y[measured][bins == b]) for b in np.unique(bins)) / 3
    assert around_means > 30 * 0.01


def test_log_factor_is_the_density_of_the_deviations_from_the_mean():
    # prod_j N(y_j | f, lam) / N(ybar | f, lam / a) does not depend on f.
    from scipy import stats

    y, lam = np.array([1.0, 1.7, 0.4]), 0.3
    ss = np.array([[np.sum((y - y.mean()) ** 2)]])
    terms = ReplicateTerms(np.array([[3.0]]), ss, np.array([[2.0]]))
    for f in (-1.0, 0.5, 2.0):
        expected = stats.norm.logpdf(y, f, np.sqrt(lam)).sum() - stats.norm.logpdf(
            y.mean(), f, np.sqrt(lam / 3)
        )
        assert terms.log_factor(np.array([lam])) == pytest.approx(expected, rel=1e-13)
    # and its gradient in log lam against finite differences
    _, grad = terms.log_factor(np.array([lam]), eval_gradient=True)
    h = 1e-6
    fd = (
        terms.log_factor(np.array([lam * np.exp(h)]))
        - terms.log_factor(np.array([lam * np.exp(-h)]))
    ) / (2 * h)
    assert grad[0] == pytest.approx(fd, rel=1e-7)


@pytest.mark.parametrize("gaps", [False, True])
@pytest.mark.parametrize("theta", [-0.6, 0.3])
def test_global_model_on_means_equals_the_dense_likelihood_of_the_readings(
    problem, gaps, theta
):
    gp, _gm, X_m, Y_m, X_e, Y_e, sigma2_d, noise = problem
    # The emulator's nugget (1e-6 here) is on the simulations only, so the
    # identity holds whatever its size: the model at a field input is one
    # value, whether one reading or many were taken there.
    assert gp.nugget_ == 1e-6
    emulator = Emulator(gp, X_m, Y_m, "linear")
    X, Y = _readings(X_e, Y_e, noise, np.random.default_rng(2), gaps)
    readings = FieldReadings.from_readings(X, Y)
    disc = discrepancy(sigma2_d, noise)
    dense = GlobalModel(emulator, X, Y, disc)
    means = GlobalModel(
        emulator, readings.X, readings.Y, disc, readings.terms(np.ones(2))
    )
    t = np.array([theta])
    expected = dense.log_likelihood(t)
    assert means.log_likelihood(t) == pytest.approx(expected, rel=1e-10, abs=1e-10)
    # the stacked path (module 3's sampler and the mixture) as well
    assert means.log_likelihoods(t[None, :])[0] == pytest.approx(expected, rel=1e-10)


@pytest.mark.parametrize("gaps", [False, True])
def test_module_2_on_means_equals_the_readings_with_gradient(problem, gaps):
    _gp, _gm, _X_m, _Y_m, X_e, Y_e, _sigma2_d, noise = problem
    X, Y = _readings(X_e, Y_e, noise, np.random.default_rng(3), gaps)
    readings = FieldReadings.from_readings(X, Y)
    rng = np.random.default_rng(4)
    # A fixed covariance of the distinct inputs, and the same of the readings.
    A = rng.normal(size=(12, 12))
    V_u = 0.05 * A @ A.T
    group = np.array([np.flatnonzero((readings.X == x).all(1))[0] for x in X])
    vec = np.concatenate([group, group + len(readings.X)])
    V_r = V_u[np.ix_(vec, vec)]

    def fit(x, y, V, terms):
        H = np.ones((len(x), 1))
        return DiscrepancyFit(
            Gauss(roughness=1.0), x, y, H, V, restricted=True, unit_scale=True,
            replicates=terms,
        )  # fmt: skip

    dense = fit(X, Y, V_r, None)
    means = fit(readings.X, readings.Y, V_u, readings.terms(np.ones(2)))
    for _ in range(3):
        params = dense.start() + rng.normal(scale=0.3, size=dense.start().size)
        ll_d, g_d = dense.evaluate(params)
        ll_m, g_m = means.evaluate(params)
        assert ll_m == pytest.approx(ll_d, rel=1e-10)
        np.testing.assert_allclose(g_m, g_d, rtol=1e-7, atol=1e-9)


def test_module_2_gradient_with_replicates_matches_finite_differences(problem):
    _gp, _gm, _X_m, _Y_m, X_e, Y_e, _sigma2_d, noise = problem
    X, Y = _readings(X_e, Y_e, noise, np.random.default_rng(5))
    r = FieldReadings.from_readings(X, Y)
    fit = DiscrepancyFit(
        Gauss(roughness=1.0), r.X, r.Y, np.ones((6, 1)), np.zeros((12, 12)),
        replicates=r.terms(np.ones(2)),
    )  # fmt: skip
    p = fit.start()
    _, grad = fit.evaluate(p)
    h = 1e-6
    for i in range(p.size):
        step = np.zeros_like(p)
        step[i] = h
        fd = (
            fit.evaluate(p + step, eval_gradient=False)
            - fit.evaluate(p - step, eval_gradient=False)
        ) / (2 * h)
        assert grad[i] == pytest.approx(fd, rel=1e-5, abs=1e-6)


def test_bin_width_is_checked():
    assert check_bin_width(None, 2) is None
    np.testing.assert_array_equal(check_bin_width(0.5, 2), [0.5, 0.5])
    with pytest.raises(ValueError, match="bin_width must be positive"):
        check_bin_width(-1.0, 1)
    with pytest.raises(ValueError, match="one per design variable"):
        check_bin_width([0.5, 1.0, 2.0], 2)
    with pytest.raises(TypeError, match="bin_width must be None"):
        check_bin_width("wide", 1)


def test_batches_append_by_column_name():
    pd = pytest.importorskip("pandas")
    first = (
        pd.DataFrame({"T": [1.0, 2.0]}, index=[0, 1]),
        pd.DataFrame({"f1": [1.0, 2.0], "f2": [3.0, 4.0]}, index=[0, 1]),
    )
    batch_y = pd.DataFrame({"f2": [6.0], "f1": [5.0]}, index=[2])
    X, y = appended_readings(first, pd.DataFrame({"T": [3.0]}, index=[2]), batch_y)
    assert list(y.columns) == ["f1", "f2"]
    np.testing.assert_array_equal(y.to_numpy()[-1], [5.0, 6.0])
    assert list(X.index) == [0, 1, 2]
    with pytest.raises(ValueError, match="pass the same columns in every batch"):
        appended_readings(first, first[0], pd.DataFrame({"f3": [1.0, 1.0]}))
    with pytest.raises(ValueError, match="not a table"):
        appended_readings(first, np.ones((1, 1)), np.ones((1, 2)))
    with pytest.raises(ValueError, match="pass the same columns"):
        appended_readings((np.ones((2, 1)), np.ones((2, 2))), [[1.0]], [[1.0]])
