"""Module 3 through a low-rank model term: the determinant lemma's values
are the dense path's, where the emulator knows the simulator well at the
field points, and the dense path takes over where it does not."""

import types

import numpy as np
import pytest

import skmba.calibration._module3_mixture as mixture_module
from skmba import MultiResponseGP
from skmba.calibration._module1_emulator import Emulator
from skmba.calibration._module3_likelihood import GlobalModel, schur_log_likelihoods
from skmba.calibration._module3_low_rank import (
    LOW_RANK_TOL,
    fixed_factors,
    low_rank_log_likelihoods,
    max_low_rank,
    model_term_factor,
)
from skmba.calibration._module3_mixture import LOW_RANK_MIN_THETAS, ModelMixture
from skmba.kernels import Gauss
from tests.conftest import discrepancy, mixture_draws


@pytest.fixture(scope="module")
def smooth_mixture():
    """A smooth emulator of 81 runs on a grid of [x, theta], 40 field points
    (m = 80): its model term has a small numerical rank (12)."""
    grid = np.linspace(-1, 1, 9)
    X_m = np.array([(a, b) for a in grid for b in grid])
    Y_m = np.column_stack([np.sin(2 * X_m[:, 0]) * X_m[:, 1], np.cos(X_m.sum(axis=1))])
    gp = MultiResponseGP(
        Gauss(roughness=[1.0, 1.0]),
        regression="linear",
        alpha=1e-8,
        optimizer=None,
        normalize_y=False,
    ).fit(X_m, Y_m)
    X_e = np.linspace(-0.9, 0.9, 40)[:, None]
    Y_e = np.column_stack([np.sin(2 * X_e[:, 0]) * 0.3, np.cos(X_e[:, 0] + 0.3)])
    Y_e = Y_e + 0.01 * np.random.default_rng(1).standard_normal(Y_e.shape)
    gm = GlobalModel(
        Emulator(gp, X_m, Y_m, "linear"),
        X_e,
        Y_e,
        discrepancy(0.1 * np.eye(2), np.array([0.01, 0.02])),
    )
    return ModelMixture(gm, mixture_draws())


def _dense(mix, thetas, monkeypatch):
    with monkeypatch.context() as patch:
        patch.setattr(mixture_module, "LOW_RANK_MIN_THETAS", len(thetas) + 1)
        return mix.batch_component_log_likelihoods(thetas)


def test_the_low_rank_values_are_the_dense_ones(smooth_mixture, monkeypatch):
    """A batch of 40 thetas: the model term's rank is within the cost
    rule's, and every (theta, draw) value is the dense path's within m times
    LOW_RANK_TOL nats (8e-5): what is dropped, below the threshold on every
    remaining diagonal entry, holds at most m thresholds of trace, over
    Schur complements no smaller than the noise floor (measured: 2.9e-6).
    A wrong term of the determinant lemma or of Woodbury's identity would
    be off by nats."""
    mix = smooth_mixture
    thetas = np.linspace(-0.95, 0.95, 40)[:, None]
    _, terms = mix.base.conditionals(thetas)
    m = terms.shape[1]
    max_rank = max_low_rank(m, mix.base.P + 1)
    U = model_term_factor(terms, min(mdl.noise_floor for mdl in mix.models), max_rank)
    assert U is not None and U.shape[2] <= max_rank
    used = []
    original = mixture_module.low_rank_log_likelihoods

    def spy(*args):
        values = original(*args)
        used.append(True)  # completed: the dense path did not take over
        return values

    monkeypatch.setattr(mixture_module, "low_rank_log_likelihoods", spy)
    low = mix.batch_component_log_likelihoods(thetas)
    assert used
    dense = _dense(mix, thetas, monkeypatch)
    bound = terms.shape[1] * LOW_RANK_TOL
    assert np.max(np.abs(low - dense)) <= bound
    # and the mixture's own values, one theta at a time (the dense path)
    single = [mix.component_log_likelihoods(t) for t in thetas[::13]]
    np.testing.assert_allclose(low[::13], single, rtol=0, atol=bound)


def test_a_model_term_of_high_rank_is_left_to_the_dense_path(problem, monkeypatch):
    """The rough Exp emulator of 14 runs (the shared problem, m = 12): no
    factor within the cost rule's rank (6) holds its model term (it needs
    all 12 columns), and the batch's values are the dense path's to the
    bit."""
    mix = ModelMixture(problem[1], mixture_draws())
    thetas = np.linspace(-0.9, 0.9, LOW_RANK_MIN_THETAS)[:, None]
    _, terms = mix.base.conditionals(thetas)
    max_rank = max_low_rank(terms.shape[1], mix.base.P + 1)
    assert max_rank == 6
    assert model_term_factor(terms, 0.005, max_rank) is None
    assert model_term_factor(terms, 0.005, terms.shape[1]).shape[2] == 12
    np.testing.assert_array_equal(
        mix.batch_component_log_likelihoods(thetas), _dense(mix, thetas, monkeypatch)
    )


def test_the_factor_holds_the_term_to_its_threshold():
    """A term of rank 3 plus a part of rank 40 below the threshold: U U'
    differs from it by no more than that part, and the rank is 3."""
    rng = np.random.default_rng(0)
    A = rng.normal(size=(2, 40, 3))
    small = rng.normal(size=(2, 40, 40))
    floor = 1e-3
    tiny = 0.1 * LOW_RANK_TOL * floor / 40
    terms = A @ np.swapaxes(A, 1, 2) + tiny * small @ np.swapaxes(small, 1, 2) / 40
    U = model_term_factor(terms, floor, 10)
    assert U.shape == (2, 40, 3)
    gap = np.linalg.eigvalsh(terms - U @ np.swapaxes(U, 1, 2))
    assert np.all(np.abs(gap) <= LOW_RANK_TOL * floor)


def _regression_problem(scales, rng, m=30, rho=4, draws=3, thetas=5):
    """Fixed parts, a model-term factor, field rows whose regression
    columns are scaled by ``scales`` (P of them, then the data), and a
    simulation block of two rows scaled alike."""
    A = rng.normal(size=(draws, m, m)) / np.sqrt(m)
    fixed = A @ np.swapaxes(A, 1, 2) + 0.5 * np.eye(m)
    U = 0.3 * rng.normal(size=(thetas, m, rho))
    c = len(scales)
    Z = rng.normal(size=(thetas, m, c)) * scales
    top = np.triu(rng.normal(size=(2, c)) + 3 * np.eye(2, c)) * scales
    model = types.SimpleNamespace(
        top=top, rss_top_perp=1.0, log_det_A=0.5, N=4, q=1, n_observed=m
    )
    return fixed, U, Z, model


def _both_paths(fixed, U, Z, model):
    K, m, _ = fixed.shape
    B = len(U)
    low = low_rank_log_likelihoods(*fixed_factors(fixed), U, Z, model)
    S = (fixed[None] + (U @ np.swapaxes(U, 1, 2))[:, None]).reshape(B * K, m, m)
    Zs = np.broadcast_to(Z[:, None], (B, K, *Z.shape[1:])).reshape(B * K, m, -1)
    dense = schur_log_likelihoods(S, Zs, 0.5, model.top, 1.0, 0.5, 4 + m)
    return low, dense.reshape(B, K)


def test_regression_columns_of_other_scales_stay_low_rank():
    """Columns 1e6 apart in scale (the regression's factor's diagonal too)
    are no rank deficiency: the low-rank path gives the dense values. (A
    check on the ratio of the diagonal entries sent 4.7.3's batches to the
    dense path, whose fit then took 12.3 s instead of 7.3.)"""
    rng = np.random.default_rng(0)
    problem = _regression_problem(np.array([1.0, 1e-6, 1.0, 1.0]), rng)
    low, dense = _both_paths(*problem)
    np.testing.assert_allclose(low, dense, rtol=1e-10, atol=1e-8)


def test_a_nearly_dependent_regression_column_is_left_to_the_dense_path():
    """A column within 1e-6 of another's span (sine) is beyond what the
    Gram matrix resolves: the low-rank path refuses it."""
    rng = np.random.default_rng(1)
    fixed, U, Z, model = _regression_problem(np.ones(4), rng)
    Z[:, :, 1] = Z[:, :, 0] + 1e-6 * Z[:, :, 1]
    model.top[:, 1] = model.top[:, 0] + 1e-6 * model.top[:, 1]
    with pytest.raises(np.linalg.LinAlgError, match="rank-deficient"):
        low_rank_log_likelihoods(*fixed_factors(fixed), U, Z, model)
