"""ThermalFeatures and its numerics: values, run isolation, causality, errors, containers."""

import re

import numpy as np
import pandas as pd
import polars as pl
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy import sparse
from sklearn.linear_model import LinearRegression
from sklearn.model_selection import GridSearchCV, GroupKFold
from sklearn.pipeline import make_pipeline

from sklearn_ifog import ThermalFeatures
from sklearn_ifog._compat import InvalidParameterError
from sklearn_ifog._contract import DEFAULT_STATE_TERMS
from sklearn_ifog._lags import lag_deficit, smoothed_rate
from sklearn_ifog.datasets import _simulator, make_thermal_campaign
from sklearn_ifog.features import (
    assemble_terms,
    causal_rate,
    compute_thermal_features,
)

T4 = [20.0, 21.0, 23.0, 22.0]
VALID_4 = ("T", "dT", "TdT", "T2")


def _frame(temperature, time=None, run=None):
    data = {"temperature": temperature}
    if time is not None:
        data["time"] = time
    if run is not None:
        data["run"] = run
    return pd.DataFrame(data)


def _random_run(rng, n, start_temperature):
    time = np.cumsum(rng.uniform(0.5, 2.0, n))
    temperature = start_temperature + np.cumsum(rng.normal(0.0, 0.3, n))
    return time, temperature


def _two_run_frame(seed=0, n_a=37, n_b=23):
    """Two runs with string ids, rows interleaved at random (each run's rows in time order)."""
    rng = np.random.default_rng(seed)
    time_a, temp_a = _random_run(rng, n_a, 20.0)
    time_b, temp_b = _random_run(rng, n_b, 35.0)
    run_a = pd.DataFrame({"run": "a", "time": time_a, "temperature": temp_a})
    run_b = pd.DataFrame({"run": "b", "time": time_b, "temperature": temp_b})
    is_a = rng.permutation(np.r_[np.ones(n_a, bool), np.zeros(n_b, bool)])
    frame = pd.DataFrame(index=range(n_a + n_b), columns=["run", "time", "temperature"])
    frame.loc[is_a] = run_a.to_numpy()
    frame.loc[~is_a] = run_b.to_numpy()
    frame = frame.astype({"time": float, "temperature": float})
    frame["note"] = "free text"  # an unused, non-numeric column must pass untouched
    return frame, run_a, run_b, is_a


# --- hand-computed values --------------------------------------------------------------------


def test_terms_per_sample_hand_computed():
    features = ThermalFeatures(terms=("T", "dT", "TdT", "T2"))
    out = features.fit_transform(_frame(T4))
    expected = np.array(
        [
            [20.0, 0.0, 0.0, 400.0],
            [21.0, 1.0, 21.0, 441.0],
            [23.0, 2.0, 46.0, 529.0],
            [22.0, -1.0, -22.0, 484.0],
        ]
    )
    assert_array_equal(out, expected)
    assert list(features.get_feature_names_out()) == ["T", "dT", "T_dT", "T2"]


def test_terms_any_subset_and_order():
    out = ThermalFeatures(terms=["TdT", "T"]).fit_transform(_frame(T4))
    assert_array_equal(out, [[0.0, 20.0], [21.0, 21.0], [46.0, 23.0], [-22.0, 22.0]])
    out = ThermalFeatures(terms=("dT",)).fit_transform(_frame(T4))
    assert_array_equal(out[:, 0], [0.0, 1.0, 2.0, -1.0])


@pytest.mark.parametrize(
    ("rate_unit", "expected"),
    [
        ("min", [0.0, 2.0, 2.0, -2.0]),
        ("s", [0.0, 1 / 30, 2 / 60, -1 / 30]),
        ("h", [0.0, 120.0, 120.0, -120.0]),
        (10.0, [0.0, 1 / 3, 1 / 3, -1 / 3]),
    ],
)
def test_rate_with_time_hand_computed(rate_unit, expected):
    X = _frame(T4, time=[0.0, 30.0, 90.0, 120.0])
    paper = ("T", "dT", "TdT")  # the default with a time column smooths dT
    out = ThermalFeatures(time="time", rate_unit=rate_unit, terms=paper).fit_transform(X)
    assert_allclose(out[:, 0], T4)
    assert_allclose(out[:, 1], expected, rtol=1e-14)
    assert_allclose(out[:, 2], np.asarray(T4) * expected, rtol=1e-14)


def test_smoothing_without_time_is_refused():
    X = _frame([20.0, 22.0, 22.0, 26.0])
    with pytest.raises(
        ValueError, match=r"smoothing=1\.0 is a time constant in seconds and needs"
    ):
        ThermalFeatures(smoothing=1.0).fit_transform(X)
    with pytest.raises(ValueError, match="needs a time column"):
        compute_thermal_features(np.array(T4), smoothing=60.0)


def test_smoothing_with_time_hand_computed():
    # A ramp of 1 degC/min from rest, tau = 60 s: the deficit after t is 1 - exp(-t / 60 s)
    # (exact for a linear input), so dT = deficit / tau = (1 - exp(-t / 60)) degC/min; then
    # a soak: the deficit decays as exp(-dt / 60 s).
    X = _frame([20.0, 21.0, 23.0, 23.0], time=[0.0, 60.0, 180.0, 240.0])
    out = ThermalFeatures(time="time", smoothing=60.0, terms=["dT"]).fit_transform(X)
    e1 = 1 - np.exp(-1.0)
    e2 = 1 - np.exp(-3.0)
    assert_allclose(out[:, 0], [0.0, e1, e2, e2 * np.exp(-1.0)], rtol=1e-14)


def test_lag_terms_hand_computed_and_named():
    # 1 degC/min ramp: T - lag_600s(T) = 10 (1 - exp(-t / 600 s)) degC.
    t = np.array([0.0, 60.0, 600.0, 6000.0])
    X = _frame(20.0 + t / 60.0, time=t)
    features = ThermalFeatures(time="time", terms=("T", "T_lag600s", "T_lag90.5s"))
    out = features.fit_transform(X)
    assert_allclose(out[:, 1], 10.0 * (1 - np.exp(-t / 600.0)), rtol=1e-13)
    assert_allclose(out[:, 2], 90.5 / 60.0 * (1 - np.exp(-t / 90.5)), rtol=1e-13)
    assert list(features.get_feature_names_out()) == ["T", "T_lag600s", "T_lag90.5s"]
    # Another spelling of a time constant: the canonical name.
    assert list(ThermalFeatures(terms=["T_lag0600.0s"]).get_feature_names_out()) == ["T_lag600s"]


def test_lag_terms_and_smoothing_equal_the_lags_module():
    frame, _, _, _ = _two_run_frame(seed=12, n_a=300, n_b=150)
    terms = ("T", "dT", "TdT", "T_lag5s", "T_lag60s", "T_lag3600s")
    features = ThermalFeatures(time="time", run="run", terms=terms, smoothing=20.0, rate_unit="s")
    out = features.fit_transform(frame)
    for run_id in ("a", "b"):
        rows = (frame["run"] == run_id).to_numpy()
        T = frame["temperature"].to_numpy()[rows]
        t = frame["time"].to_numpy()[rows]
        deficit = lag_deficit(T, t, None, [5.0, 60.0, 3600.0])
        rate = smoothed_rate(T, t, None, 20.0, seconds_per_unit=1.0)
        assert_array_equal(out[rows, 0], T)
        assert_array_equal(out[rows, 1], rate)
        assert_array_equal(out[rows, 2], T * rate)
        assert_array_equal(out[rows, 3:], deficit)
        assert_array_equal(out[rows][0, 1:], 0.0)  # the first row of a run: dT = 0, lags 0


def test_lag_terms_with_several_sensors():
    rng = np.random.default_rng(13)
    t = np.cumsum(rng.uniform(5.0, 60.0, 80))
    coil = 20.0 + np.cumsum(rng.normal(0.0, 0.1, 80))
    case = coil - 1.0
    X = pd.DataFrame({"time": t, "coil": coil, "case": case})
    features = ThermalFeatures(temperature=["coil", "case"], time="time", terms=("T", "T_lag300s"))
    out = features.fit_transform(X)
    assert list(features.get_feature_names_out()) == [
        "coil_T",
        "coil_T_lag300s",
        "case_T",
        "case_T_lag300s",
    ]
    assert_array_equal(out[:, 1], lag_deficit(coil, t, None, 300.0))
    assert_array_equal(out[:, 3], lag_deficit(case, t, None, 300.0))
    # The lag of a constant offset is the same offset: equal deficits.
    assert_allclose(out[:, 1], out[:, 3], atol=1e-12)


@pytest.mark.parametrize(
    "name", ["T_lag0s", "T_lag0.0s", "T_lags", "T_lag-5s", "T_lag1e3s", "T_lag600", "t_lag600s"]
)
def test_bad_lag_term_names_list_the_valid_forms(name):
    with pytest.raises(ValueError, match=r"(Unknown term|must be > 0 seconds)") as info:
        ThermalFeatures(time="time", terms=("T", name)).get_feature_names_out()
    if "Unknown" in str(info.value):
        assert "'T_lag<tau>s' with tau in seconds" in str(info.value)
        assert "'T_lag600s', 'T_lag90.5s'" in str(info.value)


def test_duplicate_time_constant_and_lag_without_time():
    with pytest.raises(
        ValueError, match=re.escape("Duplicate term(s) ['T_lag600.0s', 'T_lag600s']")
    ):
        ThermalFeatures(terms=("T_lag600s", "T_lag600.0s")).get_feature_names_out()
    with pytest.raises(ValueError, match=r"lag term\(s\) \['T_lag600s'\] need a time column"):
        ThermalFeatures(terms=("T", "T_lag600s")).fit_transform(_frame(T4))


def test_first_row_of_each_run_has_zero_rate():
    X = _frame([20.0, 30.0, 21.0, 33.0], run=[1, 2, 1, 2])
    out = ThermalFeatures(run="run", terms=["dT"]).fit_transform(X)
    assert_array_equal(out[:, 0], [0.0, 0.0, 1.0, 3.0])


# --- run isolation and causality -------------------------------------------------------------


@pytest.mark.parametrize(
    ("smoothing", "terms"),
    [(0.0, VALID_4), (4.0, VALID_4), (3.0, (*VALID_4, "T_lag2s", "T_lag30s"))],
)
def test_interleaved_runs_equal_per_run_results_bit_for_bit(smoothing, terms):
    frame, run_a, run_b, is_a = _two_run_frame()
    features = ThermalFeatures(time="time", run="run", smoothing=smoothing, terms=terms)
    out = features.fit_transform(frame)
    alone_a = ThermalFeatures(time="time", smoothing=smoothing, terms=terms).fit_transform(run_a)
    alone_b = ThermalFeatures(time="time", smoothing=smoothing, terms=terms).fit_transform(run_b)
    assert_array_equal(out[is_a], alone_a)
    assert_array_equal(out[~is_a], alone_b)
    # Without the run column the two runs would mix: the test data can tell the difference.
    mixed = ThermalFeatures(terms=VALID_4).fit_transform(frame[["temperature"]])
    assert not np.array_equal(mixed[is_a], alone_a[:, : len(VALID_4)])


def test_numeric_run_ids_and_many_runs_bit_for_bit():
    rng = np.random.default_rng(3)
    lengths = [1, 2, 5, 9, 17, 40]  # several power-of-two length classes of the smoother
    run = np.repeat(np.arange(len(lengths)) * 10.0, lengths)  # rows grouped, in time order
    temperature = rng.normal(25.0, 3.0, run.size)
    # A random interleaving of the runs that keeps each run's rows in order.
    slot_runs = rng.permutation(run)
    source_row = np.empty(run.size, dtype=int)
    source_row[np.argsort(slot_runs, kind="stable")] = np.arange(run.size)
    # Time within each run: irregular steps of 5 to 60 s.
    time = np.concatenate([np.cumsum(rng.uniform(5.0, 60.0, n)) for n in lengths])
    X = np.column_stack([run[source_row], temperature[source_row], time[source_row]])
    assert not np.array_equal(X[:, 0], run)
    params = {"smoothing": 25.0, "terms": ("T", "dT", "T_lag30s", "T_lag900s")}
    out = ThermalFeatures(temperature=1, run=0, time=2, **params).fit_transform(X)
    for run_id in np.unique(run):
        rows = run == run_id
        alone = ThermalFeatures(temperature=0, time=1, **params).fit_transform(
            np.column_stack([temperature[rows], time[rows]])
        )
        assert_array_equal(out[X[:, 0] == run_id], alone)


@pytest.mark.parametrize("k", [1, 2, 7, 16, 17, 30, 64, 65, 200])
def test_causal_prefix_property(k):
    _, run_a, _, _ = _two_run_frame(seed=1, n_a=301)
    features = ThermalFeatures(
        time="time", smoothing=5.0, terms=(*VALID_4, "T_lag3s", "T_lag100s")
    )
    whole = features.fit_transform(run_a)
    prefix = features.fit_transform(run_a.iloc[:k])
    assert_array_equal(prefix, whole[:k])


def test_output_rows_follow_input_rows():
    frame, _, _, _ = _two_run_frame(seed=2)
    frame.index = frame.index[::-1]
    features = ThermalFeatures(time="time", run="run").set_output(transform="pandas")
    out = features.fit_transform(frame)
    assert list(out.index) == list(frame.index)
    assert_array_equal(out["T"].to_numpy(), frame["temperature"].to_numpy())


# --- plain numerics --------------------------------------------------------------------------


def test_causal_rate_rejects_non_increasing_time():
    with pytest.raises(ValueError, match=r"row 2 has time 1\.0 after 1\.0 at row 1"):
        causal_rate([1.0, 2.0, 3.0], [True, False, False], time=[0.0, 1.0, 1.0])
    # A time reset at a run start is fine.
    rate = causal_rate([1.0, 2.0, 3.0], [True, False, True], time=[0.0, 30.0, 0.0])
    assert_array_equal(rate, [0.0, 2.0, 0.0])


def test_assemble_terms_gradient_and_compute_match_estimator():
    T = np.array([[20.0, 21.0], [22.0, 25.0]])
    out = assemble_terms(T, np.zeros_like(T), ["T", "gradient"])
    assert_array_equal(out, [[20.0, 21.0, 1.0], [22.0, 25.0, 3.0]])
    frame, _, _, _ = _two_run_frame(seed=5)
    direct = compute_thermal_features(
        frame["temperature"].to_numpy(),
        time=frame["time"].to_numpy(),
        run=frame["run"].to_numpy(),
        terms=DEFAULT_STATE_TERMS,
        smoothing=2.0,
        seconds_per_unit=60.0,
    )
    # The estimator's default terms with a time column.
    estimator = ThermalFeatures(time="time", run="run", smoothing=2.0).fit_transform(frame)
    assert_array_equal(direct, estimator)


# --- several sensors, containers, names ------------------------------------------------------


def test_several_sensors_names_and_values():
    X = pd.DataFrame(
        {"coil": [20.0, 21.0, 23.0], "case": [19.0, 19.5, 21.0], "run": ["r", "r", "r"]}
    )
    features = ThermalFeatures(
        temperature=["coil", "case"], run="run", terms=("T", "dT", "TdT", "gradient")
    ).set_output(transform="pandas")
    out = features.fit_transform(X)
    assert list(out.columns) == [
        "coil_T",
        "coil_dT",
        "coil_T_dT",
        "case_T",
        "case_dT",
        "case_T_dT",
        "case_gradient",
    ]
    assert_array_equal(out["coil_dT"], [0.0, 1.0, 2.0])
    assert_array_equal(out["case_dT"], [0.0, 0.5, 1.5])
    assert_array_equal(out["case_T_dT"], [0.0, 9.75, 31.5])
    assert_array_equal(out["case_gradient"], [-1.0, -1.5, -2.0])


def test_several_sensors_by_position_names():
    X = np.array([[20.0, 1.0, 19.0], [21.0, 1.0, 19.5]])
    features = ThermalFeatures(temperature=[2, 0], terms=["T", "gradient"])
    assert list(features.get_feature_names_out()) == ["x2_T", "x0_T", "x0_gradient"]
    out = features.fit_transform(X)
    assert list(features.get_feature_names_out()) == ["x2_T", "x0_T", "x0_gradient"]
    assert_array_equal(out, [[19.0, 20.0, 1.0], [19.5, 21.0, 1.5]])
    frame = pd.DataFrame(X, columns=["coil", "flag", "case"])
    features.fit(frame)
    assert list(features.get_feature_names_out()) == ["case_T", "coil_T", "coil_gradient"]


def test_array_and_dataframe_give_equal_values():
    frame, _, _, _ = _two_run_frame(seed=6)
    by_name = ThermalFeatures(time="time", run="run", smoothing=1.5).fit_transform(frame)
    array = frame[["run", "time", "temperature"]].to_numpy()  # object array: string run ids
    by_position = ThermalFeatures(temperature=2, time=1, run=0, smoothing=1.5).fit_transform(array)
    assert_array_equal(by_name, by_position)


def test_polars_input_equals_pandas():
    frame, _, _, _ = _two_run_frame(seed=7)
    features = ThermalFeatures(time="time", run="run", smoothing=2.0, terms=VALID_4)
    from_pandas = features.fit_transform(frame)
    from_polars = features.fit_transform(pl.from_pandas(frame))
    assert_array_equal(from_polars, from_pandas)
    out = features.set_output(transform="polars").fit_transform(pl.from_pandas(frame))
    assert isinstance(out, pl.DataFrame)
    assert out.columns == ["T", "dT", "T_dT", "T2"]
    assert_array_equal(out.to_numpy(), from_pandas)


def test_set_output_pandas_named_columns():
    frame, _, _, _ = _two_run_frame(seed=8)
    frame.index = frame.index + 100
    features = ThermalFeatures(time="time", run="run").set_output(transform="pandas")
    out = features.fit(frame).transform(frame)
    assert list(out.columns) == [
        "T",
        "dT",
        "T_dT",
        "T2",
        "T_lag900s",
        "T_T_lag900s",
        "T_lag3600s",
        "T_T_lag3600s",
    ]
    assert_array_equal(out["T_T_lag900s"], out["T"] * out["T_lag900s"])
    assert list(out.index) == list(frame.index)
    assert_array_equal(out["T"], frame["temperature"])


def test_transform_without_fit_is_stateless():
    frame, _, _, _ = _two_run_frame(seed=9)
    unfitted = ThermalFeatures(time="time", run="run")
    assert unfitted.__sklearn_is_fitted__()
    assert not hasattr(unfitted, "n_features_in_")
    assert_array_equal(unfitted.transform(frame), unfitted.fit_transform(frame))
    assert unfitted.n_features_in_ == 4
    assert list(unfitted.feature_names_in_) == ["run", "time", "temperature", "note"]


# --- GridSearchCV ----------------------------------------------------------------------------


def test_gridsearch_tunes_smoothing_in_pipeline():
    """Checked once on data seeds 10-19 (holds on each)."""
    rng = np.random.default_rng(10)
    parts = []
    for run in range(4):
        time = np.arange(120) * 10.0
        temperature = 20.0 + np.cumsum(rng.normal(0.0, 0.2, 120))
        parts.append(pd.DataFrame({"run": run, "time": time, "temperature": temperature}))
    X = pd.concat(parts, ignore_index=True)
    # The drift follows the rate of a smoothed temperature (time constant 40 s).
    true_rate = ThermalFeatures(time="time", run="run", smoothing=40.0, terms=["dT"])
    y = 0.3 * true_rate.fit_transform(X)[:, 0] + rng.normal(0.0, 1e-3, len(X))
    pipe = make_pipeline(ThermalFeatures(time="time", run="run", terms=["dT"]), LinearRegression())
    grid = {"thermalfeatures__smoothing": [0.0, 40.0, 200.0]}
    search = GridSearchCV(pipe, grid, cv=GroupKFold(n_splits=2)).fit(X, y, groups=X["run"])
    assert search.best_params_["thermalfeatures__smoothing"] == 40.0
    assert np.all(np.isfinite(search.cv_results_["mean_test_score"]))
    assert search.cv_results_["mean_test_score"].max() > 0.99


# --- errors ----------------------------------------------------------------------------------


def test_missing_column_is_named_with_available_ones():
    X = _frame(T4, time=[0.0, 1.0, 2.0, 3.0])
    with pytest.raises(
        ValueError, match=r"Column 'coil' \(temperature\) not found in X; available columns: "
    ) as info:
        ThermalFeatures(temperature="coil").fit(X)
    assert "['temperature', 'time']" in str(info.value)
    with pytest.raises(ValueError, match=r"Column 'run' \(run\) not found"):
        ThermalFeatures(run="run").fit(X)


def test_column_name_with_array_and_position_out_of_range():
    X = np.ones((3, 2))
    with pytest.raises(ValueError, match=r"temperature='temperature' names a column, but X has"):
        ThermalFeatures().fit(X)
    with pytest.raises(ValueError, match=r"time=5 is not a column position of X, which has 2"):
        ThermalFeatures(temperature=0, time=5).fit(X)


def test_same_column_in_two_roles_and_duplicate_sensors():
    X = _frame(T4, time=[0.0, 1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match=r"time='temperature' is the same column as temperature"):
        ThermalFeatures(time="temperature").fit(X)
    with pytest.raises(ValueError, match="lists a column twice"):
        ThermalFeatures(temperature=["temperature", 0]).fit(X)
    with pytest.raises(ValueError, match="temperature is empty"):
        ThermalFeatures(temperature=[]).fit(X)


def test_non_numeric_temperature_and_time():
    with pytest.raises(ValueError, match=r"temperature column 'temperature' must be numeric"):
        ThermalFeatures().fit(_frame(["warm", "hot", "hot", "hot"]))
    with pytest.raises(ValueError, match=r"time column 'time' must be numeric"):
        ThermalFeatures(time="time").fit(_frame(T4, time=["a", "b", "c", "d"]))
    # Strings that look like numbers are not parsed silently in an object array either.
    X = np.array([["20.5", 1], ["21.0", 1]], dtype=object)
    with pytest.raises(ValueError, match=r"temperature column 0 must be numeric"):
        ThermalFeatures(temperature=0).fit(X)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_nan_or_inf_temperature_names_column_and_row(bad):
    X = _frame([20.0, 21.0, bad, 22.0, bad])
    with pytest.raises(
        ValueError,
        match=r"temperature column 'temperature' contains NaN or inf \(2 value\(s\); "
        r"first at row 2",
    ):
        ThermalFeatures().fit(X)
    with pytest.raises(ValueError, match=r"first at row 2"):
        ThermalFeatures().transform(X)


def test_time_not_increasing_names_run_and_row():
    X = pd.DataFrame(
        {
            "run": ["a", "b", "a", "b", "b", "a"],
            "time": [0.0, 0.0, 60.0, 30.0, 30.0, 50.0],
            "temperature": [20.0, 30.0, 21.0, 29.0, 28.0, 22.0],
        }
    )
    with pytest.raises(
        ValueError,
        match=r"time column 'time': time must increase strictly within each run; in run 'b' "
        r"row 4 has time 30\.0, not after 30\.0 at row 3",
    ):
        ThermalFeatures(time="time", run="run").fit(X)
    # Without the run column, X is one run: the first violation is row 1 (0.0 after 0.0).
    with pytest.raises(ValueError, match=r"; row 1 has time 0\.0, not after 0\.0 at row 0"):
        ThermalFeatures(time="time").transform(X)


def test_missing_run_ids_are_rejected():
    X = _frame(T4, run=["a", None, "a", "a"])
    with pytest.raises(ValueError, match=r"run column 'run' has missing run ids \(first at row 1"):
        ThermalFeatures(run="run").fit(X)
    X = _frame(T4, run=[1.0, 1.0, np.nan, 1.0])
    with pytest.raises(ValueError, match=r"missing run ids \(first at row 2"):
        ThermalFeatures(run="run").fit(X)
    with pytest.raises(ValueError, match=r"run column 1 has missing run ids \(first at row 3"):
        ThermalFeatures(temperature=0, run=1).fit(
            np.array([[20, "a"], [21, "a"], [22, "b"], [23, None]], dtype=object)
        )
    X = pl.DataFrame({"temperature": T4, "run": [None, "a", "a", "a"]})
    with pytest.raises(ValueError, match=r"run column 'run' has missing run ids \(first at row 0"):
        ThermalFeatures(run="run").fit(X)


@pytest.mark.parametrize(
    ("terms", "message"),
    [
        (
            ("T", "dT2"),
            re.escape("Unknown term(s) ['dT2'] in terms; valid terms are ['T', 'dT', 'TdT', 'T2'"),
        ),
        ((), "terms is empty"),
        (("T", "dT", "T"), re.escape("Duplicate term(s) ['T']")),
        (("gradient",), "needs at least two temperature columns; got 1"),
    ],
)
def test_bad_terms(terms, message):
    with pytest.raises(ValueError, match=message):
        ThermalFeatures(terms=terms).fit(_frame(T4))
    with pytest.raises(ValueError, match=message):
        ThermalFeatures(terms=terms).get_feature_names_out()


def test_wrong_columns_at_transform():
    X = _frame(T4, time=[0.0, 1.0, 2.0, 3.0])
    features = ThermalFeatures(time="time").fit(X)
    with pytest.raises(
        ValueError, match="Feature names seen at fit time, yet now missing:\n- time"
    ):
        features.transform(X[["temperature"]])
    with pytest.raises(ValueError, match="The feature names should match those"):
        features.transform(X.rename(columns={"time": "seconds"}))
    array_fitted = ThermalFeatures(temperature=0).fit(np.ones((3, 2)))
    with pytest.raises(ValueError, match="X has 3 features, but ThermalFeatures is expecting 2"):
        array_fitted.transform(np.ones((3, 3)))


@pytest.mark.parametrize(
    ("params", "name"),
    [
        ({"smoothing": -1.0}, "smoothing"),
        ({"smoothing": "big"}, "smoothing"),
        ({"rate_unit": "day"}, "rate_unit"),
        ({"rate_unit": 0.0}, "rate_unit"),
        ({"terms": "T"}, "terms"),
        ({"temperature": 1.5}, "temperature"),
        ({"time": -1}, "time"),
        ({"run": 2.0}, "run"),
    ],
)
def test_bad_parameter_types(params, name):
    with pytest.raises(InvalidParameterError, match=f"The '{name}' parameter of ThermalFeatures"):
        ThermalFeatures(**params).fit(_frame(T4))


def test_bad_column_key_type_in_list_and_sparse_input():
    with pytest.raises(TypeError, match=r"temperature must name a column .* got 1\.5"):
        ThermalFeatures(temperature=["temperature", 1.5]).fit(_frame(T4))
    with pytest.raises(TypeError, match=r"[Ss]parse"):
        ThermalFeatures(temperature=0).fit(sparse.csr_matrix(np.ones((3, 2))))


# --- sampling invariance ---------------------------------------------------------------------


def _simulated_run(sampling_period):
    # The lumped preset: its sensor temperature is smooth (max |c''| 2.6e-6 degC/s^2), so the
    # linear-hold term of the bounds below is small and the bounds are set by the resolution.
    # The layered presets' housing sensor follows the chamber's set-point corners closely
    # (max |c''| 1e-4 degC/s^2 at a corner), which loosens that term, not the features.
    return make_thermal_campaign(
        n_units=1,
        n_runs=1,
        azimuths=0.0,
        sampling_period=sampling_period,
        noise=False,
        physics="lumped",
        random_state=0,
    ).frame


def test_sampling_invariance_of_lags_and_smoothed_rate(monkeypatch):
    """The same physical run at 10 s and 60 s: features agree at coincident times.

    Bound, from the sensor's 0.01 degC resolution q. Write each reading u = c + e, c the
    simulated (unquantised) sensor temperature and |e| <= q/2. A deficit is D(u) = u - L(u),
    L a lag of unit gain and positive kernel, so at a coincident time
    |D10 - D60| <= |u10 - u60| + |L10(u10) - L60(u60)|, with
    |u10 - u60| <= q + eta and |L10(u10) - L60(u60)| <= q + eta + (10^2 + 60^2) / 8 max|c''|
    (quantisation: L(e) within +-q/2 for each; eta: the simulator's own difference between
    its 10 s and 60 s sensor temperatures at coincident times; interpolation: a linear hold of
    step h misses c by at most h^2/8 max|c''|). The smoothed rate is D / tau.
    """
    runs = {period: _simulated_run(period) for period in (10.0, 60.0)}
    t10, t60 = (runs[p]["time"].to_numpy() for p in (10.0, 60.0))
    coincident = slice(None, None, 6)
    assert_array_equal(t10[coincident], t60)
    # The unquantised sensor temperatures (resolution 1e-12): eta and the curvature.
    monkeypatch.setattr(_simulator, "SENSOR_RESOLUTION", 1e-12)
    c10, c60 = (_simulated_run(p)["temperature"].to_numpy() for p in (10.0, 60.0))
    monkeypatch.undo()
    q = 0.01
    assert np.abs(runs[10.0]["temperature"].to_numpy() - c10).max() <= q / 2 + 1e-9
    eta = np.abs(c10[coincident] - c60).max()
    curvature = np.abs(np.diff(c10, 2)).max() / 10.0**2
    # Measured: eta 0.0017 degC (the simulator samples its chamber's corners at the period),
    # curvature 2.6e-6 degC/s^2; the bound (0.0245 degC) is set by the resolution.
    interpolation = (10.0**2 + 60.0**2) / 8 * curvature
    bound = 2 * q + 2 * eta + interpolation
    assert bound < 3 * q

    terms = ("dT", "T_lag600s", "T_lag3600s")
    features = ThermalFeatures(time="time", terms=terms, smoothing=300.0, rate_unit="min")
    out10 = features.fit_transform(runs[10.0])[coincident]
    out60 = features.fit_transform(runs[60.0])
    error = np.abs(out10 - out60).max(axis=0)
    # Measured: dT 0.0019 degC/min, T_lag600s 0.0095 degC, T_lag3600s 0.0100 degC (about one
    # quantum: the two readings at a coincident time may differ by q); bound 0.0245 degC.
    assert np.all(error[1:] <= bound)
    assert error[0] <= bound / 300.0 * 60.0
    # The plain backward difference of the same readings is not sampling-invariant: its
    # quantisation noise is q / h, six times larger at 10 s (measured: 0.05 degC/min).
    plain = ThermalFeatures(time="time", terms=["dT"])
    raw_error = np.abs(
        plain.fit_transform(runs[10.0])[coincident] - plain.fit_transform(runs[60.0])
    ).max()
    assert raw_error > 10 * error[0]


def test_sampling_invariance_of_default_features(monkeypatch):
    """The default features of one physical run at 10 s and 60 s agree after the first hour.

    Same bound as above (from the sensor's resolution q = 0.01 degC, the simulator's own
    difference eta between its 10 s and 60 s sensor temperatures and the linear hold), per
    column of the default ``("T", "dT", "TdT", "T2", "T_lag900s", "TT_lag900s",
    "T_lag3600s", "TT_lag3600s")`` with ``dT`` smoothed over 120 s:

    - T, the raw readings: ``|u10 - u60| <= q + eta``;
    - the lag deficits: ``2 q + 2 eta + (10^2 + 60^2) / 8 max|c''|``;
    - dT, the deficit at 120 s over 120 s, in degC/min: that bound times 60 / 120;
    - T·dT: ``max|T| b_dT + max|dT| b_T`` (product rule on the two bounds above);
    - T² and T·deficit: the product rule with its second-order term,
      ``|a1 b1 - a2 b2| <= |a2| |b1 - b2| + |b2| |a1 - a2| + |a1 - a2| |b1 - b2|``.
    """
    runs = {period: _simulated_run(period) for period in (10.0, 60.0)}
    t10, t60 = (runs[p]["time"].to_numpy() for p in (10.0, 60.0))
    coincident = slice(None, None, 6)
    assert_array_equal(t10[coincident], t60)
    monkeypatch.setattr(_simulator, "SENSOR_RESOLUTION", 1e-12)
    c10, c60 = (_simulated_run(p)["temperature"].to_numpy() for p in (10.0, 60.0))
    monkeypatch.undo()
    q = 0.01
    eta = np.abs(c10[coincident] - c60).max()
    curvature = np.abs(np.diff(c10, 2)).max() / 10.0**2
    deficit_bound = 2 * q + 2 * eta + (10.0**2 + 60.0**2) / 8 * curvature
    assert deficit_bound < 3 * q

    features = ThermalFeatures(time="time", run="run")
    out10 = features.fit_transform(runs[10.0])[coincident]
    assert features.terms_ == (
        "T",
        "dT",
        "TdT",
        "T2",
        "T_lag900s",
        "TT_lag900s",
        "T_lag3600s",
        "TT_lag3600s",
    )
    assert features.smoothing_ == 120.0
    out60 = features.fit_transform(runs[60.0])
    after_first_hour = t60 >= 3600.0
    out10, out60 = out10[after_first_hour], out60[after_first_hour]
    names = list(features.get_feature_names_out())
    error = dict(zip(names, np.abs(out10 - out60).max(axis=0), strict=True))
    column = {name: out60[:, names.index(name)] for name in names}
    temperature_bound = q + eta
    rate_bound = deficit_bound * 60.0 / 120.0
    largest_T = np.abs(column["T"]).max()
    product_bound = largest_T * rate_bound + np.abs(column["dT"]).max() * temperature_bound

    def second_order_product_bound(a_max, a_bound, b_max, b_bound):
        return a_max * b_bound + b_max * a_bound + a_bound * b_bound

    square_bound = second_order_product_bound(
        largest_T, temperature_bound, largest_T, temperature_bound
    )
    # Measured (lumped physics): T 0.0100, dT 0.0046 degC/min, T_dT 0.106, T_lag900s 0.0097,
    # T_lag3600s 0.0100 degC; bounds 0.0117, 0.0122, 0.375, 0.0245, 0.0245. T2 0.524,
    # T_T_lag900s 0.276, T_T_lag3600s 0.379 degC²; bounds 0.710, 0.793, 0.884.
    assert error["T"] <= temperature_bound
    assert error["dT"] <= rate_bound
    assert error["T_dT"] <= product_bound
    assert error["T2"] <= square_bound
    for tau in ("900", "3600"):
        assert error[f"T_lag{tau}s"] <= deficit_bound
        assert error[f"T_T_lag{tau}s"] <= second_order_product_bound(
            largest_T, temperature_bound, np.abs(column[f"T_lag{tau}s"]).max(), deficit_bound
        )
    # The columns are not trivially equal: the run heats and cools by tens of degC.
    assert np.ptp(column["T"]) > 10.0
    assert np.abs(column["T_lag900s"]).max() > 100 * deficit_bound
    assert np.abs(column["T_T_lag900s"]).max() > 100 * error["T_T_lag900s"]
