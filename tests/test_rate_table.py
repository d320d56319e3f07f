"""Tests of the rate-table simulator, sklearn_ifog.datasets.make_rate_table_campaign (issue 44)."""

import time

import numpy as np
import pandas as pd
import pytest
from pandas.testing import assert_frame_equal

from sklearn_ifog.datasets import (
    DEFAULT_RATES,
    RATE_TABLE_PRESETS,
    make_rate_table_campaign,
)
from sklearn_ifog.datasets._rate_table import scale_factor_terms
from sklearn_ifog.metrics import EARTH_ROTATION_RATE

FRAME_COLUMNS = [
    "unit",
    "run",
    "time",
    "temperature",
    "source_temperature",
    "table_rate",
    "reference",
    "rate",
    "drift",
    "scale_factor_error",
    "chamber_temperature",
]
FEATURES = ["unit", "run", "time", "temperature", "source_temperature", "reference"]
SF_TERMS = [
    "scale_factor_coil",
    "scale_factor_source",
    "scale_factor_asymmetry",
    "scale_factor_nonlinearity",
]
SF_COEFFICIENTS = [
    "sf_coil_linear",
    "sf_coil_quadratic",
    "sf_coil_gradient",
    "sf_source",
    "sf_asymmetry",
    "sf_nonlinearity",
    "tau_source",
    "source_self_heating",
    "tau_source_sensor",
    "source_sensor_offset",
]


@pytest.fixture(scope="module")
def quiet():
    """A noise-free campaign of every preset, same seed (shared units and runs)."""
    return {
        preset: make_rate_table_campaign(preset=preset, noise=False, random_state=0)
        for preset in RATE_TABLE_PRESETS
    }


def test_constants_and_defaults():
    assert DEFAULT_RATES == (0, 1, -1, 10, -10, 100, -100, 300, -300)
    assert RATE_TABLE_PRESETS == ("coil", "coil_source", "asymmetric")
    start = time.perf_counter()
    campaign = make_rate_table_campaign(random_state=0)
    assert time.perf_counter() - start < 2.0
    frame = campaign.frame
    assert list(frame.columns) == FRAME_COLUMNS
    # 3 units x 2 runs, run ids unique across the campaign, each run one unit
    assert frame["run"].nunique() == 6
    assert (frame.groupby("run")["unit"].nunique() == 1).all()
    assert sorted(frame["unit"].unique().tolist()) == [0, 1, 2]
    # runs reach different temperatures
    assert campaign.run_params["min_setpoint"].nunique() == 6
    assert campaign.run_params["max_setpoint"].nunique() == 6
    assert frame["chamber_temperature"].min() > -40.5
    assert frame["chamber_temperature"].max() < 70.5


@pytest.mark.parametrize("physics", ["lumped", "layered", "layered_glass"])
@pytest.mark.parametrize("preset", RATE_TABLE_PRESETS)
def test_noise_free_output_is_the_scale_factor_identity(preset, physics):
    campaign = make_rate_table_campaign(
        n_units=2, n_runs=1, preset=preset, physics=physics, noise=False, random_state=1
    )
    f = campaign.frame
    expected = f["reference"] * (1.0 + f["scale_factor_error"] * 1e-6) + f["drift"]
    np.testing.assert_allclose(f["rate"], expected, rtol=1e-15, atol=1e-9)
    # the error is the sum of its terms, and the terms are functions of the hidden state
    c = campaign.components
    np.testing.assert_allclose(f["scale_factor_error"], c[SF_TERMS].sum(axis=1), atol=1e-9)
    np.testing.assert_allclose(c["coil_gradient"], c["coil_outer"] - c["coil_inner"])
    for unit, rows in f.groupby("unit"):
        params = campaign.unit_params[unit]
        terms = scale_factor_terms(
            params,
            c.loc[rows.index, "coil_mean"],
            c.loc[rows.index, "coil_gradient"],
            c.loc[rows.index, "source_temp_true"],
            rows["reference"],
        )
        for name in SF_TERMS:
            np.testing.assert_allclose(terms[name], c.loc[rows.index, name], atol=1e-12)
    # both temperature readings stay quantised to 0.01 degC
    for column in ("temperature", "source_temperature"):
        hundredths = f[column].to_numpy() * 100.0
        np.testing.assert_allclose(hundredths, np.round(hundredths), atol=1e-6)
    # target = rate - reference; X = the six feature columns
    np.testing.assert_array_equal(campaign.target, f["rate"] - f["reference"])
    assert campaign.target.name == "drift_measured"
    assert list(campaign.data.columns) == FEATURES


def test_noisy_output_is_the_identity_plus_the_gyro_noise():
    campaign = make_rate_table_campaign(n_units=1, n_runs=1, random_state=2)
    f, c = campaign.frame, campaign.components
    noise = f["rate"] - f["reference"] * (1.0 + f["scale_factor_error"] * 1e-6) - f["drift"]
    parts = c[["turn_on_bias", "bias_instability", "angle_random_walk", "quantisation"]]
    np.testing.assert_allclose(noise, parts.sum(axis=1), atol=1e-6)
    # the noise does not grow with the input rate (the output counts angle quanta)
    spread = noise.groupby(f["table_rate"].abs()).std()
    assert spread.max() < 1.5 * spread.min()
    assert 0.005 < spread.min() < 0.05  # ARW 0.001-0.003 deg/sqrt(h) at 30 s: 0.011-0.033


@pytest.mark.parametrize(("dwell", "sampling_period"), [(120.0, 30.0), (60.0, 20.0), (30.0, 30.0)])
def test_table_steps_through_every_rate_each_cycle(dwell, sampling_period):
    rates = np.array([0.0, 5.0, -5.0, 50.0, -50.0])
    campaign = make_rate_table_campaign(
        n_units=1,
        n_runs=2,
        rates=rates,
        dwell=dwell,
        sampling_period=sampling_period,
        latitude=30.0,
        random_state=3,
    )
    per_dwell = round(dwell / sampling_period)
    cycle = per_dwell * rates.size
    for run, rows in campaign.frame.groupby("run"):
        table = rows["table_rate"].to_numpy()
        np.testing.assert_allclose(np.diff(rows["time"]), sampling_period)
        # whole cycles of whole dwells, steps on sample boundaries from the first row
        assert table.size % cycle == 0
        dwells = table.reshape(-1, per_dwell)
        assert (dwells == dwells[:, :1]).all()
        sequence = dwells[:, 0]
        np.testing.assert_array_equal(sequence, campaign.run_params.loc[run, "rate_sequence"])
        # every rate exactly once per cycle, in a fresh order per cycle
        orders = sequence.reshape(-1, rates.size)
        assert orders.shape[0] == campaign.run_params.loc[run, "n_cycles"] > 10
        np.testing.assert_array_equal(
            np.sort(orders, axis=1), np.sort(rates)[None, :].repeat(orders.shape[0], 0)
        )
        assert len({tuple(order) for order in orders}) > orders.shape[0] // 2
    f = campaign.frame
    earth = EARTH_ROTATION_RATE * np.sin(np.deg2rad(30.0))
    np.testing.assert_allclose(f["reference"], f["table_rate"] * 3600.0 + earth, rtol=1e-15)
    assert earth == pytest.approx(7.5205335)


def _ramp_delay(rows, reading, ramp_rate):
    """Time by which ``reading`` trails the chamber at the end of the first ramp, seconds."""
    return (rows["chamber_temperature"] - reading) / (ramp_rate / 60.0)


def test_source_sensor_lags_the_chamber_with_its_own_time_constants():
    # steady ramp at 0.5 degC/min, long enough (>= 130 min) for both lags to settle
    campaign = make_rate_table_campaign(
        n_units=3, n_runs=1, ramp_rate=0.5, physics="lumped", noise=False, random_state=4
    )
    f = campaign.frame
    for run, rows in f.groupby("run"):
        p = campaign.unit_params[int(rows["unit"].iloc[0])]
        times = campaign.run_params.loc[run, "breakpoint_times"]
        end = rows[rows["time"] <= times[2]].iloc[-1]  # the last sample of the heating ramp
        assert times[2] - times[1] > 120 * 60.0
        coil = _ramp_delay(end, end["temperature"] - p["sensor_offset"], 0.5)
        source_reading = end["source_temperature"] - p["source_sensor_offset"]
        source = _ramp_delay(end, source_reading - p["source_self_heating"], 0.5)
        assert coil == pytest.approx(p["tau_outer"] + p["tau_sensor"], rel=0.03, abs=5.0)
        assert source == pytest.approx(p["tau_source"] + p["tau_source_sensor"], rel=0.03, abs=5.0)
        assert abs(coil - source) > 60.0
        # in a soak the source sits its self-heating above the chamber, the coil at it
        soak = rows[rows["time"] <= times[1]].iloc[0]
        assert soak["source_temperature"] - soak["chamber_temperature"] == pytest.approx(
            p["source_self_heating"] + p["source_sensor_offset"], abs=0.006
        )


@pytest.mark.parametrize("physics", ["lumped", "layered"])
def test_heating_and_cooling_differ_at_the_same_coil_temperature(physics):
    campaign = make_rate_table_campaign(
        preset="coil", physics=physics, ramp_rate=1.5, noise=False, random_state=5
    )
    f, c = campaign.frame, campaign.components
    checked = 0
    for unit, rows in f.groupby("unit"):
        g = campaign.unit_params[unit]["sf_coil_gradient"]
        state = c.loc[rows.index]
        heating = state[state["coil_rate"] > 0.3]
        cooling = state[state["coil_rate"] < -0.3].sort_values("coil_mean")
        # pair each heating row with the cooling row closest in mean coil temperature
        index = np.clip(
            np.searchsorted(cooling["coil_mean"], heating["coil_mean"]), 1, len(cooling) - 1
        )
        left = cooling.iloc[index - 1]
        right = cooling.iloc[index]
        closer = np.abs(right["coil_mean"].to_numpy() - heating["coil_mean"].to_numpy()) < np.abs(
            left["coil_mean"].to_numpy() - heating["coil_mean"].to_numpy()
        )
        match = np.where(closer[:, None], right.to_numpy(), left.to_numpy())
        match = pd.DataFrame(match, columns=cooling.columns, index=heating.index)
        close = np.abs(match["coil_mean"] - heating["coil_mean"]) < 0.02
        assert close.sum() > 20
        hot, cold = heating[close], match[close]
        delta_s = hot["scale_factor_coil"] - cold["scale_factor_coil"]
        delta_gradient = hot["coil_gradient"] - cold["coil_gradient"]
        # heating: outer layer warmer than the inner one; cooling: colder
        assert (delta_gradient > 0.5).all()
        # the difference at one coil temperature is the thermal-state term
        np.testing.assert_allclose(delta_s, g * delta_gradient, atol=0.4)
        assert np.abs(delta_s).max() > 5.0
        checked += 1
    assert checked == 3


def test_presets_share_units_and_runs_and_add_terms(quiet):
    coil, source, asym = (quiet[name] for name in RATE_TABLE_PRESETS)
    thermal = ["unit", "run", "time", "temperature", "source_temperature", "table_rate"]
    thermal += ["reference", "drift", "chamber_temperature"]
    assert_frame_equal(coil.frame[thermal], asym.frame[thermal])
    assert_frame_equal(source.frame[thermal], asym.frame[thermal])
    # "coil": the source, asymmetry and nonlinearity terms are zero
    c = coil.components
    for name in ("scale_factor_source", "scale_factor_asymmetry", "scale_factor_nonlinearity"):
        assert (c[name] == 0.0).all()
    np.testing.assert_array_equal(coil.frame["scale_factor_error"], c["scale_factor_coil"])
    assert all(
        u["sf_source"] == u["sf_asymmetry"] == u["sf_nonlinearity"] == 0 for u in coil.unit_params
    )
    # "coil_source": plus a non-zero source term, no rate terms
    s = source.components
    assert (s["scale_factor_source"].abs() > 0).mean() > 0.99
    np.testing.assert_array_equal(s["scale_factor_coil"], c["scale_factor_coil"])
    assert (s["scale_factor_asymmetry"] == 0).all()
    assert (s["scale_factor_nonlinearity"] == 0).all()
    np.testing.assert_allclose(
        source.frame["scale_factor_error"] - coil.frame["scale_factor_error"],
        s["scale_factor_source"],
        atol=1e-9,
    )
    for unit in source.unit_params:
        assert 1.0 <= unit["sf_source"] <= 3.0


def test_asymmetric_preset_splits_positive_and_negative_inputs(quiet):
    campaign = quiet["asymmetric"]
    f, c = campaign.frame, campaign.components
    rate_terms = c["scale_factor_asymmetry"] + c["scale_factor_nonlinearity"]
    for unit, rows in f.groupby("unit"):
        p = campaign.unit_params[unit]
        assert 3.0 <= abs(p["sf_asymmetry"]) <= 20.0
        assert 2.0 <= abs(p["sf_nonlinearity"]) <= 10.0
        terms = rate_terms[rows.index]
        for table_rate in (1.0, 10.0, 100.0, 300.0):
            plus = terms[rows["table_rate"] == table_rate].to_numpy()
            minus = terms[rows["table_rate"] == -table_rate].to_numpy()
            # s(+Ω) - s(-Ω) = δ at every state: the nonlinearity is odd in the output (up to
            # the Earth rate in both inputs: 4 ν Ω Ω_e / (300 deg/s)² < 1e-3 ppm)
            difference = plus.mean() - minus.mean()
            assert difference == pytest.approx(p["sf_asymmetry"], abs=1e-3)
            assert 3.0 <= abs(difference) <= 20.0
            assert np.ptp(plus) < 1e-9
            assert np.ptp(minus) < 1e-9
        nonlinearity = c.loc[rows.index, "scale_factor_nonlinearity"]
        at_full_scale = nonlinearity[rows["table_rate"].abs() == 300.0]
        at_one = nonlinearity[rows["table_rate"].abs() == 1.0]
        assert at_full_scale.to_numpy() == pytest.approx(p["sf_nonlinearity"], rel=1e-4)
        assert np.abs(at_one).max() < 1e-3


@pytest.mark.parametrize("physics", ["lumped", "layered"])
@pytest.mark.parametrize("preset", RATE_TABLE_PRESETS)
def test_scale_factor_moves_by_hundreds_of_ppm_over_the_range(preset, physics):
    for seed in range(4):
        campaign = make_rate_table_campaign(preset=preset, physics=physics, random_state=seed)
        f = campaign.frame
        spread = f.groupby("unit")["scale_factor_error"].agg(np.ptp)
        assert spread.between(100.0, 1000.0).all(), (seed, spread.tolist())


def test_reproducible_by_random_state():
    first = make_rate_table_campaign(n_units=2, n_runs=1, physics="layered", random_state=7)
    second = make_rate_table_campaign(
        n_units=2, n_runs=1, physics="layered", random_state=np.random.RandomState(7)
    )
    assert_frame_equal(first.frame, second.frame)
    assert_frame_equal(first.components, second.components)
    assert first.unit_params == second.unit_params
    other = make_rate_table_campaign(n_units=2, n_runs=1, physics="layered", random_state=8)
    assert not np.array_equal(other.frame["rate"][:100], first.frame["rate"][:100])


def test_lot_spread_scatters_around_the_design():
    same = make_rate_table_campaign(n_units=3, n_runs=1, lot_spread=0.0, random_state=9)
    design = same.design_params
    for name in SF_COEFFICIENTS[:4] + SF_COEFFICIENTS[6:]:
        assert all(unit[name] == design[name] for unit in same.unit_params)
    assert design["sf_asymmetry"] == design["sf_nonlinearity"] == 0.0  # coil_source
    lot = make_rate_table_campaign(
        n_units=20, n_runs=1, lot_spread=0.1, preset="asymmetric", random_state=9
    )
    design = lot.design_params
    for name in SF_COEFFICIENTS:
        ratios = np.array([unit[name] / design[name] for unit in lot.unit_params])
        assert (ratios > 0).all(), name  # signs kept
        assert 0.05 < np.std(np.log(ratios)) < 0.2, name
    independent = make_rate_table_campaign(n_units=3, n_runs=1, random_state=9)
    assert independent.design_params is None


def test_numpy_output_and_return_X_y():
    bunch = make_rate_table_campaign(n_units=1, n_runs=1, as_frame=False, random_state=0)
    assert bunch.frame is None
    assert bunch.data.shape[1] == 6
    assert bunch.feature_names == FEATURES
    assert isinstance(bunch.components, dict)
    assert "scale_factor_coil" in bunch.components
    assert isinstance(bunch.run_params, list)
    assert len(bunch.run_params) == 1
    assert bunch.DESCR.startswith("Simulated IFOG rate-table campaign")
    X, y = make_rate_table_campaign(n_units=1, n_runs=1, random_state=0, return_X_y=True)
    assert list(X.columns) == FEATURES
    assert isinstance(y, pd.Series)
    assert y.name == "drift_measured"
    np.testing.assert_array_equal(X.to_numpy(), bunch.data)
    np.testing.assert_array_equal(y.to_numpy(), bunch.target)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"rates": []}, "rates"),
        ({"rates": [0.0, np.nan]}, "rates must be finite"),
        ({"rates": [0.0, np.inf, 1.0]}, "rates must be finite"),
        ({"rates": [0.0, 0.0]}, "rates must hold at least one non-zero"),
        ({"rates": [1.0, -1001.0]}, "rates must be within"),
        ({"rates": [[1.0, 2.0]]}, "rates must be a non-empty 1-D"),
        ({"rates": ["fast"]}, "rates must be numbers"),
        ({"dwell": 0.0}, "'dwell' parameter"),
        ({"dwell": -60.0}, "'dwell' parameter"),
        ({"dwell": 45.0}, "dwell must be a positive multiple of sampling_period"),
        ({"dwell": 10.0}, "dwell must be a positive multiple of sampling_period"),
        ({"preset": "quadratic"}, "'preset' parameter"),
        ({"profile": "sine"}, "'profile' parameter"),
        ({"profile": ["cycle", "sine"]}, "profile must be one of"),
        ({"physics": "finite_elements"}, "'physics' parameter"),
        ({"temperature_range": (70.0, -40.0)}, "temperature_range"),
        ({"ramp_rate": (2.0, 0.5)}, "ramp_rate"),
        ({"latitude": 91.0}, "'latitude' parameter"),
    ],
)
def test_bad_input_names_the_parameter(kwargs, match):
    with pytest.raises(ValueError, match=match):
        make_rate_table_campaign(n_units=1, n_runs=1, random_state=0, **kwargs)
