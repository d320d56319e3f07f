"""Export of fitted compensation Pipelines to C99 and JSON.

The generated C is compiled with the strict flags of the issue (plus ``-pedantic`` and the
warnings embedded toolchains commonly turn on) and run by a small driver on simulated
samples; its outputs are compared with ``pipeline.predict``. "Relative" agreement: every
sample's drift (and compensated rate) within ``rtol`` times the largest drift of the model on
those samples (``|c - p| <= rtol * max|p|``), because a fitted drift model may pass near zero,
and so may a compensated rate (at 90 deg azimuth), where a per-sample ratio means nothing.
"""

import json
import math
import os
import shutil
import subprocess

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.neighbors import KNeighborsRegressor
from sklearn.pipeline import Pipeline, make_pipeline
from sklearn.preprocessing import (
    MaxAbsScaler,
    MinMaxScaler,
    PolynomialFeatures,
    RobustScaler,
    StandardScaler,
)

from sklearn_ifog import (
    RBFNetRegressor,
    ThermalFeatures,
    UnitwiseRegressor,
    _description,
    make_compensation_pipeline,
)
from sklearn_ifog._description import SCHEMA_NAME, SCHEMA_VERSION, describe_pipeline
from sklearn_ifog._output_layer import LINEAR_REGRESSORS
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.export import to_c, to_c_units, to_json
from sklearn_ifog.export._c import format_c_literal

CC = shutil.which("cc")
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
STRICT_FLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror"]
EXTRA_FLAGS = ["-pedantic", "-Wshadow", "-Wconversion", "-Wdouble-promotion"]
N_SAMPLES = 10_000

# Reads rows (run-start flag, time, rates..., temperatures...) as float64; runs the streaming
# step and the compensation (resetting at each run start) and the batch function per run;
# writes the three outputs.
DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include "ifog.h"

#define WIDTH (2 + IFOG_N_OUTPUTS + IFOG_N_SENSORS)

int main(int argc, char **argv)
{
    long n, i, k, start = 0;
    double *rows, *time, *temperature;
    ifog_real *streamed, *batched, *compensated, rate[IFOG_N_OUTPUTS];
    ifog_state state, other;
    FILE *in, *out;
    if (argc != 4) return 1;
    n = atol(argv[1]);
    rows = malloc((size_t)(n * WIDTH) * sizeof(double));
    time = malloc((size_t)n * sizeof(double));
    temperature = malloc((size_t)(n * IFOG_N_SENSORS) * sizeof(double));
    streamed = malloc((size_t)(n * IFOG_N_OUTPUTS) * sizeof(ifog_real));
    batched = malloc((size_t)(n * IFOG_N_OUTPUTS) * sizeof(ifog_real));
    compensated = malloc((size_t)(n * IFOG_N_OUTPUTS) * sizeof(ifog_real));
    in = fopen(argv[2], "rb");
    out = fopen(argv[3], "wb");
    if (!rows || !time || !temperature || !streamed || !batched || !compensated || !in || !out)
        return 2;
    if (fread(rows, sizeof(double), (size_t)(n * WIDTH), in) != (size_t)(n * WIDTH)) return 3;
    ifog_init(&state);
    ifog_init(&other);
    for (i = 0; i < n; ++i) {
        const double *row = rows + i * WIDTH;
        time[i] = row[1];
        for (k = 0; k < IFOG_N_OUTPUTS; ++k) rate[k] = (ifog_real)row[2 + k];
        for (k = 0; k < IFOG_N_SENSORS; ++k) {
            temperature[i * IFOG_N_SENSORS + k] = row[2 + IFOG_N_OUTPUTS + k];
        }
        if (row[0] != 0.0) {
            ifog_reset(&state);
            ifog_reset(&other);
        }
        ifog_step(&state, time[i], temperature + i * IFOG_N_SENSORS,
                  streamed + i * IFOG_N_OUTPUTS);
        ifog_compensate(&other, time[i], temperature + i * IFOG_N_SENSORS, rate,
                        compensated + i * IFOG_N_OUTPUTS);
    }
    for (i = 1; i <= n; ++i) {
        if (i == n || rows[i * WIDTH] != 0.0) {
            ifog_batch(i - start, time + start, temperature + start * IFOG_N_SENSORS,
                       batched + start * IFOG_N_OUTPUTS);
            start = i;
        }
    }
    fwrite(streamed, sizeof(ifog_real), (size_t)(n * IFOG_N_OUTPUTS), out);
    fwrite(batched, sizeof(ifog_real), (size_t)(n * IFOG_N_OUTPUTS), out);
    fwrite(compensated, sizeof(ifog_real), (size_t)(n * IFOG_N_OUTPUTS), out);
    fclose(out);
    fclose(in);
    return 0;
}
"""


@pytest.fixture(scope="module")
def campaign():
    frame = make_thermal_campaign(n_units=1, n_runs=3, sampling_period=10.0, random_state=0).frame
    # Irregular time steps: a random 60 % of the 10 s samples (steps of 10 s to a few minutes).
    keep = np.random.default_rng(0).random(len(frame)) < 0.6
    frame = frame[keep].iloc[:N_SAMPLES].reset_index(drop=True)
    # A second sensor for the multi-sensor models: the reading of a lagging neighbour.
    frame["temperature_2"] = (
        frame.groupby("run")["temperature"].shift(30).fillna(frame["temperature"])
    )
    frame["drift_2"] = 0.5 * frame["drift"] + 0.01
    assert frame["run"].nunique() >= 2, "the tests want several runs in the first samples"
    return frame


def _features(**params):
    return ThermalFeatures(temperature="temperature", time="time", run="run", **params)


def _rbf(**params):
    # Small and quick to fit; refined by default (centres and widths move off the grid).
    params = {"n_centers": 15, "max_candidates": 100, "max_samples": 1000, **params}
    return RBFNetRegressor(random_state=0, **params)


def _fitted(campaign, *steps, features=None, target=("drift",)):
    model = make_pipeline(features or _features(), *steps)
    rows = campaign
    y = rows[list(target)].to_numpy() if len(target) > 1 else rows[target[0]]
    return model.fit(rows, y)


MODELS = {
    "ridge": lambda c: _fitted(c, StandardScaler(), Ridge(alpha=1e-3)),
    "poly-ridge": lambda c: _fitted(
        c,
        StandardScaler(),
        PolynomialFeatures(degree=2),
        Ridge(alpha=1e-3),
        features=_features(smoothing=120.0, rate_unit="h"),
    ),
    # The default (quadratic) tail, with exactly 15 Gaussian units.
    "rbf": lambda c: _fitted(c, StandardScaler(), _rbf(criterion=None)),
    "rbf-no-tail": lambda c: _fitted(
        c, StandardScaler(), _rbf(tail=False, refine=None), features=_features(smoothing=300.0)
    ),
    # Thermal-state terms (and their products with T) and a smoothed rate whose time
    # constant is also a lag term's.
    "lags-rbf": lambda c: _fitted(
        c,
        StandardScaler(),
        _rbf(tail="linear"),
        features=_features(
            terms=("T", "dT", "TdT", "T_lag600s", "TT_lag600s", "T_lag3600s", "T_lag90.5s"),
            smoothing=600.0,
        ),
    ),
    "lags-2-sensors-poly": lambda c: _fitted(
        c,
        StandardScaler(),
        PolynomialFeatures(degree=2),
        Ridge(alpha=1e-3),
        features=ThermalFeatures(
            temperature=["temperature", "temperature_2"],
            time="time",
            run="run",
            terms=("T", "dT", "T_lag300s", "gradient"),
            smoothing=60.0,
            rate_unit="s",
        ),
    ),
    "lags-only": lambda c: _fitted(
        c, StandardScaler(), Ridge(alpha=1e-3), features=_features(terms=("T", "T_lag1800s"))
    ),
    # A linear tail: an unpenalised quadratic one on these ten nearly collinear features
    # sums terms ~900 times the drift, which alone costs float its 1e-4.
    "rbf-2-sensors-2-outputs": lambda c: _fitted(
        c,
        MinMaxScaler(clip=True),
        _rbf(tail="linear"),
        features=ThermalFeatures(
            temperature=["temperature", "temperature_2"],
            time="time",
            run="run",
            terms=("T", "dT", "TdT", "T_lag900s", "T_lag3600s"),
            smoothing=60.0,
        ),
        target=("drift", "drift_2"),
    ),
    # The default features (terms="auto": sixteen columns for two sensors, T, T² and the T
    # products of two nearly equal sensors nearly collinear) and the default network.
    "default-features-2-sensors-2-outputs": lambda c: _fitted(
        c,
        StandardScaler(),
        _rbf(),
        features=ThermalFeatures(
            temperature=["temperature", "temperature_2"], time="time", run="run"
        ),
        target=("drift", "drift_2"),
    ),
    "gradient-T2": lambda c: _fitted(
        c,
        StandardScaler(),
        Ridge(alpha=1e-3),
        features=ThermalFeatures(
            temperature=["temperature", "temperature_2"],
            time="time",
            run="run",
            terms=("T", "dT", "TdT", "T2", "gradient"),
        ),
    ),
    "per-sample-dT": lambda c: _fitted(
        c,
        RobustScaler(),
        MaxAbsScaler(),
        LinearRegression(),
        features=ThermalFeatures(temperature="temperature", run="run", terms=("TdT", "T", "dT")),
    ),
}


@pytest.fixture(scope="module", params=sorted(MODELS))
def model(request, campaign):
    return MODELS[request.param](campaign)


def _compile(directory, flags=(), optimise="-O1"):
    result = subprocess.run(
        [CC, *STRICT_FLAGS, *flags, optimise, "driver.c", "ifog.c", "-lm", "-o", "driver"],
        cwd=directory,
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    return directory / "driver"


def _rates(campaign, n_outputs):
    return np.repeat(campaign["rate"].to_numpy()[:, None], n_outputs, axis=1)


def _run(executable, campaign, spec, real):
    """(streamed drift, batched drift, compensated rate) of the compiled model."""
    run = campaign["run"].to_numpy()
    starts = np.r_[True, run[1:] != run[:-1]]
    sensors = campaign[spec["features"]["temperature"]].to_numpy()
    rates = _rates(campaign, spec["n_outputs"])
    rows = np.column_stack([starts.astype(float), campaign["time"], rates, sensors])
    rows.astype(np.float64).tofile(executable.parent / "in.bin")
    subprocess.run(
        [executable, str(len(rows)), "in.bin", "out.bin"], cwd=executable.parent, check=True
    )
    out = np.fromfile(executable.parent / "out.bin", dtype=real).astype(np.float64)
    return out.reshape(3, len(rows), spec["n_outputs"])


def _assert_close(actual, expected, rtol, scale=None):
    """|actual - expected| <= rtol * scale per column; scale: the largest |expected|."""
    expected = np.asarray(expected, dtype=np.float64).reshape(actual.shape)
    error = np.max(np.abs(actual - expected), axis=0)
    scale = np.max(np.abs(expected), axis=0) if scale is None else scale
    assert np.all(error <= rtol * scale), f"max error {error} > {rtol} * max|drift| {scale}"


@needs_cc
@pytest.mark.parametrize(("precision", "rtol"), [("double", 1e-9), ("float", 1e-4)])
def test_c_matches_pipeline(model, campaign, tmp_path, precision, rtol):
    to_c(model, tmp_path, precision=precision)
    (tmp_path / "driver.c").write_text(DRIVER)
    executable = _compile(tmp_path, EXTRA_FLAGS)
    spec = json.loads(to_json(model, tmp_path / "model.json").read_text())
    real = np.float64 if precision == "double" else np.float32
    streamed, batched, compensated = _run(executable, campaign, spec, real)
    expected = model.predict(campaign).reshape(N_SAMPLES, -1)
    _assert_close(streamed, expected, rtol)
    np.testing.assert_array_equal(batched, streamed)
    # The compensated rate: the C compensate function, to the same absolute tolerance (the
    # rate itself may be near zero: at 90 deg azimuth the Earth-rate reference vanishes).
    rates = _rates(campaign, spec["n_outputs"])
    _assert_close(compensated, rates - expected, rtol, scale=np.max(np.abs(expected), axis=0))


@needs_cc
def test_float_build_differs_from_double_build(campaign, tmp_path):
    model = MODELS["rbf"](campaign)
    outputs = {}
    for precision, real in [("double", np.float64), ("float", np.float32)]:
        directory = tmp_path / precision
        directory.mkdir()
        to_c(model, directory, precision=precision)
        (directory / "driver.c").write_text(DRIVER)
        spec = json.loads(to_json(model, directory / "model.json").read_text())
        outputs[precision] = _run(_compile(directory), campaign[:500], spec, real)[0]
        assert f"typedef {precision} ifog_real;" in (directory / "ifog.h").read_text()
    expected = model.predict(campaign[:500]).reshape(-1, 1)
    error_double = np.max(np.abs(outputs["double"] - expected))
    error_float = np.max(np.abs(outputs["float"] - expected))
    assert error_double < 1e-3 * error_float


def test_generated_c_is_self_contained(campaign, tmp_path):
    model = MODELS["rbf"](campaign)
    header, source = to_c(model, tmp_path / "new" / "dir", prefix="gyro7")
    assert (header.name, source.name) == ("gyro7.h", "gyro7.c")
    text = source.read_text() + header.read_text()
    includes = sorted({line for line in text.splitlines() if line.startswith("#include")})
    assert includes == ['#include "gyro7.h"', "#include <math.h>"]
    for forbidden in ("malloc", "calloc", "free(", "static double", "printf"):
        assert forbidden not in text
    for name in ("gyro7_state", "gyro7_init", "gyro7_reset", "gyro7_step", "gyro7_batch"):
        assert name in header.read_text()
    assert not list(tmp_path.glob("**/.*")), "temporary files left behind"


@needs_cc
def test_c_prefix_builds_strictly(campaign, tmp_path):
    model = MODELS["poly-ridge"](campaign)
    for precision in ("double", "float"):
        to_c(model, tmp_path, precision=precision, prefix="gyro_x")
        result = subprocess.run(
            [CC, *STRICT_FLAGS, *EXTRA_FLAGS, "-c", "gyro_x.c", "-o", "gyro_x.o"],
            cwd=tmp_path,
            capture_output=True,
            text=True,
            check=False,
        )
        assert result.returncode == 0, result.stderr


@needs_cc
def test_user_names_cannot_break_the_c_comments(campaign, tmp_path):
    frame = campaign.iloc[:500].rename(columns={"temperature": "coil */ T"})
    model = Pipeline(
        [
            ("features */ x", ThermalFeatures(temperature="coil */ T", time="time", run="run")),
            ("scale */", StandardScaler()),
            ("ridge", Ridge()),
        ]
    ).fit(frame, frame["drift"])
    to_c(model, tmp_path)
    result = subprocess.run(
        [CC, *STRICT_FLAGS, *EXTRA_FLAGS, "-c", "ifog.c", "-o", "ifog.o"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert "scale * /" in (tmp_path / "ifog.c").read_text()


def test_parameters_written_with_round_trip_precision(campaign, tmp_path):
    model = MODELS["rbf"](campaign)
    to_c(model, tmp_path)
    source = (tmp_path / "ifog.c").read_text()
    centers = model[-1].centers_
    for value in centers.ravel()[:20]:
        assert repr(float(value)) in source
    to_c(model, tmp_path, precision="float")
    source = (tmp_path / "ifog.c").read_text()
    assert f"{float(np.float32(centers[0, 0])):.9g}f" in source


@pytest.mark.parametrize(
    "value", [0.1, -1 / 3, 1e-300, 2.0**-1074, 1.7976931348623157e308, 123456789.0, -0.0, 5.0]
)
def test_double_literal_round_trips(value):
    assert float(format_c_literal(value)) == value


@pytest.mark.parametrize("value", [0.1, -1 / 3, 123456789.0, -0.0, 5.0, 3.4e38, 1.5e-38])
def test_float_literal_round_trips(value):
    literal = format_c_literal(value, "float")
    assert literal.endswith("f")
    assert np.float32(literal[:-1]) == np.float32(value)


def test_float_literal_underflow_and_overflow():
    assert format_c_literal(1e-300, "float") == "0.0f"
    with pytest.raises(ValueError, match="overflows single precision"):
        format_c_literal(1e39, "float")


def test_c_literal_refuses_non_finite():
    with pytest.raises(ValueError, match="not finite"):
        format_c_literal(float("nan"))


@pytest.mark.parametrize("exporter", ["c", "json"])
def test_unknown_final_step_is_named(campaign, tmp_path, exporter):
    model = _fitted(campaign, StandardScaler(), KNeighborsRegressor(n_neighbors=3))
    export = (
        (lambda m: to_c(m, tmp_path))
        if exporter == "c"
        else (lambda m: to_json(m, tmp_path / "m.json"))
    )
    message = r"step 'kneighborsregressor' \(sklearn\.neighbors\..*KNeighborsRegressor\)"
    with pytest.raises(TypeError, match=message):
        export(model)
    assert not list(tmp_path.iterdir()), "nothing may be written for a model that fails"


def test_unknown_middle_step_is_named(campaign, tmp_path):
    from sklearn.decomposition import PCA

    model = _fitted(campaign, PCA(n_components=2), Ridge())
    with pytest.raises(TypeError, match=r"step 'pca' \(sklearn\.decomposition\..*PCA\)"):
        to_c(model, tmp_path)


def test_first_step_must_be_thermal_features(campaign, tmp_path):
    model = Pipeline([("scale", StandardScaler()), ("ridge", Ridge())])
    model.fit(campaign[["temperature"]], campaign["drift"])
    with pytest.raises(ValueError, match=r"first step must be .*ThermalFeatures.*'scale'"):
        to_c(model, tmp_path)
    with pytest.raises(TypeError, match=r"Expected a fitted sklearn\.pipeline\.Pipeline"):
        to_json(Ridge().fit(campaign[["temperature"]], campaign["drift"]), tmp_path / "x")


def test_bad_precision_and_prefix(campaign, tmp_path):
    model = MODELS["ridge"](campaign)
    with pytest.raises(ValueError, match="precision must be 'double' or 'float'"):
        to_c(model, tmp_path, precision="half")
    with pytest.raises(ValueError, match="prefix must be a C identifier"):
        to_c(model, tmp_path, prefix="1-gyro")


def test_export_replaces_existing_files_atomically(campaign, tmp_path):
    (tmp_path / "ifog.c").write_text("old")
    (tmp_path / "model.json").write_text("old")
    to_c(MODELS["ridge"](campaign), tmp_path)
    to_json(MODELS["ridge"](campaign), tmp_path / "model.json")
    assert (tmp_path / "ifog.c").read_text().startswith("/*")
    assert json.loads((tmp_path / "model.json").read_text())["schema"] == SCHEMA_NAME
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ifog.c", "ifog.h", "model.json"]


# --- JSON: a pure-numpy evaluator of the documented schema, independent of the package ---


def _column_values(frame, column):
    return frame.iloc[:, column] if isinstance(column, int) else frame[column]


def evaluate_json(spec, frame):
    """Predict from the JSON schema alone (numpy; mirrors the schema's documentation)."""
    features = spec["features"]
    temperature = np.column_stack([_column_values(frame, c) for c in features["temperature"]])
    time = None if features["time"] is None else _column_values(frame, features["time"])
    run = None if features["run"] is None else _column_values(frame, features["run"])
    run = np.zeros(len(frame)) if run is None else np.asarray(run)
    rows = np.empty((len(frame), spec["n_features"]))
    taus = features["time_constants"]
    smoothing = features["smoothing"]
    for run_id in np.unique(run):
        index = np.flatnonzero(run == run_id)
        raw = temperature[index]
        n, n_sensors = raw.shape
        # The deficit recursion as written in the schema, sample by sample, in plain Python.
        deficit = np.zeros((n, n_sensors, len(taus)))
        delta = np.zeros_like(raw)
        for i in range(1, n):
            elapsed = (
                None if time is None else float(time.iloc[index[i]] - time.iloc[index[i - 1]])
            )
            for sensor in range(n_sensors):
                change = raw[i, sensor] - raw[i - 1, sensor]
                for k, tau in enumerate(taus):
                    x = elapsed / tau
                    g = -math.expm1(-x) / x if x > 0 else 1.0
                    deficit[i, sensor, k] = math.exp(-x) * deficit[i - 1, sensor, k] + g * change
                if smoothing > 0:
                    e = deficit[i, sensor, taus.index(smoothing)]
                    delta[i, sensor] = e / smoothing * features["seconds_per_unit"]
                elif time is not None:
                    delta[i, sensor] = change / elapsed * features["seconds_per_unit"]
                else:
                    delta[i, sensor] = change
        columns = []
        for sensor in range(n_sensors):
            T, dT = raw[:, sensor], delta[:, sensor]
            terms = {"T": T, "dT": dT, "TdT": T * dT, "T2": T * T, "gradient": T - raw[:, 0]}
            described = zip(
                features["terms"],
                features["term_time_constants"],
                features["term_parameters"],
                strict=True,
            )
            for term, tau, parameters in described:
                if term == "gradient" and sensor == 0:
                    continue
                if parameters is not None:
                    lagged = {tau: deficit[:, sensor, taus.index(tau)] for tau in taus}
                    columns.append(_transition_column(parameters, T, dT, lagged))
                elif tau is None:
                    columns.append(terms[term])
                else:
                    lagged = deficit[:, sensor, taus.index(tau)]
                    columns.append(T * lagged if term.startswith("TT_lag") else lagged)
        rows[index] = np.column_stack(columns)
    x = evaluate_steps(spec["steps"], rows)
    return x[:, 0] if spec["single_output"] else x


def _transition_column(parameters, T, dT, deficit):
    """A transition term from its ``term_parameters`` entry, the schema's formulas written
    out here (not the package's step): ``deficit`` maps a time constant to its deficit."""
    c, w = parameters["centre"], parameters["width"]
    z = ((T - deficit[parameters["lag"]]) - c) / w
    shape = parameters["shape"]
    if shape == "logistic":
        s = 0.5 + 0.5 * np.tanh(0.5 * z)
    elif shape == "erf":
        s = 0.5 + 0.5 * np.array([math.erf(math.sqrt(0.5) * value) for value in z])
    elif shape == "hinge":
        s = w * (np.maximum(z, 0.0) + np.log1p(np.exp(-np.abs(z))))
    else:
        raise AssertionError(f"unknown shape {shape}")
    if parameters["multiplier"] == "dT":
        return s * dT
    if parameters["multiplier"] == "T_lag":
        return s * deficit[parameters["multiplier_lag"]]
    assert parameters["multiplier"] is None
    assert parameters["multiplier_lag"] is None
    return s


def evaluate_steps(steps, rows):
    """The schema's ``steps`` on feature rows (the first step's output), with numpy alone."""
    x = np.asarray(rows, dtype=np.float64)
    for step in steps:
        op = step["op"]
        if op == "center_scale":
            x = (x - np.array(step["center"])) / np.array(step["scale"])
        elif op == "multiply_add":
            x = x * np.array(step["multiply"]) + np.array(step["add"])
            if step["clip"] is not None:
                x = np.clip(x, *step["clip"])
        elif op == "polynomial":
            x = np.prod(x[:, None, :] ** np.array(step["powers"])[None], axis=2)
        elif op == "linear":
            x = x @ np.array(step["coef"]).T + np.array(step["intercept"])
        elif op == "rbf_network":
            z = (x - np.array(step["x_mean"])) / np.array(step["x_scale"])
            centers = np.array(step["centers"]).reshape(-1, step["n_inputs"])
            d2 = ((z[:, None, :] - centers[None]) ** 2).sum(axis=2)
            phi = np.exp(-d2 / (2 * np.array(step["widths"]) ** 2))
            coef = np.array(step["coef"]).reshape(step["n_outputs"], -1)
            tail = [z]
            if step["tail_degree"] == 2:
                first, second = np.triu_indices(z.shape[1])
                tail.append(z[:, first] * z[:, second])
            x = phi @ coef.T + np.hstack(tail) @ np.array(step["tail_coef"]).T
            x = x + np.array(step["intercept"])
        else:
            raise AssertionError(f"unknown op {op}")
    return x


def test_the_schema_text_names_the_schema_version():
    """The schema's specification (the docstring of ``sklearn_ifog._description``) names the
    version the exports write, in its text and in its example document."""
    text = _description.__doc__
    assert f"Schema (version {SCHEMA_VERSION};" in text
    assert f'"schema_version": {SCHEMA_VERSION},' in text
    assert f'"schema": "{SCHEMA_NAME}",' in text


def test_json_round_trip_reproduces_predictions(model, campaign, tmp_path):
    path = to_json(model, tmp_path / "model.json")
    spec = json.loads(path.read_text())
    assert (spec["schema"], spec["schema_version"]) == (SCHEMA_NAME, SCHEMA_VERSION)
    subset = campaign.iloc[:3000]
    predicted = evaluate_json(spec, subset)
    expected = model.predict(subset)
    assert predicted.shape == expected.shape
    _assert_close(predicted.reshape(len(subset), -1), expected, 1e-10)


def test_json_holds_exact_parameters(campaign, tmp_path):
    model = MODELS["rbf"](campaign)
    spec = json.loads(to_json(model, tmp_path / "model.json").read_text())
    network = spec["steps"][-1]
    np.testing.assert_array_equal(network["centers"], model[-1].centers_)
    np.testing.assert_array_equal(network["widths"], model[-1].widths_)
    np.testing.assert_array_equal(spec["steps"][0]["scale"], model[1].scale_)
    assert spec["features"]["feature_names"] == list(model[0].get_feature_names_out())


def test_json_carries_the_time_constants(campaign, tmp_path):
    model = MODELS["lags-rbf"](campaign)
    features = json.loads(to_json(model, tmp_path / "model.json").read_text())["features"]
    assert features["terms"] == [
        "T",
        "dT",
        "TdT",
        "T_lag600s",
        "TT_lag600s",
        "T_lag3600s",
        "T_lag90.5s",
    ]
    assert features["term_time_constants"] == [None, None, None, 600.0, 600.0, 3600.0, 90.5]
    assert features["smoothing"] == 600.0
    assert features["time_constants"] == [90.5, 600.0, 3600.0]  # the smoothing shares 600 s
    assert features["seconds_per_unit"] == 60.0
    source = to_c(model, tmp_path)[1].read_text()
    assert "#define IFOG_N_LAGS 3" in (tmp_path / "ifog.h").read_text()
    assert "ifog_time_constants[3] = {\n    90.5, 600.0, 3600.0\n}" in source
    assert "gain[k] = (x > 0.0) ? -expm1(-x) / x : 1.0;" in source


@pytest.mark.parametrize("regressor", LINEAR_REGRESSORS, ids=lambda cls: cls.__name__)
def test_every_listed_linear_regressor_exports(regressor, campaign, tmp_path):
    subset = campaign.iloc[:400]
    estimator = regressor()
    if "random_state" in estimator.get_params():
        estimator.set_params(random_state=0)
    if regressor.__name__ == "QuantileRegressor":
        estimator.set_params(alpha=0.0)
    model = _fitted(subset, StandardScaler(), estimator)
    spec = json.loads(to_json(model, tmp_path / "model.json").read_text())
    _assert_close(evaluate_json(spec, subset)[:, None], model.predict(subset), 1e-10)


def test_written_files_get_ordinary_permissions(campaign, tmp_path):
    header, source = to_c(MODELS["ridge"](campaign), tmp_path)
    path = to_json(MODELS["ridge"](campaign), tmp_path / "model.json")
    umask = os.umask(0o022)
    os.umask(umask)
    for written in (header, source, path):
        assert written.stat().st_mode & 0o777 == 0o666 & ~umask


# --- issue 13: the online recalibration in C ----------------------------------------------

# Reads rows (run-start flag, time, has-reference flag, rates..., references...,
# temperatures...); adapt on the samples with a reference, step on the others; writes the
# drift of every sample, then the numbers of updates and of covariance resets.
ADAPT_DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include "ifog.h"

#define WIDTH (3 + 2 * IFOG_N_OUTPUTS + IFOG_N_SENSORS)

int main(int argc, char **argv)
{
    long n, i, k;
    double *rows, reference[IFOG_N_OUTPUTS];
    ifog_real *drift, rate[IFOG_N_OUTPUTS];
    ifog_state state;
    FILE *in, *out;
    if (argc != 4) return 1;
    n = atol(argv[1]);
    rows = malloc((size_t)(n * WIDTH) * sizeof(double));
    drift = malloc((size_t)(n * IFOG_N_OUTPUTS) * sizeof(ifog_real));
    in = fopen(argv[2], "rb");
    out = fopen(argv[3], "wb");
    if (!rows || !drift || !in || !out) return 2;
    if (fread(rows, sizeof(double), (size_t)(n * WIDTH), in) != (size_t)(n * WIDTH)) return 3;
    ifog_init(&state);
    for (i = 0; i < n; ++i) {
        const double *row = rows + i * WIDTH;
        const double *temperature = row + 3 + 2 * IFOG_N_OUTPUTS;
        for (k = 0; k < IFOG_N_OUTPUTS; ++k) {
            rate[k] = row[3 + k];
            reference[k] = row[3 + IFOG_N_OUTPUTS + k];
        }
        if (row[0] != 0.0) ifog_reset(&state); /* a new run keeps the recalibration */
        if (row[2] != 0.0) {
            ifog_adapt(&state, row[1], temperature, rate, reference, drift + i * IFOG_N_OUTPUTS);
        } else {
            ifog_step(&state, row[1], temperature, drift + i * IFOG_N_OUTPUTS);
        }
    }
    fwrite(drift, sizeof(ifog_real), (size_t)(n * IFOG_N_OUTPUTS), out);
    fwrite(&state.n_updates, sizeof(long), 1, out);
    fwrite(&state.n_resets, sizeof(long), 1, out);
    fclose(out);
    fclose(in);
    free(rows);
    free(drift);
    return 0;
}
"""

ADAPT_MODELS = {
    name: MODELS[name]
    for name in [
        "rbf",
        "rbf-no-tail",
        "ridge",
        "lags-2-sensors-poly",
        "rbf-2-sensors-2-outputs",
        "default-features-2-sensors-2-outputs",
    ]
}
# The pipeline users build (make_compensation_pipeline: the default features, scaler and
# network, with its calibration domain), on two sensors.
ADAPT_MODELS["default-pipeline-2-sensors"] = lambda c: make_compensation_pipeline(
    _rbf(), temperature=["temperature", "temperature_2"]
).fit(c, c["drift"])

# The recalibrated C against the Python compensator, relative to the largest drift. Both run
# the square-root recursion (sklearn_ifog._rls), which keeps the drift within 1e-12 of the
# same recursion in extended precision (test_streaming_adapt.py), so two summation orders
# (BLAS's and the C's loops) agree closely. The covariance form it replaced parted by more
# than the 1e-9 then documented on the default features ("default-*" below).
ADAPT_RTOL = 1e-11


@needs_cc
@pytest.mark.parametrize("adapt", ["bias", "output"])
@pytest.mark.parametrize("name", sorted(ADAPT_MODELS))
def test_c_recalibration_matches_python(name, adapt, campaign, tmp_path):
    from sklearn_ifog.streaming import StreamingCompensator

    model = ADAPT_MODELS[name](campaign)
    forgetting = 0.995
    to_c(model, tmp_path, adapt=adapt, forgetting=forgetting)
    (tmp_path / "driver.c").write_text(ADAPT_DRIVER)
    executable = _compile(tmp_path, EXTRA_FLAGS)
    spec = json.loads(to_json(model, tmp_path / "model.json").read_text())
    n_outputs = spec["n_outputs"]
    run = campaign["run"].to_numpy()
    starts = np.r_[True, run[1:] != run[:-1]]
    # References on 30 % of the samples, 0.05 deg/h off the model's training target.
    has = np.random.default_rng(3).random(N_SAMPLES) < 0.3
    rates = _rates(campaign, n_outputs)
    references = np.repeat(campaign["reference"].to_numpy()[:, None], n_outputs, axis=1) + 0.05
    sensors = campaign[spec["features"]["temperature"]].to_numpy()
    rows = np.column_stack([starts, campaign["time"], has, rates, references, sensors])
    rows.astype(np.float64).tofile(tmp_path / "in.bin")
    subprocess.run([executable, str(N_SAMPLES), "in.bin", "out.bin"], cwd=tmp_path, check=True)
    raw = (tmp_path / "out.bin").read_bytes()
    c_drift = np.frombuffer(raw[: 8 * N_SAMPLES * n_outputs], dtype=np.float64)
    counts = np.frombuffer(raw[8 * N_SAMPLES * n_outputs :], dtype=np.int64)
    compensator = StreamingCompensator(model, adapt=adapt, forgetting=forgetting)
    python_rates = rates[:, 0] if spec["single_output"] else rates
    python_references = np.where(has[:, None], references, None)
    if spec["single_output"]:
        python_references = python_references[:, 0]
    _, drift = compensator.update(campaign, python_rates, python_references)
    drift = drift.reshape(N_SAMPLES, n_outputs)
    _assert_close(c_drift.reshape(N_SAMPLES, n_outputs), drift, ADAPT_RTOL)
    state = compensator.get_state()["rls"]
    assert counts.tolist() == [state["n_updates"], state["n_resets"]] == [has.sum(), 0]
    # The recalibration moved the drift (else the comparison would be the plain model's).
    assert np.max(np.abs(drift - model.predict(campaign).reshape(N_SAMPLES, -1))) > 0.01


def test_c_recalibration_needs_double_and_valid_parameters(campaign, tmp_path):
    model = MODELS["ridge"](campaign)
    with pytest.raises(ValueError, match=r"adapt='bias' needs precision='double'"):
        to_c(model, tmp_path, precision="float", adapt="bias")
    with pytest.raises(ValueError, match=r"adapt must be None, 'bias' or 'output'"):
        to_c(model, tmp_path, adapt="weights")
    with pytest.raises(ValueError, match=r"forgetting must be a number in \(0, 1\]"):
        to_c(model, tmp_path, adapt="bias", forgetting=0.0)
    knn = _fitted(campaign, StandardScaler(), KNeighborsRegressor(3))
    with pytest.raises(TypeError, match="KNeighborsRegressor"):
        to_c(knn, tmp_path, adapt="bias")
    assert not list(tmp_path.iterdir()), "a refused export writes nothing"


# -- a production lot: one C source per unit -------------------------------------------------


def _lot(campaign):
    """Two units: the campaign's rows, and the same recordings with another drift."""
    other = campaign.assign(
        run=campaign["run"] + 100, drift=1.5 * campaign["drift"] + 0.02, unit="gyro-2"
    )
    return pd.concat([campaign.assign(unit="gyro-1"), other], ignore_index=True)


@needs_cc
@pytest.mark.parametrize("pooling", ["partial", "none"])
def test_unitwise_c_matches_each_unit(campaign, tmp_path, pooling):
    lot = _lot(campaign)
    columns = ["unit", "temperature", "time", "run"]
    pipeline = make_pipeline(_features(), StandardScaler(), _rbf(refine=None))
    model = UnitwiseRegressor(pipeline, pooling=pooling).fit(lot[columns], lot["drift"])
    written = to_c_units(model, tmp_path, precision="double")
    assert sorted(written) == ["gyro-1", "gyro-2"]
    predictions = {}
    for unit, (header, source) in written.items():
        name = header.stem
        assert name == f"ifog_unit_{unit.replace('-', '_')}"
        directory = tmp_path / name
        directory.mkdir()
        for path in (header, source):
            (directory / path.name).write_text(path.read_text())
        (directory / "driver.c").write_text(
            DRIVER.replace("ifog", name).replace("IFOG", name.upper())
        )
        result = subprocess.run(
            [CC, *STRICT_FLAGS, "-O1", "driver.c", f"{name}.c", "-lm", "-o", "driver"],
            cwd=directory,
            capture_output=True,
            text=True,
            check=False,
        )
        assert result.returncode == 0, result.stderr
        rows = lot[lot["unit"] == unit].reset_index(drop=True)
        spec = describe_pipeline(model.estimators_[unit])
        streamed, batched, _ = _run(directory / "driver", rows, spec, np.float64)
        expected = model.predict(rows[columns]).reshape(-1, 1)
        _assert_close(streamed, expected, 1e-9)
        np.testing.assert_array_equal(batched, streamed)
        predictions[unit] = expected
    # the units' models differ: each source carries its own unit's weights
    assert not np.allclose(predictions["gyro-1"], predictions["gyro-2"])


def test_unitwise_json_holds_every_unit(campaign, tmp_path):
    lot = _lot(campaign)
    columns = ["unit", "temperature", "time", "run"]
    pipeline = make_pipeline(_features(), StandardScaler(), LinearRegression())
    model = UnitwiseRegressor(pipeline, pooling="partial").fit(lot[columns], lot["drift"])
    document = json.loads(to_json(model, tmp_path / "lot.json").read_text())
    assert document["schema"] == "sklearn-ifog-units"
    assert document["unit_column"] == "unit"
    assert [entry["unit"] for entry in document["units"]] == ["gyro-1", "gyro-2"]
    for entry in document["units"]:
        rows = lot[lot["unit"] == entry["unit"]]
        np.testing.assert_allclose(
            evaluate_json(entry["model"], rows),
            model.predict(rows[columns]),
            rtol=1e-10,
            atol=1e-12,
        )


def test_unitwise_export_errors(campaign, tmp_path):
    lot = _lot(campaign)
    lot.loc[lot["unit"] == "gyro-2", "unit"] = "gyro_1"  # same identifier as "gyro-1"
    columns = ["unit", "temperature", "time", "run"]
    pipeline = make_pipeline(_features(), StandardScaler(), LinearRegression())
    model = UnitwiseRegressor(pipeline, pooling="none").fit(lot[columns], lot["drift"])
    with pytest.raises(ValueError, match="same C identifier 'ifog_unit_gyro_1'"):
        to_c_units(model, tmp_path)
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(TypeError, match="UnitwiseRegressor"):
        to_c_units(pipeline, tmp_path)
