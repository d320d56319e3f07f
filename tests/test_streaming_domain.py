"""StreamingCompensator with a CompensationPipeline: the calibration domain, online.

Equalities are "to 1e-12 relative" with an absolute floor of 1e-12 times the largest value
of the run (as in test_streaming.py). The models are calibrated from 10 to 40 degC and
streamed on a run of a -10 to 40 degC campaign, most of whose rows lie outside the domain
and some inside (both asserted), so an ignored policy or a policy applied everywhere
cannot pass.
"""

import copy
import json
import warnings

import numpy as np
import pytest
from sklearn.linear_model import Ridge
from sklearn.neighbors import KNeighborsRegressor

from sklearn_ifog import ConformalRegressor, RBFNetRegressor, make_compensation_pipeline
from sklearn_ifog._compiled import compile_domain
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.domain import OutsideCalibrationWarning
from sklearn_ifog.streaming import StreamingCompensator

RTOL = 1e-12
POLICIES = ["blend", "clip", "none"]


def _campaign(temperature_range, random_state, n_runs=1):
    frame = make_thermal_campaign(
        n_units=1,
        n_runs=n_runs,
        sampling_period=60.0,
        temperature_range=temperature_range,
        random_state=random_state,
    ).frame
    # A second sensor that lags the first (for the two-sensor model).
    frame["temperature_2"] = frame.groupby("run")["temperature"].transform(
        lambda values: values.rolling(10, min_periods=1).mean()
    )
    return frame


@pytest.fixture(scope="module")
def calibration():
    return _campaign((10.0, 40.0), random_state=0, n_runs=2)


@pytest.fixture(scope="module")
def wide_run():
    """One run of a -10 to 40 degC campaign."""
    frame = _campaign((-10.0, 40.0), random_state=3)
    return frame[frame["run"] == frame["run"].iloc[0]].reset_index(drop=True)


def _drift(frame):
    return frame["rate"] - frame["reference"]


@pytest.fixture(scope="module")
def fitted(calibration):
    y = _drift(calibration)
    rbf = RBFNetRegressor(n_centers=10, criterion=None, max_candidates=60, random_state=0)
    return {
        "rbf": make_compensation_pipeline(rbf).fit(calibration, y),
        "ridge": make_compensation_pipeline(Ridge(alpha=1e-3)).fit(calibration, y),
        # Not compiled: scikit-learn evaluates the steps after the features.
        "knn": make_compensation_pipeline(KNeighborsRegressor(5)).fit(calibration, y),
    }


def _with_policy(model, policy):
    """A copy of the fitted pipeline with another ``uncalibrated`` (a predict-time parameter)."""
    return copy.deepcopy(model).set_params(uncalibrated=policy)


def _batch(model, frame, method="predict"):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        return getattr(model, method)(frame)


def _close(actual, expected):
    expected = np.asarray(expected, dtype=np.float64)
    floor = RTOL * np.max(np.abs(expected))
    np.testing.assert_allclose(np.asarray(actual, dtype=np.float64), expected, RTOL, floor)


def _steps(compensator, frame, reference=None):
    """Step every row; the drift, the compensated rate and the per-row flags."""
    drift, compensated, outside, distance = [], [], [], []
    references = [None] * len(frame) if reference is None else reference
    rows = zip(
        frame["time"], frame["temperature"], frame["rate"], frame["run"], references, strict=True
    )
    for time, temperature, rate, run, known in rows:
        out = compensator.step(time, temperature, rate, run=run, reference=known)
        compensated.append(out[0])
        drift.append(out[1])
        outside.append(compensator.last_outside)
        distance.append(compensator.last_distance)
    return (
        np.asarray(drift),
        np.asarray(compensated),
        np.concatenate(outside),
        np.concatenate(distance),
    )


def _chunks(compensator, frame, size, reference=None):
    """Update chunk by chunk; as :func:`_steps`."""
    drift, compensated, outside, distance = [], [], [], []
    rate = frame["rate"].to_numpy()
    for start in range(0, len(frame), size):
        stop = start + size
        known = None if reference is None else reference[start:stop]
        out = compensator.update(frame.iloc[start:stop], rate[start:stop], known)
        compensated.append(out[0])
        drift.append(out[1])
        outside.append(compensator.last_outside)
        distance.append(compensator.last_distance)
    return tuple(np.concatenate(part) for part in (drift, compensated, outside, distance))


def _stream(compensator, frame, chunk, reference=None):
    if chunk == 1:
        return _steps(compensator, frame, reference)
    return _chunks(compensator, frame, chunk or len(frame), reference)


def test_the_run_leaves_the_domain_and_the_policies_act(fitted, wide_run):
    # The premise of every test below, asserted once per model.
    for name, model in fitted.items():
        outside = model.outside_calibration(wide_run)
        assert 0.3 < outside.mean() < 1.0, name
        unchanged = _batch(_with_policy(model, "none"), wide_run)
        for policy in ("blend", "clip"):
            expected = _batch(_with_policy(model, policy), wide_run)
            np.testing.assert_array_equal(expected[~outside], unchanged[~outside])
            assert np.max(np.abs(expected - unchanged)[outside]) > 1e-3, (name, policy)


@pytest.mark.parametrize("chunk", [1, 7, None], ids=["step", "chunks-of-7", "whole-run"])
@pytest.mark.parametrize("name", ["rbf", "ridge", "knn"])
@pytest.mark.parametrize("policy", POLICIES)
def test_streaming_equals_batch_outside_the_domain(fitted, wide_run, policy, name, chunk):
    model = _with_policy(fitted[name], policy)
    compensator = StreamingCompensator(model)
    assert compensator.compiled is (name != "knn")
    drift, compensated, outside, distance = _stream(compensator, wide_run, chunk)
    expected = _batch(model, wide_run)
    _close(drift, expected)
    _close(compensated, wide_run["rate"] - expected)
    # The flags, row for row, are the batch ones.
    np.testing.assert_array_equal(outside, model.outside_calibration(wide_run))
    _close(distance, model.calibration_distance(wide_run))
    assert outside.dtype == bool


@pytest.mark.parametrize("chunk", [1, 13])
def test_a_temperature_beyond_its_range_is_outside_at_any_distance(fitted, calibration, chunk):
    # A calibration run 0.3 degC colder: its coldest rows are beyond the calibrated range
    # by less than a degree, close to the box (within the margin), outside all the same.
    model = fitted["rbf"]
    run = calibration[calibration["run"] == calibration["run"].iloc[0]]
    coldest = calibration["temperature"].min()
    run = run.assign(temperature=run["temperature"] - (run["temperature"].min() - coldest) - 0.3)
    outside = model.outside_calibration(run)
    near = model.calibration_distance(run) <= model.domain.margin
    assert np.any(outside & near)
    compensator = StreamingCompensator(model)
    drift, _, flags, _ = _stream(compensator, run, chunk)
    np.testing.assert_array_equal(flags, outside)
    _close(drift, _batch(model, run))


@pytest.mark.parametrize("policy", POLICIES)
def test_save_and_restore_outside_the_domain(fitted, wide_run, policy):
    model = _with_policy(fitted["rbf"], policy)
    half = len(wide_run) // 2 + 3
    first = StreamingCompensator(model)
    head = _chunks(first, wide_run.iloc[:half], 11)
    saved = json.loads(json.dumps(first.get_state()))
    second = StreamingCompensator(model).set_state(saved)
    tail = _steps(second, wide_run.iloc[half:])
    expected = _batch(model, wide_run)
    _close(np.concatenate([head[0], tail[0]]), expected)
    np.testing.assert_array_equal(
        np.concatenate([head[2], tail[2]]), model.outside_calibration(wide_run)
    )


def test_two_sensors_and_two_outputs(calibration, wide_run):
    y = np.column_stack([_drift(calibration), 0.5 * _drift(calibration) + 0.01])
    model = make_compensation_pipeline(
        Ridge(alpha=1e-3), temperature=["temperature", "temperature_2"], uncalibrated="blend"
    ).fit(calibration, y)
    assert compile_domain(model).temperature_columns == model.domain_.temperature_columns_
    assert len(model.domain_.temperature_columns_) == 2
    expected = _batch(model, wide_run)
    outside = model.outside_calibration(wide_run)
    assert 0.3 < outside.mean() < 1.0
    rate = np.column_stack([wide_run["rate"], wide_run["rate"]])
    stepper = StreamingCompensator(model)
    stepped, flags = [], []
    temperatures = wide_run[["temperature", "temperature_2"]].to_numpy()
    rows = zip(wide_run["time"], temperatures, rate, strict=True)
    for time, sensors, rates in rows:
        stepped.append(stepper.step(time, sensors, rates, run=wide_run["run"].iloc[0])[1])
        flags.append(stepper.last_outside)
    _close(np.array(stepped), expected)
    np.testing.assert_array_equal(np.concatenate(flags), outside)
    chunker = StreamingCompensator(model)
    chunks = [
        chunker.update(wide_run.iloc[s : s + 9], rate[s : s + 9])[1]
        for s in range(0, len(wide_run), 9)
    ]
    _close(np.concatenate(chunks), expected)


@pytest.mark.parametrize("policy", POLICIES)
def test_conformal_streams_the_policy_and_the_band(calibration, wide_run, policy):
    model = ConformalRegressor(make_compensation_pipeline(Ridge(), uncalibrated=policy), cv=3)
    model.fit(calibration, _drift(calibration))
    assert model.estimator_.outside_calibration(wide_run).mean() > 0.3
    if policy == "blend":
        # the band's terms beyond the calibrated temperatures are streamed too
        assert model.thermal_slope_ != 0.0
        assert wide_run["temperature"].min() < calibration["temperature"].min()
    drift = _batch(model, wide_run)
    band = _batch(model, wide_run, "predict_interval")
    stepper = StreamingCompensator(model)
    stepped, bands, flags = [], [], []
    rows = zip(wide_run["time"], wide_run["temperature"], wide_run["run"], strict=True)
    for time, temperature, run in rows:
        stepped.append(stepper.step(time, temperature, run=run)[1])
        bands.append(stepper.last_interval)
        flags.append(stepper.last_outside)
    np.testing.assert_allclose(stepped, drift, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(np.concatenate(bands), band, rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(
        np.concatenate(flags), model.estimator_.outside_calibration(wide_run)
    )
    chunker = StreamingCompensator(model)
    bands = []
    for start in range(0, len(wide_run), 11):
        chunker.update(wide_run.iloc[start : start + 11])
        bands.append(chunker.last_interval)
    np.testing.assert_allclose(np.concatenate(bands), band, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("mode", ["bias", "output"])
def test_an_outside_reference_leaves_the_recalibration_alone(fitted, wide_run, mode):
    compensator = StreamingCompensator(fitted["rbf"], adapt=mode)
    reference = wide_run["reference"].to_numpy() + 0.05
    used = {True: 0, False: 0}
    rows = zip(wide_run["time"], wide_run["temperature"], wide_run["rate"], reference, strict=True)
    for time, temperature, rate, known in rows:
        before = compensator.get_state()["rls"]
        compensator.step(time, temperature, rate, run=wide_run["run"].iloc[0], reference=known)
        after = compensator.get_state()["rls"]
        outside = bool(compensator.last_outside[0])
        used[outside] += 1
        if outside:
            assert after == before
        else:
            assert after["n_updates"] == before["n_updates"] + 1
            assert after["weights"] != before["weights"]
    assert used[True] > 0.3 * len(wide_run)
    assert used[False] > 0
    assert compensator.get_state()["rls"]["n_updates"] == used[False]


@pytest.mark.parametrize("policy", POLICIES)
@pytest.mark.parametrize("mode", ["bias", "output"])
def test_recalibration_outside_is_the_same_whatever_the_chunking(fitted, wide_run, mode, policy):
    model = _with_policy(fitted["rbf"], policy)
    has = np.random.default_rng(1).random(len(wide_run)) < 0.5
    reference = np.where(has, wide_run["reference"].to_numpy() + 0.05, None)
    whole = _chunks(StreamingCompensator(model, adapt=mode), wide_run, len(wide_run), reference)
    chunked = _chunks(StreamingCompensator(model, adapt=mode), wide_run, 7, reference)
    stepper = StreamingCompensator(model, adapt=mode)
    stepped = _steps(stepper, wide_run, reference)
    _close(chunked[0], whole[0])
    _close(stepped[0], whole[0])
    outside = model.outside_calibration(wide_run)
    np.testing.assert_array_equal(whole[2], outside)
    assert stepper.get_state()["rls"]["n_updates"] == int(np.sum(has & ~outside))
    # The recalibration moved the drift (the references are 0.05 deg/h off the model).
    assert np.max(np.abs(whole[0] - _batch(model, wide_run))[~outside]) > 0.01


@pytest.mark.parametrize("policy", POLICIES)
@pytest.mark.parametrize("mode", ["bias", "output"])
def test_without_references_adaptation_keeps_the_batch_policy(fitted, wide_run, mode, policy):
    model = _with_policy(fitted["rbf"], policy)
    expected = _batch(model, wide_run)
    for chunk in (1, 7):
        drift = _stream(StreamingCompensator(model, adapt=mode), wide_run, chunk)[0]
        _close(drift, expected)


@pytest.mark.parametrize("policy", POLICIES)
def test_the_bias_is_added_after_the_policy(fitted, calibration, wide_run, policy):
    """The bias learnt inside the domain is added after the batch policy outside it.

    The learnt bias lay in 0.05-0.15 with the calibration's campaign seeds 0-9 (checked
    once).
    """
    model = _with_policy(fitted["ridge"], policy)
    learnt_on = calibration[calibration["run"] == calibration["run"].iloc[0]]
    assert not model.outside_calibration(learnt_on).any()
    compensator = StreamingCompensator(model, adapt="bias", forgetting=1.0)
    compensator.update(learnt_on, learnt_on["rate"], learnt_on["reference"] - 0.1)
    bias = compensator.get_state()["rls"]["weights"][0][0]
    assert 0.05 < bias < 0.15  # the shift of 0.1 deg/h, plus the model's mean residual
    # Outside rows without references: the batch policy's drift, then the learnt offset
    # (a new run of the same id: reset, which keeps the recalibration).
    drift = _steps(compensator.reset(), wide_run)[0]
    _close(drift, _batch(model, wide_run) + bias)


@pytest.mark.parametrize("policy", POLICIES)
def test_streaming_never_warns(fitted, wide_run, policy):
    model = _with_policy(fitted["rbf"], policy)
    with pytest.warns(OutsideCalibrationWarning, match=r"outside the calibration domain"):
        model.predict(wide_run)
    compensator = StreamingCompensator(model, adapt="bias")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        stepped = _steps(compensator, wide_run.iloc[:40])
        chunked = _chunks(compensator, wide_run.iloc[40:], 17)
    outside = np.concatenate([stepped[2], chunked[2]])
    assert outside[:40].mean() > 0.3
    assert outside[40:].mean() > 0.3


def test_flags_are_none_before_the_first_call_and_kept_by_a_failed_one(fitted, wide_run):
    compensator = StreamingCompensator(fitted["rbf"])
    assert compensator.last_outside is None
    assert compensator.last_distance is None
    _steps(compensator, wide_run.iloc[:5])
    outside, distance = compensator.last_outside, compensator.last_distance
    assert outside.shape == distance.shape == (1,)
    with pytest.raises(ValueError, match="temperature contains NaN"):
        compensator.step(wide_run["time"].iloc[5], np.nan, 1.0)
    np.testing.assert_array_equal(compensator.last_outside, outside)
    np.testing.assert_array_equal(compensator.last_distance, distance)


def test_a_plain_pipeline_has_no_domain(fitted, wide_run):
    model = fitted["rbf"]
    plain = model[:]  # a scikit-learn Pipeline of the same fitted steps
    assert compile_domain(plain) is None
    compensator = StreamingCompensator(plain)
    _, drift = compensator.update(wide_run)
    assert compensator.last_outside is None
    assert compensator.last_distance is None
    compensator.reset().step(wide_run["time"].iloc[0], wide_run["temperature"].iloc[0])
    assert compensator.last_outside is None
    assert compensator.last_distance is None
    # The regressor's own extrapolation: the "none" policy's prediction.
    _close(drift, _batch(_with_policy(model, "none"), wide_run))


def test_row_where_is_the_batch_test(fitted, calibration, wide_run):
    model = fitted["rbf"]
    domain = compile_domain(model)
    features = np.vstack([model[0].transform(calibration), model[0].transform(wide_run)])
    distance, outside = domain.where(features)
    rows = [domain.row_where(row) for row in features.tolist()]
    _close([d for d, _ in rows], distance)
    np.testing.assert_array_equal([o for _, o in rows], outside)
    assert all(isinstance(d, float) and isinstance(o, bool) for d, o in rows)
    assert 0 < outside.mean() < 1
