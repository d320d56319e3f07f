"""StreamingCompensator: online compensation equal to the batch Pipeline.

"Equal to 1e-12 relative", sample by sample, for the drift and the compensated rate, with an
absolute floor of 1e-12 times the largest value on the run (a value near zero has no
meaningful ratio). The features are bit for bit the batch ones, except the lag terms and the
smoothed rate of a run cut into chunks (1e-12 relative: the batch prefix scan groups its
products differently); the rows after ThermalFeatures go through the same fitted steps, but
BLAS may sum a 1-row product in another order than a 1,500-row one, hence a tolerance rather
than equality (equality is asserted where the shapes are the same).
"""

import json
import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import Ridge
from sklearn.pipeline import Pipeline, make_pipeline
from sklearn.preprocessing import (
    MaxAbsScaler,
    MinMaxScaler,
    PolynomialFeatures,
    RobustScaler,
    StandardScaler,
)

from sklearn_ifog import RBFNetRegressor, ThermalFeatures
from sklearn_ifog._lags import lag_deficit, lag_step
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.features import compute_thermal_features
from sklearn_ifog.streaming import StreamingCompensator, advance_features

LAG_TERMS = ("T", "dT", "TdT", "T_lag600s", "T_lag3600s", "TT_lag3600s")

RTOL = 1e-12


@pytest.fixture(scope="module")
def campaign():
    frame = make_thermal_campaign(n_units=1, n_runs=1, sampling_period=10.0, random_state=0).frame
    runs = frame["run"].unique()[:2]
    frame = frame[frame["run"].isin(runs)]
    # Keep the module fast: the first 1,500 samples of each of two runs (a run's prefix is a
    # run: the features are causal).
    frame = frame.groupby("run", sort=False).head(1500).reset_index(drop=True)
    frame["temperature_2"] = frame["temperature"].rolling(20, min_periods=1).mean()
    return frame


def _rbf(**params):
    params = {"n_centers": 15, "max_candidates": 100, "max_samples": 1000, **params}
    return RBFNetRegressor(random_state=0, **params)


def _features(**params):
    return ThermalFeatures(temperature="temperature", time="time", run="run", **params)


@pytest.fixture(scope="module")
def models(campaign):
    y = campaign["drift"]
    return {
        # The default (quadratic) tail, with exactly 15 Gaussian units.
        "rbf": make_pipeline(
            _features(terms=("T", "dT", "TdT"), smoothing=120.0),
            StandardScaler(),
            _rbf(criterion=None),
        ).fit(campaign, y),
        # The default features: thermal-state terms, dT smoothed over 120 s.
        "poly-ridge": make_pipeline(
            _features(), StandardScaler(), PolynomialFeatures(2), Ridge(alpha=1e-3)
        ).fit(campaign, y),
        # Thermal-state terms and a smoothed rate: five lags per sensor carried.
        "lags": make_pipeline(
            _features(terms=LAG_TERMS, smoothing=300.0),
            StandardScaler(),
            PolynomialFeatures(2),
            Ridge(alpha=1e-3),
        ).fit(campaign, y),
    }


@pytest.fixture(scope="module", params=["rbf", "poly-ridge", "lags"])
def model(request, models):
    return models[request.param]


def _one_run(campaign, n_samples=None):
    run = campaign[campaign["run"] == campaign["run"].iloc[0]]
    return run if n_samples is None else run.iloc[:n_samples]


def _stream(compensator, frame, chunk, rate=None):
    compensated, drift = [], []
    rate = frame["rate"].to_numpy() if rate is None else rate
    for start in range(0, len(frame), chunk):
        out = compensator.update(frame.iloc[start : start + chunk], rate[start : start + chunk])
        compensated.append(out[0])
        drift.append(out[1])
    return np.concatenate(compensated), np.concatenate(drift)


def _assert_close(actual, expected):
    expected = np.asarray(expected)
    floor = RTOL * np.max(np.abs(expected))
    np.testing.assert_allclose(actual, expected, rtol=RTOL, atol=floor)


def _assert_equal_to_batch(model, frame, compensated, drift):
    expected_drift = model.predict(frame)
    _assert_close(compensated, frame["rate"].to_numpy() - expected_drift)
    _assert_close(drift, expected_drift)


@pytest.mark.parametrize("chunk", [1, 7, None], ids=["1", "7", "whole-run"])
def test_streaming_equals_batch_for_any_chunking(model, campaign, chunk):
    # Chunks of one sample cost a Pipeline call each: a 600-sample run is enough there.
    run = _one_run(campaign, 600 if chunk == 1 else None)
    compensated, drift = _stream(StreamingCompensator(model), run, chunk or len(run))
    _assert_equal_to_batch(model, run, compensated, drift)


def test_whole_run_chunk_is_bitwise_batch(model, campaign):
    run = _one_run(campaign)
    _, drift = StreamingCompensator(model).update(run, run["rate"])
    np.testing.assert_array_equal(drift, model.predict(run))


def test_save_and_restore_mid_run(model, campaign):
    run = _one_run(campaign)
    half = len(run) // 2 + 3
    first = StreamingCompensator(model)
    head = first.update(run.iloc[:half], run["rate"].iloc[:half])
    saved = json.loads(json.dumps(first.get_state()))
    # The first compensator goes on with other rows: the saved state must not move with it.
    first.update(run.iloc[half : half + 10], run["rate"].iloc[half : half + 10])
    second = StreamingCompensator(model).set_state(saved)
    tail = _stream(second, run.iloc[half:], 7)
    compensated = np.concatenate([head[0], tail[0]])
    drift = np.concatenate([head[1], tail[1]])
    _assert_equal_to_batch(model, run, compensated, drift)
    assert saved["has_history"] is True
    assert len(saved["temperature"]) == 1
    n_lags = len(saved["time_constants"])
    assert np.shape(saved["deficit"]) == ((1, n_lags) if n_lags else ())


def test_step_equals_update(models, campaign):
    model = models["rbf"]
    run = _one_run(campaign, 50)
    compensator = StreamingCompensator(model)
    by_step = [
        compensator.step(t, temperature, rate)
        for t, temperature, rate in zip(run["time"], run["temperature"], run["rate"], strict=True)
    ]
    _assert_equal_to_batch(model, run, [c for c, _ in by_step], [d for _, d in by_step])
    assert isinstance(by_step[0][1], float)


def test_run_change_inside_a_chunk_starts_a_new_run(models, campaign):
    model = models["poly-ridge"]
    compensated, drift = _stream(StreamingCompensator(model), campaign, 1100)
    assert campaign["run"].nunique() == 2
    assert len(campaign) % 1100 != 0
    _assert_equal_to_batch(model, campaign, compensated, drift)


def test_returning_to_a_finished_run_is_refused(models, campaign):
    model = models["poly-ridge"]
    first_run, second_run = campaign["run"].unique().tolist()
    compensator = StreamingCompensator(model)
    compensator.update(campaign[campaign["run"] == first_run].iloc[:10])
    compensator.update(campaign[campaign["run"] == second_run].iloc[:10])
    before = compensator.get_state()
    with pytest.raises(ValueError, match=f"Run {first_run!r} already ended"):
        compensator.update(campaign[campaign["run"] == first_run].iloc[10:20])
    assert compensator.get_state() == before, "a refused chunk must leave the state alone"
    assert before["finished_runs"] == [first_run]
    compensator.reset()
    compensator.update(campaign[campaign["run"] == first_run].iloc[:5])


def test_reset_starts_a_new_run_without_run_column(campaign):
    run = _one_run(campaign, 200)
    # The paper's terms: without reset only the first row's dT sees the previous pass (lag
    # terms would carry it for hours).
    features = ThermalFeatures(temperature="temperature", time="time", terms=("T", "dT", "TdT"))
    model = make_pipeline(features, StandardScaler(), Ridge()).fit(run, run["drift"])
    compensator = StreamingCompensator(model)
    compensator.update(run)
    again = compensator.reset().update(run)[1]
    np.testing.assert_array_equal(again, model.predict(run))
    continued = compensator.update(run.assign(time=run["time"] + 1e6))[1]
    # Without reset the first row of the second pass has a dT from the last row: it differs.
    assert continued[0] != again[0]
    np.testing.assert_array_equal(continued[1:], again[1:])


def test_time_must_increase_across_chunks(models, campaign):
    run = _one_run(campaign, 30)
    compensator = StreamingCompensator(models["rbf"])
    compensator.update(run.iloc[:20])
    with pytest.raises(ValueError, match=r"time must increase strictly within run .*row 0"):
        compensator.update(run.iloc[15:25])
    with pytest.raises(ValueError, match=r"time must increase strictly .*row 3"):
        compensator.update(
            run.iloc[20:30].assign(time=run["time"].to_numpy()[[20, 21, 22] * 3 + [29]])
        )


def test_bad_inputs_are_named(models, campaign):
    compensator = StreamingCompensator(models["rbf"])
    with pytest.raises(ValueError, match="Feature names seen at fit time, yet now missing"):
        compensator.update(campaign[["time", "run"]])
    with pytest.raises(
        ValueError, match=r"temperature contains NaN or inf \(1 value\(s\); first at row 0: nan\)"
    ):
        compensator.step(0.0, np.nan, 1.0, run=0)
    with pytest.raises(ValueError, match=r"Expected 1 temperature value\(s\)"):
        compensator.step(0.0, [20.0, 21.0], 1.0)
    with pytest.raises(ValueError, match="needs the time column 'time'"):
        compensator.step(None, 20.0, 1.0)
    with pytest.raises(TypeError, match=r"needs a fitted sklearn\.pipeline\.Pipeline"):
        StreamingCompensator(Ridge())
    scaler_first = Pipeline([("scale", StandardScaler()), ("ridge", Ridge())]).fit(
        campaign[["temperature"]], campaign["drift"]
    )
    with pytest.raises(ValueError, match=r"ThermalFeatures as the Pipeline's first step.*scale"):
        StreamingCompensator(scaler_first)


def test_set_state_validates(models):
    compensator = StreamingCompensator(models["rbf"])
    state = compensator.get_state()
    with pytest.raises(ValueError, match="state must be a dict with keys"):
        compensator.set_state({"run": 0})
    with pytest.raises(ValueError, match="sensor"):
        compensator.set_state({**state, "n_sensors": 2})
    with pytest.raises(ValueError, match=r"state\['temperature'\] must hold 1 value"):
        compensator.set_state({**state, "has_history": True})


def test_several_sensors_and_outputs(campaign):
    features = ThermalFeatures(
        temperature=["temperature", "temperature_2"],
        time="time",
        run="run",
        terms=("T", "dT", "TdT", "T2", "gradient", "T_lag900s"),
        smoothing=60.0,
    )
    y = np.column_stack([campaign["drift"], 0.5 * campaign["drift"] + 0.01])
    # A linear tail: an unpenalised quadratic one on these ten nearly collinear features sums
    # terms ~900 times the drift, which amplifies the last-bit differences of BLAS too.
    model = make_pipeline(features, StandardScaler(), _rbf(tail="linear"))
    model.fit(campaign, y)
    rate = np.column_stack([campaign["rate"], campaign["rate"]])
    compensator = StreamingCompensator(model)
    out = [
        compensator.update(campaign.iloc[s : s + 7], rate[s : s + 7])
        for s in range(0, len(campaign), 7)
    ]
    drift = np.concatenate([d for _, d in out])
    expected = model.predict(campaign)
    assert drift.shape == expected.shape == (len(campaign), 2)
    _assert_close(drift, expected)
    _assert_close(np.concatenate([c for c, _ in out]), rate - expected)
    compensated, drift_one = compensator.reset().step(0.0, [20.0, 20.0], [1.0, 2.0], run=99)
    assert drift_one.shape == compensated.shape == (2,)
    with pytest.raises(ValueError, match=r"one rate per output"):
        compensator.update(campaign.iloc[:2], campaign["rate"].iloc[:2])


def test_array_input_by_position(campaign):
    data = campaign[["time", "temperature", "run"]].to_numpy()
    model = make_pipeline(
        ThermalFeatures(temperature=1, time=0, run=2), StandardScaler(), Ridge()
    ).fit(data, campaign["drift"])
    rate = campaign["rate"].to_numpy()
    compensator = StreamingCompensator(model)
    chunks = [
        compensator.update(data[s : s + 13], rate[s : s + 13]) for s in range(0, len(data), 13)
    ]
    drift = np.concatenate([d for _, d in chunks])
    expected = model.predict(data)
    _assert_close(drift, expected)
    _assert_close(np.concatenate([c for c, _ in chunks]), rate - expected)


@pytest.mark.parametrize("smoothing", [0.0, 3.0])
def test_advance_features_continues_exactly(smoothing):
    rng = np.random.default_rng(0)
    temperature = 20 + np.cumsum(rng.normal(0, 0.01, (150, 2)), axis=0)
    time = np.cumsum(rng.uniform(0.5, 1.5, 150))  # irregular steps
    terms = ("T", "dT", "TdT", "T_lag2s", "T_lag40.5s", "TT_lag2s")
    params = {"terms": terms, "smoothing": smoothing, "seconds_per_unit": 60.0}
    start = {"has_history": False, "temperature": None, "last_time": None, "deficit": None}
    whole, _ = advance_features(temperature, time, start, **params)
    batch = compute_thermal_features(temperature, time=time, **params)
    np.testing.assert_array_equal(whole, batch)
    for cut in (1, 17, 64, 65, 149):
        head, state = advance_features(temperature[:cut], time[:cut], start, **params)
        tail, _ = advance_features(temperature[cut:], time[cut:], state, **params)
        np.testing.assert_array_equal(head, batch[:cut])
        scale = np.abs(batch).max(axis=0)
        assert np.all(np.abs(tail - batch[cut:]) <= 1e-12 * scale)
    # The carried state is the LagState convention: the deficit after the last row.
    _, state = advance_features(temperature[:17], time[:17], start, **params)
    assert state["temperature"] == temperature[16].tolist()
    assert state["last_time"] == time[16]
    taus = [2.0, 40.5] if smoothing == 0 else [2.0, 3.0, 40.5]
    np.testing.assert_array_equal(
        state["deficit"], lag_deficit(temperature[:17], time[:17], None, taus)[-1]
    )
    # One more sample: one exact step of every lag (the step streaming and C take).
    step, _ = advance_features(temperature[17:18], time[17:18], state, **params)
    expected = lag_step(
        np.asarray(state["deficit"]),
        temperature[16][:, None],
        temperature[17][:, None],
        time[17] - time[16],
        np.asarray(taus),
    )
    np.testing.assert_allclose(step[0, [3, 9]], expected[:, 0], rtol=1e-15)
    np.testing.assert_allclose(step[0, [4, 10]], expected[:, -1], rtol=1e-15)
    # TT_lag2s is T times that deficit.
    np.testing.assert_allclose(step[0, [5, 11]], temperature[17] * expected[:, 0], rtol=1e-15)
    # First row: dT = 0 and every lag (and lag product) 0.
    np.testing.assert_array_equal(whole[0, [1, 3, 4, 5, 7, 9, 10, 11]], 0.0)


def test_irregular_steps_and_interleaved_runs_stream_like_batch(models, campaign):
    """Two runs with irregular time steps, interleaved: one compensator per run."""
    model = models["lags"]
    rng = np.random.default_rng(5)
    parts = []
    for run_id in campaign["run"].unique():
        run = campaign[campaign["run"] == run_id].iloc[:700].copy()
        keep = np.sort(rng.choice(len(run), size=400, replace=False))
        parts.append(run.iloc[keep])  # irregular steps: 10 s to over a minute
    assert np.ptp(np.diff(parts[0]["time"])) > 30.0
    order = rng.permutation(np.r_[np.zeros(400, int), np.ones(400, int)])
    interleaved = []
    counters = [0, 0]
    for which in order:
        interleaved.append(parts[which].iloc[counters[which]])
        counters[which] += 1
    frame = pd.DataFrame(interleaved).reset_index(drop=True)
    expected = model.predict(frame)
    compensators = {run_id: StreamingCompensator(model) for run_id in frame["run"].unique()}
    drift = np.empty(len(frame))
    for position, row in frame.iterrows():
        _, drift[position] = compensators[row["run"]].step(
            row["time"], row["temperature"], row["rate"], run=row["run"]
        )
    _assert_close(drift, expected)
    # The batch features of the interleaved rows are each run's alone, bit for bit.
    features = model[0].transform(frame)
    for run_id in frame["run"].unique():
        rows = (frame["run"] == run_id).to_numpy()
        np.testing.assert_array_equal(features[rows], model[0].transform(frame[rows]))


def test_pandas_output_pipeline_gets_named_features(campaign):
    run = _one_run(campaign, 300)
    model = make_pipeline(_features(), StandardScaler(), Ridge()).set_output(transform="pandas")
    model.fit(run, run["drift"])
    assert list(model[1].feature_names_in_) == [
        "T",
        "dT",
        "T_dT",
        "T2",
        "T_lag900s",
        "T_T_lag900s",
        "T_lag3600s",
        "T_T_lag3600s",
    ]
    compensator = StreamingCompensator(model)
    with warnings.catch_warnings():
        # A missing-feature-names warning here would mean the rows lost their names.
        warnings.simplefilter("error")
        _, drift = _stream(compensator, run, 7)
    _assert_close(drift, model.predict(run))


# --- item 8 of issue 10: more pipelines equal to batch, and set_state refusals -------------


def _run_frame(campaign, n_samples=400):
    return _one_run(campaign, n_samples).reset_index(drop=True)


@pytest.mark.parametrize(
    "steps",
    [
        pytest.param(lambda: [MinMaxScaler(), Ridge(alpha=1e-3)], id="minmax"),
        pytest.param(lambda: [MinMaxScaler(clip=True), Ridge(alpha=1e-3)], id="minmax-clip"),
        pytest.param(lambda: [RobustScaler(), Ridge(alpha=1e-3)], id="robust"),
        pytest.param(lambda: [MaxAbsScaler(), Ridge(alpha=1e-3)], id="maxabs"),
        pytest.param(
            lambda: [StandardScaler(), _rbf(tail=False, criterion=None, n_centers=8)],
            id="rbf-no-tail",
        ),
    ],
)
def test_streaming_equals_batch_for_other_steps(campaign, steps):
    run = _run_frame(campaign)
    model = make_pipeline(_features(smoothing=60.0), *steps()).fit(run, run["drift"])
    compensated, drift = _stream(StreamingCompensator(model), run, 9)
    _assert_equal_to_batch(model, run, compensated, drift)
    # Whole-run chunk: the same shapes as batch, so equal to the last bit.
    _, whole = StreamingCompensator(model).update(run, run["rate"].to_numpy())
    np.testing.assert_array_equal(whole, model.predict(run))


def test_streaming_without_time_column_equals_batch(campaign):
    run = _run_frame(campaign)
    features = ThermalFeatures(temperature="temperature", run="run")
    model = make_pipeline(features, StandardScaler(), Ridge(alpha=1e-3)).fit(run, run["drift"])
    compensated, drift = _stream(StreamingCompensator(model), run, 7)
    _assert_equal_to_batch(model, run, compensated, drift)
    # step() takes no time stamp for such a model.
    compensator = StreamingCompensator(model)
    stepped = [
        compensator.step(None, temperature, run=run_id)[1]
        for temperature, run_id in zip(run["temperature"], run["run"], strict=True)
    ]
    _assert_close(np.asarray(stepped), model.predict(run))


def test_streaming_with_passthrough_steps_equals_batch(campaign):
    run = _run_frame(campaign)
    model = Pipeline(
        [
            ("features", _features()),
            ("nothing", "passthrough"),
            ("scale", StandardScaler()),
            ("none", None),
            ("ridge", Ridge(alpha=1e-3)),
        ]
    ).fit(run, run["drift"])
    compensated, drift = _stream(StreamingCompensator(model), run, 11)
    _assert_equal_to_batch(model, run, compensated, drift)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"schema": "other-schema"}, r"schema 'other-schema' version 4; expected"),
        ({"version": 3}, r"version 3; expected 'sklearn-ifog-streaming-state' version 4"),
        ({"version": 1}, r"version 1; expected 'sklearn-ifog-streaming-state' version 4"),
    ],
)
def test_set_state_refuses_wrong_schema_or_version(models, change, message):
    compensator = StreamingCompensator(models["rbf"])
    before = compensator.get_state()
    with pytest.raises(ValueError, match=message):
        compensator.set_state({**before, **change})
    assert compensator.get_state() == before


@pytest.mark.parametrize(
    "field",
    [
        "n_sensors",
        "time_constants",
        "run",
        "has_history",
        "temperature",
        "last_time",
        "deficit",
        "finished_runs",
    ],
)
def test_set_state_refuses_a_missing_field(models, campaign, field):
    compensator = StreamingCompensator(models["rbf"])
    compensator.update(_one_run(campaign, 5))
    state = compensator.get_state()
    del state[field]
    with pytest.raises(ValueError, match=r"state must be a dict with keys \[.*\], got \["):
        compensator.set_state(state)
    # The refused state changed nothing: streaming continues as before.
    assert compensator.get_state()["has_history"] is True


def test_set_state_refuses_a_missing_time_when_the_model_uses_time(models, campaign):
    compensator = StreamingCompensator(models["rbf"])
    compensator.update(_one_run(campaign, 5))
    state = {**compensator.get_state(), "last_time": None}
    with pytest.raises(ValueError, match=r"state\['last_time'\] is missing: the model uses time"):
        compensator.set_state(state)


def test_set_state_refuses_entries_of_the_wrong_type_or_shape(models, campaign):
    """Every entry of a state is checked before anything is restored (issue "Honest
    measurement, part two", point 10): the refused state changes nothing."""
    compensator = StreamingCompensator(models["lags"])
    compensator.update(_one_run(campaign, 5))
    state = compensator.get_state()
    deficit = json.loads(json.dumps(state["deficit"]))
    deficit[0][1] = float("inf")
    refused = [
        ({"has_history": "yes"}, r"state\['has_history'\] must be True or False, got 'yes'"),
        ({"temperature": ["20.5"]}, r"state\['temperature'\] must hold 1 value\(s\)"),
        ({"temperature": [float("nan")]}, r"state\['temperature'\] holds NaN or inf"),
        ({"last_time": "40"}, r"state\['last_time'\] must be a number, got '40'"),
        ({"deficit": deficit}, r"state\['deficit'\] holds NaN or inf"),
        ({"deficit": None}, r"state\['deficit'\] must have shape \(1, 3\)"),
        ({"time_constants": None}, r"time constants None s; this model's are"),
        ({"finished_runs": None}, r"state\['finished_runs'\] must be a list of run ids"),
        (
            {"has_history": False},
            r"state\['temperature'\] must be None before a run's first row",
        ),
    ]
    for change, message in refused:
        with pytest.raises(ValueError, match=message):
            compensator.set_state({**state, **change})
        assert compensator.get_state() == state, message
    # Without lags, a deficit is refused; without a time column, a last time.
    plain = make_pipeline(
        ThermalFeatures(temperature="temperature", run="run", terms=("T", "dT")),
        StandardScaler(),
        Ridge(alpha=1e-3),
    ).fit(campaign, campaign["drift"])
    other = StreamingCompensator(plain)
    other.update(_one_run(campaign, 5))
    kept = other.get_state()
    with pytest.raises(ValueError, match=r"state\['deficit'\] must be None: the model carries"):
        other.set_state({**kept, "deficit": [[0.0]]})
    with pytest.raises(ValueError, match=r"state\['last_time'\] must be None: the model has"):
        other.set_state({**kept, "last_time": 40.0})
    assert other.get_state() == kept


def test_set_state_refuses_an_old_version_and_other_lags(models, campaign):
    compensator = StreamingCompensator(models["lags"])
    compensator.update(_one_run(campaign, 5))
    state = compensator.get_state()
    assert state["time_constants"] == [300.0, 600.0, 3600.0]
    old = {key: state[key] for key in ("schema", "n_sensors", "run", "has_history")}
    old.update(version=1, smoothed=[20.0], last_time=40.0, finished_runs=[])
    with pytest.raises(ValueError, match=r"version 1; expected .* version 4"):
        compensator.set_state(old)
    with pytest.raises(ValueError, match=r"time constants \[300\.0, 600\.0\]"):
        compensator.set_state({**state, "time_constants": [300.0, 600.0]})
    with pytest.raises(ValueError, match=r"state\['deficit'\] must have shape \(1, 3\)"):
        compensator.set_state({**state, "deficit": [[0.0, 0.0]]})
    # A state of a model with other lags is refused too.
    other = StreamingCompensator(models["rbf"])
    with pytest.raises(ValueError, match="this model's are \\[120\\.0\\] s"):
        other.set_state(state)
    assert compensator.get_state() == state
