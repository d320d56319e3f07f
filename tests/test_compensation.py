"""Drift targets (rate - reference, the paper's error set Q) and compensated rates."""

import numpy as np
import pandas as pd
import polars as pl
import pytest
from sklearn.compose import ColumnTransformer
from sklearn.exceptions import NotFittedError
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from sklearn_ifog.compensation import compensate, drift_target


@pytest.fixture
def frame():
    rng = np.random.default_rng(0)
    n = 12
    return pd.DataFrame(
        {
            # Interleaved runs, as a merged log could hold them.
            "run": np.tile([7, 3, 5], n // 3),
            "temperature": np.linspace(-10.0, 40.0, n),
            "rate": 9.0 + rng.normal(size=n),
            "reference": np.repeat([9.5, 10.0], n // 2),
        },
        index=np.arange(100, 100 + n),
    )


def test_reference_target_is_rate_minus_reference(frame):
    target = drift_target(frame)
    assert isinstance(target, pd.Series)
    assert target.name == "drift_measured"
    pd.testing.assert_index_equal(target.index, frame.index)
    np.testing.assert_array_equal(target.to_numpy(), (frame["rate"] - frame["reference"]))


def test_error_set_is_output_minus_its_run_mean(frame):
    target = drift_target(frame, kind="error_set", reference=None)
    assert target.name == "error_set"
    expected = frame["rate"] - frame.groupby("run")["rate"].transform("mean")
    np.testing.assert_allclose(target.to_numpy(), expected.to_numpy(), atol=1e-12)
    np.testing.assert_allclose(target.groupby(frame["run"]).mean().to_numpy(), 0.0, atol=1e-12)


def test_error_set_subtracts_reference_first_when_given(frame):
    with_reference = drift_target(frame, kind="error_set")
    difference = frame["rate"] - frame["reference"]
    expected = difference - difference.groupby(frame["run"]).transform("mean")
    np.testing.assert_allclose(with_reference.to_numpy(), expected.to_numpy(), atol=1e-12)


def test_error_set_with_constant_reference_per_run_ignores_it(frame):
    frame = frame.assign(reference=frame["run"].map({7: 1.0, 3: -2.0, 5: 4.0}))
    np.testing.assert_allclose(
        drift_target(frame, kind="error_set").to_numpy(),
        drift_target(frame, kind="error_set", reference=None).to_numpy(),
        atol=1e-12,
    )


def test_error_set_without_run_column_is_one_run(frame):
    target = drift_target(frame.drop(columns="run"), kind="error_set", run=None)
    np.testing.assert_allclose(
        target.to_numpy(), (frame["rate"] - frame["reference"]).pipe(lambda d: d - d.mean())
    )


def test_polars_frame_gives_array(frame):
    target = drift_target(pl.from_pandas(frame), kind="error_set")
    assert isinstance(target, np.ndarray)
    np.testing.assert_allclose(target, drift_target(frame, kind="error_set").to_numpy())


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"rate": "gyro"}, ValueError, r"Column 'gyro' \(rate\) not found in frame; available"),
        (
            {"reference": "earth"},
            ValueError,
            r"Column 'earth' \(reference\) not found in frame; available",
        ),
        (
            {"kind": "error_set", "run": "burst"},
            ValueError,
            r"Column 'burst' \(run\) not found in frame.*Pass run=None",
        ),
        ({"kind": "mean"}, ValueError, r"kind must be one of"),
        ({"reference": None}, ValueError, r'kind="reference" needs the reference'),
    ],
)
def test_bad_arguments_name_the_problem(frame, kwargs, error, match):
    with pytest.raises(error, match=match):
        drift_target(frame, **kwargs)


def test_text_column_is_a_type_error(frame):
    frame = frame.assign(reference="north")
    with pytest.raises(TypeError, match=r"reference column 'reference' must be numeric"):
        drift_target(frame)


def test_missing_values_are_refused_not_dropped(frame):
    frame.loc[104, "rate"] = np.nan
    with pytest.raises(
        ValueError, match=r"rate column 'rate' contains NaN or inf \(1 value\(s\); first at row 4"
    ):
        drift_target(frame)


def test_not_a_frame_is_a_type_error():
    with pytest.raises(TypeError, match="frame must be a pandas or polars DataFrame"):
        drift_target(np.zeros((3, 2)))


@pytest.fixture
def fitted(frame):
    X = frame[["temperature"]]
    drift = 0.02 * frame["temperature"] + 0.1
    model = make_pipeline(StandardScaler(), LinearRegression()).fit(X, drift)
    return model, X, drift


def test_compensate_subtracts_the_predicted_drift(frame, fitted):
    model, X, drift = fitted
    rate = frame["reference"] + drift
    compensated = compensate(model, X, rate)
    assert isinstance(compensated, pd.Series)
    assert compensated.name == "rate_compensated"
    pd.testing.assert_index_equal(compensated.index, frame.index)
    np.testing.assert_allclose(compensated.to_numpy(), frame["reference"].to_numpy(), atol=1e-9)
    np.testing.assert_allclose(
        compensate(model, X, rate.to_numpy()), rate.to_numpy() - model.predict(X)
    )


def test_compensate_reads_rate_column_of_X(frame):
    # The model only reads the temperature column; the rate column rides along in X.
    model = make_pipeline(
        ColumnTransformer([("temperature", "passthrough", ["temperature"])]), LinearRegression()
    ).fit(frame, 0.01 * frame["temperature"])
    compensated = compensate(model, frame, "rate")
    np.testing.assert_allclose(
        compensated.to_numpy(), frame["rate"].to_numpy() - 0.01 * frame["temperature"].to_numpy()
    )
    with pytest.raises(
        ValueError, match=r"Column 'gyro' \(rate\) not found in X; available columns"
    ):
        compensate(model, frame, "gyro")


def test_compensate_refuses_unfitted_and_mismatched_input(frame, fitted):
    model, X, _ = fitted
    with pytest.raises(NotFittedError):
        compensate(LinearRegression(), X, frame["rate"])
    with pytest.raises(ValueError, match=r"rate has 5 values but X has 12 rows"):
        compensate(model, X, frame["rate"].to_numpy()[:5])
    with pytest.raises(ValueError, match=r"rate='rate' names a column, but X has no column names"):
        compensate(model, X.to_numpy(), "rate")


def test_compensate_refuses_multi_output_models(frame):
    X = frame[["temperature"]]
    model = LinearRegression().fit(X, np.column_stack([frame["rate"], frame["rate"]]))
    with pytest.raises(ValueError, match="predicts 2 outputs"):
        compensate(model, X, frame["rate"])


def test_error_set_refuses_missing_run_ids_and_handles_interleaved_runs(frame):
    # Interleaved runs: the per-run mean is the mean of each run's rows wherever they are.
    shuffled = frame.sample(frac=1.0, random_state=0)
    target = drift_target(shuffled, kind="error_set")
    np.testing.assert_allclose(
        target.sort_index().to_numpy(), drift_target(frame, kind="error_set").to_numpy()
    )
    frame = frame.assign(run=frame["run"].astype(float))
    frame.loc[frame.index[3], "run"] = np.nan
    with pytest.raises(ValueError, match=r"run column 'run' has missing run ids \(first at row 3"):
        drift_target(frame, kind="error_set")
