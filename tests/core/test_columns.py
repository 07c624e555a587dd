"""Named columns (skmba._core.columns): tables matched by name, arrays by position.

The calibrator's results with reordered tables are checked in
tests/calibration/test_estimator_calibration.py; these check the functions.
"""

import numpy as np
import pytest

from skmba._core.columns import column_names, match_columns, response_index

pd = pytest.importorskip("pandas")


def test_column_names_of_a_dataframe_and_of_an_array():
    assert column_names(pd.DataFrame(np.zeros((2, 2)), columns=["a", 3])) == ["a", "3"]
    assert column_names(pd.Series([1.0, 2.0], name="a")) is None
    assert column_names(np.zeros((2, 2))) is None


def test_match_columns_reorders_a_table_and_leaves_arrays():
    table = pd.DataFrame({"b": [1.0, 2.0], "a": [3.0, 4.0]})
    matched = match_columns(table, ["a", "b"], "X_sim", "the columns of X")
    assert list(matched.columns) == ["a", "b"]
    np.testing.assert_array_equal(matched.to_numpy(), [[3.0, 1.0], [4.0, 2.0]])
    assert match_columns(table, None, "X_sim", "X") is table
    array = np.zeros((2, 2))
    assert match_columns(array, ["a", "b"], "X_sim", "X") is array


def test_match_columns_names_the_missing_and_the_unknown():
    table = pd.DataFrame({"force": [1.0], "temp": [2.0]})
    with pytest.raises(
        ValueError,
        match=r"The columns of X_sim do not match the columns of X: X_sim lacks "
        r"\['load'\] and has \['force'\] besides \(the columns of X: \['temp', "
        r"'load'\]; X_sim: \['force', 'temp'\]\)",
    ):
        match_columns(table, ["temp", "load"], "X_sim", "the columns of X")
    repeated = pd.DataFrame(np.zeros((1, 2)), columns=["a", "a"])
    with pytest.raises(ValueError, match=r"X_sim has repeated column names \['a'\]"):
        match_columns(repeated, ["a", "b"], "X_sim", "X")


def test_response_index_by_name_and_by_index():
    names = ["tip", "energy", "mid"]
    assert [response_index(k, names, 3) for k in ("mid", 0, np.int64(1))] == [2, 0, 1]
    assert response_index(2, None, 3) == 2
    with pytest.raises(ValueError, match="fitted on an array y without names"):
        response_index("tip", None, 3)
    with pytest.raises(ValueError, match="response index -1 is out of range"):
        response_index(-1, names, 3)
