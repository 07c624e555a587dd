"""The prefix tree of response subsets equals each subset's own likelihood."""

import itertools

import numpy as np
import pytest
from test_subset_likelihood import _three_response_problem

from skmba._core.regression import regression_basis
from skmba.calibration._module1_emulator import Emulator
from skmba.kernels import Gauss
from skmba.sensor_design import _subset_tree
from skmba.sensor_design._subset_likelihood import FieldDesignEmulator, SubsetLikelihood
from skmba.sensor_design._subset_tree import FieldTerms, subset_tree_log_likelihoods


def _fields_and_design():
    gp, X_m, Y_m, X_e, Y_e, sigma2_d, noise = _three_response_problem()
    design = FieldDesignEmulator(Emulator(gp, X_m, Y_m, "linear"), X_e)
    rng = np.random.default_rng(7)
    A = rng.normal(size=(3, 3))
    fields = [
        FieldTerms(Y_e, Gauss(roughness=2.0)(X_e), sigma2_d, noise),
        FieldTerms(
            Y_e + 0.3 * rng.normal(size=Y_e.shape),
            Gauss(roughness=0.5)(X_e),
            0.05 * (A @ A.T + np.eye(3)),
            np.array([0.03, 0.001, 0.01]),
        ),
    ]
    return design, X_e, fields


def _one_by_one(design, X_e, fields, subsets, H_d, pieces):
    return np.array(
        [
            [
                SubsetLikelihood(
                    design, list(s), f.Y_e, f.R_d, H_d, f.sigma2_d, f.noise
                ).log_likelihood(pieces)
                for f in fields
            ]
            for s in subsets
        ]
    )


@pytest.mark.parametrize("regression", ["constant", "linear"])
def test_every_subset_equals_its_own_factorisation(regression):
    design, X_e, fields = _fields_and_design()
    H_d = regression_basis(X_e, regression)
    pieces = design.pieces(np.array([[-0.7], [0.1], [0.9], [0.4]]))
    subsets = [s for m in range(1, 4) for s in itertools.combinations(range(3), m)]
    tree = subset_tree_log_likelihoods(design, subsets, fields, H_d, pieces)
    assert tree.shape == (7, 2, 4)
    reference = _one_by_one(design, X_e, fields, subsets, H_d, pieces)
    np.testing.assert_allclose(tree, reference, rtol=1e-10, atol=1e-9)


@pytest.mark.parametrize("smallest", [1, 10**6], ids=["triangular", "lu"])
def test_both_ways_of_whitening_a_node_equal_the_subsets_own(monkeypatch, smallest):
    # TRIANGULAR_MIN_N picks per-matrix triangular solves (large designs) or
    # numpy's batched LU solve (small ones): both give each subset's value.
    monkeypatch.setattr(_subset_tree, "TRIANGULAR_MIN_N", smallest)
    design, X_e, fields = _fields_and_design()
    H_d = regression_basis(X_e, "linear")
    pieces = design.pieces(np.array([[-0.5], [0.3], [0.8]]))
    subsets = [s for m in range(1, 4) for s in itertools.combinations(range(3), m)]
    tree = subset_tree_log_likelihoods(design, subsets, fields, H_d, pieces)
    reference = _one_by_one(design, X_e, fields, subsets, H_d, pieces)
    assert np.all(np.isfinite(reference))
    np.testing.assert_allclose(tree, reference, rtol=1e-10, atol=1e-9)


def test_subsets_whose_prefixes_are_not_asked_for():
    design, X_e, fields = _fields_and_design()
    H_d = regression_basis(X_e, "constant")
    pieces = design.pieces(np.array([[0.2], [-0.3]]))
    subsets = [(1, 2), (0, 2), (2,)]
    tree = subset_tree_log_likelihoods(design, subsets, fields, H_d, pieces)
    reference = _one_by_one(design, X_e, fields, subsets, H_d, pieces)
    np.testing.assert_allclose(tree, reference, rtol=1e-10, atol=1e-9)


def test_a_covariance_that_is_not_positive_definite_is_minus_inf_below_it():
    design, X_e, fields = _fields_and_design()
    H_d = regression_basis(X_e, "constant")
    pieces = list(design.pieces(np.array([[0.0], [0.5]])))
    pieces[0] = pieces[0].copy()
    pieces[0][1] -= 50.0 * np.eye(len(X_e))  # break the second theta only
    subsets = [(0,), (0, 1), (1, 2)]
    tree = subset_tree_log_likelihoods(design, subsets, fields, H_d, tuple(pieces))
    assert np.all(np.isfinite(tree[:, :, 0]))
    assert np.all(tree[:, :, 1] == -np.inf)
    reference = _one_by_one(design, X_e, fields, subsets, H_d, tuple(pieces))
    np.testing.assert_allclose(tree[:, :, 0], reference[:, :, 0], rtol=1e-10)
