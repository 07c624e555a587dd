"""plot_change_history: the relative changes as bands over the evidence
panel, with the alarm threshold at -log10 alpha and the alarms marked."""

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")
pd = pytest.importorskip("pandas")

from skmba.plotting import plot_change_history  # noqa: E402


def _scan():
    index = pd.date_range("2025-01-01", periods=4, freq="7D")
    return pd.DataFrame(
        {
            "p_value": [0.5, 0.2, 1e-3, 1e-40],
            "E_mean": [0.0, 0.001, -0.01, -0.02],
            "E_2.5%": [-0.002, -0.001, -0.012, -0.022],
            "E_97.5%": [0.002, 0.003, -0.008, -0.018],
            "k_mean": [0.0, 0.0, 0.0, 0.0],
            "k_2.5%": [-0.01] * 4,
            "k_97.5%": [0.01] * 4,
        },
        index=index,
    )


def test_panels_threshold_and_alarms():
    fig = plot_change_history(
        _scan(), alpha=0.01, events={"damage": pd.Timestamp("2025-01-12")}
    )
    E, k, evidence = fig.axes[:3]
    assert E.get_ylabel() == "E change" and k.get_ylabel() == "k change"
    threshold = [ln for ln in evidence.get_lines() if ln.get_linestyle() == "--"]
    assert threshold[0].get_ydata()[0] == pytest.approx(2.0)
    alarms = next(ln for ln in evidence.get_lines() if ln.get_label() == "alarm")
    np.testing.assert_allclose(alarms.get_ydata(), [3.0, 40.0])


def test_a_table_without_p_values_is_refused():
    with pytest.raises(ValueError, match=r"ChangeDetector\.scan"):
        plot_change_history(_scan().drop(columns="p_value"))
    with pytest.raises(ValueError, match="alpha"):
        plot_change_history(_scan(), alpha=2.0)
