"""Searches over subsets of sensors (responses); they know nothing of GPs.

A subset is a sorted tuple of item indices. Every search calls
``evaluate(subsets) -> scores`` (lower is better) on batches of subsets it
has not scored yet, so the caller can run a batch in parallel and cache
scores; the searches never ask twice for the same subset.

* :func:`all_subsets`: the ``2^q - 1`` non-empty subsets (or those of at
  most ``max_size`` items), smallest first.
* :func:`greedy_forward`: forward selection, adding at each step the item
  that lowers the score most (thesis chapter 6 names optimisation routines
  as the alternative to the combinatorial search when ``q`` is large).
* :func:`genetic`: a binary-chromosome genetic algorithm (tournament
  selection, uniform crossover, bit-flip mutation, elitism), the analogue of
  the genetic algorithms the thesis recommends for many sensors.

Examples
--------
>>> all_subsets(3)
[(0,), (1,), (2,), (0, 1), (0, 2), (1, 2), (0, 1, 2)]
>>> cost = {0: 3.0, 1: 1.0, 2: 2.0}
>>> def evaluate(subsets):  # lower is better; a fixed cost per extra item
...     return [sum(cost[i] for i in s) / len(s) ** 2 for s in subsets]
>>> greedy_forward(evaluate, 3, max_size=2)
[(1,), (1, 2)]
"""

from dataclasses import dataclass
from itertools import combinations
from numbers import Integral

import numpy as np

from skmba._core.validation import check_count


def check_max_size(max_size, n_items):
    """``max_size`` as an int in ``[1, n_items]`` (None means ``n_items``)."""
    if max_size is None:
        return n_items
    if isinstance(max_size, bool) or not isinstance(max_size, Integral):
        raise TypeError(
            f"max_responses must be an int between 1 and {n_items} or None, got "
            f"{max_size!r}."
        )
    if not 1 <= max_size <= n_items:
        raise ValueError(
            f"max_responses={max_size} is out of range: there are {n_items} "
            f"responses, so use an int between 1 and {n_items} (or None for all)."
        )
    return int(max_size)


def all_subsets(n_items, max_size=None):
    """All non-empty subsets of at most ``max_size`` items, smallest first."""
    max_size = check_max_size(max_size, n_items)
    return [
        c for size in range(1, max_size + 1) for c in combinations(range(n_items), size)
    ]


class _Cache:
    """Scores of the subsets evaluated so far, filled batch by batch."""

    def __init__(self, evaluate):
        self.evaluate = evaluate
        self.scores = {}

    def __call__(self, subsets):
        subsets = [tuple(sorted(s)) for s in subsets]
        new = list(dict.fromkeys(s for s in subsets if s not in self.scores))
        if new:
            values = np.asarray(self.evaluate(new), dtype=float)
            self.scores.update(zip(new, values, strict=True))
        return np.array([self.scores[s] for s in subsets])


def greedy_forward(evaluate, n_items, max_size=None):
    """Forward selection; returns the path of chosen subsets, one per size.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(list of tuples) -> scores``; lower is better.
    n_items : int
    max_size : int or None
        Stop after this many items (None: all of them).

    Returns
    -------
    path : list of tuple
        The best subset found of each size 1, 2, ..., ``max_size``.
    """
    max_size = check_max_size(max_size, n_items)
    score = _Cache(evaluate)
    current, path = (), []
    for _ in range(max_size):
        candidates = [
            tuple(sorted((*current, j))) for j in range(n_items) if j not in current
        ]
        values = score(candidates)
        current = candidates[int(np.argmin(values))]
        path.append(current)
    return path


def _repair(mask, max_size, rng):
    """At least one and at most ``max_size`` items switched on."""
    on = np.flatnonzero(mask)
    if len(on) == 0:
        mask[rng.integers(len(mask))] = True
    elif len(on) > max_size:
        mask[rng.choice(on, size=len(on) - max_size, replace=False)] = False
    return mask


def genetic(
    evaluate,
    n_items,
    max_size=None,
    *,
    population_size=20,
    n_generations=20,
    mutation_rate=None,
    patience=5,
    random_state=None,
):
    """Binary genetic algorithm over subsets; returns the best subset found.

    Each chromosome is a boolean mask over the items. A generation keeps the
    two best chromosomes (elitism) and fills the rest of the population with
    children of two parents chosen by binary tournaments: uniform crossover,
    then each bit flipped with probability ``mutation_rate``, then repaired
    to hold between 1 and ``max_size`` items. The search stops after
    ``n_generations`` or when the best score has not improved for
    ``patience`` generations. Each generation's new chromosomes are scored in
    one ``evaluate`` call.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(list of tuples) -> scores``; lower is better.
    n_items : int
    max_size : int or None
    population_size : int, default=20
    n_generations : int, default=20
    mutation_rate : float or None, default=None
        None means ``1 / n_items``.
    patience : int, default=5
    random_state : int, numpy Generator or None

    Returns
    -------
    best : tuple
    """
    max_size = check_max_size(max_size, n_items)
    check_count(population_size, "population_size")
    check_count(n_generations, "n_generations")
    check_count(patience, "patience")
    if population_size < 2:
        raise ValueError(
            f"population_size must be at least 2 for crossover, got {population_size}."
        )
    rate = 1.0 / n_items if mutation_rate is None else float(mutation_rate)
    if not 0.0 <= rate <= 1.0:
        raise ValueError(f"mutation_rate must lie in [0, 1], got {mutation_rate!r}.")
    rng = np.random.default_rng(random_state)
    score = _Cache(evaluate)

    def as_tuple(mask):
        return tuple(int(i) for i in np.flatnonzero(mask))

    population = np.zeros((population_size, n_items), dtype=bool)
    for k in range(population_size):
        size = rng.integers(1, max_size + 1)
        population[k, rng.choice(n_items, size=size, replace=False)] = True
    fitness = score([as_tuple(m) for m in population])
    best, stale = float(fitness.min()), 0
    for _ in range(n_generations):
        order = np.argsort(fitness, kind="stable")
        children = [population[order[0]].copy(), population[order[1]].copy()]
        while len(children) < population_size:
            parents = []
            for _ in range(2):
                a, b = rng.integers(population_size, size=2)
                parents.append(population[a if fitness[a] <= fitness[b] else b])
            child = np.where(rng.random(n_items) < 0.5, parents[0], parents[1])
            child = child ^ (rng.random(n_items) < rate)
            children.append(_repair(child, max_size, rng))
        population = np.array(children)
        fitness = score([as_tuple(m) for m in population])
        if fitness.min() < best:
            best, stale = float(fitness.min()), 0
        else:
            stale += 1
            if stale >= patience:
                break
    return as_tuple(population[int(np.argmin(fitness))])


@dataclass(frozen=True)
class SearchSettings:
    """A search over subsets of at most ``max_size`` items: ``search`` is
    ``"exhaustive"``, ``"greedy"`` or ``"genetic"`` (whose population,
    generations and seed are the other fields)."""

    search: str
    max_size: int
    population_size: int
    n_generations: int
    random_state: object

    def planned(self, q):
        """The subsets of ``q`` items it scores at least: all of them
        (exhaustive), every step of the forward selection (greedy), or the
        single items and the first generation (genetic)."""
        if self.search == "exhaustive":
            return len(all_subsets(q, self.max_size))
        if self.search == "greedy":
            return sum(q - k for k in range(self.max_size))
        return q + self.population_size

    def run(self, evaluate, q):
        """Run the search over subsets of ``q`` items, scoring batches of
        subsets with ``evaluate``; the single items are scored first by the
        greedy and genetic searches."""
        if self.search == "exhaustive":
            evaluate(all_subsets(q, self.max_size))
            return
        evaluate([(j,) for j in range(q)])
        if self.search == "greedy":
            greedy_forward(evaluate, q, self.max_size)
        else:
            genetic(
                evaluate,
                q,
                self.max_size,
                population_size=self.population_size,
                n_generations=self.n_generations,
                random_state=self.random_state,
            )
