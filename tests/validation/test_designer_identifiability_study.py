"""The designer's prediction of the identifiability warning, fixed-seed
subset of ``validation/studies/designer_identifiability.py`` (slow)."""

import pytest

from validation.studies.designer_identifiability import Problem, run

pytestmark = pytest.mark.slow


def test_the_study_scores_every_subset_of_at_most_three_responses():
    subsets = Problem("cantilever").subsets()
    assert len(subsets) == 5 + 10 + 10
    assert Problem("offset").subsets() == [(0,)]


def test_the_designer_predicts_the_calibrator_on_the_cantilever():
    # Study (20 seeds, n_mc 50): 484/500 = 0.968 [0.949, 0.980] agree.
    text, agree, total, failed = run("cantilever", 4, 20, 2)
    assert failed == 0 and total == 4 * 25
    assert 0.9 <= agree / total <= 1.0, text


def test_the_designer_names_the_offset_and_not_the_frequency():
    # Study (20 seeds): predicted rates 0.26 and 0.64; named 5/20 and 18/20;
    # the agreement 33/40, bounded by the observed rates (0.75 and 0.90).
    text, agree, total, failed = run("offset", 10, 20, 2)
    assert failed == 0 and total == 20
    assert 0.65 <= agree / total <= 0.95, text
    lines = text.splitlines()
    assert "quiet" in lines[0] and lines[0].startswith("frequency"), text
    assert "names" in lines[1] and lines[1].startswith("offset"), text
