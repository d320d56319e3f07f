"""Transition terms ``<shape><c>C_w<w>C_lag<tau>s[_dT|_T_lag<tau2>s]`` end to end.

The terms of the feature contract (:mod:`sklearn_ifog._transition`): their values from the
formulas written out here, their names, the JSON schema's ``term_parameters`` (evaluated by
``test_export``'s reference evaluator, which writes the step formulas itself), the streaming
compensator and the C export equal to the batch pipeline, the calibration domain over their
columns, the bad inputs of ``ThermalFeatures(transition=...)``, the search on simulated
targets with and without a step, and UnitwiseRegressor around a searching pipeline.
"""

import json
import math
import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import special, stats
from sklearn.linear_model import LinearRegression
from test_export import evaluate_json, evaluate_steps
from test_export_domain import CC, _build, _evaluate_domain
from test_export_domain import _run as _run_c

from sklearn_ifog import (
    RBFNetRegressor,
    ThermalFeatures,
    UnitwiseRegressor,
    make_compensation_pipeline,
)
from sklearn_ifog._contract import DEFAULT_STATE_TERMS, get_term
from sklearn_ifog._description import describe_pipeline
from sklearn_ifog._lags import lag_deficit
from sklearn_ifog._transition import TRANSITION_SHAPES, step, step_c_expression
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.domain import OutsideCalibrationWarning
from sklearn_ifog.streaming import StreamingCompensator

RTOL = 1e-12

#: One transition of each shape, alone, times dT and times the lag excess at 900 s.
TRANSITIONS = ("logistic20C_w2C_lag900s", "erf15.5C_w3C_lag600s", "hinge25C_w1.5C_lag1800s")
TRANSITION_TERMS = tuple(
    name + suffix for name in TRANSITIONS for suffix in ("", "_dT", "_T_lag900s")
)
TERMS = DEFAULT_STATE_TERMS + TRANSITION_TERMS


def _quiet(method, *args):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        return method(*args)


def _close(actual, expected, rtol=RTOL):
    """``|actual - expected| <= rtol * max|expected|`` (a drift may cross zero)."""
    expected = np.asarray(expected, dtype=np.float64)
    actual = np.asarray(actual, dtype=np.float64).reshape(expected.shape)
    np.testing.assert_allclose(actual, expected, rtol=0, atol=rtol * np.max(np.abs(expected)))


def _glass_campaign(random_state=0, **params):
    params = {"n_units": 1, "n_runs": 2, "azimuths": (0.0, 90.0), **params}
    return make_thermal_campaign(
        physics="layered_glass", random_state=random_state, **params
    ).frame


@pytest.fixture(scope="module")
def campaign():
    return _glass_campaign()


@pytest.fixture(scope="module")
def cold(campaign):
    """A calibration run, then a run of -20 to 20 degC: partly colder than the calibration."""
    colder = _glass_campaign(1, n_runs=1, azimuths=(0.0,), temperature_range=(-20.0, 20.0))
    colder = colder.assign(run=colder["run"] + 100)
    frame = pd.concat([campaign[campaign["run"] == 0], colder], ignore_index=True)
    below = frame["temperature"] < campaign["temperature"].min()
    assert 0.1 < below.mean() < 0.6  # rows on both sides of the calibrated minimum
    return frame


MODELS = {
    "linear": lambda: make_compensation_pipeline(LinearRegression(), terms=TERMS),
    "rbf": lambda: make_compensation_pipeline(RBFNetRegressor(random_state=0), terms=TERMS),
}


@pytest.fixture(scope="module", params=sorted(MODELS))
def model(request, campaign):
    return MODELS[request.param]().fit(campaign, campaign["drift"])


# --- the feature values, by hand ------------------------------------------------------------


def _profile(seed, n_runs=3, period=60.0):
    """Runs of soaks and ramps between about 5 and 35 degC (through 20 degC four times)."""
    rng = np.random.default_rng(seed)
    frames = []
    for run in range(n_runs):
        knot_time, knot_temperature = [0.0], [rng.uniform(3.0, 8.0)]
        for ramp in range(4):
            knot_time.append(knot_time[-1] + rng.uniform(1800.0, 3600.0))  # a soak
            knot_temperature.append(knot_temperature[-1])
            target = rng.uniform(32.0, 37.0) if ramp % 2 == 0 else rng.uniform(3.0, 8.0)
            rate = rng.uniform(0.2, 1.0) / 60.0  # degC/s
            knot_time.append(knot_time[-1] + abs(target - knot_temperature[-1]) / rate)
            knot_temperature.append(target)
        time = np.arange(0.0, knot_time[-1], period)
        temperature = np.interp(time, knot_time, knot_temperature)
        temperature = temperature + 0.01 * rng.standard_normal(time.size)
        frames.append(pd.DataFrame({"run": run, "time": time, "temperature": temperature}))
    return pd.concat(frames, ignore_index=True)


def _deficits(frame, column, taus):
    """``{tau: T - lag_tau(T)}`` of one column, run by run."""
    run = frame["run"].to_numpy()
    starts = np.r_[True, run[1:] != run[:-1]]
    taus = [float(tau) for tau in taus]
    values = lag_deficit(frame[column].to_numpy(), frame["time"].to_numpy(), starts, taus)
    return {tau: values[:, k] for k, tau in enumerate(taus)}


def _by_hand(shape, inner, centre, width):
    """The steps from their textbook forms (not the package's tanh / softplus writing)."""
    z = (inner - centre) / width
    if shape == "logistic":
        return 1.0 / (1.0 + np.exp(-z))
    if shape == "erf":
        return stats.norm.cdf(z)
    return width * np.logaddexp(0.0, z)


HAND_TERMS = (
    "T",
    "logistic20C_w2C_lag900s",
    "erf-5.5C_w3C_lag600s_dT",
    "hinge25C_w1.5C_lag1800s_T_lag3600s",
    "erf12C_w0.5C_lag300s_T_lag300s",
)


@pytest.fixture(scope="module")
def profile():
    frame = _profile(0)
    frame["coil"] = frame.groupby("run")["temperature"].shift(5).fillna(frame["temperature"])
    return frame


def _expected_columns(frame, column):
    T = frame[column].to_numpy()
    deficit = _deficits(frame, column, (300, 600, 900, 1800, 3600))
    run, time = frame["run"].to_numpy(), frame["time"].to_numpy()
    dT = np.r_[0.0, np.diff(T) / np.diff(time)]  # rate_unit="s", no smoothing
    dT[np.r_[True, run[1:] != run[:-1]]] = 0.0
    return [
        T,
        _by_hand("logistic", T - deficit[900.0], 20.0, 2.0),
        _by_hand("erf", T - deficit[600.0], -5.5, 3.0) * dT,
        _by_hand("hinge", T - deficit[1800.0], 25.0, 1.5) * deficit[3600.0],
        _by_hand("erf", T - deficit[300.0], 12.0, 0.5) * deficit[300.0],
    ]


def test_values_equal_the_formulas_by_hand(profile):
    features = ThermalFeatures(
        time="time", run="run", terms=HAND_TERMS, smoothing=0.0, rate_unit="s"
    )
    out = features.fit_transform(profile)
    expected = np.column_stack(_expected_columns(profile, "temperature"))
    assert out.shape == expected.shape
    np.testing.assert_allclose(out, expected, rtol=1e-12, atol=1e-13)
    # Every step is exercised on both sides of its centre.
    for k in (1, 2, 3):
        assert np.ptp(out[:, k]) > 0.5 * np.max(np.abs(out[:, k]))


def test_two_sensors_names_and_values(profile):
    features = ThermalFeatures(
        temperature=["temperature", "coil"],
        time="time",
        run="run",
        terms=HAND_TERMS,
        smoothing=0.0,
        rate_unit="s",
    )
    out = features.fit_transform(profile)
    outputs = [get_term(term).output for term in HAND_TERMS]
    names = [f"{sensor}_{output}" for sensor in ("temperature", "coil") for output in outputs]
    assert list(features.get_feature_names_out()) == names
    assert names[1] == "temperature_logistic20C_w2C_lag900s"
    assert names[-1] == "coil_erf12C_w0.5C_lag300s_T_lag300s"
    expected = _expected_columns(profile, "temperature") + _expected_columns(profile, "coil")
    np.testing.assert_allclose(out, np.column_stack(expected), rtol=1e-12, atol=1e-13)


def test_names_one_sensor_and_canonical_forms(profile):
    given_terms = ("logistic20.0C_w2C_lag900s", "erf-5.50C_w3.0C_lag600.0s_T_lag3600.0s")
    features = ThermalFeatures(time="time", run="run", terms=given_terms)
    assert list(features.get_feature_names_out()) == [
        "logistic20C_w2C_lag900s",
        "erf-5.5C_w3C_lag600s_T_lag3600s",
    ]
    canonical = ThermalFeatures(
        time="time", run="run", terms=tuple(features.get_feature_names_out())
    )
    np.testing.assert_array_equal(features.transform(profile), canonical.transform(profile))
    # the parameters as the exports read them
    assert get_term(given_terms[1]).parameters == {
        "shape": "erf",
        "centre": -5.5,
        "width": 3.0,
        "lag": 600.0,
        "multiplier": "T_lag",
        "multiplier_lag": 3600.0,
    }


def test_duplicate_transition_terms_are_refused(profile):
    terms = ("T", "logistic20C_w2C_lag900s", "logistic20.0C_w2.0C_lag900.0s")
    with pytest.raises(ValueError, match=r"Duplicate term\(s\).*logistic20\.0C_w2\.0C_lag900\.0s"):
        ThermalFeatures(time="time", run="run", terms=terms).fit(profile)


@pytest.mark.parametrize(
    ("name", "what"),
    [
        ("logistic20C_w0C_lag900s", "width must be > 0"),
        ("erf20C_w0.0C_lag900s_dT", "width must be > 0"),
        ("hinge20C_w2C_lag0s", "lag must be > 0"),
        ("logistic20C_w2C_lag900s_T_lag0s", "time constant must be > 0"),
    ],
)
def test_bad_term_parameters_name_the_term(name, what, profile):
    with pytest.raises(ValueError, match="terms") as info:
        ThermalFeatures(time="time", run="run", terms=("T", name)).fit(profile)
    assert repr(name) in str(info.value)
    assert what in str(info.value)


# --- ThermalFeatures(transition=...): bad input ---------------------------------------------


@pytest.mark.parametrize(
    ("transition", "match"),
    [
        ({"widths": (0.0,)}, r"transition\['widths'\] must be numbers > 0 \(degC\)"),
        ({"widths": (2.0, -1.0)}, r"transition\['widths'\].*-1\.0"),
        ({"lags": (0.0,)}, r"transition\['lags'\] must be numbers > 0 \(seconds\)"),
        ({"shapes": ("logistic", "sigmoid")}, r"transition\['shapes'\].*'sigmoid'"),
        ({"shapes": ()}, r"transition\['shapes'\]"),
        ({"shape": "erf"}, r"transition has unknown key\(s\) \['shape'\]"),
        ({"centres": (30.0, 10.0)}, r"transition\['centres'\] must be a range \(low, high\)"),
        ({"centres": (10.0, 10.0)}, r"transition\['centres'\] must be a range"),
        ({"centres": 20.0}, r"transition\['centres'\] must be a range.*got 20\.0"),
        ({"centres": (-50.0, 20.0)}, r"transition\['centres'\]=\(-50\.0, 20\.0\) reaches beyond"),
        ({"centres": (10.0, 90.0)}, r"transition\['centres'\].*beyond the calibrated"),
        ("sometimes", r"'transition' parameter of ThermalFeatures"),
    ],
)
def test_bad_transition_names_the_entry(transition, match, profile):
    features = ThermalFeatures(time="time", run="run", transition=transition)
    y = np.zeros(len(profile))
    with pytest.raises(ValueError, match=match):
        features.fit(profile, y)
    if transition != "sometimes":  # checked before the calibration is read: short X too
        with pytest.raises(ValueError, match=match):
            features.fit(profile.iloc[:50], y[:50])


def test_transition_needs_a_finite_target(profile):
    y = np.ones(len(profile))
    y[3] = np.nan
    with pytest.raises(ValueError, match=r"transition: .*finite drift target y.* 1 entries"):
        ThermalFeatures(time="time", run="run", transition="auto").fit(profile, y)


def test_transition_needs_a_time_column(profile):
    features = ThermalFeatures(run="run", transition="auto")
    needs_time = r"transition='auto'.*needs a time column \(time=\.\.\.\)"
    with pytest.raises(ValueError, match=needs_time):
        features.fit(profile, np.zeros(len(profile)))
    features = ThermalFeatures(run="run", terms=("T", "logistic20C_w2C_lag900s"))
    with pytest.raises(ValueError, match="logistic20C_w2C_lag900s"):
        features.fit_transform(profile)


# --- the search -----------------------------------------------------------------------------

CENTRE = 20.3


def _step_target(frame, seed, amplitude=0.05):
    """A sharp logistic step (w = 1 degC at 20.3 degC of the lag at 900 s) times the lag
    excess at 3600 s, carrying most of the target's variance; a slope in T and noise."""
    T = frame["temperature"].to_numpy()
    deficit = _deficits(frame, "temperature", (900, 3600))
    s = _by_hand("logistic", T - deficit[900.0], CENTRE, 1.0)
    noise = np.random.default_rng(100 + seed).standard_normal(T.size)
    return amplitude * s * deficit[3600.0] + 0.002 * T + 0.005 * noise


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_search_finds_a_step_times_a_lag_excess(seed):
    frame = _profile(seed)
    features = ThermalFeatures(time="time", run="run", transition="auto")
    out = features.fit_transform(frame, _step_target(frame, seed))
    found = features.transition_
    assert abs(found.centre - CENTRE) <= 1.0
    assert found.lag == 900.0
    assert found.held_out_gain > 0.9
    assert found.terms
    assert found.terms[0] == f"{found.shape}{found.centre:g}C_w{found.width:g}C_lag900s"
    assert features.terms_ == DEFAULT_STATE_TERMS + found.terms
    names = list(features.get_feature_names_out())
    assert names[len(DEFAULT_STATE_TERMS) :] == [get_term(t).output for t in found.terms]
    assert out.shape == (len(frame), len(names))
    # the multipliers: the step alone, times dT, times each of the base lags
    suffixes = [term[len(found.terms[0]) :] for term in found.terms]
    assert suffixes == ["", "_dT", "_T_lag900s", "_T_lag3600s"]


def test_search_keeps_nothing_without_a_step():
    # The halves gate (chosen on half of the folds, confirmed on the other, both ways) is
    # there for this: the best of hundreds of candidates always looks better on the rows it
    # was chosen on, so a one-standard-error rule on every held-out row fires on most
    # targets without a step.
    fired = {"smooth": 0, "noise": 0}
    for seed in range(10):
        frame = _profile(seed)
        T = frame["temperature"].to_numpy()
        deficit = _deficits(frame, "temperature", (900,))[900.0]
        rng = np.random.default_rng(200 + seed)
        targets = {
            "smooth": 0.002 * T + 0.01 * deficit + 0.005 * rng.standard_normal(T.size),
            "noise": rng.standard_normal(T.size),
        }
        for kind, y in targets.items():
            features = ThermalFeatures(time="time", run="run", transition="auto").fit(frame, y)
            assert features.transition_ is not None
            fired[kind] += bool(features.transition_.terms)
            if not features.transition_.terms:
                assert features.terms_ == DEFAULT_STATE_TERMS
    assert fired["smooth"] <= 2, fired
    assert fired["noise"] <= 2, fired


def test_no_search_without_y_or_with_few_rows(profile):
    y = _step_target(profile, 0)
    features = ThermalFeatures(time="time", run="run", transition="auto").fit(profile)
    assert features.transition_ is None
    assert features.terms_ == DEFAULT_STATE_TERMS
    short = profile.iloc[:199]  # one run, 199 rows
    features.fit(short, y[:199])
    assert features.transition_ is None
    assert features.terms_ == DEFAULT_STATE_TERMS
    few = profile.groupby("run").head(66)  # three runs, 198 rows
    assert features.fit(few, y[few.index]).transition_ is None
    assert features.fit(profile, y).transition_ is not None


def test_step_equals_the_textbook_forms():
    inner = np.concatenate([np.linspace(-800.0, 800.0, 4001), [20.0, 20.0 + 1e-9]])
    for centre, width in ((20.0, 2.0), (-5.5, 0.3), (0.0, 7.0)):
        z = (inner - centre) / width
        np.testing.assert_allclose(
            step("logistic", inner, centre, width), special.expit(z), rtol=1e-14, atol=1e-16
        )
        np.testing.assert_allclose(
            step("erf", inner, centre, width), stats.norm.cdf(z), rtol=1e-14, atol=1e-16
        )
        np.testing.assert_allclose(
            step("hinge", inner, centre, width),
            width * np.logaddexp(0.0, z),
            rtol=1e-14,
            atol=1e-300,
        )
    assert step("logistic", 20.0, 20.0, 2.0) == step("erf", 20.0, 20.0, 2.0) == 0.5
    assert step("hinge", 20.0, 20.0, 2.0) == 2.0 * math.log(2.0)


_C_NAMES = {
    "tanh": math.tanh,
    "erf": math.erf,
    "exp": math.exp,
    "log1p": math.log1p,
    "fabs": math.fabs,
    "fmax": max,
}


@settings(max_examples=300, deadline=None)
@given(
    shape=st.sampled_from(TRANSITION_SHAPES),
    centre=st.floats(-60.0, 90.0),
    width=st.floats(0.05, 30.0),
    inner=st.floats(-80.0, 120.0),
)
def test_c_expression_equals_step(shape, centre, width, inner):
    expression = step_c_expression(shape, "u", centre, width)
    value = eval(expression, {"__builtins__": {}}, {**_C_NAMES, "u": inner})
    expected = float(step(shape, inner, centre, width))
    assert math.isclose(value, expected, rel_tol=1e-14, abs_tol=1e-14)


# --- the exports and the stream equal the batch pipeline ------------------------------------


def test_json_carries_the_term_parameters(model, campaign):
    spec = json.loads(json.dumps(describe_pipeline(model)))
    features = spec["features"]
    assert features["terms"] == list(TERMS)
    parameters = dict(zip(features["terms"], features["term_parameters"], strict=True))
    assert all(parameters[term] is None for term in DEFAULT_STATE_TERMS)
    for term in TRANSITION_TERMS:
        assert parameters[term] == get_term(term).parameters
    assert parameters["erf15.5C_w3C_lag600s_T_lag900s"] == {
        "shape": "erf",
        "centre": 15.5,
        "width": 3.0,
        "lag": 600.0,
        "multiplier": "T_lag",
        "multiplier_lag": 900.0,
    }
    assert parameters["hinge25C_w1.5C_lag1800s_dT"]["multiplier"] == "dT"
    assert parameters["hinge25C_w1.5C_lag1800s_dT"]["multiplier_lag"] is None
    assert features["time_constants"] == [120.0, 600.0, 900.0, 1800.0, 3600.0]
    assert features["feature_names"] == list(model[0].get_feature_names_out())


def test_json_reproduces_predict(model, campaign, cold):
    spec = json.loads(json.dumps(describe_pipeline(model)))
    for frame in (campaign, cold):
        _close(evaluate_json(spec, frame), model[:].predict(frame))  # the steps alone
    # with the domain and its "blend" policy, on rows partly colder than the calibration
    features = np.asarray(model[0].transform(cold), dtype=np.float64)
    drift, distance, flag = _evaluate_domain(
        spec["domain"],
        features,
        model[1:].predict(features),
        lambda rows: evaluate_steps(spec["steps"], rows),
    )
    _close(drift, _quiet(model.predict, cold))
    np.testing.assert_array_equal(flag, model.outside_calibration(cold))
    np.testing.assert_allclose(distance, model.calibration_distance(cold), rtol=1e-10)


def _stream_steps(compensator, frame):
    drift, flags = [], []
    rows = zip(frame["time"], frame["temperature"], frame["rate"], frame["run"], strict=True)
    for time, temperature, rate, run in rows:
        drift.append(compensator.step(time, temperature, rate, run=run)[1])
        flags.append(compensator.last_outside)
    return np.ravel(drift), np.concatenate(flags)


def _stream_chunks(compensator, frame, size=97):
    drift, flags = [], []
    rate = frame["rate"].to_numpy()
    for start in range(0, len(frame), size):
        out = compensator.update(frame.iloc[start : start + size], rate[start : start + size])
        drift.append(np.ravel(out[1]))
        flags.append(compensator.last_outside)
    return np.concatenate(drift), np.concatenate(flags)


@pytest.mark.parametrize("stream", [_stream_steps, _stream_chunks], ids=["step", "update"])
def test_streaming_equals_batch(model, cold, stream):
    expected = _quiet(model.predict, cold)
    flags = model.outside_calibration(cold)
    assert 0.1 < flags.mean() < 0.9
    drift, streamed_flags = _quiet(stream, StreamingCompensator(model), cold)
    _close(drift, expected)
    np.testing.assert_array_equal(streamed_flags, flags)
    # the blend acts on the flagged rows: the stream follows it there, not the bare model
    bare = model[:].predict(cold)
    assert np.max(np.abs(expected - bare)[flags]) > 1e-3 * np.max(np.abs(expected))


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
def test_c_equals_python(model, cold, tmp_path):
    c = _run_c(_build(model, tmp_path), model, cold)
    expected = _quiet(model.predict, cold)
    flags = model.outside_calibration(cold)
    _close(c["streamed"], expected)
    _close(c["stateless"], expected)
    np.testing.assert_array_equal(c["batched"], c["streamed"])
    np.testing.assert_array_equal(c["outside"], flags)
    distance = model.calibration_distance(cold)
    np.testing.assert_allclose(c["distance"], distance, rtol=RTOL, atol=RTOL * distance.max())
    source = (tmp_path / "ifog.c").read_text()
    assert "tanh(" in source
    assert "erf(" in source
    assert "log1p(exp(-fabs(" in source


# --- the calibration domain -----------------------------------------------------------------


def test_domain_covers_the_transition_columns(campaign):
    model = MODELS["linear"]().fit(campaign, campaign["drift"])
    names = list(model[0].get_feature_names_out())
    outputs = [get_term(term).output for term in TRANSITION_TERMS]
    assert names[len(DEFAULT_STATE_TERMS) :] == outputs
    assert list(model.feature_names_out_) == names
    domain = model.domain_
    assert domain.n_features_in_ == len(names) == len(TERMS)
    features = np.asarray(model[0].transform(campaign), dtype=np.float64)
    np.testing.assert_array_equal(domain.data_min_, features.min(axis=0))
    np.testing.assert_array_equal(domain.data_max_, features.max(axis=0))
    assert domain.components_.shape == (len(names), len(names))


def test_held_out_run_inside_and_cold_run_flagged():
    # Cycle profiles, three calibration runs: a held-out fourth run is mostly inside the
    # domain, a run below the calibrated temperatures is flagged wherever it is colder.
    held_out, colder = [], []
    for seed in range(5):
        frame = _glass_campaign(
            seed,
            n_runs=4,
            azimuths=(0.0,),
            profile="cycle",
            ramp_rate=0.5,
            temperature_range=(0.0, 35.0),
        )
        last = frame["run"] == frame["run"].max()
        calibration = frame[~last]
        model = MODELS["linear"]().fit(calibration, calibration["drift"])
        held_out.append(model.outside_calibration(frame[last]).mean())
        cold = _glass_campaign(
            seed + 100,
            n_runs=1,
            azimuths=(0.0,),
            profile="cycle",
            ramp_rate=0.5,
            temperature_range=(-20.0, 0.0),
        )
        below = (cold["temperature"] < calibration["temperature"].min()).to_numpy()
        flags = model.outside_calibration(cold)
        assert np.all(flags[below])
        colder.append(flags.mean())
    assert max(held_out) < 0.3, held_out
    assert np.mean(held_out) < 0.1, held_out
    assert min(colder) > 0.9, colder


# --- UnitwiseRegressor around a searching pipeline ------------------------------------------


@pytest.fixture(scope="module")
def step_lot():
    """Three units of the step target (their amplitudes differ), three runs each."""
    frames, targets = [], []
    for unit in range(3):
        frame = _profile(10 + unit).assign(unit=unit)
        frame["run"] = 10 * unit + frame["run"]
        frames.append(frame)
        targets.append(_step_target(frame, unit, amplitude=0.04 + 0.01 * unit))
    X = pd.concat(frames, ignore_index=True)[["unit", "run", "time", "temperature"]]
    return X, np.concatenate(targets)


def _searching():
    return make_compensation_pipeline(LinearRegression(), transition="auto")


def test_make_compensation_pipeline_passes_transition():
    assert _searching().named_steps["features"].transition == "auto"
    grid = {"widths": (2.0,)}
    pipeline = make_compensation_pipeline(transition=grid)
    assert pipeline.named_steps["features"].transition == grid


def test_unitwise_none_searches_each_unit(step_lot):
    X, y = step_lot
    model = UnitwiseRegressor(_searching(), pooling="none").fit(X, y)
    for unit, estimator in model.estimators_.items():
        rows = (X["unit"] == unit).to_numpy()
        found = estimator[0].transition_
        alone = ThermalFeatures(time="time", run="run", transition="auto")
        assert found == alone.fit(X[rows], y[rows]).transition_
        assert found.terms
        assert abs(found.centre - CENTRE) <= 1.0
        assert estimator[0].terms_ == DEFAULT_STATE_TERMS + found.terms
        residual = y[rows] - model.predict(X[rows])
        assert np.mean(residual**2) < 0.05 * np.var(y[rows])


@pytest.mark.parametrize("pooling", ["partial", "full"])
def test_unitwise_pooled_units_share_the_lots_search(step_lot, pooling):
    X, y = step_lot
    model = UnitwiseRegressor(_searching(), pooling=pooling).fit(X, y)
    lot = model.lot_estimator_
    found = lot[0].transition_
    inner = X.drop(columns="unit")
    assert (
        found
        == ThermalFeatures(time="time", run="run", transition="auto").fit(inner, y).transition_
    )
    assert found.terms
    assert abs(found.centre - CENTRE) <= 1.0
    for unit, estimator in model.estimators_.items():
        rows = (X["unit"] == unit).to_numpy()
        # the lot's features (its search) for every unit: one layout for the shrunk layers
        assert estimator[0].terms_ == lot[0].terms_
        np.testing.assert_array_equal(
            estimator[0].transform(inner[rows]), lot[0].transform(inner[rows])
        )
        np.testing.assert_array_equal(model.predict(X[rows]), estimator.predict(inner[rows]))
        # one model for the lot ("full") misses each unit's own amplitude of the step
        residual = y[rows] - model.predict(X[rows])
        limit = 0.05 if pooling == "partial" else 0.15
        assert np.mean(residual**2) < limit * np.var(y[rows])
