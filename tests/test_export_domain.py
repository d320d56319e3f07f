"""The calibration domain in the exports: the JSON ``"domain"`` entry and the C flag and policy.

A CompensationPipeline is calibrated on a simulated unit between 0 and 40 degC and exported;
the generated C is compiled with the strict flags of ``tests/test_export.py`` and run on one
calibration run (inside the domain) followed by a colder and hotter excursion (mostly
outside it, by its distance to the decorrelated box and by its temperatures). Its drift,
distance and flag are compared with ``pipeline.predict``, ``pipeline.calibration_distance``
and ``pipeline.outside_calibration``, for every ``outside`` policy. The distance's rate term
is checked apart: a unit calibrated on heating runs and operated on cooling runs within the
calibrated temperatures, whose negative rates alone put rows outside.
"""

import json
import re
import shutil
import subprocess
import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import Ridge
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from sklearn_ifog import (
    RBFNetRegressor,
    ThermalFeatures,
    UnitwiseRegressor,
    make_compensation_pipeline,
)
from sklearn_ifog import domain as domain_module
from sklearn_ifog import fallback as fallback_module
from sklearn_ifog import policy as policy_module
from sklearn_ifog._description import SCHEMA_VERSION, describe_pipeline
from sklearn_ifog._tuning import PROJECTION_ROUNDS
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.domain import OutsideCalibrationWarning
from sklearn_ifog.export import to_c, to_c_units, to_json
from sklearn_ifog.streaming import StreamingCompensator

CC = shutil.which("cc")
STRICT_FLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror"]
EXTRA_FLAGS = ["-pedantic", "-Wshadow", "-Wconversion", "-Wdouble-promotion"]
POLICIES = ["blend", "clip", "none"]
# Double precision: the C and Python compute the same formulas in another order (BLAS sums a
# product's terms in its own order), so they agree to rounding. The distance's tolerance adds
# an absolute term: the excess beyond the box is a difference of coordinates near the box's
# edge.
RTOL = 1e-12
# The recalibrated drift: C and Python run the same square-root recursion in other summation
# orders, and a recursion carries rounding from one reference to the next (test_export.py).
ADAPT_RTOL = 1e-11

# Reads rows (run-start flag, time, has-reference flag, rates..., references...,
# temperatures..., Python's features...); steps every sample (adapt on those with a
# reference, when built with adapt), resetting at each run start, and records the state's
# distance and flag; evaluates the stateless predict_features and calibration_distance on
# Python's features; runs the batch function per run. Writes streamed drift, batched drift,
# stateless drift (ifog_real), distance, stateless distance (double), flags (int), then with
# adapt the numbers of updates and resets and the final weights.
DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include "ifog.h"

#define WIDTH (3 + 2 * IFOG_N_OUTPUTS + IFOG_N_SENSORS + IFOG_N_FEATURES)

int main(int argc, char **argv)
{
    long n, i, k, start = 0;
    double *rows, *time, *temperature, *distance, *checked, reference[IFOG_N_OUTPUTS];
    int *outside;
    ifog_real *streamed, *batched, *stateless, rate[IFOG_N_OUTPUTS];
    ifog_real features[IFOG_N_FEATURES];
    ifog_state state;
    FILE *in, *out;
    if (argc != 4) return 1;
    n = atol(argv[1]);
    rows = malloc((size_t)(n * WIDTH) * sizeof(double));
    time = malloc((size_t)n * sizeof(double));
    temperature = malloc((size_t)(n * IFOG_N_SENSORS) * sizeof(double));
    distance = malloc((size_t)n * sizeof(double));
    checked = malloc((size_t)n * sizeof(double));
    outside = malloc((size_t)n * sizeof(int));
    streamed = malloc((size_t)(n * IFOG_N_OUTPUTS) * sizeof(ifog_real));
    batched = malloc((size_t)(n * IFOG_N_OUTPUTS) * sizeof(ifog_real));
    stateless = malloc((size_t)(n * IFOG_N_OUTPUTS) * sizeof(ifog_real));
    in = fopen(argv[2], "rb");
    out = fopen(argv[3], "wb");
    if (!rows || !time || !temperature || !distance || !checked || !outside || !streamed
        || !batched || !stateless || !in || !out)
        return 2;
    if (fread(rows, sizeof(double), (size_t)(n * WIDTH), in) != (size_t)(n * WIDTH)) return 3;
    ifog_init(&state);
    for (i = 0; i < n; ++i) {
        const double *row = rows + i * WIDTH;
        const double *sensors = row + 3 + 2 * IFOG_N_OUTPUTS;
        time[i] = row[1];
        for (k = 0; k < IFOG_N_OUTPUTS; ++k) {
            rate[k] = (ifog_real)row[3 + k];
            reference[k] = row[3 + IFOG_N_OUTPUTS + k];
        }
        for (k = 0; k < IFOG_N_SENSORS; ++k) temperature[i * IFOG_N_SENSORS + k] = sensors[k];
        for (k = 0; k < IFOG_N_FEATURES; ++k) {
            features[k] = (ifog_real)sensors[IFOG_N_SENSORS + k];
        }
        if (row[0] != 0.0) ifog_reset(&state);
#ifdef IFOG_N_WEIGHTS
        if (row[2] != 0.0) {
            ifog_adapt(&state, time[i], sensors, rate, reference, streamed + i * IFOG_N_OUTPUTS);
        } else
#endif
        {
            ifog_step(&state, time[i], sensors, streamed + i * IFOG_N_OUTPUTS);
        }
        distance[i] = state.last_distance;
        outside[i] = state.last_outside;
        ifog_predict_features(features, stateless + i * IFOG_N_OUTPUTS);
        checked[i] = ifog_calibration_distance(features);
    }
    (void)rate;
    (void)reference;
    for (i = 1; i <= n; ++i) {
        if (i == n || rows[i * WIDTH] != 0.0) {
            ifog_batch(i - start, time + start, temperature + start * IFOG_N_SENSORS,
                       batched + start * IFOG_N_OUTPUTS);
            start = i;
        }
    }
    fwrite(streamed, sizeof(ifog_real), (size_t)(n * IFOG_N_OUTPUTS), out);
    fwrite(batched, sizeof(ifog_real), (size_t)(n * IFOG_N_OUTPUTS), out);
    fwrite(stateless, sizeof(ifog_real), (size_t)(n * IFOG_N_OUTPUTS), out);
    fwrite(distance, sizeof(double), (size_t)n, out);
    fwrite(checked, sizeof(double), (size_t)n, out);
    fwrite(outside, sizeof(int), (size_t)n, out);
#ifdef IFOG_N_WEIGHTS
    fwrite(&state.n_updates, sizeof(long), 1, out);
    fwrite(&state.n_resets, sizeof(long), 1, out);
    fwrite(state.weights, sizeof(double), IFOG_N_WEIGHTS * IFOG_N_OUTPUTS, out);
#endif
    fclose(out);
    fclose(in);
    return 0;
}
"""


def _campaign(random_state, temperature_range, n_runs, profile="paper", sampling_period=30.0):
    frame = make_thermal_campaign(
        n_units=1,
        n_runs=n_runs,
        azimuths=[0.0],
        profile=profile,
        sampling_period=sampling_period,
        temperature_range=temperature_range,
        random_state=random_state,
    ).frame
    # A second sensor (a lagging neighbour) and a second output for the wider models.
    frame["temperature_2"] = frame.groupby("run")["temperature"].shift(20)
    frame["temperature_2"] = frame["temperature_2"].fillna(frame["temperature"])
    frame["drift_2"] = 0.5 * frame["drift"] + 0.01
    return frame


@pytest.fixture(scope="module")
def calibration():
    """Three runs between 0 and 40 degC: what every model is calibrated on."""
    return _campaign(3, (0.0, 40.0), n_runs=3)


@pytest.fixture(scope="module")
def excursion(calibration):
    """One calibration run (inside), then two runs from -10 to 45 degC (mostly outside)."""
    first = calibration[calibration["run"] == calibration["run"].iloc[0]]
    later = _campaign(14, (-10.0, 45.0), n_runs=2)
    later = later.assign(run=later["run"] + 1000)
    return pd.concat([first, later], ignore_index=True)


def _rbf():
    return RBFNetRegressor(n_centers=15, max_candidates=100, max_samples=1000, random_state=0)


def _two_sensors(policy, **params):
    """Two temperature columns, two outputs; one rate column per sensor."""
    return make_compensation_pipeline(
        Ridge(1e-3),
        temperature=["temperature", "temperature_2"],
        terms=("T", "dT", "T_lag900s", "gradient"),
        uncalibrated=policy,
        **params,
    )


def _no_temperature(policy, **params):
    """No T among the features: a constant fallback, no temperature column."""
    return make_compensation_pipeline(
        Ridge(1e-3), terms=("dT", "T_lag900s", "T_lag3600s"), uncalibrated=policy, **params
    )


# name -> (make the pipeline for a policy, target columns). The margins are given (not the
# default, which the domain's benchmark sets) so that the excursion's share outside stays
# well above 30 %, and the two-sensor model also has rows outside by a temperature alone.
MODELS = {
    # T first among the features: the fallback is a line in T, the domain has one
    # temperature column.
    "ridge": (
        lambda policy: make_compensation_pipeline(Ridge(1e-3), uncalibrated=policy, margin=1.0),
        ["drift"],
    ),
    "rbf": (
        lambda policy: make_compensation_pipeline(_rbf(), uncalibrated=policy, margin=1.0),
        ["drift"],
    ),
    # Two temperature columns (rows outside by a temperature alone), two outputs.
    "two-sensors-two-outputs": (
        lambda policy: _two_sensors(policy, margin=1.0),
        ["drift", "drift_2"],
    ),
    # No T among the features: a constant fallback, no temperature column.
    "no-temperature": (lambda policy: _no_temperature(policy, margin=0.5), ["drift"]),
}


def _fit(name, policy, frame, models=MODELS):
    make, target = models[name]
    y = frame[target].to_numpy() if len(target) > 1 else frame[target[0]]
    return make(policy).fit(frame, y)


def _quiet(function, *args):
    """``function(*args)`` without the OutsideCalibrationWarning (a test of the values)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        return function(*args)


def _build(model, directory, precision="double", driver=DRIVER, **options):
    """Export ``model`` to C in ``directory`` and compile it with ``driver`` (C source)."""
    to_c(model, directory, precision=precision, **options)
    (directory / "driver.c").write_text(driver)
    result = subprocess.run(
        [CC, *STRICT_FLAGS, *EXTRA_FLAGS, "-O1", "driver.c", "ifog.c", "-lm", "-o", "driver"],
        cwd=directory,
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    return directory / "driver"


def _run(executable, model, frame, real=np.float64, has_reference=None, inner=None):
    """The C outputs for ``frame`` (see DRIVER), as a dict of arrays.

    ``has_reference``: the rows given a reference (``reference + 0.05``); ``inner``: the
    columns ``model`` was fitted on, when ``frame`` holds more (a unit column).
    """
    spec = describe_pipeline(model)
    n, n_outputs = len(frame), spec["n_outputs"]
    run = frame["run"].to_numpy()
    starts = np.r_[True, run[1:] != run[:-1]]
    has_reference = np.zeros(n, dtype=bool) if has_reference is None else has_reference
    rates = np.repeat(frame[["rate"]].to_numpy(), n_outputs, axis=1)
    references = np.repeat(frame[["reference"]].to_numpy(), n_outputs, axis=1) + 0.05
    sensors = frame[spec["features"]["temperature"]].to_numpy()
    features = model[0].transform(frame if inner is None else frame[inner])
    features = np.asarray(features, dtype=np.float64)
    rows = np.column_stack(
        [starts, frame["time"], has_reference, rates, references, sensors, features]
    )
    rows.astype(np.float64).tofile(executable.parent / "in.bin")
    subprocess.run([executable, str(n), "in.bin", "out.bin"], cwd=executable.parent, check=True)
    raw = (executable.parent / "out.bin").read_bytes()
    out, position = {}, 0
    layout = [
        *[(key, real, (n, n_outputs)) for key in ("streamed", "batched", "stateless")],
        *[(key, np.float64, (n,)) for key in ("distance", "stateless_distance")],
        ("outside", np.intc, (n,)),
    ]
    for key, dtype, shape in layout:
        size = np.dtype(dtype).itemsize * int(np.prod(shape))
        out[key] = np.frombuffer(raw[position : position + size], dtype=dtype).reshape(shape)
        position += size
    rest = raw[position:]
    if rest:  # built with adapt
        counts = np.frombuffer(rest[:16], dtype=np.int64)
        out["n_updates"], out["n_resets"] = int(counts[0]), int(counts[1])
        n_weights = (len(rest) - 16) // 8
        out["weights"] = np.frombuffer(rest[16:], dtype=np.float64).reshape(
            n_weights // n_outputs, n_outputs
        )
    out["streamed"] = out["streamed"].astype(np.float64)
    return out


def _assert_close(actual, expected, rtol=RTOL):
    """Per output: ``|actual - expected| <= rtol * max|expected|`` (a drift may cross 0)."""
    expected = np.asarray(expected, dtype=np.float64).reshape(actual.shape)
    error = np.max(np.abs(actual - expected), axis=0)
    scale = np.max(np.abs(expected), axis=0)
    assert np.all(error <= rtol * scale), f"max error {error} > {rtol} * {scale}"


# --- the schema -----------------------------------------------------------------------------


def test_schema_carries_the_exact_domain(calibration, tmp_path):
    model = _fit("two-sensors-two-outputs", "clip", calibration)
    document = json.loads(to_json(model, tmp_path / "model.json").read_text())
    assert document["schema_version"] == SCHEMA_VERSION == 9
    domain = document["domain"]
    box = model.domain_.box_
    for key in ("center", "scale", "axes", "axis_scale", "lower", "upper"):
        np.testing.assert_array_equal(domain[key], getattr(box, key))
    assert np.shape(domain["axes"]) == (7, 7)  # one axis per row, as Box.axes
    assert domain["margin"] == model.domain_.threshold_
    assert domain["blend_width"] == policy_module.BlendWithFallback().width == 1.0
    assert domain["uncalibrated"] == "clip"
    assert domain["temperature_columns"] == model.domain_.temperature_columns_ == [0, 3]
    np.testing.assert_array_equal(domain["temperature_low"], model.domain_.data_min_[[0, 3]])
    np.testing.assert_array_equal(domain["temperature_high"], model.domain_.data_max_[[0, 3]])
    # the rate term: dT of each sensor
    assert domain["rate_columns"] == list(box.rate_columns) == [1, 4]
    for key in ("rate_low", "rate_high", "rate_scale"):
        np.testing.assert_array_equal(domain[key], getattr(box, key))
    np.testing.assert_array_equal(domain["rate_low"], model.domain_.data_min_[[1, 4]])
    assert domain["projection_rounds"] == PROJECTION_ROUNDS
    fallback = domain["fallback"]
    np.testing.assert_array_equal(fallback["intercept"], model.fallback_.intercept)
    np.testing.assert_array_equal(fallback["slope"], model.fallback_.slope)
    assert fallback["column"] == model.fallback_.column == 0


def test_plain_pipeline_has_no_domain(calibration, tmp_path):
    plain = make_pipeline(
        ThermalFeatures(temperature="temperature", time="time", run="run"),
        StandardScaler(),
        Ridge(1e-3),
    ).fit(calibration, calibration["drift"])
    assert describe_pipeline(plain)["domain"] is None
    assert json.loads(to_json(plain, tmp_path / "plain.json").read_text())["domain"] is None
    header = to_c(plain, tmp_path)[0].read_text()
    assert "#define IFOG_HAS_DOMAIN 0" in header
    assert "last_outside" not in header
    assert "IFOG_MARGIN" not in header


@pytest.mark.parametrize("adapt", [None, "output"])
def test_domain_c_is_self_contained(adapt, calibration, tmp_path):
    model = _fit("two-sensors-two-outputs", "clip", calibration)
    header, source = to_c(model, tmp_path, adapt=adapt)
    text = header.read_text() + source.read_text()
    includes = sorted({line for line in text.splitlines() if line.startswith("#include")})
    assert includes == ['#include "ifog.h"', "#include <math.h>"]
    for forbidden in ("malloc", "calloc", "free(", "printf"):
        assert forbidden not in text
    # No mutable static state: every static object is a const table.
    assert not re.findall(r"^static (?!const )[^(]*;", text, flags=re.MULTILINE)
    declared = header.read_text()
    for name in (
        "#define IFOG_HAS_DOMAIN 1",
        "#define IFOG_N_TEMPERATURES 2",
        "#define IFOG_N_RATES 2",
        "double last_distance;",
        "int last_outside;",
        "double ifog_calibration_distance(",
        'the policy "clip"',
    ):
        assert name in declared


def test_export_reads_the_settings_at_export_time(calibration, tmp_path, monkeypatch):
    model = _fit("ridge", "blend", calibration)
    monkeypatch.setattr(policy_module, "_BLEND_WIDTH", 2.5)  # the blend's default width
    _, target = MODELS["ridge"]
    y = calibration[target].to_numpy() if len(target) > 1 else calibration[target[0]]
    # read at fit
    model.set_params(domain__margin=0.25, domain__alpha=0.5, uncalibrated="none")
    model.fit(calibration, y)
    threshold = model.domain_.threshold_
    assert threshold >= 0.25
    domain = describe_pipeline(model)["domain"]
    assert (domain["blend_width"], domain["margin"], domain["uncalibrated"]) == (
        2.5,
        threshold,
        "none",
    )
    header = to_c(model, tmp_path)[0].read_text()
    assert "#define IFOG_BLEND_WIDTH 2.5\n" in header
    assert f"#define IFOG_MARGIN {threshold!r}\n" in header
    assert 'the policy "none"' in header


def test_bad_policy_is_named(calibration, tmp_path):
    model = _fit("ridge", "blend", calibration)
    model.uncalibrated = "extrapolate"  # set behind set_params' validation
    with pytest.raises(ValueError, match=r"uncalibrated must be one of .*'extrapolate'"):
        to_c(model, tmp_path)
    model.uncalibrated, model.domain_.threshold_ = "clip", float("nan")
    with pytest.raises(ValueError, match=r"threshold_, the exported margin\) must be a finite"):
        to_json(model, tmp_path / "model.json")
    assert not list(tmp_path.iterdir()), "a refused export writes nothing"


def _evaluate_fallback(fallback, features):
    """The JSON "fallback" entry's prediction, from the schema alone."""
    intercept, slope = np.array(fallback["intercept"]), np.array(fallback["slope"])
    if fallback["column"] is None:
        return np.broadcast_to(intercept, (len(features), intercept.size))
    t = features[:, [fallback["column"]]]
    f = intercept + t * slope
    if any(fallback["hold_below"]):
        f = f - np.minimum(t - fallback["low"], 0.0) * (slope * fallback["hold_below"])
    if any(fallback["hold_above"]):
        f = f - np.maximum(t - fallback["high"], 0.0) * (slope * fallback["hold_above"])
    if fallback["rate_column"] is not None:
        bound = fallback["rate_bound"]
        rate = np.clip(features[:, [fallback["rate_column"]]], -bound, bound)
        f = f + rate * np.array(fallback["rate_slope"])
    return f


def _evaluate_domain(domain, features, network, evaluate):
    """Apply the JSON "domain" entry to the steps' prediction, from the schema alone."""
    center, scale = np.array(domain["center"]), np.array(domain["scale"])
    axes, axis_scale = np.array(domain["axes"]), np.array(domain["axis_scale"])
    lower, upper = np.array(domain["lower"]), np.array(domain["upper"])
    columns = domain["temperature_columns"]
    low, high = np.array(domain["temperature_low"]), np.array(domain["temperature_high"])
    margin = domain["margin"]

    def box(x):
        p = ((x - center) / scale) @ axes.T
        c = np.clip(p, lower, upper)
        return p, c, np.sqrt((((p - c) / axis_scale) ** 2).sum(axis=1))

    # The distance: the box's, with under the root every rate's excess over its scale.
    _, _, d = box(features)
    rates = features[:, domain["rate_columns"]]
    rate_low, rate_high = np.array(domain["rate_low"]), np.array(domain["rate_high"])
    beyond = np.maximum(rate_low - rates, 0.0) + np.maximum(rates - rate_high, 0.0)
    rate_squares = ((beyond / np.array(domain["rate_scale"])) ** 2).sum(axis=1)
    # Beyond the calibrated rates or temperatures: held to the margin by the boost.
    t = features[:, columns]
    b_low = np.array(domain["boost_temperature_low"])
    b_high = np.array(domain["boost_temperature_high"])
    t_excess = (np.maximum(b_low - t, 0.0) + np.maximum(t - b_high, 0.0)) / scale[columns]
    t_excess = t_excess / domain["boost_temperature_ramp"]
    novelty = np.sqrt(rate_squares / domain["boost_rate_ramp"] ** 2 + (t_excess**2).sum(axis=1))
    d = np.sqrt(d**2 + rate_squares) + domain["boost"] * np.minimum(novelty, 1.0)
    outside = (d > margin) | np.any(
        (features[:, columns] < low) | (features[:, columns] > high), 1
    )
    result = network.reshape(len(features), -1).copy()
    if domain["uncalibrated"] == "blend":
        s = np.clip((d - margin) / domain["blend_width"], 0.0, 1.0)
        w = (s * s * (3.0 - 2.0 * s))[:, None]
        line = _evaluate_fallback(domain["fallback"], features)
        result[outside] = ((1.0 - w) * result + w * line)[outside]
    elif domain["uncalibrated"] == "clip":
        x = features[outside].copy()
        for _ in range(domain["projection_rounds"] if columns else 1):
            point, clamped, gap = box(x)  # by the box alone: the rates are not moved
            far = gap > margin
            q = clamped[far] + (point[far] - clamped[far]) * (margin / gap[far])[:, None]
            x[far] = (q @ axes) * scale + center
            if columns:
                x[:, columns] = np.clip(x[:, columns], low, high)
        if columns:
            # Then the box once more, and back along the segment to the centre until every
            # temperature is within its range: found here by bisection, not in closed form.
            point, clamped, gap = box(x)
            far = gap > margin
            q = clamped[far] + (point[far] - clamped[far]) * (margin / gap[far])[:, None]
            x[far] = (q @ axes) * scale + center

            def within(rows):
                return np.all((rows[:, columns] >= low) & (rows[:, columns] <= high), axis=1)

            beyond = ~within(x)
            inner, outer = np.zeros(beyond.sum()), np.ones(beyond.sum())
            for _ in range(64):
                middle = (inner + outer) / 2
                inside = within(center + middle[:, None] * (x[beyond] - center))
                inner, outer = np.where(inside, middle, inner), np.where(inside, outer, middle)
            x[beyond] = center + inner[:, None] * (x[beyond] - center)
        result[outside] = evaluate(x).reshape(len(x), -1)
    return result, d, outside


@pytest.mark.parametrize("policy", POLICIES)
@pytest.mark.parametrize("name", ["ridge", "two-sensors-two-outputs", "no-temperature"])
def test_json_domain_reproduces_predict(name, policy, calibration, excursion, tmp_path):
    model = _fit(name, policy, calibration)
    domain = json.loads(to_json(model, tmp_path / "model.json").read_text())["domain"]
    features = np.asarray(model[0].transform(excursion), dtype=np.float64)
    network = model[1:].predict(features)
    drift, distance, flag = _evaluate_domain(domain, features, network, model[1:].predict)
    expected = _quiet(model.predict, excursion)
    _assert_close(drift, expected, 1e-10)
    np.testing.assert_allclose(distance, model.calibration_distance(excursion), rtol=1e-10)
    np.testing.assert_array_equal(flag, model.outside_calibration(excursion))
    assert flag.mean() > 0.3
    if policy != "none":  # the policy changes the prediction where it applies
        assert np.max(np.abs(expected.reshape(drift.shape) - network.reshape(drift.shape))) > 1e-3


# --- C: drift, distance and flag equal Python's ---------------------------------------------


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
@pytest.mark.parametrize("policy", POLICIES)
@pytest.mark.parametrize("name", sorted(MODELS))
def test_c_follows_the_domain(name, policy, calibration, excursion, tmp_path):
    model = _fit(name, policy, calibration)
    c = _run(_build(model, tmp_path), model, excursion)
    expected = _quiet(model.predict, excursion).reshape(len(excursion), -1)
    flag = model.outside_calibration(excursion)
    distance = model.calibration_distance(excursion)
    # A meaningful share outside, and rows inside too: neither path can pass vacuously.
    assert 0.3 < flag.mean() < 0.95
    np.testing.assert_array_equal(c["outside"], flag)
    np.testing.assert_allclose(c["distance"], distance, rtol=RTOL, atol=RTOL * distance.max())
    np.testing.assert_allclose(
        c["stateless_distance"], distance, rtol=RTOL, atol=RTOL * distance.max()
    )
    _assert_close(c["streamed"], expected)
    _assert_close(c["stateless"], expected)
    np.testing.assert_array_equal(c["batched"], c["streamed"])
    network = model[:].predict(excursion).reshape(expected.shape)  # a plain Pipeline
    np.testing.assert_array_equal(expected[~flag], network[~flag])  # inside: unchanged
    changed = np.max(np.abs(expected - network), axis=1) > 1e-6
    if policy == "none":
        assert not changed.any()
    elif name != "two-sensors-two-outputs" or policy == "clip":
        # (blend moves nothing for rows outside by a temperature alone: its weight is 0)
        assert changed[flag].mean() > 0.3


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
@pytest.mark.parametrize("policy", POLICIES)
def test_c_float_follows_the_domain(policy, calibration, excursion, tmp_path):
    # The domain is computed in double from the front end's double features, whatever the
    # precision: its gradient column is an exact difference of the two sensors, so one axis
    # of the box is degenerate, and features rounded to float would read as a distance.
    model = _fit("two-sensors-two-outputs", policy, calibration)
    c = _run(_build(model, tmp_path, precision="float"), model, excursion, real=np.float32)
    expected = _quiet(model.predict, excursion).reshape(len(excursion), -1)
    distance = model.calibration_distance(excursion)
    flag = model.outside_calibration(excursion)
    assert 0.3 < flag.mean() < 0.95
    np.testing.assert_array_equal(c["outside"], flag)
    np.testing.assert_allclose(c["distance"], distance, rtol=RTOL, atol=RTOL * distance.max())
    _assert_close(c["streamed"], expected, 1e-4)
    header = (tmp_path / "ifog.h").read_text()
    assert "typedef float ifog_real;" in header
    assert f"#define IFOG_MARGIN {model.domain_.threshold_!r}\n" in header  # a double literal


# --- the rate term: a heating-only calibration operated on cooling runs --------------------


@pytest.fixture(scope="module")
def heating():
    """Three heating-only runs (soak, ramp up, soak) between 10 and 40 degC."""
    return _campaign(0, (10.0, 40.0), n_runs=3, profile="paper", sampling_period=60.0)


@pytest.fixture(scope="module")
def cooling():
    """Two cooling-only runs of the same unit in the same range: rates of the other sign."""
    return _campaign(0, (10.0, 40.0), n_runs=2, profile="cooling", sampling_period=60.0)


# name -> (make the pipeline for a policy, target columns), at the default margin (the one
# the rate weight was chosen with): one rate column (dT), one per sensor, and no temperature
# column ("clip" projects once, by the box alone).
RATE_MODELS = {
    "default": (
        lambda policy: make_compensation_pipeline(Ridge(1e-3), uncalibrated=policy),
        ["drift"],
    ),
    # alpha=0.5: the threshold at the median held-out distance (the margin here), so that
    # the cooling runs have rows the box alone puts outside (at the default alpha the three
    # heating runs spread along the sensors' gradient axis well beyond them).
    "two-sensors-two-outputs": (
        lambda policy: _two_sensors(policy, alpha=0.5),
        ["drift", "drift_2"],
    ),
    "no-temperature": (_no_temperature, ["drift"]),
}


def _outside_by_rates(model, calibration, frame):
    """The rows of ``frame`` outside the domain by the rate term alone (flagged, every
    temperature within its calibrated range, the box's distance within the margin), and the
    box's distance of every row."""
    box = model.domain_.box_
    assert box.rate_columns, "the model has a rate term"
    features = np.asarray(model[0].transform(frame), dtype=np.float64)
    pure = domain_module.box_distance(box._replace(rate_columns=()), features)
    sensors = describe_pipeline(model)["features"]["temperature"]
    low, high = calibration[sensors].min(), calibration[sensors].max()
    within = ((frame[sensors] >= low) & (frame[sensors] <= high)).all(axis=1).to_numpy()
    by_rates = model.outside_calibration(frame) & within & (pure <= model.domain_.threshold_)
    return by_rates, pure


def _distance_atol(model, distance):
    """The absolute tolerance of a distance: RTOL of the largest, or one rounding of a unit
    coordinate over the narrowest axis's scale. Along an axis whose spread is floored (two
    sensors' gradient is an exact difference of them), a row on the box's edge reads 0 in
    one summation order and about 1e-11 in another."""
    floor = np.finfo(np.float64).eps / model.domain_.box_.axis_scale.min()
    return max(RTOL * distance.max(), floor)


@pytest.mark.parametrize("policy", POLICIES)
@pytest.mark.parametrize("name", sorted(RATE_MODELS))
def test_json_follows_the_rate_term(name, policy, heating, cooling, tmp_path):
    model = _fit(name, policy, heating, RATE_MODELS)
    domain = json.loads(to_json(model, tmp_path / "model.json").read_text())["domain"]
    box = model.domain_.box_
    assert domain["rate_columns"] == list(box.rate_columns)
    by_rates, _ = _outside_by_rates(model, heating, cooling)
    assert by_rates.sum() >= 10  # the rows the rate term exists for
    features = np.asarray(model[0].transform(cooling), dtype=np.float64)
    network = model[1:].predict(features)
    drift, distance, flag = _evaluate_domain(domain, features, network, model[1:].predict)
    expected = model.calibration_distance(cooling)
    np.testing.assert_array_equal(flag, model.outside_calibration(cooling))
    atol = _distance_atol(model, expected)
    np.testing.assert_allclose(distance, expected, rtol=RTOL, atol=atol)
    _assert_close(drift, _quiet(model.predict, cooling))


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
@pytest.mark.parametrize("policy", POLICIES)
@pytest.mark.parametrize("name", sorted(RATE_MODELS))
def test_c_follows_the_rate_term(name, policy, heating, cooling, tmp_path):
    model = _fit(name, policy, heating, RATE_MODELS)
    by_rates, pure = _outside_by_rates(model, heating, cooling)
    flag = model.outside_calibration(cooling)
    distance = model.calibration_distance(cooling)
    # Rows outside by their rates alone, rows the box puts outside, and rows inside: no path
    # of the C can pass vacuously.
    assert by_rates.sum() >= 10
    assert (flag & (pure > model.domain_.threshold_)).sum() >= 10
    assert (~flag).sum() >= 10
    c = _run(_build(model, tmp_path), model, cooling)
    header = (tmp_path / "ifog.h").read_text()
    assert f"#define IFOG_N_RATES {len(model.domain_.box_.rate_columns)}\n" in header
    expected = _quiet(model.predict, cooling).reshape(len(cooling), -1)
    np.testing.assert_array_equal(c["outside"], flag)
    atol = _distance_atol(model, distance)
    np.testing.assert_allclose(c["distance"], distance, rtol=RTOL, atol=atol)
    np.testing.assert_allclose(c["stateless_distance"], distance, rtol=RTOL, atol=atol)
    _assert_close(c["streamed"], expected)
    _assert_close(c["stateless"], expected)
    np.testing.assert_array_equal(c["batched"], c["streamed"])
    network = model[:].predict(cooling).reshape(expected.shape)  # a plain Pipeline
    moved = np.max(np.abs(expected - network), axis=1) > 1e-9
    if policy == "blend":
        # weighed by the full distance: the rows outside by their rates move to the fallback
        assert moved[by_rates].mean() > 0.9
    elif policy == "clip":
        # projected by the box alone: the rows outside by their rates are evaluated as they
        # are (a shrink of margin / distance would have moved them), the others move
        _assert_close(c["streamed"][by_rates], network[by_rates])
        assert not moved[by_rates].any()
        assert moved[flag & (pure > model.domain_.threshold_)].mean() > 0.5
    else:
        assert not moved.any()


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
@pytest.mark.parametrize("policy", POLICIES)
def test_domain_without_rates_writes_no_rate_code(policy, calibration, excursion, tmp_path):
    model = make_compensation_pipeline(
        Ridge(1e-3), terms=("T", "T_lag900s"), uncalibrated=policy, margin=1.0
    ).fit(calibration, calibration["drift"])
    assert model.domain_.box_.rate_columns == ()
    domain = describe_pipeline(model)["domain"]
    for key in ("rate_columns", "rate_low", "rate_high", "rate_scale"):
        assert domain[key] == []
    c = _run(_build(model, tmp_path), model, excursion)
    text = (tmp_path / "ifog.h").read_text() + (tmp_path / "ifog.c").read_text()
    for absent in ("IFOG_N_RATES", "ifog_with_rates", "ifog_rate_", "a rate ("):
        assert absent not in text
    flag = model.outside_calibration(excursion)
    distance = model.calibration_distance(excursion)
    assert 0.3 < flag.mean() < 0.95
    np.testing.assert_array_equal(c["outside"], flag)
    np.testing.assert_allclose(c["distance"], distance, rtol=RTOL, atol=RTOL * distance.max())
    _assert_close(c["streamed"], _quiet(model.predict, excursion).reshape(len(excursion), -1))


# --- a production lot ----------------------------------------------------------------------


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
@pytest.mark.parametrize("pooling", ["partial", "none"])
def test_unitwise_c_carries_each_units_domain(
    calibration, excursion, tmp_path, pooling, monkeypatch
):
    # The second unit was calibrated 5 degC warmer: another domain.
    warmer = calibration.assign(
        unit="gyro-2",
        run=calibration["run"] + 100,
        temperature=calibration["temperature"] + 5.0,
        drift=1.5 * calibration["drift"] + 0.02,
    )
    lot = pd.concat([calibration.assign(unit="gyro-1"), warmer], ignore_index=True)
    columns = ["unit", "temperature", "time", "run"]
    # A far-unit spread of 1 lets the evidence give these units their own models (with
    # "partial" too): each carries its own domain, which the export must write.
    monkeypatch.setattr("sklearn_ifog.unitwise.OWN_MODEL_SPREAD", 1.0)
    model = UnitwiseRegressor(make_compensation_pipeline(Ridge(1e-3)), pooling=pooling)
    model.fit(lot[columns], lot["drift"])
    written = to_c_units(model, tmp_path)
    domains = {}
    for unit, (header, _) in written.items():
        estimator = model.estimators_[unit]
        domains[unit] = describe_pipeline(estimator)["domain"]
        np.testing.assert_array_equal(domains[unit]["upper"], estimator.domain_.upper_)
        name = header.stem
        (tmp_path / "driver.c").write_text(
            DRIVER.replace("ifog", name).replace("IFOG", name.upper())
        )
        result = subprocess.run(
            [CC, *STRICT_FLAGS, "-O1", "driver.c", f"{name}.c", "-lm", "-o", f"{name}-driver"],
            cwd=tmp_path,
            capture_output=True,
            text=True,
            check=False,
        )
        assert result.returncode == 0, result.stderr
        rows = excursion.assign(unit=unit)
        inner = ["temperature", "time", "run"]
        c = _run(tmp_path / f"{name}-driver", estimator, rows, inner=inner)
        expected = _quiet(model.predict, rows[columns]).reshape(len(rows), -1)
        _assert_close(c["streamed"], expected)
        flag = estimator.outside_calibration(rows[inner])
        np.testing.assert_array_equal(c["outside"], flag)
        assert flag.mean() > 0.3
    # each unit's source carries its own domain, and so does the lot's JSON document
    assert domains["gyro-1"]["temperature_high"] != domains["gyro-2"]["temperature_high"]
    document = json.loads(to_json(model, tmp_path / "lot.json").read_text())
    assert {entry["unit"]: entry["model"]["domain"] for entry in document["units"]} == domains


# --- recalibration: outside the domain, compensated by the policy, never learnt from --------


def _references(n, seed=3, share=0.3):
    return np.random.default_rng(seed).random(n) < share


def _stream(model, frame, adapt, has_reference, offset=0.05, forgetting=0.995):
    """The Python StreamingCompensator's drift and counts on ``frame``."""
    compensator = StreamingCompensator(model, adapt=adapt, forgetting=forgetting)
    n_outputs = compensator.n_outputs
    rates = np.repeat(frame[["rate"]].to_numpy(), n_outputs, axis=1)
    references = np.repeat(frame[["reference"]].to_numpy(), n_outputs, axis=1) + offset
    references = np.where(has_reference[:, None], references, None)
    if n_outputs == 1:
        rates, references = rates[:, 0], references[:, 0]
    _, drift = compensator.update(frame, rates, references)
    return np.asarray(drift, dtype=np.float64).reshape(len(frame), -1), compensator


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
@pytest.mark.parametrize("adapt", ["bias", "output"])
@pytest.mark.parametrize("name", ["ridge", "rbf"])
def test_c_recalibration_inside_the_domain_matches_python(name, adapt, calibration, tmp_path):
    model = _fit(name, "blend", calibration)
    has = _references(len(calibration))
    directory = tmp_path / "adapt"
    c = _run(
        _build(model, directory, adapt=adapt, forgetting=0.995),
        model,
        calibration,
        has_reference=has,
    )
    assert not c["outside"].any()  # the calibration lies inside its own domain
    drift, compensator = _stream(model, calibration, adapt, has)
    _assert_close(c["streamed"], drift, ADAPT_RTOL)
    state = compensator.get_state()["rls"]
    assert [c["n_updates"], c["n_resets"]] == [state["n_updates"], state["n_resets"]]
    assert c["n_updates"] == has.sum()
    # The recalibration moved the drift (else the comparison would be the plain model's).
    assert np.max(np.abs(drift - model.predict(calibration).reshape(drift.shape))) > 0.01


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
@pytest.mark.parametrize("policy", POLICIES)
@pytest.mark.parametrize("adapt", ["bias", "output"])
def test_c_recalibration_outside_the_domain_matches_python(
    adapt, policy, calibration, excursion, tmp_path
):
    model = _fit("ridge", policy, calibration)
    has = _references(len(excursion))
    directory = tmp_path / "adapt"
    c = _run(
        _build(model, directory, adapt=adapt, forgetting=0.995),
        model,
        excursion,
        has_reference=has,
    )
    flag = model.outside_calibration(excursion)
    np.testing.assert_array_equal(c["outside"], flag)
    assert c["n_updates"] == (has & ~flag).sum() < has.sum()
    drift, compensator = _stream(model, excursion, adapt, has)
    _assert_close(c["streamed"], drift, ADAPT_RTOL)
    np.testing.assert_array_equal(compensator.last_outside, flag)
    assert compensator.get_state()["rls"]["n_updates"] == c["n_updates"]


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
@pytest.mark.parametrize("adapt", ["bias", "output"])
def test_c_references_outside_the_domain_change_nothing(adapt, calibration, excursion, tmp_path):
    """The rule checked on the C alone: references outside are ignored; bias after policy."""
    model = _fit("ridge", "blend", calibration)
    flag = model.outside_calibration(excursion)
    executable = _build(model, tmp_path / "adapt", adapt=adapt, forgetting=0.995)
    # References on every row inside; then also on every row outside.
    inside_only = _run(executable, model, excursion, has_reference=~flag)
    everywhere = _run(executable, model, excursion, has_reference=np.ones(len(flag), bool))
    for key in ("streamed", "distance", "outside", "weights"):
        np.testing.assert_array_equal(everywhere[key], inside_only[key])
    assert everywhere["n_updates"] == inside_only["n_updates"] == (~flag).sum()
    if adapt == "bias":
        # Over the longest stretch outside, the offset stays as learnt before it, added to the
        # policy's drift (the batch predict): a constant difference from predict.
        edges = np.flatnonzero(np.diff(np.r_[False, flag, False].astype(int)))
        stretches = zip(edges[::2], edges[1::2], strict=True)
        start, stop = max(stretches, key=lambda pair: pair[1] - pair[0])
        assert stop - start > 100
        assert (~flag[:start]).any()  # references inside before it
        offset = (
            everywhere["streamed"][start:stop, 0] - _quiet(model.predict, excursion)[start:stop]
        )
        np.testing.assert_allclose(offset, offset[0], rtol=0, atol=RTOL * abs(offset[0]) + 1e-15)
        assert abs(offset[0]) > 0.01  # an offset was learnt inside


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
@pytest.mark.parametrize("adapt", ["bias", "output"])
def test_c_recalibration_ignores_rows_outside_by_their_rates(adapt, heating, cooling, tmp_path):
    model = _fit("default", "blend", heating, RATE_MODELS)
    by_rates, _ = _outside_by_rates(model, heating, cooling)
    has = _references(len(cooling))
    assert (has & by_rates).sum() >= 5  # references the rate term alone turns away
    c = _run(
        _build(model, tmp_path / "adapt", adapt=adapt, forgetting=0.995),
        model,
        cooling,
        has_reference=has,
    )
    flag = model.outside_calibration(cooling)
    np.testing.assert_array_equal(c["outside"], flag)
    assert c["n_updates"] == (has & ~flag).sum()
    drift, compensator = _stream(model, cooling, adapt, has)
    _assert_close(c["streamed"], drift, ADAPT_RTOL)
    assert compensator.get_state()["rls"]["n_updates"] == c["n_updates"]


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
@pytest.mark.parametrize("precision", ["double", "float"])
def test_c_and_json_follow_every_term_of_a_plane_fallback(
    precision, calibration, excursion, tmp_path
):
    """A fallback with a rate term clipped to its bound, held flat below its low edge on
    one output and above its high edge on the other: C and the JSON schema give predict's
    drift (the calibration's own fallback may not use every term)."""
    model = _fit("two-sensors-two-outputs", "blend", calibration)
    features = np.asarray(model[0].transform(excursion), dtype=np.float64)
    names = list(model.feature_names_out_)
    t, rate = features[:, names.index("temperature_T")], features[:, names.index("temperature_dT")]
    handed = model.outside_calibration(excursion) & (model.calibration_distance(excursion) > 2)
    model.fallback_ = fallback_module.Fallback(
        intercept=np.array([0.01, -0.02]),
        slope=np.array([0.003, -0.002]),
        column=names.index("temperature_T"),
        rate_slope=np.array([0.05, 0.08]),
        rate_column=names.index("temperature_dT"),
        rate_bound=float(np.quantile(np.abs(rate[handed]), 0.5)),
        low=float(np.quantile(t[handed], 0.3)),
        high=float(np.quantile(t[handed], 0.7)),
        hold_below=np.array([True, False]),
        hold_above=np.array([False, True]),
    )
    expected = _quiet(model.predict, excursion).reshape(len(excursion), -1)
    fallback = model.fallback_.predict(features)
    # every term acts on some rows the blend hands to the fallback
    assert (t[handed] < model.fallback_.low).any()
    assert (t[handed] > model.fallback_.high).any()
    assert (np.abs(rate[handed]) > model.fallback_.rate_bound).any()
    domain = json.loads(to_json(model, tmp_path / "model.json").read_text())["domain"]
    np.testing.assert_allclose(
        _evaluate_fallback(domain["fallback"], features), fallback, rtol=1e-14
    )
    c = _run(
        _build(model, tmp_path, precision),
        model,
        excursion,
        real=np.float64 if precision == "double" else np.float32,
    )
    _assert_close(c["streamed"], expected, RTOL if precision == "double" else 1e-4)


@pytest.fixture(scope="module")
def widened():
    """A pipeline whose held-out runs let its model keep rows beyond the calibrated
    temperatures (``handover=True`` on a drift that follows a lag: the linear model on the
    features is exact, the fallback is not), and a colder and warmer excursion of it."""
    frame = make_thermal_campaign(
        n_units=1,
        n_runs=6,
        azimuths=[0.0],
        sampling_period=120.0,
        random_state=0,
    ).frame
    X = frame
    features = make_compensation_pipeline(Ridge(1e-3))[0].fit(X)
    lag = list(features.get_feature_names_out()).index("T_lag3600s")
    y = 0.05 * np.asarray(features.transform(X))[:, lag]
    # A small margin: the threshold the held-out runs calibrate lies above it, so that a
    # row beyond the calibrated temperatures is held to the margin (boost_ > 0).
    model = make_compensation_pipeline(Ridge(1e-3), margin=0.25, handover=True).fit(X, y)
    excursion = pd.concat(
        [
            frame[frame["run"] == 0].assign(temperature=lambda t: t["temperature"] - 12.0),
            frame[frame["run"] == 1].assign(run=9, temperature=lambda t: t["temperature"] + 12.0),
        ],
        ignore_index=True,
    )
    return model, excursion


def test_exports_follow_a_domain_widened_by_held_out_evidence(widened, tmp_path):
    model, excursion = widened
    domain = model.domain_
    assert model.handover_["temperatures below"]["keeps"]
    assert np.all(domain.boost_low_ < domain.data_min_[domain.temperature_columns_])
    assert domain.boost_ > 0
    spec = json.loads(to_json(model, tmp_path / "model.json").read_text())["domain"]
    assert spec["boost_temperature_low"] == domain.boost_low_.tolist()
    features = np.asarray(model[0].transform(excursion), dtype=np.float64)
    # Rows held to the margin and rows the evidence lets the model keep: both paths run.
    beyond = domain.temperature_excess(features) > 0
    temperatures = features[:, domain.temperature_columns_]
    kept = beyond & np.all(
        (temperatures >= domain.boost_low_) & (temperatures <= domain.boost_high_), axis=1
    )
    assert kept.sum() >= 10
    assert (beyond & ~kept).sum() >= 10
    network = model[1:].predict(features)
    drift, distance, flag = _evaluate_domain(spec, features, network, model[1:].predict)
    expected = model.calibration_distance(excursion)
    np.testing.assert_array_equal(flag, model.outside_calibration(excursion))
    atol = _distance_atol(model, expected)
    np.testing.assert_allclose(distance, expected, rtol=RTOL, atol=atol)
    _assert_close(drift, _quiet(model.predict, excursion))
    if CC is None:
        return
    c = _run(_build(model, tmp_path), model, excursion)
    np.testing.assert_array_equal(c["outside"], flag)
    np.testing.assert_allclose(c["distance"], expected, rtol=RTOL, atol=atol)
    _assert_close(c["streamed"], _quiet(model.predict, excursion))
