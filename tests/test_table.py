"""_table: columns of arrays / pandas / polars, runs (however interleaved), time order."""

import numpy as np
import pandas as pd
import polars as pl
import pytest
from numpy.testing import assert_array_equal

from sklearn_ifog import _table
from sklearn_ifog._table import (
    TableError,
    TableTypeError,
    check_finite,
    check_time_increasing,
    column_position,
    contiguous_runs,
    find_column,
    first_time_violation,
    group_rows_by_run,
    label_column,
    numeric_column,
    per_run_mean,
    read_thermal_columns,
    run_segments,
)

DATA = {
    "run": ["b", "a", "b", "a", "b"],
    "time": [0.0, 0.0, 60.0, 30.0, 120.0],
    "coil": [20.0, 30.0, 21.0, 29.0, 23.0],
}


def _containers():
    frame = pd.DataFrame(DATA)
    array = np.array([DATA["run"], DATA["time"], DATA["coil"]], dtype=object).T
    return {"pandas": frame, "polars": pl.DataFrame(DATA), "array": array}


# --- columns ---------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["pandas", "polars", "array"])
def test_pandas_polars_and_array_read_the_same_columns(kind):
    X = _containers()[kind]
    by_name = kind != "array"
    keys = {"temperature": ["coil" if by_name else 2], "time": "time" if by_name else 1}
    columns = read_thermal_columns(X, **keys, run="run" if by_name else 0)
    assert columns.temperature.dtype == np.float64
    assert_array_equal(columns.temperature[:, 0], DATA["coil"])
    assert_array_equal(columns.time, DATA["time"])
    assert columns.run.tolist() == DATA["run"]
    assert columns.time_label == ("time column 'time'" if by_name else "time column 1")


def test_column_position_errors_name_the_column_and_parameter():
    frame = pd.DataFrame(DATA)
    assert column_position(frame, 2, param="temperature") == 2
    with pytest.raises(ValueError, match=r"Column 'gyro' \(rate\) not found in X; available "):
        column_position(frame, "gyro", param="rate")
    with pytest.raises(ValueError, match=r"not found in frame; .*\]\. Pass run=None\.$"):
        column_position(frame, "burst", param="run", source="frame", hint="Pass run=None.")
    with pytest.raises(ValueError, match=r"time=3 is not a column position of X, which has 3"):
        column_position(frame, 3, param="time")
    with pytest.raises(ValueError, match=r"rate='rate' names a column, but X has no column names"):
        column_position(np.ones((2, 2)), "rate", param="rate")
    with pytest.raises(TypeError, match=r"run must name a column .* got True"):
        column_position(frame, True, param="run")
    twice = pd.DataFrame([[1.0, 2.0]], columns=["t", "t"])
    with pytest.raises(ValueError, match=r"Column 't' \(time\) appears 2 times in X"):
        column_position(twice, "t", param="time")


def test_find_column_is_lenient():
    frame = pd.DataFrame(DATA)
    assert find_column(frame, "time") == 1
    assert find_column(frame, -1) == 2
    assert find_column(frame, "unit") is None
    assert find_column(frame, 3) is None
    assert find_column(None, "run") is None
    assert find_column([[1, 2, 3]], 1) == 1
    assert find_column(np.ones(3), 0) is None


@pytest.mark.parametrize("kind", ["pandas", "polars", "array"])
def test_non_numeric_column_is_a_type_error_naming_it(kind):
    X = _containers()[kind]
    key = "run" if kind != "array" else 0
    name = "'run'" if kind != "array" else "0"
    with pytest.raises(TableTypeError, match=rf"temperature column {name} must be numeric"):
        numeric_column(X, key, param="temperature")
    # A TableTypeError is a ValueError too (a bad value of X) as well as a TypeError.
    assert issubclass(TableTypeError, ValueError)
    assert issubclass(TableTypeError, TypeError)


def test_bool_and_text_numbers_are_refused_unless_parsing_is_asked():
    frame = pd.DataFrame({"flag": [True, False], "text": ["20.5", "21"]})
    with pytest.raises(
        TableTypeError, match=r"flag column 'flag' must be numeric, got dtype bool"
    ):
        numeric_column(frame, "flag", param="flag")
    with pytest.raises(TableTypeError, match=r"text column 'text' must be numeric"):
        numeric_column(frame, "text", param="text")
    assert_array_equal(numeric_column(frame, "text", param="text", parse_text=True), [20.5, 21.0])
    bad = pd.DataFrame({"text": ["20.5", "warm", ""]})
    with pytest.raises(TableError, match=r"text column 'text' holds 'warm' at row 1") as info:
        numeric_column(bad, "text", param="text", parse_text=True)
    assert (info.value.row, info.value.value) == (1, "warm")


@pytest.mark.parametrize("kind", ["pandas", "polars", "array"])
def test_non_finite_values_name_column_count_and_row(kind):
    data = {**DATA, "coil": [20.0, 21.0, np.inf, 22.0, np.nan]}
    X = {
        "pandas": pd.DataFrame(data),
        "polars": pl.DataFrame(data),
        "array": np.array([data["time"], data["coil"]]).T,
    }[kind]
    key = 1 if kind == "array" else "coil"
    with pytest.raises(
        TableError, match=r"contains NaN or inf \(2 value\(s\); first at row 2: inf"
    ):
        numeric_column(X, key, param="temperature")
    values = numeric_column(X, key, param="temperature", finite=False)
    assert np.isinf(values[2])
    assert np.isnan(values[4])


def test_check_finite_on_several_columns_reports_first_bad_row():
    values = np.array([[1.0, 2.0], [3.0, np.nan], [np.inf, 1.0]])
    with pytest.raises(TableError, match=r"x contains NaN or inf \(2 value\(s\); first at row 1"):
        check_finite(values, "x")


@pytest.mark.parametrize("kind", ["pandas", "polars", "array"])
def test_missing_labels_are_refused(kind):
    run = ["a", None, "b", "b"]
    X = {
        "pandas": pd.DataFrame({"run": run}),
        "polars": pl.DataFrame({"run": run}),
        "array": np.array(run, dtype=object)[:, None],
    }[kind]
    key = 0 if kind == "array" else "run"
    with pytest.raises(TableError, match=r"has missing run ids \(first at row 1\)") as info:
        label_column(X, key, param="run")
    assert info.value.row == 1


def test_a_column_has_one_role():
    frame = pd.DataFrame(DATA)
    with pytest.raises(ValueError, match=r"time='coil' is the same column as temperature"):
        read_thermal_columns(frame, temperature=["coil"], time="coil")
    with pytest.raises(ValueError, match="lists a column twice"):
        read_thermal_columns(frame, temperature=["coil", 2])


# --- runs ------------------------------------------------------------------------------------


def test_group_rows_by_run_is_stable():
    order, run_starts = group_rows_by_run(np.array([3, 1, 3, 1, 2, 3]))
    assert_array_equal(order, [1, 3, 4, 0, 2, 5])
    assert_array_equal(run_starts, [True, False, True, True, False, False])
    assert group_rows_by_run(None) == (None, None)


def test_group_rows_by_run_mixed_id_types(monkeypatch):
    # Hashing (pandas) keeps 1 and "1" apart and needs no order between types.
    order, run_starts = group_rows_by_run(np.array([1, "1", 1, "a", "1"], dtype=object))
    assert_array_equal(order, [0, 2, 1, 4, 3])
    assert_array_equal(run_starts, [True, False, True, False, True])
    # Without pandas, ids are sorted, which mixed types cannot be.
    monkeypatch.setattr(_table, "_object_codes", lambda run: None)
    with pytest.raises(ValueError, match=r"one orderable type.*\['int', 'str'\]"):
        group_rows_by_run(np.array([1, "a", 2], dtype=object))
    order, _ = group_rows_by_run(np.array(["b", "a", "b"], dtype=object))
    assert_array_equal(order, [1, 0, 2])


@pytest.mark.parametrize("dtype", [object, str])
def test_run_segments_of_interleaved_runs_in_first_appearance_order(dtype):
    run = np.array(["b", "a", "b", "c", "a", "b"], dtype=dtype)
    segments = run_segments(run, run.size)
    assert [str(label) for label, _ in segments] == ["b", "a", "c"]
    assert [rows.tolist() for _, rows in segments] == [[0, 2, 5], [1, 4], [3]]
    ((label, rows),) = run_segments(None, 4)
    assert label is None
    assert rows.tolist() == [0, 1, 2, 3]


def test_contiguous_runs_for_a_stream():
    assert contiguous_runs(np.array([1.0, 1.0, 2.0, 1.0]), 4) == [(0, 2, 1), (2, 3, 2), (3, 4, 1)]
    stretches = contiguous_runs(np.array(["x", "x"]), 2)
    assert stretches == [(0, 2, "x")]
    assert type(stretches[0][2]) is str
    assert contiguous_runs(None, 3) == [(0, 3, None)]
    assert contiguous_runs(None, 0) == []


def test_per_run_mean_of_interleaved_runs():
    values = np.array([1.0, 10.0, 3.0, 20.0, 5.0])
    run = np.array(["a", "b", "a", "b", "a"], dtype=object)
    assert_array_equal(per_run_mean(values, run), [3.0, 15.0, 3.0, 15.0, 3.0])
    assert_array_equal(per_run_mean(values, np.zeros(5)), np.full(5, values.mean()))


# --- time order ------------------------------------------------------------------------------


def test_time_violation_in_interleaved_runs_names_run_and_rows():
    frame = pd.DataFrame(DATA).assign(time=[0.0, 0.0, 60.0, 30.0, 50.0])
    with pytest.raises(
        TableError,
        match=r"in run 'b' row 4 has time 50\.0, not after 60\.0 at row 2 \(rows are positions",
    ) as info:
        check_time_increasing(frame["time"].to_numpy(), frame["run"].to_numpy())
    error = info.value
    assert (error.row, error.previous_row, error.run, error.value) == (4, 2, "b", 50.0)
    # The same table is fine when its runs are told apart and time increases in each one.
    check_time_increasing(np.array(DATA["time"]), np.array(DATA["run"]))
    # Without runs, the repeated 0.0 at row 1 is the first violation.
    with pytest.raises(TableError, match=r"; row 1 has time 0\.0, not after 0\.0 at row 0"):
        check_time_increasing(np.array(DATA["time"]))


def test_first_time_violation_is_the_smallest_row_and_nan_never_increases():
    run = np.array([1, 2, 1, 2, 1])
    time = np.array([0.0, 5.0, 1.0, 4.0, 0.5])
    assert first_time_violation(time, *group_rows_by_run(run)) == (3, 1)
    assert first_time_violation(np.array([0.0, np.nan, 2.0])) == (1, 0)
    assert first_time_violation(np.array([1.0, 2.0])) is None
    assert first_time_violation(np.empty(0)) is None
    # A carried previous time (a stream): row 0 must come after it.
    assert first_time_violation(np.array([5.0, 6.0]), previous=5.0) == (0, -1)
    assert first_time_violation(np.array([5.0, 6.0, 6.0]), previous=4.0) == (2, 1)
