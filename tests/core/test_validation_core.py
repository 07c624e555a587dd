"""The table-driven parameter checks of skmba._core.validation."""

import re

import numpy as np
import pytest
from sklearn.base import BaseEstimator
from sklearn.gaussian_process.kernels import RBF, Kernel

from skmba._core.validation import (
    NO_VALIDATION,
    Boolean,
    Callable,
    Count,
    InstanceOf,
    InvalidParameterError,
    NJobs,
    Options,
    Real,
    check_count,
    int_seed,
    random_state_instance,
    seed_sequence,
    validate_parameter_table,
)

# (constraint, good values, bad value, message of the bad value for "p")
CASES = {
    "options": (
        Options(("constant", "linear"), hint="thesis Table 3.1"),
        ["constant", "linear"],
        "cubic",
        "p='cubic' is not supported; use one of 'constant', 'linear' "
        "(thesis Table 3.1).",
    ),
    "options-not-a-string": (
        Options(("exhaustive", "greedy")),
        ["greedy"],
        1,
        "p=1 is not supported; use one of 'exhaustive', 'greedy'.",
    ),
    "count-positive": (
        Count(),
        [1, np.int64(7)],
        0,
        "p must be a positive integer, got 0.",
    ),
    "count-bool": (Count(), [3], True, "p must be a positive integer, got True."),
    "count-non-negative": (
        Count(minimum=0),
        [0, 5],
        1.5,
        "p must be a non-negative integer, got 1.5.",
    ),
    "count-minimum-or-none": (
        Count(minimum=2, allow_none=True),
        [None, 2],
        1,
        "p must be an integer >= 2 or None, got 1.",
    ),
    "real-non-negative": (
        Real(minimum=0, hint="the nugget, e.g. 1e-8"),
        [0.0, 1e-8, 3, np.float32(2.0)],
        -1.0,
        "p must be a finite float >= 0 (the nugget, e.g. 1e-8), got -1.0.",
    ),
    "real-finite": (Real(), [-1.5], np.inf, "p must be a finite float, got inf."),
    "real-string": (
        Real(minimum=0),
        [1.0],
        "x",
        "p must be a finite float >= 0, got 'x'.",
    ),
    "real-bool": (Real(), [0.5], False, "p must be a finite float, got False."),
    "real-not-finite-allowed": (
        Real(finite=False),
        [np.inf, 2.0],
        None,
        "p must be a float, got None.",
    ),
    "boolean": (
        Boolean(),
        [True, False, np.True_],
        "yes",
        "p must be True or False, got 'yes'.",
    ),
    "boolean-int": (Boolean(), [False], 1, "p must be True or False, got 1."),
    "instance-of-or-none": (
        InstanceOf(
            Kernel, what="an sklearn Kernel", hint="e.g. Gauss()", allow_none=True
        ),
        [None, RBF()],
        "rbf",
        "p must be an sklearn Kernel (e.g. Gauss()) or None, got str.",
    ),
    "instance-of-default-name": (
        InstanceOf(BaseEstimator),
        [BaseEstimator()],
        3,
        "p must be a BaseEstimator, got int.",
    ),
    "callable": (
        Callable(what="a callable simulator(X, theta) -> Y"),
        [len, lambda X, theta: X],
        "model.exe",
        "p must be a callable simulator(X, theta) -> Y, got str.",
    ),
    "callable-or-none": (
        Callable(allow_none=True),
        [None, print],
        1.0,
        "p must be a callable or None, got float.",
    ),
    "n_jobs": (
        NJobs(),
        [None, 1, 4, -1, -2],
        0,
        "p must be None, a positive integer (number of parallel tasks) or a "
        "negative one (-1: all cores), got 0.",
    ),
    "n_jobs-float": (NJobs(), [2], 1.5, None),
    "n_jobs-bool": (NJobs(), [2], True, None),
}


@pytest.mark.parametrize("case", list(CASES))
def test_constraint_accepts_good_values_and_words_the_bad_one(case):
    constraint, good, bad, message = CASES[case]
    for value in good:
        assert constraint.accepts(value), value
    assert not constraint.accepts(bad)
    if message is not None:
        assert constraint.message("p", bad) == message


class Estimator(BaseEstimator):
    _parameter_table = {  # noqa: RUF012
        "regression": [Options(("constant", "linear"))],
        "optimizer": [Options(("fmin_l_bfgs_b",), allow_none=True), Callable()],
        "n_jobs": [NJobs()],
        "prior": NO_VALIDATION,
        "alpha": [Real(minimum=0)],
    }

    def __init__(
        self,
        regression="constant",
        optimizer="fmin_l_bfgs_b",
        n_jobs=None,
        prior=None,
        alpha=0.0,
    ):
        self.regression = regression
        self.optimizer = optimizer
        self.n_jobs = n_jobs
        self.prior = prior
        self.alpha = alpha


@pytest.mark.parametrize(
    "params",
    [
        {},
        {"optimizer": None},
        {"optimizer": print},
        {"prior": "anything"},
        {"n_jobs": -1},
    ],
)
def test_valid_parameters_pass(params):
    assert _validate(Estimator(**params)) is None


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"regression": "cubic"}, "regression='cubic' is not supported; use one of"),
        (
            {"optimizer": "adam"},
            "optimizer='adam' is not supported; use 'fmin_l_bfgs_b', None or a "
            "callable.",
        ),
        ({"n_jobs": 0}, "n_jobs must be None, a positive integer"),
        ({"alpha": -1}, "alpha must be a finite float >= 0, got -1."),
    ],
)
def test_invalid_parameter_is_named_with_its_constraint(params, message):
    with pytest.raises(InvalidParameterError, match=re.escape(message)):
        _validate(Estimator(**params))


def _validate(estimator):
    return validate_parameter_table(
        type(estimator)._parameter_table,
        estimator.get_params(deep=False),
        type(estimator).__name__,
    )


def test_error_is_both_a_value_and_a_type_error():
    # the three estimators raised either for the same kind of check
    for expected in (ValueError, TypeError):
        with pytest.raises(expected):
            _validate(Estimator(alpha="big"))


def test_parameters_are_checked_in_table_order():
    with pytest.raises(InvalidParameterError, match=r"^regression="):
        _validate(Estimator(regression="cubic", alpha=-1.0))


def test_parameter_missing_from_the_table_is_a_bug():
    class Incomplete(Estimator):
        _parameter_table = {"regression": []}  # noqa: RUF012

    with pytest.raises(RuntimeError, match=r"no entry for \['alpha', 'n_jobs'"):
        _validate(Incomplete())


def test_check_count():
    assert check_count(np.int64(3), "n") == 3 and type(check_count(3, "n")) is int
    assert check_count(0, "burn_in", minimum=0) == 0
    with pytest.raises(
        ValueError, match=r"^n_chains must be a positive integer, got 0\.$"
    ):
        check_count(0, "n_chains")
    with pytest.raises(ValueError, match="burn_in must be a non-negative integer"):
        check_count(-1, "burn_in", minimum=0)
    with pytest.raises(ValueError, match=r"n_design must be an integer >= 2, got True"):
        check_count(True, "n_design", minimum=2)


@pytest.mark.parametrize(
    "random_state",
    [7, np.random.RandomState(7), np.random.default_rng(7), np.random.SeedSequence(7)],
)
def test_seed_sequence_takes_every_kind_of_random_state(random_state):
    sequence = seed_sequence(random_state)
    assert isinstance(sequence, np.random.SeedSequence)
    children = [int_seed(c) for c in sequence.spawn(3)]
    assert len(set(children)) == 3  # independent streams


def test_seed_sequence_is_reproducible_and_refuses_bad_seeds():
    assert int_seed(seed_sequence(3)) == int_seed(seed_sequence(3))
    assert int_seed(seed_sequence(3)) != int_seed(seed_sequence(4))
    for bad in (-1, 1.5, "0", True):
        with pytest.raises(ValueError, match="random_state must be None, a non-neg"):
            seed_sequence(bad)


def test_random_state_instance_keeps_sklearn_numbers_and_takes_generators():
    from sklearn.utils import check_random_state

    for seed in (None, 7, np.random.RandomState(3)):
        rng = random_state_instance(seed)
        assert isinstance(rng, np.random.RandomState)
    assert random_state_instance(7).uniform() == check_random_state(7).uniform()
    same = [random_state_instance(np.random.default_rng(5)).normal(size=3)]
    same.append(random_state_instance(np.random.default_rng(5)).normal(size=3))
    np.testing.assert_array_equal(*same)
    seq = np.random.SeedSequence(9)
    assert (
        random_state_instance(seq).uniform()
        == random_state_instance(np.random.SeedSequence(9)).uniform()
    )
