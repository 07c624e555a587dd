"""Module 3 over module-2 draws: the mixture equals its components."""

import numpy as np
import pytest
from scipy import special

from skmba._core.linalg import FactorizationError, observed_block
from skmba.calibration._module2_posterior import (
    DiscrepancyComponent,
    HyperposteriorDraws,
)
from skmba.calibration._module3_likelihood import GlobalModel
from skmba.calibration._module3_mixture import ModelMixture
from skmba.calibration._module4_prediction import conditional_moments
from skmba.kernels import Gauss
from tests.conftest import mixture_draws as _draws


@pytest.mark.parametrize("theta", [-0.7, 0.1, 0.9])
@pytest.mark.parametrize("data", ["problem", "gapped_problem"])
def test_stacked_equals_each_component(request, theta, data):
    gm = request.getfixturevalue(data)[1]
    draws = _draws()
    mix = ModelMixture(gm, draws)
    t = np.array([theta])
    each = np.array(
        [gm.with_discrepancy(c).log_likelihood(t) for c in draws.components]
    )
    np.testing.assert_allclose(
        mix.component_log_likelihoods(t), draws.log_weights + each, rtol=1e-10
    )
    assert mix.log_likelihood(t) == pytest.approx(
        special.logsumexp(draws.log_weights + each), rel=1e-12
    )
    # Several theta in one stack: the values of each theta on its own.
    thetas = np.array([[-0.7], [0.1], [0.9]])
    np.testing.assert_allclose(
        mix.batch_component_log_likelihoods(thetas),
        [mix.component_log_likelihoods(u) for u in thetas],
        rtol=1e-12,
    )
    np.testing.assert_allclose(
        mix.log_likelihoods(thetas),
        [mix.log_likelihood(u) for u in thetas],
        rtol=1e-12,
    )


@pytest.mark.parametrize("data", ["problem", "gapped_problem"])
def test_a_draw_s_fixed_part_is_the_dense_sum_to_the_bit(request, data):
    # sigma2_d ⊗ R_d with the noise added on its diagonal, at the measured
    # entries: the dense formula's sum, entry for entry.
    gm = request.getfixturevalue(data)[1]
    for c in _draws().components:
        dense = np.kron(c.sigma2, c.kernel_(gm.X_e)) + np.diag(np.repeat(c.noise, gm.n))
        np.testing.assert_array_equal(
            gm.with_discrepancy(c).S_fixed, observed_block(dense, gm.observed)
        )


def test_models_built_beforehand_give_the_same_mixture(problem):
    # The converged integral hands over the global models it built while
    # evaluating the draws: the mixture holds those very models, with the
    # values of a mixture that builds its own.
    gm = problem[1]
    draws = _draws()
    models = [gm.with_discrepancy(c) for c in draws.components]
    given = ModelMixture(gm, draws, models)
    assert all(a is b for a, b in zip(given.models, models, strict=True))
    thetas = np.array([[-0.7], [0.1], [0.9]])
    np.testing.assert_array_equal(
        given.batch_component_log_likelihoods(thetas),
        ModelMixture(gm, draws).batch_component_log_likelihoods(thetas),
    )
    with pytest.raises(ValueError, match="models has 3 entries for 4 module-2 draws"):
        ModelMixture(gm, draws, models[:3])


@pytest.mark.parametrize("data", ["problem", "gapped_problem"])
def test_a_draw_that_cannot_be_factored_weighs_nothing(request, data):
    # A Schur complement that is not positive definite fails the stacked
    # factorisation; the draws are then factored one by one and that draw
    # gets -inf, the others their own values.
    gm = request.getfixturevalue(data)[1]
    draws = _draws()
    mix = ModelMixture(gm, draws)
    t = np.array([0.1])
    expected = mix.component_log_likelihoods(t)
    broken = ModelMixture(gm, draws)
    broken.models[2].S_fixed = -np.eye(len(broken.models[2].S_fixed))
    values = broken.component_log_likelihoods(t)
    assert values[2] == -np.inf
    keep = np.arange(4) != 2
    np.testing.assert_allclose(values[keep], expected[keep], rtol=1e-12)
    # No draw can be factored: the error says why.
    for model in broken.models:
        model.S_fixed = -np.eye(len(model.S_fixed))
    broken._S_fixed = None
    with pytest.raises(FactorizationError, match="not positive definite"):
        broken.component_log_likelihoods(t)


@pytest.mark.parametrize("data", ["problem", "gapped_problem"])
def test_a_draw_with_a_rank_deficient_regression_weighs_nothing(request, data):
    # A draw of the discrepancy's size 1e30 times the others' (a far draw
    # of the proposal's prior share) makes the whitened regression rank
    # deficient with it alone: that draw gets -inf, the others (in the
    # same stack, at every theta) their own values, as the dense formula
    # gives them. Before, the whole stack raised and every draw got -inf.
    gm = request.getfixturevalue(data)[1]
    draws = _draws()
    thetas = np.array([[-0.7], [0.1], [0.9]])
    expected = ModelMixture(gm, draws).batch_component_log_likelihoods(thetas)
    broken = ModelMixture(gm, draws)
    broken.models[1].S_fixed = 1e30 * broken.models[1].S_fixed
    with pytest.raises(FactorizationError, match="rank"):
        broken.models[1].log_likelihood(thetas[1])
    values = broken.batch_component_log_likelihoods(thetas)
    assert np.all(values[:, 1] == -np.inf)
    keep = np.arange(4) != 1
    np.testing.assert_allclose(values[:, keep], expected[:, keep], rtol=1e-12)
    # Rank deficient with every draw: the error, as for one model.
    for model in broken.models:
        model.S_fixed = 1e30 * model.S_fixed
    broken._S_fixed = None
    with pytest.raises(FactorizationError, match="rank"):
        broken.batch_component_log_likelihoods(thetas)


@pytest.mark.parametrize("data", ["problem", "gapped_problem"])
def test_one_draw_is_the_plug_in_model(request, dense_global, data):
    problem = request.getfixturevalue(data)
    gm = problem[1]
    comp = DiscrepancyComponent(gm.kernel_d, gm.sigma2_d, gm.noise, "constant")
    one = HyperposteriorDraws(None, [comp], np.zeros(1), None, gm.noise, 1.0)
    mix = ModelMixture(gm, one)
    for theta in (-0.5, 0.4):
        assert mix.log_likelihood(np.array([theta])) == pytest.approx(
            dense_global(problem, theta), rel=1e-8
        )


def test_spread_evaluation_is_the_batch_one_for_any_n_jobs(problem):
    from skmba.calibration._module3_mixture import TASK_THETAS

    mix = ModelMixture(problem[1], _draws(K=5, seed=2))
    thetas = np.linspace(-0.9, 0.9, 2 * TASK_THETAS + 7)[:, None]  # 3 tasks
    serial = mix.spread_component_log_likelihoods(thetas)
    assert serial.shape == (len(thetas), 5)
    np.testing.assert_allclose(
        serial, mix.batch_component_log_likelihoods(thetas), rtol=1e-12
    )
    np.testing.assert_array_equal(
        mix.spread_component_log_likelihoods(thetas, n_jobs=2), serial
    )


def test_a_stack_s_chunks_on_two_threads_give_the_same_bits(problem, monkeypatch):
    # 1,500 thetas of 4 draws are several 1 MiB chunks; with a budget of two
    # threads they are factored on two, each on its own: the same bits,
    # a draw that cannot be factored included.
    from skmba._core import threads

    mix = ModelMixture(problem[1], _draws())
    mix.models[3].S_fixed = -np.eye(len(mix.models[3].S_fixed))
    thetas = np.linspace(-0.9, 0.9, 1500)[:, None]
    labels = np.arange(1500) % 3
    with threads.blas_threads(10, n_jobs=10_000):  # a budget of one thread
        assert threads.stack_threads() == 1
        serial = mix.batch_component_log_likelihoods(thetas)
        serial_labelled = mix.labelled_log_likelihoods(thetas, labels)
    assert np.all(serial[:, 3] == -np.inf) and np.isfinite(serial[:, :3]).all()
    monkeypatch.setattr(threads, "thread_budget", lambda n_jobs=None: 2)
    ran, spread = [], threads.stack_map

    def counted(func, items):
        items = list(items)
        ran.append(len(items))
        return spread(func, items)

    monkeypatch.setattr("skmba.calibration._module3_mixture.stack_map", counted)
    with threads.blas_threads(10):
        np.testing.assert_array_equal(
            mix.batch_component_log_likelihoods(thetas), serial
        )
        np.testing.assert_array_equal(
            mix.labelled_log_likelihoods(thetas, labels), serial_labelled
        )
    assert ran[0] >= 2


def test_draw_weights_and_effective_draws(problem):
    gm = problem[1]
    mix = ModelMixture(gm, _draws(K=8, seed=1))
    t = np.array([0.2])
    w = mix.draw_weights(t)
    assert w.sum() == pytest.approx(1.0) and np.all(w >= 0)
    # Known answers: eight copies of one draw, equally weighted, are eight
    # effective draws; with weights 1 and 3 of two copies, (1+3)^2/(1+9) = 1.6.
    one = _draws(K=1, seed=1)
    same = HyperposteriorDraws(
        None, one.components * 8, np.full(8, -np.log(8.0)), None, one.noise_mean, 8.0
    )
    assert ModelMixture(gm, same).effective_draws(t) == pytest.approx(8.0, rel=1e-12)
    pair = HyperposteriorDraws(
        None, one.components * 2, np.log([0.25, 0.75]), None, one.noise_mean, 2.0
    )
    assert ModelMixture(gm, pair).effective_draws(t) == pytest.approx(1.6, rel=1e-12)
    # A component's conditional moments are those of its own global model.
    X = np.array([[0.3], [-0.2]])
    m1 = conditional_moments(mix.models[3], t, X, "reality")
    m2 = conditional_moments(
        GlobalModel(gm.emulator, gm.X_e, gm.Y_e, _as_fit(mix.models[3])),
        t,
        X,
        "reality",
    )
    np.testing.assert_allclose(m1[0], m2[0], rtol=1e-10)
    np.testing.assert_allclose(m1[1], m2[1], rtol=1e-10)


def _as_fit(model):
    return DiscrepancyComponent(model.kernel_d, model.sigma2_d, model.noise, "constant")


def test_copies_have_their_own_caches(problem):
    import copy

    mix = ModelMixture(problem[1], _draws())
    other = copy.copy(mix)
    assert all(a is not b for a, b in zip(mix.models, other.models, strict=True))
    t = np.array([0.1])
    assert other.log_likelihood(t) == mix.log_likelihood(t)


def _with_an_idle_draw():
    """Six draws and a seventh of absurd noise, which carries no weight
    anywhere near the data."""
    draws = _draws(K=6, seed=3)
    idle = DiscrepancyComponent(
        Gauss(roughness=1.0), 0.1 * np.eye(2), 1e3 * np.ones(2), "constant"
    )
    return HyperposteriorDraws(
        None,
        [*draws.components, idle],
        np.append(draws.log_weights, 0.0),
        None,
        draws.noise_mean,
        draws.noise_ess,
    )


def test_restricted_keeps_the_draws_with_weight(problem):
    gm = problem[1]
    draws = _with_an_idle_draw()
    mix = ModelMixture(gm, draws)
    thetas = [np.array([t]) for t in (-0.5, 0.0, 0.5)]
    restricted, kept = mix.restricted(thetas)
    np.testing.assert_array_equal(kept, np.arange(6))
    assert len(restricted.models) == 6 and len(mix.models) == 7
    for t in thetas:
        # Within K tol of the full mixture; the draws kept are the same.
        assert restricted.log_likelihood(t) == pytest.approx(
            mix.log_likelihood(t), abs=7 * 1e-10
        )
        np.testing.assert_array_equal(
            restricted.component_log_likelihoods(t),
            mix.component_log_likelihoods(t)[:6],
        )
    # Nothing to leave out: the mixture itself.
    same, kept = restricted.restricted(thetas, tol=0.0)
    assert same is restricted and len(kept) == 6


def test_spread_restricted_keeps_what_restricted_keeps(problem):
    """At many thetas, evaluated in joblib tasks: the same draws as
    :meth:`restricted` one theta at a time, and an unevaluable theta gives
    no evidence."""
    mix = ModelMixture(problem[1], _with_an_idle_draw())
    thetas = np.linspace(-0.5, 0.5, 30)[:, None]
    spread, kept, values_at = mix.spread_restricted(thetas, n_jobs=2)
    one_by_one, expected = mix.restricted(list(thetas))
    # the values it read, over every draw, for the caller
    np.testing.assert_array_equal(
        values_at, mix.spread_component_log_likelihoods(thetas)
    )
    np.testing.assert_array_equal(kept, expected)
    np.testing.assert_array_equal(kept, np.arange(6))
    np.testing.assert_array_equal(
        spread.batch_component_log_likelihoods(thetas),
        one_by_one.batch_component_log_likelihoods(thetas),
    )
    # a theta where no draw can be evaluated gives no evidence
    values = mix.spread_component_log_likelihoods

    def with_a_dead_theta(thetas, n_jobs=None):
        out = values(thetas, n_jobs)
        out[0] = -np.inf
        return out

    mix.spread_component_log_likelihoods = with_a_dead_theta
    np.testing.assert_array_equal(mix.spread_restricted(thetas)[1], np.arange(6))
    mix.spread_component_log_likelihoods = lambda thetas, n_jobs=None: np.full(
        (len(thetas), 7), -np.inf
    )
    assert mix.spread_restricted(thetas)[0] is mix  # no evidence at all
    del mix.spread_component_log_likelihoods
    # at tol 0 every draw weighs something: the mixture itself; one draw
    # (the plug-in) always matters
    assert mix.spread_restricted(thetas, tol=0.0)[0] is mix
    single = ModelMixture(problem[1], _draws(K=1, seed=5))
    assert single.spread_restricted(thetas)[0] is single


def test_restricted_skips_thetas_that_cannot_be_evaluated(problem, monkeypatch):
    mix = ModelMixture(problem[1], _draws(K=3, seed=4))
    good, bad = np.array([0.1]), np.array([5.0])
    weights = mix.draw_weights

    def draw_weights(theta):
        if theta[0] == bad[0]:
            raise FactorizationError("not positive definite")
        return weights(theta)

    monkeypatch.setattr(mix, "draw_weights", draw_weights)
    assert mix.restricted([good, bad], tol=0.0)[0] is mix
    # Nothing evaluable: no evidence to leave a draw out.
    same, kept = mix.restricted([bad], tol=1.0)
    assert same is mix and len(kept) == 3
