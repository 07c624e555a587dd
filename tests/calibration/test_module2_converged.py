"""The integral over module 2's hyperparameters to a stated Monte Carlo error
(skmba.calibration._module2_converged, ``discrepancy_tol``)."""

import warnings
from types import SimpleNamespace

import numpy as np
import pytest
from scipy import special, stats

import skmba.calibration._module2_converged as converged
from skmba import ModularBayesCalibrator
from skmba.calibration._module2_converged import AUTO_TOL
from skmba.calibration._module2_theta_grid import ThetaGrid
from skmba.priors._theta import check_prior
from validation.cases import case_freq

TOL = 0.1


def _fit(case, random_state, tol=TOL):
    cal = ModularBayesCalibrator(
        prior=case.prior, random_state=random_state, discrepancy_tol=tol
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return cal.fit(
            case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim, y_sim=case.y_sim
        )


@pytest.fixture(scope="module")
def case():
    return case_freq(0)


@pytest.fixture(scope="module")
def fits(case):
    return [_fit(case, random_state) for random_state in (0, 1)]


def _trapezoid(nodes):
    return 0.5 * (np.diff(nodes, prepend=nodes[0]) + np.diff(nodes, append=nodes[-1]))


def _log_weight_error(cal):
    """Largest difference of the grid's log weights from the mixture's own
    log posterior times the trapezoid, within 20 of the largest."""
    nodes, weights = cal.theta_nodes_[:, 0], cal.theta_weights_
    log_post = np.array([cal.log_posterior(np.array([t])) for t in nodes])
    log_expected = log_post + np.log(_trapezoid(nodes))
    log_expected -= special.logsumexp(log_expected)
    relevant = log_expected > log_expected.max() - 20
    return np.max(np.abs(np.log(weights[relevant]) - log_expected[relevant]))


def test_grid_weights_are_the_mixtures_posterior(fits):
    # Identity up to the spline: the posterior on the grid is the fitted
    # mixture's own log posterior (all draws, their importance weights) times
    # the trapezoid, where the likelihood between the evaluated nodes comes
    # from a spline checked to SPLINE_TOL (the normalisation adds as much).
    # On this smooth case the spline is far better than its check.
    cal = fits[0]
    assert _log_weight_error(cal) <= 1e-2 * converged.SPLINE_TOL
    assert cal.discrepancy_draws_ == len(cal.global_model_.models) >= 512


def test_a_coarse_spline_is_caught_and_refined(monkeypatch):
    # On a1 (E confounded with the discrepancy, the conditional posteriors
    # skewed and of many widths) evaluated 5 first-pass sds apart, the
    # spline misses the likelihood by about 0.5: the check at the midpoints
    # refines the evaluation grid until it holds. (freq's log likelihood is
    # so nearly quadratic in theta that a spline through 3 nodes holds.)
    from validation.cases import case_a1

    changes = []
    regridded = converged._regridded

    def spy(draws, grids, prior, evaluate, change):
        changes.append(change)
        return regridded(draws, grids, prior, evaluate, change)

    monkeypatch.setattr(converged, "_regridded", spy)
    monkeypatch.setattr(converged, "GRID_STEP", 5.0)
    cal = _fit(case_a1(0), 0)
    assert "coarse" in changes
    assert _log_weight_error(cal) <= 2 * converged.SPLINE_TOL


def test_warns_when_the_spline_cannot_be_refined(monkeypatch):
    from validation.cases import case_a1

    case = case_a1(0)
    monkeypatch.setattr(converged, "GRID_STEP", 5.0)
    monkeypatch.setattr(converged, "_GRID_CHANGES", 0)
    cal = ModularBayesCalibrator(prior=case.prior, random_state=0, discrepancy_tol=TOL)
    with pytest.warns(UserWarning, match="interpolated with an error"):
        cal.fit(
            case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim, y_sim=case.y_sim
        )


def test_same_data_same_interval_within_the_reported_error(fits):
    # Two seeds differ by their Monte Carlo errors, no more: the difference
    # of each summary within 4 combined standard errors...
    a, b = fits
    summaries = []
    for cal in fits:
        q = np.quantile(cal.theta_samples_[:, 0], [0.025, 0.975])
        sd = np.sqrt(cal.theta_cov_[0, 0])
        summaries.append(np.r_[cal.theta_mean_[0], sd, q])
    se = np.hypot(a.theta_mcse_[:, 0], b.theta_mcse_[:, 0])
    assert np.all(np.abs(summaries[0] - summaries[1]) <= 4 * se)
    # ...and the errors are those asked for, not vacuous ones.
    for cal, values in zip(fits, summaries, strict=True):
        relative = cal.theta_mcse_[:, 0] / values[1]
        assert np.all(relative[:2] <= TOL) and np.all(relative[2:] <= 2 * TOL)
        assert np.all(relative > 1e-4)


def test_predictive_noise_comes_from_the_same_weights(fits):
    # One posterior for the hyperparameters: the noise a new observation
    # adds is their posterior mean under the weights of module 3's mixture.
    cal = fits[0]
    mixture = cal.global_model_
    nodes = cal.theta_nodes_
    scaler_theta = (nodes - cal.theta_offset_) / cal.theta_scale_
    log_l = mixture.batch_component_log_likelihoods(scaler_theta)
    log_prior = np.ravel(cal.prior_.logpdf(nodes))
    log_trapezoid = np.log(_trapezoid(nodes[:, 0]))
    log_z = special.logsumexp(log_l + (log_prior + log_trapezoid)[:, None], axis=0)
    weights = np.exp(log_z - special.logsumexp(log_z))
    noise = weights @ np.array([m.noise for m in mixture.models])
    # The fit integrates a spline of these log likelihoods (checked to
    # SPLINE_TOL); a weighted mean of positive values moves by less than
    # its weights' largest relative change.
    np.testing.assert_allclose(
        mixture.predictive_noise, noise, rtol=np.expm1(4 * converged.SPLINE_TOL)
    )


def test_trapezoid_grid_integrates_a_gaussian():
    prior = check_prior([stats.uniform(-50, 100)])
    grid = ThetaGrid.around(prior, 0.3, 1.0, 7.0, converged.GRID_STEP)
    assert grid.step == pytest.approx(converged.GRID_STEP)
    trapezoid = np.exp(grid.log_weights) * 100.0  # over the prior density
    gauss = stats.norm(0.3, 1.0).pdf(grid.nodes)
    fine = grid.subdivided(prior, 4)
    assert np.sum(trapezoid * gauss) == pytest.approx(1.0, rel=1e-3)
    fine_gauss = np.exp(fine.log_weights) * 100.0 @ stats.norm(0.3, 1.0).pdf(fine.nodes)
    assert fine_gauss == pytest.approx(1.0, rel=1e-10)
    np.testing.assert_array_equal(fine.nodes[::4], grid.nodes)
    finer = grid.refined(prior)
    np.testing.assert_array_equal(finer.nodes[::2], grid.nodes)
    wider, below, above = grid.extended(prior, True, False)
    assert wider.step == grid.step and below > 0 and above == 0
    np.testing.assert_array_equal(wider.nodes[below:], grid.nodes)
    np.testing.assert_allclose(np.diff(wider.nodes), grid.step, rtol=1e-9)


def test_an_extension_adds_a_quarter_of_the_grid_s_whole_steps():
    """A grid of 12 steps grows by 3 nodes at a flagged end, however its
    coordinates round (before: 3 or 4, as ``ceil`` of 12 * (1 +- eps) / 4
    fell, which sent two fits of the same data down different paths)."""
    prior = check_prior([stats.uniform(0.0, 1e6)])
    rng = np.random.default_rng(0)
    added = set()  # before: 3 on 103 of these 200 grids, 4 on 97
    for mean, sd in rng.uniform([5e4, 10.0], [8e4, 200.0], (200, 2)):
        grid = ThetaGrid.around(prior, mean, sd, 7.0, 1.2)
        assert len(grid.nodes) == 13
        wider, below, above = grid.extended(prior, True, True)
        added.add((below, above))
        assert len(wider.nodes) == 13 + below + above
    assert added == {(3, 3)}


def test_errors_over_the_draws_match_their_spread_over_replicates():
    """The delta-method errors of the four summaries against their spread
    over 300 replicates of 256 importance draws, on a mixture whose answer
    is known: phi ~ N(0, 1) drawn from a Student-t with 4 degrees of freedom
    (weights p / q), theta | phi ~ N(phi, 0.5^2) on the grid, so theta ~
    N(0, 1.25). Each summary's rms z is within 0.85-1.15 (its sampling
    error over 300 replicates is about 0.04; measured 0.99-1.08 here, and
    0.93-1.08 over seeds 0-3). Four blocks' spread, the estimate used
    before, gives 1.6-3.1 on this mixture (400 replicates of four blocks of
    64 draws: a standard error from four values)."""
    prior = check_prior([stats.uniform(-50, 100)])
    grid = ThetaGrid.build(prior, np.linspace(-9.0, 9.0, 361), 0.05)
    truth = np.r_[0.0, np.sqrt(1.25), stats.norm(0, np.sqrt(1.25)).ppf([0.025, 0.975])]
    proposal = stats.t(4)
    rng = np.random.default_rng(0)
    z = []
    for _ in range(300):
        phi = proposal.rvs(256, random_state=rng)
        draws = SimpleNamespace(
            F=stats.norm.logpdf(grid.nodes[:, None], phi[None, :], 0.5),
            log_w=stats.norm.logpdf(phi) - proposal.logpdf(phi),
            source=np.zeros(len(phi), dtype=int),
        )
        pooled, se = converged._errors(draws, grid)[:2]
        z.append((pooled - truth) / se)
    rms = np.sqrt(np.mean(np.square(z), axis=0))
    assert np.all((rms > 0.85) & (rms < 1.15)), rms


def test_grid_stops_at_the_prior_and_keeps_its_nodes():
    # At the prior's 0.9999 interval the lattice ends with a shorter
    # spacing; extending there keeps the old nodes and adds the bound.
    prior = check_prior([stats.uniform(0.0, 1.0)])
    lo, hi = prior.bounds(0.9999)[0]
    grid = ThetaGrid.around(prior, 0.05, 0.1, 7.0, 0.8)
    assert grid.nodes[0] == lo and grid.nodes[-1] < hi
    assert np.all(np.diff(grid.nodes) <= grid.step * (1 + 1e-12))
    assert np.all(np.diff(grid.nodes) >= 0.25 * grid.step)
    assert np.all(np.isfinite(grid.log_weights))
    wider, below, _ = grid.extended(prior, False, True)
    assert below == 0 and wider.nodes[-1] <= hi
    np.testing.assert_array_equal(wider.nodes[: len(grid.nodes)], grid.nodes)
    # The trapezoid of the uneven grid integrates the prior's density.
    whole = ThetaGrid.around(prior, 0.5, 0.3, 7.0, 0.8)
    assert whole.nodes[0] == lo and whole.nodes[-1] == hi
    assert np.exp(whole.log_weights).sum() == pytest.approx(hi - lo, rel=1e-12)


def test_warns_when_the_tolerance_is_not_reached(case, monkeypatch):
    monkeypatch.setattr(converged, "MAX_DRAWS", 2 * converged.N_BLOCK)
    monkeypatch.setattr(converged, "MIN_BLOCKS", 2)
    cal = ModularBayesCalibrator(prior=case.prior, random_state=0, discrepancy_tol=1e-4)
    with pytest.warns(UserWarning, match="Monte Carlo tolerance in 256 draws:"):
        cal.fit(
            case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim, y_sim=case.y_sim
        )
    assert cal.discrepancy_draws_ == 2 * converged.N_BLOCK
    assert np.all(np.isfinite(cal.theta_mcse_))


def test_an_unknown_error_doubles_the_draws():
    # A NaN error (a block without any weight has no estimate; it stopped a
    # CI run with "cannot convert float NaN to integer") is not met: twice
    # the blocks, up to the cap, never a crash.
    cap = converged.MAX_DRAWS // converged.N_BLOCK
    assert converged._grown(4, float("nan"), 0.05) == 8
    assert converged._grown(cap, float("nan"), 0.05) == cap
    assert converged._grown(4, 0.1, 0.05) == 8
    assert converged._grown(8, 0.05, 0.05) == 9


def test_default_integrates_to_its_tolerance_and_none_to_16_draws(case):
    # "auto" (the default) is discrepancy_tol=0.05 with one parameter; None
    # keeps module 2's 16 draws and reports their error as the draws see it
    # (skmba.calibration._module3_mixture_error).
    auto = _fit(case, 0, tol="auto")
    sd = np.sqrt(auto.theta_cov_[0, 0])
    relative = auto.theta_mcse_[:, 0] / sd
    assert np.all(relative[:2] <= AUTO_TOL) and np.all(relative[2:] <= 2 * AUTO_TOL)
    assert auto.discrepancy_draws_ >= 512
    explicit = _fit(case, 0, tol=AUTO_TOL)
    np.testing.assert_array_equal(auto.theta_samples_, explicit.theta_samples_)
    cal = _fit(case, 0, tol=None)
    assert cal.discrepancy_draws_ == 16
    assert np.all(np.isfinite(cal.theta_mcse_)) and np.all(cal.theta_mcse_ > 0)
    table = cal.summary()
    assert table["mcse_sd"].iloc[0] == cal.theta_mcse_[1, 0]


@pytest.mark.parametrize("tol", [0.0, -0.1, "0.05", "Auto", np.inf])
def test_discrepancy_tol_is_checked(case, tol):
    cal = ModularBayesCalibrator(prior=case.prior, discrepancy_tol=tol)
    with pytest.raises((ValueError, TypeError), match="discrepancy_tol"):
        cal.fit(
            case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim, y_sim=case.y_sim
        )


def test_summary_and_arviz_carry_the_errors(fits):
    cal = fits[0]
    table = cal.summary()
    np.testing.assert_array_equal(
        table[["mcse_mean", "mcse_sd", "mcse_2.5%", "mcse_97.5%"]].to_numpy()[0],
        cal.theta_mcse_[:, 0],
    )
    assert "Monte Carlo error of mean/sd" in cal.summary(kind="text")
    pytest.importorskip("arviz")
    idata = cal.to_inference_data()
    attrs = idata["posterior"].attrs
    assert attrs["mcse_sd_theta0"] == pytest.approx(cal.theta_mcse_[1, 0])
    assert attrs["discrepancy_draws"] == cal.discrepancy_draws_


def test_confounded_design_converges_in_draws():
    """a1 seed 0 (E confounded with the discrepancy), where 16 draws move
    theta's posterior sd by a factor 1.8 with random_state: at
    discrepancy_tol=0.05 two seeds agree within their reported errors, and
    the errors are within the tolerance (5 s on two cores)."""
    from validation.cases import case_a1

    case = case_a1(0)
    fits = [_fit(case, random_state, tol=0.05) for random_state in (0, 1)]
    sds = [np.sqrt(cal.theta_cov_[0, 0]) for cal in fits]
    se = np.hypot(*(cal.theta_mcse_[1, 0] for cal in fits))
    assert abs(sds[0] - sds[1]) <= 4 * se
    for cal, sd in zip(fits, sds, strict=True):
        assert cal.theta_mcse_[1, 0] <= 0.05 * sd
        assert cal.theta_mcse_[3, 0] <= 0.1 * sd
        assert cal.discrepancy_draws_ >= 4 * converged.N_BLOCK


def test_tolerance_not_applied_is_said(case):
    # The plug-in has nothing to integrate; several parameters go by MCMC
    # over 16 draws: either way the setting is named, not silently dropped.
    cal = ModularBayesCalibrator(
        prior=case.prior, discrepancy_uncertainty="plug-in", discrepancy_tol=0.05
    )
    with pytest.warns(UserWarning, match="discrepancy_tol is not applied"):
        cal.fit(
            case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim, y_sim=case.y_sim
        )
    assert np.all(np.isnan(cal.theta_mcse_)) and cal.discrepancy_draws_ == 1
    cal = ModularBayesCalibrator(
        prior=case.prior, sampler="mcmc", n_samples=200, burn_in=100,
        discrepancy_tol=0.05,
    )  # fmt: skip
    with pytest.warns(UserWarning, match="or one with its quadrature"):
        cal.fit(
            case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim, y_sim=case.y_sim
        )
    # the draws' own estimate of their error, read at the chains' draws
    assert np.all(np.isfinite(cal.theta_mcse_)) and cal.discrepancy_draws_ == 16


@pytest.mark.parametrize(
    ("tol", "entries", "expected"),
    [("auto", 200, AUTO_TOL), ("auto", 201, None), (0.02, 201, 0.02), (None, 50, None)],
)
def test_auto_keeps_16_draws_above_its_field_entries(tol, entries, expected):
    # "auto" stops at AUTO_MAX_ENTRIES measured field entries (each draw
    # costs factorisations of that order); a number asks for the integral
    # whatever the size.
    from types import SimpleNamespace

    from skmba.calibration import _pipeline
    from skmba.calibration._module2_converged import AUTO_MAX_ENTRIES

    assert AUTO_MAX_ENTRIES == 200
    Ys = np.zeros((entries + 1, 1))
    Ys[0] = np.nan  # a gap is not an entry
    said = []
    inputs = SimpleNamespace(
        settings=SimpleNamespace(
            discrepancy_tol=tol, sampler=SimpleNamespace(sampler="auto")
        ),
        prior=SimpleNamespace(dim=1),
        Ys=Ys,
        progress=SimpleNamespace(info=said.append),
    )
    assert _pipeline._tolerance(inputs) == expected
    assert bool(said) == (tol == "auto" and expected is None)


def test_adapted_proposal_stays_proper_when_one_draw_has_all_the_weight():
    # A first round whose weight sits on one draw (Kish size 1) moves the
    # proposal by 1 / (1 + 2 (m + 1)) of the way: its covariance stays the
    # old one's, shrunk by as much, never singular.
    from types import SimpleNamespace

    m = 3
    rng = np.random.default_rng(0)
    V = rng.normal(size=(512, m))
    A = np.full((5, 512), -np.inf)
    A[:, 7] = 0.0  # one draw carries the posterior
    old_cov = converged.INFLATION**2 * np.eye(m)
    space, mode, cov = converged.adapted(
        ("space", np.zeros(m), old_cov), SimpleNamespace(V=V), A
    )
    share = 1.0 / (1.0 + 2 * (m + 1))
    np.testing.assert_allclose(mode, share * V[7])
    np.testing.assert_allclose(cov, (1 - share) * old_cov, rtol=1e-6)
    assert space == "space" and np.all(np.linalg.eigvalsh(cov) > 0)


def test_a_likelihood_that_is_no_number_carries_no_weight():
    # A NaN from a factorisation becomes -inf (no weight), never a NaN
    # posterior; a spline that overflows is replaced by exact values.
    from types import SimpleNamespace

    from skmba.calibration._module2_theta_grid import GridEvaluator, ThetaGrids

    class Stub(GridEvaluator):
        def mixture(self, V):
            values = np.zeros((1, len(V)))
            values[0, 0] = np.nan
            return SimpleNamespace(
                batch_component_log_likelihoods=lambda thetas: np.repeat(
                    values, len(thetas), axis=0
                ),
                models=list(V),
            )

    scaler = SimpleNamespace(theta=lambda t: t)
    evaluate = Stub(None, None, scaler)
    out = evaluate(np.zeros((3, 2)), np.linspace(0.0, 1.0, 4))
    assert np.all(out[:, 0] == -np.inf) and np.all(out[:, 1:] == 0.0)
    prior = check_prior([stats.uniform(0.0, 1.0)])
    grids = ThetaGrids.of(prior, ThetaGrid.around(prior, 0.5, 0.1, 2.0, 1.0), 2)
    L = np.zeros((len(grids.coarse.nodes), 2))
    L[:, 1] = [-1e308 * (-1) ** j for j in range(len(L))]  # overflows the spline
    fine = evaluate.splined(np.zeros((2, 2)), L, grids)
    np.testing.assert_array_equal(fine[:, 0], 0.0)
    # The stub's exact value (its first draw's NaN, as -inf), not a spline
    # through +-1e308.
    assert np.all(fine[:, 1] == -np.inf)


def test_the_grid_evaluator_builds_each_draw_s_model_once(problem):
    # Draws evaluated again (new nodes, the checks) reuse their component and
    # global model; the values are those of a mixture built afresh.
    from skmba.calibration._module2_posterior import (
        DiscrepancyComponent,
        HyperposteriorDraws,
    )
    from skmba.calibration._module2_theta_grid import GridEvaluator
    from skmba.calibration._module3_mixture import ModelMixture
    from skmba.kernels import Gauss

    gm = problem[1]
    built = []

    def component(v):
        built.append(float(v[0]))
        return DiscrepancyComponent(
            Gauss(roughness=1.0 + v[0]),
            0.1 * np.eye(2),
            np.array([0.01, 0.02]),
            "constant",
        )

    evaluate = GridEvaluator(
        gm, SimpleNamespace(component=component), SimpleNamespace(theta=lambda t: t)
    )
    V = np.array([[0.5, 0.0], [1.5, 0.0], [2.5, 0.0]])
    first = evaluate(V, np.array([-0.5, 0.5]))
    again = evaluate(V[::-1], np.array([0.0, 0.5]))
    assert built == [0.5, 1.5, 2.5]
    models = evaluate.models(V)
    assert all(a is b for a, b in zip(evaluate.models(V), models, strict=True))
    fresh = ModelMixture(
        gm,
        HyperposteriorDraws(None, [component(v) for v in V], np.zeros(3), *[None] * 3),
    )
    np.testing.assert_array_equal(
        first, fresh.batch_component_log_likelihoods(np.array([[-0.5], [0.5]]))
    )
    np.testing.assert_array_equal(
        again[:, ::-1], fresh.batch_component_log_likelihoods(np.array([[0.0], [0.5]]))
    )


def test_a_first_round_below_its_share_refits_the_proposal(case, monkeypatch):
    # Every first round counts as missed (share 1): the proposal is refitted
    # once, the draws start again, and the fit completes with its errors.
    calls = []
    refit = converged.adapted

    def counted(*args):
        calls.append(1)
        return refit(*args)

    monkeypatch.setattr(converged, "ADAPT_SHARE", 1.0)
    monkeypatch.setattr(converged, "adapted", counted)
    cal = _fit(case, 0, tol=0.2)
    assert len(calls) == 1
    assert np.all(np.isfinite(cal.theta_mcse_))
