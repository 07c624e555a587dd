"""The designer's prediction of the calibrator's identifiability warning."""

import warnings
from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from skmba import ModularBayesCalibrator, PreposteriorDesigner
from skmba.calibration._module3_identifiability import (
    data_information,
    data_share,
    probe_sds,
    probe_share,
    sensitivities,
)
from skmba.kernels import Gauss
from skmba.priors._hyperprior import Hyperprior
from skmba.sensor_design._identifiability import (
    identifiability_summary,
    kronecker_information,
    predicted_identified,
    replicate_identifiability,
)


def _dense_V0(sigma2_m, noise, T):
    n = len(T)
    return np.kron(sigma2_m, T) + np.kron(np.diag(noise), np.eye(n))


def test_kronecker_information_equals_the_dense_formula():
    """Two eigen-decompositions give ``J' V_0^-1 J`` of the dense
    Cholesky, with a rank-deficient emulator covariance and a smooth
    correlation whose small eigenvalues round to about zero."""
    rng = np.random.default_rng(0)
    n, s, r = 15, 3, 2
    x = np.sort(rng.uniform(size=n))
    T = np.exp(-3.0 * (x[:, None] - x[None, :]) ** 2)
    A = rng.normal(size=(s, 2))
    sigma2_m = A @ A.T  # rank 2 of 3
    noise = np.array([0.01, 0.3, 2.0])
    J = rng.normal(size=(n, s, r))
    dense = data_information(
        J.transpose(1, 0, 2).reshape(s * n, r), _dense_V0(sigma2_m, noise, T)
    )
    got = kronecker_information(J, sigma2_m, noise, T)
    np.testing.assert_allclose(got, dense, rtol=1e-9)
    np.testing.assert_allclose(got, got.T, rtol=1e-12)


@pytest.fixture(scope="module")
def context():
    """A Monte Carlo context of the two-response cantilever (both
    treatments share the emulator and design)."""
    from skmba.calibration._module1_emulator import Standardizer, fit_emulator
    from skmba.calibration._settings import CalibrationSettings
    from skmba.datasets import make_cantilever
    from skmba.priors._theta import check_prior
    from skmba.sensor_design._inputs import check_design_priors
    from skmba.sensor_design._replicates import MonteCarloContext

    data = make_cantilever(40, 12, random_state=0)
    settings = CalibrationSettings.from_params(
        ModularBayesCalibrator(prior=data.prior).get_params()
    )
    scaler = Standardizer.from_simulations(data.X_sim, data.theta_sim, data.y_sim)
    emulator = fit_emulator(scaler, data.X_sim, data.theta_sim, data.y_sim,
                            **settings.emulator.kwargs(), random_state=0)  # fmt: skip
    X_design = np.linspace(2e3, 9e3, 12)[:, None]
    out = {}
    for treatment in ("propagate", "plug-in"):
        if treatment == "propagate":
            priors = Hyperprior()
        else:
            priors = check_design_priors(
                None, None, "standardised", 1, 2, scaler.y_scale
            )
        out[treatment] = MonteCarloContext.build(
            settings, emulator, scaler, X_design, check_prior(data.prior), priors,
            (0, 1), fast=True, module2_max_iter=50,
        )  # fmt: skip
    return out


@pytest.mark.parametrize("treatment", ["propagate", "plug-in"])
@pytest.mark.parametrize("subset", [(0,), (1,), (0, 1)])
def test_replicate_identifiability_is_the_calibrators_rule(context, treatment, subset):
    """The designer's ratio for a subset is the calibrator's formula on the
    subset's rows, written densely: the data share of the posterior
    (propagate) or the probe's ratio (plug-in), with module 2's mode on all
    responses restricted to the subset."""
    ctx = context[treatment]
    idx = list(subset)
    mode = SimpleNamespace(
        noise=np.array([0.02, 0.05]),
        sigma2=np.array([[0.3, 0.12], [0.12, 0.2]]),
        kernel_=Gauss(roughness=2.0),
    )
    mean = np.array([69e3])
    cov = np.array([[1500.0**2]])
    # Two subsets in one call, each at its own mean.
    got = replicate_identifiability(
        ctx,
        [(0, 1), subset],
        [mode, mode],
        np.vstack([mean * 1.1, mean]),
        np.stack([cov, cov]),
    )[1]

    J, T = sensitivities(ctx.emulator, ctx.Xs, ctx.std_theta(mean)[None, :])
    J, T = J[0], T[0]
    n, s = ctx.n, len(idx)
    J = J[:, idx].transpose(1, 0, 2).reshape(s * n, 1)
    V0 = _dense_V0(ctx.emulator.sigma2[np.ix_(idx, idx)], mode.noise[idx], T)
    info = data_information(J, V0)
    if treatment == "propagate":
        scale = ctx.scaler.theta_scale
        expected = data_share(info, cov / np.outer(scale, scale))
    else:
        S = mode.sigma2[np.ix_(idx, idx)]
        sd = np.sqrt(np.diag(S))
        big = ctx.probe_prior.sd_quantile(0.95, 2)[idx]
        K_d = np.kron(S / np.outer(sd, sd) * np.outer(big, big), mode.kernel_(ctx.Xs))
        X_d = np.kron(np.eye(s), ctx.H_d)
        expected = probe_share(info, probe_sds(J, V0, K_d, X_d))
    np.testing.assert_allclose(got, expected, rtol=1e-8)
    assert 0.0 < got[0] <= 1.0


def test_summary_is_the_median_and_the_share_below_the_threshold():
    ratios = np.array([[[0.1, 0.9], [0.2, 0.8], [0.5, 0.2], [0.6, 0.7]]])  # 1 subset
    median, rate, mcse = identifiability_summary(ratios)
    np.testing.assert_allclose(median, [[0.35, 0.75]])
    np.testing.assert_allclose(rate, [[0.5, 0.25]])
    # the standard error of a share of 4 independent replicates
    np.testing.assert_allclose(mcse, [stats.bernoulli([0.5, 0.25]).std() / 2])


def test_predicted_identified_is_every_rate_within_the_bound():
    rate = np.array([[0.0, 0.1], [0.1, 0.11], [0.3, 0.0]])
    np.testing.assert_array_equal(predicted_identified(rate, 0.1), [True, False, False])
    np.testing.assert_array_equal(predicted_identified(rate, 1.0), [True] * 3)
    np.testing.assert_array_equal(predicted_identified(rate, None), [True] * 3)


def _frequency_designer(with_offset, n_mc=10):
    """freq's model (y = sin(2 pi t x) + 0.5 x), with an additive offset
    as a second parameter or not, 150 simulations on a Latin hypercube."""
    rng = np.random.default_rng(0)
    bounds = [(0.0, 1.0), (2.0, 4.0)] + ([(-0.5, 0.5)] if with_offset else [])
    lo, hi = np.array(bounds).T
    Z = lo + (hi - lo) * stats.qmc.LatinHypercube(len(bounds), seed=rng).random(150)
    y = np.sin(2 * np.pi * Z[:, 1] * Z[:, 0]) + 0.5 * Z[:, 0]
    if with_offset:
        y = y + Z[:, 2]
    prior = [stats.uniform(a, b - a) for a, b in bounds[1:]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return PreposteriorDesigner(
            prior,
            discrepancy_uncertainty="propagate",
            n_design=30,
            n_mc=n_mc,
            random_state=0,
        ).fit(Z, y)


def test_the_designer_names_the_confounded_parameter_only():
    """A frequency is identified whatever the discrepancy; an additive
    offset is absorbed by the discrepancy's constant mean. The calibrator
    names the offset alone (validation.studies.identifiability, 60/60 fits);
    the designer predicts it: the offset's median identifiability below
    1/3, the frequency's above, alone and beside the offset."""
    alone = _frequency_designer(False)
    both = _frequency_designer(True)
    assert alone.identifiability_.shape == (1, 1)
    assert alone.identifiability_[0, 0] > 1 / 3
    assert alone.warning_rate_[0, 0] < 0.5
    frequency, offset = both.identifiability_[0]
    assert frequency > 1 / 3 > offset
    assert both.warning_rate_[0, 1] > 0.5 > both.warning_rate_[0, 0]
    # n_mc = 10: rates are multiples of 1/10
    np.testing.assert_allclose(
        both.warning_rate_ * 10, np.round(both.warning_rate_ * 10)
    )
    table = both.summary()
    assert list(table.columns)[-4:] == [
        "warning_rate[theta0]",
        "warning_rate[theta1]",
        "warning_rate_mcse[theta0]",
        "warning_rate_mcse[theta1]",
    ]
    p = both.warning_rate_
    np.testing.assert_allclose(both.warning_rate_mcse_, np.sqrt(p * (1 - p) / 10))
    np.testing.assert_allclose(
        table["warning_rate_mcse[theta1]"], [np.sqrt(p[0, 1] * (1 - p[0, 1]) / 10)]
    )


def test_the_probe_falls_back_to_one_by_one_when_the_stack_fails(context, monkeypatch):
    """Where the stacked factorisation's eigenvalue bound fails, each
    subset's probe is factored on its own: the same ratios."""
    import skmba.sensor_design._identifiability as module

    ctx = context["plug-in"]
    mode = SimpleNamespace(
        noise=np.array([0.02, 0.05]),
        sigma2=np.array([[0.3, 0.12], [0.12, 0.2]]),
        kernel_=Gauss(roughness=2.0),
    )
    args = (ctx, [(0,), (1,)], [mode, mode], np.array([[69e3], [71e3]]))
    covs = np.full((2, 1, 1), 1500.0**2)
    stacked = replicate_identifiability(*args, covs)

    def fail(*a, **k):
        raise np.linalg.LinAlgError("no bound")

    monkeypatch.setattr(module, "stacked_probe_sds", fail)
    np.testing.assert_allclose(
        replicate_identifiability(*args, covs), stacked, rtol=1e-8
    )


def _results(scores_and_ratios):
    """Synthetic phase-2 results ``{subset: (means, covs, ratios)}`` for one
    parameter and 4 replicates: each subset's posterior variance its score
    (the prior's variance is 1), its ratios the given ones."""
    return {
        subset: (
            np.zeros((4, 1)),
            np.full((4, 1, 1), score),
            np.reshape(ratios, (4, 1)),
        )
        for subset, (score, ratios) in scores_and_ratios.items()
    }


# (0, 1) scores best but the calibrator would warn on 3 of 4 replicates;
# (1,) is next and would warn on 1 of 4, (0,) on 2.
RESULTS = _results(
    {
        (0,): (0.5, [0.9, 0.1, 0.1, 0.9]),
        (1,): (0.3, [0.9, 0.8, 0.7, 0.2]),
        (0, 1): (0.1, [0.1, 0.2, 0.9, 0.3]),
    }
)
REPLICATES = [SimpleNamespace(theta=np.zeros(1))] * 4


def test_the_best_subset_is_the_best_predicted_to_identify_theta():
    from skmba.sensor_design._scoring import design_scores

    plain = design_scores(RESULTS, REPLICATES, np.eye(1), "trace", 2)
    assert plain["best_subset"] == (0, 1)
    np.testing.assert_array_equal(plain["identified"], [True, True, True])
    strict = design_scores(RESULTS, REPLICATES, np.eye(1), "trace", 2, 0.25)
    assert strict["subsets"] == [(0,), (1,), (0, 1)]
    np.testing.assert_array_equal(strict["identified"], [False, True, False])
    assert strict["best_subset"] == (1,)
    np.testing.assert_array_equal(strict["support"], [False, True])
    np.testing.assert_allclose(strict["warning_rate"].ravel(), [0.5, 0.25, 0.75])
    np.testing.assert_array_equal(strict["scores"], plain["scores"])
    # at 0.5 the first subset qualifies too, and (1,) still scores better
    assert design_scores(RESULTS, REPLICATES, np.eye(1), "trace", 2, 0.5)[
        "best_subset"
    ] == (1,)


def test_no_identified_subset_warns_and_takes_the_best_of_all():
    from skmba.exceptions import NonIdentifiabilityWarning
    from skmba.sensor_design._scoring import design_scores

    with pytest.warns(
        NonIdentifiabilityWarning, match=r"max_warning_rate=0:.*rate 0\.25\)"
    ):
        out = design_scores(RESULTS, REPLICATES, np.eye(1), "trace", 2, 0.0)
    assert out["best_subset"] == (0, 1)
    assert not out["identified"].any()


def test_the_table_lists_the_identified_subsets_first():
    from skmba.sensor_design._scoring import design_scores, design_table

    out = design_scores(RESULTS, REPLICATES, np.eye(1), "trace", 2, 0.5)
    rates = (out["warning_rate"], out["warning_rate_mcse"])
    table = design_table(
        ["a", "b"],
        out["subsets"],
        out["scores"],
        out["scores_mcse"],
        rates,
        ["E"],
        out["identified"],
    )
    assert list(table["subset"]) == ["b", "a", "a, b"]
    assert list(table["identified"]) == [True, True, False]
    np.testing.assert_allclose(table["warning_rate[E]"], [0.25, 0.5, 0.75])
    np.testing.assert_allclose(
        table["warning_rate_mcse[E]"],
        [np.sqrt(0.75 * 0.25 / 4), 0.25, np.sqrt(0.75 * 0.25 / 4)],
    )
    plain = design_table(
        ["a", "b"], out["subsets"], out["scores"], out["scores_mcse"], rates, ["E"]
    )
    assert list(plain["subset"]) == ["a, b", "b", "a"]
    assert "identified" not in plain.columns


def test_the_greedy_search_follows_the_identified_subsets():
    """Forward selection from the best single sensor: by score it adds
    sensor 0 to sensor 1; with the bound, the pair is predicted
    unidentified, so it stops at (1,) and then (1, 2)."""
    from skmba.sensor_design._scoring import search_values
    from skmba.sensor_design._subset_search import greedy_forward

    table = {
        (0,): (0.5, 0.9),
        (1,): (0.3, 0.9),
        (2,): (0.6, 0.9),
        (0, 1): (0.1, 0.1),
        (1, 2): (0.2, 0.9),
        (0, 1, 2): (0.05, 0.1),
    }

    def evaluate(max_rate):
        def run(subsets):
            scores = [table[tuple(s)][0] for s in subsets]
            ratios = [np.full((4, 1), table[tuple(s)][1]) for s in subsets]
            return search_values(scores, ratios, max_rate).tolist()

        return run

    by_score = greedy_forward(evaluate(None), 3)
    identified = greedy_forward(evaluate(0.5), 3)
    assert (0, 1) in by_score and (1, 2) not in by_score
    assert (1, 2) in identified


def test_max_warning_rate_reranks_the_same_analysis():
    """The bound changes which subset is best, not what is computed: the
    same scores and rates, ``identified_`` those within it, the best of
    them first; none within it warns; a rate outside [0, 1] is refused."""
    from skmba.datasets import make_cantilever
    from skmba.exceptions import NonIdentifiabilityWarning

    data = make_cantilever(
        40,
        responses=("tip_displacement", "mid_displacement", "tip_rotation"),
        random_state=0,
    )
    X = np.hstack([data.X_sim, data.theta_sim])

    def fit(rate):
        return PreposteriorDesigner(
            data.prior,
            calibrator=ModularBayesCalibrator(n_restarts_optimizer=0),
            discrepancy_uncertainty="propagate",
            n_design=8,
            n_mc=10,
            random_state=0,
            max_warning_rate=rate,
        ).fit(X, data.y_sim)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plain = fit(None)
    largest = plain.warning_rate_.max(axis=1)
    bound = float(np.median(largest))
    assert largest.min() <= bound < largest.max()  # some in, some out
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bounded = fit(bound)
    np.testing.assert_array_equal(bounded.scores_, plain.scores_)
    np.testing.assert_array_equal(bounded.warning_rate_, plain.warning_rate_)
    np.testing.assert_array_equal(bounded.identified_, largest <= bound)
    assert plain.identified_.all()
    inside = np.flatnonzero(bounded.identified_)
    best = bounded.subsets_[inside[np.argmin(bounded.scores_[inside])]]
    assert bounded.best_subset_ == best
    table = bounded.summary()
    n_in = int(bounded.identified_.sum())
    assert table["identified"].iloc[:n_in].all()
    assert not table["identified"].iloc[n_in:].any()
    assert np.all(np.diff(table["score"].iloc[:n_in]) >= 0)
    with pytest.warns(NonIdentifiabilityWarning, match="No scored subset"):
        none = fit(largest.min() / 2)
    assert none.best_subset_ == plain.best_subset_
    with pytest.raises(ValueError, match=r"max_warning_rate must be .* in \[0, 1\]"):
        fit(1.5)
