"""PreposteriorDesigner: the fast preposterior analysis of thesis chapter 6."""

import pickle
import warnings

import joblib
import numpy as np
import pytest
from scipy import linalg, stats
from sklearn.base import clone
from sklearn.gaussian_process.kernels import RBF
from thesis._helpers import designer, table_6_2_on_a_common_scale

import skmba.calibration._module2_posterior
from skmba import ModularBayesCalibrator, PreposteriorDesigner
from skmba.datasets import make_cantilever
from skmba.sensor_design._scoring import criterion_value


@pytest.fixture(scope="module")
def cantilever():
    """Table 6.1 responses (A tip, B energy, C rotation, D mid, E quarter)."""
    data = make_cantilever(54, responses="all", random_state=1)
    return data, np.hstack([data.X_sim, data.theta_sim])


@pytest.fixture(scope="module")
def small():
    """Three responses, few replicates: for the exactness checks."""
    data = make_cantilever(
        30,
        responses=("tip_displacement", "energy", "mid_displacement"),
        random_state=0,
    )
    return data, np.hstack([data.X_sim, data.theta_sim])


@pytest.fixture(scope="module")
def exhaustive(small):
    data, X = small
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return designer(data.prior).fit(X, data.y_sim)


@pytest.mark.parametrize("budget", ["one field", "one theta"])
def test_prefix_trees_split_to_their_memory_budget_give_the_same_scores(
    small, exhaustive, budget, monkeypatch
):
    """Trees over fewer fields, or over fewer nodes of one field, when a
    tree would hold more than TREE_BYTES: the same posterior moments."""
    import skmba.sensor_design._scoring as prepost
    from skmba.sensor_design._subset_tree import path_bytes

    # 8 design points, 3 responses; the calibrator's default regressions
    # are constant (p_m = p_d = 1).
    per_element = path_bytes(exhaustive.X_design_.shape[0], 3, 2)
    nodes = 33  # one parameter: the stage-1 Gauss-Legendre rule
    elements = nodes if budget == "one field" else 5  # 1 field, 7 node chunks
    monkeypatch.setattr(prepost, "TREE_BYTES", elements * per_element)
    shapes = []
    tree = prepost.subset_tree_log_likelihoods

    def recorded(design, subsets, fields, H_d, pieces):
        shapes.append((len(fields), len(pieces[0])))
        return tree(design, subsets, fields, H_d, pieces)

    monkeypatch.setattr(prepost, "subset_tree_log_likelihoods", recorded)
    data, X = small
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        split = designer(data.prior, n_jobs=1).fit(X, data.y_sim)
    assert max(f for f, _ in shapes) == 1
    assert max(t for _, t in shapes) == (nodes if budget == "one field" else 5)
    np.testing.assert_allclose(
        split.preposterior_cov_, exhaustive.preposterior_cov_, rtol=1e-12
    )


def test_fitted_attributes_are_consistent(exhaustive):
    d = exhaustive
    assert d.subsets_ == [(0,), (1,), (2,), (0, 1), (0, 2), (1, 2), (0, 1, 2)]
    assert d.preposterior_cov_.shape == (7, 1, 1)
    prior_var = d.prior_.cov()[0, 0]
    # For one parameter every criterion is the posterior-to-prior variance ratio.
    np.testing.assert_allclose(d.scores_, d.preposterior_cov_[:, 0, 0] / prior_var)
    assert np.all((d.scores_ > 0) & (d.scores_ < 1.05))
    np.testing.assert_allclose(d.convergence_[-1], d.scores_)
    assert d.convergence_.shape == (6, 7)
    assert d.best_subset_ == d.subsets_[int(np.argmin(d.scores_))]
    assert d.support_.tolist() == [i in d.best_subset_ for i in range(3)]
    singles = d.scores_[:3]
    assert d.ranking_.tolist() == list(stats.rankdata(singles, method="min"))
    assert d.expected_error_.shape == (7, 1)
    assert d.theta_draws_.shape == (6, 1)
    lo, hi = d.prior_.bounds()[0]
    assert np.all((d.theta_draws_ >= lo) & (d.theta_draws_ <= hi))
    assert d.X_design_.shape == (8, 1)
    # More sensors, on average, identify theta better.
    assert d.scores_[-1] <= singles.min() + 1e-12


def test_criteria_are_norms_of_the_same_covariance(small):
    """r = 2: trace, det^(1/r) and max eigenvalue of the prior-scaled covariance."""
    data = make_cantilever(
        40,
        responses=("tip_displacement", "energy"),
        parameters=("E", "I"),
        random_state=0,
    )
    X = np.hstack([data.X_sim, data.theta_sim])
    scores = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for criterion in ("trace", "det", "max_eig"):
            d = designer(data.prior, criterion=criterion, n_mc=3).fit(X, data.y_sim)
            scores[criterion] = d.scores_
    sd = np.sqrt(np.diag(d.prior_.cov()))
    scaled = d.preposterior_cov_ / np.outer(sd, sd)
    # Each norm is 1 at the prior, whatever r: the trace is over r.
    np.testing.assert_allclose(
        scores["trace"], np.trace(scaled, axis1=1, axis2=2) / 2, rtol=1e-12
    )
    np.testing.assert_allclose(
        scores["det"], np.sqrt(np.linalg.det(scaled)), rtol=1e-10
    )
    np.testing.assert_allclose(scores["max_eig"], np.linalg.eigvalsh(scaled)[:, -1])


@pytest.mark.parametrize("criterion", ["trace", "det", "max_eig"])
def test_a_correlated_prior_scores_one_under_every_criterion(criterion):
    """The criterion whitens by the prior covariance: a preposterior
    covariance equal to a correlated prior's scores 1, whatever r and the
    units; with independent parameters it is the covariance scaled by the
    prior standard deviations, bit for bit as before the whitening."""
    rng = np.random.default_rng(0)
    for r in (2, 3):
        units = np.array([2e4, 3e-3, 1.0])[:r]
        A = rng.standard_normal((r, r + 2))
        correlated = (A @ A.T + 0.1 * np.eye(r)) * np.outer(units, units)
        corr = correlated / np.outer(units, units)
        assert np.abs(corr[np.triu_indices(r, 1)]).max() > 0.3
        assert criterion_value(correlated, correlated, criterion) == pytest.approx(
            1.0, abs=1e-12
        )
        # The cov [[1, .8], [.8, 1]] of the audit scored 1.0, 0.6 and 1.8.
        rho = np.array([[1.0, 0.8], [0.8, 1.0]])
        assert criterion_value(rho, rho, criterion) == pytest.approx(1.0, abs=1e-12)
        # Any covariance: the norm of the eigenvalues of C relative to the
        # prior (C v = lambda P v), e.g. the prior's variances without its
        # correlation score trace(R^-1) / r > 1 by the trace.
        independent = np.diag(np.diag(correlated))
        ratios = linalg.eigh(independent, correlated, eigvals_only=True)
        expected = {
            "trace": ratios.mean(),
            "det": np.prod(ratios) ** (1.0 / r),
            "max_eig": ratios.max(),
        }[criterion]
        assert criterion_value(independent, correlated, criterion) == pytest.approx(
            expected, rel=1e-12
        )
        assert expected > 1.01  # the scaling by the prior sd alone scored it 1

        diagonal = np.diag(rng.uniform(0.5, 2.0, r) * units**2)
        B = rng.standard_normal((r, r))
        cov = (B @ B.T) * np.outer(units, units)
        sd = np.sqrt(np.diag(diagonal))
        scaled = cov / np.outer(sd, sd)
        old = {
            "trace": np.trace(scaled) / r,
            "det": max(np.linalg.det(scaled), 0.0) ** (1.0 / r),
            "max_eig": np.linalg.eigvalsh(scaled)[-1],
        }[criterion]
        assert criterion_value(cov, diagonal, criterion) == old
        assert criterion_value(diagonal, diagonal, criterion) == pytest.approx(
            1.0, abs=1e-12
        )


def test_same_random_state_same_result_for_any_n_jobs(small, exhaustive):
    data, X = small
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for n_jobs in (2, -1):
            other = designer(data.prior, n_jobs=n_jobs).fit(X, data.y_sim)
            np.testing.assert_array_equal(other.scores_, exhaustive.scores_)
            np.testing.assert_array_equal(other.theta_draws_, exhaustive.theta_draws_)


def test_a_generator_seeds_the_designer(small):
    """random_state takes a numpy Generator: two fresh Generators of one
    seed give the same replicates and scores."""
    data, X = small
    fits = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for _ in range(2):
            d = designer(
                data.prior,
                n_mc=2,
                max_responses=1,
                random_state=np.random.default_rng(0),
            )
            fits.append(d.fit(X, data.y_sim))
    assert fits[0].subsets_ == [(0,), (1,), (2,)]
    assert np.all(np.isfinite(fits[0].scores_) & (fits[0].scores_ > 0))
    np.testing.assert_array_equal(fits[0].scores_, fits[1].scores_)
    np.testing.assert_array_equal(fits[0].theta_draws_, fits[1].theta_draws_)


def test_fast_and_full_rankings_agree(small, exhaustive):
    """Phase-1 reuse against per-subset re-estimation (Arendt et al.)."""
    data, X = small
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        full = designer(data.prior, fast=False).fit(X, data.y_sim)
    assert full.subsets_ == exhaustive.subsets_
    rho = stats.spearmanr(full.scores_, exhaustive.scores_).statistic
    assert rho >= 0.8, rho


def fit_propagated(small, **params):
    """A designer with ``discrepancy_uncertainty="propagate"`` (n_mc=4 unless
    given) fitted on the small cantilever, its warnings silenced."""
    data, X = small
    params = {"n_mc": 4, **params}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return designer(data.prior, discrepancy_uncertainty="propagate", **params).fit(
            X, data.y_sim
        )


@pytest.fixture(scope="module")
def propagated(small):
    return fit_propagated(small)


def test_propagate_changes_module_2_and_the_data_priors_only(small, propagated):
    """The same theta per replicate as the plug-in; other data and scores."""
    d = propagated
    assert d.subsets_ == [(0,), (1,), (2,), (0, 1), (0, 2), (1, 2), (0, 1, 2)]
    assert np.all((d.scores_ > 0) & (d.scores_ < 1.05))
    np.testing.assert_allclose(d.convergence_[-1], d.scores_)
    # The same replicates' theta as the plug-in designer: only module 2 and
    # the discrepancy and noise of the synthetic data differ.
    data, X = small
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plug_in = designer(data.prior, n_mc=4).fit(X, data.y_sim)
    np.testing.assert_array_equal(d.theta_draws_, plug_in.theta_draws_)
    assert not np.allclose(d.scores_, plug_in.scores_)


def test_propagate_skips_the_noise_posterior_mean(small, monkeypatch):
    """The designer predicts no new observation: its module-2 fits leave out
    the noise variances' posterior mean (most of a small fit's time)."""
    calls = []
    monkeypatch.setattr(
        skmba.calibration._module2_posterior,
        "_noise_posterior_mean",
        lambda *args, **kwargs: calls.append(args),
    )
    fitted = fit_propagated(small, n_mc=2, fast=False)
    assert np.all(np.isfinite(fitted.scores_))
    assert calls == []


def test_propagate_full_subset_is_the_same_fit_fast_or_not(small, propagated):
    """With every response, re-estimating module 2 per subset (fast=False)
    fits the very same data with the same seed: the same scores, to the
    round-off of factoring the subset along the prefix tree (fast) or on
    its own (fast=False)."""
    full = fit_propagated(small, fast=False)
    np.testing.assert_allclose(full.scores_[-1], propagated.scores_[-1], rtol=1e-7)
    # Smaller subsets are fitted on their own responses: other estimates.
    assert not np.allclose(full.scores_[:-1], propagated.scores_[:-1])


def test_propagate_same_result_for_any_n_jobs(small, propagated):
    other = fit_propagated(small, n_jobs=2)
    np.testing.assert_array_equal(other.scores_, propagated.scores_)


def test_mixture_of_subset_likelihoods_is_their_weighted_log_sum():
    """``mixed``: log sum_k w_k L_k, and L itself for one component."""
    from skmba.sensor_design._replicates import mixed

    class Fixed:
        def __init__(self, values):
            self.values = np.asarray(values, dtype=float)

        def log_likelihood(self, pieces):
            return self.values

    likes = [Fixed([-1.0, -2.0]), Fixed([-3.0, -np.inf])]
    log_w = np.log([0.25, 0.75])
    expected = np.log(0.25 * np.exp([-1.0, -2.0]) + 0.75 * np.exp([-3.0, -np.inf]))
    np.testing.assert_allclose(mixed(likes, log_w, None), expected)
    np.testing.assert_array_equal(mixed(likes[:1], np.zeros(1), None), [-1.0, -2.0])


def test_greedy_and_genetic_find_the_exhaustive_optimum(cantilever):
    data, X = cantilever
    found = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for search in ("exhaustive", "greedy", "genetic"):
            d = designer(
                data.prior,
                search=search,
                max_responses=2,
                n_mc=8,
                n_design=10,
                **table_6_2_on_a_common_scale(data),
            ).fit(X, data.y_sim)
            found[search] = (d.best_subset_, len(d.subsets_))
            assert max(len(s) for s in d.subsets_) <= 2
    assert found["greedy"][0] == found["exhaustive"][0]
    assert found["genetic"][0] == found["exhaustive"][0]
    assert found["exhaustive"][1] == 15
    assert found["greedy"][1] == 5 + 4


def test_informative_rotation_prior_in_standardised_units(cantilever):
    """A small relative discrepancy makes the rotation the best single sensor."""
    data, X = cantilever
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = designer(
            data.prior,
            max_responses=1,
            discrepancy_prior={"variance": (0.01, [20, 20, 0.1, 20, 20])},
        ).fit(X, data.y_sim)
    assert d.ranking_[2] == 1
    assert d.scores_[2] < 0.5 * np.min(np.delete(d.scores_, 2))


def test_clone_pickle_and_joblib_persistence(exhaustive, tmp_path):
    clone(exhaustive)
    for loaded in (
        pickle.loads(pickle.dumps(exhaustive)),
        joblib.load(joblib.dump(exhaustive, tmp_path / "designer.joblib")[0]),
    ):
        np.testing.assert_array_equal(loaded.scores_, exhaustive.scores_)
        assert loaded.best_subset_ == exhaustive.best_subset_
        assert loaded.score_subset((0, 2)) == exhaustive.score_subset((2, 0))


def test_verbose_reports_progress(small, capsys):
    data, X = small
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        designer(data.prior, n_mc=2, max_responses=1, verbose=1).fit(X, data.y_sim)
    captured = capsys.readouterr()
    assert captured.out == ""  # progress goes to standard error
    assert "phase 1: 2 replicates" in captured.err and "best subset" in captured.err
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        designer(data.prior, n_mc=2, max_responses=1).fit(X, data.y_sim)
    assert capsys.readouterr() == ("", "")


@pytest.mark.parametrize(
    ("params", "error", "match"),
    [
        ({"max_responses": 0}, ValueError, "max_responses=0 is out of range"),
        ({"max_responses": 4}, ValueError, "max_responses=4 is out of range"),
        ({"max_responses": 1.5}, TypeError, "max_responses must be an int"),
        ({"search": "random"}, ValueError, "search='random' is not supported"),
        ({"criterion": "norm"}, ValueError, "criterion='norm' is not supported"),
        ({"prior_units": "mm"}, ValueError, "prior_units='mm' is not supported"),
        ({"n_mc": 0}, ValueError, "n_mc must be a positive integer"),
        ({"module2_max_iter": 0}, ValueError, "module2_max_iter must be a positive"),
        ({"n_design": 1}, ValueError, "n_design must be an integer >= 2"),
        ({"fast": "yes"}, TypeError, "fast must be True or False"),
        ({"calibrator": "mba"}, TypeError, "calibrator must be a Modular"),
        ({"X_design": [[20e3]]}, ValueError, "X_design lies outside the range"),
        ({"X_design": [[2e3, 1.0]]}, ValueError, "X_design has 2 columns"),
        ({"discrepancy_prior": {"sd": (0, 1)}}, ValueError, "unknown keys"),
        (
            {"discrepancy_prior": {"variance": (2.0, 1.0)}},
            ValueError,
            r"discrepancy_prior\['variance'\] needs low <= high",
        ),
        (
            {"discrepancy_prior": {"correlation": 1.0}},
            ValueError,
            "not positive definite",
        ),
        ({"noise_prior": (-1.0, 1.0)}, ValueError, "noise_prior must be >= 0"),
        (
            {"discrepancy_uncertainty": "mixed"},
            ValueError,
            "discrepancy_uncertainty='mixed' is not supported",
        ),
        (
            {"discrepancy_uncertainty": "propagate", "noise_prior": (0, 1e-4)},
            ValueError,
            r"noise_prior=\(0, 0.0001\) belongs to discrepancy_uncertainty='plug-in'",
        ),
        (
            {"discrepancy_uncertainty": "propagate", "prior_units": "user"},
            ValueError,
            "prior_units='user' belongs to discrepancy_uncertainty='plug-in'",
        ),
        (
            {
                "discrepancy_uncertainty": "propagate",
                "discrepancy_prior": {"variance": (0.01, 20.0)},
            },
            ValueError,
            "the ranges 'variance' belong to discrepancy_uncertainty='plug-in'",
        ),
        (
            {
                "discrepancy_uncertainty": "propagate",
                "discrepancy_prior": {"sd_scale": [0.5, 0.5]},
            },
            ValueError,
            r"discrepancy_prior\['sd_scale'\] has 2 values for 3 responses",
        ),
        (
            {"calibrator": ModularBayesCalibrator(discrepancy_kernel=RBF())},
            TypeError,
            "no 'roughness' hyperparameter",
        ),
        (
            {"calibrator": ModularBayesCalibrator(estimand="best_fit")},
            ValueError,
            "calibrator has estimand='best_fit'.*estimand=\"physical\"",
        ),
    ],
)
def test_bad_input_names_the_argument(small, params, error, match):
    data, X = small
    with pytest.raises(error, match=match):
        designer(data.prior, **params).fit(X, data.y_sim)


def test_bad_data_names_the_fix(small):
    data, X = small
    # The prior has one parameter: X needs a design variable before it.
    with pytest.raises(ValueError, match="last r columns"):
        designer(data.prior).fit(X[:, 1:], data.y_sim)
    two = [stats.uniform(20e3, 80e3), stats.uniform(1, 2)]
    with pytest.raises(
        ValueError, match=r"X has 2 columns \(n_features=2\) but the prior has 2"
    ):
        designer(two).fit(X, data.y_sim)
    with pytest.raises(ValueError, match="too few"):
        designer(data.prior).fit(X[:4], data.y_sim[:4])
    with pytest.raises(ValueError, match="prior is required"):
        PreposteriorDesigner().fit(X, data.y_sim)
    far = [stats.uniform(1e6, 1e5)]
    with pytest.raises(ValueError, match="do not overlap the prior"):
        designer(far).fit(X, data.y_sim)
    with pytest.raises(ValueError, match="NaN"):
        bad = X.copy()
        bad[0, 0] = np.nan
        designer(data.prior).fit(bad, data.y_sim)


def test_responses_by_name_with_a_dataframe(small, exhaustive):
    """A DataFrame y names the responses: score_subset and summary take
    them; with an array y, names are an error that says what to do."""
    pd = pytest.importorskip("pandas")
    data, X = small
    names = ["tip", "energy", "mid"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        named = designer(data.prior).fit(X, pd.DataFrame(data.y_sim, columns=names))
    assert named.response_names_ == names
    np.testing.assert_array_equal(named.scores_, exhaustive.scores_)
    assert named.score_subset(["mid", "tip"]) == exhaustive.score_subset([0, 2])
    assert named.score_subset(["energy", 0]) == exhaustive.score_subset((0, 1))
    assert set(named.summary()["subset"]) >= {"tip", "tip, energy, mid"}
    assert exhaustive.response_names_ is None
    with pytest.raises(ValueError, match="fitted on an array y without names"):
        exhaustive.score_subset(["tip"])
    with pytest.raises(ValueError, match=r"unknown response 'rotation'; the "):
        named.score_subset(["rotation"])
    with pytest.raises(ValueError, match="response index 3 is out of range"):
        named.score_subset([3])


def test_parameter_columns_of_a_table_found_by_the_prior_names(small, exhaustive):
    """With a DataFrame X and a dict prior, the parameter column is found by
    name wherever it is (here first): the same scores as the array with the
    parameter last. A prior key that X lacks is an error listing both."""
    pd = pytest.importorskip("pandas")
    data, X = small
    table = pd.DataFrame({"E": X[:, 1], "F": X[:, 0]})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        named = designer({"E": data.prior[0]}).fit(table, data.y_sim)
    np.testing.assert_array_equal(named.scores_, exhaustive.scores_)
    assert list(named.feature_names_in_) == ["F", "E"]
    with pytest.raises(
        ValueError,
        match=r"X has no column for the parameter\(s\) \['modulus'\] of the prior "
        r"\(its keys: \['modulus'\]; the columns of X: \['E', 'F'\]\)",
    ):
        designer({"modulus": data.prior[0]}).fit(table, data.y_sim)


def test_a_named_X_design_is_matched_to_the_design_columns_by_name():
    """X_design as a table in another column order than the simulations
    gives the scores of the same design as an array; unknown names fail."""
    import pandas as pd

    from skmba import ModularBayesCalibrator, PreposteriorDesigner
    from skmba.datasets import make_cantilever

    data = make_cantilever(40, design_variables=("force", "moment"), random_state=0)
    names = list(data.design_variable_names)
    X = pd.DataFrame(np.hstack([data.X_sim, data.theta_sim]), columns=[*names, "E"])
    lo, hi = data.X_sim.min(axis=0), data.X_sim.max(axis=0)
    X_design = lo + (hi - lo) * np.array([[0.1, 0.9], [0.5, 0.2], [0.8, 0.6]])

    def scores(design):
        designer = PreposteriorDesigner(
            {"E": data.prior[0]},
            calibrator=ModularBayesCalibrator(n_restarts_optimizer=0),
            X_design=design,
            n_mc=4,
            random_state=0,
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return designer.fit(X, data.y_sim).scores_

    table = pd.DataFrame(X_design, columns=names)[names[::-1]]
    np.testing.assert_array_equal(scores(table), scores(X_design))
    with pytest.raises(ValueError, match="do not match the design-variable columns"):
        scores(table.rename(columns={names[0]: "load"}))


@pytest.mark.parametrize(
    ("extra", "search", "treatment"),
    [
        ("duplicate", "genetic", "plug-in"),
        ("scaled", "greedy", "propagate"),
        ("sum", "exhaustive", "propagate"),
    ],
)
def test_dependent_responses_give_scores_not_linear_algebra_errors(
    extra, search, treatment
):
    """A response that repeats, scales or adds others: every search and
    treatment gives finite scores (a user's trial of nearly dependent
    responses met scipy's 'allow_singular is False' error; the proposal
    covariances are now floored, tests/core/test_linalg.py)."""
    from skmba import ModularBayesCalibrator, PreposteriorDesigner
    from skmba.datasets import make_cantilever

    sims = make_cantilever(
        30, responses=("tip_displacement", "mid_displacement", "energy"), random_state=0
    )
    Y = sims.y_sim
    added = {"duplicate": Y[:, 0], "scaled": 2.0 * Y[:, 0], "sum": Y[:, 0] + Y[:, 1]}
    designer = PreposteriorDesigner(
        sims.prior,
        calibrator=ModularBayesCalibrator(n_restarts_optimizer=0),
        discrepancy_uncertainty=treatment,
        n_design=8,
        n_mc=3,
        search=search,
        random_state=0,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        designer.fit(
            np.hstack([sims.X_sim, sims.theta_sim]),
            np.column_stack([Y, added[extra]]),
        )
    assert np.all(np.isfinite(designer.scores_)) and np.all(designer.scores_ > 0)
