"""Subset searches: exhaustive, greedy forward selection, genetic."""

from itertools import combinations

import numpy as np
import pytest

from skmba.sensor_design._subset_search import (
    all_subsets,
    check_max_size,
    genetic,
    greedy_forward,
)

WEIGHTS = np.array([5.0, 1.0, 4.0, 2.0, 8.0, 3.0, 7.0, 6.0, 0.5, 9.0, 2.5, 4.5])


class Counting:
    """A known score (lower is better) that records what it was asked."""

    def __init__(self, target_size=3):
        self.calls, self.seen, self.target = 0, [], target_size

    def __call__(self, subsets):
        self.calls += 1
        self.seen.extend(subsets)
        return [
            WEIGHTS[list(s)].sum() + 10.0 * abs(len(s) - self.target) for s in subsets
        ]


def brute_force(n, max_size, target):
    score = Counting(target)
    subsets = all_subsets(n, max_size)
    return subsets[int(np.argmin(score(subsets)))]


@pytest.mark.parametrize(("n", "max_size"), [(1, None), (4, None), (5, 2), (9, None)])
def test_all_subsets_counts_and_order(n, max_size):
    subsets = all_subsets(n, max_size)
    k = n if max_size is None else max_size
    expected = sum(len(list(combinations(range(n), s))) for s in range(1, k + 1))
    assert len(subsets) == expected == len(set(subsets))
    assert [len(s) for s in subsets] == sorted(len(s) for s in subsets)
    assert all(list(s) == sorted(s) for s in subsets)


def test_greedy_follows_the_best_step_and_never_asks_twice():
    score = Counting(target_size=3)
    path = greedy_forward(score, 12, max_size=4)
    assert [len(s) for s in path] == [1, 2, 3, 4]
    assert path[0] == (8,) and path[1] == (1, 8) and path[2] == (1, 3, 8)
    assert len(score.seen) == len(set(score.seen)) == 12 + 11 + 10 + 9
    assert score.calls == 4  # one batch per step


def test_genetic_finds_the_optimum_with_far_fewer_evaluations():
    n, target = 12, 3
    best = brute_force(n, None, target)
    score = Counting(target)
    found = genetic(score, n, random_state=0, population_size=30, n_generations=40)
    assert found == best
    assert len(score.seen) == len(set(score.seen)) < 0.5 * (2**n - 1)


def test_genetic_respects_max_size_and_is_reproducible():
    score = Counting(target_size=5)
    a = genetic(score, 10, max_size=2, random_state=3)
    assert len(a) <= 2 and all(len(s) <= 2 for s in score.seen)
    assert genetic(Counting(5), 10, max_size=2, random_state=3) == a
    assert a == brute_force(10, 2, 5)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"population_size": 1}, "population_size must be at least 2"),
        ({"n_generations": 0}, "n_generations must be a positive integer"),
        ({"mutation_rate": 1.5}, "mutation_rate must lie in"),
    ],
)
def test_genetic_rejects_bad_settings(kwargs, match):
    with pytest.raises(ValueError, match=match):
        genetic(Counting(), 4, **kwargs)


def test_check_max_size():
    assert check_max_size(None, 5) == 5
    assert check_max_size(2, 5) == 2
    with pytest.raises(ValueError, match="between 1 and 5"):
        check_max_size(6, 5)
    with pytest.raises(TypeError, match="must be an int"):
        check_max_size(True, 5)
