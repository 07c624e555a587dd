"""The missing-readings study ``validation/studies/missing_data.py``: helpers
and a pinned subset.

The fast tests check how the gaps are drawn; the slow test runs 8 fixed
seeds of the a1 and b1 cantilever cases and pins today's behaviour of the
calibrator with 10 % of the field readings removed, with tolerances that
catch a regression (the full study, 40 seeds per case, is quoted in
``docs/monitoring_data.rst``).
"""

import numpy as np
import pytest

from validation.studies import missing_data


def test_gaps_remove_the_share_asked_and_never_a_whole_response():
    y = np.arange(40.0).reshape(20, 2)
    for seed in range(20):
        gapped, mask = missing_data.with_gaps(y, 0.1, np.random.default_rng(seed))
        assert mask.sum() == 4 and np.isnan(gapped).sum() == 4
        np.testing.assert_array_equal(gapped[~mask], y[~mask])
    # a share that would empty a response is redrawn until it does not
    y = np.ones((3, 2))
    _, mask = missing_data.with_gaps(y, 0.5, np.random.default_rng(0))
    assert not mask.all(axis=0).any()


@pytest.mark.slow
def test_gaps_keep_theta_and_cover_the_removed_readings():
    records = missing_data.run(["a1", "b1"], n_seeds=8, n_jobs=1)
    summary = missing_data.summarise(records)
    for name, s in summary.items():
        # theta stays inside the complete data's 95 % interval every time
        # (40/40 seeds in the full study) ...
        assert s["inside"].tolist() == [8], name
        # ... with an interval barely wider (median ratio 1.03-1.05) ...
        assert 0.95 < s["sd_ratio_median"][0] < 1.3, name
        # ... and the removed readings are covered at the nominal rate
        # (0.945-0.95 with rms z 0.98 over 200 readings in the full study;
        # 40 here, of which at most 5 may fall outside: 1.4 % chance at a
        # true 0.95, while a drop to 0.85 fails with probability 0.57 per case).
        assert s["n_removed"] == 40
        assert s["covered"] >= 35, name
        assert 0.6 < s["rms_z"] < 1.4, name
