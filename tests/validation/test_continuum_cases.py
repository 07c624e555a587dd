"""The cases of the discrepancy-continuum study (validation/continuum_cases.py):
the continuum's two shapes are orthogonal and of unit rms over the field
inputs, its ends are a1 and c3, and the larger designs have the sizes they
claim."""

import numpy as np
import pytest

from validation.cases import case_a1, case_c3
from validation.continuum_cases import (
    DESIGN_CASES,
    ContinuumReality,
    c3_relative_size,
    case_continuum,
)


@pytest.mark.parametrize("seed", [0, 7])
def test_shapes_are_orthogonal_and_of_unit_rms_over_the_field_inputs(seed):
    X = case_a1(seed).X
    s_in, s_out = ContinuumReality(X, 1.0, 45.0).shapes(X)
    np.testing.assert_allclose(np.mean(s_in * s_out, axis=0), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.sqrt(np.mean(s_in**2, axis=0)), 1.0, rtol=1e-12)
    np.testing.assert_allclose(np.sqrt(np.mean(s_out**2, axis=0)), 1.0, rtol=1e-12)


def test_s_in_is_a_softening_and_s_out_is_not_one():
    # The model is proportional to 1/E: s_in is the response itself, scaled.
    X = case_a1(0).X
    s_in, s_out = ContinuumReality(X, 1.0, 0.0).shapes(X)
    y = case_a1(0).reality_fn(X)
    np.testing.assert_allclose(s_in, y / np.sqrt(np.mean(y**2, axis=0)), rtol=1e-7)
    # s_out is no multiple of the response: its fit by one leaves most of it.
    coef = np.sum(s_out * y, axis=0) / np.sum(y * y, axis=0)
    assert np.all(np.mean((s_out - coef * y) ** 2, axis=0) > 0.99)


def test_c3_size_is_the_spring_s_effective_softening():
    # c3's discrepancy is F L^2/K* on the tip, (F L)^2/(2K*) on the energy:
    # 3 E* I / (K* L) of the model's response, at every force.
    expected = 3 * 70e3 * 6.75e8 / (1.5e11 * 3000.0)
    np.testing.assert_allclose(c3_relative_size(case_a1(3).X), expected, rtol=1e-12)


@pytest.mark.parametrize("seed", [0, 5])
def test_size_zero_is_a1_and_size_one_inside_the_span_is_c3(seed):
    a1, c3 = case_a1(seed), case_c3(seed)
    for alpha in (0.0, 90.0):
        zero = case_continuum(seed, size=0.0, alpha_deg=alpha)
        np.testing.assert_array_equal(zero.y, a1.y)
        np.testing.assert_array_equal(zero.X_sim, a1.X_sim)
    one = case_continuum(seed, size=1.0, alpha_deg=0.0)
    np.testing.assert_allclose(one.y, c3.y, rtol=1e-11)
    X_new = np.linspace(1e3, 10e3, 7)[:, None]  # anywhere, not only the field
    np.testing.assert_allclose(one.reality_fn(X_new), c3.reality_fn(X_new), rtol=1e-11)


def test_outside_the_span_the_size_is_c3_s():
    X = case_a1(2).X
    reality = ContinuumReality(X, 0.25, 90.0)
    model = case_a1(2).reality_fn(X)
    relative = np.sqrt(
        np.mean(reality.discrepancy(X) ** 2, axis=0) / np.mean(model**2, axis=0)
    )
    np.testing.assert_allclose(relative, 0.25 * c3_relative_size(X), rtol=1e-12)


@pytest.mark.parametrize(
    "name, d, q, r", [("two_inputs", 2, 1, 1), ("four_responses", 1, 4, 1),
                      ("three_parameters", 1, 1, 3)],
)  # fmt: skip
def test_the_larger_designs_have_their_sizes(name, d, q, r):
    spec = DESIGN_CASES[name]
    data = spec.build(0)
    assert data.X.shape[1] == d and data.y.shape[1] == q
    assert data.theta_sim.shape[1] == r == len(spec.parameter_names) == len(data.prior)
    # Seeded: the same seed gives the same data, another seed other data.
    same = spec.build(0)
    np.testing.assert_array_equal(same.y, data.y)
    assert not np.array_equal(spec.build(1).y, data.y)
