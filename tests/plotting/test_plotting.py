"""Tests of skmba.plotting (headless, Agg backend)."""

import subprocess
import sys
import warnings
from itertools import combinations
from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection, PathCollection, QuadMesh
from matplotlib.figure import Figure
from scipy import stats
from sklearn.exceptions import NotFittedError

from skmba import ModularBayesCalibrator, MultiResponseGP, PreposteriorDesigner
from skmba.datasets import make_cantilever
from skmba.plotting import (
    plot_calibrated_components,
    plot_convergence,
    plot_criterion_by_size,
    plot_criterion_vs_bias,
    plot_gp_prediction,
    plot_posterior,
    plot_traces,
    plot_warning_rate,
)


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def fit_calibrator(data, **params):
    cal = ModularBayesCalibrator(
        prior=data.prior, n_restarts_optimizer=0, random_state=0, **params
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return cal.fit(
            data.X_obs,
            data.y_obs,
            X_sim=data.X_sim,
            theta_sim=data.theta_sim,
            y_sim=data.y_sim,
        )


@pytest.fixture(scope="module")
def data():
    return make_cantilever(40, 15, random_state=2)


@pytest.fixture(scope="module")
def calibrator(data):
    """One parameter: quadrature posterior, no chains."""
    return fit_calibrator(data, n_samples=1000)


@pytest.fixture(scope="module")
def mcmc_calibrator():
    data = make_cantilever(60, 20, parameters=("E", "I"), random_state=0)
    return fit_calibrator(data, n_chains=2, n_samples=300, burn_in=200)


@pytest.fixture(scope="module")
def gp(data):
    rng = np.random.default_rng(0)
    y = data.y_obs + rng.normal(scale=[0.01, 50.0], size=data.y_obs.shape)
    return MultiResponseGP(noise=True).fit(data.X_obs, y), y


def band_limits(band, x):
    """Lower and upper edge of a fill_between band at the abscissae ``x``."""
    vertices = band.get_paths()[0].vertices
    lower, upper = [], []
    for value in x:
        at = vertices[np.isclose(vertices[:, 0], value), 1]
        lower.append(at.min())
        upper.append(at.max())
    return np.array(lower), np.array(upper)


def legend_texts(ax):
    return [t.get_text() for t in ax.get_legend().get_texts()]


# ----------------------------------------------------------------- import


def test_import_skmba_does_not_import_matplotlib():
    code = "import sys, skmba; print('matplotlib' in sys.modules)"
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == "False"


def test_public_names():
    import skmba.plotting

    assert skmba.plotting.__all__ == [
        "plot_calibrated_components",
        "plot_change_history",
        "plot_convergence",
        "plot_criterion_by_size",
        "plot_criterion_vs_bias",
        "plot_gp_prediction",
        "plot_posterior",
        "plot_theta_history",
        "plot_traces",
        "plot_warning_rate",
    ]
    for name in skmba.plotting.__all__:
        assert getattr(skmba.plotting, name).__module__.startswith("skmba.plotting.")


def test_missing_matplotlib_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", None)
    with pytest.raises(ImportError, match=r"pip install skmba\[plot\]"):
        plot_traces(np.zeros((2, 10, 1)))


# ------------------------------------------------------- GP predictions


def test_gp_prediction_1d_bands_are_mean_pm_196_std(gp, data):
    model, y = gp
    X = np.linspace(1e3, 1e4, 40)[::-1]  # any order
    fig = plot_gp_prediction(
        model,
        X,
        X_train=data.X_obs,
        y_train=y,
        names=data.response_names,
        units=data.response_units,
        input_names=["force [N]"],
    )
    assert isinstance(fig, Figure)
    assert len(fig.axes) == 2
    mean, std = model.predict(X[:, None], return_std=True)
    for k, ax in enumerate(fig.axes):
        assert len(ax.collections) == 1  # the band
        assert len(ax.lines) == 2  # mean and training data
        lower, upper = band_limits(ax.collections[0], X)
        np.testing.assert_allclose(lower, mean[:, k] - 1.96 * std[:, k], rtol=1e-10)
        np.testing.assert_allclose(upper, mean[:, k] + 1.96 * std[:, k], rtol=1e-10)
        line = ax.lines[0]
        np.testing.assert_allclose(line.get_xdata(), np.sort(X))
        np.testing.assert_allclose(line.get_ydata(), mean[::-1, k])
        np.testing.assert_allclose(ax.lines[1].get_ydata(), y[:, k])
        assert legend_texts(ax) == ["95 % band", "mean", "training data"]
    assert fig.axes[0].get_xlabel() == ""  # shared x axis: bottom label only
    assert fig.axes[1].get_xlabel() == "force [N]"
    assert fig.axes[0].get_ylabel() == "tip_displacement [mm]"
    assert fig.axes[1].get_ylabel() == "energy [N*mm]"


def test_gp_prediction_one_response_and_noise(gp):
    model, _ = gp
    X = np.linspace(1e3, 1e4, 25)
    ax = plot_gp_prediction(model, X, response=1, include_noise=True)
    assert isinstance(ax, Axes)
    assert ax.get_ylabel() == "y1"
    _, std = model.predict(X[:, None], return_std=True)
    total = np.sqrt(std[:, 1] ** 2 + model.noise_[1])
    lower, upper = band_limits(ax.collections[0], X)
    np.testing.assert_allclose(upper - lower, 2 * 1.96 * total, rtol=1e-10)
    assert legend_texts(ax)[0] == "95 % band, new measurement"
    # by name, into a given Axes, with training inputs as ticks
    _, given = plt.subplots()
    out = plot_gp_prediction(
        model, X, response="b", names=["a", "b"], X_train=X[::5], ax=given
    )
    assert out is given
    assert legend_texts(given) == ["95 % band", "mean", "training inputs"]


def test_gp_prediction_errors(gp):
    model, _ = gp
    X = np.linspace(1e3, 1e4, 5)
    with pytest.raises(TypeError, match="predict"):
        plot_gp_prediction(object(), X)
    with pytest.raises(ValueError, match="fitted on 1 input:"):
        plot_gp_prediction(model, np.zeros((4, 3)))
    with pytest.raises(ValueError, match="response"):
        plot_gp_prediction(model, X, response=2)
    with pytest.raises(ValueError, match="not one of"):
        plot_gp_prediction(model, X, response="energy")
    with pytest.raises(ValueError, match="names has 1"):
        plot_gp_prediction(model, X, names=["only one"])
    with pytest.raises(ValueError, match="y_train needs X_train"):
        plot_gp_prediction(model, X, y_train=np.zeros((3, 2)))
    noise_free = MultiResponseGP().fit(X[:, None], np.sin(X / 1e3))
    with pytest.raises(ValueError, match="noise"):
        plot_gp_prediction(noise_free, X, include_noise=True)


def test_gp_prediction_2d_contours():
    rng = np.random.default_rng(0)
    X = rng.uniform(size=(25, 2))
    y = np.column_stack([np.sin(3 * X[:, 0]) + X[:, 1], X[:, 0] * X[:, 1]])
    model = MultiResponseGP().fit(X, y)
    grid = np.array(np.meshgrid(*[np.linspace(0, 1, 15)] * 2)).reshape(2, -1).T
    fig = plot_gp_prediction(model, grid, X_train=X, names=["a", "b"], units=["mm", ""])
    # 2 responses x (mean, half-width) panels, each with its colorbar
    panels = [ax for ax in fig.axes if ax.get_title()]
    assert [ax.get_title() for ax in panels] == [
        "a: mean",
        "a: 95 % half-width",
        "b: mean",
        "b: 95 % half-width",
    ]
    assert len(fig.axes) == 8
    for ax in panels:
        assert ax.get_xlabel() == "x0" and ax.get_ylabel() == "x1"
        assert legend_texts(ax) == ["training inputs"]
        np.testing.assert_allclose(ax.lines[0].get_xdata(), X[:, 0])
    colorbars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert len(colorbars) == 4
    assert colorbars[0].get_ylabel() == "a [mm]"
    assert colorbars[3].get_ylabel() == "b"
    # the contour levels span the mean and the half-width 1.96 std
    mean, std = model.predict(grid, return_std=True)
    for panel, values in ((panels[0], mean[:, 0]), (panels[3], 1.96 * std[:, 1])):
        levels = panel.collections[0].levels
        assert levels[0] <= values.min() and levels[-1] >= values.max()
        assert levels[-1] - levels[0] < 2 * np.ptp(values)


# ------------------------------------------------ calibrated components


def test_calibrated_components(calibrator, data):
    X = np.linspace(1e3, 1e4, 30)

    def true_discrepancy(X):
        theta = np.broadcast_to(data.theta_true, (len(X), 1))
        return data.reality(X) - data.simulator(X, theta)

    fig = plot_calibrated_components(
        calibrator,
        X,
        X_obs=data.X_obs,
        y_obs=data.y_obs,
        y_true=data.reality,
        discrepancy_true=true_discrepancy,
        names=data.response_names,
        units=data.response_units,
        input_name="force [N]",
    )
    assert isinstance(fig, Figure)
    axes = np.array(fig.axes).reshape(2, 3)
    assert [ax.get_title() for ax in axes[0]] == [
        "model $y^m(x, \\theta)$",
        "discrepancy $\\delta(x)$",
        "observation $y^m + \\delta + \\varepsilon$",
    ]
    assert legend_texts(axes[0, 0]) == ["95 % band", "mean", "observations"]
    assert legend_texts(axes[0, 1]) == [
        "95 % band",
        "mean",
        "true discrepancy",
        "observations - model mean",
    ]
    assert legend_texts(axes[0, 2]) == [
        "95 % band",
        "mean",
        "observations",
        "true process (no noise)",
    ]
    assert axes[1, 0].get_ylabel() == "energy [N*mm]"
    assert axes[1, 2].get_xlabel() == "force [N]"
    methods = ("predict_model", "predict_discrepancy", "predict")
    for j, method in enumerate(methods):
        mean, std = getattr(calibrator, method)(X[:, None], return_std=True)
        for k in range(2):
            lower, upper = band_limits(axes[k, j].collections[0], X)
            np.testing.assert_allclose(lower, mean[:, k] - 1.96 * std[:, k])
            np.testing.assert_allclose(upper, mean[:, k] + 1.96 * std[:, k])
    reality = data.reality(X[:, None])
    np.testing.assert_allclose(axes[0, 2].lines[-1].get_ydata(), reality[:, 0])
    residual = data.y_obs - calibrator.predict_model(data.X_obs)
    np.testing.assert_allclose(axes[1, 1].lines[-1].get_ydata(), residual[:, 1])


def test_calibrated_components_errors(calibrator, gp, data):
    X = np.linspace(1e3, 1e4, 5)
    with pytest.raises(TypeError, match="ModularBayesCalibrator"):
        plot_calibrated_components(gp[0], X)
    with pytest.raises(ValueError, match="has 1 design variable:"):
        plot_calibrated_components(calibrator, np.zeros((5, 2)))
    with pytest.raises(ValueError, match="together"):
        plot_calibrated_components(calibrator, X, X_obs=data.X_obs)
    with pytest.raises(ValueError, match="y_true has shape"):
        plot_calibrated_components(calibrator, X, y_true=np.zeros((4, 2)))
    with pytest.raises(NotFittedError):
        plot_calibrated_components(ModularBayesCalibrator(), X)


# ------------------------------------------------------------ posterior


def test_posterior_from_calibrator(calibrator, data):
    fig = plot_posterior(calibrator, true_value=data.theta_true, names=["E"])
    assert isinstance(fig, Figure) and len(fig.axes) == 1
    ax = fig.axes[0]
    assert legend_texts(ax) == [
        "posterior",
        "95 % credible interval",
        "prior",
        "true",
    ]
    assert ax.get_xlabel() == "E" and ax.get_ylabel() == "density"
    heights = [p.get_height() for p in ax.patches]
    assert len(heights) == 40
    widths = np.array([p.get_width() for p in ax.patches])
    assert np.sum(np.array(heights) * widths) == pytest.approx(1.0)
    interval = np.quantile(calibrator.theta_samples_[:, 0], [0.025, 0.975])
    vertical = [line.get_xdata()[0] for line in ax.lines if line.get_linestyle() == ":"]
    np.testing.assert_allclose(vertical[:2], interval)
    mean = calibrator.theta_samples_.mean()
    assert ax.get_title().startswith(f"E: mean {mean:.5g}")
    # "auto" shows the draws against the prior's range when they and the
    # truth span at least 5 % of it, else zooms on them; "prior" always
    # shows that range; "posterior" zooms on the draws and the truth.
    draws = calibrator.theta_samples_[:, 0]
    span = max(draws.max(), data.theta_true[0]) - min(draws.min(), data.theta_true[0])
    prior_lo, prior_hi = calibrator.prior_.bounds(0.99)[0]
    lo, hi = ax.get_xlim()
    if span >= 0.05 * (prior_hi - prior_lo):
        assert lo < prior_lo and hi > prior_hi
    else:
        assert prior_lo < lo and hi < prior_hi
    fig = plot_posterior(calibrator, true_value=data.theta_true, limits="prior")
    lo, hi = fig.axes[0].get_xlim()
    assert lo < prior_lo and hi > prior_hi
    fig = plot_posterior(calibrator, true_value=data.theta_true, limits="posterior")
    lo, hi = fig.axes[0].get_xlim()
    assert lo < draws.min() and hi > max(draws.max(), data.theta_true[0])
    assert hi - lo < 1.1 * (max(draws.max(), data.theta_true[0]) - draws.min())
    fig = plot_posterior(calibrator, limits="prior")
    lo, hi = fig.axes[0].get_xlim()
    assert lo < 21e3 and hi > 99e3
    prior_line = [line for line in fig.axes[0].lines if line.get_label() == "prior"]
    np.testing.assert_allclose(prior_line[0].get_ydata()[200], 1 / 80e3)


def test_posterior_pairs():
    rng = np.random.default_rng(0)
    cov = [[4e7, -2e12], [-2e12, 1.5e17]]
    draws = rng.multivariate_normal([70e3, 6.8e8], cov, size=5000)
    prior = [stats.uniform(20e3, 80e3), stats.uniform(2.25e8, 9e8)]
    fig = plot_posterior(
        draws,
        prior=prior,
        true_value=[70e3, 6.75e8],
        names=["E", "I"],
        units=["MPa", "mm4"],
    )
    axes = np.array(fig.axes).reshape(2, 2)
    assert axes[1, 0].get_xlabel() == "E [MPa]"
    assert axes[1, 0].get_ylabel() == "I [mm4]"
    assert axes[1, 1].get_xlabel() == "I [mm4]"
    scatter = axes[1, 0].lines[0]
    assert len(scatter.get_xdata()) <= 2000  # thinned
    np.testing.assert_allclose(scatter.get_xdata(), draws[::3, 0])
    true_marker = axes[1, 0].lines[-1]
    assert true_marker.get_label() == "true"
    np.testing.assert_allclose(true_marker.get_xydata(), [[70e3, 6.75e8]])
    assert not axes[0, 1].axison
    rho = np.corrcoef(draws.T)[0, 1]
    assert axes[0, 1].texts[0].get_text() == f"corr(E, I)\n= {rho:.2f}"
    assert legend_texts(axes[0, 1]) == [
        "posterior",
        "95 % credible interval",
        "prior",
        "true",
    ]
    for j, dist in enumerate(prior):  # prior's range shown: posterior is wide
        lo, hi = axes[j, j].get_xlim()
        assert lo < dist.ppf(0.005) and hi > dist.ppf(0.995)
    # uniform prior density of E on the diagonal
    prior_line = next(line for line in axes[0, 0].lines if line.get_label() == "prior")
    inside = (prior_line.get_xdata() > 21e3) & (prior_line.get_xdata() < 99e3)
    np.testing.assert_allclose(prior_line.get_ydata()[inside], 1 / 80e3)


def test_posterior_gaussian_and_generic_priors():
    rng = np.random.default_rng(1)
    draws = rng.normal([65e3, 7e8], [5e3, 1e8], size=(3000, 2))
    mvn = stats.multivariate_normal([53e3, 4.72e8], np.diag([1e8, 4.5e15]))
    fig = plot_posterior(draws, prior=mvn, kind="hist2d")
    axes = np.array(fig.axes).reshape(2, 2)
    assert any(isinstance(c, QuadMesh) for c in axes[1, 0].collections)
    line = next(line for line in axes[1, 1].lines if line.get_label() == "prior")
    expected = stats.norm(4.72e8, np.sqrt(4.5e15)).pdf(line.get_xdata())
    np.testing.assert_allclose(line.get_ydata(), expected)
    assert axes[0, 0].get_title().startswith("θ0: mean")
    # a prior known only through logpdf/rvs: its marginals are histograms
    generic = stats.multivariate_t([65e3, 7e8], np.diag([4e7, 1e16]), df=5)
    fig = plot_posterior(draws, prior=generic)
    labels = [p.get_label() for p in fig.axes[0].patches]
    assert "prior (draws)" in labels


def test_posterior_errors(calibrator):
    draws = np.zeros((10, 2))
    with pytest.raises(TypeError, match="array of posterior draws"):
        plot_posterior(["a", "b"])
    with pytest.raises(NotFittedError):
        plot_posterior(ModularBayesCalibrator())
    with pytest.raises(ValueError, match="true_value must have 2"):
        plot_posterior(draws, true_value=[1.0])
    with pytest.raises(ValueError, match="kind"):
        plot_posterior(draws, kind="kde")
    with pytest.raises(ValueError, match="limits"):
        plot_posterior(draws, limits="all")
    with pytest.raises(ValueError, match="calibration parameters"):
        plot_posterior(draws, prior=[stats.uniform(0, 1)])
    with pytest.raises(ValueError, match="ax must hold 4"):
        plot_posterior(draws + np.arange(2), ax=plt.subplots()[1])


# ---------------------------------------------------------------- traces


def test_traces_from_array():
    rng = np.random.default_rng(0)
    chains = rng.normal([70e3, 7e8], [5e3, 1e8], size=(3, 200, 2))
    fig = plot_traces(
        chains, names=["E", "I"], units=["MPa", "mm4"], true_value=[70e3, 7e8]
    )
    assert isinstance(fig, Figure) and len(fig.axes) == 2
    for p, ax in enumerate(fig.axes):
        assert len(ax.lines) == 4  # three chains and the true value
        for c in range(3):
            np.testing.assert_allclose(ax.lines[c].get_ydata(), chains[c, :, p])
        assert "split R-hat = 1.0" in ax.get_title()
    assert fig.axes[0].get_ylabel() == "E [MPa]"
    assert fig.axes[1].get_xlabel() == "draw (after burn-in)"
    assert legend_texts(fig.axes[0]) == ["chain 1", "chain 2", "chain 3", "true"]
    # a stuck chain shows in R-hat
    chains[0] += 3 * np.array([5e3, 1e8])
    fig = plot_traces(chains)
    rhat = float(fig.axes[0].get_title().split("= ")[1])
    assert rhat > 1.1


def test_traces_from_calibrators(calibrator, mcmc_calibrator):
    with pytest.raises(ValueError, match="sampler='mcmc'"):
        plot_traces(calibrator)
    if hasattr(mcmc_calibrator, "theta_chains_"):
        fig = plot_traces(mcmc_calibrator, names=["E", "I"])
        chains = mcmc_calibrator.theta_chains_
        assert len(fig.axes) == 2
        assert len(fig.axes[0].lines) == chains.shape[0]
        np.testing.assert_allclose(fig.axes[1].lines[0].get_ydata(), chains[0, :, 1])
    else:  # a calibrator without chains asks for the array form
        with pytest.raises(ValueError, match=r"\(n_chains, n_draws, r\)"):
            plot_traces(mcmc_calibrator)


def test_traces_errors():
    with pytest.raises(ValueError, match=r"\(n_chains, n_draws, r\)"):
        plot_traces(np.zeros((100, 2)))
    with pytest.raises(TypeError, match="plot_traces needs"):
        plot_traces([["a"]])
    with pytest.raises(NotFittedError):
        plot_traces(ModularBayesCalibrator())
    with pytest.raises(ValueError, match="true_value"):
        plot_traces(np.zeros((2, 10, 2)), true_value=[1.0, 2.0, 3.0])


# --------------------------------------------------------- sensor design


@pytest.fixture
def designer():
    """Seven responses, all 127 subsets; criterion falls with size."""
    rng = np.random.default_rng(0)
    subsets = [s for k in range(1, 8) for s in combinations(range(7), k)]
    scores = np.array([1.0 / (len(s) + 0.2 * sum(s)) for s in subsets])
    scores = scores * (1 + 0.01 * rng.random(len(subsets)))
    n_mc = 50
    replicate = 1 + 0.5 * rng.standard_normal((n_mc, len(subsets)))
    running = scores * np.cumsum(replicate, axis=0) / np.arange(1, n_mc + 1)[:, None]
    running[-1] = scores
    return SimpleNamespace(
        subsets_=subsets,
        scores_=scores,
        preposterior_cov_=scores[:, None, None] * np.ones((1, 1, 1)),
        convergence_=running,
        n_responses_=7,
        criterion="trace",
    )


def test_criterion_by_size(designer):
    names = list("ABCDEFG")
    ax = plot_criterion_by_size(designer, names=names)
    assert isinstance(ax, Axes)
    maximum, minimum = ax.lines
    sizes = np.array([len(s) for s in designer.subsets_])
    np.testing.assert_array_equal(minimum.get_xdata(), np.arange(1, 8))
    for k, size in enumerate(range(1, 8)):
        members = designer.scores_[sizes == size]
        assert minimum.get_ydata()[k] == members.min()
        assert maximum.get_ydata()[k] == members.max()
    assert minimum.get_linestyle() == "--" and minimum.get_marker() == "o"
    assert maximum.get_linestyle() == "-" and maximum.get_marker() == "x"
    texts = [t.get_text() for t in ax.texts]
    assert texts[0] == "G"  # 1 / (1 + 0.2 * 6): the best single response
    assert texts[-1] == "A, B, C, D, E, F, G"
    assert len(texts) == 7
    assert legend_texts(ax) == ["maximum", "minimum (best)"]
    assert ax.get_xlabel() == "number of sensors (responses)"
    assert ax.get_ylabel() == "preposterior criterion (trace), lower is better"
    # default names
    ax = plot_criterion_by_size(designer)
    assert ax.texts[0].get_text() == "y6"


def test_criterion_vs_bias(designer):
    rng = np.random.default_rng(0)
    bias = 0.1 * designer.scores_ + 0.01 * rng.random(len(designer.scores_))
    ax = plot_criterion_vs_bias(
        designer.scores_, bias, subsets=designer.subsets_, names=list("ABCDEFG")
    )
    assert isinstance(ax, Axes)
    groups = [c for c in ax.collections if isinstance(c, PathCollection)]
    assert len(groups) == 7  # one colour per number of sensors
    assert sum(len(g.get_offsets()) for g in groups) == len(bias)
    np.testing.assert_allclose(
        groups[0].get_offsets(), np.c_[bias, designer.scores_][:7]
    )
    assert legend_texts(ax) == ["1 sensor"] + [f"{k} sensors" for k in range(2, 8)]
    assert ax.get_xlabel() == "identification bias"
    assert not ax.texts
    # from the designer itself, annotated
    ax = plot_criterion_vs_bias(designer, bias, names=list("ABCDEFG"), annotate=True)
    assert len(ax.texts) == len(bias)
    assert ax.texts[7].get_text() == "AB"
    # without subsets: one group
    ax = plot_criterion_vs_bias([1.0, 2.0], [0.1, 0.2])
    assert legend_texts(ax) == ["configurations"]


def test_criterion_vs_bias_errors(designer):
    with pytest.raises(ValueError, match="one of each"):
        plot_criterion_vs_bias([1.0, 2.0], [0.1])
    with pytest.raises(ValueError, match="needs the subsets"):
        plot_criterion_vs_bias([1.0, 2.0], [0.1, 0.2], annotate=True)
    with pytest.raises(ValueError, match="subsets has 1"):
        plot_criterion_vs_bias([1.0, 2.0], [0.1, 0.2], subsets=[(0,)])
    with pytest.raises(TypeError, match="arrays of numbers"):
        plot_criterion_vs_bias(["x"], [0.1])


def test_warning_rate(designer):
    """Each subset at (its largest warning rate, its score), with bars of
    two standard errors; the bound, the lowest criterion and the best
    subset marked; one parameter by name or index."""
    n = len(designer.subsets_)
    rng = np.random.default_rng(1)
    rate = np.round(rng.random((n, 2)) * 10) / 10
    mcse = np.sqrt(rate * (1 - rate) / 10)
    best = int(np.argmin(np.where(rate.max(axis=1) <= 0.5, designer.scores_, np.inf)))
    fitted = SimpleNamespace(
        **vars(designer),
        warning_rate_=rate,
        warning_rate_mcse_=mcse,
        best_subset_=designer.subsets_[best],
        max_warning_rate=0.5,
        prior_=SimpleNamespace(names=["E", "k"]),
    )
    ax = plot_warning_rate(fitted, names=list("ABCDEFG"))
    groups = [c for c in ax.collections if isinstance(c, PathCollection)]
    points = np.concatenate([g.get_offsets() for g in groups])
    sizes = [len(s) for s in designer.subsets_]
    order = np.argsort(sizes, kind="stable")
    np.testing.assert_allclose(points, np.c_[rate.max(axis=1), designer.scores_][order])
    (bars,) = [c for c in ax.collections if isinstance(c, LineCollection)]
    k = int(np.argmax(mcse.max(axis=1)))
    j = int(np.argmax(rate[k]))
    width = np.ptp(bars.get_segments()[k][:, 0])
    np.testing.assert_allclose(width, 4 * mcse[k, j])
    assert ax.lines[0].get_xdata()[0] == 0.5
    assert "max_warning_rate" in legend_texts(ax)
    texts = sorted(t.get_text() for t in ax.texts)
    lowest = designer.subsets_[int(np.argmin(designer.scores_))]
    assert texts == sorted(
        [
            ", ".join("ABCDEFG"[i] for i in lowest) + " (lowest criterion)",
            ", ".join("ABCDEFG"[i] for i in fitted.best_subset_) + " (best_subset_)",
        ]
    )
    assert ax.get_xlabel() == "predicted warning rate (largest over the parameters)"
    for parameter in ("k", 1):
        ax = plot_warning_rate(fitted, parameter=parameter)
        groups = [c for c in ax.collections if isinstance(c, PathCollection)]
        points = np.concatenate([g.get_offsets() for g in groups])
        np.testing.assert_allclose(points[:, 0], rate[order, 1])
        assert ax.get_xlabel() == "predicted warning rate of k"
    with pytest.raises(ValueError, match=r"parameter must be one of \['E', 'k'\]"):
        plot_warning_rate(fitted, parameter="I")
    with pytest.raises(TypeError, match="warning_rate_"):
        plot_warning_rate(designer)


def test_convergence(designer):
    names = list("ABCDEFG")
    ax = plot_convergence(designer, names=names)
    assert isinstance(ax, Axes)
    labels = [line.get_label() for line in ax.get_lines()]
    # best of each size, 5 sizes spread over 1..7 (rounding half to even)
    sizes = [label.count(",") + 1 for label in labels]
    assert sizes == [1, 3, 4, 5, 7]
    assert labels[0] == "G"
    index = designer.subsets_.index((6,))
    np.testing.assert_allclose(
        ax.get_lines()[0].get_ydata(), designer.convergence_[:, index]
    )
    np.testing.assert_array_equal(ax.get_lines()[0].get_xdata(), np.arange(1, 51))
    assert ax.get_xlabel() == "Monte Carlo replicates"
    assert ax.get_ylabel() == "running preposterior criterion (trace)"
    assert ax.get_legend().get_title().get_text() == "responses"
    # chosen subsets, in any order of their responses
    ax = plot_convergence(designer, subsets=[(1, 0), (2,)], names=names)
    assert [line.get_label() for line in ax.get_lines()] == ["A, B", "C"]
    index = designer.subsets_.index((0, 1))
    np.testing.assert_allclose(
        ax.get_lines()[0].get_ydata(), designer.convergence_[:, index]
    )


def test_sensor_plot_errors(designer):
    with pytest.raises(ValueError, match="not evaluated"):
        plot_convergence(designer, subsets=[(0, 9)])
    with pytest.raises(TypeError, match="tuples of response indices"):
        plot_convergence(designer, subsets=[0, 1])
    with pytest.raises(TypeError, match="fitted PreposteriorDesigner"):
        plot_criterion_by_size(SimpleNamespace(scores_=[1.0]))

    class Unfitted:
        def fit(self, X, y):
            return self

    with pytest.raises(NotFittedError, match="not fitted"):
        plot_convergence(Unfitted())
    with pytest.raises(ValueError, match="names has 2"):
        plot_criterion_by_size(designer, names=["A", "B"])
    bad = SimpleNamespace(**{**vars(designer), "convergence_": np.zeros((5, 3))})
    with pytest.raises(ValueError, match="convergence_ has shape"):
        plot_convergence(bad)


# ------------------------------------ several design variables and parameters


def analytic_simulator(X, theta):
    """Two design variables, three parameters (a, b, c), two responses."""
    x0, x1 = X.T
    a, b, c = theta.T
    return np.column_stack([a * x0 + b * x1, c * x0 * x1 + a * x1**2])


def analytic_reality(X):
    truth = np.broadcast_to([1.0, 2.0, 1.0], (len(X), 3))
    return analytic_simulator(X, truth) + 0.05 * np.sin(3 * X[:, :1])


def fit_small(prior, X_obs, y_obs, X_sim, theta_sim, y_sim):
    cal = ModularBayesCalibrator(
        prior=prior,
        n_restarts_optimizer=0,
        n_samples=200,
        burn_in=100,
        n_chains=2,
        random_state=0,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # short chains: R-hat and ESS warn
        return cal.fit(X_obs, y_obs, X_sim=X_sim, theta_sim=theta_sim, y_sim=y_sim)


@pytest.fixture(scope="module")
def cantilever_2x2():
    """Force and moment, E and I (r = 2), named by a dict prior."""
    data = make_cantilever(
        40,
        15,
        design_variables=("force", "moment"),
        parameters=("E", "I"),
        random_state=0,
    )
    prior = dict(zip(data.parameter_names, data.prior, strict=True))
    cal = fit_small(
        prior, data.X_obs, data.y_obs, data.X_sim, data.theta_sim, data.y_sim
    )
    return data, cal


@pytest.fixture(scope="module")
def analytic_2x3():
    """Two design variables in [0, 1]^2, three parameters a, b, c (r = 3)."""
    rng = np.random.default_rng(0)
    u = stats.qmc.LatinHypercube(d=5, seed=0).random(60)
    X_sim = u[:, :2]
    theta_sim = np.column_stack([0.5 + u[:, 2], 1.0 + 2.0 * u[:, 3], 2.0 * u[:, 4]])
    X_obs = stats.qmc.LatinHypercube(d=2, seed=1).random(15)
    y_obs = analytic_reality(X_obs) + 0.01 * rng.standard_normal((15, 2))
    prior = {
        "a": stats.uniform(0.5, 1.0),
        "b": stats.uniform(1.0, 2.0),
        "c": stats.uniform(0.0, 2.0),
    }
    y_sim = analytic_simulator(X_sim, theta_sim)
    cal = fit_small(prior, X_obs, y_obs, X_sim, theta_sim, y_sim)
    return SimpleNamespace(X_obs=X_obs, y_obs=y_obs), cal


def without_warnings(tmp_path, plot, *args, **kwargs):
    """``plot(*args, **kwargs)`` and its PNG, with warnings as errors."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = plot(*args, **kwargs)
        figure = out if isinstance(out, Figure) else out.figure
        path = tmp_path / f"{plot.__name__}.png"
        figure.savefig(path, dpi=40)
    assert path.stat().st_size > 0
    return out


def test_gp_prediction_on_a_slice_of_two_design_variables(cantilever_2x2, tmp_path):
    """The calibrated prediction along the force at one moment: a line in
    the plane, which a Delaunay triangulation (qhull) cannot handle."""
    data, cal = cantilever_2x2
    X = np.column_stack([np.linspace(1e4, 1e3, 20), np.full(20, 1e7)])
    fig = without_warnings(
        tmp_path,
        plot_gp_prediction,
        cal,
        X,
        X_train=data.X_obs,
        y_train=data.y_obs,
        names=data.response_names,
        input_names=["force", "moment"],
    )
    assert len(fig.axes) == 2  # one column: the slice X is
    mean, std = cal.predict(X[::-1], return_std=True)
    for k, ax in enumerate(fig.axes):
        lower, upper = band_limits(ax.collections[0], X[::-1, 0])
        np.testing.assert_allclose(upper - lower, 2 * 1.96 * std[:, k])
        np.testing.assert_allclose(ax.lines[0].get_ydata(), mean[:, k])
        np.testing.assert_allclose(ax.lines[1].get_xdata(), data.X_obs[:, 0])
    assert legend_texts(fig.axes[0]) == [
        "95 % band",
        "mean",
        "training data (projected)",
    ]
    assert fig.axes[1].get_xlabel() == "force\n(moment = 1e7)"
    # the same slice asked for by vary and fixed, from any points
    ax = plot_gp_prediction(cal, data.X_obs, vary=0, fixed={1: 1e7}, response=0)
    assert ax.get_xlabel() == "x0\n(x1 = 1e7)"
    x = np.sort(data.X_obs[:, 0])
    np.testing.assert_allclose(ax.lines[0].get_xdata(), x)
    expected = cal.predict(np.column_stack([x, np.full(len(x), 1e7)]))[:, 0]
    np.testing.assert_allclose(ax.lines[0].get_ydata(), expected)


def test_gp_prediction_grid_of_design_variables(tmp_path):
    rng = np.random.default_rng(0)
    X = rng.uniform(size=(30, 3))
    y = np.column_stack([np.sin(3 * X[:, 0]) + X[:, 1] ** 2 + X[:, 2], X[:, 0]])
    gp = MultiResponseGP(random_state=0).fit(X, y)
    fig = without_warnings(
        tmp_path, plot_gp_prediction, gp, X, fixed={2: 0.25}, names=["a", "b"]
    )
    axes = np.array(fig.axes).reshape(2, 2)  # responses x varied inputs 0, 1
    held = (X.min(axis=0) + X.max(axis=0)) / 2
    for c in range(2):
        x = np.unique(X[:, c])
        points = np.tile([*held[:2], 0.25], (len(x), 1))
        points[:, c] = x
        mean = gp.predict(points)
        for k in range(2):
            np.testing.assert_allclose(axes[k, c].lines[0].get_xdata(), x)
            np.testing.assert_allclose(axes[k, c].lines[0].get_ydata(), mean[:, k])
    assert axes[1, 0].get_xlabel() == f"x0\n(x1 = {held[1]:.5g}, x2 = 0.25)"
    assert axes[1, 1].get_xlabel().startswith("x1\n(x0 = ")
    assert [ax.get_ylabel() for ax in axes[:, 0]] == ["a", "b"]
    # "all": one column per input X spans; an input held by fixed may vary
    fig = plot_gp_prediction(gp, X, vary="all", fixed={2: 0.25})
    assert len(fig.axes) == 6
    ax = plot_gp_prediction(gp, X, vary=[2], response="y1")
    assert ax.get_xlabel().startswith("x2\n")


def test_gp_prediction_plane_needs_no_triangulation(tmp_path):
    """Two inputs spanned by X: contours on a grid, also for points on a
    line (singular for a triangulation)."""
    rng = np.random.default_rng(1)
    X = rng.uniform(size=(20, 2))
    gp = MultiResponseGP(random_state=0).fit(X, X[:, 0] + np.cos(3 * X[:, 1]))
    diagonal = np.column_stack([np.linspace(0, 1, 10)] * 2)
    fig = without_warnings(tmp_path, plot_gp_prediction, gp, diagonal, X_train=X)
    panel = fig.axes[0]
    assert panel.get_title() == "y0: mean"
    assert panel.get_xlim() == (0.0, 1.0) and panel.get_ylim() == (0.0, 1.0)
    u = np.linspace(0, 1, 50)
    grid = np.column_stack([g.ravel() for g in np.meshgrid(u, u)])
    mean = gp.predict(grid)
    levels = panel.collections[0].levels
    assert levels[0] <= mean.min() and levels[-1] >= mean.max()


def test_calibrated_components_along_one_design_variable(cantilever_2x2, tmp_path):
    data, cal = cantilever_2x2
    X = np.column_stack([np.linspace(1e3, 1e4, 15), np.linspace(1e6, 3e7, 15)])
    fig = without_warnings(
        tmp_path,
        plot_calibrated_components,
        cal,
        X,
        vary="force",
        fixed={"moment": 2e7},
        X_obs=data.X_obs,
        y_obs=data.y_obs,
        y_true=data.reality,
        names=data.response_names,
        units=data.response_units,
        input_names=["force", "moment"],
    )
    axes = np.array(fig.axes).reshape(2, 3)
    points = np.column_stack([X[:, 0], np.full(15, 2e7)])
    methods = ("predict_model", "predict_discrepancy", "predict")
    for j, method in enumerate(methods):
        mean, std = getattr(cal, method)(points, return_std=True)
        for k in range(2):
            lower, upper = band_limits(axes[k, j].collections[0], X[:, 0])
            np.testing.assert_allclose(lower, mean[:, k] - 1.96 * std[:, k])
            np.testing.assert_allclose(upper, mean[:, k] + 1.96 * std[:, k])
    np.testing.assert_allclose(
        axes[0, 2].lines[-1].get_ydata(), data.reality(points)[:, 0]
    )
    assert legend_texts(axes[0, 0]) == ["95 % band", "mean", "observations (projected)"]
    np.testing.assert_allclose(axes[0, 0].lines[1].get_xdata(), data.X_obs[:, 0])
    assert axes[1, 1].get_xlabel() == "force\n(moment = 2e7)"
    assert axes[1, 0].get_ylabel() == "energy [N*mm]"


def test_calibrated_components_grid_of_design_variables(analytic_2x3, tmp_path):
    data, cal = analytic_2x3
    fig = without_warnings(
        tmp_path,
        plot_calibrated_components,
        cal,
        X_obs=data.X_obs,
        y_obs=data.y_obs,
        y_true=analytic_reality,
    )
    axes = np.array(fig.axes).reshape(4, 3)  # (x0: y0, y1), (x1: y0, y1)
    lo, hi = data.X_obs.min(axis=0), data.X_obs.max(axis=0)
    middle = (lo + hi) / 2
    assert axes[1, 0].get_xlabel() == f"x0\n(x1 = {middle[1]:.5g})"
    assert axes[3, 2].get_xlabel() == f"x1\n(x0 = {middle[0]:.5g})"
    assert axes[0, 0].get_xlabel() == "" and axes[2, 0].get_xlabel() == ""
    assert [ax.get_ylabel() for ax in axes[:, 0]] == ["y0", "y1", "y0", "y1"]
    x1 = np.linspace(lo[1], hi[1], 50)
    points = np.column_stack([np.full(50, middle[0]), x1])
    mean = cal.predict_model(points)
    np.testing.assert_allclose(axes[3, 0].lines[0].get_xdata(), x1)
    np.testing.assert_allclose(axes[3, 0].lines[0].get_ydata(), mean[:, 1])
    # one design variable of the two, by index
    fig = plot_calibrated_components(cal, vary=1, fixed={0: 0.2})
    assert len(fig.axes) == 6
    assert fig.axes[-1].get_xlabel() == "x1\n(x0 = 0.2)"


def test_calibrated_components_slice_errors(cantilever_2x2, analytic_2x3):
    data, cal = cantilever_2x2
    X = data.X_obs
    with pytest.raises(ValueError, match="both varied and fixed"):
        plot_calibrated_components(cal, X, vary=0, fixed={0: 2e3})
    with pytest.raises(ValueError, match="not a design variable"):
        plot_calibrated_components(cal, X, vary="force")
    with pytest.raises(ValueError, match="index in"):
        plot_calibrated_components(cal, X, vary=2)
    with pytest.raises(ValueError, match="give input_names"):
        plot_calibrated_components(cal, X, input_name="force")
    with pytest.raises(ValueError, match="as a function of X"):
        plot_calibrated_components(cal, X, vary=0, y_true=data.y_obs_true)
    with pytest.raises(ValueError, match="one value"):
        plot_calibrated_components(cal, np.column_stack([X[:, 0], X[:, 0] * 0]), vary=1)
    with pytest.raises(ValueError, match="spans no range"):
        plot_calibrated_components(cal, X, fixed={0: 2e3, 1: 1e7})
    with pytest.raises(TypeError, match="fixed must be a dict"):
        plot_calibrated_components(cal, X, fixed=[2e3])
    with pytest.raises(ValueError, match="X_obs has 1 columns"):
        plot_calibrated_components(cal, X, X_obs=X[:, :1], y_obs=data.y_obs)


@pytest.mark.parametrize("problem", ["cantilever_2x2", "analytic_2x3"])
def test_posterior_and_traces_named_by_the_calibrator(problem, request, tmp_path):
    _, cal = request.getfixturevalue(problem)
    names = cal.parameter_names_
    r = len(names)
    assert names == (["E", "I"] if r == 2 else ["a", "b", "c"])
    fig = without_warnings(tmp_path, plot_posterior, cal)
    axes = np.array(fig.axes).reshape(r, r)
    assert [ax.get_xlabel() for ax in axes[-1]] == names
    assert [ax.get_ylabel() for ax in axes[1:, 0]] == names[1:]
    assert axes[0, 0].get_title().startswith(f"{names[0]}: mean")
    fig = without_warnings(tmp_path, plot_traces, cal)
    assert [ax.get_ylabel() for ax in fig.axes] == names
    assert fig.axes[-1].get_title().startswith(f"{names[-1]}: split R-hat")
    # names= still wins
    fig = plot_traces(cal, names=[f"p{j}" for j in range(r)])
    assert fig.axes[0].get_ylabel() == "p0"


def test_posterior_and_traces_from_inference_data(analytic_2x3, tmp_path):
    arviz = pytest.importorskip("arviz")
    rng = np.random.default_rng(0)
    chains = rng.normal([1.0, 5.0, -2.0], [0.1, 0.5, 0.2], size=(3, 100, 3))
    idata = arviz.from_dict(
        posterior={"E": chains[..., 0], "k": chains[..., 1:]},
        prior={"E": rng.uniform(0.5, 1.5, (1, 400)), "k": rng.normal(size=(1, 400, 2))},
    )
    fig = without_warnings(tmp_path, plot_traces, idata, true_value=[1.0, 5.0, -2.0])
    assert [ax.get_ylabel() for ax in fig.axes] == ["E", "k[0]", "k[1]"]
    for p, ax in enumerate(fig.axes):
        for c in range(3):
            np.testing.assert_allclose(ax.lines[c].get_ydata(), chains[c, :, p])
    fig = without_warnings(tmp_path, plot_posterior, idata)
    axes = np.array(fig.axes).reshape(3, 3)
    assert [ax.get_xlabel() for ax in axes[-1]] == ["E", "k[0]", "k[1]"]
    assert "prior (draws)" in [p.get_label() for p in axes[0, 0].patches]
    heights = [p.get_height() for p in axes[2, 2].patches[:40]]
    expected, _ = np.histogram(chains[..., 2], bins=40, density=True)
    np.testing.assert_allclose(heights, expected)
    # ArviZ 1.x returns an xarray DataTree
    xarray = pytest.importorskip("xarray")
    if hasattr(xarray, "DataTree"):
        tree = xarray.DataTree.from_dict(
            {"posterior": idata.posterior, "prior": idata.prior}
        )
        fig = plot_posterior(tree)
        assert "prior (draws)" in [p.get_label() for p in fig.axes[0].patches]
        fig = plot_traces(tree)
        assert [ax.get_ylabel() for ax in fig.axes] == ["E", "k[0]", "k[1]"]
    # the posterior group alone, with names given
    fig = plot_posterior(idata.posterior, names=["a", "b", "c"])
    assert np.array(fig.axes).reshape(3, 3)[-1, 0].get_xlabel() == "a"
    # the calibrator's own ArviZ export
    _, cal = analytic_2x3
    exported = cal.to_inference_data()
    fig = without_warnings(tmp_path, plot_traces, exported)
    assert [ax.get_ylabel() for ax in fig.axes] == ["a", "b", "c"]
    np.testing.assert_allclose(
        fig.axes[1].lines[1].get_ydata(), cal.theta_chains_[1, :, 1]
    )


def test_traces_refuse_quadrature_inference_data(calibrator):
    pytest.importorskip("arviz")
    with pytest.raises(ValueError, match="quadrature"):
        plot_traces(calibrator.to_inference_data())
    fig = plot_posterior(calibrator.to_inference_data())
    assert fig.axes[0].get_xlabel() == calibrator.parameter_names_[0]


def test_inference_data_errors():
    xarray = pytest.importorskip("xarray")
    no_chain = xarray.Dataset({"E": (("draw",), np.zeros(10))})
    with pytest.raises(ValueError, match=r"expected \(chain, draw"):
        plot_posterior(no_chain)
    with pytest.raises(ValueError, match="no variables"):
        plot_traces(xarray.Dataset())


def test_designer_figures_named_by_response_names(designer, tmp_path):
    named = SimpleNamespace(**vars(designer), response_names_=list("ABCDEFG"))
    ax = without_warnings(tmp_path, plot_criterion_by_size, named)
    assert ax.texts[0].get_text() == "G"
    assert ax.texts[-1].get_text() == "A, B, C, D, E, F, G"
    ax = without_warnings(tmp_path, plot_convergence, named, subsets=[(1, 0)])
    assert [line.get_label() for line in ax.get_lines()] == ["A, B"]
    bias = np.linspace(0.0, 1.0, len(named.scores_))
    ax = without_warnings(tmp_path, plot_criterion_vs_bias, named, bias, annotate=True)
    assert ax.texts[7].get_text() == "AB"
    # names= wins; the default stays y0, y1, ...
    words = [f"s{k}" for k in range(7)]
    ax = plot_criterion_by_size(named, names=words)
    assert ax.texts[0].get_text() == "s6"
    assert plot_criterion_by_size(designer).texts[0].get_text() == "y6"
    wrong = SimpleNamespace(**vars(designer), response_names_=["A"])
    with pytest.raises(ValueError, match="response_names_ has 1 entries"):
        plot_convergence(wrong)
    with pytest.raises(ValueError, match="subsets use response 6"):
        plot_criterion_vs_bias(
            designer.scores_, bias, subsets=designer.subsets_, names=["A", "B"]
        )


def test_designer_subsets_by_response_name(designer):
    """Response names go wherever indices do, resolved against the
    designer's response_names_ (the columns of a DataFrame y), or against
    names= with plain scores; names and indices mix."""
    names = ["tip", "energy", "rotation", "mid", "quarter", "shear", "strain"]
    named = SimpleNamespace(**vars(designer), response_names_=names)
    ax = plot_convergence(named, subsets=[("tip",), ("energy", "tip"), (2, "mid")])
    assert [line.get_label() for line in ax.get_lines()] == [
        "tip",
        "tip, energy",
        "rotation, mid",
    ]
    for line, subset in zip(ax.get_lines(), [(0,), (0, 1), (2, 3)], strict=True):
        index = designer.subsets_.index(subset)
        np.testing.assert_array_equal(line.get_ydata(), designer.convergence_[:, index])
    by_index = plot_convergence(named, subsets=[(0,), (1, 0), (2, 3)])
    for a, b in zip(ax.get_lines(), by_index.get_lines(), strict=True):
        np.testing.assert_array_equal(a.get_ydata(), b.get_ydata())

    # With a designer, against its response_names_ ...
    bias = np.linspace(0.0, 1.0, len(designer.scores_))
    spelled = [tuple(names[k] for k in s) for s in designer.subsets_]
    ax = plot_criterion_vs_bias(named, bias, subsets=spelled, annotate=True)
    reference = plot_criterion_vs_bias(named, bias, annotate=True)
    assert [t.get_text() for t in ax.texts] == [t.get_text() for t in reference.texts]
    assert ax.texts[7].get_text() == "tip, energy"
    for a, b in zip(ax.collections, reference.collections, strict=True):
        np.testing.assert_array_equal(a.get_offsets(), b.get_offsets())
    # ... and with plain scores, against names=.
    scores = designer.scores_[[0, 7, 6]]
    ax = plot_criterion_vs_bias(
        scores,
        bias[:3],
        subsets=[("tip",), ("energy", "tip"), ("strain",)],
        names=names,
        annotate=True,
    )
    assert [t.get_text() for t in ax.texts] == ["tip", "energy, tip", "strain"]
    singles = next(c for c in ax.collections if isinstance(c, PathCollection))
    np.testing.assert_array_equal(
        singles.get_offsets(), np.c_[bias[:3], scores][[0, 2]]
    )

    # Unknown names: a ValueError naming the argument and listing the names.
    with pytest.raises(
        ValueError,
        match=r"subsets entry \('tip', 'torsion'\): unknown response 'torsion'; "
        r"the responses are \['tip', 'energy', 'rotation', 'mid', 'quarter', "
        r"'shear', 'strain'\]",
    ):
        plot_convergence(named, subsets=[("tip", "torsion")])
    with pytest.raises(ValueError, match=r"subsets entry \('torsion',\): unknown"):
        plot_criterion_vs_bias(
            scores, bias[:3], subsets=[("tip",), ("torsion",), (6,)], names=names
        )
    # Names without names to resolve them: what to do instead.
    with pytest.raises(ValueError, match="fitted on an array y without names"):
        plot_convergence(designer, subsets=[("tip",)])
    with pytest.raises(ValueError, match=r"no response names: pass names="):
        plot_criterion_vs_bias(scores, bias[:3], subsets=[("tip",), (0, 1), (6,)])
    with pytest.raises(TypeError, match="tuples of response indices or names"):
        plot_convergence(named, subsets=["tip"])


def test_a_plot_given_another_kind_of_fitted_estimator_names_the_kind(calibrator):
    """A fitted designer in a calibrator's plot (and the reverse) was called
    'not fitted'."""
    sims = make_cantilever(20, random_state=0)
    designer = PreposteriorDesigner(
        sims.prior,
        calibrator=ModularBayesCalibrator(n_restarts_optimizer=0),
        n_design=5,
        n_mc=2,
        random_state=0,
    ).fit(np.hstack([sims.X_sim, sims.theta_sim]), sims.y_sim)
    wants_calibrator = "needs a fitted ModularBayesCalibrator; got a fitted Prepos"
    with pytest.raises(TypeError, match=wants_calibrator):
        plot_posterior(designer)
    with pytest.raises(TypeError, match=wants_calibrator):
        plot_traces(designer)
    wants_designer = "needs a fitted PreposteriorDesigner; got a fitted ModularBay"
    with pytest.raises(TypeError, match=wants_designer):
        plot_convergence(calibrator)
    with pytest.raises(NotFittedError, match="not fitted: call fit"):
        plot_criterion_by_size(PreposteriorDesigner())


def test_gp_prediction_labels_the_responses_of_a_table(data):
    import pandas as pd

    y = pd.DataFrame(data.y_obs, columns=["tip", "energy"])
    gp = MultiResponseGP(noise=True).fit(data.X_obs, y)
    assert gp.response_names_ == ["tip", "energy"]
    fig = plot_gp_prediction(gp, data.X_obs)
    titles = " ".join(ax.get_ylabel() + ax.get_title() for ax in fig.axes)
    assert "tip" in titles and "energy" in titles
    assert MultiResponseGP().fit(data.X_obs, data.y_obs).response_names_ is None
