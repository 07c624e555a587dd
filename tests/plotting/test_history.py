"""plot_theta_history: the posterior after each update, from a calibrator's
theta_history_ (a DataFrame) or the structured array it is without pandas."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest
from sklearn.exceptions import NotFittedError

from skmba import ModularBayesCalibrator
from skmba.calibration._summary import history_table
from skmba.plotting import plot_theta_history


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def _rows():
    """Three updates of two parameters, as the calibrator records them."""
    return [
        {
            "label": np.datetime64("2025-01-31") + np.timedelta64(30 * k, "D"),
            "n_readings": 700 * (k + 1),
            "n_means": 20 + k,
            "statistics": np.array(
                [[30.0 + k, 4.0], [2.0, 1.0], [26.0 + k, 2.0], [34.0 + k, 6.0]]
            ),
        }
        for k in range(3)
    ]


@pytest.mark.parametrize("with_pandas", [True, False])
def test_bands_are_the_recorded_intervals(monkeypatch, with_pandas):
    if not with_pandas:
        import skmba.calibration._summary as summary

        monkeypatch.setattr(summary, "_pandas", lambda: None)
    table = history_table(_rows(), ["E", "k"])
    fig = plot_theta_history(
        table,
        true_value=[31.0, 4.5],
        units=["GPa", "MN/m"],
        events={"damage": np.datetime64("2025-02-15")},
    )
    assert [a.get_ylabel() for a in fig.axes] == ["E [GPa]", "k [MN/m]"]
    band = fig.axes[0].collections[0].get_paths()[0].vertices[:, 1]
    assert band.min() == 26.0 and band.max() == 36.0
    line = fig.axes[0].lines[0]
    np.testing.assert_array_equal(line.get_ydata(), [30.0, 31.0, 32.0])
    assert fig.axes[1].lines[1].get_ydata()[0] == 4.5  # the true value
    assert fig.axes[0].get_legend_handles_labels()[1][-1] == "damage"


def test_a_calibrator_not_fitted_or_a_table_without_intervals():
    with pytest.raises(NotFittedError, match="call fit or partial_fit"):
        plot_theta_history(ModularBayesCalibrator())
    pd = pytest.importorskip("pandas")
    with pytest.raises(ValueError, match="no <name>_mean"):
        plot_theta_history(pd.DataFrame({"E_mean": [1.0]}))
