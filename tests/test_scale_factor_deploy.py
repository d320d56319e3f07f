"""The scale factor (issue 44, point 4) in streaming and in the C and JSON exports.

A pipeline fitted with ``input_rate`` on rate-table data (a static simulated campaign with
the turntable's input rates and a scale-factor error a few ppm/degC added, as
``/tmp/h44/try1.py`` made it) is calibrated between -10 and 50 degC on input rates up to
300 deg/s, and then run on one calibration run (inside), a run 30 degC colder (outside by
its temperatures: the policy acts on the pair [b, s]) and a run within the calibrated
temperatures whose input rates reach 450 deg/s (beyond the calibrated rates: flagged, the
policy untouched). Everywhere the compensated output is ``model.compensate(X, rate)``
(the input rate ``(rate - b) / (1 + s)``), the drift at a known input rate
``model.predict(X)``, and the flags ``model.outside_calibration`` (the output standing in
for the input rate in compensate), to 1e-12.
"""

import json
import shutil
import subprocess
import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import LinearRegression
from test_export import evaluate_json, evaluate_steps
from test_export_domain import _build as _build_with_driver
from test_export_domain import _evaluate_domain

from sklearn_ifog import RBFNetRegressor, make_compensation_pipeline
from sklearn_ifog._description import SCHEMA_VERSION, describe_pipeline
from sklearn_ifog._tuning import INPUT_RATE_SLACK
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.domain import OutsideCalibrationWarning
from sklearn_ifog.export import to_c, to_c_units, to_json
from sklearn_ifog.scale_factor import beyond_input_rates
from sklearn_ifog.streaming import StreamingCompensator

CC = shutil.which("cc")
RTOL = 1e-12
POLICIES = ["blend", "clip", "none"]
# The turntable's steps, deg/h (0, ±1, ±10, ±100, ±300 deg/s), two samples each.
RATES = np.array([0, 1, -1, 10, -10, 100, -100, 300, -300]) * 3600.0
ASYMMETRY = 15e-6


def _rate_table(seed, temperature_range, n_runs, rates=RATES, first_run=0):
    """Rows with an input-rate column ``reference`` (deg/h), the drift ``y`` and the gyro
    output ``rate = reference + y`` (a scale factor of about 4 ppm/degC and an asymmetry of
    15 ppm between positive and negative inputs, so the exports' sign branch is exercised)."""
    X, y = make_thermal_campaign(
        n_units=1,
        n_runs=n_runs,
        azimuths=[0.0],
        profile="cycle",
        sampling_period=120.0,
        temperature_range=temperature_range,
        random_state=seed,
        return_X_y=True,
    )
    omega = rates[(np.arange(len(X)) // 2) % len(rates)]
    T = X["temperature"].to_numpy()
    s = 1e-6 * (4.0 * (T - 15.0) + 0.02 * (T - 15.0) ** 2)
    X = X.assign(run=X["run"] + first_run, reference=omega)
    y = y.to_numpy() + omega * s + ASYMMETRY * np.abs(omega)
    return X, y, omega + y


@pytest.fixture(scope="module")
def calibration():
    X, y, _ = _rate_table(1, (-10.0, 50.0), 3)
    return X, y


@pytest.fixture(scope="module")
def trial(calibration):
    """(X, rate, kind): a calibration run, a colder run, a run beyond the calibrated rates."""
    X, y = calibration
    first = (X["run"] == X["run"].iloc[0]).to_numpy()
    cold, _, cold_rate = _rate_table(5, (-40.0, 20.0), 1, first_run=100)
    fast, _, fast_rate = _rate_table(1, (-10.0, 50.0), 1, rates=RATES * 1.5, first_run=200)
    frame = pd.concat([X[first], cold, fast], ignore_index=True)
    rate = np.concatenate([X["reference"].to_numpy()[first] + y[first], cold_rate, fast_rate])
    kind = np.repeat(["inside", "cold", "fast"], [first.sum(), len(cold), len(fast)])
    return frame, rate, kind


def _rbf():
    return RBFNetRegressor(n_centers=15, max_candidates=100, max_samples=1000, random_state=0)


REGRESSORS = {"linear": LinearRegression, "rbf": _rbf}


def _fit(name, policy, calibration):
    X, y = calibration
    model = make_compensation_pipeline(
        REGRESSORS[name](), input_rate="reference", uncalibrated=policy
    )
    return model.fit(X, y)


def _quiet(function, *args):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        return function(*args)


def _expected(model, frame, rate):
    """What the C and the stream must give: compensate, predict, the flags, the pairs."""
    bare = frame.drop(columns="reference")
    return {
        "compensated": _quiet(model.compensate, bare, rate),
        "drift": _quiet(model.predict, frame),
        "pair": _quiet(model._policed, frame),
        "compensate_outside": model.outside_calibration(frame.assign(reference=rate)),
        "drift_outside": model.outside_calibration(frame),
        "distance": model.calibration_distance(frame),
        "domain_outside": model._where_of(frame).outside,
    }


def _assert_close(actual, expected, rtol=RTOL):
    """``|actual - expected| <= rtol * max|expected|`` per column (a value may cross 0)."""
    actual = np.asarray(actual, dtype=np.float64)
    expected = np.asarray(expected, dtype=np.float64).reshape(actual.shape)
    error = np.max(np.abs(actual - expected), axis=0)
    scale = np.max(np.abs(expected), axis=0)
    assert np.all(error <= rtol * scale), f"max error {error} > {rtol} * {scale}"


def test_the_trial_has_every_kind_of_row(calibration, trial):
    """The rows the other tests compare: inside, outside colder, beyond the rates; and the
    policy moves the pair where it acts, so no comparison passes vacuously."""
    frame, rate, kind = trial
    model = _fit("linear", "blend", calibration)
    expected = _expected(model, frame, rate)
    inside, cold, fast = (kind == name for name in ("inside", "cold", "fast"))
    assert not expected["compensate_outside"][inside].any()
    assert expected["domain_outside"][cold].mean() > 0.5
    beyond = beyond_input_rates(frame["reference"].to_numpy(), *model.input_rate_range_)
    assert beyond[fast].mean() > 0.2
    assert not beyond[~fast].any()
    # Beyond the rates: flagged, though the domain (the thermal state) holds them.
    only_rates = fast & beyond & ~expected["domain_outside"]
    assert only_rates.sum() > 20
    assert expected["drift_outside"][only_rates].all()
    assert expected["compensate_outside"][only_rates].all()
    # The policy changes the pair [b, s] on the cold rows.
    raw = model[:].predict(frame)
    moved = np.abs(expected["pair"] - raw).max(axis=1) > 0
    assert moved[cold].mean() > 0.3
    assert not moved[inside].any()
    # The input rate is recovered far better than by taking the output as it is.
    truth = frame["reference"].to_numpy()
    assert (
        np.abs(expected["compensated"] - truth)[inside].max()
        < 0.1 * np.abs(rate - truth)[inside].max()
    )


def test_beyond_input_rates_is_the_pipelines_rule(calibration):
    model = _fit("linear", "none", calibration)
    low, high = model.input_rate_range_
    slack = INPUT_RATE_SLACK * max(abs(low), abs(high))
    omega = np.array([low - slack, low - slack * 1.001, high + slack, high + slack * 1.001, 0.0])
    expected = [False, True, False, True, False]
    assert beyond_input_rates(omega, low, high).tolist() == expected
    X = calibration[0].iloc[:5].assign(reference=omega)
    np.testing.assert_array_equal(
        model.outside_calibration(X), expected | model._where_of(X).outside
    )


# --- JSON -----------------------------------------------------------------------------------


def test_schema_carries_the_scale_factor(calibration, tmp_path):
    model = _fit("rbf", "blend", calibration)
    document = json.loads(to_json(model, tmp_path / "model.json").read_text())
    assert document["schema_version"] == SCHEMA_VERSION == 9
    assert document["n_outputs"] == 2
    assert not document["single_output"]
    assert len(document["domain"]["fallback"]["intercept"]) == 2
    low, high = model.input_rate_range_
    assert document["scale_factor"] == {
        "input_rate": "reference",
        "input_rate_unit": "deg/h",
        "outputs": ["bias", "scale_factor"],
        "input_rate_range": [low, high],
        "slack": INPUT_RATE_SLACK,
        "asymmetry": model.asymmetry_,
    }
    assert model.asymmetry_ == pytest.approx(ASYMMETRY, rel=0.02)
    assert (low, high) == (RATES.min(), RATES.max())
    # A bias-only pipeline writes no entry (a version-7 document's meaning).
    bias_only = make_compensation_pipeline(LinearRegression()).fit(*calibration)
    assert "scale_factor" not in describe_pipeline(bias_only)


@pytest.mark.parametrize("policy", POLICIES)
@pytest.mark.parametrize("name", sorted(REGRESSORS))
def test_json_reproduces_compensate_and_predict(name, policy, calibration, trial, tmp_path):
    """From the JSON document alone: the steps' pair, the domain's policy on it, then the
    input rate, the drift at the known rate and the flags."""
    frame, rate, _ = trial
    model = _fit(name, policy, calibration)
    document = json.loads(to_json(model, tmp_path / "model.json").read_text())
    features = np.asarray(model[0].transform(frame), dtype=np.float64)
    network = evaluate_json(document, frame)
    pair, _, outside = _evaluate_domain(
        document["domain"], features, network, lambda rows: evaluate_steps(document["steps"], rows)
    )
    scale = document["scale_factor"]
    low, high = scale["input_rate_range"]
    slack = scale["slack"] * max(abs(low), abs(high))

    def beyond(values):
        return (values < low - slack) | (values > high + slack)

    omega = frame[scale["input_rate"]].to_numpy()
    expected = _expected(model, frame, rate)
    a = scale["asymmetry"]
    excess = rate - pair[:, 0]
    _assert_close(
        excess / (1.0 + pair[:, 1] + a * np.sign(excess)), expected["compensated"], 1e-10
    )
    _assert_close(pair[:, 0] + omega * pair[:, 1] + a * np.abs(omega), expected["drift"], 1e-10)
    np.testing.assert_array_equal(outside | beyond(rate), expected["compensate_outside"])
    np.testing.assert_array_equal(outside | beyond(omega), expected["drift_outside"])


# --- C --------------------------------------------------------------------------------------

# Reads rows (run-start flag, time, gyro output, input rate, temperatures...); three states
# follow the same rows, reset at each run start: ifog_compensate (the input rate, its flag
# and distance), ifog_drift_at (the drift at the known input rate, its flag) and ifog_step
# (the pair [b, s]); then ifog_batch per run. Writes compensated, drift, streamed pairs,
# batched pairs (ifog_real), distance (double), the two flags (int).
DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include "ifog.h"

#if !IFOG_HAS_SCALE_FACTOR || IFOG_N_OUTPUTS != 2
#error "a scale-factor model writes IFOG_HAS_SCALE_FACTOR 1 and two outputs"
#endif

#define WIDTH (4 + IFOG_N_SENSORS)

int main(int argc, char **argv)
{
    long n, i, k, start = 0;
    double *rows, *time, *temperature, *distance;
    int *outside_compensate, *outside_drift;
    ifog_real *compensated, *drift, *pairs, *batched, rate[1];
    ifog_state compensating, drifting, stepping;
    FILE *in, *out;
    if (argc != 4) return 1;
    n = atol(argv[1]);
    rows = malloc((size_t)(n * WIDTH) * sizeof(double));
    time = malloc((size_t)n * sizeof(double));
    temperature = malloc((size_t)(n * IFOG_N_SENSORS) * sizeof(double));
    distance = malloc((size_t)n * sizeof(double));
    outside_compensate = malloc((size_t)n * sizeof(int));
    outside_drift = malloc((size_t)n * sizeof(int));
    compensated = malloc((size_t)n * sizeof(ifog_real));
    drift = malloc((size_t)n * sizeof(ifog_real));
    pairs = malloc((size_t)(n * IFOG_N_OUTPUTS) * sizeof(ifog_real));
    batched = malloc((size_t)(n * IFOG_N_OUTPUTS) * sizeof(ifog_real));
    in = fopen(argv[2], "rb");
    out = fopen(argv[3], "wb");
    if (!rows || !time || !temperature || !distance || !outside_compensate || !outside_drift
        || !compensated || !drift || !pairs || !batched || !in || !out)
        return 2;
    if (fread(rows, sizeof(double), (size_t)(n * WIDTH), in) != (size_t)(n * WIDTH)) return 3;
    ifog_init(&compensating);
    ifog_init(&drifting);
    ifog_init(&stepping);
    for (i = 0; i < n; ++i) {
        const double *row = rows + i * WIDTH;
        const double *sensors = row + 4;
        time[i] = row[1];
        for (k = 0; k < IFOG_N_SENSORS; ++k) temperature[i * IFOG_N_SENSORS + k] = sensors[k];
        if (row[0] != 0.0) {
            ifog_reset(&compensating);
            ifog_reset(&drifting);
            ifog_reset(&stepping);
        }
        rate[0] = (ifog_real)row[2];
        ifog_compensate(&compensating, time[i], sensors, rate, compensated + i);
        outside_compensate[i] = compensating.last_outside;
        distance[i] = compensating.last_distance;
        ifog_drift_at(&drifting, time[i], sensors, row[3], drift + i);
        outside_drift[i] = drifting.last_outside;
        ifog_step(&stepping, time[i], sensors, pairs + i * IFOG_N_OUTPUTS);
    }
    for (i = 1; i <= n; ++i) {
        if (i == n || rows[i * WIDTH] != 0.0) {
            ifog_batch(i - start, time + start, temperature + start * IFOG_N_SENSORS,
                       batched + start * IFOG_N_OUTPUTS);
            start = i;
        }
    }
    fwrite(compensated, sizeof(ifog_real), (size_t)n, out);
    fwrite(drift, sizeof(ifog_real), (size_t)n, out);
    fwrite(pairs, sizeof(ifog_real), (size_t)(n * IFOG_N_OUTPUTS), out);
    fwrite(batched, sizeof(ifog_real), (size_t)(n * IFOG_N_OUTPUTS), out);
    fwrite(distance, sizeof(double), (size_t)n, out);
    fwrite(outside_compensate, sizeof(int), (size_t)n, out);
    fwrite(outside_drift, sizeof(int), (size_t)n, out);
    fclose(out);
    fclose(in);
    return 0;
}
"""


def _run(executable, frame, rate, real=np.float64):
    """The C outputs for ``frame`` and the gyro output ``rate`` (see DRIVER)."""
    n = len(frame)
    run = frame["run"].to_numpy()
    starts = np.r_[True, run[1:] != run[:-1]]
    rows = np.column_stack(
        [starts, frame["time"], rate, frame["reference"], frame[["temperature"]]]
    )
    rows.astype(np.float64).tofile(executable.parent / "in.bin")
    subprocess.run([executable, str(n), "in.bin", "out.bin"], cwd=executable.parent, check=True)
    raw = (executable.parent / "out.bin").read_bytes()
    layout = [
        ("compensated", real, (n,)),
        ("drift", real, (n,)),
        ("pair", real, (n, 2)),
        ("batched", real, (n, 2)),
        ("distance", np.float64, (n,)),
        ("compensate_outside", np.intc, (n,)),
        ("drift_outside", np.intc, (n,)),
    ]
    out, position = {}, 0
    for key, dtype, shape in layout:
        size = np.dtype(dtype).itemsize * int(np.prod(shape))
        out[key] = np.frombuffer(raw[position : position + size], dtype=dtype).reshape(shape)
        position += size
    assert position == len(raw)
    return out


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
@pytest.mark.parametrize("policy", POLICIES)
@pytest.mark.parametrize("name", sorted(REGRESSORS))
def test_c_equals_compensate_and_predict(name, policy, calibration, trial, tmp_path):
    frame, rate, _ = trial
    model = _fit(name, policy, calibration)
    c = _run(_build_with_driver(model, tmp_path, driver=DRIVER), frame, rate)
    expected = _expected(model, frame, rate)
    _assert_close(c["compensated"], expected["compensated"])
    _assert_close(c["drift"], expected["drift"])
    _assert_close(c["pair"], expected["pair"])
    np.testing.assert_array_equal(c["batched"], c["pair"])
    np.testing.assert_array_equal(c["compensate_outside"], expected["compensate_outside"])
    np.testing.assert_array_equal(c["drift_outside"], expected["drift_outside"])
    distance = expected["distance"]
    np.testing.assert_allclose(c["distance"], distance, rtol=RTOL, atol=RTOL * distance.max())
    header = (tmp_path / "ifog.h").read_text()
    low, high = model.input_rate_range_
    assert f"#define IFOG_INPUT_RATE_LOW {low!r}\n" in header
    assert f"#define IFOG_INPUT_RATE_HIGH {high!r}\n" in header
    assert "ifog_drift_at(" in header
    assert "rate[k] - drift[k]" not in header


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
def test_c_float_build_follows_in_single_precision(calibration, trial, tmp_path):
    # The parameters and the network in float; the domain, the input-rate check and the
    # last division in double. A float holds an output of 1e6 deg/h to about 0.06 deg/h
    # (6e-8 relative): the input rate is that close, the flags exact.
    frame, rate, _ = trial
    model = _fit("rbf", "blend", calibration)
    c = _run(
        _build_with_driver(model, tmp_path, precision="float", driver=DRIVER),
        frame,
        rate,
        real=np.float32,
    )
    expected = _expected(model, frame, rate)
    _assert_close(c["compensated"], expected["compensated"], 1e-6)
    _assert_close(c["drift"], expected["drift"], 1e-4)
    np.testing.assert_array_equal(c["compensate_outside"], expected["compensate_outside"])
    np.testing.assert_array_equal(c["drift_outside"], expected["drift_outside"])


def test_c_refuses_adapt_with_a_scale_factor(calibration, tmp_path):
    model = _fit("linear", "blend", calibration)
    for adapt in ("bias", "output"):
        with pytest.raises(ValueError, match=rf"adapt='{adapt}' .* input_rate='reference'"):
            to_c(model, tmp_path / adapt, adapt=adapt)
        assert not (tmp_path / adapt).exists(), "a refused export writes nothing"


def test_bias_only_c_keeps_its_compensate(calibration, tmp_path):
    model = make_compensation_pipeline(LinearRegression()).fit(*calibration)
    header, source = (path.read_text() for path in to_c(model, tmp_path))
    assert "SCALE_FACTOR" not in header
    assert "drift_at" not in header + source
    assert "compensated[output] = rate[output] - drift[output];" in source


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
def test_c_units_carry_each_units_scale_factor(calibration, trial, tmp_path):
    from sklearn_ifog import UnitwiseRegressor

    X, y = calibration
    lot = pd.concat([X, X.assign(unit=1)], ignore_index=True)
    target = np.concatenate([y, 1.5 * y])
    pipeline = make_compensation_pipeline(LinearRegression(), input_rate="reference")
    model = UnitwiseRegressor(pipeline, pooling="none").fit(lot, target)
    written = to_c_units(model, tmp_path)
    assert set(written) == {0, 1}
    for unit, (header, _) in written.items():
        text = header.read_text()
        prefix = f"IFOG_UNIT_{unit}"
        assert f"#define {prefix}_HAS_SCALE_FACTOR 1" in text
        assert f"ifog_unit_{unit}_drift_at(" in text


# --- streaming ------------------------------------------------------------------------------


def _chunks(n, seed=0):
    """Chunk boundaries of 1 to 150 rows."""
    sizes = np.random.default_rng(seed).integers(1, 150, size=n)
    edges = np.concatenate([[0], np.cumsum(sizes)])
    return [
        (start, stop)
        for start, stop in zip(edges[:-1], np.minimum(edges[1:], n), strict=False)
        if start < n
    ]


@pytest.mark.parametrize("policy", POLICIES)
@pytest.mark.parametrize("name", sorted(REGRESSORS))
def test_stream_equals_batch(name, policy, calibration, trial):
    """In chunks or sample by sample, the compensated output is compensate's input rate,
    the drift rate minus it, and the flags and distances the batch ones; from rows holding
    the input rate (no output), the drift is predict's."""
    frame, rate, _ = trial
    model = _fit(name, policy, calibration)
    expected = _expected(model, frame, rate)
    bare = frame.drop(columns="reference")
    compensator = StreamingCompensator(model)
    assert (compensator.n_outputs, compensator.compiled) == (1, True)
    parts = {"compensated": [], "drift": [], "outside": [], "distance": []}
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # streaming never warns
        for start, stop in _chunks(len(frame)):
            done, drift = compensator.update(bare.iloc[start:stop], rate[start:stop])
            parts["compensated"].append(done)
            parts["drift"].append(drift)
            parts["outside"].append(compensator.last_outside)
            parts["distance"].append(compensator.last_distance)
    chunked = {key: np.concatenate(value) for key, value in parts.items()}
    _assert_close(chunked["compensated"], expected["compensated"])
    np.testing.assert_array_equal(chunked["drift"], rate - chunked["compensated"])
    np.testing.assert_array_equal(chunked["outside"], expected["compensate_outside"])
    distance = expected["distance"]  # (an excess near the box's edge: an absolute term)
    np.testing.assert_allclose(
        chunked["distance"], distance, rtol=RTOL, atol=RTOL * distance.max()
    )

    stepper = StreamingCompensator(model)
    steps, flags = [], []
    for row, output in zip(bare.itertuples(index=False), rate, strict=True):
        done, drift = stepper.step(row.time, row.temperature, output, run=row.run)
        assert isinstance(done, float)
        assert drift == output - done
        steps.append(done)
        flags.append(bool(stepper.last_outside[0]))
    _assert_close(np.array(steps), expected["compensated"])
    np.testing.assert_array_equal(flags, expected["compensate_outside"])

    known = StreamingCompensator(model)
    done, drift = known.update(frame)  # the input-rate column, no output
    assert done is None
    _assert_close(drift, expected["drift"])
    np.testing.assert_array_equal(known.last_outside, expected["drift_outside"])


def test_stream_state_round_trip(calibration, trial):
    frame, rate, _ = trial
    model = _fit("rbf", "clip", calibration)
    bare = frame.drop(columns="reference")
    whole = StreamingCompensator(model).update(bare, rate)[0]
    first = StreamingCompensator(model)
    half = len(frame) // 2 + 7
    head = first.update(bare.iloc[:half], rate[:half])[0]
    second = StreamingCompensator(model).set_state(json.loads(json.dumps(first.get_state())))
    tail = second.update(bare.iloc[half:], rate[half:])[0]
    _assert_close(np.concatenate([head, tail]), whole)  # chunking: the last bits


def test_stream_errors_name_the_problem(calibration, trial):
    frame, rate, _ = trial
    model = _fit("linear", "blend", calibration)
    for adapt in ("bias", "output"):
        with pytest.raises(ValueError, match=rf"adapt='{adapt}' .* input_rate='reference'"):
            StreamingCompensator(model, adapt=adapt)
    compensator = StreamingCompensator(model)
    state = compensator.get_state()
    with pytest.raises(ValueError, match=r"step needs rate, the gyro output.*input_rate="):
        compensator.step(0.0, 20.0)
    bare = frame.drop(columns="reference")
    with pytest.raises(ValueError, match=r"without rate .* Column 'reference' \(input_rate\)"):
        compensator.update(bare.iloc[:5])  # neither an output nor the input rate
    with pytest.raises(ValueError, match=r"rate must hold one gyro output per row of X \(5\)"):
        compensator.update(bare.iloc[:5], rate[:4])
    with pytest.raises(ValueError, match="rate"):
        compensator.update(bare.iloc[:5], np.r_[rate[:4], np.nan])
    assert compensator.get_state() == state, "a refused call changes nothing"
    assert compensator.last_outside is None
