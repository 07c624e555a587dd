"""Thesis section 6.3: the cantilever's sensor ranking (Figs. 6.3-6.4)."""

import warnings

import numpy as np
import pytest

from skmba.datasets import make_cantilever

from ._helpers import designer, table_6_2_on_a_common_scale


@pytest.mark.parametrize("seed", [1, 2])
@pytest.mark.slow
def test_cantilever_ranking_of_section_6_3(seed):
    """Figs. 6.3-6.4: A beats D and E; an informative prior lifts C."""
    data = make_cantilever(54, responses="all", random_state=seed)
    X = np.hstack([data.X_sim, data.theta_sim])
    ranks = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for informative in (False, True):
            d = designer(
                data.prior,
                max_responses=1,
                n_design=25,
                n_mc=12,
                random_state=seed,
                **table_6_2_on_a_common_scale(data, informative),
            ).fit(X, data.y_sim)
            ranks[informative] = d.ranking_
    A, C, D, E = 0, 2, 3, 4
    assert ranks[False][A] < ranks[False][D] and ranks[False][A] < ranks[False][E]
    assert ranks[False][C] == 5  # the Type II error of Fig. 6.3
    assert ranks[True][C] < ranks[False][C]
